"""The expression language of constitutive laws, guards and outputs: our own parser, no Python.

Text from a model file is data. It is read by the tokenizer and recursive-descent parser of this
module into a small tree (:class:`Expression`), which converts to sympy for the compiler
(:meth:`Expression.to_sympy`) and evaluates numerically without sympy (:meth:`Expression.evaluate`,
used to check parameter values against the components' constraints at run time). Nothing is ever
handed to ``eval``, ``sympify`` or ``parse_expr``.

The language (docs/model-files.md states the same)
--------------------------------------------------
* numbers: ``2``, ``0.5``, ``.5``, ``1e-3`` (decimal, finite in float64);
* names: ASCII identifiers, dotted for other components' states, ports and outputs
  (``k``, ``mass.p``, ``walker.foot1.z``); ``t`` is the time, ``pi`` the constant;
* ``+ - * / **``, unary ``-`` and ``+``, parentheses, with Python's precedence (``-x**2`` is
  ``-(x**2)``, ``**`` is right-associative);
* calls of the functions in :data:`FUNCTIONS` only;
* comparisons ``< <= > >= == !=`` only as the condition of ``where(condition, a, b)`` (a if the
  condition holds, else b) or of a ``Piecewise((value, condition), ..., (value, True))`` pair.

Everything else is refused with the offending token and its column: attribute access
(``x.__class__``), subscripts and lists, strings, lambdas and every other Python keyword,
comprehensions, any name beginning with ``_``, implicit multiplication (``2x``), ``^`` (write
``**``).

Bounds (work is bounded whatever the text): at most :data:`MAX_LENGTH` characters,
:data:`MAX_NODES` operations and operands, nesting depth :data:`MAX_DEPTH`, and
:data:`MAX_TERMS` terms once multiplied out; a power of numbers is computed only when its result
is within the float64 range (``9**9**9**9`` is refused at once), every number in the result must
be a finite float64, and a division by zero is refused.

Names: the model's parameters, ``t``, names local to a law (``q``, ``f``, ``e``...) and dotted
names resolved by the caller. A misspelt name is an :class:`UnknownParameterError` naming the
component and argument, never a silent new symbol or a sympy constant (``E``, ``I``, ``S`` and
``N`` are plain names here).
"""
from __future__ import annotations

import functools
import keyword
import math
import re
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from numbers import Integral, Real
from typing import TYPE_CHECKING, Any

from ..errors import ExpressionError, ModelError, UnknownParameterError

#: Longest accepted expression text (characters).
MAX_LENGTH = 10_000
#: Most operations and operands (numbers, names, operators, calls) in one expression.
MAX_NODES = 2_000
#: Deepest nesting of parentheses, calls, unary operators and powers.
MAX_DEPTH = 50
#: Most terms an expression may have once multiplied out (``(a + b)**2`` has 3).
MAX_TERMS = 1_000

#: The time symbol shared by every model.
if TYPE_CHECKING:
    # SympyExpr: for parse's nested function, where the local ``sp`` (the lazy module) hides ``sp``
    import sympy as sp
    from sympy import Expr as SympyExpr

    TIME: sp.Symbol


def _sympy() -> Any:
    """The sympy module, imported on first use: parsing and numeric evaluation
    (:func:`parse_text`, :meth:`Expression.evaluate`) need none of it, so that a compiled model
    checks its parameter values without loading sympy."""
    import sympy

    return sympy


def __getattr__(name: str) -> Any:
    """``TIME``, the time symbol ``t``, is made when first asked for (with sympy)."""
    if name == "TIME":
        value = globals()["TIME"] = _sympy().Symbol("t", real=True)
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _sign(x: float) -> float:
    return float((x > 0) - (x < 0))


def _heaviside(x: float) -> float:
    return 1.0 if x > 0 else (0.5 if x == 0 else 0.0)


def _log(x: float, base: float | None = None) -> float:
    return math.log(x) if base is None else math.log(x) / math.log(base)


@dataclass(frozen=True)
class Function:
    """A function of the language: the name of its sympy counterpart, its float version and its
    arity."""

    sympy_name: str
    numeric: Callable[..., float]
    arity: tuple[int, int | None]           # (fewest, most; None: any number) arguments

    @property
    def symbolic(self) -> Callable[..., sp.Expr]:
        """The sympy counterpart (sympy imported now)."""
        fn: Callable[..., sp.Expr] = getattr(_sympy(), self.sympy_name)
        return fn


#: Functions available in expressions, by the name used in text (``where`` and ``Piecewise`` are
#: the conditionals, handled by the parser).
FUNCTIONS: dict[str, Function] = {
    "sin": Function("sin", math.sin, (1, 1)), "cos": Function("cos", math.cos, (1, 1)),
    "tan": Function("tan", math.tan, (1, 1)), "asin": Function("asin", math.asin, (1, 1)),
    "acos": Function("acos", math.acos, (1, 1)), "atan": Function("atan", math.atan, (1, 1)),
    "atan2": Function("atan2", math.atan2, (2, 2)),
    "sinh": Function("sinh", math.sinh, (1, 1)), "cosh": Function("cosh", math.cosh, (1, 1)),
    "tanh": Function("tanh", math.tanh, (1, 1)), "exp": Function("exp", math.exp, (1, 1)),
    "log": Function("log", _log, (1, 2)), "sqrt": Function("sqrt", math.sqrt, (1, 1)),
    "abs": Function("Abs", abs, (1, 1)), "Abs": Function("Abs", abs, (1, 1)),
    "sign": Function("sign", _sign, (1, 1)),
    "min": Function("Min", lambda *a: min(a), (1, None)),
    "max": Function("Max", lambda *a: max(a), (1, None)),
    "Min": Function("Min", lambda *a: min(a), (1, None)),
    "Max": Function("Max", lambda *a: max(a), (1, None)),
    "Heaviside": Function("Heaviside", _heaviside, (1, 1)),
}
#: Named constants: the name of the sympy constant, the value.
CONSTANTS: dict[str, tuple[str, float]] = {"pi": ("pi", math.pi)}
_CONDITIONALS = ("where", "Piecewise")

#: comparisons: the name of the sympy relation, the float version
_COMPARE: dict[str, tuple[str, Callable[[Any, Any], bool]]] = {
    "<": ("Lt", lambda a, b: a < b), "<=": ("Le", lambda a, b: a <= b),
    ">": ("Gt", lambda a, b: a > b), ">=": ("Ge", lambda a, b: a >= b),
    "==": ("Eq", lambda a, b: a == b), "!=": ("Ne", lambda a, b: a != b),
}

# --- tokens ---------------------------------------------------------------------------------------
_TOKEN = re.compile(r"""
    (?P<space>[ \t\r\n]+)
  | (?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
  | (?P<name>[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*)
  | (?P<op>\*\*|<=|>=|==|!=|[-+*/(),<>])
""", re.VERBOSE)
_HINTS = {
    "^": "'^' is not a power here: write '**'",
    "'": "strings are not expressions", '"': "strings are not expressions",
    "[": "subscripts and lists are not allowed", "]": "subscripts and lists are not allowed",
    ".": "attribute access is not allowed",
    ":": "lambdas, slices and annotations are not allowed",
    "=": "assignments are not allowed (comparisons only inside where(...) or Piecewise(...))",
    "{": "sets and dictionaries are not allowed", "}": "sets and dictionaries are not allowed",
    ";": "statements are not allowed", "@": "'@' is not allowed", "!": "write '!=' or nothing",
    "\\": "backslashes are not allowed", "#": "comments are not allowed",
}


@dataclass(frozen=True)
class Token:
    kind: str          # "number", "name", "op" or "end"
    text: str
    column: int        # 1-based


def _tokens(text: str) -> list[Token]:
    out: list[Token] = []
    pos = 0
    while pos < len(text):
        match = _TOKEN.match(text, pos)
        if match is None:
            ch = text[pos]
            hint = _HINTS.get(ch, "not part of the expression language")
            raise _Syntax(f"unexpected character {ch!r} at column {pos + 1} ({hint})")
        kind = match.lastgroup or ""      # every alternative of _TOKEN is a named group
        token = match.group()
        if kind == "name":
            _check_name(token, pos + 1)
            if match.end() < len(text) and text[match.end()] == ".":
                raise _Syntax(f"attribute access is not allowed ({text[pos:match.end() + 1]!r} at "
                              f"column {pos + 1})")
        elif kind == "number" and match.end() < len(text) and (
                text[match.end()].isalnum() or text[match.end()] in "_."):
            raise _Syntax(f"{text[pos:match.end() + 1]!r} at column {pos + 1} is not a number "
                          "(write a '*' between a number and a name)")
        if kind != "space":
            out.append(Token(kind, token, pos + 1))
        pos = match.end()
        if len(out) > MAX_NODES:
            raise _Syntax(f"more than {MAX_NODES} tokens (the limit of an expression)")
    out.append(Token("end", "", len(text) + 1))
    return out


def _check_name(name: str, column: int) -> None:
    for part in name.split("."):
        if part.startswith("_"):
            raise _Syntax(f"names beginning with '_' are not allowed ({part!r} at column {column})")
        if keyword.iskeyword(part) and part != "True":
            raise _Syntax(f"the Python keyword {part!r} at column {column} is not part of the "
                          "expression language")
        column += len(part) + 1


class _Syntax(Exception):
    """A syntax error inside the parser (turned into an ExpressionError naming ``where``)."""


# --- the tree -------------------------------------------------------------------------------------
# Nodes are tuples: ("num", text) | ("name", name, column) | ("neg", x)
# | ("add", [("+" or "-", term), ...]) | ("mul", [("*" or "/", factor), ...]) | ("pow", base, exp)
# | ("call", function, [args], column) | ("cmp", op, a, b) | ("true",) | ("piece", [(value, cond)])
# (sums and products are flat lists, so a long sum is a shallow tree)
Node = tuple[Any, ...]


class _Parser:
    """Recursive descent over the tokens, with Python's precedence; counts nodes and depth."""

    def __init__(self, tokens: list[Token]):
        self.tokens = tokens
        self.i = 0
        self.depth = 0
        self.nodes = 0

    @property
    def token(self) -> Token:
        return self.tokens[self.i]

    def take(self) -> Token:
        token = self.tokens[self.i]
        self.i += 1
        return token

    def expect(self, text: str) -> None:
        if self.token.text != text or self.token.kind != "op":
            raise _Syntax(f"expected {text!r} {self.where()}")
        self.i += 1

    def where(self) -> str:
        token = self.token
        return "at the end" if token.kind == "end" else f"at {token.text!r} (column {token.column})"

    def node(self, value: Node) -> Node:
        self.nodes += 1
        if self.nodes > MAX_NODES:
            raise _Syntax(f"more than {MAX_NODES} operations and operands (the limit of an "
                          "expression)")
        return value

    def enter(self) -> None:
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise _Syntax(f"nested more than {MAX_DEPTH} levels deep {self.where()}")

    def whole(self) -> Node:
        if self.token.kind == "end":
            raise _Syntax("the expression is empty")
        tree = self.sum()
        if self.token.kind != "end":
            if self.token.text in _COMPARE:
                raise _Syntax(f"a comparison ({self.token.text!r} at column {self.token.column}) "
                              "is only allowed as the condition of where(condition, a, b) or of "
                              "a Piecewise pair; a guard is an expression that crosses zero, "
                              "e.g. 'x - 1' for x > 1")
            raise _Syntax(f"expected an operator or the end {self.where()}")
        return tree

    def sum(self) -> Node:
        self.enter()
        items = [("+", self.term())]
        while self.token.kind == "op" and self.token.text in "+-":
            op = self.take().text
            items.append((op, self.term()))
        self.depth -= 1
        return items[0][1] if len(items) == 1 else self.node(("add", items))

    def term(self) -> Node:
        items = [("*", self.unary())]
        while self.token.kind == "op" and self.token.text in ("*", "/"):
            op = self.take().text
            items.append((op, self.unary()))
        return items[0][1] if len(items) == 1 else self.node(("mul", items))

    def unary(self) -> Node:
        if self.token.kind == "op" and self.token.text in "+-":
            op = self.take().text
            self.enter()
            operand = self.unary()
            self.depth -= 1
            return operand if op == "+" else self.node(("neg", operand))
        return self.power()

    def power(self) -> Node:
        base = self.atom()
        if self.token.kind == "op" and self.token.text == "**":
            self.take()
            self.enter()
            exponent = self.unary()
            self.depth -= 1
            return self.node(("pow", base, exponent))
        return base

    def atom(self) -> Node:
        token = self.token
        if token.kind == "number":
            self.take()
            return self.node(("num", token.text))
        if token.kind == "name":
            self.take()
            if token.text == "True":
                raise _Syntax(f"'True' (column {token.column}) is only allowed as the last "
                              "condition of a Piecewise")
            if self.token.text == "(" and self.token.kind == "op":
                return self.call(token)
            if token.text in FUNCTIONS or token.text in _CONDITIONALS:
                raise _Syntax(f"{token.text!r} (column {token.column}) is a function: write "
                              f"{token.text}(...)")
            return self.node(("name", token.text, token.column))
        if token.kind == "op" and token.text == "(":
            self.take()
            tree = self.sum()
            if self.token.text == ",":
                raise _Syntax(f"tuples are not expressions ({self.where()})")
            self.expect(")")
            return tree
        if token.kind == "end":
            raise _Syntax("the expression ends too early: expected a number, a name or '('")
        raise _Syntax(f"expected a number, a name or '(' {self.where()}")

    def call(self, name: Token) -> Node:
        if name.text not in FUNCTIONS and name.text not in _CONDITIONALS:
            known = ", ".join([*FUNCTIONS, *_CONDITIONALS])
            raise _Syntax(f"unknown function {name.text!r} (column {name.column}); functions: "
                          f"{known}")
        self.expect("(")
        self.enter()
        if name.text == "Piecewise":
            tree = self.piecewise(name)
        elif name.text == "where":
            cond = self.condition()
            self.expect(",")
            a = self.sum()
            self.expect(",")
            b = self.sum()
            tree = self.node(("piece", [(a, cond), (b, ("true",))]))
        else:
            args = [] if self.token.text == ")" else [self.sum()]
            while self.token.text == "," and self.token.kind == "op":
                self.take()
                args.append(self.sum())
            low, high = FUNCTIONS[name.text].arity
            if len(args) < low or (high is not None and len(args) > high):
                count = str(low) if low == high else f"{low} or more" if high is None else \
                    f"{low} to {high}"
                raise _Syntax(f"{name.text}() takes {count} argument(s), got {len(args)} "
                              f"(column {name.column})")
            tree = self.node(("call", name.text, args, name.column))
        self.depth -= 1
        self.expect(")")
        return tree

    def piecewise(self, name: Token) -> Node:
        pairs = []
        while True:
            self.expect("(")
            value = self.sum()
            self.expect(",")
            pairs.append((value, self.condition()))
            self.expect(")")
            if self.token.text != ",":
                break
            self.take()
        if pairs[-1][1] != ("true",):
            raise _Syntax(f"Piecewise (column {name.column}) needs a last pair (value, True), the "
                          "value where no condition holds")
        return self.node(("piece", pairs))

    def condition(self) -> Node:
        if self.token.kind == "name" and self.token.text == "True":
            self.take()
            return ("true",)
        left = self.sum()
        if self.token.kind != "op" or self.token.text not in _COMPARE:
            raise _Syntax(f"expected a comparison (<, <=, >, >=, ==, !=) {self.where()}")
        op = self.take().text
        return self.node(("cmp", op, left, self.sum()))


def _walk(tree: Node) -> Iterator[Node]:
    stack = [tree]
    while stack:
        node = stack.pop()
        yield node
        kind = node[0]
        if kind == "neg":
            stack.append(node[1])
        elif kind in ("add", "mul"):
            stack += [item for _, item in node[1]]
        elif kind == "pow":
            stack += [node[1], node[2]]
        elif kind == "cmp":
            stack += [node[2], node[3]]
        elif kind == "call":
            stack += node[2]
        elif kind == "piece":
            for value, cond in node[1]:
                stack += [value, cond]


def _literal(node: Node) -> float | None:
    """The value of a number or a negated number node, else None."""
    if node[0] == "num":
        return float(node[1])
    if node[0] == "neg" and node[1][0] == "num":
        return -float(node[1][1])
    return None


def _terms(node: Node) -> int:
    """An upper bound of the number of terms of ``node`` multiplied out (for MAX_TERMS)."""
    kind = node[0]
    if kind == "neg":
        return _terms(node[1])
    if kind == "add":
        count = sum(_terms(item) for _, item in node[1])
    elif kind == "mul":
        count = 1
        for op, item in node[1]:
            count *= _terms(item) if op == "*" else 1
            if count > MAX_TERMS:
                break
    elif kind == "pow":
        count, base, n = 1, _terms(node[1]), _literal(node[2])
        if base > 1 and n is not None and n == int(n):
            n = abs(int(n))
            count = MAX_TERMS + 1 if n > MAX_TERMS else math.comb(base + n - 1, n)
    else:
        for child in (node[2] if kind == "call" else ()):
            _terms(child)
        return 1
    if count > MAX_TERMS:
        raise _Syntax(f"more than {MAX_TERMS} terms once multiplied out")
    return count


@dataclass(frozen=True)
class Expression:
    """A parsed expression: ``text`` and its tree. Build with :func:`parse_text`."""

    text: str
    tree: Node

    @property
    def names(self) -> set[str]:
        """Every name the expression uses (without function names and ``pi``)."""
        return {node[1] for node in _walk(self.tree) if node[0] == "name"} - set(CONSTANTS)

    def to_sympy(self, resolve: Callable[[str], sp.Expr | None]) -> tuple[sp.Expr, list[str]]:
        """The sympy expression, names bound by ``resolve`` (None: unknown), and the unknown
        names. Powers of numbers are computed only within the float64 range."""
        sp = _sympy()
        unknown: list[str] = []
        undefined = (sp.nan, sp.zoo, sp.oo, sp.S.NegativeInfinity)

        def build(node: Node) -> Any:
            value = made(node)
            if any(value is u for u in undefined):
                raise _Syntax("division by zero or an infinite value")
            return value

        def made(node: Node) -> Any:
            kind = node[0]
            if kind == "num":
                return _number(node[1])
            if kind == "name":
                value = resolve(node[1])
                if value is None and node[1] in CONSTANTS:
                    value = getattr(sp, CONSTANTS[node[1]][0])
                if value is None:
                    unknown.append(node[1])
                    return sp.Symbol(node[1], real=True)
                return value
            if kind == "neg":
                return -build(node[1])
            if kind == "add":
                total = build(node[1][0][1])
                for op, item in node[1][1:]:
                    total = total + build(item) if op == "+" else total - build(item)
                return total
            if kind == "mul":
                total = build(node[1][0][1])
                for op, item in node[1][1:]:
                    factor = build(item)
                    if op == "*":
                        total = total * factor
                    elif factor == 0:
                        raise _Syntax("division by zero")
                    else:
                        total = total / factor
                return total
            if kind == "pow":
                base, exponent = build(node[1]), build(node[2])
                _check_power(base, exponent)
                return base**exponent
            if kind == "call":
                args = [build(arg) for arg in node[2]]
                if node[1] in _STEEP and isinstance(args[0], sp.Number) and abs(args[0]) > 1e4:
                    return _steep(node[1], float(args[0]))
                return FUNCTIONS[node[1]].symbolic(*args)
            if kind == "cmp":
                return getattr(sp, _COMPARE[node[1]][0])(build(node[2]), build(node[3]))
            if kind == "true":
                return sp.true
            return sp.Piecewise(*((build(value), build(cond)) for value, cond in node[1]))

        try:
            return build(self.tree), unknown
        except (TypeError, ValueError) as err:     # sympy refuses to compare a non-real value
            raise _Syntax(f"a value that is not a real number (a root or logarithm of a negative "
                          f"number) is compared ({err})") from None

    def evaluate(self, values: Mapping[str, float]) -> float:
        """The value for the names in ``values`` (floats; ``pi`` and the functions known),
        without sympy. Raises UnknownParameterError for a name not in ``values`` and
        ArithmeticError/ValueError where the arithmetic fails (0 ** -1, log(-1), overflow).
        Zeros carry no sign (as in sympy), so that atan2 and divisions see what sympy sees."""

        def value(node: Node) -> float:
            return raw(node) + 0.0             # -0.0 + 0.0 is 0.0

        def raw(node: Node) -> float:
            kind = node[0]
            if kind == "num":
                return float(node[1])
            if kind == "name":
                if node[1] in values:
                    return float(values[node[1]])
                if node[1] in CONSTANTS:
                    return CONSTANTS[node[1]][1]
                raise UnknownParameterError(f"{self.text!r} uses {node[1]!r}, which has no value")
            if kind == "neg":
                return -value(node[1])
            if kind == "add":
                return math.fsum(value(item) if op == "+" else -value(item)
                                 for op, item in node[1])
            if kind == "mul":
                total = value(node[1][0][1])
                for op, item in node[1][1:]:
                    total = total * value(item) if op == "*" else total / value(item)
                return total
            if kind == "pow":
                return math.pow(value(node[1]), value(node[2]))
            if kind == "call":
                return float(FUNCTIONS[node[1]].numeric(*(value(arg) for arg in node[2])))
            if kind == "cmp":
                return float(_COMPARE[node[1]][1](value(node[2]), value(node[3])))
            if kind == "true":
                return 1.0
            for item, cond in node[1]:
                if value(cond):
                    return value(item)
            return math.nan

        return value(self.tree)


_STEEP = ("exp", "sinh", "cosh")


def _steep(name: str, x: float) -> sp.Float:
    """exp, sinh or cosh of a number far out (|x| > 1e4), in float64 (sympy's arbitrary precision
    takes long there): 0 where it underflows, refused where it overflows."""
    sp = _sympy()
    try:
        return sp.Float(FUNCTIONS[name].numeric(x))
    except OverflowError:
        raise _Syntax(f"{name}({x:g}) is outside the float64 range") from None


def _number(text: str) -> sp.Number:
    sp = _sympy()
    number = sp.Integer(text) if text.isdigit() else sp.Float(text)
    if not math.isfinite(float(text)):
        raise _Syntax(f"the number {text} is outside the float64 range")
    return number


def _check_power(base: Any, exponent: Any) -> None:
    """Refuse a power of numbers whose value is outside the float64 range (before computing it:
    ``9**387420489`` would take minutes and gigabytes)."""
    sp = _sympy()
    if not (isinstance(base, sp.Number) and isinstance(exponent, sp.Number)):
        return
    b, e = abs(float(base)), float(exponent)
    if base < 0 and not exponent.is_integer:
        raise _Syntax(f"{base}**{exponent} is not a real number")
    if b == 0 and e < 0:
        raise _Syntax("division by zero (0 to a negative power)")
    if b in (0.0, 1.0):
        return
    if abs(e * math.log10(b)) > 308:
        raise _Syntax(f"the power {base}**{exponent} is outside the float64 range")


def parse_text(text: str, where: str = "expression") -> Expression:
    """Parse ``text`` into an :class:`Expression` (syntax and bounds only; names are bound by
    :meth:`Expression.to_sympy` or :meth:`Expression.evaluate`).

    Raises
    ------
    ExpressionError : the text is not in the language or exceeds a bound; the message names
        ``where``, the text and the offending token with its column.
    """
    if not isinstance(text, str):
        raise ExpressionError(f"{where}: expected an expression (text), got {_shown(text)}")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"{where}: the expression is {len(text)} characters long; the "
                              f"limit is {MAX_LENGTH}")
    try:
        parser = _Parser(_tokens(text))
        tree = parser.whole()
        _terms(tree)
    except _Syntax as err:
        raise ExpressionError(f"{where}: cannot parse {_shown(text)}: {err}") from None
    return Expression(text, tree)


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 120 else text[:100] + "..." + text[-12:]


def parse(text: str | float | sp.Expr, names: Mapping[str, sp.Expr], where: str,
          dotted: Callable[[str], sp.Expr | None] | None = None) -> sp.Expr:
    """Parse ``text`` into a sympy expression over ``names`` (plus ``t``, ``pi`` and
    :data:`FUNCTIONS`).

    Parameters
    ----------
    text : the expression (text in the language of the module docstring); Python numbers give
        sympy numbers, and sympy expressions (built in Python code) are re-bound to ``names`` by
        the names of their symbols.
    names : every name the expression may use, mapped to its symbol or expression. Dotted names
        (``mass.p``) are allowed.
    where : what is being parsed, for messages, e.g. ``"component 'spring' argument 'stiffness'"``.
    dotted : resolves a dotted name that is not in ``names`` (e.g. another component's state),
        returning ``None`` when it does not exist.

    Raises
    ------
    ExpressionError : the text is not a valid expression (or exceeds a bound).
    UnknownParameterError : the expression uses a name not in ``names``.
    """
    sp = _sympy()
    local = {"t": sp.Symbol("t", real=True), **names}

    def resolve(name: str) -> SympyExpr | None:
        if name in local:
            return local[name]
        return dotted(name) if dotted is not None and "." in name else None

    if isinstance(text, bool) or not isinstance(text, (str, Real, sp.Basic)):
        raise ExpressionError(f"{where}: expected a number or an expression, got {_shown(text)}")
    if isinstance(text, sp.Basic):
        expr, unknown = _rebind(text, resolve)
        shown = str(text)
    elif isinstance(text, Real):
        if not math.isfinite(float(text)):
            raise ExpressionError(f"{where}: expected a finite number, got {text!r}")
        return sp.Integer(int(text)) if isinstance(text, Integral) else sp.Float(float(text))
    else:
        try:
            expr, unknown = parse_text(text, where).to_sympy(resolve)
            _check_result(expr)
        except _Syntax as err:
            raise ExpressionError(f"{where}: cannot parse {_shown(text)}: {err}") from None
        shown = text
    if unknown:
        known = ", ".join(sorted(n for n in names if "." not in n)) or "none"
        raise UnknownParameterError(
            f"{where}: unknown name(s) {', '.join(sorted(set(unknown)))} in {_shown(shown)}; "
            f"known names here: {known} (declare model parameters under [parameters])"
        )
    if not isinstance(expr, sp.Expr):
        raise ExpressionError(f"{where}: {_shown(shown)} is not a mathematical expression")
    return expr


def _rebind(expr: sp.Basic, resolve: Callable[[str], sp.Expr | None]) -> tuple[sp.Basic, list[str]]:
    """A sympy expression (from Python code) with its symbols replaced by ``resolve``'s, by name
    (their assumptions may differ from ours)."""
    mapping, unknown = {}, []
    for symbol in expr.free_symbols:
        value = resolve(str(symbol))
        if value is None:
            unknown.append(str(symbol))
        else:
            mapping[symbol] = value
    return expr.xreplace(mapping), unknown


def _check_result(expr: sp.Basic) -> None:
    """Every number of a parsed expression is a finite float64; no division by zero."""
    sp = _sympy()
    if expr.has(sp.zoo, sp.oo, -sp.oo, sp.nan):
        raise _Syntax("division by zero or an infinite value")
    if expr.has(sp.I):
        raise _Syntax("the value is not a real number (a root or logarithm of a negative number)")
    for number in expr.atoms(sp.Number):
        try:
            finite = math.isfinite(float(number))
        except OverflowError:
            finite = False
        if not finite:
            raise _Syntax(f"the number {_shown(number)[:40]} is outside the float64 range")


# --- back to text ---------------------------------------------------------------------------------
@functools.cache
def _written() -> tuple[dict[type, str], dict[type, str]]:
    """(the language's name of each sympy function class, the operator of each relation)."""
    sp = _sympy()
    names: dict[type, str] = {sp.Abs: "abs", sp.Min: "min", sp.Max: "max", sp.sign: "sign",
                              sp.atan2: "atan2", sp.exp: "exp",
                              sp.log: "log"}
    names.update({getattr(sp, n): n for n in ("sin", "cos", "tan", "asin", "acos", "atan",
                                              "sinh", "cosh", "tanh")})
    ops = {sp.StrictLessThan: "<", sp.LessThan: "<=", sp.StrictGreaterThan: ">",
           sp.GreaterThan: ">=", sp.Equality: "==", sp.Unequality: "!="}
    return names, ops


def to_text(expr: sp.Basic) -> str:
    """``expr`` written in the expression language (fully parenthesized), so that
    ``parse_text(to_text(e))`` evaluates like ``e``. Symbols are written by name.

    Raises
    ------
    ExpressionError : ``expr`` holds something the language cannot write (e.g. an unevaluated
        integral).
    """
    sp = _sympy()
    names_of, ops_of = _written()
    if expr is sp.true:
        return "True"
    if isinstance(expr, sp.Symbol):
        return str(expr.name)
    if isinstance(expr, sp.Integer):
        return str(int(expr)) if expr >= 0 else f"(-{-int(expr)})"
    if isinstance(expr, sp.Rational):
        return f"({int(expr.p)}/{int(expr.q)})"
    if isinstance(expr, sp.Float):
        value = float(expr)
        return repr(value) if value >= 0 else f"(-{-value!r})"
    if expr is sp.pi:
        return "pi"
    if expr is sp.E:
        return "exp(1)"
    if isinstance(expr, (sp.Add, sp.Mul)):
        joint = " + " if isinstance(expr, sp.Add) else " * "
        return "(" + joint.join(to_text(arg) for arg in expr.args) + ")"
    if isinstance(expr, sp.Pow):
        return f"({to_text(expr.base)} ** {to_text(expr.exp)})"
    if isinstance(expr, sp.Piecewise):
        if all(c is sp.true or type(c) in ops_of for _, c in expr.args):
            inner = ", ".join(f"({to_text(v)}, {to_text(c)})" for v, c in expr.args)
            return f"Piecewise({inner})"
        return _branches(list(expr.args))
    if isinstance(expr, sp.Heaviside):
        # sympy keeps the value at zero as a second argument (1/2 unless given); the language's
        # Heaviside is 1/2 at zero, any other value is written as a Piecewise.
        x, at_zero = expr.args[0], (expr.args[1] if len(expr.args) > 1 else sp.S.Half)
        if at_zero == sp.S.Half:
            return f"Heaviside({to_text(x)})"
        arg = to_text(x)
        return f"Piecewise((1, {arg} > 0), ({to_text(at_zero)}, {arg} == 0), (0, True))"
    if type(expr) in ops_of:
        return f"{to_text(expr.lhs)} {ops_of[type(expr)]} {to_text(expr.rhs)}"
    if type(expr) in names_of:
        return f"{names_of[type(expr)]}({', '.join(to_text(a) for a in expr.args)})"
    raise ExpressionError(f"{expr} ({type(expr).__name__}) cannot be written in the expression "
                          "language")


def _branches(pairs: list[tuple[sp.Expr, sp.Basic]]) -> str:
    """The (value, condition) pairs of a Piecewise whose conditions are logic (and, or, not,
    if-then-else of comparisons, as sympy makes of a ``where`` inside a condition) as nested
    ``where``: the language compares, it has no logic."""
    sp = _sympy()
    (value, cond), rest = pairs[0], pairs[1:]
    if not rest:
        if cond is sp.true:
            return to_text(value)
        raise ExpressionError(f"{sp.Piecewise(*pairs)} (a Piecewise without a last 'otherwise' "
                              "branch) cannot be written in the expression language")
    return _choose(cond, to_text(value), _branches(rest))


def _choose(cond: sp.Basic, yes: str, no: str) -> str:
    """Text that is ``yes`` where the logic ``cond`` holds, else ``no``."""
    sp = _sympy()
    _, ops_of = _written()
    if cond is sp.true or cond is sp.false:
        return yes if cond is sp.true else no
    if type(cond) in ops_of:
        return f"where({to_text(cond)}, {yes}, {no})"
    if isinstance(cond, (sp.And, sp.Or)):
        first, rest = cond.args[0], type(cond)(*cond.args[1:])
        return (_choose(first, _choose(rest, yes, no), no) if isinstance(cond, sp.And) else
                _choose(first, yes, _choose(rest, yes, no)))
    if isinstance(cond, sp.Not):
        return _choose(cond.args[0], no, yes)
    if isinstance(cond, sp.ITE):
        test, then, otherwise = cond.args
        return _choose(test, _choose(then, yes, no), _choose(otherwise, yes, no))
    raise ExpressionError(f"{cond} ({type(cond).__name__}) cannot be written in the expression "
                          "language")


_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


def is_name(text: Any, dotted: bool = False) -> bool:
    """True when ``text`` is a name of the language: an ASCII letter, then letters, digits and
    ``_`` (not a Python keyword); with ``dotted``, such a name followed by dotted parts of
    letters, digits and ``_`` (``q.hip``, ``M.0.1``)."""
    if not isinstance(text, str):
        return False
    head, *rest = text.split(".") if dotted else [text]
    return bool(_NAME.fullmatch(head) and not keyword.iskeyword(head)
                and all(re.fullmatch(r"[A-Za-z0-9_]+", part) for part in rest))


def check_name(name: Any, what: str, dotted: bool = False) -> None:
    """Raise ModelError unless ``name`` is a name (see :func:`is_name`): names of components,
    parameters, states, ports, events and outputs reach generated code and expressions."""
    if not is_name(name, dotted):
        raise ModelError(f"{what} {_shown(name)} is not a valid name: use ASCII letters, digits "
                         f"and '_', starting with a letter{' (parts joined by dots)' if dotted else ''}"
                         ", e.g. 'foot1'")


def as_expr(value: Any) -> sp.Basic:
    """A value produced by code (a sympy object or a Python number) as a sympy object; never
    parses text (``sympify`` of a string would run Python)."""
    if isinstance(value, str):
        raise TypeError(f"expected a sympy expression or a number, got the text {value!r}; "
                        "text goes through porthamiltonian.modeling.expressions.parse")
    return _sympy().sympify(value, strict=True)


__all__ = [
    "CONSTANTS",
    "FUNCTIONS",
    "MAX_DEPTH",
    "MAX_LENGTH",
    "MAX_NODES",
    "MAX_TERMS",
    "TIME",
    "Expression",
    "as_expr",
    "check_name",
    "is_name",
    "parse",
    "parse_text",
    "to_text",
]

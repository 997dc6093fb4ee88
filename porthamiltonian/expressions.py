"""Parsing of constitutive-law expressions given as text (model files, component arguments).

Expressions are sympy expressions over

* the model's parameters (plain names, e.g. ``k``),
* the time ``t``,
* states of other components by their dotted name (``mass.p``), for modulation,
* names local to a component's law (e.g. ``q``, ``f``, ``e``).

Only the functions in :data:`FUNCTIONS` are available; every other name must be one of the above,
so a misspelt parameter is an error naming the component and argument, never a silent new symbol
or a sympy constant (``E``, ``I``, ``S`` and ``N`` are plain names here).
"""
from __future__ import annotations

import re
import tokenize
from collections.abc import Callable, Mapping

import sympy as sp
from sympy.parsing.sympy_parser import parse_expr, standard_transformations

from .errors import ExpressionError, UnknownParameterError

#: Functions available in expressions, by the name used in text.
FUNCTIONS: dict[str, object] = {
    "sin": sp.sin, "cos": sp.cos, "tan": sp.tan, "asin": sp.asin, "acos": sp.acos,
    "atan": sp.atan, "atan2": sp.atan2, "sinh": sp.sinh, "cosh": sp.cosh, "tanh": sp.tanh,
    "exp": sp.exp, "log": sp.log, "sqrt": sp.sqrt, "abs": sp.Abs, "Abs": sp.Abs,
    "sign": sp.sign, "min": sp.Min, "max": sp.Max, "Min": sp.Min, "Max": sp.Max,
    "pi": sp.pi, "Piecewise": sp.Piecewise, "Heaviside": sp.Heaviside,
}

_GLOBALS = {"Symbol": sp.Symbol, "Integer": sp.Integer, "Float": sp.Float,
            "Rational": sp.Rational, **FUNCTIONS}
_DOTTED = re.compile(r"\b([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)+)\b")

#: The time symbol shared by every model.
TIME = sp.Symbol("t", real=True)


def parse(text: str | float | int | sp.Expr, names: Mapping[str, sp.Expr], where: str,
          dotted: Callable[[str], sp.Expr | None] | None = None) -> sp.Expr:
    """Parse ``text`` into a sympy expression over ``names`` (plus ``t`` and :data:`FUNCTIONS`).

    Parameters
    ----------
    text : the expression; numbers and sympy expressions pass through (their free symbols are
        still checked against ``names``).
    names : every name the expression may use, mapped to its symbol or expression. Dotted names
        (``mass.p``) are allowed.
    where : what is being parsed, for messages, e.g. ``"component 'spring' argument 'stiffness'"``.
    dotted : resolves a dotted name that is not in ``names`` (e.g. another component's state),
        returning ``None`` when it does not exist.

    Raises
    ------
    ExpressionError : the text is not a valid expression.
    UnknownParameterError : the expression uses a name not in ``names``.
    """
    local = {"t": TIME, **names}
    resolved: set[sp.Basic] = set()
    if isinstance(text, sp.Basic):
        text = str(text)  # rebind user symbols by name (their assumptions may differ from ours)
    if isinstance(text, bool):
        raise ExpressionError(f"{where}: expected a number or an expression, got {text!r}")
    if isinstance(text, (int, float)):
        return sp.Float(text) if isinstance(text, float) else sp.Integer(text)
    if isinstance(text, str):
        placeholders: dict[str, sp.Expr] = {}

        def _replace(match: re.Match[str]) -> str:
            token = f"__ref{len(placeholders)}"
            name = match.group(1)
            value = local.get(name, dotted(name) if dotted else None)
            placeholders[token] = sp.Symbol(name) if value is None else value
            if value is not None:
                resolved.add(value)
            return token

        source = _DOTTED.sub(_replace, text)
        try:
            expr = parse_expr(source, local_dict={**local, **placeholders},
                              global_dict=dict(_GLOBALS), transformations=standard_transformations,
                              evaluate=True)
        except (SyntaxError, TypeError, NameError, AttributeError, ValueError, ZeroDivisionError,
                tokenize.TokenError) as err:
            raise ExpressionError(f"{where}: cannot parse {text!r}: {err}") from None
        if not isinstance(expr, sp.Basic):
            raise ExpressionError(f"{where}: {text!r} is not a mathematical expression")
    else:
        raise ExpressionError(f"{where}: expected a number or an expression, got {text!r}")
    allowed = {s for v in [*local.values(), *resolved] if isinstance(v, sp.Basic)
               for s in v.free_symbols}
    unknown = sorted(str(s) for s in expr.free_symbols if s not in allowed)
    if unknown:
        known = ", ".join(sorted(n for n in names if "." not in n)) or "none"
        raise UnknownParameterError(
            f"{where}: unknown name(s) {', '.join(unknown)} in {text!r}; "
            f"known names here: {known} (declare model parameters under [parameters])"
        )
    return expr

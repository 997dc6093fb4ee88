"""Symbolic differentiation for the compiler and for components: partial derivatives and time
derivatives through named intermediates (forward mode).

* :func:`derivative` — ∂expr/∂v, sums, products and numeric powers by hand (the bulk of
  generated expressions, about ten times faster than sympy's general ``diff``).
* :func:`free_symbols` — ``expr.free_symbols``, remembered for every subexpression while a
  :func:`remembering` call runs (a compiler stage, a derivative): the derivative asks at each
  level which of its parts contain the variable, which sympy answers by walking each part's
  whole subtree again.
* :class:`Rates` — the time derivative of expressions of the states along given state rates,
  through a component's intermediates by the forward chain rule: for each intermediate
  w = e(x, w_1, …) that an expression reaches, ẇ = ∂e/∂t + Σ ∂e/∂x_i ẋ_i + Σ ∂e/∂w_j ẇ_j becomes
  an intermediate of its own (named ``<w>.dot``), so the result stays as small as the expressions
  it differentiates (O(1) per intermediate) and the compiler's chain rule differentiates through
  it again. A multibody uses it for the velocity products Ṁ(q) v and Ġ(q) v of its closed loops
  (:mod:`porthamiltonian.mechanics.constrained`).
"""
from __future__ import annotations

import functools
from collections.abc import Callable, Iterable, Mapping
from typing import Any, TypeVar, cast

import sympy as sp
from sympy.core.function import ArgumentIndexError

from .expressions import TIME


def derivative(expr: sp.Expr, v: sp.Symbol,
               memo: dict[tuple[sp.Expr, sp.Symbol], sp.Expr] | None = None) -> sp.Expr:
    """∂expr/∂v by the rules of :func:`_derivative` (sums, products, numeric powers, functions
    of one or more arguments by their ``fdiff``, Piecewise branch by branch), anything else by
    ``sympy.diff``: the same derivative sympy's ``diff`` gives, built without its ``Derivative``
    objects and their assumption queries (several times faster on the compiler's expressions).

    ``memo``: the derivatives found so far, by (expression, variable), filled and reused for
    every subexpression: the code generator differentiates the same subexpressions again and
    again (a model's Jacobians share them; the compass walker's program asks 1108 times for 490
    distinct derivatives). The result is the same expression with or without it."""
    if not isinstance(expr, sp.Basic):
        expr = sp.sympify(expr)             # (a number, or a component's plain value)
    return _remembering_derivative(expr, v, memo)


def _memoized(expr: sp.Expr, v: sp.Symbol,
              memo: dict[tuple[sp.Expr, sp.Symbol], sp.Expr] | None) -> sp.Expr:
    """:func:`derivative` of a sympy expression, looked up in and added to ``memo``."""
    if memo is None:
        return _derivative(expr, v, None)
    key = (expr, v)
    found = memo.get(key)
    if found is None:
        found = memo[key] = _derivative(expr, v, memo)
    return found


#: the function classes whose derivative is the chain rule over their arguments with their own
#: ``fdiff`` (sympy's ``Function._eval_derivative``); the others (Abs, sign, re, im, ...) go to
#: ``sympy.diff``, which knows their special rules
_CHAIN_RULE = sp.Function._eval_derivative


#: the free symbols found while a :func:`remembering` call runs, by the id of the expression
#: (each entry holds the expression, so no other object has that id while it is there); None
#: outside one. (A thread that compiles while another's call runs uses that call's table and,
#: once that call returns, sympy's walk: the same sets either way.)
_REMEMBERED: dict[int, tuple[sp.Basic, frozenset[sp.Basic]]] | None = None

_F = TypeVar("_F", bound=Callable[..., Any])


def remembering(fn: _F) -> _F:
    """``fn`` with :func:`free_symbols` remembering the sets it finds until the outermost
    ``remembering`` call returns (the compiler's stages: ``structure.build_system``,
    ``structure.solve``, ``assemble.assemble``, ``codegen.program``; a :func:`derivative`):
    nothing is kept after it, so that the expressions of one model do not stay alive, and an
    expression equal to an earlier one but built anew is a new entry, not a comparison of the
    two whole trees."""
    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        global _REMEMBERED
        if _REMEMBERED is not None:
            return fn(*args, **kwargs)
        _REMEMBERED = {}
        try:
            return fn(*args, **kwargs)
        finally:
            _REMEMBERED = None
    return cast(_F, wrapper)


def free_symbols(expr: sp.Basic) -> frozenset[sp.Basic]:
    """``expr.free_symbols``, remembered for each expression object while a :func:`remembering`
    call runs (sympy's set, as a frozenset, outside one): for a class whose free symbols are
    those of its arguments (sympy's ``Basic.free_symbols``: sums, products, powers, functions,
    Piecewise, relations), the union of its arguments' remembered sets; for one with a rule of
    its own (a symbol, an array entry, and the classes with bound variables — Lambda,
    Integral, Derivative, Subs), that rule's set."""
    table = _REMEMBERED
    if table is None:
        return frozenset(expr.free_symbols)
    found = table.get(id(expr))
    if found is not None:
        return found[1]
    if type(expr).free_symbols is not _PLAIN_FREE_SYMBOLS:
        symbols = frozenset(expr.free_symbols)
    else:
        symbols = frozenset().union(*map(free_symbols, expr.args))
    table[id(expr)] = (expr, symbols)
    return symbols


#: sympy's free symbols of a tree: those of its arguments (the property classes with bound
#: variables or leaves of their own replace)
_PLAIN_FREE_SYMBOLS = sp.Basic.free_symbols

#: :func:`derivative` of a sympy expression with its free symbols remembered
_remembering_derivative = remembering(_memoized)


def _derivative(expr: sp.Expr, v: sp.Symbol,
                memo: dict[tuple[sp.Expr, sp.Symbol], sp.Expr] | None) -> sp.Expr:
    """:func:`derivative` without looking ``expr`` up in ``memo`` (its parts are)."""
    if expr == v:
        return sp.S.One
    if v not in free_symbols(expr):
        return sp.S.Zero
    if expr.is_Add:
        return sp.Add(*[_memoized(a, v, memo) for a in expr.args if v in free_symbols(a)])
    if expr.is_Mul:
        args, terms = expr.args, []
        for i, a in enumerate(args):
            if v in free_symbols(a):
                d = _memoized(a, v, memo)
                if d != 0:
                    terms.append(sp.Mul(*args[:i], d, *args[i + 1:]))
        return sp.Add(*terms)
    if expr.is_Pow and expr.exp.is_Number:
        return expr.exp * expr.base ** (expr.exp - 1) * _memoized(expr.base, v, memo)
    if isinstance(expr, sp.Piecewise):
        # the conditions are constants of the derivative (as for sympy's Piecewise)
        branches = [(_memoized(e, v, memo), c) for e, c in expr.args]
        if all(d == branches[0][0] for d, _ in branches):
            return branches[0][0]
        return sp.Piecewise(*branches)
    if isinstance(expr, sp.Function) and type(expr)._eval_derivative is _CHAIN_RULE:
        terms = []
        for i, a in enumerate(expr.args, start=1):
            d = _memoized(a, v, memo)
            if d != 0:
                try:
                    terms.append(expr.fdiff(i) * d)
                except ArgumentIndexError:      # no rule for this argument: sympy's Derivative
                    return sp.diff(expr, v)
        return sp.Add(*terms)
    return sp.diff(expr, v)


class Rates:
    """Time derivatives along the state rates ``rates`` (symbol -> ṡ) through the intermediates
    ``definitions`` (symbol -> expression, e.g. a builder's ``built.intermediates``); ``make(name,
    expr)`` declares a new intermediate and returns its symbol (e.g. ``Builder.intermediate``
    with the name relative to the component), ``local(symbol)`` gives the name an intermediate
    was declared with. Symbols that are neither states with a rate, intermediates nor time
    (parameters, inputs held constant) have zero rate."""

    def __init__(self, rates: Mapping[sp.Symbol, sp.Expr],
                 definitions: Iterable[tuple[sp.Symbol, sp.Expr]],
                 make: Callable[[str, sp.Expr], sp.Expr], local: Callable[[sp.Symbol], str]):
        self.rates = dict(rates)
        self.rates.setdefault(TIME, sp.S.One)
        self.definitions = dict(definitions)
        self.make = make
        self.local = local
        self._done: dict[sp.Symbol, sp.Expr] = {}

    def __call__(self, expr: sp.Expr) -> sp.Expr:
        """d(expr)/dt: its partial derivatives by the states and intermediates it reads times
        their rates (an intermediate's rate is made once, as ``<name>.dot``)."""
        expr = sp.sympify(expr)
        terms = []
        for s in sorted(expr.free_symbols, key=str):
            rate = self.rates.get(s)
            if rate is None and s in self.definitions:
                rate = self._intermediate(s)
            if rate is None or rate == 0:
                continue
            d = derivative(expr, s)
            if d != 0:
                terms.append(d * rate)
        return sp.Add(*terms)

    def _intermediate(self, w: sp.Symbol) -> sp.Expr:
        if w not in self._done:
            value = self(self.definitions[w])
            self._done[w] = value if value.is_number else self.make(f"{self.local(w)}.dot", value)
        return self._done[w]


__all__ = ["Rates", "derivative", "free_symbols", "remembering"]

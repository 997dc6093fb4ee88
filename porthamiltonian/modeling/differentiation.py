"""Symbolic differentiation for the compiler and for components: partial derivatives and time
derivatives through named intermediates (forward mode).

* :func:`derivative` — ∂expr/∂v, sums, products and numeric powers by hand (the bulk of
  generated expressions, about ten times faster than sympy's general ``diff``).
* :func:`free_symbols` — ``expr.free_symbols``, remembered for every subexpression: the
  derivative asks at each level which of its parts contain the variable, which sympy answers by
  walking each part's whole subtree again.
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


def free_symbols(expr: sp.Basic) -> frozenset[sp.Basic]:
    """``expr.free_symbols``, remembered for each expression object: for a class whose free
    symbols are those of its arguments (sympy's ``Basic.free_symbols``: sums, products, powers,
    functions, Piecewise, relations), the union of its arguments' remembered sets; for one with
    a rule of its own (a symbol, an array entry, and the classes with bound variables — Lambda,
    Integral, Derivative, Subs), that rule's set."""
    return _free_symbols(id(expr), expr)


@functools.lru_cache(maxsize=1 << 14)
def _free_symbols(key: int, expr: sp.Basic) -> frozenset[sp.Basic]:
    """:func:`free_symbols` of ``expr`` by its identity ``key = id(expr)`` (the entry holds
    ``expr``, so no other object has that id while it is remembered): an equal expression
    built anew — sympy's cache forgets its symbols, the next model's expressions are made
    again — is a new entry, not a comparison of the two whole trees, which remembering by
    equality costs at every level of :func:`_derivative`'s recursion. The most recent 16384
    expressions: more than the largest shipped model's compile asks about (the Whipple
    bicycle's 10400); 12 MB held when full of the largest models' expressions."""
    if type(expr).free_symbols is not _PLAIN_FREE_SYMBOLS:
        return frozenset(expr.free_symbols)
    return frozenset().union(*map(free_symbols, expr.args))


#: sympy's free symbols of a tree: those of its arguments (the property classes with bound
#: variables or leaves of their own replace)
_PLAIN_FREE_SYMBOLS = sp.Basic.free_symbols


def _derivative(expr: sp.Expr, v: sp.Symbol,
                memo: dict[tuple[sp.Expr, sp.Symbol], sp.Expr] | None) -> sp.Expr:
    """:func:`derivative` without looking ``expr`` up in ``memo`` (its parts are)."""
    if expr == v:
        return sp.S.One
    if v not in free_symbols(expr):
        return sp.S.Zero
    if expr.is_Add:
        return sp.Add(*[derivative(a, v, memo) for a in expr.args if v in free_symbols(a)])
    if expr.is_Mul:
        args, terms = expr.args, []
        for i, a in enumerate(args):
            if v in free_symbols(a):
                d = derivative(a, v, memo)
                if d != 0:
                    terms.append(sp.Mul(*args[:i], d, *args[i + 1:]))
        return sp.Add(*terms)
    if expr.is_Pow and expr.exp.is_Number:
        return expr.exp * expr.base ** (expr.exp - 1) * derivative(expr.base, v, memo)
    if isinstance(expr, sp.Piecewise):
        # the conditions are constants of the derivative (as for sympy's Piecewise)
        branches = [(derivative(e, v, memo), c) for e, c in expr.args]
        if all(d == branches[0][0] for d, _ in branches):
            return branches[0][0]
        return sp.Piecewise(*branches)
    if isinstance(expr, sp.Function) and type(expr)._eval_derivative is _CHAIN_RULE:
        terms = []
        for i, a in enumerate(expr.args, start=1):
            d = derivative(a, v, memo)
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


__all__ = ["Rates", "derivative", "free_symbols"]

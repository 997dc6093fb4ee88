"""Common-subexpression elimination for code generation, by hash-consing.

:func:`cse` names every subexpression that occurs more than once, as sympy's ``cse`` does, and
shares a negated product (``-x*y`` with ``x*y``) and a reciprocal power (``x**-2`` with
``x**2``) with their positive forms, as sympy's ``opt_cse`` does. It leaves out the rest of
``opt_cse`` — the matching of common sub-sums and sub-products among sums and products
(``a + b`` in ``a + b + c`` and ``a + b + d``), quadratic in the number of sums and products and
most of sympy's time on a large model — and rebuilds sums, products, powers, functions and
relations with their arguments as they stand (no re-evaluation: sympy's flattening and
assumption queries were most of the rest). The order of every sum's and product's terms is the expression's own, so the
printed code evaluates each the same way whatever was named.
"""
from __future__ import annotations

import itertools
from collections.abc import Iterator

import sympy as sp


def _leaf(e: sp.Basic) -> bool:
    """Atoms and array entries (``x[0]``) are printed as they are, never named."""
    return not e.args or isinstance(e, sp.Indexed)


class _Forms:
    """The form each node is taken in: a negated product as -1 times its positive part, a
    power with a negative exponent as the reciprocal of the positive power (``None``: the node
    as it is)."""

    def __init__(self) -> None:
        self.inner: dict[sp.Basic, sp.Basic | None] = {}

    def __call__(self, e: sp.Basic) -> sp.Basic | None:
        try:
            return self.inner[e]
        except KeyError:
            pass
        inner: sp.Basic | None = None
        if isinstance(e, sp.Mul):
            c = e.args[0]
            if c.is_Number and c.is_negative:
                rest = e.args[1:] if c == -1 else (-c, *e.args[1:])
                inner = rest[0] if len(rest) == 1 else sp.Mul._from_args(rest)
                if _leaf(inner):
                    inner = None
        elif isinstance(e, sp.Pow):
            x = e.exp
            if x.is_Number and x.is_negative:
                inner = sp.Pow(e.base, -x, evaluate=False) if x != -1 else None
        self.inner[e] = inner
        return inner


def _node(func: type, args: tuple[sp.Basic, ...]) -> sp.Basic:
    """``func(*args)`` without re-evaluation where sympy allows it (sums, products, powers,
    functions, relations): the arguments as they stand, in their order."""
    if func is sp.Add or func is sp.Mul:
        return func._from_args(args)
    if issubclass(func, (sp.Pow, sp.Function, sp.core.relational.Relational)):
        return func(*args, evaluate=False)
    return func(*args)


def cse(exprs: list[sp.Expr], prefix: str, rule: dict[sp.Basic, sp.Basic]
        ) -> tuple[list[tuple[sp.Symbol, sp.Expr]], list[sp.Expr]]:
    """``exprs`` with the symbols of ``rule`` replaced by what it maps them to (the names of
    the generated code), as (replacements, reduced) in the way of ``sympy.cse(...,
    numbered_symbols(prefix), order="none")``: ``replacements`` the named subexpressions
    ``(symbol, expr)``, each reading only earlier ones, ``reduced`` the expressions in terms of
    them (see the module docstring for what is shared; a symbol that ``rule`` maps to an
    expression, such as an input ``p[a] + p[b]*t``, is named like a subexpression when it
    occurs more than once). Deterministic: the names follow the expressions' own order."""
    seen: set[sp.Basic] = set()
    repeated: set[sp.Basic] = set()
    taken: set[str] = set()
    form = _Forms()

    def visit(e: sp.Basic) -> None:
        if _leaf(e):
            target = rule.get(e, e)
            if target.is_Symbol:
                taken.add(target.name)
            elif not _leaf(target):         # named like a subexpression when repeated
                if e in seen:
                    repeated.add(e)
                seen.add(e)
            return
        if isinstance(e, sp.Tuple):         # a Piecewise's (value, condition): not a value
            for a in e.args:
                visit(a)
            return
        if e in seen:
            repeated.add(e)
            return
        seen.add(e)
        inner = form(e)
        if inner is None:
            for a in e.args:
                visit(a)
        else:
            visit(inner)

    exprs = [sp.sympify(e) for e in exprs]
    for e in exprs:
        visit(e)

    names: Iterator[sp.Symbol] = (sp.Symbol(f"{prefix}{i}") for i in itertools.count()
                                  if f"{prefix}{i}" not in taken)
    replacements: list[tuple[sp.Symbol, sp.Expr]] = []
    done: dict[sp.Basic, sp.Basic] = {}

    def build(e: sp.Basic) -> sp.Basic:
        out = done.get(e)
        if out is not None:
            return out
        if _leaf(e):
            out = rule.get(e, e)
        else:
            inner = form(e)
            if inner is not None and inner in repeated:
                named = build(inner)
                out = (sp.Mul._from_args((sp.S.NegativeOne, named)) if isinstance(e, sp.Mul)
                       else sp.Pow(named, -1, evaluate=False))
            else:
                args = e.args
                new = tuple(build(a) for a in args)
                out = e if new == args else _node(e.func, new)
        if e in repeated:
            symbol = next(names)
            replacements.append((symbol, out))
            out = symbol
        done[e] = out
        return out

    return replacements, [build(e) for e in exprs]


__all__ = ["cse"]

"""The code generator's common-subexpression elimination (:mod:`porthamiltonian.compiler.cse`).

The named subexpressions, substituted back, give the expressions with the rule's symbols
replaced (numerically at random points: 1e-14 relative; the arithmetic is the same, only the
grouping of a shared product may differ); a repeated subtree, a product and its negation, a
power and its reciprocal are each named once; a symbol the rule maps to an expression (an input,
``p[a] + p[b]*t``) is named when repeated; a Piecewise's (value, condition) pairs stay pairs.
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from porthamiltonian.compiler.cse import cse

x, y, z, u = sp.symbols("x y z u", real=True)
a, b, t = sp.symbols("a b t")


def _expanded(replacements: list[tuple[sp.Symbol, sp.Expr]],
              reduced: list[sp.Expr]) -> list[sp.Expr]:
    """The reduced expressions with every named subexpression substituted back."""
    env: dict[sp.Basic, sp.Basic] = {}
    for symbol, expr in replacements:
        env[symbol] = expr.xreplace(env)
    return [e.xreplace(env) for e in reduced]


def _close(got: list[sp.Expr], want: list[sp.Expr], symbols: list[sp.Symbol]) -> None:
    rng = np.random.default_rng(3)
    f_got, f_want = sp.lambdify(symbols, got), sp.lambdify(symbols, want)
    for _ in range(20):
        point = rng.uniform(0.5, 2.0, len(symbols))
        np.testing.assert_allclose(f_got(*point), f_want(*point), rtol=1e-14, atol=0)


def test_named_subexpressions_give_back_the_expressions():
    exprs = [sp.sin(x * y) + x * y * z, -x * y * sp.cos(x * y), 1 / (x + y) ** 2 + z * (x + y) ** 2,
             -2 * x * z + sp.exp(-2 * x * z), sp.Piecewise((x * y, x > y), (x * y * z, True))]
    replacements, reduced = cse(exprs, "c", {})
    _close(_expanded(replacements, reduced), exprs, [x, y, z])
    named = [e for _, e in replacements]
    assert named.count(x * y) == 1 and -x * y not in named       # -x*y reads x*y's name
    assert named.count((x + y) ** 2) == 1                          # 1/(x+y)**2 its reciprocal
    assert named.count(-2 * x * z) == 1                            # in the sum and in exp()
    assert not any(isinstance(e, sp.Tuple) for e in named)         # pairs stay in the Piecewise


def test_rule_maps_symbols_and_names_a_repeated_mapped_expression():
    rule: dict[sp.Basic, sp.Basic] = {x: a, u: a + b * t}
    exprs = [u * sp.sin(u) + x, 3 * u]
    replacements, reduced = cse(exprs, "c", rule)
    assert [e for _, e in replacements] == [a + b * t]
    assert not (set().union(*(e.free_symbols for e in reduced)) & {x, u})
    _close(_expanded(replacements, reduced), [e.xreplace(rule) for e in exprs], [a, b, t])


def test_names_skip_those_the_expressions_use():
    c0 = sp.Symbol("c0")
    replacements, _ = cse([sp.sin(c0 * y) * sp.sin(c0 * y) + sp.cos(c0 * y)], "c", {})
    assert [str(s) for s, _ in replacements] == ["c1"]

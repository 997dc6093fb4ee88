"""The compiler's differentiation (porthamiltonian.modeling.differentiation.derivative) against
sympy's own ``diff``: the same derivative, numerically at points on both sides of every
Piecewise condition, for the functions the walkers and mechanisms use (sin, cos, exp, tanh,
atan2, sqrt, Piecewise contact and friction laws), built without sympy's ``Derivative`` (its
rules by hand) except for the functions with special rules (Abs, sign), which go to sympy."""
from __future__ import annotations

import math

import pytest
import sympy as sp

from porthamiltonian.modeling import differentiation
from porthamiltonian.modeling.differentiation import derivative, free_symbols, remembering
from porthamiltonian.modeling.expressions import FUNCTIONS

x, y, k = sp.symbols("x y k", real=True)

#: expressions of x and y (k a parameter) shaped like the compiler's: a Hunt-Crossley force
#: clipped at zero, a smoothed friction law, a joint's trigonometry, a variable stiffness
BY_HAND = [
    sp.sin(x) * sp.cos(y) + x**3 * y,
    sp.exp(-k * x**2) * sp.tanh(20 * y),
    sp.atan2(y, x + 2) * sp.sqrt(1 + x**2),
    sp.Piecewise((k * x**sp.Rational(3, 2) * (1 + 0.2 * y), x > 0), (0, True)),
    sp.Piecewise((sp.Max(0, k * x * (1 + y)), x >= 0), (0, True)) + sp.cos(x * y),
    sp.Piecewise((x**2 * y, x + y > 0), (-x * y**2, True)) / (2 + sp.sin(x)),
    sp.sqrt(k + (x - y) ** 2) * sp.Piecewise((x - y, x - y >= 0), (y - x, True)),
]
#: points on both sides of the conditions above
POINTS = [(0.3, 0.7), (-0.4, 0.2), (0.9, -1.3), (-0.8, -0.1)]


def _value(expr: sp.Expr, at: tuple[float, float]) -> float:
    return float(expr.subs({x: at[0], y: at[1], k: 1.7}).evalf(30))


@pytest.mark.parametrize("expr", BY_HAND, ids=range(len(BY_HAND)))
@pytest.mark.parametrize("v", [x, y], ids=["x", "y"])
def test_derivative_is_sympys_diff_at_points(expr, v):
    ours, theirs = derivative(expr, v), sp.diff(expr, v)
    for at in POINTS:
        expected = _value(theirs, at)
        assert math.isclose(_value(ours, at), expected, rel_tol=1e-13, abs_tol=1e-13), (v, at)


@pytest.mark.parametrize("expr", BY_HAND[:4] + BY_HAND[5:], ids=range(len(BY_HAND) - 1))
def test_the_functions_and_piecewise_need_no_sympy_diff(expr, monkeypatch):
    """The chain rule by each function's fdiff and Piecewise branch by branch: sympy's diff
    (its Derivative objects, the cost the by-hand rules save) is never called (Max, in the
    fifth expression, is one that goes to sympy)."""
    def refused(*args):
        raise AssertionError(f"sympy.diff called on {args[0]}")
    monkeypatch.setattr(differentiation.sp, "diff", refused)
    assert derivative(expr, x) != 0


def test_functions_with_rules_of_their_own_go_to_sympy():
    """Abs and sign have rules of their own in sympy (not the chain rule over fdiff)."""
    assert derivative(sp.Abs(x) * y, x) == sp.diff(sp.Abs(x) * y, x)
    assert derivative(sp.sign(x - y), y) == sp.diff(sp.sign(x - y), y)


def test_a_piecewise_whose_branches_have_one_derivative_is_that_derivative():
    """A Piecewise whose branches differ by constants has a derivative without conditions (no
    branch left for the code to test), and one constant in x differentiates to an exact zero."""
    assert derivative(sp.Piecewise((x + 1, y > 0), (x - 1, True)), x) == 1
    assert derivative(sp.Piecewise((y, x > 0), (2 * y, True)), x) == 0
    assert derivative(sp.Piecewise((k * x, x > 0), (0, True)), k) == sp.Piecewise(
        (x, x > 0), (0, True))


def test_a_plain_number_differentiates_to_zero():
    assert derivative(3, x) == 0
    assert derivative(2.5, x) == 0


@pytest.mark.parametrize("name", sorted(FUNCTIONS))
def test_every_function_a_model_file_may_call_differentiates_as_sympy_does(name):
    """Each function of the model files' expression language (expressions.FUNCTIONS), of
    arguments that depend on x and y, by x and by y: the value of sympy's diff at three points."""
    low, _ = FUNCTIONS[name].arity
    args = [0.7 * x + 0.3, 0.5 * y + 0.4, x + 2][:max(low, 1)]
    expr = FUNCTIONS[name].symbolic(*args)
    for v in (x, y):
        ours, theirs = derivative(expr, v), sp.diff(expr, v)
        for at in [(0.3, 0.2), (-0.4, 0.7), (0.9, -0.6)]:
            expected = _value(theirs, at)
            assert math.isclose(_value(ours, at), expected, rel_tol=1e-13, abs_tol=1e-13), (
                name, v, at)


def _random_tree(rng, depth: int) -> sp.Expr:
    """A random expression of x, y, k, array entries a[i] and a function f, with sums,
    products, powers, functions, Piecewise and the classes with bound variables (Integral,
    Derivative, Subs) among its parts."""
    a, f = sp.IndexedBase("a"), sp.Function("f")
    if depth == 0:
        return rng.choice([x, y, k, a[0], a[x], sp.Integer(rng.randint(-3, 3)), sp.Float(0.5)])
    u, w = _random_tree(rng, depth - 1), _random_tree(rng, depth - 1)
    return rng.choice([
        lambda: u + w, lambda: u * w, lambda: u ** 2, lambda: sp.sin(u) * sp.cos(w),
        lambda: f(u, w), lambda: sp.Piecewise((u, w > 0), (w, True)),
        lambda: sp.Integral(u, (x, 0, 1)) * w, lambda: sp.Derivative(f(x, y), x) * u,
        lambda: sp.Subs(f(x, y), x, w) + u,
    ])()


@remembering
def test_free_symbols_are_sympys_on_random_expressions():
    """The remembered free symbols of every subexpression are sympy's ``free_symbols``, also
    in and around the classes whose bound variables are not free (x in a Lambda, an Integral,
    a Derivative or a Subs) and for array entries (a[i] and a); asked again (from the memory),
    the same."""
    import random

    rng = random.Random(1)
    for _ in range(200):
        expr = sp.Tuple(_random_tree(rng, 4), sp.Lambda(x, _random_tree(rng, 2)))
        for sub in sp.postorder_traversal(expr):
            assert free_symbols(sub) == sub.free_symbols, sub
        assert differentiation._REMEMBERED
        assert free_symbols(expr) == expr.free_symbols


def test_free_symbols_are_remembered_only_while_a_remembering_call_runs():
    """Nothing is kept once the outermost call returns (the expressions of one model stay
    alive no longer than its compiler stage); a nested call shares the outer one's table."""
    seen = []

    @remembering
    def inner():
        free_symbols(sp.sin(x) + y)
        seen.append(len(differentiation._REMEMBERED))

    @remembering
    def outer():
        free_symbols(x * y)
        inner()
        seen.append(len(differentiation._REMEMBERED))

    outer()
    assert seen == [5, 5]           # x*y, x, y, then sin(x) + y and sin(x) (x, y known)
    assert differentiation._REMEMBERED is None
    assert free_symbols(x * k) == {x, k}


def test_derivative_with_the_remembered_free_symbols_is_sympys_diff():
    """Derivatives of random expressions without bound variables (sums, products, powers,
    functions, Piecewise, array entries at constant indices) by x, with a memo shared between
    them: sympy's diff (their difference expands to exactly 0)."""
    import random

    rng = random.Random(2)
    memo: dict = {}
    for _ in range(200):
        expr = _random_tree(rng, 3)
        if expr.has(sp.Integral, sp.Derivative, sp.Subs, sp.Function("f"),
                    sp.IndexedBase("a")[x]):
            continue
        assert sp.expand(derivative(expr, x, memo) - sp.diff(expr, x)) == 0, expr

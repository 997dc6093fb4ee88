"""Hypothesis fuzz of the expression parser (porthamiltonian.modeling.expressions): random token sequences,
random unicode and random well-formed expressions.

Properties:
* any text gives a sympy expression or an ExpressionError / UnknownParameterError (a
  ModelError), never anything else, each example within the hypothesis deadline (a hang
  detector: 9**9**9**9-like work must be refused, not computed);
* through a model file, the same texts give a model or a ModelFileError naming the file;
* a parsed expression in parameters evaluates without sympy (Expression.evaluate) to what sympy
  gives for it (an independent check of the run-time constraint evaluator), and writing it back
  (to_text) and parsing again gives the same expression (the constraint metadata round-trips).
"""
from __future__ import annotations

import math
from datetime import timedelta

import sympy as sp
from fuzzing import fuzz_settings
from hypothesis import HealthCheck, assume, given
from hypothesis import strategies as st

from porthamiltonian import io
from porthamiltonian.errors import ExpressionError, ModelFileError, UnknownParameterError
from porthamiltonian.modeling.expressions import parse, parse_text, to_text

NAMES = {n: sp.Symbol(n, real=True) for n in ("k", "m", "c", "x0")}
VALUES = {"k": 4.0, "m": 1.5, "c": -0.4, "x0": 0.1}
FUZZ = fuzz_settings(150, deadline=timedelta(seconds=2),
                     suppress_health_check=[HealthCheck.too_slow])

TOKENS = st.sampled_from([
    "k", "m", "c", "x0", "t", "pi", "E", "mass.p", "spring.q", "sin", "cos", "exp", "log", "sqrt",
    "abs", "sign", "min", "max", "Heaviside", "atan2", "where", "Piecewise", "True", "(", ")",
    ",", "+", "-", "*", "/", "**", "<", "<=", ">", ">=", "==", "!=", "0", "1", "2", "9", "0.5",
    "1e308", "1e-308", "1e400", ".", "_", "__class__", "__globals__", "[", "]", "'", '"', "lambda",
    ":", "^", "@", "=", ";", "#", "\\", "{", "}", "if", "else", "import", "x", "\n", "\t", "\u00e9",
    "\uff45", "\u202e"])
TOKEN_TEXT = st.lists(TOKENS, max_size=40).map(" ".join) | st.lists(TOKENS, max_size=40).map("".join)


def _dotted(name: str):
    return sp.Symbol(name, real=True) if name.split(".")[0] in ("mass", "spring") else None


def check_parse(text: str):
    try:
        expr = parse(text, NAMES, "fuzz", _dotted)
    except (ExpressionError, UnknownParameterError) as err:
        assert str(err).startswith("fuzz"), str(err)
        return None
    assert isinstance(expr, sp.Expr)
    return expr


@FUZZ
@given(TOKEN_TEXT)
def test_random_token_sequences(text):
    check_parse(text)


@FUZZ
@given(st.text(max_size=300))
def test_random_unicode(text):
    check_parse(text)


@fuzz_settings(100, deadline=timedelta(seconds=2))
@given(st.one_of(TOKEN_TEXT, st.text(max_size=100)))
def test_random_expressions_in_a_model_file(text):
    doc = io.model_to_dict(io.loads('bonds = ["j -> spring.p", "j -> mass.p"]\n'
                                    '[parameters]\nk = 1.0\n[components.j]\ntype = "1"\n'
                                    '[components.mass]\ntype = "I"\ninertance = 1.0\n'
                                    '[components.spring]\ntype = "C"\nstiffness = "k"\n'))
    doc["components"]["spring"]["stiffness"] = text
    try:
        io.model_from_dict(doc, source="fuzz.toml")
    except ModelFileError as err:
        assert str(err).startswith("fuzz.toml")


# --- well-formed expressions: the numeric evaluator and the text round trip ----------------------
ATOMS = st.one_of(st.sampled_from(["k", "m", "c", "x0", "pi"]),
                  st.integers(0, 20).map(str),
                  st.floats(0.01, 100, allow_nan=False).map(lambda v: f"{v:.6g}"))
UNARY = ["sin", "cos", "tanh", "exp", "abs", "sign", "atan", "sqrt", "log", "Heaviside"]


def _combine(children):
    return st.one_of(
        st.tuples(children, st.sampled_from(["+", "-", "*", "/"]), children).map(
            lambda t: f"({t[0]} {t[1]} {t[2]})"),
        st.tuples(children, st.sampled_from(["2", "3", "-1", "0.5"])).map(
            lambda t: f"({t[0]})**{t[1]}"),
        st.tuples(st.sampled_from(UNARY), children).map(lambda t: f"{t[0]}({t[1]})"),
        st.tuples(children, children).map(lambda t: f"max({t[0]}, {t[1]})"),
        st.tuples(children, children).map(lambda t: f"atan2({t[0]}, {t[1]})"),
        st.tuples(children, st.sampled_from(["<", ">=", "!="]), children, children, children).map(
            lambda t: f"where({t[0]} {t[1]} {t[2]}, {t[3]}, {t[4]})"),
        children.map(lambda c: f"-{c}"))


EXPRESSIONS = st.recursive(ATOMS, _combine, max_leaves=8)


def _sympy_value(expr: sp.Expr) -> float | None:
    """sympy's value of ``expr`` at VALUES; None where it is not real (sympy refuses to compare
    a non-real number: ``k < sqrt(c)`` with c < 0)."""
    try:
        value = complex(expr.subs({NAMES[n]: sp.Float(v) for n, v in VALUES.items()}).evalf(30))
    except (TypeError, ValueError):
        return None
    return value.real if abs(value.imag) <= 1e-12 * max(1.0, abs(value.real)) else None


@fuzz_settings(80, deadline=timedelta(seconds=2),
               suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(EXPRESSIONS)
def test_numeric_evaluation_agrees_with_sympy_and_text_round_trips(text):
    expr = check_parse(text)
    assume(expr is not None)
    try:
        numeric = parse_text(text).evaluate(VALUES)
    except (ArithmeticError, ValueError):
        numeric = None
    exact = _sympy_value(expr)
    assume(numeric is not None and exact is not None and math.isfinite(exact))
    assume(abs(exact) < 1e12)
    assert math.isclose(numeric, exact, rel_tol=1e-9, abs_tol=1e-9), (text, numeric, exact)
    written = to_text(expr)
    again = _sympy_value(parse(written, NAMES, "round trip"))
    assert again is not None and math.isclose(again, exact, rel_tol=1e-12, abs_tol=1e-12), (
        text, written)
    assert math.isclose(parse_text(written).evaluate(VALUES), exact, rel_tol=1e-9, abs_tol=1e-9)


def test_heaviside_round_trips_with_its_value_at_zero():
    """sympy writes Heaviside(x) as Heaviside(x, 1/2): the text names one argument, and a value at
    zero other than 1/2 (which the language's Heaviside cannot take) comes back as a Piecewise."""
    k = NAMES["k"]
    assert to_text(sp.Heaviside(k)) == "Heaviside(k)"
    for at_zero, expected in ((sp.S.Half, 0.5), (sp.S.One, 1.0), (sp.S.Zero, 0.0)):
        back = parse(to_text(sp.Heaviside(k - 4, at_zero)), NAMES, "round trip")
        assert float(back.subs(k, 4)) == expected
        assert float(back.subs(k, 4.5)) == 1.0 and float(back.subs(k, 3.5)) == 0.0
        assert parse_text(to_text(sp.Heaviside(k - 4, at_zero))).evaluate({"k": 4.0}) == expected


def test_a_where_inside_a_condition_round_trips():
    """sympy folds ``where(k < where(k < m, k, m), k, m)`` into a Piecewise whose condition is
    an if-then-else of comparisons (ITE), and ``where(k < m and ...)``-like logic into And, Or
    and Not: the text writes them as nested ``where`` (found by the fuzz round trip)."""
    k, m, c = NAMES["k"], NAMES["m"], NAMES["c"]
    cases = [parse("where(k < where(k < m, k, m), k, m)", NAMES, "case"),
             sp.Piecewise((k, sp.And(k < m, c < 0)), (m, True)),
             sp.Piecewise((k, sp.Or(k > m, c > 0)), (m, sp.Not(c > 1)), (c, True)),
             sp.Piecewise((k, sp.ITE(k > m, c < 0, c > 0)), (m, True))]
    for values in ({"k": 4.0, "m": 1.5, "c": -0.4}, {"k": 1.0, "m": 1.5, "c": 0.4},
                   {"k": 1.0, "m": 1.5, "c": 2.0}, {"k": 4.0, "m": 1.5, "c": 0.4}):
        at = {NAMES[n]: v for n, v in values.items() if n in ("k", "m", "c")}
        for expr in cases:
            text = to_text(expr)
            assert "where(" in text
            assert float(parse(text, NAMES, "again").subs(at)) == float(expr.subs(at)), text
            assert parse_text(text).evaluate({**VALUES, **values}) == float(expr.subs(at))


def test_an_undefined_or_non_real_value_inside_an_expression_is_an_expression_error():
    """atan2(0, 0) (NaN), log(0) (complex infinity) and sqrt(-1) inside a power, a steep function,
    max or a comparison: sympy raised TypeError or ValueError from there (found by the fuzz);
    each is now an ExpressionError naming where and why."""
    for text, why in [("-(atan2(0, 0))**2", "division by zero or an infinite value"),
                      ("exp(atan2(0, 0))", "division by zero or an infinite value"),
                      ("max(atan2(0, 0), 1)", "division by zero or an infinite value"),
                      ("where(k*log(0) < 1, 1, 2)", "division by zero or an infinite value"),
                      ("exp(-log(0))**2", "division by zero or an infinite value"),
                      ("where(sqrt(-1) < 1, 1, 2)", "not a real number"),
                      ("max(log(-1), k)", "not a real number")]:
        try:
            parse(text, NAMES, "case")
        except ExpressionError as err:
            assert str(err).startswith(f"case: cannot parse {text!r}: ") and why in str(err)
        else:
            raise AssertionError(f"{text!r} parsed")

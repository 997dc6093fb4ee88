"""Every bad numerical option and parameter value gets a typed error naming it, before any work
(issue 10, item 4): porthamiltonian.simulation.options (simulate's arguments) and the components'
constraints on parameter values (porthamiltonian.modeling.constraints, checked by CompiledModel.params).

Before: a NaN tolerance hung the step loop, rtol = 0 hung or divided by zero, a negative one
returned wrong numbers marked "finished", a mass of 0 bound at run time raised ZeroDivisionError
and one of -1 ran with negative kinetic energy. A SIGALRM guard (60 s) turns a hang into a
failure instead of a stuck suite; there is no timing assertion.
"""
from __future__ import annotations

import math
import re
import signal

import numpy as np
import pytest

from porthamiltonian import Model, compile_model, io
from porthamiltonian.errors import (
    InputError,
    ModelError,
    ModelFileError,
    OptionError,
    ParameterValueError,
    StateError,
    UnknownParameterError,
)
from porthamiltonian.simulation.linearize import linearize, trim


@pytest.fixture(autouse=True)
def hang_guard():
    def hung(signum, frame):
        raise AssertionError("no answer within 60 s: the input hangs instead of being refused")

    previous = signal.signal(signal.SIGALRM, hung)
    signal.alarm(60)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


@pytest.fixture(scope="module")
def msd():
    return compile_model(io.load("mass_spring_damper"), backend="python")


def _f(t, x, p):
    return 0.0


NAN, INF = math.nan, math.inf
#: (option, value, error type, words the message must hold)
OPTIONS = [
    ("rtol", NAN, OptionError, ["rtol", "finite"]), ("rtol", 0.0, OptionError, ["rtol", "> 0"]),
    ("rtol", -1e-6, OptionError, ["rtol", "> 0"]), ("rtol", INF, OptionError, ["rtol"]),
    ("rtol", 1.0, OptionError, ["rtol", "< 1"]), ("rtol", 5.0, OptionError, ["rtol", "< 1"]),
    ("rtol", 1e-20, OptionError, ["rtol", "epsilon"]), ("rtol", "1e-6", OptionError, ["rtol", "number"]),
    ("rtol", None, OptionError, ["rtol"]), ("rtol", [1e-6], OptionError, ["rtol"]),
    ("rtol", True, OptionError, ["rtol"]),
    ("atol", NAN, OptionError, ["atol"]), ("atol", 0.0, OptionError, ["atol", "> 0"]),
    ("atol", -1.0, OptionError, ["atol"]), ("atol", INF, OptionError, ["atol", "finite"]),
    ("atol", "x", OptionError, ["atol"]), ("atol", [1e-9], OptionError, ["atol", "per state"]),
    ("atol", [1e-9, NAN], OptionError, ["atol"]), ("atol", [1e-9, -1.0], OptionError, ["atol"]),
    ("max_step", NAN, OptionError, ["max_step"]), ("max_step", 0.0, OptionError, ["max_step"]),
    ("max_step", -1.0, OptionError, ["max_step"]), ("max_step", "1", OptionError, ["max_step"]),
    ("first_step", NAN, OptionError, ["first_step"]), ("first_step", 0.0, OptionError, ["first_step"]),
    ("first_step", -1.0, OptionError, ["first_step"]), ("first_step", INF, OptionError, ["first_step"]),
    ("first_step", 1e9, OptionError, ["first_step", "span"]),
    ("first_step", "0.1", OptionError, ["first_step"]),
    ("t_end", NAN, OptionError, ["t_end"]), ("t_end", INF, OptionError, ["t_end"]),
    ("t_end", -1.0, OptionError, ["t_end", "t_start"]), ("t_end", 0.0, OptionError, ["t_end"]),
    ("t_end", "10", OptionError, ["t_end", "number"]), ("t_end", None, OptionError, ["t_end"]),
    ("t_start", NAN, OptionError, ["t_start"]), ("t_start", "0", OptionError, ["t_start"]),
    ("t_eval", [-1.0, 1.0], OptionError, ["t_eval", "inside"]),
    ("t_eval", [0.0, 20.0], OptionError, ["t_eval", "inside"]),
    ("t_eval", [0.0, NAN], OptionError, ["t_eval", "finite"]),
    ("t_eval", [[0.0, 1.0]], OptionError, ["t_eval", "one-dimensional"]),
    ("t_eval", [1.0, 0.5], OptionError, ["t_eval", "sorted"]),
    ("t_eval", "abc", OptionError, ["t_eval"]),
    ("method", 3, OptionError, ["method"]), ("method", "RK23x", ModelError, ["RK23x", "Radau"]),
    ("max_events", 0, OptionError, ["max_events"]), ("max_events", 1.5, OptionError, ["max_events"]),
    ("max_events", True, OptionError, ["max_events"]), ("max_steps", 0, OptionError, ["max_steps"]),
    ("max_steps", "10", OptionError, ["max_steps"]),
    ("divergence_bound", 0.0, OptionError, ["divergence_bound"]),
    ("divergence_bound", NAN, OptionError, ["divergence_bound"]),
    ("jacobian", "yes", OptionError, ["jacobian"]), ("dense_output", 1, OptionError, ["dense_output"]),
    ("x0", "abc", OptionError, ["x0"]), ("x0", [1.0, 2.0, 3.0], StateError, ["mass.p", "spring.q"]),
    ("x0", {"mass.x": 1.0}, StateError, ["mass.x"]), ("x0", [NAN, 0.0], StateError, ["not finite"]),
    ("params", [1, 2], OptionError, ["params", "mapping"]),
    ("actions", {"nope": _f}, ModelError, ["nope"]), ("actions", {"e": 3}, OptionError, ["actions"]),
    ("events", "x", OptionError, ["events"]),
    # integers beyond the float range (JSON and Python have no bound on them): OverflowError
    # out of the checks before
    ("t_end", 10**400, OptionError, ["t_end", "finite"]),
    ("rtol", 10**400, OptionError, ["rtol", "finite"]),
    ("atol", -10**400, OptionError, ["atol", "finite"]),
    ("first_step", 10**400, OptionError, ["first_step", "finite"]),
    ("x0", {"spring.q": 10**400}, StateError, ["spring.q = inf", "not finite"]),
    ("params", {"k": 10**400}, ParameterValueError, ["'k'", "finite", "inf"]),
    ("sensitivity", [[10**400], [0]], OptionError, ["sensitivity directions must be finite"]),
]


@pytest.mark.parametrize("option, value, error, words", OPTIONS,
                         ids=[f"{o}={re.sub(' at 0x[0-9a-f]+', '', repr(v))[:40]}"
                              for o, v, _, _ in OPTIONS])
def test_bad_option_is_a_typed_error_naming_it(msd, option, value, error, words):
    kwargs = {"t_end": 10.0, "method": "Radau"}
    kwargs[option] = value
    t_end = kwargs.pop("t_end")
    with pytest.raises(error) as info:
        msd.simulate(t_end, **kwargs)
    for word in words:
        assert word in str(info.value), str(info.value)


def test_an_input_beyond_the_float_range_is_not_finite():
    """An input bound to an integer beyond float64 (``inputs={"F": 10**400}``; trim's and
    linearize's ``u``) raised OverflowError; it is not finite, as an input of inf is."""
    cart_pole = compile_model(io.load("cart_pole"), backend="python")
    with pytest.raises(InputError, match=r"^input 'F' must be finite, got 10{400}$"):
        cart_pole.simulate(0.1, inputs={"F": 10**400})
    for call in (trim, linearize):
        with pytest.raises(InputError, match="model 'cart_pole': the inputs must be finite"):
            call(cart_pole, u={"F": -10**400})


#: trim's and linearize's arguments taken as given before: (call, options, error, message)
TRIM = [
    (trim, {"tol": math.inf}, OptionError, "tol must be finite and > 0, got inf"),
    (trim, {"tol": math.nan}, OptionError, "tol must be finite and > 0, got nan"),
    (trim, {"max_iter": -1}, OptionError, "max_iter must be an integer >= 0, got -1"),
    (trim, {"max_iter": 2.5}, OptionError, "max_iter must be an integer >= 0, got 2.5"),
    (trim, {"free_states": []}, OptionError,
     "nothing to trim: free_states and free_inputs are both empty"),
    (trim, {"free_states": "cart_pole.q.pivot"}, OptionError,
     "free_states and free_inputs are lists of names, not a string"),
    (trim, {"t": 10**400}, OptionError, f"t must be finite, got {10**400}"),
    (linearize, {"t": math.nan}, OptionError, "t must be finite, got nan"),
    (linearize, {"x": "abcd"}, StateError, ("model 'cart_pole': the state must be numbers (an "
                                            "array or a mapping {state: value}), got 'abcd'")),
]


@pytest.mark.parametrize("call, options, error, message", TRIM,
                         ids=[f"{c.__name__} {o}"[:50] for c, o, _, _ in TRIM])
def test_trim_and_linearize_check_their_arguments(call, options, error, message):
    """trim(tol=inf) "converged" at its start (residual 0.098), tol=NaN never did, max_iter=-1
    returned an empty message, free_states=[] iterated 50 times with nothing free, a name given
    as a string was read letter by letter ("no state 'c'"); t = NaN linearized at NaN, t =
    10**400 raised OverflowError, x = "abcd" a ValueError. Each is a typed error now."""
    cart_pole = compile_model(io.load("cart_pole"), backend="python")
    with pytest.raises(error) as info:
        call(cart_pole, u={"F": 0.0}, **options)
    assert str(info.value) == message


#: (model, parameter values, error, words)
PARAMETERS = [
    ("mass_spring_damper", {"m": -1.0}, ParameterValueError, ["'mass'", "'inertance'", "> 0", "m = -1"]),
    ("mass_spring_damper", {"m": 0.0}, ParameterValueError, ["'mass'", "'inertance'", "> 0"]),
    ("mass_spring_damper", {"c": -0.1}, ParameterValueError, ["'damper'", "'resistance'", ">= 0"]),
    ("mass_spring_damper", {"k": NAN}, ParameterValueError, ["'k'", "finite"]),
    ("mass_spring_damper", {"k": INF}, ParameterValueError, ["'k'", "finite"]),
    ("mass_spring_damper", {"k": "9"}, ParameterValueError, ["'k'", "number"]),
    ("mass_spring_damper", {"k": None}, ParameterValueError, ["'k'", "number"]),
    ("mass_spring_damper", {"k": True}, ParameterValueError, ["'k'", "number"]),
    ("mass_spring_damper", {"k": [1.0]}, ParameterValueError, ["'k'", "number"]),
    ("mass_spring_damper", {"kk": 1.0}, UnknownParameterError, ["'kk'", "parameters: m, k"]),
    ("mass_spring_damper", {"m": -1.0, "c": -1.0}, ParameterValueError, ["'mass'", "'damper'"]),
    ("pendulum", {"m": -1.0}, ParameterValueError, ["'pendulum'", "body 'bob' mass", "> 0"]),
    ("pendulum", {"m": 0.0}, ParameterValueError, ["'pendulum'", "body 'bob' mass"]),
    ("bouncing_ball", {"K": -1.0}, ParameterValueError, ["'floor'", "'stiffness'", ">= 0"]),
    ("bouncing_ball", {"n": 0.0}, ParameterValueError, ["'floor'", "'exponent'", "> 0"]),
    ("block_on_incline", {"mu_c": 0.9}, ParameterValueError, ["'friction'", "'mu_c'", "'mu_st'"]),
    ("block_on_incline", {"v_st": 0.0}, ParameterValueError, ["'friction'", "'v_st'", "> 0"]),
    ("variable_stiffness_spring", {"alpha": -0.1}, ParameterValueError, ["'spring'", "'alpha'"]),
    ("lc_oscillator", {"Cap": 0.0}, ParameterValueError, ["'capacitor'", "'compliance'", "!= 0"]),
]


@pytest.mark.parametrize("name, values, error, words", PARAMETERS,
                         ids=[f"{n}-{v}" for n, v, _, _ in PARAMETERS])
def test_bad_parameter_value_is_refused_like_a_literal(compile_named, name, values, error, words):
    model = compile_named(name)
    for call in (lambda: model.simulate(0.01, params=values, method="Radau"),
                 lambda: model.params(values),
                 lambda: model.changed_params(model.param_defaults, values)):
        with pytest.raises(error) as info:
            call()
        for word in words:
            assert word in str(info.value), str(info.value)


def test_changed_params_checks_the_constraints_of_what_changed(compile_named):
    """An event action's parameter changes (CompiledModel.changed_params): the values of
    params(...) with them; a constraint that reads no changed parameter is not evaluated again,
    so a vector that already violates it passes unless that parameter changes."""
    model = compile_named("mass_spring_damper")
    p = model.params({"k": 9.0})
    assert np.array_equal(model.changed_params(p, {"c": 0.2, "F": 1.5}),
                          model.params({"k": 9.0, "c": 0.2, "F": 1.5}))
    bad = p.copy()
    bad[model.param_names.index("m")] = -1.0            # m's constraint fails for this vector
    assert model.changed_params(bad, {"F": 2.0})[model.param_names.index("F")] == 2.0
    with pytest.raises(ParameterValueError, match="'mass'"):
        model.changed_params(bad, {"m": -2.0})


def test_the_same_value_as_a_literal_gives_the_same_rule():
    """A mass of 0 written in the model and one bound at run time: the same rule, the same
    names (the literal when the model compiles, the parameter whenever it is bound)."""
    base = io.load("mass_spring_damper")
    literal = io.reads(io.dumps(base).replace('inertance = "m"', "inertance = 0.0"))
    with pytest.raises(ModelFileError) as lit:             # from a model file: names the file
        literal.compile(backend="python", use_cache=False)
    with pytest.raises(ParameterValueError) as bound:
        compile_model(base, backend="python").params({"m": 0.0})
    for message in (str(lit.value), str(bound.value)):
        assert "component 'mass' argument 'inertance'" in message and "must be > 0" in message


def test_good_values_still_run(compile_named):
    model = compile_named("pendulum")
    traj = model.simulate(0.5, params={"m": 2.0}, method="Radau", rtol=1e-8,
                          t_eval=np.linspace(0, 0.5, 6))
    assert traj.success and len(traj.t) == 6


def test_empty_model_is_refused():
    with pytest.raises(ModelError) as info:
        compile_model(Model("nothing"), backend="python", use_cache=False)
    assert "'nothing'" in str(info.value) and "no components" in str(info.value)
    with pytest.raises(ModelFileError) as info:
        compile_model(io.loads("[model]\nname = \"nothing\"\n", source="empty.toml"),
                      backend="python", use_cache=False)
    assert str(info.value).startswith("empty.toml") and "no components" in str(info.value)


@pytest.mark.parametrize("old, new, words", [
    ("rtol = 1e-9", "rtol = 2.0", ["rtol", "< 1"]),
    ("rtol = 1e-9", "rtol = 1e-30", ["rtol", "epsilon"]),
    ("rtol = 1e-9", "rtol = nan", ["rtol", "positive"]),
    ("atol = 1e-12", "atol = -1.0", ["atol", "positive"]),
    ("t_end = 20.0", "t_end = inf", ["t_end", "positive"]),
    ('method = "auto"', 'method = "radau"', ["unknown method 'radau'", "Radau"]),
    ("atol = 1e-12", 'atol = 1e-12\ninitial = { "spring.q" = nan }',
     ["[simulation] initial", "a table of state = finite number", "nan"]),
    ("atol = 1e-12", "atol = 1e-12\ninputs = { F = inf }",
     ["[simulation] inputs", "a table of input = finite number", "inf"]),
])
def test_bad_simulation_table_is_a_model_file_error(model_text, old, new, words):
    text = model_text("mass_spring_damper")
    assert old in text
    with pytest.raises(ModelFileError) as info:
        io.loads(text.replace(old, new), source="msd.toml")
    assert str(info.value).startswith("msd.toml, line ")
    for word in words:
        assert word in str(info.value), str(info.value)


@pytest.mark.parametrize("values", [{"x0": 1e308}, {"x0": 1e200}, {"m": 1e-308}],
                         ids=["x0=1e308", "x0=1e200", "m=1e-308"])
def test_arithmetic_beyond_the_float_range_fails_the_run_on_every_back_end(msd, values):
    """Python's floats raise where C's give inf or NaN: on the python back end a state or a
    parameter near the float range raised OverflowError or ZeroDivisionError out of simulate
    (`porthamiltonian --backend python simulate mass_spring_damper --set x0=1e308`: a bug
    report, status 3). The run now fails as it does on the C back end: status "failed" at
    t = 0, the same message."""
    c = compile_model(io.load("mass_spring_damper"), backend="c")
    for model in (msd, c):
        traj = model.simulate(1.0, params=values)
        assert (traj.status, traj.t_final) == ("failed", 0.0), (model.backend, traj.message)
        assert traj.message.startswith("Rodas5P: step size too small"), traj.message


def test_an_output_outside_its_functions_domain_is_nan_on_every_back_end():
    """``sqrt``, ``log``, ``acos`` and a fractional power of the spring's elongation, which
    swings negative: C and numba compute NaN (and -inf for log 0) where the elongation is
    outside the domain; the python back end raised "math domain error" (or a TypeError for the
    complex number of ``q**1.5``) out of ``traj[...]`` and of a direct call. Now every back end
    gives the same values (NaN at the same points, 1e-15 elsewhere)."""
    from porthamiltonian import C, I, OneJunction
    m = Model("domains")
    m.parameter("a", 1.0, "m")
    m.add("j", OneJunction())
    m.add("mass", I(inertance=1.0))
    m.add("spring", C(stiffness=1.0, q0="a"))
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    names = {"root": "sqrt(spring.q)", "logarithm": "log(spring.q)", "angle": "acos(2*spring.q)",
             "power": "spring.q**1.5"}
    for name, expression in names.items():
        m.output(name, expression)
    runs = {}
    for backend in ("c", "python"):
        model = compile_model(m, backend=backend)
        traj = model.simulate(4.0, method="Rodas5P")
        runs[backend] = np.array([traj[name] for name in names])
        at_zero = model.outputs(0.0, np.zeros(4), model.params())[-4:]
        assert np.isnan(model.outputs(0.0, np.array([0.0, -1.0, 0, 0]), model.params())[-4:]).all()
        np.testing.assert_array_equal(at_zero, [0.0, -np.inf, math.pi / 2, 0.0])
    undefined = np.isnan(runs["c"])
    assert undefined.any() and (~undefined).any()
    np.testing.assert_array_equal(np.isnan(runs["python"]), undefined)
    np.testing.assert_allclose(runs["python"][~undefined], runs["c"][~undefined], rtol=1e-15)

"""Impossible physics and colliding names are refused, whatever way the values arrive (issue 21):
the physical constraints are checked on the values that parameters take when they are bound
(porthamiltonian/modeling/constraints.py, mechanics/inertia.py), and every name a model
defines lives in one namespace (modeling/component.py, modeling/model.py).

Before: a negative or indefinite inertia given through an expression or ``--set`` ran as
"finished" (``simulate heavy_top --set C=-0.006``: H(0) = −9.94 J), only literals were checked;
inertias that break the triangle inequality ran silently; a zero quaternion reached through
parameters said "initial state is not finite" without naming the joint; ``sqrt(k)`` with k < 0
failed deep in the integrator; a body named ``world`` was accepted; a body point named like a
joint's state group (``q`` beside a joint ``x``) silently shadowed the state.

Each case answers a typed error naming the component, the argument and the parameter values,
within :data:`bounds.REFUSAL_CPU` seconds of processor time; the good values beside them
still run, and their numbers are unchanged.
"""
from __future__ import annotations

import json
import textwrap

import numpy as np
import pytest
from bounds import MODELS_DIR, capped

import porthamiltonian as ph
from porthamiltonian import compile_model, io
from porthamiltonian.errors import DuplicateNameError, ModelError, ParameterValueError, StateError
from porthamiltonian.interfaces import cli
from porthamiltonian.mechanics import FreeBody


def _text(name: str) -> str:
    return (MODELS_DIR / f"{name}.toml").read_text()


@pytest.fixture(scope="module")
def heavy_top(isolated_cache):
    return compile_model(io.load("heavy_top"), backend="python")


#: heavy_top: inertia ["A_c", "A_c", "C"] about the centre of mass (A_c = 0.004, C = 0.006)
TOP = [
    ({"C": -0.006}, ["I_xx + I_zz (triangle inequality)", "C = -0.006", "got -0.002"]),
    ({"C": 0.01}, ["I_xx + I_yy (triangle inequality)", "must be >= I_zz (0.01)", "got 0.008"]),
    ({"A_c": -0.004}, ["I_xx + I_yy", "A_c = -0.004"]),
    ({"A_c": 0.0, "C": 0.0}, []),                      # a point mass: allowed
    ({"A_c": 0.001, "C": 0.002}, []),                  # a thin disc, I_zz = I_xx + I_yy: allowed
    ({"m": -1.0}, ["body 'body' mass", "must be > 0"]),
    ({"m": 0.0}, ["body 'body' mass"]),
]


@pytest.mark.parametrize("values, words", TOP, ids=[str(v) for v, _ in TOP])
def test_inertia_bound_at_run_time_gets_the_literal_rule(heavy_top, values, words, within):
    with within():
        if not words:
            heavy_top.params(values)
            return
        with pytest.raises(ParameterValueError) as info:
            heavy_top.simulate(0.01, params=values)
    message = str(info.value)
    assert "model 'heavy_top': component 'top'" in message
    for word in words:
        assert word in message, message


def test_remembered_values_pass_and_a_violation_is_refused_every_time(heavy_top):
    """The checker remembers value sets that satisfied every constraint (a walker binds the same
    parameters at every stride); a violating set raises at every call, after good ones too,
    and a set that differs in one value is evaluated again."""
    checker = heavy_top.constraints
    good = dict(zip(heavy_top.param_names, heavy_top.params().tolist()))
    checker.check(good)
    assert tuple(good.items()) in checker._passed
    bad = {**good, "C": -0.006}
    for _ in range(3):
        with pytest.raises(ParameterValueError, match="triangle inequality"):
            checker.check(bad)
        checker.check(good)
    assert tuple(bad.items()) not in checker._passed
    with pytest.raises(ParameterValueError, match="triangle inequality"):
        heavy_top.changed_params(heavy_top.params(), {"C": -0.006})   # a partial check


@pytest.mark.parametrize("argv, words", [
    (["simulate", "heavy_top", "--set", "C=-0.006"], ["component 'top' body 'body' inertia"]),
    (["simulate", "heavy_top", "--set", "A_c=0.001", "--set", "C=0.01"], ["triangle"]),
    (["simulate", "pendulum", "--set", "r_g=nan"], ["'r_g'", "finite"]),
])
def test_the_command_line_refuses_impossible_bodies(argv, words, capsys, within):
    with within():
        status = cli.main(["--backend", "python", *argv, "--t-end", "0.01"])
    err = capsys.readouterr().err
    assert status == 2 and err.startswith("error: ") and "Traceback" not in err, err
    for word in words:
        assert word in err, err


@pytest.mark.parametrize("inertia, words", [
    ('["0.004*2", "0.004", "0.02"]', ["I_xx + I_yy (triangle inequality)", "got 0.012"]),
    ('[1, 1, 3]', ["eigenvalues [1.0, 1.0, 3.0]"]),
    ('[[1, 0.9, 0], [0.9, 1, 0], [0, 0, 1]]', ["triangle inequality"]),
    ('[[1, 2, 0], [2, 1, 0], [0, 0, 1]]', ["eigenvalues [-1.0"]),
])
def test_a_literal_inconsistent_inertia_is_refused_in_the_file(inertia, words, tmp_path, within):
    text = _text("heavy_top").replace('inertia = ["A_c", "A_c", "C"]', f"inertia = {inertia}")
    assert text != _text("heavy_top")
    with within(), pytest.raises(ModelError) as info:
        io.reads(text, source="top.toml").compile(backend="python", use_cache=False)
    assert str(info.value).startswith("top.toml, line ")
    for word in words + ["body 'body'"]:
        assert word in str(info.value), str(info.value)


def test_an_expression_inertia_that_is_not_symmetric_is_refused():
    text = _text("heavy_top").replace('inertia = ["A_c", "A_c", "C"]',
                                      'inertia = [["A_c", "C", 0], ["A_c", "A_c", 0], [0, 0, "C"]]')
    with pytest.raises(ModelError, match="must be symmetric: I_xy = C but I_yx = A_c"):
        compile_model(io.loads(text), backend="python", use_cache=False)


def test_a_planar_body_needs_only_its_moment_about_the_normal(compile_named):
    """In the x-z plane only I_yy enters: [0, I, 0] (the walkers' legs) is a body; I < 0 is
    not."""
    pendulum = compile_named("pendulum")
    pendulum.params({"r_g": 0.1})
    text = _text("pendulum").replace('inertia = ["m*r_g**2", "m*r_g**2", "m*r_g**2"]',
                                     'inertia = [0, "J", 0]').replace("[parameters]",
                                                                      "[parameters]\nJ = 0.01")
    model = compile_model(io.loads(text), backend="python", use_cache=False)
    assert model.simulate(0.1).success
    with pytest.raises(ParameterValueError, match=r"body 'bob' inertia I_yy = J must be >= 0"):
        model.params({"J": -0.01})


#: a quaternion q0 that parameters can make zero: heavy_top's joint, a FreeBody's quaternion0
def _quaternion_top():
    text = _text("heavy_top").replace('q0 = ["cos(theta0/2)", "sin(theta0/2)", 0, 0]',
                                      'q0 = ["a*cos(theta0/2)", "a*sin(theta0/2)", 0, 0]')
    return text.replace("[parameters]", "[parameters]\na = 1.0")


def _free_body():
    m = ph.Model("tumbler")
    m.parameter("w", 1.0)
    m.parameter("x", 0.0)
    m.parameter("I3", 3.0)
    m.add("body", FreeBody(mass=1.0, inertia=[1.0, 2.0, "I3"], gravity=[0, 0, 0],
                           quaternion0=["w", "x", 0, 0]))
    return m


def test_a_zero_quaternion_through_parameters_names_the_joint(within):
    top = compile_model(io.loads(_quaternion_top()), backend="python", use_cache=False)
    assert top.simulate(0.01, params={"a": 2.0}).success          # any non-zero multiple
    with within(), pytest.raises(ParameterValueError) as info:
        top.simulate(0.01, params={"a": 0.0})
    assert "joint 'tip' q0 (the squared norm of its quaternion" in str(info.value)
    assert "a = 0" in str(info.value)
    body = compile_model(_free_body(), backend="python", use_cache=False)
    assert body.simulate(0.1).success
    with pytest.raises(ParameterValueError, match="argument 'quaternion0' .* must be > 0"):
        body.params({"w": 0.0})
    with pytest.raises(ParameterValueError, match="inertia' I_xx \\+ I_yy .* must be >= I_zz"):
        body.params({"I3": 3.5})


@pytest.mark.parametrize("law, values, words", [
    ("sqrt(k)", {"k": -1.0}, ["argument 'stiffness' = (k ** (1/2)) cannot be evaluated"]),
    ("1/k", {"k": 0.0}, ["argument 'stiffness'", "cannot be evaluated"]),
    ("log(k)", {"k": -2.0}, ["argument 'stiffness' = log(k)"]),
    ("exp(k)", {"k": 1000.0}, ["argument 'stiffness'"]),
    ("sqrt(k)", {"k": 4.0}, []),
])
def test_an_expression_undefined_at_the_bound_values_is_refused(law, values, words, within):
    """Before: sqrt(k) with k < 0 ended as "step size too small" (or an integrator's NaN)."""
    model = compile_model(io.loads(_text("mass_spring_damper").replace('stiffness = "k"',
                                                                         f'stiffness = "{law}"')),
                          backend="python", use_cache=False)
    with within():
        if not words:
            assert model.simulate(1.0, params=values).success
            return
        with pytest.raises(ParameterValueError) as info:
            model.simulate(1.0, params=values)
    for word in words + ["component 'spring'"]:
        assert word in str(info.value), str(info.value)


@pytest.mark.parametrize("method", ["Rodas5P", "Rodas4", "Radau"])
def test_a_tiny_end_time_finishes(method):
    """t_end = 1e-300 finishes (before: the Rodas loops said "step size too small" at t = 0:
    the whole span was below their smallest step); the state moved by ẋ t_end: the momentum
    by −k x0 t_end = −4e-301 N s."""
    model = compile_model(io.load("mass_spring_damper"), backend="python")
    traj = model.simulate(1e-300, method=method)
    assert traj.success and traj.t_final == 1e-300, traj.message
    assert traj.x_final[0] == pytest.approx(-4e-301, rel=1e-12)
    assert traj.x_final[1] == 0.1


#: the back ends the subprocess runs below compare (each prints the same lines)
BACKENDS = ("c", "python")


def _each_backend(body: str) -> str:
    """A script that runs ``body`` (``backend`` bound to its back end's name) once for each
    back end named on its command line, each part headed ``== BACKEND`` and an exception's
    traceback printed in its back end's part."""
    return ("import sys, traceback\n"
            "def run(backend):\n" + textwrap.indent(textwrap.dedent(body), "    ") +
            "for backend in sys.argv[1:]:\n"
            "    print('==', backend)\n"
            "    try:\n"
            "        run(backend)\n"
            "    except Exception:\n"
            "        traceback.print_exc(file=sys.stdout)\n")


@pytest.fixture(scope="module")
def fresh_runs():
    """``fresh_runs(body, timeout)``: the lines each back end printed (``{backend: lines}``)
    from :func:`_each_backend`'s script of ``body``, run for both back ends in one subprocess
    (the interpreter's start and imports paid once), with warnings as errors (``-W error``),
    4 GB of address space and ``timeout`` seconds: a hang in C code cannot be interrupted, and
    fails the tests of the script at the timeout. Once per body for the module."""
    runs: dict[str, dict[str, list[str]]] = {}

    def get(body: str, timeout: float) -> dict[str, list[str]]:
        if body not in runs:
            run = capped(["-W", "error", "-c", _each_backend(body), *BACKENDS], 4 << 30,
                         timeout=timeout)
            assert run.returncode == 0, run.stderr
            parts: dict[str, list[str]] = {}
            for line in run.stdout.splitlines():
                if line.startswith("== ") and line[3:] in BACKENDS:
                    parts[line[3:]] = []
                else:
                    assert parts, run.stdout            # nothing before the first part
                    parts[list(parts)[-1]].append(line)
            assert list(parts) == list(BACKENDS), run.stdout
            runs[body] = parts
        return runs[body]
    return get


_NOT_FINITE = """
from porthamiltonian import compile_model, io
m = compile_model(io.load("double_pendulum"), backend=backend)
x = m.initial_state()
x[2], x[3] = 1e308, -1e308
for method in ("Rodas5P", "QBDF"):
    r = m.simulate(1.0, x0=x, method=method)
    print(method, r.status, r.message)
x = m.initial_state()
x[:] = 1e300
for method in ("auto", "Radau", "RK45"):
    r = m.simulate(1.0, x0=x, method=method)
    print(method, r.status, r.t[-1])
for name, value, sensitivity in (("mass_spring_damper", 1e300, False),
                                 ("mass_spring_damper", 1e300, True), ("heavy_top", 1e-320, True)):
    m = compile_model(io.load(name), backend=backend)
    for method in ("Rodas5P", "QBDF"):
        r = m.simulate(0.5, x0=[value] * m.n_states, method=method, sensitivity=sensitivity)
        print(method, r.status, r.t[-1], r.sensitivity is not None)
"""


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_state_whose_derivative_is_not_finite_fails_at_once(backend, fresh_runs):
    """The double pendulum with momenta ±1e308: the right-hand side at the start holds inf and
    NaN, the first step size was NaN, and the compiled loops (C, and the python back end's
    template) compared it with their smallest step forever (every comparison with NaN is
    false). Both loops now say that the step size is too small, at t = 0; the run is a
    subprocess (``fresh_runs``), since a hang in C code cannot be interrupted. From a state of
    1e300 the back ends end the same runs the same way, and say nothing else: the python back
    end's generated code warned (numpy's RuntimeWarning of an overflow in its small solves; the
    subprocess turns warnings into errors) and raised (Python's ``x**2`` overflowing, QBDF's
    first step dividing by its step size 0, the heavy top's quaternion of 1e-320 normalised)
    where C computes inf and NaN; its runs now end failed, with their start (and their
    sensitivities) kept."""
    lines = fresh_runs(_NOT_FINITE, 120)[backend]
    assert lines[:2] == [f"{m} failed {m}: step size too small (or W singular) at t = 0"
                         for m in ("Rodas5P", "QBDF")]
    assert lines[2:5] == ["auto failed 0.0", "Radau failed 0.0", "RK45 failed 0.0"]
    assert lines[5:] == [f"{m} failed 0.0 {s}" for s in ("False", "True", "True")
                         for m in ("Rodas5P", "QBDF")]


@pytest.mark.parametrize("method", ["RK45", "DOP853"])
def test_rates_that_are_not_finite_at_the_start_fail_the_scipy_run(method, within):
    """``simulate mass_spring_damper --method RK45 --set m=1e-300`` hung for ever, printing
    nothing: the damper's power c p²/m² is 0/0 = NaN at the start (m² underflows), scipy's
    first step size was then NaN, and the step loops of RK45 and DOP853 never leave with one.
    The run now fails at t = 0 and names the rate that is not finite."""
    model = compile_model(io.load("mass_spring_damper"), backend="python")
    with within():
        traj = model.simulate(1.0, params={"m": 1e-300}, method=method)
    assert traj.status == "failed" and traj.t_final == 0.0
    assert traj.message == "the rates at t = 0 are not finite (E_diss: nan)", traj.message


def test_an_lsoda_step_below_the_resolution_of_t_fails_the_run(within):
    """``simulate pendulum --method LSODA --set g=1e300`` ran for many minutes without a word:
    at periods of 1e-150 s LSODA's steps are below the resolution of t = 0 and never advance
    it, and the loop took max_steps (10⁷) of them. The first such step fails the run."""
    model = compile_model(io.load("pendulum"), backend="python")
    with within():
        traj = model.simulate(1.0, params={"g": 1e300}, method="LSODA")
    assert traj.status == "failed" and traj.t_final == 0.0
    assert traj.message == ("LSODA's step size fell below the resolution of t at t = 0: its "
                            "steps no longer advance"), traj.message


# --- one namespace ------------------------------------------------------------------------------------
def _pendulum(points: str = "", joint: str = "pivot", body: str = "bob") -> str:
    text = _text("pendulum").replace("[components.pendulum.joints.pivot]",
                                     f"[components.pendulum.joints.{joint}]")
    text = text.replace("[components.pendulum.bodies.bob]", f"[components.pendulum.bodies.{body}]")
    text = text.replace('child = "bob"', f'child = "{body}"')
    return text.replace('points = { tip = [0, 0, "-l"] }', f'points = {{ tip = [0, 0, "-l"]{points} }}')


NAMES = [
    (_pendulum(', q = [0, 0, "-l"]', joint="x"), "its output 'q.x' has the name of its state 'q.x'"),
    (_pendulum(', p = [0, 0, "-l"]', joint="z"), "its output 'p.z' has the name of its state 'p.z'"),
    (_pendulum(joint="e0").replace('points = {', 'frames = { q = [0, 0, 0] }\npoints = {'),
     "its state 'q.e0' has the name of its port 'q' variable 'q.e0'"),
    (_pendulum(', q = [0, 0, "-l"]', joint="f1"), "state 'q.f1' has the name of its port 'q'"),
    (_pendulum(body="world"), "'world' is the fixed frame"),
    (_text("mass_spring_damper") + '\n[outputs]\nk = "spring.q"\n',
     "the output 'k' has the name of its parameter 'k'"),
    (_text("mass_spring_damper") + '\n[outputs]\nspring = "mass.p"\n',
     "the output 'spring' has the name of its component 'spring'"),
    (_text("mass_spring_damper").replace("[parameters]", "[parameters]\ndamper = 1.0"),
     "the component 'damper' has the name of its parameter 'damper'"),
]


@pytest.mark.parametrize("text, words", NAMES, ids=range(len(NAMES)))
def test_colliding_names_are_refused(text, words, within):
    """Before: the point q beside the joint x shadowed the state q.x (the pendulum never moved
    and the run "finished")."""
    with within(), pytest.raises(ModelError) as info:
        io.reads(text, source="names.toml").compile(backend="python", use_cache=False)
    assert words in str(info.value) and str(info.value).startswith("names.toml"), str(info.value)


def test_names_collide_in_python_too():
    m = ph.Model("m")
    m.parameter("k", 1.0)
    with pytest.raises(DuplicateNameError, match="component 'k' has the name of its parameter"):
        m.add("k", ph.C(stiffness=1.0))
    m.add("spring", ph.C(stiffness="k"))
    with pytest.raises(DuplicateNameError, match="output 'spring'"):
        m.output("spring", "spring.q")


def test_a_point_with_another_name_still_runs(compile_named):
    """The same pendulum with a point beside its tip: unchanged numbers (regression)."""
    model = compile_model(io.loads(_pendulum(', knee = [0, 0, "-l/2"]')), backend="python",
                          use_cache=False)
    reference = compile_named("pendulum")
    a = model.simulate(1.0, method="Radau", rtol=1e-10, atol=1e-12)
    b = reference.simulate(1.0, method="Radau", rtol=1e-10, atol=1e-12)
    assert np.array_equal(a.x_final, b.x_final)


def test_a_walker_whose_mass_matrix_is_singular_says_so():
    """compass_walker with l = 1e-300 (inside its range (0, inf)): the legs' inertia
    m l²/12 rounds to zero and the mass matrix is singular. `walker gait` ended with numpy's
    LinAlgError and "this is a bug" (found by fuzzing the command line); the walker now raises a
    StateError naming the matrix and the likely cause."""
    from walker_library import load_walker

    walker = load_walker("compass_walker", {"l": 1e-300})
    with pytest.raises(StateError, match=r"the mass matrix walker\.M is singular at this state"):
        walker.section_state(walker.initial_guess())


_HUGE_VELOCITIES = """
from walker_library import load_walker
walker = load_walker('kneed_walker', backend=backend)
for v in ((None, 1e308), (-1.7e308, 1.7e308)):
    z = walker.initial_guess()
    z[1] = z[1] if v[0] is None else v[0]
    z[2] = v[1]
    stride = walker.stride(z)
    print(stride.status, stride.reason.split(':')[0])
walker = load_walker('compliant_leg_walker', backend=backend)
for i in (6, 9):
    z = walker.initial_guess()
    z[i] = 1e308
    stride = walker.stride(z)
    print(stride.status, stride.reason.split(':')[0])
"""


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_stride_from_velocities_beyond_float64_falls_quietly(backend, fresh_runs):
    """The kneed walker from its guess with walker.v.hip = 1e308 (found by fuzzing the walker
    files' guesses): the right-hand side holds inf and NaN, and the stride hung in the compiled
    loop (a NaN step size); with walker.v.stance = -1.7e308 as well, the momenta overflow and
    numpy warned of it. Now both strides fall at once (failed; invalid_state), without a warning
    (a subprocess, ``fresh_runs``, with warnings as errors: a hang in C code cannot be
    interrupted). On the python back end too, where the generated code warned (numpy's overflow
    in the stride's energy and outputs) or raised (the compliant-leg walker's section completed from a hip
    velocity of 1e308: Python's ``s**2`` overflowing in the lift, a crash): every stride falls
    as on C (the reason of an invalid state names Python's exception there)."""
    lines = fresh_runs(_HUGE_VELOCITIES, 300)[backend]
    assert lines == ["fell failed", "fell invalid_state", "fell invalid_state", "fell failed"]


def test_a_guess_beyond_float64_is_reported_without_numpy_warnings():
    """``walker gait simplest_walker --set theta_dot=-1e308`` (found by fuzzing): the search
    falls from the guess and finds the gait from the file's own, but reporting Newton's last
    iterate (the guess) leaked numpy's "overflow encountered in dot" from the hip's speed (an
    error under ``-W error``). Now that speed is null in the JSON, without a warning."""
    run = capped(["-W", "error", "-m", "walker_library", "gait", "simplest_walker", "--set",
                  "theta_dot=-1e308", "--json", "--quiet"], 4 << 30, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "warning" not in run.stderr.lower(), run.stderr
    d = json.loads(run.stdout)
    assert d["status"] == "periodic" and d["stable"]
    last = d["newton"]["last_iterate"]
    assert last["theta_dot"] == -1e308 and last["hip_speed"] is None

"""QBDF, the compiled variable-order BDF reusing its Jacobian and LU (porthamiltonian/integrators/
bdf_loop.py and .c), against closed forms and against the other compiled methods:

* its history and dense output (the backward differences rescaled to a new step, the polynomial
  over a step) reproduce polynomials exactly, checked against numpy's polynomial evaluation;
* the global error follows the tolerance on closed forms (the mass-spring-damper's free
  response; the stiff dc motor's step response, from the matrix exponential);
* event times of a bouncing ball against the closed form; agreement with Radau on stiff,
  time-dependent and implicit models;
* the python, numba and C loops agree;
* sensitivities: the trajectory is bit for bit the same with and without them; Φ against the
  matrix exponential, and against Rodas5P's through the events of a bouncing ball;
* the reuse of the Jacobian and the LU is visible in the trajectory's counters.

References: Shampine & Reichelt, "The MATLAB ODE Suite", SIAM J. Sci. Comput. 18 (1997) §2
(the quasi-constant step BDF); Hindmarsh et al., "SUNDIALS", ACM TOMS 31 (2005) (CVODE's
reuse rules).
"""
from __future__ import annotations

import itertools
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

import porthamiltonian as ph
from porthamiltonian import compile_model, io
from porthamiltonian.backends.module import python_loop_module
from porthamiltonian.simulation.simulate import auto_method

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "unit"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_events import ball_model, bounce_action, bounce_times
from test_sensitivity import _bounce, _linear


@pytest.fixture(scope="module")
def template() -> dict:
    """The loop templates: the python back end's loop module (the helpers tested here call no
    rhs, jac or guards)."""
    return vars(python_loop_module())


def _differences(values: np.ndarray, order: int) -> np.ndarray:
    """D_j = ∇^j y_n for j = 0..order from values y_n, y_{n-1}, ... (rows)."""
    D = np.zeros((order + 1, values.shape[1]))
    diffs = values.copy()
    for j in range(order + 1):
        D[j] = diffs[0]
        diffs = diffs[:-1] - diffs[1:]
    return D


@pytest.mark.parametrize("order", [1, 3, 5])
def test_history_rescaling_and_dense_output_are_exact_on_polynomials(template, order):
    """For y(t) a polynomial of degree ``order`` (two components, random coefficients), the
    backward differences on the grid t_n - j h rescaled by r (_bdf_rescale) equal those on the
    grid t_n - j r h, and the dense output of the step t_n - h -> t_n (_bdf_dense, read by
    _dense) equals y there, both to 1e-12 relative."""
    rng = np.random.default_rng(order)
    coef = rng.normal(size=(2, order + 1))
    h, r, t_n = 0.3, 0.45, 1.7

    def y(t):
        return np.array([np.polyval(c, t) for c in coef]).T

    grid = t_n - h * np.arange(order + 1)
    D = np.zeros((8, 2))
    D[: order + 1] = _differences(y(grid), order)
    E = np.zeros((4, 2))
    template["_bdf_dense"](D, order, E)
    out = np.empty(2)
    for th in np.linspace(0.0, 1.0, 7):
        template["_dense"](th, y(t_n - h), y(t_n), E, out)
        assert np.allclose(out, y(t_n - h + th * h), rtol=1e-12, atol=1e-12)
    template["_bdf_rescale"](D, order, r)
    expected = _differences(y(t_n - r * h * np.arange(order + 1)), order)
    assert np.allclose(D[: order + 1], expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())


def _msd_exact(t: float) -> float:
    """Free response of models/mass_spring_damper.toml (m = 1, k = 4, c = 0.4, x0 = 0.1)."""
    wn, z = 2.0, 0.1
    wd = wn * math.sqrt(1 - z * z)
    return 0.1 * math.exp(-z * wn * t) * (math.cos(wd * t) + z * wn / wd * math.sin(wd * t))


def _dc_motor_exact(model, t: float) -> np.ndarray:
    """The dc motor's response to its constant voltage from rest: x' = A x + b (A written from
    the physics, test_sensitivity._linear), x(t) = A⁻¹ (expm(A t) − I) b."""
    _, A = _linear("dc_motor")
    b = np.zeros(2)
    d = dict(zip(model.param_names, model.param_defaults))
    b[model.state_index("winding_inductance.p")] = d["V"]
    return np.linalg.solve(A, (expm(A * t) - np.eye(2)) @ b)


@pytest.fixture(scope="module")
def dc_motor():
    return compile_model(io.load("dc_motor"), backend="c")


def test_global_error_follows_the_tolerance_on_closed_forms(dc_motor):
    """The error at the end falls with the tolerance (100x smaller rtol: 20-500x smaller
    error) and stays within 30 rtol of the solution's scale, on the mass-spring-damper's free
    oscillation (20 s) and on the stiff dc motor's step response (time constants 0.5 ms and
    ~40 ms, 0.2 s); the steps grow by less than 100^(1/3) (the method's orders reach 3-5)."""
    msd = compile_model(io.load("mass_spring_damper"), backend="c")
    cases = [(msd, 20.0, lambda tr: abs(tr.x_final[msd.state_index("spring.q")]
                                        - _msd_exact(20.0)), 0.1),
             (dc_motor, 0.2, lambda tr: np.max(np.abs(tr.x_final - _dc_motor_exact(dc_motor,
                                                                                   0.2))),
              np.max(np.abs(_dc_motor_exact(dc_motor, 0.2))))]
    for model, t_end, error, scale in cases:
        errors, steps = [], []
        for rtol in (1e-6, 1e-8, 1e-10):
            traj = model.simulate(t_end, method="QBDF", rtol=rtol, atol=rtol * 1e-2 * scale)
            assert traj.status == "finished"
            errors.append(error(traj))
            steps.append(len(traj.t))
            assert errors[-1] < 30 * rtol * scale
        for a, b in itertools.pairwise(errors):
            assert 20 < a / b < 500, errors
        for a, b in itertools.pairwise(steps):
            assert 1.3 < b / a < 100 ** (1 / 3), steps


@pytest.mark.parametrize("backend", ["python", "c"])
def test_bounce_times_match_closed_form(backend):
    """Bounces of a ball with restitution 0.8 (closed form in test_events.py) to 1e-9, the
    ledger closed across the resets: the events are located on the BDF's dense output (the
    flight between two bounces is a parabola, which orders >= 2 integrate exactly)."""
    ball = compile_model(ball_model(ground_event=True), backend=backend)
    traj = ball.simulate(2.5, method="QBDF", actions={"ground": bounce_action(ball)},
                         rtol=1e-10, atol=1e-12)
    times = np.array([t for t, _ in traj.events])
    assert len(times) == 4
    np.testing.assert_allclose(times, bounce_times(4), atol=1e-9)
    assert traj.relative_residual < 1e-9


@pytest.mark.parametrize("other", ["c", pytest.param("numba", marks=pytest.mark.numba_loop)])
def test_python_numba_and_c_loops_agree(dc_motor, other):
    """The same loop as plain Python, as numba machine code and as C: the same steps (up to
    the last bits of pow() in the step-size rule), the same counts of Jacobians and LUs, and
    results within the tolerance (rtol 1e-8). (numba: in .ci/run's numba pass.)"""
    model = io.load("dc_motor")
    runs = [compile_model(model, backend=b).simulate(0.2, method="QBDF", rtol=1e-8, atol=1e-11)
            for b in ("python", other)]
    for run in runs[1:]:
        assert abs(len(run.t) - len(runs[0].t)) <= 2
        assert abs(run.njev - runs[0].njev) <= 1 and abs(run.nlu - runs[0].nlu) <= 2
        np.testing.assert_allclose(run.x_final, runs[0].x_final, rtol=1e-7)


@pytest.mark.parametrize("name", ["dc_motor", "modulated_spring", "double_pendulum",
                                  "free_rigid_body"])
def test_agrees_with_radau(c_run, name):
    """Stiff (dc_motor), time-dependent (modulated_spring: the BDF needs no ∂f/∂t), implicit
    blocks (double pendulum, free body): QBDF at rtol 1e-11 and Radau at 1e-10 agree to 1e-6
    relative to the state scale, and the ledger closes. (Radau's run is the session's one per
    model, shared with test_rodas: validation/conftest.py.)"""
    model = compile_model(io.load(name), backend="c")
    t_end = min(3.0, float(io.read(name).simulation["t_end"]))
    a = model.simulate(t_end, method="QBDF", rtol=1e-11, atol=1e-13)
    b = c_run(name, t_end, "Radau", 1e-10, 1e-12)
    assert a.status == b.status == "finished"
    scale = max(1.0, float(np.max(np.abs(b.x))))
    assert np.max(np.abs(a.x_final - b.x_final)) < 1e-6 * scale
    assert a.relative_residual < 1e-7


def test_jacobian_and_lu_are_reused(dc_motor):
    """The counters say what the method does: QBDF evaluates the Jacobian at the start and then
    at most every 50 steps or after a failed Newton iteration, and factors at most every 20
    steps or after a change of step or order; Rodas5P does both at every attempted step."""
    bdf = dc_motor.simulate(0.5, method="QBDF", rtol=1e-10, atol=1e-12)
    rodas = dc_motor.simulate(0.5, method="Rodas5P", rtol=1e-10, atol=1e-12)
    steps = len(bdf.t) - 1
    assert steps > 500
    assert 1 <= bdf.njev <= 0.05 * steps and bdf.nlu <= 0.2 * steps
    assert bdf.nfev < 1.6 * steps
    assert rodas.njev >= len(rodas.t) - 1 and rodas.nlu >= rodas.njev


def test_trajectory_is_bit_identical_with_sensitivities_and_phi_is_the_exponential():
    """With sensitivities the x trajectory is the same bit for bit (the BDF's own Jacobian is
    never replaced by Φ's), on the three back ends; Φ(T) of the linear oscillator equals
    expm(A T) to 1e-8 relative at rtol 1e-10 (Φ carried over each BDF step by Rodas5P's
    variational step in sub-steps of its own error control)."""
    for backend in ("python", "c"):
        model = compile_model(io.load("mass_spring_damper"), backend=backend)
        kwargs = {"method": "QBDF", "rtol": 1e-10, "atol": 1e-12}
        with_phi = model.simulate(10.0, sensitivity=True, **kwargs)
        without = model.simulate(10.0, **kwargs)
        assert np.array_equal(with_phi.t, without.t) and np.array_equal(with_phi.y, without.y)
        _, A = _linear("mass_spring_damper")
        ref = expm(A * 10.0)
        assert np.max(np.abs(with_phi.sensitivity.final - ref)) < 1e-8 * np.max(np.abs(ref))


def test_sensitivities_through_bounces_agree_with_rodas5p():
    """Φ of a bouncing ball through its bounces (saltation matrices at the events) from QBDF
    and from Rodas5P agree to 1e-6 relative, and with central differences of whole runs to
    1e-5; the trajectory with Φ is the same bit for bit."""
    ball = compile_model(ball_model(ground_event=True), backend="c")
    kwargs = {"actions": {"ground": _bounce(ball)}, "rtol": 1e-10, "atol": 1e-12}
    runs = {m: ball.simulate(1.5, method=m, sensitivity=True, **kwargs)
            for m in ("QBDF", "Rodas5P")}
    plain = ball.simulate(1.5, method="QBDF", **kwargs)
    assert np.array_equal(runs["QBDF"].y, plain.y)
    phi, phi_r = runs["QBDF"].sensitivity.final, runs["Rodas5P"].sensitivity.final
    assert len(runs["QBDF"].sensitivity.crossings) == 2
    assert np.max(np.abs(phi - phi_r)) < 1e-6 * np.max(np.abs(phi_r))
    x0 = ball.initial_state(ball.param_defaults)
    fd = np.empty_like(phi)
    for j in range(len(x0)):
        step = 1e-6 * max(1.0, abs(x0[j]))
        ends = []
        for sign in (1, -1):
            x = x0.copy()
            x[j] += sign * step
            ends.append(ball.simulate(1.5, x0=x, method="QBDF", **kwargs).x_final)
        fd[:, j] = (ends[0] - ends[1]) / (2 * step)
    assert np.max(np.abs(phi - fd)) < 1e-5 * np.max(np.abs(fd))


def test_auto_picks_qbdf_for_multibodies_of_two_or_more_coordinates():
    """The documented rule of method="auto": QBDF for a multibody of >= 2 coordinates (the
    double pendulum), Rodas5P otherwise (the one-coordinate pendulum, a linear circuit), and
    the run is then the named method's, bit for bit."""
    double = compile_model(io.load("double_pendulum"), backend="c")
    assert auto_method(double) == "QBDF"
    assert auto_method(compile_model(io.load("pendulum"), backend="c")) == "Rodas5P"
    assert auto_method(compile_model(io.load("dc_motor"), backend="c")) == "Rodas5P"
    a, b = double.simulate(1.0), double.simulate(1.0, method="QBDF")
    assert np.array_equal(a.y, b.y)


def test_auto_with_t_eval_samples_the_compiled_method_on_every_back_end(compile_named):
    """method="auto" with t_eval: the compiled method of auto_method (before: scipy's Radau)
    on the C and the python back end, bit for bit the named method's run, at the asked times;
    the steps' interpolant there is within 1e-9 m of the closed form x0 e^(-zeta wn t)(cos wd t
    + zeta/sqrt(1-zeta^2) sin wd t) of the mass-spring-damper (m 1, k 4, c 0.4, x0 0.1: Ogata,
    Modern Control Engineering, 5-3; measured 2e-11 at rtol 1e-9), as are the steps' own
    values (the run without t_eval) and Radau's; with sensitivities the loop stops on the
    times instead, and the states there are the same run's to 1e-9 m."""
    c = compile_model(io.load("mass_spring_damper"), backend="c")
    py = compile_named("mass_spring_damper")
    t_eval = np.linspace(0.0, 5.0, 501)
    tol = {"rtol": 1e-9, "atol": 1e-12}
    wn, zeta = 2.0, 0.4 / (2 * 2.0)
    wd = wn * math.sqrt(1 - zeta**2)

    def exact(t):
        return 0.1 * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2)
                                               * np.sin(wd * t))
    q = c.state_index("spring.q")
    for model in (c, py):
        assert auto_method(model) == "Rodas5P"
        auto = model.simulate(5.0, t_eval=t_eval, **tol)
        named = model.simulate(5.0, t_eval=t_eval, method="Rodas5P", **tol)
        steps = model.simulate(5.0, method="Rodas5P", **tol)
        radau = model.simulate(5.0, t_eval=t_eval, method="Radau", **tol)
        stopped = model.simulate(5.0, t_eval=t_eval, method="Rodas5P", sensitivity=True, **tol)
        assert np.array_equal(auto.t, t_eval) and np.array_equal(auto.y, named.y)
        assert np.array_equal(stopped.t, t_eval)
        assert len(steps.t) < len(t_eval)          # the interpolant bridges long steps
        for run in (auto, radau, stopped):
            assert np.max(np.abs(run.y[q] - exact(t_eval))) < 1e-9, run
        assert np.max(np.abs(steps.y[q] - exact(steps.t))) < 1e-9
        assert np.max(np.abs(auto.y[q] - stopped.y[q])) < 1e-9


def test_auto_runs_rodas5p_again_where_qbdf_stalls_on_a_jump_of_the_force():
    """The Kelvin-Voigt floor at its file's tolerances (rtol 1e-9, atol 1e-12): the damping
    force B v jumps from 0 to 140 N*s/m x 3.1 m/s at touchdown (t = 0.3193 s, the free fall of
    0.5 m: sqrt(2 x 0.5 / 9.81) = 0.3193 s), inside a step. QBDF's controller stalls there;
    "auto" (QBDF for this two-coordinate multibody) makes the run again with Rodas5P, says so,
    and gives Rodas5P's run, bit for bit, with the ledger closed."""
    ball = compile_model(io.load("bouncing_ball_kelvin_voigt"), backend="c")
    assert auto_method(ball) == "QBDF"
    tol = {"rtol": 1e-9, "atol": 1e-12}
    stalled = ball.simulate(1.5, method="QBDF", **tol)
    assert stalled.status == "failed" and "step size too small" in stalled.message
    assert abs(stalled.t[-1] - math.sqrt(2 * 0.5 / 9.81)) < 1e-4
    auto, rodas = ball.simulate(1.5, **tol), ball.simulate(1.5, method="Rodas5P", **tol)
    assert auto.status == "finished" and auto.message == (
        f"reached t_end (method 'auto': {stalled.message}; run again with Rodas5P)")
    assert np.array_equal(auto.t, rodas.t) and np.array_equal(auto.y, rodas.y)
    assert np.max(np.abs(auto.residual)) < 1e-6 * auto.energy_scale


def test_refuses_python_events(dc_motor):
    turn = ph.Event("turn", lambda t, x, p: x[1])
    with pytest.raises(ph.errors.ModelError, match="QBDF.*Python events"):
        dc_motor.simulate(0.1, method="QBDF", events=[turn])

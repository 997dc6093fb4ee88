"""Dense output of the compiled methods (porthamiltonian.simulation.dense): quintic Hermite
interpolation of the steps with the model's exact rates and their time derivatives.

Checked against closed forms: the free mass–spring–damper (Ogata, Modern Control Engineering,
§5-3), the same driven by a force ramp F = b t (the particular solution b t / k − b c / k²
plus the free response that meets x(0) = ẋ(0) = 0), where ∂f/∂t enters; the ideal bouncing
ball's parabolas between its bounces (the events), against scipy's Radau interpolants; and the
back ends against each other."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicHermiteSpline

from porthamiltonian import compile_model, io
from porthamiltonian.errors import OptionError
from porthamiltonian.simulation.dense import StepInterpolant, step_interpolant
from porthamiltonian.simulation.inputs import Samples

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "unit"))
from test_control import MASS
from test_control import msd as driven_msd
from test_events import HEIGHT, E, G, ball_model, bounce_action, bounce_times

M, X0 = 1.0, 0.1        # models/mass_spring_damper.toml: mass (kg), initial elongation (m)
K, CD = 4.0, 0.8        # the runs' stiffness (N/m) and damping (N s/m): ζ = 0.2
COMPILED = ("Rodas5P", "Rodas4", "QBDF")


def free_response(t, k: float = K, c: float = CD, m: float = M, x0: float = X0):
    """x(t) of m x'' + c x' + k x = 0, x(0) = x0, x'(0) = 0 (underdamped)."""
    wn, zeta = math.sqrt(k / m), c / (2 * math.sqrt(k * m))
    wd = wn * math.sqrt(1 - zeta**2)
    return x0 * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2)
                                          * np.sin(wd * t))


def ramp_response(t, b: float, k: float = K, c: float = CD, m: float = M):
    """(x(t), m ẋ(t)) of m x'' + c x' + k x = b t from rest at x = 0: the elongation and the
    momentum."""
    wn, zeta = math.sqrt(k / m), c / (2 * math.sqrt(k * m))
    sigma, wd = zeta * wn, wn * math.sqrt(1 - zeta**2)
    a = b * c / k**2
    bb = (sigma * a - b / k) / wd
    decay, cos, sin = np.exp(-sigma * t), np.cos(wd * t), np.sin(wd * t)
    x = b * t / k - a + decay * (a * cos + bb * sin)
    v = b / k + decay * ((wd * bb - sigma * a) * cos - (sigma * bb + wd * a) * sin)
    return x, m * v


@pytest.fixture(scope="module")
def msd():
    return compile_model(io.load("mass_spring_damper"), backend="c")


@pytest.mark.parametrize("rtol", [1e-3, 1e-6, 1e-9])
@pytest.mark.parametrize("method", COMPILED)
def test_interpolant_error_is_that_of_the_steps(msd, method, rtol):
    """Over 60 s (30 damped periods), on 60 001 times: the interpolant's largest error is at most
    3x that of the stored points themselves (measured 1.0-2.3x), which it passes through."""
    traj = msd.simulate(60.0, params={"k": K, "c": CD}, method=method, rtol=rtol,
                        atol=rtol * 1e-3, dense_output=True)
    assert traj.status == "finished"
    q = msd.state_index("spring.q")
    points = np.max(np.abs(traj["spring.q"] - free_response(traj.t)))
    grid = np.linspace(0.0, 60.0, 60_001)
    dense = np.max(np.abs(traj.sol(grid)[q] - free_response(grid)))
    assert dense <= 3.0 * points
    np.testing.assert_allclose(traj.sol(traj.t), traj.x.T, rtol=1e-13, atol=1e-15)


def test_the_derivatives_are_needed_on_rodas5p_steps(msd):
    """The same interpolation with values and rates only (a cubic Hermite) is 20x worse or more
    than the quintic one on Rodas5P's steps (measured 37x at rtol 1e-3, 13 000x at 1e-9): the
    reason for the second derivatives."""
    grid = np.linspace(0.0, 60.0, 60_001)
    q = msd.state_index("spring.q")
    for rtol in (1e-3, 1e-9):
        traj = msd.simulate(60.0, params={"k": K, "c": CD}, method="Rodas5P", rtol=rtol,
                            atol=rtol * 1e-3, dense_output=True)
        seg = traj.segments[0]
        rates = np.array([msd.functions.rhs(t, seg.y[:, i], seg.p) for i, t in enumerate(seg.t)])
        cubic = CubicHermiteSpline(seg.t, seg.y, rates.T, axis=1)
        quintic = np.max(np.abs(traj.sol(grid)[q] - free_response(grid)))
        assert np.max(np.abs(cubic(grid)[q] - free_response(grid))) > 20.0 * quintic


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_ramp_input_enters_through_the_time_derivative(backend):
    """F = b t (a linear input: its slope makes the right-hand side read t) on test_control's
    driven mass–spring–damper (mass MASS): the interpolants of the elongation and the momentum
    against the closed form at rtol 1e-9, at most 3x the stored points' error (measured
    1.2-1.7x); leaving ∂f/∂t out of the momentum's second derivative (ṗ = F − k q − c p / m
    reads t through F) makes it 100x worse or more (measured 1.3e7x: the check can fail)."""
    b, t_end = 0.5, 30.0
    model = compile_model(driven_msd(), backend=backend)      # mass MASS, input force F
    x0 = dict.fromkeys(model.state_names, 0.0)
    traj = model.simulate(t_end, x0=x0, params={"k": K, "c": CD},
                          inputs={"F": Samples([0.0, t_end], [0.0, b * t_end], "linear")},
                          method="Rodas5P", rtol=1e-9, atol=1e-12, dense_output=True)
    rows = [model.state_index("spring.q"), model.state_index("mass.p")]
    grid = np.linspace(0.0, t_end, 30_001)
    exact = np.array(ramp_response(grid, b, m=MASS))
    dense = np.max(np.abs(traj.sol(grid)[rows] - exact), axis=1)
    points = np.max(np.abs(traj.x[:, rows].T - np.array(ramp_response(traj.t, b, m=MASS))),
                    axis=1)
    assert np.all(points < 1e-9) and np.all(dense <= 3.0 * points)
    seg = traj.segments[0]
    without = step_interpolant(model, seg.t, seg.y, seg.p, time_dependent=False)
    assert np.max(np.abs(without(grid)[rows[1]] - exact[1])) > 100.0 * dense[1]


@pytest.fixture(scope="module")
def ball():
    return compile_model(ball_model(ground_event=True), backend="c")


@pytest.mark.parametrize("method", ["Rodas5P", "QBDF"])
def test_segments_between_bounces_follow_the_parabolas(ball, method):
    """The ideal ball with restitution E: between bounces each segment's interpolant is the
    free flight's parabola to 1e-9 m (the bounce times to 1e-8 s, test_events), the apex
    heights (E^k v1)²/(2g); scipy's Radau interpolants at the same tolerance agree to 1e-9."""
    traj = ball.simulate(2.5, actions={"ground": bounce_action(ball)}, method=method,
                         rtol=1e-12, atol=1e-14, dense_output=True)
    radau = ball.simulate(2.5, actions={"ground": bounce_action(ball)}, method="Radau",
                          rtol=1e-12, atol=1e-14, dense_output=True)
    times = bounce_times(4)
    h = ball.state_index("height.q")
    v1 = math.sqrt(2 * G * HEIGHT)
    for k in range(3):
        apex = 0.5 * (times[k] + times[k + 1])
        assert traj.sol(apex)[h] == pytest.approx((E ** (k + 1) * v1) ** 2 / (2 * G), abs=1e-9)
        inside = np.linspace(times[k] + 1e-6, times[k + 1] - 1e-6, 501)
        v_out = E ** (k + 1) * v1
        flight = v_out * (inside - times[k]) - 0.5 * G * (inside - times[k]) ** 2
        np.testing.assert_allclose(traj.sol(inside)[h], flight, rtol=0, atol=1e-9)
        np.testing.assert_allclose(traj.sol(inside)[h], radau.sol(inside)[h], rtol=0, atol=1e-9)


def test_back_ends_and_t_eval(msd, compile_named):
    """The python back end's loop takes the C loop's steps: their interpolants agree to 1e-12.
    With ``t_eval`` the trajectory keeps those times and the interpolant is still made from
    every step (as accurate as without)."""
    py = compile_named("mass_spring_damper")
    grid = np.linspace(0.0, 20.0, 2001)
    runs = [model.simulate(20.0, params={"k": K, "c": CD}, method="Rodas5P", rtol=1e-9,
                           atol=1e-12, dense_output=True) for model in (msd, py)]
    np.testing.assert_allclose(runs[0].sol(grid), runs[1].sol(grid), rtol=0, atol=1e-12)
    t_eval = np.linspace(0.0, 20.0, 5)
    few = msd.simulate(20.0, params={"k": K, "c": CD}, method="Rodas5P", rtol=1e-9, atol=1e-12,
                       t_eval=t_eval, dense_output=True)
    np.testing.assert_array_equal(few.t, t_eval)
    q = msd.state_index("spring.q")
    assert np.max(np.abs(few.sol(grid)[q] - free_response(grid))) < 1e-11


def test_repeated_times_and_a_single_point(msd):
    """Of two points at the same time (a terminal event at a step's start) the last is kept;
    a segment of one point is that state at its time."""
    p = msd.params()
    y = np.array([[0.0, 0.5, 0.6, 0.7], [0.1, 0.2, 0.3, 0.4], [0.0] * 4, [0.0] * 4])
    t = np.array([0.0, 1.0, 1.0, 2.0])
    sol = step_interpolant(msd, t, y, p, time_dependent=False)
    np.testing.assert_array_equal(sol(1.0), y[:, 2])
    assert (sol.t_min, sol.t_max) == (0.0, 2.0) and sol(np.array([0.0, 2.0])).shape == (4, 2)
    one = step_interpolant(msd, t[:1], y[:, :1], p, time_dependent=False)
    np.testing.assert_array_equal(one(0.0), y[:, 0])
    assert one(np.array([0.0, 0.0])).shape == (4, 2)


def test_horners_rule_on_the_steps_is_scipys_piecewise_polynomial(msd):
    """The interpolant's own evaluation (Horner's rule on the step that holds each time, which
    spares importing scipy.interpolate) gives scipy's ``PPoly`` of the same coefficients, to
    round-off, at random times, at the stored points and at both ends; a number gives a state,
    an array a column per time."""
    from scipy.interpolate import PPoly

    from porthamiltonian.simulation.dense import _quintic

    rng = np.random.default_rng(7)
    t = np.cumsum(rng.uniform(0.05, 0.4, 40))
    y, f, rate = (rng.normal(size=(4, len(t))) for _ in range(3))
    sol = step_interpolant(msd, t, y, msd.params(), time_dependent=False)
    ours = StepInterpolant(t, _quintic(t, y, f, rate), y[:, 0])
    scipys = PPoly(_quintic(t, y, f, rate), t)
    times = np.concatenate([rng.uniform(t[0], t[-1], 500), t])
    np.testing.assert_allclose(ours(times), scipys(times).T, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(ours(t), y, rtol=1e-12, atol=1e-12)     # through the points
    assert ours(float(t[3])).shape == (4,) and ours(times).shape == (4, len(times))
    np.testing.assert_allclose(sol(t), y, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("backend", ["c", "python"])
def test_extrema_of_a_state_and_an_output_between_the_steps(backend, msd, compile_named):
    """``traj.extrema``: the first undershoot of x (−x0 e^(−ζπ/√(1−ζ²)) at t = π/ω_d, Ogata
    §5-3) to 1e-10 m, and of the spring's force k x (an output, computed from the dense
    output's states) to k × that, where the largest and smallest stored points miss them by
    more than 1e-6 (Rodas5P's long steps at rtol 1e-9); values_at gives traj[name] at the
    stored points; without dense output, an error that says so."""
    model = msd if backend == "c" else compile_named("mass_spring_damper")
    traj = model.simulate(20.0, params={"k": K, "c": CD}, method="Rodas5P", rtol=1e-9,
                          atol=1e-12, dense_output=True)
    zeta = CD / (2 * math.sqrt(K * M))
    undershoot = -X0 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2))
    low, high = traj.extrema("spring.q")
    assert abs(low - undershoot) < 1e-10 and high == X0
    assert traj["spring.q"].min() - undershoot > 1e-6          # the steps alone
    force_low, force_high = traj.extrema("spring.p.e")
    assert abs(force_low - K * undershoot) < 1e-9 and abs(force_high - K * X0) < 1e-12
    assert traj["spring.p.e"].min() - K * undershoot > 4e-6
    np.testing.assert_allclose(traj.values_at("spring.p.e", traj.t[1:-1]),
                               traj["spring.p.e"][1:-1], rtol=1e-12, atol=1e-15)
    assert traj.values_at("spring.p.e", 1.0) == pytest.approx(K * float(free_response(1.0)),
                                                               abs=1e-9)
    with pytest.raises(OptionError, match="dense_output=True"):
        model.simulate(1.0, params={"k": K, "c": CD}).extrema("spring.q")


@pytest.mark.numba_loop
def test_numba_makes_the_c_interpolant(msd):
    """On the numba back end (its compiled loops: .ci/run's numba pass) the same steps and the
    same interpolant as on C, to 1e-12."""
    nb = compile_model(io.load("mass_spring_damper"), backend="numba")
    grid = np.linspace(0.0, 20.0, 2001)
    runs = [model.simulate(20.0, params={"k": K, "c": CD}, method="Rodas5P", rtol=1e-9,
                           atol=1e-12, dense_output=True) for model in (msd, nb)]
    np.testing.assert_allclose(runs[1].sol(grid), runs[0].sol(grid), rtol=0, atol=1e-12)

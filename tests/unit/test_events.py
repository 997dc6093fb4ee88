"""Events, actions and resets: a bouncing ball against its closed form, the ledger across resets,
terminal events, mode (parameter) switches and chattering guards.

Ball: mass m at height q above the ground, H = p²/(2m) + m g q (a C storing the potential energy
m g q, so gravity is part of H). Dropped from rest at height h it first hits the ground at
t₁ = √(2h/g) with speed v₁ = g t₁; each bounce reverses and scales the velocity by the
restitution e, so bounce k+1 follows bounce k after the flight time 2 eᵏ v₁ / g, and bounce k
removes the kinetic energy ½ m (e^{k−1} v₁)² (1 − e²) (e.g. Goldsmith, *Impact*, 1960; any
first-year mechanics text).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import porthamiltonian as ph
from porthamiltonian import compile_model

MASS, G, HEIGHT, E = 0.5, 9.81, 1.0, 0.8


def ball_model(ground_event: bool, terminal: bool = True) -> ph.Model:
    m = ph.Model("ball" + ("_ground" if ground_event else "") + ("" if terminal else "_nt"))
    m.parameter("m", MASS, "kg")
    m.parameter("g", G, "m/s^2")
    m.parameter("h", HEIGHT, "m")
    m.add("j", ph.OneJunction())
    m.add("ball", ph.I(inertance="m"))
    m.add("height", ph.C(energy="m*g*q", q0="h"))
    m.connect("j", "ball.p")
    m.connect("j", "height.p")
    if ground_event:
        m.event("ground", "height.q", direction=-1, terminal=terminal)
    return m


@pytest.fixture(scope="module")
def ball():
    return compile_model(ball_model(ground_event=True), backend="python")


@pytest.fixture(scope="module")
def free_ball():
    return compile_model(ball_model(ground_event=False), backend="python")


def bounce_times(n: int) -> np.ndarray:
    t1 = math.sqrt(2 * HEIGHT / G)
    v1 = G * t1
    times = [t1]
    for k in range(1, n):
        times.append(times[-1] + 2 * E**k * v1 / G)
    return np.array(times)


def kinetic_energy_lost(n: int) -> np.ndarray:
    v1 = math.sqrt(2 * G * HEIGHT)
    return np.array([0.5 * MASS * (E ** (k - 1) * v1) ** 2 * (1 - E**2) for k in range(1, n + 1)])


def bounce_action(model):
    ip = model.state_index("ball.p")

    def bounce(t, x, p):
        x = x.copy()
        x[ip] = -E * x[ip]
        return ph.Reset(x=x)

    return bounce


def _check_bounces(traj, n_expected):
    assert traj.status == "finished", traj.message
    times = np.array([t for t, _ in traj.events])
    assert len(times) == n_expected
    np.testing.assert_allclose(times, bounce_times(n_expected), rtol=0, atol=1e-8)
    lost = kinetic_energy_lost(n_expected)
    jumps = np.array([j for _, _, j in traj.jumps])
    np.testing.assert_allclose(-jumps, lost, rtol=1e-9)
    assert traj.ledger()["dissipated"] == pytest.approx(lost.sum(), rel=1e-9)
    assert traj.ledger()["supplied"] == 0.0
    assert traj.relative_residual < 1e-9


def test_bouncing_ball_model_event_matches_closed_form(ball):
    """Bounce times to 1e-8 s, kinetic energy lost per bounce booked as dissipated (1e-9 relative),
    residual < 1e-9 of the energy scale — with the model's 'ground' event and an action."""
    traj = ball.simulate(2.5, actions={"ground": bounce_action(ball)}, dense_output=True, rtol=1e-12, atol=1e-14)
    n = int(np.sum(bounce_times(10) <= 2.5))
    assert n == 4
    _check_bounces(traj, n)
    assert all(name == "ground" for _, name in traj.events)
    # between bounces the ball flies freely: the apex after bounce k is (e^k v1)²/(2g)
    t = bounce_times(2)
    apex_time = 0.5 * (t[0] + t[1])
    q_apex = traj.sol(apex_time)[ball.state_index("height.q")]
    assert q_apex == pytest.approx((E * math.sqrt(2 * G * HEIGHT)) ** 2 / (2 * G), rel=1e-9)


def test_bouncing_ball_python_event_with_action(free_ball):
    """The same bounces with a Python-level Event (guard on the state vector) and an action for it."""
    iq = free_ball.state_index("height.q")
    ground = ph.Event("floor", lambda t, x, p: x[iq], direction=-1, terminal=True)
    traj = free_ball.simulate(2.5, events=[ground], actions={"floor": bounce_action(free_ball)},
                              rtol=1e-12, atol=1e-14)
    _check_bounces(traj, 4)
    assert all(name == "floor" for _, name in traj.events)


def test_terminal_model_event_without_action_stops(ball):
    traj = ball.simulate(2.5, rtol=1e-12, atol=1e-14)
    assert traj.status == "event" and traj.success
    assert "ground" in traj.message
    assert traj.t_final == pytest.approx(bounce_times(1)[0], abs=1e-8)
    assert traj.events == [(traj.t_final, "ground")]
    assert abs(traj.x_final[ball.state_index("height.q")]) < 1e-9


def test_terminal_python_event_without_action_stops(free_ball):
    iq = free_ball.state_index("height.q")
    half = ph.Event("half_way", lambda t, x, p: x[iq] - HEIGHT / 2, direction=-1)
    traj = free_ball.simulate(2.5, events=[half], rtol=1e-12, atol=1e-14)
    assert traj.status == "event"
    assert "half_way" in traj.message
    assert traj.t_final == pytest.approx(math.sqrt(HEIGHT / G), abs=1e-8)


def test_non_terminal_model_event_is_recorded_without_stopping():
    """A non-terminal model event without action is recorded in traj.events (its crossing time)
    and the run goes on to t_end (the ball falls through the ground)."""
    compiled = compile_model(ball_model(ground_event=True, terminal=False), backend="python")
    traj = compiled.simulate(1.0, rtol=1e-12, atol=1e-14)
    assert traj.status == "finished"
    assert len(traj.events) == 1
    t, name = traj.events[0]
    assert name == "ground"
    assert t == pytest.approx(bounce_times(1)[0], abs=1e-8)


def test_action_stop_ends_with_status_event(ball):
    def stop(t, x, p):
        return ph.Reset(stop=True)

    traj = ball.simulate(2.5, actions={"ground": stop}, rtol=1e-12, atol=1e-14)
    assert traj.status == "event" and "ground" in traj.message
    assert traj.t_final == pytest.approx(bounce_times(1)[0], abs=1e-8)


def test_parameter_switch_booked_as_supplied_energy():
    """A controller doubles a spring's stiffness at t = 0.3 s (a mode change through Reset.params,
    booked as supplied). H jumps by ½ (k₂ − k₁) q(0.3)², E_in jumps by the same amount, and the
    residual stays closed; after the switch the oscillator runs at ω = √(k₂/m)."""
    m = ph.Model("switched_spring")
    m.parameter("k", 4.0, "N/m")
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0))
    m.add("spring", ph.C(stiffness="k", q0=0.1))
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    m.event("switch", "t - 0.3", direction=1)
    compiled = compile_model(m, backend="python")

    def stiffen(t, x, p):
        return ph.Reset(params={"k": 8.0}, energy="supplied")

    traj = compiled.simulate(2.0, actions={"switch": stiffen}, method="DOP853", dense_output=True, rtol=1e-12,
                             atol=1e-14, max_events=50)  # one crossing: one event
    assert traj.status == "finished"
    assert [name for _, name in traj.events] == ["switch"]
    q_s = 0.1 * math.cos(2.0 * 0.3)
    p_s = -0.1 * 2.0 * math.sin(2.0 * 0.3)
    (t_s, _, jump), = traj.jumps
    assert t_s == pytest.approx(0.3, abs=1e-10)
    assert jump == pytest.approx(0.5 * (8.0 - 4.0) * q_s**2, rel=1e-9)
    assert traj.ledger()["supplied"] == pytest.approx(jump, rel=1e-12)
    assert traj.relative_residual < 1e-9
    w2 = math.sqrt(8.0)
    t = 1.7
    q_exact = q_s * math.cos(w2 * (t - 0.3)) + p_s / w2 * math.sin(w2 * (t - 0.3))
    assert traj.sol(t)[compiled.state_index("spring.q")] == pytest.approx(q_exact, abs=1e-9)


def test_chattering_guard_fails_with_hysteresis_message(ball):
    """A plastic landing that leaves the ball exactly on the ground (q = p = 0) under gravity
    re-triggers the guard at once, forever: the run stops after max_events with status "failed"
    and a message advising hysteresis, not an endless loop."""
    def land(t, x, p):
        return ph.Reset(x=np.zeros_like(x))

    traj = ball.simulate(2.5, actions={"ground": land}, max_events=20)
    assert traj.status == "failed" and not traj.success
    assert "hysteresis" in traj.message
    assert "20" in traj.message
    assert len(traj.events) == 21
    assert traj.t_final == pytest.approx(bounce_times(1)[0], abs=1e-6)


def test_action_for_unknown_event_is_an_error(ball):
    with pytest.raises(ph.errors.ModelError, match="'?nope'?"):
        ball.simulate(1.0, actions={"nope": lambda t, x, p: ph.Reset()})


@pytest.mark.parametrize(("direction", "terminal", "expected"), [
    (0, False, [(0.48, 1.0), (0.52, -1.0)]), (-1, False, [(0.48, 1.0)]),
    (1, True, [(0.52, -1.0)])])
def test_a_guard_crossing_twice_within_a_scipy_step_is_seen(direction, terminal, expected):
    """A scipy method's step (0, 1] in which a guard dips below zero and back, (t − 0.48)(t −
    0.52): positive at both ends, where the step alone shows no crossing. The guards sampled
    inside the step (``GUARD_SAMPLES``, as the compiled loops do) see it: both crossings in
    their directions, located to 1e-12, each with the guard's sign before it."""
    import re
    from pathlib import Path

    from scipy.optimize import brentq

    import porthamiltonian.integrators as loops
    from porthamiltonian.simulation.simulate import GUARD_SAMPLES, _crossings

    here = Path(loops.__file__).parent      # the compiled loops sample as many points
    assert re.search(r"#define PH_SAMPLES (\d+)", (here / "rosenbrock_loop.c").read_text())[1] \
        == re.search(r"^_SAMPLES = (\d+)", (here / "rosenbrock_loop.py").read_text(), re.MULTILINE)[1] \
        == str(GUARD_SAMPLES) == "3"

    def g_at(t: float) -> np.ndarray:
        return np.array([(t - 0.48) * (t - 0.52)])

    found = _crossings(g_at, 0.0, g_at(0.0), 1.0, g_at(1.0), np.array([direction]),
                       np.array([terminal]), brentq)
    assert [k for _, k, _ in found] == [0] * len(expected)
    assert [before for _, _, before in found] == [b for _, b in expected]
    np.testing.assert_allclose([t for t, _, _ in found], [t for t, _ in expected], atol=1e-12)

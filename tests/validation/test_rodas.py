"""The compiled Rodas4 loop (porthamiltonian/integrators/rodas_loop.py) against closed forms and
against scipy's Radau: order of convergence, events, stiffness, time-dependent models, back ends.

References: Hairer & Wanner, *Solving Ordinary Differential Equations II* (2nd ed., 1996), §IV.7
(Rodas: order 4, embedded order 3, L-stable); the closed forms are those of test_textbook.py.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import porthamiltonian as ph
from porthamiltonian import compile_model, io

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "unit"))
from test_events import ball_model, bounce_action, bounce_times  # noqa: E402


def _msd_exact(t: float) -> float:
    """Free response of models/mass_spring_damper.toml (m = 1, k = 4, c = 0.4, x0 = 0.1)."""
    wn, z = 2.0, 0.1
    wd = wn * math.sqrt(1 - z * z)
    return 0.1 * math.exp(-z * wn * t) * (math.cos(wd * t) + z * wn / wd * math.sin(wd * t))


@pytest.fixture(scope="module")
def msd():
    return compile_model(io.load("mass_spring_damper"), backend="numba")


def test_rodas4_error_falls_with_tolerance_and_steps_grow_as_fourth_root(msd):
    """A 4th-order method with tolerance-proportional control: 100x smaller rtol gives ~100x
    smaller error and 100^(1/4) ≈ 3.2x more steps (we accept 2.5-4x)."""
    errors, steps = [], []
    for rtol in (1e-6, 1e-8, 1e-10):
        traj = msd.simulate(20.0, method="Rodas4", rtol=rtol, atol=rtol * 1e-2)
        errors.append(abs(traj.x_final[msd.state_index("spring.q")] - _msd_exact(20.0)))
        steps.append(len(traj.t))
    assert errors[0] < 1e-6 * 0.1 * 10 and errors[2] < 1e-10 * 0.1 * 10
    for a, b in zip(errors, errors[1:]):
        assert 20 < a / b < 500
    for a, b in zip(steps, steps[1:]):
        assert 2.5 < b / a < 4.0


@pytest.mark.parametrize("backend", ["python", "numba"])
def test_rodas4_bounce_times_match_closed_form(backend):
    """Bounces of a ball with restitution 0.8 (closed form in test_events.py) to 1e-9, with the
    ledger closed across the resets; the whole flight between two bounces may fit in a few steps,
    so this also checks that interior guard samples catch the crossing."""
    ball = compile_model(ball_model(ground_event=True), backend=backend)
    traj = ball.simulate(2.5, method="Rodas4", actions={"ground": bounce_action(ball)},
                         rtol=1e-10, atol=1e-12)
    times = np.array([t for t, _ in traj.events])
    assert len(times) == 4
    np.testing.assert_allclose(times, bounce_times(4), atol=1e-9)
    assert traj.relative_residual < 1e-9


def test_rodas4_python_and_numba_agree():
    """The same loop as plain Python and as numba machine code: the same steps up to the last
    bits of pow() in the step-size rule, so the results agree to the tolerance (rtol 1e-8)."""
    model = io.load("dc_motor")
    a = compile_model(model, backend="python").simulate(0.2, method="Rodas4", rtol=1e-8, atol=1e-11)
    b = compile_model(model, backend="numba").simulate(0.2, method="Rodas4", rtol=1e-8, atol=1e-11)
    assert abs(len(a.t) - len(b.t)) <= 2
    np.testing.assert_allclose(a.x_final, b.x_final, rtol=1e-7)


@pytest.mark.parametrize("name", ["dc_motor", "modulated_spring", "double_pendulum", "free_rigid_body"])
def test_rodas4_agrees_with_radau(name):
    """Stiff (dc_motor: time constants 0.5 ms and ~40 ms), time-dependent (modulated_spring:
    ∂f/∂t by a difference), implicit blocks (double pendulum, free body): Rodas4 and Radau at
    rtol 1e-10 agree to 1e-6 relative to the state scale, and both ledgers close."""
    model = compile_model(io.load(name), backend="python")
    t_end = min(3.0, float(io.read(name).simulation["t_end"]))
    a = model.simulate(t_end, method="Rodas4", rtol=1e-10, atol=1e-12)
    b = model.simulate(t_end, method="Radau", rtol=1e-10, atol=1e-12)
    assert a.status == b.status == "finished"
    scale = max(1.0, float(np.max(np.abs(b.x))))
    assert np.max(np.abs(a.x_final - b.x_final)) < 1e-6 * scale
    assert a.relative_residual < 1e-7


def test_rodas4_reports_divergence_with_status():
    m = ph.Model("unstable")
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0, p0=1.0))
    m.add("spring", ph.C(stiffness=-100.0))
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    traj = compile_model(m, backend="numba").simulate(100.0, method="Rodas4", divergence_bound=1e6)
    assert traj.status == "diverged" and "1e+06" in traj.message
    assert 0.0 < traj.t_final < 2.0


def test_rodas4_refuses_python_events_and_dense_output(msd):
    with pytest.raises(ph.errors.ModelError, match="Rodas4"):
        msd.simulate(1.0, method="Rodas4", dense_output=True)

"""Parameter sensitivities of a run, ∂x(t)/∂p (``simulate(..., sensitivity=["e", "h"])``):
the forcing ∂f/∂p in the compiled loops' variational sub-steps and the parameter terms of the
saltation matrix at events (porthamiltonian/simulation/psensitivity.py), against closed forms
and central differences of whole runs:

* the bouncing ball (free flight z'' = −g, the bounce v⁺ = −e v⁻ as an action that reads the
  parameter e): bounce times t_k = t₁ + (2 v₁/g) Σ_{j<k} e^j (t₁ = √(2h/g), v₁ = √(2gh)) and the
  state after three bounces, differentiated by the restitution e and the drop height h in
  closed form (sympy); the trajectory is the same bit for bit with and without the columns;
* the pendulum: for a small amplitude θ(t) = θ₀ cos ωt, ω = √(g/l), so ∂θ/∂θ₀ = cos ωt and
  ∂θ/∂l = θ₀ ωt sin ωt / 2l (the nonlinearity's relative error is O(θ₀²) = 1e-6 at θ₀ = 1e-3);
  at θ₀ = 1 rad against Richardson-extrapolated central differences of whole runs.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import porthamiltonian as ph
from porthamiltonian import compile_model, io

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "unit"))
from test_events import MASS, G

E, HEIGHT = 0.8, 1.0


@pytest.fixture(scope="module", params=["c", "python"])
def ball(request):
    """The ideal ball with its restitution ``e`` and drop height ``h`` as parameters (python:
    the numba loops' source, not compiled)."""
    m = ph.Model("ball_e")
    m.parameter("m", MASS, "kg")
    m.parameter("g", G, "m/s^2")
    m.parameter("h", HEIGHT, "m")
    m.parameter("e", E, "1")
    m.add("j", ph.OneJunction())
    m.add("ball", ph.I(inertance="m"))
    m.add("height", ph.C(energy="m*g*q", q0="h"))
    m.connect("j", "ball.p")
    m.connect("j", "height.p")
    m.event("ground", "height.q", direction=-1, terminal=False)
    return compile_model(m, backend=request.param)


def _bounce(model):
    """v⁺ = −e v⁻ (a reset reading the parameter e): ∂x⁺/∂x⁻ and ∂x⁺/∂e."""
    ip, ie = model.state_index("ball.p"), model.param_names.index("e")

    def bounce(t, x, p):
        R = np.eye(2)
        R[ip, ip] = -p[ie]
        dx_de = np.zeros(2)
        dx_de[ip] = -x[ip]
        return ph.Reset(x=R @ x, jacobian=R, jacobian_p={"e": dx_de})

    return bounce


e_, h_ = sp.symbols("e h", positive=True)
V1 = sp.sqrt(2 * G * h_)
BOUNCES = [sp.sqrt(2 * h_ / G) + 2 * V1 / G * sum(e_ ** j for j in range(1, k))
           for k in range(1, 4)]


def test_ball_bounce_times_and_state_by_restitution_and_height(ball):
    """Three bounces to T = 2.2 s: ∂t_k/∂(e, h) of every bounce (the crossings' time
    sensitivities) and ∂(z, v)(T)/∂(e, h) equal the closed form to 1e-9 relative (rtol 1e-11;
    measured 4e-12 on both back ends), and the run is the one without sensitivities bit for bit."""
    T = 2.2
    kwargs = {"actions": {"ground": _bounce(ball)}, "rtol": 1e-11, "atol": 1e-13,
              "method": "Rodas5P"}
    traj = ball.simulate(T, sensitivity=["e", "h"], **kwargs)
    plain = ball.simulate(T, **kwargs)
    np.testing.assert_array_equal(traj.t, plain.t)
    np.testing.assert_array_equal(traj.x, plain.x)
    subs = {e_: E, h_: HEIGHT}
    crossings = traj.sensitivity.crossings
    assert [c.event for c in crossings] == ["ground"] * 3
    for c, tk in zip(crossings, BOUNCES):
        assert c.t == pytest.approx(float(tk.subs(subs)), rel=1e-10)
        exact = [float(sp.diff(tk, s).subs(subs)) for s in (e_, h_)]
        np.testing.assert_allclose(c.time_sensitivity[-2:], exact, rtol=1e-9)   # after x₀'s
    t3, w3 = BOUNCES[2], e_ ** 3 * V1
    z_T, v_T = w3 * (T - t3) - G * (T - t3) ** 2 / 2, w3 - G * (T - t3)
    iq, ip = ball.state_index("height.q"), ball.state_index("ball.p")
    for name, s in (("e", e_), ("h", h_)):
        got = traj.sensitivity.parameters[name]
        assert got.shape == (len(traj.t), 2)
        exact = [float(sp.diff(z_T, s).subs(subs)), MASS * float(sp.diff(v_T, s).subs(subs))]
        np.testing.assert_allclose(got[-1, [iq, ip]], exact, rtol=1e-9, atol=1e-12)


@pytest.fixture(scope="module")
def pendulum():
    return compile_model(io.load("pendulum"), backend="c")


def test_pendulum_small_angle_closed_form(pendulum):
    """θ₀ = 1e-3 rad, 3 s: ∂θ/∂θ₀ and ∂θ/∂l at every stored point equal the linear pendulum's
    cos ωt and θ₀ ωt sin ωt / 2l to 1e-5 of their scale (the small-angle approximation's
    error is ~θ₀²/16 relative; measured 1.5e-6 and 7e-7)."""
    traj = pendulum.simulate(3.0, params={"theta0": 1e-3}, rtol=1e-11, atol=1e-15,
                             method="Rodas5P", sensitivity=["theta0", "l"])
    d = dict(zip(pendulum.param_names, pendulum.param_defaults))
    w = math.sqrt(d["g"] / d["l"])
    i = pendulum.state_index("pendulum.q.pivot")
    t = traj.t
    by_theta0 = traj.sensitivity.parameters["theta0"][:, i]
    by_l = traj.sensitivity.parameters["l"][:, i]
    assert np.max(np.abs(by_theta0 - np.cos(w * t))) < 1e-5
    ref_l = 1e-3 * w * t * np.sin(w * t) / (2 * d["l"])
    assert np.max(np.abs(by_l - ref_l)) < 1e-5 * np.max(np.abs(ref_l))


def richardson(run, p0: float, h: float) -> np.ndarray:
    """(4 D(h) − D(2h))/3 of central differences D of ``run`` at ``p0``: error O(h⁴)."""
    def central(step):
        return (run(p0 + step) - run(p0 - step)) / (2 * step)
    return (4 * central(h) - central(2 * h)) / 3


def test_pendulum_large_angle_against_extrapolated_differences(pendulum):
    """θ₀ = 1 rad (the period grows with the amplitude), 3 s: ∂x(T)/∂(θ₀, l, g) against
    Richardson-extrapolated central differences of whole runs at rtol 1e-13 (step 1e-3
    relative) to 1e-9 relative (measured 9e-12 to 2e-11)."""
    kwargs = {"rtol": 1e-13, "atol": 1e-15, "method": "Rodas5P"}
    base = {"theta0": 1.0}
    traj = pendulum.simulate(3.0, params=base, sensitivity=["theta0", "l", "g"], **kwargs)
    defaults = dict(zip(pendulum.param_names, pendulum.param_defaults)) | base
    for name in ("theta0", "l", "g"):
        p0 = defaults[name]
        ref = richardson(lambda v, name=name: pendulum.simulate(
            3.0, params={**base, name: v}, **kwargs).x_final, p0, 1e-3 * p0)
        got = traj.sensitivity.parameters[name][-1]
        assert np.max(np.abs(got - ref)) < 1e-9 * np.max(np.abs(ref)), name

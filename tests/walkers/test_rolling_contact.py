"""The arc foot as a rolling contact (issue 14, item 5): the thesis walkers' friction acts on the
material point of the foot's circle at the contact, checked at random states against the rigid
body kinematics written out by hand, independently of the friction component.

A foot body turning at ω about +y (rad/s; the multibody's absolute angle θ of that body, 0 with the
leg along −z) with its arc's centre c moving at ċ: the circle's point nearest the surface is
c − R ẑ (slope frame, ẑ the surface normal), and the material point there moves at
ċ + ω ŷ × (−R ẑ) = ċ − R ω x̂ — the slip of a rolling circle, zero when it rolls without slipping
(the thesis's sign convention, θ positive the other way, writes it ẋ_c + ωR). The sole point of
the *_sole_friction files, c + R (−sin θ, 0, −cos θ) fixed in the body, moves along the slope at
ẋ_c − R ω cos θ instead. Here ċ and ω come from central differences of the multibody's position
outputs (the arc centre's x and the foot body's pose quaternion) along q̇ = M⁻¹ p, not from the
friction's port; the friction's wrench on the body is checked to be the force at the contact point
(torque about the centre r × F, r = −R ẑ) with the 20-sim SCVS law written literally
(|tanh|, sign) for its magnitude.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from walker_library import load_walker

#: (walker, where its friction acts)
CASES = [("compass_walker", "rolling"), ("compliant_leg_walker", "rolling"),
         ("ankle_stiffness_walker", "rolling"), ("compass_walker_sole_friction", "sole")]


def _scvs(v: float, p: dict) -> float:
    """μ(v) of the 20-sim SCVS law, literally (the thesis's App. A)."""
    E = math.exp(-(v / p["v_st"]) ** 2)
    return ((p["mu_c"] + (p["mu_st"] * abs(math.tanh(p["s_fric"] * v)) - p["mu_c"]) * E)
            * math.copysign(1.0, v) + p["mu_v"] * v)


def _states(walker, rng: np.random.Generator, n: int) -> list[np.ndarray]:
    """Random states with foot 1 pressed 0.1 mm into the surface (its contact on): leg (and
    ankle) angles drawn around the initial state, joint rates drawn N(0, 0.5) (m/s, rad/s; the
    momenta p = M(q) q̇)."""
    m = walker.model
    p = walker.start_params()
    x0 = m.initial_state(p)
    iz = m.state_index("walker.q.hip_joint.z")
    ip = [m.state_index(n) for n in m.state_names if n.startswith("walker.p.")]
    out = []
    for _ in range(n):
        x = x0.copy()
        for name in m.state_names:
            if name.startswith("walker.q.leg") or (name.startswith("walker.q.ankle")
                                                   and "ankle_stiffness" in m.name):
                x[m.state_index(name)] += rng.uniform(-0.15, 0.15)
        x[iz] += m.output("floor1.z", 0.0, x, p) - 1e-4           # penetration 0.1 mm
        x[ip] = m.matrix("walker.M", 0.0, x, p) @ rng.normal(0.0, 0.5, len(ip))
        out.append(x)
    return out


def _rates(walker, x: np.ndarray, p: np.ndarray, h: float = 1e-6) -> tuple[float, float, float]:
    """(ẋ_c, ω, θ) of foot 1's arc centre and body by central differences along q̇."""
    m = walker.model
    qdot = walker.velocities(x, p)
    iq = [m.state_index(n) for n in m.state_names if n.startswith("walker.q.")]
    plus, minus = x.copy(), x.copy()
    plus[iq] += h * qdot
    minus[iq] -= h * qdot
    centre = "walker.c1.x" if "walker.c1.x" in m.output_names else "walker.foot1.x"

    def angle(y: np.ndarray) -> float:
        qw = m.output("walker.foot1_body.pose.qw", 0.0, y, p)
        qy = m.output("walker.foot1_body.pose.qy", 0.0, y, p)
        return 2.0 * math.atan2(qy, qw)

    xdot = (m.output(centre, 0.0, plus, p) - m.output(centre, 0.0, minus, p)) / (2 * h)
    omega = (angle(plus) - angle(minus)) / (2 * h)
    return xdot, omega, angle(x)


@pytest.mark.parametrize("name, kind", CASES)
def test_friction_slip_is_the_rolling_contact_point_velocity(name, kind):
    """At 20 random states the friction's slip equals ẋ_c − R ω (rolling) or ẋ_c − R ω cos θ
    (sole point), to 1e-7 m/s (the central differences' error at h = 1e-6 is ~1e-10)."""
    walker = load_walker(name)
    m, p = walker.model, walker.start_params()
    R = walker.parameters["R"]
    rng = np.random.default_rng(14)
    worst = 0.0
    for x in _states(walker, rng, 20):
        xdot, omega, theta = _rates(walker, x, p)
        if kind == "rolling":
            expected = xdot - R * omega
            slip = m.output("fric1.vx", 0.0, x, p)
            assert abs(m.output("fric1.vz", 0.0, x, p)) < 1e-12      # tangential
        else:
            expected = xdot - R * omega * math.cos(theta)
            slip = m.output("fric1.v", 0.0, x, p)
        worst = max(worst, abs(slip - expected))
        assert abs(expected) > 1e-3                                  # a state that slips
    assert worst < 1e-7


@pytest.mark.parametrize("name", ["compass_walker", "compliant_leg_walker",
                                  "ankle_stiffness_walker"])
def test_friction_wrench_is_the_force_at_the_contact_point(name):
    """The friction port's effort (τ_y, f_x, f_z) is the reaction of a force F on the body at
    the contact point: F_z = 0, F_x = −Fn μ(|slip|) sign(slip) with the literal SCVS law, and
    the torque about the centre τ_y = (r × F)_y = −R F_x with r = −R ẑ; the power into the
    friction e·f = Fn μ(|slip|) |slip| ≥ 0. (At the states whose contact pushes, Fn > 0.)"""
    walker = load_walker(name)
    m, p = walker.model, walker.start_params()
    R = walker.parameters["R"]
    law = {k: walker.parameters[k] for k in ("mu_st", "mu_c", "mu_v", "s_fric", "v_st")}
    pressed = [x for x in _states(walker, np.random.default_rng(5), 40)
               if m.output("floor1.Fn", 0.0, x, p) > 0]      # else the foot leaves too fast
    assert len(pressed) >= 10
    for x in pressed:
        e = [m.output(f"fric1.p.e{i}", 0.0, x, p) for i in range(3)]
        f = [m.output(f"fric1.p.f{i}", 0.0, x, p) for i in range(3)]
        tau, Fx, Fz = -e[0], -e[1], -e[2]                          # on the body
        slip = m.output("fric1.vx", 0.0, x, p)
        Fn = m.output("floor1.Fn", 0.0, x, p)
        scale = Fn * law["mu_st"]
        assert abs(Fz) < 1e-12 * scale
        assert Fx == pytest.approx(-Fn * _scvs(slip, law), rel=1e-9, abs=1e-12 * scale)
        assert tau == pytest.approx(-R * Fx, rel=1e-12, abs=1e-15 * scale)
        power = sum(a * b for a, b in zip(e, f))
        assert power == pytest.approx(Fn * _scvs(slip, law) * slip, rel=1e-9, abs=1e-15)
        assert power >= 0

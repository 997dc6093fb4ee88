"""The thesis's compliant-leg walker (models/compliant_leg_walker.toml; M. Jafarian 2010, MSc
report 022CE2010, University of Twente, §3.1): compass_walker with each foot on a prismatic joint
along the leg, a linear spring K_leg = 6000 N/m and a damper D = 2·0.15·√(3.1 K_leg) per leg,
γ = 0.009.

Measured here (numba + Rodas4, rtol 1e-8, atol 1e-10) with point-mass legs and the friction at
the sole point (compliant_leg_walker_point_legs; the default's legs are rods, I_leg = m_leg l²/12,
and its friction acts at the rolling contact point: θ = 0.24939, θ̇ = −0.86309, |λ| = 0.309,
speed 0.3363 m/s, ground 0.00525 J per step; with the rods and the sole point θ = 0.24913, |λ| =
0.306, speed 0.3356 m/s): stable period-1 gait, θ = 0.24894,
φ = 0.46861, θ̇ = −0.86416, φ̇ = 0.02029 at touchdown; Floquet multipliers |λ| = 0.319 (a
complex pair), the rest < 4e-3; step period 1.0305 s, step length 0.3473 m, speed 0.3370 m/s
(compass_walker, rigid legs: 0.3050 m/s); 0.09873 J dissipated per step (= the potential
released: cost of transport sin γ), of which the leg dampers take 0.0935 J and the ground
(contact 0.00372 J + friction 0.00151 J) 0.00523 J — 16.7× less than compass_walker's 0.0874 J
(the thesis: "around 10 times smaller"). Ledger residual over 20 steps 3.4e-10 J.

Thesis trends (§3.1), measured with this model (K sweep by continuation, not in the tests):
stable period-1 gaits from the flip at K ≈ 1640 N/m (legs as rods; below it a stable period-2
gait, |λ| = 0.78 at 1500 N/m, which `walker gait --set K_leg=1500` finds by continuation) up to
1e7 N/m (the thesis: stable from 1500 N/m); the
largest multiplier is not monotonic in K (0.81 at 2500, 0.41 at 2250, 0.39 at 3000, 0.32 at
6000). Faster than the rigid-leg walker from K between 2500 (0.285 m/s) and 3000 N/m (0.323 m/s)
(the thesis: from ≈ 3000 N/m), the speed peaking at ≈ 0.337 m/s near K = 5000–6000 N/m and then
decreasing slowly towards the rigid leg's (the thesis reports it still increasing up to 10 000
N/m). The ground's share of the dissipation is 0.0028–0.0053 J for 2500 ≤ K ≤ 30 000 N/m (16–31×
below the rigid leg's), rising with K as in the thesis (flat at 0.0051–0.0053 J between 4500 and
30 000 N/m, then 0.0104 J at 1e5 and 0.079 J at 1e7). As K → ∞ the gait approaches
compass_walker's, slowly: with α fixed the leg stays underdamped (ζ = 0.15, a bouncy heel
strike) until K exceeds the contact stiffness (1e6 N/m): speed +4.4 % at K = 1e5, +0.3 % at 1e7.

Numba compilation ≈ 40 s once (cached on disk); ≈ 0.16 s per step on a quiet machine.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from walker_library import analyze_gait, compass_walker, compliant_leg_walker, walk
from walker_library.analyses.dissipation import dissipation_breakdown
from walker_library.analyses.metrics import gait_metrics
from walker_library.analyses.poincare import find_fixed_point
from walker_library.analyses.standing import load_above_spring, stand, static_compression


@pytest.fixture(scope="module")
def walker():
    return compliant_leg_walker()


@pytest.fixture(scope="module")
def gait(walker):
    return analyze_gait(walker)


@pytest.fixture(scope="module")
def fixed(walker, gait):
    return np.array([gait.fixed_point[k] for k in walker.section])


@pytest.fixture(scope="module")
def rigid():
    """compass_walker (the same walker with rigid legs): its fixed point and one stride."""
    w = compass_walker()
    fp = find_fixed_point(w, w.initial_guess(), tol=w.gait_tolerance)
    assert fp.converged
    return w, fp.z, w.walk(fp.z, 1, details=True)


def test_stable_period_one_gait_at_defaults(walker, gait):
    assert walker.parameters["K_leg"] == 6000.0 and walker.parameters["alpha"] == 0.15
    assert gait.status == "periodic" and gait.period_steps == 1 and gait.stable
    mults = np.abs(np.array(gait.floquet_multipliers))
    # 0.319 with point-mass legs (compliant_leg_walker_point_legs), 0.306 with the legs' inertia
    # and the friction at the sole point (compliant_leg_walker_sole_friction), 0.309 with the
    # friction at the rolling contact point
    assert mults.max() == pytest.approx(0.309, abs=0.005) and gait.multiplier_errors[0] < 1e-3
    fp = gait.fixed_point
    assert fp["theta"] == pytest.approx(0.2494, abs=1e-3)          # sole point: 0.2491
    assert fp["theta_dot"] == pytest.approx(-0.8631, abs=1e-3)     # sole point: −0.8633
    # the trailing leg is compressed (≈ 4.7 mm) when the leading foot touches down: both feet
    # on the surface with legs of different lengths, (l + s_lead) cos θ = (l + s_trail) cos(φ − θ)
    # up to the trailing foot's contact penetration (F/K ≈ 29 µm)
    P = walker.parameters
    s_lead, s_trail = fp["walker.q.ankle1"], fp["walker.q.ankle2"]
    assert -5e-3 < s_trail < -4e-3 and 0 < s_lead < 2e-4
    assert fp["trail_contact_force"] == pytest.approx(28.5, abs=0.5)
    lead_h = (P["l"] + s_lead) * math.cos(fp["theta"])
    trail_h = (P["l"] + s_trail) * math.cos(fp["phi"] - fp["theta"])
    assert trail_h - lead_h == pytest.approx(fp["trail_contact_force"] / P["K"], abs=1e-8)
    m = gait.metrics
    assert m.speed == pytest.approx(0.3363, abs=1e-3)   # sole point 0.3356, point-mass legs 0.3370
    assert m.energy_dissipated_per_step == pytest.approx(m.potential_released_per_step, rel=1e-6)
    assert m.cost_of_transport == pytest.approx(math.sin(P["slope"]), rel=1e-5)


def test_energy_ledger_closes_over_20_steps(walker, fixed):
    res = walk(walker, fixed, 20)
    assert res.steps_taken == 20 and not res.fell
    assert res.max_energy_residual < 1e-7            # J (measured 3.4e-10)
    assert res.energy_dissipated == pytest.approx(res.potential_released, rel=1e-6)


def test_static_leg_compression_is_the_load_over_the_stiffness(walker):
    """Standing on leg 1 (level surface, legs along the normal, foot 2 hanging): the stance
    spring carries the hip, both legs and the hanging foot, (M + 2 m_leg + m_foot) g = 30.61 N,
    so it shortens by 30.61/6000 = 5.101 mm; the hanging foot stretches its spring by
    m_foot g / K; the contact carries everything, (M + 2 m_leg + 2 m_foot) g / K_contact."""
    P = walker.parameters
    traj = stand(walker, 3.0)
    assert traj.status == "finished"
    g, K = P["g"], P["K_leg"]
    load = (P["M"] + 2 * P["m_leg"] + P["m_foot"]) * g
    assert static_compression(walker) == pytest.approx(load * math.cos(P["slope"]) / K, rel=1e-15)
    assert traj["walker.q.ankle1"][-1] == pytest.approx(-load / K, rel=1e-6)   # level: cos 0
    assert traj["walker.q.ankle2"][-1] == pytest.approx(P["m_foot"] * g / K, rel=1e-6)
    assert traj["floor1.z"][-1] == pytest.approx(
        (P["M"] + 2 * P["m_leg"] + 2 * P["m_foot"]) * g / P["K"], rel=1e-6)
    assert traj.relative_residual < 1e-9
    # a preload F0 shifts the rest length to F0/K: F0 = the load keeps the stance leg at l
    preloaded = walker.with_parameters(preload=load_above_spring(walker))
    assert static_compression(preloaded) == pytest.approx(0.0, abs=1e-15)


def test_the_ground_takes_a_small_share_of_the_dissipation(walker, fixed, rigid):
    """The thesis (§3.1, Fig. 3.5): the energy dissipated by the impact is "around 10 times
    smaller" than the rigid leg's. Here the ground (contact + friction) takes 0.00525 J per step
    against compass_walker's 0.0876 J (16.7×; 0.00524 and 0.0874 J with the friction at the sole
    point); the leg dampers take the rest. The split's
    quadrature error (trapezoid on the integrator's steps) is below 1e-6 J."""
    mine = dissipation_breakdown(walker, fixed, 1)[0]
    w_rigid, z_rigid, _ = rigid
    theirs = dissipation_breakdown(w_rigid, z_rigid, 1)[0]
    for row in (mine, theirs):
        assert abs(row["quadrature_error"]) < 1e-5
        assert row["contact"] > 0 and row["friction"] > 0
    assert theirs["dampers"] == 0.0 and theirs["ground"] == pytest.approx(0.0876, abs=5e-4)
    assert mine["ground"] == pytest.approx(0.00525, abs=2e-4)
    assert mine["dampers"] == pytest.approx(mine["total"] - mine["ground"], abs=1e-5)
    assert theirs["ground"] / mine["ground"] > 10


def test_stiff_legs_approach_the_rigid_leg_walker(walker, gait, rigid):
    """As K_leg grows the gait approaches compass_walker's (rigid legs; same masses, contact and
    friction), slowly (measured with point-mass legs): the speed is 0.3370 m/s at 6000 N/m,
    0.3184 at 1e5 and 0.3060 at 1e7 against 0.3050 m/s. Asserted: at K = 1e7 speed and step length within 0.5 % of the rigid
    walker's (measured 0.33 %, 0.37 %), ten times closer than at K = 6000 (10.5 %, 13 %); the
    thesis's trend "faster than the rigid leg from K ≈ 3000 N/m" holds at the default 6000 N/m.
    Newton starts from the rigid walker's fixed point (the legs' extensions at their static
    values: swing foot m_foot g / K, trailing contact force as the rigid walker's)."""
    w_rigid, z_rigid, rigid_strides = rigid
    ref = gait_metrics(rigid_strides, w_rigid.weight)
    stiff = walker.with_parameters(K_leg=1e7)
    P = stiff.parameters
    trail_pen = w_rigid.output("floor2.z", w_rigid.lift(z_rigid))
    guess = np.concatenate([z_rigid, [P["m_foot"] * P["g"] / P["K_leg"], P["K"] * trail_pen, 0, 0]])
    fp = find_fixed_point(stiff, guess, tol=stiff.gait_tolerance)
    assert fp.converged
    m = gait_metrics(stiff.walk(fp.z, 1), stiff.weight)
    soft = gait.metrics
    assert m.speed == pytest.approx(ref.speed, rel=5e-3)
    assert m.step_length == pytest.approx(ref.step_length, rel=5e-3)
    assert abs(m.speed - ref.speed) < 0.1 * abs(soft.speed - ref.speed)
    assert soft.speed > ref.speed


def test_section_names_the_states(walker):
    """The section's coordinates are named by state, in the labelling where foot 1 leads; the
    trailing leg's extension is replaced by its foot's contact force (see the model file)."""
    assert walker.section == ("walker.q.leg1", "walker.q.leg2", "walker.v.hip_joint.x",
                              "walker.v.hip_joint.z", "walker.v.leg1", "walker.v.leg2",
                              "walker.q.ankle1", "trail_contact_force", "walker.v.ankle1",
                              "walker.v.ankle2")

"""The thesis's variable-stiffness walker (models/variable_stiffness_walker.toml; M. Jafarian 2010,
MSc report 022CE2010, University of Twente, §3.2, Eq. 3.3 and App. D): the compliant-leg walker whose stance
leg stiffens from K1 = 6000 N/m at mid-stance to K2 = 8000 N/m at |φ| = φ_max,
K = K1 + (K2 − K1)|φ|/φ_max, with D = 2·0.2·√(3.1 K) (Table 3.1's first variable row), γ = 0.009.

Measured here (C + Rodas5P, rtol 1e-9, atol 1e-11; legs as rods, I_leg = m_leg l²/12; the
friction at the rolling contact point): stable period-1 gait, θ = 0.24512, φ = 0.46845,
θ̇ = −0.88453, φ̇ = 0.00927 at touchdown; Floquet multipliers |λ| = 0.272 (a pair), the rest
< 5e-3; step period 1.0330 s, step length 0.3476 m, speed 0.3365 m/s; per step the stiffness
change supplies E_in = 0.0194 J and 0.1183 J is dissipated = the potential released 0.0988 J +
E_in (cost of transport 0.0108 > sin γ). With the friction at the sole point (before issue 14):
θ = 0.24486, |λ| = 0.269, speed 0.3358 m/s, E_in = 0.0195 J (net: +0.0205 J while the stance leg
stiffens, −0.0010 J when K drops back to K1 at its lift-off). The constant-K1 gait (K2 = K1,
same α) has peak |φ| = 0.4379 rad: the default φ_max (0.4374 with the sole point, 0.4370 with
point-mass legs too). The thesis (Table 3.1, most cells lost) found 6000 → 8000 N/m at
α = 0.2 "almost equivalent" to a constant 8000 N/m at α = 0.15; here the constant 8000 N/m
walker (compliant_leg_walker) walked at 0.3344 m/s, the variable one at 0.3358 m/s (0.4 %
apart; both with the sole point, REPRODUCTION.md's Table 3.1 has the current numbers).
"""
from __future__ import annotations

import numpy as np
import pytest

from walker_library import analyze_gait, variable_stiffness_walker, walk
from walker_library.analyses.standing import stand

#: φ_max of the file: the largest |φ| over a step of the constant-K1 gait (K2 = K1, α = 0.2)
PHI_MAX_K1 = 0.4379

#: the gait of variable_stiffness_walker(K2=6000) (constant K1), section coordinates, from
#: analyze_gait (rounded to 1e-10)
CONSTANT_K1_GAIT = [-0.2344257536, 0.2025394176, 0.5975208319, -0.1123134137, 0.8020273203,
                    0.8178599449, 0.0001455844, 28.9663869215, 3.53686e-05, 0.0020914937]


@pytest.fixture(scope="module")
def walker():
    return variable_stiffness_walker()


@pytest.fixture(scope="module")
def gait(walker):
    return analyze_gait(walker)


@pytest.fixture(scope="module")
def fixed(walker, gait):
    return np.array([gait.fixed_point[k] for k in walker.section])


def test_stable_period_one_gait_at_defaults(walker, gait):
    P = walker.parameters
    assert (P["K1"], P["K2"], P["alpha"], P["phi_max"]) == (6000.0, 8000.0, 0.2, PHI_MAX_K1)
    assert gait.status == "periodic" and gait.period_steps == 1 and gait.stable
    mults = np.abs(np.array(gait.floquet_multipliers))
    # friction at the sole point (before issue 14): 0.269, 0.2449, 0.3358
    assert mults.max() == pytest.approx(0.272, abs=0.005) and gait.multiplier_errors[0] < 1e-3
    assert gait.fixed_point["theta"] == pytest.approx(0.2451, abs=1e-3)
    assert gait.metrics.speed == pytest.approx(0.3365, abs=1e-3)


def test_energy_balance_books_the_stiffness_change_as_supplied(walker, fixed):
    """Per step: dissipated = potential released + supplied (the stiffness change injects
    ½ K̇ z² while the stance spring is compressed; the lift-off's drop of K to K1 with the spring
    slightly loaded is a small negative jump, booked as supplied too). Over 20 steps the ledger
    H − H(0) + E_diss − E_in stays below 1e-7 J (measured 1.6e-8 J, of an energy scale ≈ 30 J)."""
    res = walk(walker, fixed, 20)
    assert res.steps_taken == 20 and not res.fell
    assert res.max_energy_residual < 1e-7
    s = walker.walk(fixed, 1, record=True)[0]
    e_in = s.info["energy_supplied"]
    assert e_in == pytest.approx(0.0194, abs=1e-3)            # 0.0195 with the sole point
    assert s.energy_dissipated == pytest.approx(s.potential_released + e_in, abs=1e-7)
    traj = s.info["trajectory"]
    # the trailing leg lifts off with its spring still ≈ 1 mm compressed (its force balanced by
    # the damper and the light foot), so K's drop from ≈ 8100 to 6000 N/m releases ≈ 1 mJ
    # (measured −1.03e-3 J, 5 % of E_in), booked as (negative) supplied energy
    jumps = [j for _, name, j in traj.jumps if name == "liftoff2" and j != 0.0]
    assert len(jumps) == 1 and -0.1 * e_in < jumps[0] < 0.0


def test_stiffness_follows_the_rule(walker, fixed):
    """Leg 1 leads at the start (touchdown): K1 until mid-stance (the hip angle crosses zero),
    then K1 + (K2 − K1)|φ|/φ_max up to its lift-off; leg 2 (trailing) is stiff until its
    lift-off, then K1 in swing. The damper follows: D = 2 α √(3.1 K)."""
    P = walker.parameters
    traj = walker.walk(fixed, 1, record=True)[0].info["trajectory"]
    t = traj.t
    phi = traj["walker.q.leg1"] - traj["walker.q.leg2"]
    K1, K2 = traj["spring1.K"], traj["spring2.K"]
    t_mid = [tt for tt, name in traj.events if name == "midstance1"]
    t_off2 = next(tt for tt, name in traj.events if name == "liftoff2")
    assert len(t_mid) == 1
    before, after = t < t_mid[0], t > t_mid[0]
    assert np.all(K1[before] == P["K1"])
    expected = P["K1"] + (P["K2"] - P["K1"]) * np.abs(phi) / P["phi_max"]
    assert np.allclose(K1[after], expected[after], rtol=1e-12)
    # the stance leg reaches K2 where |φ| = φ_max, a little more at touchdown (this gait's
    # φ there, 0.4679, exceeds the constant-K1 gait's peak 0.4374)
    assert P["K2"] < np.max(K1) < 1.03 * P["K2"]
    assert np.all(K2[t > t_off2] == P["K1"]) and np.all(K2[t < t_off2] > P["K1"])
    assert np.allclose(traj["spring1.D"], 2 * P["alpha"] * np.sqrt((P["M"] + P["m_foot"]) * K1),
                       rtol=1e-12)


def test_phi_max_is_the_peak_phi_of_the_constant_k1_gait(walker):
    """φ_max (thesis Eq. 3.3): the peak φ of the gait with the fixed stiffness K1; measured as
    the largest |φ| over a step of this walker's gait with K2 = K1 (same α = 0.2): 0.43789 rad
    (0.43738 with the friction at the sole point, the default before issue 14).
    The stored fixed point is a fixed point to 1e-8 and its step's max |φ| rounds to the
    default."""
    constant = walker.with_parameters(K2=walker.parameters["K1"])
    z = np.array(CONSTANT_K1_GAIT)
    s = constant.walk(z, 1, details=True)[0]
    assert np.max(np.abs(s.z_next - z) / np.maximum(1.0, np.abs(z))) < 1e-8
    assert s.max_phi == pytest.approx(PHI_MAX_K1, abs=5e-5)
    assert s.info["energy_supplied"] == pytest.approx(0.0, abs=1e-12)


def test_static_leg_compression_with_k1(walker):
    """Standing (mid-stance flags off): the stance leg shortens by (M + 2 m_leg + m_foot) g / K1."""
    P = walker.parameters
    traj = stand(walker, 3.0)
    load = (P["M"] + 2 * P["m_leg"] + P["m_foot"]) * P["g"]
    assert traj["walker.q.ankle1"][-1] == pytest.approx(-load / P["K1"], rel=1e-6)
    assert traj["spring1.K"][-1] == P["K1"]

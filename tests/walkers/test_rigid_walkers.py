"""The rigid-impact walkers against their published and closed-form results.

Sources (each test names its numbers and tolerance):

* Garcia, Chatterjee, Ruina & Coleman (1998), "The simplest walking model: stability, complexity,
  and scaling", J. Biomech. Eng. 120(2):281–288 [GARCIA]. Table 1 at γ = 0.009: long-period gait
  θ* = 0.20031090049483, θ̇* = −0.19983247291764, eigenvalues −0.19120868949940 ± 0.55633363687106i;
  short-period gait θ* = 0.19393736960624, θ̇* = −0.20386692731962, eigenvalues 4.000, 0.459 (the
  digits as in the authors' published simulation code, "to 1e-10"). Abstract: "two period-one
  gait cycles, one of which is stable when 0 < γ < 0.015 rad", then period doubling.
  Their eigenvalues come from finite differences and are accurate to ~1e-3 only (Bhounsule 2014,
  "Numerical accuracy of two benchmark models of walking", DCDIS B 21:137); this file therefore
  also checks against an independent integration of Garcia's own equations of motion
  (θ̈ = sin(θ − γ), φ̈ = sin φ (θ̇² − cos(θ − γ)) + sin(θ − γ), their eq. 3) with scipy's
  DOP853 at rtol 1e-13 [REF], which reproduces GARCIA's fixed point to 1e-10.
* Goswami, Thuilot & Espiau (1998), "A study of the passive gait of a compass-like biped robot:
  symmetry and chaos", Int. J. Robot. Res. 17(12):1282–1301, and INRIA RR-2996 (1996) [GOSWAMI]:
  m = 5 kg, m_H = 10 kg, a = b = 0.5 m at φ = 3°: stable period-one gait with the legs at
  θ_ns = −0.3234 rad, θ_s = 0.2187 rad from the vertical at heel strike (half inter-leg angle
  0.271 rad), θ̇_ns = −0.3772, θ̇_s = −1.0918 rad/s (as quoted from the paper in secondary
  sources), step period 0.735 s.
* Rimless wheel (McGeer 1990, "Passive dynamic walking", IJRR 9(2):62–82; Coleman, Chatterjee &
  Ruina 1997, Dyn. Stab. Syst. 12(3):139): impact ω⁺ = cos 2α ω⁻, energy over a step
  ω⁻² = ω⁺² + 4 (g/l) sin α sin γ, hence the steady rate ω*² = 4 (g/l) sin α sin γ cos²2α /
  (1 − cos²2α), the multiplier cos²2α, and the step period ∫ dθ / ω(θ) over the stance.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

from walker_library import (
    Walker,
    analyze_gait,
    compass_gait,
    find_fixed_point,
    floquet,
    rimless_wheel,
    simplest_walker,
    walk,
)

GAMMA = 0.009
LONG = (0.20031090049483, -0.19983247291764)          # GARCIA, long-period gait
LONG_EIG = complex(-0.19120868949940, 0.55633363687106)
SHORT = (0.19393736960624, -0.20386692731962)         # GARCIA, short-period gait
SHORT_EIG = (4.000, 0.459)


# --- [REF]: Garcia's equations of motion integrated independently ---------------------------------
def _ref_rhs(t, y, gamma):
    th, thd, ph, phd = y
    return [thd, math.sin(th - gamma), phd,
            math.sin(th - gamma) + math.sin(ph) * (thd**2 - math.cos(th - gamma))]


def ref_stride(z, gamma=GAMMA):
    """(θ, θ̇) just after heel strike -> (next (θ, θ̇), step period), Garcia's β = 0 equations and
    heel-strike law (θ̇⁺ = cos 2θ θ̇⁻, φ̇⁺ = cos 2θ (1 − cos 2θ) θ̇⁻), heel strike at φ − 2θ = 0
    crossing upwards after mid-stance (the start of the step is skipped)."""
    th, thd = z
    y0 = [th, thd, 2 * th, thd * (1 - math.cos(2 * th))]
    opts = {"method": "DOP853", "rtol": 1e-13, "atol": 1e-14}
    a = solve_ivp(_ref_rhs, [0, 1.0], y0, args=(gamma,), **opts)

    def strike(t, y, gamma):
        return y[2] - 2 * y[0]
    strike.terminal, strike.direction = True, 1
    b = solve_ivp(_ref_rhs, [1.0, 20.0], a.y[:, -1], args=(gamma,), events=strike, **opts)
    th, thd = b.y_events[0][0][:2]
    return np.array([-th, math.cos(2 * th) * thd]), float(b.t_events[0][0])


def ref_fixed_point(guess, gamma=GAMMA):
    z = np.array(guess, dtype=float)
    for _ in range(8):
        f = ref_stride(z, gamma)[0] - z
        J = np.column_stack([(ref_stride(z + e, gamma)[0] - ref_stride(z - e, gamma)[0]) / 2e-6
                             for e in np.eye(2) * 1e-6])
        z = z - np.linalg.solve(J - np.eye(2), f)
    return z, ref_stride(z, gamma)[1], np.linalg.eigvals(J)


@pytest.fixture(scope="module")
def simplest():
    return simplest_walker()


@pytest.fixture(scope="module")
def simplest_gait(simplest):
    return analyze_gait(simplest)


@pytest.fixture(scope="module")
def reference_long():
    return ref_fixed_point(LONG)


def test_walkers_implement_the_walker_protocol(simplest):
    for w in (simplest, compass_gait(), rimless_wheel()):
        assert isinstance(w, Walker)
        assert len(w.initial_guess()) == len(w.section)


# --- the simplest walker ---------------------------------------------------------------------------
def test_simplest_walker_long_period_fixed_point_matches_garcia_1998(simplest_gait, reference_long):
    """GARCIA Table 1, γ = 0.009: θ* = 0.20031090049483 and θ̇* = −0.19983247291764 to 1e-9 (the
    published digits are 'to 1e-10'; measured difference 1.3e-10); φ* = 2θ*;
    φ̇* = (1 − cos 2θ*) θ̇* (GARCIA's heel-strike law, β -> 0) to 1e-9; a stable period-1 gait."""
    r = simplest_gait
    assert r.status == "periodic" and r.period_steps == 1 and r.stable
    fp = r.fixed_point
    assert fp["theta"] == pytest.approx(LONG[0], abs=1e-9)
    assert fp["theta_dot"] == pytest.approx(LONG[1], abs=1e-9)
    assert fp["phi"] == pytest.approx(2 * fp["theta"], abs=1e-14)
    assert fp["phi_dot"] == pytest.approx((1 - math.cos(2 * LONG[0])) * LONG[1], abs=1e-9)
    z_ref, _, _ = reference_long
    assert fp["theta"] == pytest.approx(z_ref[0], abs=1e-9)
    assert fp["theta_dot"] == pytest.approx(z_ref[1], abs=1e-9)


def test_simplest_walker_step_period_and_multipliers(simplest_gait, reference_long):
    """Step period: REF 3.8824637529 (nondimensional, units of √(l/g)) to 1e-8 (measured
    3.8824637524). Floquet multipliers: the complex pair matches GARCIA's −0.1912 ± 0.5563i to
    2e-3 (the accuracy of their finite differences) and REF's (central differences, h = 1e-6)
    −0.1900998 ± 0.5575988i to 1e-6; the third multiplier (the φ̇ direction, which the β -> 0
    heel strike erases) vanishes (< 1e-6); the estimated error is below 1e-4."""
    r = simplest_gait
    _, T_ref, eig_ref = reference_long
    assert r.metrics.step_period == pytest.approx(T_ref, abs=1e-8)
    pair = [m for m in r.floquet_multipliers if abs(m.imag) > 1e-3]
    assert len(pair) == 2
    top = max(pair, key=lambda m: m.imag)
    assert abs(top - LONG_EIG) < 2e-3
    ref_top = max(eig_ref, key=lambda m: m.imag)
    assert abs(top - ref_top) < 1e-6
    small = [m for m in r.floquet_multipliers if abs(m.imag) <= 1e-3]
    assert len(small) == 1 and abs(small[0]) < 1e-6
    assert r.multiplier_error < 1e-4
    assert max(abs(m) for m in r.floquet_multipliers) == pytest.approx(0.58911, abs=1e-5)


def test_foot_mass_ratio_effect_is_below_1e_7(simplest, simplest_gait):
    """Garcia's numbers are the limit β = m/M -> 0: the default β = 1e-9 and β = 1e-10 give fixed
    point, step period and multipliers that differ by less than 1e-7 (measured ≤ 1e-8)."""
    other = analyze_gait(simplest.with_parameters(beta=1e-10))
    a, b = simplest_gait, other
    for key in ("theta", "theta_dot", "phi", "phi_dot"):
        assert abs(a.fixed_point[key] - b.fixed_point[key]) < 1e-7, key
    assert abs(a.metrics.step_period - b.metrics.step_period) < 1e-7
    ma = sorted(a.floquet_multipliers, key=lambda m: (m.real, m.imag))
    mb = sorted(b.floquet_multipliers, key=lambda m: (m.real, m.imag))
    assert max(abs(x - y) for x, y in zip(ma, mb)) < 1e-7


def test_simplest_walker_short_period_gait_is_unstable(simplest):
    """GARCIA Table 1, γ = 0.009, short-period gait: θ* = 0.19393736960624, θ̇* = −0.20386692731962
    (to 1e-9), eigenvalues 4.000 and 0.459 (relative 2e-3; measured 4.0039, 0.45959): unstable.
    Found by Newton from a rough guess; step period against REF (3.0961058681) to 1e-8."""
    fp = find_fixed_point(simplest, simplest.from_thesis([-0.205, 2 * 0.193, -0.015]))
    assert fp.converged
    s = simplest.section_state(fp.z)
    assert s["theta"] == pytest.approx(SHORT[0], abs=1e-9)
    assert s["theta_dot"] == pytest.approx(SHORT[1], abs=1e-9)
    fl = floquet(simplest, fp.z)
    assert not fl.stable
    real = sorted((m.real for m in fl.multipliers), reverse=True)
    assert real[0] == pytest.approx(SHORT_EIG[0], rel=2e-3)
    assert real[1] == pytest.approx(SHORT_EIG[1], rel=2e-3)
    assert abs(real[2]) < 1e-6
    _z_ref, T_ref, _ = ref_fixed_point(SHORT)
    assert simplest.stride(fp.z).duration == pytest.approx(T_ref, abs=1e-8)


def test_long_period_gait_period_doubles_near_0_0151(simplest, simplest_gait):
    """GARCIA (abstract): the long-period gait is stable for 0 < γ < 0.015 rad and the motion goes
    to chaos through period doublings. Continuing the fixed point in γ, the real multiplier
    crosses −1 (flip bifurcation) at γ_pd = 0.01509 (measured; |γ_pd − 0.0151| < 2e-4); just above,
    at γ = 0.0155, the walker settles into a stable period-2 gait found by iterating the map."""
    z = np.array([simplest_gait.fixed_point[k] for k in simplest.section])

    def leading_real(gamma, guess):
        w = simplest.with_parameters(slope=gamma)
        fp = find_fixed_point(w, guess)
        assert fp.converged
        fl = floquet(w, fp.z)
        return min(m.real for m in fl.multipliers if abs(m.imag) < 1e-9), fp.z

    for gamma in (0.011, 0.013, 0.014):             # continuation along the branch
        _, z = leading_real(gamma, z)
    lo, z_lo = leading_real(0.0150, z)
    hi, z_hi = leading_real(0.0151, z_lo)
    assert lo > -1 > hi
    gamma_pd = 0.0150 + 0.0001 * (lo + 1) / (lo - hi)
    assert abs(gamma_pd - 0.0151) < 2e-4
    at, _ = leading_real(gamma_pd, z_lo)
    assert at == pytest.approx(-1.0, abs=2e-3)
    w2 = simplest.with_parameters(slope=0.0155)
    r = analyze_gait(w2, z_hi, n_iterate=150)
    assert r.status == "periodic" and r.period_steps == 2 and r.stable, r.message
    assert r.unstable_fixed_point is not None        # the period-1 orbit still exists, unstable
    assert len(r.fixed_points) == 2
    assert abs(r.fixed_points[0]["theta"] - r.fixed_points[1]["theta"]) > 1e-3


# --- energy balance --------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def gaits(simplest_gait):
    return {"simplest_walker": (simplest_walker(), simplest_gait),
            "compass_gait": (compass_gait(), None), "rimless_wheel": (rimless_wheel(), None)}


def _gait(gaits, name):
    w, r = gaits[name]
    if r is None:
        r = analyze_gait(w)
        gaits[name] = (w, r)
    return w, r


@pytest.mark.parametrize("name", ["simplest_walker", "compass_gait", "rimless_wheel"])
def test_energy_lost_per_step_equals_potential_energy_released(gaits, name):
    """On the periodic gait the ledger's energy dissipated per step (the impact loss, booked by
    the Reset) equals the potential energy released by the descent, m_total g d sin γ for a step of
    length d along the slope (relative 1e-8), the ledger residual over the step is < 1e-12 of the
    energy scale, and the specific cost of transport is sin γ (relative 1e-8)."""
    w, r = _gait(gaits, name)
    m = r.metrics
    assert r.status == "periodic"
    released = w.total_mass * w.parameters["g"] * m.step_length * math.sin(w.parameters["slope"])
    assert m.energy_dissipated_per_step == pytest.approx(released, rel=1e-8)
    assert m.potential_released_per_step == pytest.approx(released, rel=1e-8)
    assert m.cost_of_transport == pytest.approx(math.sin(w.parameters["slope"]), rel=1e-8)
    assert m.energy_residual_per_step < 1e-12 * max(1.0, w.weight * w.leg_length)
    assert m.speed == pytest.approx(m.step_length / m.step_period, rel=1e-14)


@pytest.mark.parametrize("name", ["simplest_walker", "compass_gait", "rimless_wheel"])
def test_energy_residual_over_20_steps(gaits, name):
    """20 steps in one simulation from the fixed point (one energy ledger across all impacts):
    max |H − H(0) + E_diss − E_in| below 1e-10 of the energy scale, no fall, and the dissipated
    energy equals the potential energy released over the walk (relative 1e-8)."""
    w, r = _gait(gaits, name)
    z = np.array([r.fixed_point[k] for k in w.section])
    result = walk(w, z, 20)
    assert result.steps_taken == 20 and not result.fell
    assert result.relative_energy_residual < 1e-10
    assert result.energy_dissipated == pytest.approx(result.potential_released, rel=1e-8)


# --- the compass gait ---------------------------------------------------------------------------------
def test_compass_gait_matches_goswami_1998(gaits):
    """GOSWAMI, φ = 3°: stable period-1 gait; at heel strike the legs at θ_s = θ* − γ = 0.2187 and
    θ_ns = −θ* − γ = −0.3234 rad from the vertical (±1e-4, the published 4 digits; measured
    0.21867, −0.32339), half inter-leg angle 0.271 (±5e-4; measured 0.27103); just after it
    θ̇_s = −1.0918 and θ̇_ns = −0.3772 rad/s (±1e-3; measured −1.09238, −0.37737); step period
    0.735 s (±2e-3; measured 0.73435 s)."""
    w, r = _gait(gaits, "compass_gait")
    assert r.status == "periodic" and r.period_steps == 1 and r.stable
    gamma = w.parameters["slope"]
    fp = r.fixed_point
    assert fp["theta"] - gamma == pytest.approx(0.2187, abs=1e-4)
    assert -fp["theta"] - gamma == pytest.approx(-0.3234, abs=1e-4)
    assert fp["theta"] == pytest.approx(0.271, abs=5e-4)
    assert fp["theta_dot"] == pytest.approx(-1.0918, abs=1e-3)
    assert fp["theta_dot"] - fp["phi_dot"] == pytest.approx(-0.3772, abs=1e-3)   # swing leg
    assert r.metrics.step_period == pytest.approx(0.735, abs=2e-3)
    assert max(abs(m) for m in r.floquet_multipliers) < 1


# --- the rimless wheel ---------------------------------------------------------------------------------
def test_rimless_wheel_matches_closed_form(gaits):
    """Rimless wheel (m = 1 kg, l = 1 m, 8 spokes, γ = 0.08): the steady rate just after impact
    ω* = √(4 (g/l) sin α sin γ cos²2α / (1 − cos²2α)) (relative 1e-8), its single multiplier
    cos²2α = 0.5 (±1e-7), the step period ∫_{−α}^{α} dθ/√(ω*² + 2(g/l)(cos(γ−α) − cos(θ+γ)))
    (relative 1e-8), the steady speed 2 l sin α / T, and the energy per step
    m g 2 l sin α sin γ (relative 1e-8)."""
    w, r = _gait(gaits, "rimless_wheel")
    g, l, gamma = w.parameters["g"], w.parameters["l"], w.parameters["slope"]
    alpha = math.pi / w.parameters["n_spokes"]
    c2 = math.cos(2 * alpha) ** 2
    omega = math.sqrt(4 * g / l * math.sin(alpha) * math.sin(gamma) * c2 / (1 - c2))
    assert r.status == "periodic" and r.stable
    assert r.fixed_point["walker.v.stance"] == pytest.approx(omega, rel=1e-8)
    (mult,) = r.floquet_multipliers
    assert mult.real == pytest.approx(c2, abs=1e-7) and mult.imag == 0
    T, _ = quad(lambda th: 1 / math.sqrt(omega**2 + 2 * g / l * (math.cos(gamma - alpha)
                                                                 - math.cos(th + gamma))),
                -alpha, alpha, epsabs=1e-13, epsrel=1e-13)
    assert r.metrics.step_period == pytest.approx(T, rel=1e-8)
    assert r.metrics.speed == pytest.approx(2 * l * math.sin(alpha) / T, rel=1e-8)
    assert r.metrics.energy_dissipated_per_step == pytest.approx(
        w.parameters["m"] * g * 2 * l * math.sin(alpha) * math.sin(gamma), rel=1e-8)


def test_rimless_wheel_below_its_critical_slope_stops():
    """Below the slope where ω*²/2 = (g/l)(1 − cos(α − γ)) (≈ 0.0676 rad for 8 spokes) the steady
    rolling solution cannot pass over the top: the wheel, started at the rate it would need at
    0.08 rad, rolls back (a fall result at the first step, reason "rolled_back")."""
    alpha = math.pi / 8
    crit = brentq(lambda gm: 2 * math.sin(alpha) * math.sin(gm) - (1 - math.cos(alpha - gm)), 0.01, 0.2)
    assert 0.06 < crit < 0.075
    w = rimless_wheel(slope=0.05)
    r = analyze_gait(w, n_iterate=20)
    assert r.status == "fell" and r.fell_at_step is not None
    assert r.fall_reason == "rolled_back"


# --- the guards are written on the multibody's outputs -------------------------------------------
@pytest.mark.parametrize("builder,guard_points", [
    (simplest_walker, {"heel_strike": "walker.swing_foot.z"}),
    (compass_gait, {"heel_strike": "walker.swing_foot.z"}),
    (rimless_wheel, {"heel_strike": "walker.next_tip.z", "rolled_back": "walker.prev_tip.z"})])
def test_guards_equal_the_multibody_point_heights(builder, guard_points):
    """The compiled event guards (written in the files on the multibody's point outputs) equal
    those outputs: the striking point's height above ground_z plus contact_margin (and the hip
    height above the stance foot minus fall_fraction·l for the legged walkers), to 1e-14, at
    random states and modes."""
    w = builder()
    m = w.model
    rng = np.random.default_rng(7)
    names = [e.name for e in m.events]
    for _ in range(20):
        x = rng.uniform(-1.5, 1.5, m.n_states)
        p = m.params({**w.parameters, "stance_x": rng.uniform(-3, 3),
                      "stance_z": rng.uniform(-0.1, 0.1), "ground_z": rng.uniform(-0.1, 0.1),
                      "contact_margin": rng.uniform(0, 1e-3)})
        g = np.asarray(m.functions.guards(0.0, m.augment(x), m.native_params(p)))
        out = w.outputs(0.0, x, p)
        P = dict(zip(m.param_names, p))
        for event, point in guard_points.items():
            expected = out[w.model.output_index(point)] - P["ground_z"] + P["contact_margin"]
            assert g[names.index(event)] == pytest.approx(expected, abs=1e-14)
        if "fall" in names:
            expected = out[w.model.output_index("walker.hip_centre.z")] - P["stance_z"] - P["fall_fraction"] * w.leg_length
            assert g[names.index("fall")] == pytest.approx(expected, abs=1e-14)


def test_a_grazing_heel_strike_is_found_by_scipys_dop853_too():
    """The simplest walker at γ = 0.01512 from its fixed point with θ̇ lowered by 0.01: the swing
    foot grazes the surface near t = 5.03 s, crossing it and back within one of DOP853's steps
    (up to max_step 0.25 s). The guards sampled inside scipy's steps see the heel strike where
    the compiled Rodas5P loop does, to 1e-9 s, at every max_step (before, DOP853 missed it at
    max_step 0.25 and 0.05 and the stride fell at 8.85 s)."""
    from walker_library.analyses.poincare import find_fixed_point

    w = simplest_walker().with_parameters(slope=0.01512)
    z = find_fixed_point(w, w.from_thesis([-0.2319, 2 * 0.2369, -0.0256])).z.copy()
    z[1] -= 1e-2
    compiled = w.with_options(method="Rodas5P").stride(z)
    assert not compiled.fell and compiled.duration == pytest.approx(5.0326559, abs=1e-6)
    for max_step in (0.25, 0.05):
        scipy_run = w.with_options(method="DOP853", max_step=max_step).stride(z)
        assert not scipy_run.fell
        assert scipy_run.duration == pytest.approx(compiled.duration, abs=1e-9)

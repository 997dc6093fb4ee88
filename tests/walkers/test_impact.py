"""The generic rigid plastic impact map (porthamiltonian/mechanics/impact.py).

References: the plastic impact of a constrained multibody, M (v⁺ − v⁻) = Gᵀ Λ, G v⁺ = 0
(e.g. Brogliato, *Nonsmooth Mechanics*, 3rd ed., 2016, §4; Kelvin's theorem: the kinetic energy
lost equals the kinetic energy of the velocity jump, ½ (v⁻ − v⁺)ᵀ M (v⁻ − v⁺) ≥ 0). Walker
impacts: angular momentum about the impact point is conserved for the whole walker, and about the
hip for the trailing leg (Goswami et al. 1998, IJRR 17(12), §2.2; Garcia et al. 1998, J. Biomech.
Eng. 120:281, eq. 4); for Garcia's point feet (β -> 0) θ̇⁺ = cos 2θ · θ̇⁻ and
φ̇⁺ = cos 2θ (1 − cos 2θ) θ̇⁻; for a rimless wheel ω⁺ = (r² + l² cos 2α)/(r² + l²) ω⁻ (McGeer 1990,
IJRR 9(2), eq. for the rimless wheel; Coleman et al. 1997).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from porthamiltonian.errors import ModelError, StateError
from porthamiltonian.simulation.impact import model_impact, plastic_impact
from walker_library import compass_gait, rimless_wheel, simplest_walker


@pytest.fixture(scope="module")
def compass():
    return compass_gait()


def _random_problem(seed: int, n: int, k: int):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    M = A @ A.T + n * np.eye(n) * rng.uniform(0.01, 1.0)
    G = rng.normal(size=(k, n))
    v = rng.normal(size=n)
    return M, G, v


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 7), k=st.integers(1, 2))
def test_plastic_impact_properties_on_random_systems(seed, n, k):
    """For random positive definite M and constraints G: G v⁺ = 0 (1e-12 of |v|), kinetic energy
    never increases, the loss equals ½ Δvᵀ M Δv (Kelvin), p⁺ − p⁻ = Gᵀ Λ, and the KKT and the
    Schur-complement forms agree to 1e-10."""
    M, G, v = _random_problem(seed, n, k)
    r = plastic_impact(M, G, v)
    scale = np.max(np.abs(v)) * max(1.0, np.max(np.abs(G)))
    assert np.max(np.abs(G @ r.v_plus)) <= 1e-12 * scale
    assert r.T_plus <= r.T_minus * (1 + 1e-12)
    assert r.energy_lost >= 0
    assert r.energy_lost == pytest.approx(r.T_minus - r.T_plus, rel=1e-9, abs=1e-12 * r.T_minus)
    np.testing.assert_allclose(r.p_plus - M @ v, G.T @ r.impulse, atol=1e-10 * np.max(np.abs(M @ v)))
    s = plastic_impact(M, G, v, method="schur")
    np.testing.assert_allclose(s.v_plus, r.v_plus, atol=1e-10 * np.max(np.abs(v)))


def test_plastic_impact_with_singular_mass_matrix_uses_the_null_space():
    """A point mass m on a massless rotating spoke of length l (M = diag(m, m, 0) in (x, z, ψ)),
    the spoke tip stopped: the hub keeps only its velocity component normal to the spoke, and the
    spoke's rate follows; the Schur form refuses (M not invertible)."""
    m, l, psi = 2.0, 1.0, 0.3
    M = np.diag([m, m, 0.0])
    G = np.array([[1.0, 0.0, -l * math.cos(psi)], [0.0, 1.0, l * math.sin(psi)]])
    v = np.array([1.0, -0.5, 0.0])
    r = plastic_impact(M, G, v)
    u = np.array([math.sin(psi), math.cos(psi)])          # spoke direction (tip -> hub)
    n = np.array([math.cos(psi), -math.sin(psi)])
    np.testing.assert_allclose(r.v_plus[:2], (v[:2] @ n) * n, atol=1e-14)
    assert r.v_plus[2] == pytest.approx(v[:2] @ n / l, abs=1e-14)
    assert r.energy_lost == pytest.approx(0.5 * m * (v[:2] @ u) ** 2, rel=1e-12)
    with pytest.raises(StateError, match="kkt"):
        plastic_impact(M, G, v, method="schur")
    with pytest.raises(ModelError, match="method"):
        plastic_impact(M, G, v, method="inverse")


def _pre_impact(walker):
    """A swing-model state just before a heel strike, from one simulated stride."""
    stride = walker.stride(walker.initial_guess())
    assert stride.status == "step"
    return stride.info["x_minus"].copy(), stride.info["p_minus"].copy()


def _heel_strike(walker):
    """The walker's heel-strike transition (the rule with an impact)."""
    return next(tr for tr in walker.machine.transitions if tr.impact is not None)


def _floating_before(walker, x, p):
    """The floating model's state (with momenta), joint rates and parameters at swing state x:
    coordinates (hip x, hip z, stance-leg angle, swing-leg angle), the legs' angles absolute."""
    imp = _heel_strike(walker).impact
    xf, vf, pf = imp.floating_state(0.0, x, p)
    return _with_momenta(imp.floating, xf, vf, pf), vf, pf


def _with_momenta(floating, xf, vf, pf):
    xf = xf.copy()
    ip = [i for i, s in enumerate(floating.state_names) if s.startswith("walker.p.")]
    xf[ip] = floating.matrix("walker.M", 0.0, xf, pf) @ vf
    return xf


def _angular_momenta(P, xf, vf):
    """Compass gait (point masses): angular momentum (y component, slope frame) of the whole
    walker about the striking (swing) foot and of the trailing (stance) leg about the hip, from
    the geometry alone; ``xf`` = (hip x, hip z, stance-leg angle, swing-leg angle), the legs'
    angles absolute."""
    hip = np.array([xf[0], xf[1]])
    vh = vf[:2]
    b, l = P["b"], P["a"] + P["b"]

    def cross(r, v):          # y component of r x v for r, v in the (x, z) plane
        return r[1] * v[0] - r[0] * v[1]

    def leg(psi, dpsi):
        r = hip - b * np.array([math.sin(psi), math.cos(psi)])
        return r, vh - b * dpsi * np.array([math.cos(psi), -math.sin(psi)])

    foot2 = hip - l * np.array([math.sin(xf[3]), math.cos(xf[3])])
    r1, v1 = leg(xf[2], vf[2])
    r2, v2 = leg(xf[3], vf[3])
    L_total = (P["m_H"] * cross(hip - foot2, vh) + P["m"] * cross(r1 - foot2, v1)
               + P["m"] * cross(r2 - foot2, v2))
    L_trailing = P["m"] * cross(r1 - hip, v1)
    return L_total, L_trailing


def test_compass_gait_heel_strike_conserves_angular_momentum(compass):
    """At a simulated heel strike of the compass gait: angular momentum about the impact point
    (whole walker) and of the trailing leg about the hip are conserved to 1e-12 (relative), the
    new stance foot stops (|v| < 1e-13 m/s), and the kinetic energy decreases."""
    x, p = _pre_impact(compass)
    xf, vf, pf = _floating_before(compass, x, p)
    floating = _heel_strike(compass).impact.floating
    imp = model_impact(floating, xf, pf, ["walker.J.swing_foot"], v_minus=vf)
    from_momenta = model_impact(floating, xf, pf, ["walker.J.swing_foot"])
    np.testing.assert_allclose(from_momenta.impact.v_plus, imp.impact.v_plus, rtol=1e-12, atol=1e-14)
    before = _angular_momenta(compass.parameters, xf, vf)
    after = _angular_momenta(compass.parameters, xf, imp.impact.v_plus)
    assert after[0] == pytest.approx(before[0], rel=1e-12)
    assert after[1] == pytest.approx(before[1], rel=1e-12)
    foot2 = floating.matrix("walker.J.swing_foot", 0.0, imp.x_plus, pf) @ imp.impact.v_plus
    assert np.max(np.abs(foot2)) < 1e-13
    assert 0 < imp.impact.energy_lost < imp.impact.T_minus


@settings(max_examples=25, deadline=None)
@given(psi1=st.floats(-0.6, 0.6), spread=st.floats(0.1, 0.9), w1=st.floats(-3, 3),
       w2=st.floats(-3, 3), vx=st.floats(-2, 2), vz=st.floats(-2, 2))
def test_angular_momentum_conserved_for_random_compass_impacts(compass, psi1, spread, w1, w2, vx, vz):
    """Any pre-impact state of the compass gait's floating model (random leg angles and rates,
    hip velocity): both angular momenta conserved to 1e-10 of their scale, G v⁺ = 0, ΔT ≥ 0."""
    P = compass.parameters
    floating = _heel_strike(compass).impact.floating
    pf = floating.params({k: v for k, v in P.items() if k in floating.param_names})
    xf = np.zeros(floating.n_states)
    for name, value in (("pin.x", 0.3), ("pin.z", 0.9), ("stance", psi1), ("hip", psi1 - spread)):
        xf[floating.state_index(f"walker.q.{name}")] = value
    vf = np.array([vx, vz, w1, w2])
    xf = _with_momenta(floating, xf, vf, pf)
    imp = model_impact(floating, xf, pf, ["walker.J.swing_foot"], v_minus=vf)
    before = _angular_momenta(P, xf, vf)
    after = _angular_momenta(P, xf, imp.impact.v_plus)
    scale = (P["m_H"] + 2 * P["m"]) * (P["a"] + P["b"]) * (abs(vx) + abs(vz) + abs(w1) + abs(w2) + 1)
    assert abs(after[0] - before[0]) < 1e-10 * scale
    assert abs(after[1] - before[1]) < 1e-10 * scale
    assert np.max(np.abs(imp.impact.constraint_velocity)) < 1e-12 * scale
    assert imp.impact.energy_lost >= -1e-12 * scale**2


def test_simplest_walker_impact_matches_garcia_limit_law():
    """Garcia et al. (1998) eq. 4 (β -> 0): θ̇⁺ = cos 2θ θ̇⁻, φ̇⁺ = cos 2θ (1 − cos 2θ) θ̇⁻, θ⁺ = −θ⁻,
    φ⁺ = −2θ⁻; the framework's map with β = 1e-9 agrees to 1e-8 (β's own effect is O(β); the
    angles to 1e-9: the strike happens at the guard's 1e-10 margin below the surface)."""
    w = simplest_walker()
    x, p = _pre_impact(w)
    theta, theta_dot = -x[list(w.compiled.coordinates)][0], -w.velocities(x, p)[0]
    x_new, p_new, info = _heel_strike(w).apply(0.0, x, p, w.outputs(0.0, x, p))
    z = w.project(x_new, p_new)
    s = w.section_state(z)
    c = math.cos(2 * theta)
    assert s["theta"] == pytest.approx(-theta, abs=1e-9)
    assert s["phi"] == pytest.approx(-2 * theta, abs=2e-9)
    assert s["theta_dot"] == pytest.approx(c * theta_dot, abs=1e-8)
    assert s["phi_dot"] == pytest.approx(c * (1 - c) * theta_dot, abs=1e-8)
    assert info["impact_energy_lost"] > 0


@pytest.mark.parametrize("r_gyr", [0.0, 0.4])
def test_rimless_wheel_impact_matches_mcgeer(r_gyr):
    """Rimless wheel: ω⁺/ω⁻ = (r² + l² cos 2α)/(r² + l²) (angular momentum about the new contact
    point; McGeer 1990), to 1e-12, for a point hub (r = 0: cos 2α) and r_gyr = 0.4 m."""
    w = rimless_wheel(r_gyr=r_gyr)
    x, p = _pre_impact(w)
    omega = w.velocities(x, p)[0]
    x_new, p_new, info = _heel_strike(w).apply(0.0, x, p, w.outputs(0.0, x, p))
    omega_plus = w.velocities(x_new, p_new)[0]
    alpha, l = math.pi / 8, 1.0
    ratio = (r_gyr**2 + l**2 * math.cos(2 * alpha)) / (r_gyr**2 + l**2)
    assert omega_plus == pytest.approx(ratio * omega, rel=1e-12)
    assert info["trailing_foot_normal_velocity"] > 0   # the rear spoke lifts off


def _extrapolated(fun, x, h=1e-3):
    """∂fun/∂x by central differences Richardson-extrapolated twice (error O(h⁶); steps h, 2h
    and 4h relative to max(|x_j|, 1)): the reference for the impact's tangents."""
    cols = []
    for j in range(len(x)):
        e = np.zeros(len(x))
        e[j] = h * max(abs(x[j]), 1.0)

        def central(s, e=e):
            return (fun(x + s * e) - fun(x - s * e)) / (2 * s * e[e != 0][0])

        d1, d2, d4 = central(1), central(2), central(4)
        r1, r2 = (4 * d1 - d2) / 3, (4 * d2 - d4) / 3
        cols.append((16 * r1 - r2) / 15)
    return np.stack(cols, axis=1)


@pytest.mark.parametrize("name", ["compass_gait", "simplest_walker", "rimless_wheel"])
def test_impact_tangents_against_extrapolated_differences(name, compass):
    """The heel strike's derivative by the state and by every parameter it reads (masses,
    lengths, slope, the old and new stance foot's position): ImpactMap.tangents (the linear
    solves differentiated exactly, the matrices by fourth-order differences) against central
    differences of the whole map x⁺(x⁻, p) Richardson-extrapolated to O(h⁶) (their own spread
    between h = 1e-3 and 5e-4: ≤ 1e-12), to 1e-10 of the largest entry (measured 4e-14 to
    5e-13); its own error estimate below 1e-10. Rimless wheel: ∂ω⁺/∂ω⁻ is McGeer's ratio."""
    w = compass if name == "compass_gait" else (simplest_walker() if name == "simplest_walker"
                                                  else rimless_wheel())
    x, p = _pre_impact(w)
    tr = _heel_strike(w)
    m = w.model
    names = [n for n in w.parameters if n in m.param_names and n not in w.mode_names]
    out, error = w.machine._derivatives(tr, 0.0, x, p, names)
    cols = sorted({m.param_names.index(n) for n in names} | {
        i for i in range(len(p)) if m.param_names[i] in out.get("params_jacobian", {})})
    exact = np.hstack([out["jacobian"],
                       np.stack([out["jacobian_p"][m.param_names[i]] for i in cols], axis=1)])

    def composite(v):
        q = p.copy()
        q[cols] = v[len(x):]
        return tr.apply(0.0, v[:len(x)], q, m.outputs(0.0, v[:len(x)], q))[0]

    ref = _extrapolated(composite, np.concatenate([x, p[cols]]))
    assert np.max(np.abs(exact - ref)) < 1e-10 * np.max(np.abs(ref))
    assert error < 1e-10
    if name == "rimless_wheel":
        alpha = math.pi / 8
        omega = next(i for i, s in enumerate(m.state_names) if s.startswith(f"{w.multibody}.p."))
        assert out["jacobian"][omega, omega] == pytest.approx(math.cos(2 * alpha), rel=1e-12)

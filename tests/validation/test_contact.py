"""Validation of the contact, friction and spring library (porthamiltonian.library) against closed
forms and independent computations. Each test names its reference and tolerance.

Models: models/bouncing_ball.toml, models/bouncing_ball_kelvin_voigt.toml,
models/block_on_incline.toml, models/variable_stiffness_spring.toml, and small models built here.

References
----------
[HC75]  K. H. Hunt, F. R. E. Crossley, "Coefficient of restitution interpreted as damping in
        vibroimpact", J. Appl. Mech. 42 (1975) 440–445: λ = 3 K (1 − e) / (2 v_in), first order in
        1 − e.
[MO99]  D. W. Marhefka, D. E. Orin, "A compliant contact model with nonlinear damping for
        simulation of robotic systems", IEEE Trans. SMC-A 29 (1999) 566–572: the exact relation
        between λ and e. With α = λ/K and no other force, m v dv/dz = −K zⁿ (1 + α v) gives
        m v dv / (1 + α v) = −K zⁿ dz; integrating over the whole impact (z from 0 back to 0, so
        the right side vanishes) gives ∫_{v_in}^{−v_out} v/(1 + α v) dv = 0, i.e.
        α v_in (1 + e) = ln((1 + α v_in) / (1 − α v_in e)), independent of n and of K, m
        separately (a function of α v_in only). Expanded to first order in 1 − e it is [HC75].
[KV]    Kelvin–Voigt (linear spring–damper) impact without clipping and without gravity: the contact
        lasts half a damped period π/ω_d and e = exp(−ζ π / √(1 − ζ²)), ω_n = √(K/m),
        ζ = B / (2 √(K m)), ω_d = ω_n √(1 − ζ²) (e.g. W. J. Stronge, *Impact Mechanics*, 2000,
        §5; any vibrations text for the free response).
[SCVS]  20-sim reference manual, SCVS friction; the thesis's App. A (Jafarian 2010, docs/walkers.md): the literal
        formula F = −Fn ((μ_c + (μ_st |tanh(s v)| − μ_c) exp(−(v/v_st)²)) sign v + μ_v v) is coded
        below in numpy (``scvs_literal``) and is the reference for the library's form.
[incline] Newton's law on an incline: m a = m g sin γ − μ(v) Fn, Fn = m g cos γ (any first-year
        mechanics text), integrated independently with scipy's solve_ivp.
[free fall] t = √(2 h / g), v = √(2 g h).
"""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

import porthamiltonian as ph
from porthamiltonian import compile_model, io, symbolic
from porthamiltonian.library import (
    HuntCrossley,
    SpringDamper,
    VariableSpringDamper,
    make_surface,
    scvs_coefficient,
)
from porthamiltonian.modeling.expressions import TIME

CONTACT_MODELS = ["bouncing_ball", "bouncing_ball_kelvin_voigt", "block_on_incline",
                  "variable_stiffness_spring"]
G = 9.81
THESIS_FRICTION = {"mu_st": 0.5, "mu_c": 0.25, "mu_v": 0.025, "s": 500.0, "v_st": 0.02}


# --------------------------------------------------------------------------------------------
# Helpers and independent references
# --------------------------------------------------------------------------------------------
def restitution_marhefka_orin(a: float) -> float:
    """e solving α v_in (1 + e) = ln((1 + α v_in)/(1 − α v_in e)) for a = α v_in > 0 [MO99]
    (the root in (0, min(1, 1/a)); e = −1 is the trivial root)."""
    def f(e):
        return math.log((1 - a * e) / (1 + a)) + a * (1 + e)
    return brentq(f, 0.0, min(1.0, 1.0 / a) * (1 - 1e-15), xtol=1e-16, rtol=1e-15)


def scvs_literal(v, Fn, mu_st, mu_c, mu_v, s, v_st):
    """The 20-sim SCVS friction force, verbatim from the thesis's App. A (numpy) [SCVS]."""
    v = np.asarray(v, dtype=float)
    return -Fn * ((mu_c + (mu_st * np.abs(np.tanh(s * v)) - mu_c) * np.exp(-(v / v_st) ** 2))
                  * np.sign(v) + mu_v * v)


def outputs_at(model, x, p, t=0.0) -> dict[str, float]:
    values = model.functions.outputs(t, model.augment(np.asarray(x, float)), model.native_params(p))
    return dict(zip(model.output_names, np.asarray(values, dtype=float)))


def ball_model(text_replace: dict[str, str] | None = None, name: str = "bouncing_ball"):
    """A model file of models/ with textual replacements (e.g. a different contact line)."""
    text = (io.models_dirs()[-1] / f"{name}.toml").read_text()
    for old, new in (text_replace or {}).items():
        assert old in text, old
        text = text.replace(old, new)
    return io.loads(text, source=f"{name} (modified in test_contact.py)")


def stop(t, x, p):
    return ph.Reset(stop=True)


def ledger_at(traj, t: float) -> tuple[float, float]:
    """(E_diss, E_in) at time t from the dense output of the run's segments."""
    n = traj.model.n_states
    for seg in traj.segments:
        if seg.sol is not None and seg.t[0] <= t <= seg.t[-1]:
            y = seg.sol(t)
            return float(y[n]), float(y[n + 1])
    raise ValueError(f"t = {t} not covered by a dense segment")


@pytest.fixture(scope="module")
def ball(compile_named):
    return compile_named("bouncing_ball")


@pytest.fixture(scope="module")
def block(compile_named):
    return compile_named("block_on_incline")


# --------------------------------------------------------------------------------------------
# Hunt–Crossley: restitution against [MO99] and [HC75]
# --------------------------------------------------------------------------------------------
V_IN = 3.0
RESTITUTION_CASES = [(1.0, 0.001), (1.0, 0.01), (1.0, 0.05), (1.0, 0.1), (1.0, 0.3), (1.0, 1.0),
                     (1.5, 0.01), (1.5, 0.3)]


def impact(model, lam_over_k, n=1.0, v_in=V_IN, K=1e6, method="Rodas4"):
    """One impact without gravity: the tip starts 1 mm above the floor moving down at v_in; the
    run stops at the lift-off event. Returns (e, trajectory)."""
    params = {"g": 0.0, "h0": 1e-3, "vz0": -v_in, "K": K, "lam": lam_over_k * K, "n": n}
    traj = model.simulate(0.1, params=params, actions={"liftoff": stop}, method=method,
                          rtol=1e-10, atol=1e-13)
    assert traj.status == "event" and "liftoff" in traj.message, traj.message
    return traj.x_final[model.state_index("ball.p.drop.z")] / v_in, traj   # m = 1 kg


@pytest.mark.parametrize("n, lam_over_k", RESTITUTION_CASES)
def test_restitution_matches_marhefka_orin_exact_relation(ball, n, lam_over_k):
    """e from the simulated impact (exit over entry speed at the lift-off event, Rodas4,
    rtol 1e-10) equals the root of [MO99]'s exact relation for a = λ v_in / K to 1e-8 relative,
    for n = 1 and n = 3/2 (the relation does not depend on n). For small a, [HC75]'s first-order
    λ = 3 K (1 − e)/(2 v_in), solved for λ with the simulated e, is within a relative O(a) of the
    true λ (its error term)."""
    e, traj = impact(ball, lam_over_k, n)
    a = lam_over_k * V_IN
    assert e == pytest.approx(restitution_marhefka_orin(a), rel=1e-8)
    if a <= 0.05:
        lam_hc = 3 * (1 - e) / (2 * V_IN)           # λ/K from [HC75]
        assert abs(lam_hc / lam_over_k - 1) <= a
    # the whole kinetic energy lost is in the ledger as dissipated (no stored energy left: z = 0)
    assert traj.E_diss[-1] == pytest.approx(0.5 * V_IN**2 * (1 - e**2), rel=1e-8)
    assert traj.relative_residual < 1e-8


def test_restitution_does_not_depend_on_stiffness_or_exponent(ball):
    """[MO99]: e depends on λ v_in / K only: K = 1e5 and 1e7 N/m, n = 1 and 2 give the same e
    (1e-8 relative) for the same λ/K."""
    reference = restitution_marhefka_orin(0.1 * V_IN)
    for K, n in [(1e5, 1.0), (1e7, 1.0), (1e6, 2.0)]:
        e, _ = impact(ball, 0.1, n, K=K)
        assert e == pytest.approx(reference, rel=1e-8), (K, n)


# --------------------------------------------------------------------------------------------
# Hunt–Crossley: energy of one impact with gravity, from the ledger and by quadrature
# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def dropped(ball):
    """The default ball dropped from h0 = 0.5 m (gravity on), Radau with dense output."""
    traj = ball.simulate(0.6, method="Radau", dense_output=True, rtol=1e-11, atol=1e-13)
    assert traj.status == "finished", traj.message
    return traj


def test_impact_energy_loss_equals_kinetic_energy_change_and_damping_integral(ball, dropped):
    """First impact of the default model (K = 1e6 N/m, λ = 1e5 N s/m², gravity on): the
    ledger's dissipated energy between the touchdown and lift-off events (guards on the
    penetration) equals ½ m (v_in² − v_out²) (the contact starts and ends at z = 0, at the same
    height: no stored or potential energy difference), v_in = √(2 g h0) [free fall], to 1e-8
    relative; and it equals ∫ λ z ż² dt computed independently by adaptive quadrature (scipy
    quad) of the dense output z = r − q_z, ż = −p_z/m, to 1e-8 relative. No energy is
    dissipated in flight."""
    events = {name: t for t, name in reversed(dropped.events)}
    t_td, t_lo = events["touchdown"], events["liftoff"]
    m, r, lam, h0 = 1.0, 0.05, 1e5, 0.5
    iq, ip = ball.state_index("ball.q.drop.z"), ball.state_index("ball.p.drop.z")
    v_in = math.sqrt(2 * G * h0)
    v_out = dropped.sol(t_lo)[ip] / m
    lost_ledger = ledger_at(dropped, t_lo)[0] - ledger_at(dropped, t_td)[0]
    kinetic = 0.5 * m * (v_in**2 - v_out**2)

    def damping_power(t):
        x = dropped.sol(t)
        z, zdot = r - x[iq], -x[ip] / m
        return lam * z * zdot**2 if z > 0 else 0.0

    quadrature, _ = quad(damping_power, t_td, t_lo, epsabs=0, epsrel=1e-12, limit=200)
    assert lost_ledger == pytest.approx(kinetic, rel=1e-8)
    assert quadrature == pytest.approx(lost_ledger, rel=1e-8)
    assert dropped.E_diss[dropped.t <= t_td].max() == pytest.approx(0.0, abs=1e-15)
    # with gravity the restitution differs from [MO99]'s (no other force) by O(g t_c / v_in)
    e = v_out / v_in
    assert abs(e - restitution_marhefka_orin(1e5 / 1e6 * v_in)) < 2 * G * (t_lo - t_td) / v_in
    assert dropped.relative_residual < 1e-8


def test_events_located_to_integrator_tolerance(ball, dropped):
    """Touchdown and lift-off (model events, guards r − q_z on the penetration) are located where
    the penetration is zero to 1e-10 m (Radau dense output); the first touchdown is at
    √(2 h0/g) [free fall] to 1e-9 s, with Radau, with the compiled Rodas4 loop, and with the
    guards written on the contact's output ``floor.z`` instead of the state; the event times of
    the three runs agree to 1e-8 s."""
    iq = ball.state_index("ball.q.drop.z")
    for t, name in dropped.events:
        assert abs(0.05 - dropped.sol(t)[iq]) < 1e-10, (t, name)
    t1 = math.sqrt(2 * 0.5 / G)
    radau = [t for t, _ in dropped.events]
    assert radau[0] == pytest.approx(t1, abs=1e-9)
    rodas = ball.simulate(0.6, method="Rodas4", rtol=1e-11, atol=1e-13)
    assert [n for _, n in dropped.events] == ["touchdown", "liftoff"]
    assert [n for _, n in rodas.events] == ["touchdown", "liftoff"]
    np.testing.assert_allclose([t for t, _ in rodas.events], radau, rtol=0, atol=1e-8)
    on_output = compile_model(ball_model({'guard = "r - ball.q.drop.z"': 'guard = "floor.z"'}),
                              backend="python")
    out = on_output.simulate(0.6, method="Radau", rtol=1e-11, atol=1e-13)
    assert [n for _, n in out.events] == ["touchdown", "liftoff"]
    np.testing.assert_allclose([t for t, _ in out.events], radau, rtol=0, atol=1e-8)


def test_normal_force_never_pulls(ball, dropped):
    """Hunt–Crossley F ≥ 0 along the drop (outputs at every step), and in a separation faster
    than the damper allows (start 1 mm deep moving up at 5 m/s with λ/K = 1 s/m, so
    K + λ ż < 0 at once): F = 0 throughout (the clipped branch), the ball leaves with its initial
    momentum (1e-12), and the released spring energy ½ K z0² is booked as dissipated
    (−K z ż ≥ 0 while clipped) to 1e-9 relative."""
    assert dropped["floor.Fn"].min() >= 0.0
    assert dropped["floor.Fn"].max() > 1e3
    z0, v0, K = 1e-3, 5.0, 1e6
    traj = ball.simulate(0.01, params={"g": 0.0, "h0": -z0, "vz0": v0, "lam": K * 1.0, "K": K},
                         actions={"liftoff": stop}, method="Radau", rtol=1e-11, atol=1e-14)
    assert traj.status == "event"
    assert np.all(traj["floor.Fn"] == 0.0)
    assert traj.x_final[ball.state_index("ball.p.drop.z")] == pytest.approx(v0, rel=1e-12)
    assert traj.E_diss[-1] == pytest.approx(0.5 * K * z0**2, rel=1e-9)
    assert traj.relative_residual < 1e-9


@settings(max_examples=60, deadline=None)
@given(z=st.floats(-1e-2, 1e-2), zdot=st.floats(-20.0, 20.0), lam=st.floats(0.0, 1e8),
       n=st.floats(0.5, 2.5), K=st.floats(1e3, 1e8))
def test_contact_force_and_dissipated_power_are_non_negative(ball, z, zdot, lam, n, K):
    """At any penetration, rate and parameters (λ ≥ 0, n > 0, K > 0): F ≥ 0, P_diss ≥ 0, and
    P_diss = F ż − dH/dt = (F − K z₊ⁿ) ż (the power the force delivers beyond the storage's rate) to 1e-9 relative."""
    p = ball.params({"lam": lam, "n": n, "K": K})
    x = np.array([0.0, 0.05 - z, 0.0, -zdot])          # q_x, q_z, p_x, p_z (m = 1)
    out = outputs_at(ball, x, p)
    _, p_diss, _ = ball.energy(0.0, x, p)
    F = out["floor.Fn"]
    zp = max(out["floor.z"], 0.0)                      # z as the model rounds it
    assert out["floor.zdot"] == zdot
    expected = (F - K * zp**n) * zdot
    assert F >= 0.0 and p_diss >= 0.0
    assert p_diss == pytest.approx(expected, rel=1e-9, abs=1e-9 * (abs(F * zdot) + 1e-300))


# --------------------------------------------------------------------------------------------
# Kelvin–Voigt: closed-form impact without clipping, the tensile force, the one-line swap
# --------------------------------------------------------------------------------------------
KV_CLIP_FALSE = {'damping = "B" }': 'damping = "B", clip = false }'}


def test_kelvin_voigt_file_differs_from_hunt_crossley_in_one_line():
    """Swapping the contact law is one line of the model file (besides comments, name and
    description): the [components] line of the floor."""
    def lines(name):
        text = (io.models_dirs()[-1] / f"{name}.toml").read_text().splitlines()
        return [ln for ln in text if not ln.startswith("#") and not ln.startswith(("name =", "description ="))]
    a, b = lines("bouncing_ball"), lines("bouncing_ball_kelvin_voigt")
    assert len(a) == len(b)
    diff = [(x, y) for x, y in zip(a, b) if x != y]
    assert len(diff) == 1 and "HuntCrossley" in diff[0][0] and "KelvinVoigt" in diff[0][1]


def test_kelvin_voigt_without_clipping_matches_closed_form_and_pulls_at_separation(isolated_cache):
    """Kelvin–Voigt with clip = false, no gravity: the contact lasts π/ω_d and e =
    exp(−ζπ/√(1 − ζ²)) [KV] (1e-8 relative, Radau rtol 1e-11 with the events on the penetration);
    just before lift-off the force is tensile, F → B ż = −B v_out (the law's value at z → 0⁺,
    1e-6 relative). With clipping (the default) F ≥ 0 throughout: the force vanishes while the
    ball still penetrates, so the pull is gone and the ball leaves faster (a higher restitution);
    both ledgers close."""
    unclipped = compile_model(ball_model(KV_CLIP_FALSE, "bouncing_ball_kelvin_voigt"),
                              backend="python")
    clipped = compile_model(io.load("bouncing_ball_kelvin_voigt"), backend="python")
    m, K, B, v_in = 1.0, 1e6, 140.0, 3.0
    params = {"g": 0.0, "h0": 1e-3, "vz0": -v_in}
    ip = unclipped.state_index("ball.p.drop.z")
    runs = {}
    for name, model in (("unclipped", unclipped), ("clipped", clipped)):
        runs[name] = model.simulate(0.1, params=params, actions={"liftoff": stop}, method="Radau",
                                    rtol=1e-11, atol=1e-13)
        assert runs[name].status == "event" and runs[name].relative_residual < 1e-8
    traj = runs["unclipped"]
    wn, zeta = math.sqrt(K / m), B / (2 * math.sqrt(K * m))
    wd = wn * math.sqrt(1 - zeta**2)
    (t_td, _), (t_lo, _) = traj.events
    assert t_lo - t_td == pytest.approx(math.pi / wd, rel=1e-8)
    v_out = traj.x_final[ip] / m
    assert v_out / v_in == pytest.approx(math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2)), rel=1e-8)
    F = traj["floor.Fn"]
    assert F.min() < 0
    before = traj.t < t_lo
    assert F[before][-1] == pytest.approx(-B * v_out, rel=1e-6)
    c = runs["clipped"]
    assert c["floor.Fn"].min() >= 0.0
    assert c.x_final[ip] / m > v_out
    assert np.any((c["floor.z"] > 1e-7) & (c["floor.Fn"] == 0.0))   # separated while penetrating


# --------------------------------------------------------------------------------------------
# Surfaces: slope (penetration along the normal) and a step down
# --------------------------------------------------------------------------------------------
def test_surface_geometry_is_consistent():
    """Slope γ: n = (sin γ, cos γ) and t = (cos γ, −sin γ) are orthonormal, t points downhill
    (z decreases along t), a point at the surface has zero penetration, a point d along −n has
    penetration d; the step's lower part is h lower (vertically) at x ≥ x_step, h cos γ along n."""
    x, z, g, h, xs, d = sp.symbols("x z gamma h x_s d", real=True)
    s = make_surface("step", "test", slope=g, step_height=h, step_x=xs)
    n, t = sp.Matrix(s.normal), sp.Matrix(s.tangent)
    assert sp.simplify(n.dot(n)) == 1 and sp.simplify(t.dot(t)) == 1 and sp.simplify(n.dot(t)) == 0
    vals = {g: 0.2, h: 0.03, xs: 1.0}
    assert float(t[1].subs(vals)) < 0
    for x0 in (0.3, 1.7):
        on = (x0, s.elevation(x0).subs(vals))
        assert abs(float(s.penetration(*on).subs(vals))) < 1e-15
        inside = (on[0] - d * n[0], on[1] - d * n[1])
        assert float(s.penetration(*inside).subs(vals | {d: 0.01})) == pytest.approx(0.01, rel=1e-12)
    upper = s.penetration(x, z).subs(vals | {x: 0.5, z: 0.0})
    lower = s.penetration(x, z).subs(vals | {x: 1.5, z: 0.0}) + 1.0 * sp.sin(0.2)
    assert float(upper - lower) == pytest.approx(0.03 * math.cos(0.2), rel=1e-12)


def test_ball_on_a_slope_keeps_tangential_velocity_and_rebounds_along_the_normal(isolated_cache):
    """A ball dropped (no friction, no gravity, moving straight down at v) onto a slope of
    γ = 0.3 rad: the contact acts along the normal only, so the tangential velocity t·v is
    unchanged (1e-10) and the normal velocity is reversed and scaled by the [MO99] restitution
    for α v cos γ (1e-8)."""
    gamma, v = 0.3, 3.0
    model = compile_model(ball_model({'exponent = "n" }': 'exponent = "n", surface = "slope", slope = 0.3 }'}),
                          backend="python")
    # the tip at x = 0 is 1 mm above the surface along the vertical
    traj = model.simulate(0.1, params={"g": 0.0, "h0": 1e-3, "vz0": -v}, method="Radau",
                          rtol=1e-11, atol=1e-13)
    assert traj.status == "finished"
    ix, iz = model.state_index("ball.p.drop.x"), model.state_index("ball.p.drop.z")
    vel = traj.x_final[[ix, iz]]
    n = np.array([math.sin(gamma), math.cos(gamma)])
    t = np.array([math.cos(gamma), -math.sin(gamma)])
    v0 = np.array([0.0, -v])
    assert vel @ t == pytest.approx(v0 @ t, abs=1e-10)
    e = restitution_marhefka_orin(0.1 * v * math.cos(gamma))
    assert vel @ n == pytest.approx(-e * (v0 @ n), rel=1e-8)
    assert traj["floor.Fn"].max() > 0 and traj.relative_residual < 1e-8


def test_ball_dropped_past_a_step_down_lands_on_the_lower_level(isolated_cache):
    """Surface 'step' with h = 0.1 m, the edge at x = −1 m (the ball falls at x = 0, past it):
    first touchdown when the tip has fallen h0 + h, at √(2 (h0 + h)/g) [free fall] to 1e-9 s (a
    terminal model event on the output floor.z); with the edge at x = +1 m the ball lands on the
    upper level at √(2 h0/g)."""
    model = compile_model(ball_model({'exponent = "n" }': 'exponent = "n", surface = "step", step_height = "hs", step_x = "xs" }',
                                      "[parameters]\n": "[parameters]\nhs = 0.1\nxs = -1.0\n",
                                      'name = "touchdown"\nguard = "r - ball.q.drop.z"\ndirection = 1':
                                      'name = "touchdown"\nguard = "floor.z"\ndirection = 1\nterminal = true'}),
                          backend="python")
    for xs, drop in ((-1.0, 0.1), (1.0, 0.0)):
        traj = model.simulate(1.0, params={"xs": xs}, method="Radau", rtol=1e-11, atol=1e-13)
        assert traj.status == "event"
        assert traj.t_final == pytest.approx(math.sqrt(2 * (0.5 + drop) / G), abs=1e-9)


# --------------------------------------------------------------------------------------------
# Contact modes: a touchdown rule (scuffing) switching the 'active' flag by events
# --------------------------------------------------------------------------------------------
def scuffing_pendulum() -> ph.Model:
    """A pendulum (point mass m_f at the end of a massless rod of length L, hinge at the origin)
    whose foot dips δ below a floor at its lowest point. The floor's contact is active only while
    the mode parameter c1 = 1. Released from θ0 = 0.5 rad (foot behind the hinge, x < 0)."""
    m = ph.Model("scuffing_pendulum")
    for name, value in (("L", 1.0), ("m_f", 1.0), ("g", G), ("delta", 0.005), ("K", 1e6),
                        ("lam", 1e5), ("c1", 0.0), ("theta0", 0.5)):
        m.parameter(name, value)
    m.add("leg", ph.Multibody(
        bodies={"foot_body": {"mass": "m_f", "com": [0, 0, "-L"], "inertia": 0,
                          "points": {"foot": [0, 0, "-L"]}}},
        joints={"hinge": {"type": "revolute", "parent": "world", "child": "foot_body",
                          "axis": "y", "q0": "theta0"}},
        gravity=[0, 0, "-g"], plane="xz"))
    m.add("floor", HuntCrossley(x="leg.foot.x", z="leg.foot.z", stiffness="K", damping="lam",
                                height="-L + delta", active="c1"))
    m.connect("leg.foot", "floor.p")
    penetration = "delta - L + L*cos(leg.q.hinge)"       # of the foot, in the state θ
    m.event("touch", penetration, direction=1)
    m.event("leave", penetration, direction=-1)
    return m


def test_touchdown_rule_lets_a_swinging_foot_pass_through_then_contact(isolated_cache):
    """Item 6 of issue 4 (the thesis's scuffing rule, §2.3.1): a contact may start
    only when the foot crosses the surface *in front* (here x > 0, ahead of the hinge); it ends
    when the foot rises above the surface. The first crossing (x < 0) is ignored: the foot
    passes 5 mm deep through the floor with no force (Fn = 0 while z > 0) and no energy loss;
    on the way back it crosses at x > 0, the contact starts (Fn > 0) and turns the swing back
    before the bottom. The mode switches happen at z = 0, so H does not jump (1e-12 J); the
    ledger closes (1e-8) and the compiled Rodas4 loop agrees with Radau on the event times
    (1e-8 s)."""
    compiled = compile_model(scuffing_pendulum(), backend="python")
    ith = compiled.state_index("leg.q.hinge")

    def touch(t, x, p):
        in_front = -1.0 * math.sin(x[ith]) > 0          # foot x = −L sin θ
        return ph.Reset(params={"c1": 1.0}) if in_front else ph.Reset()

    def leave(t, x, p):
        return ph.Reset(params={"c1": 0.0})

    runs = {method: compiled.simulate(3.0, actions={"touch": touch, "leave": leave},
                                      method=method, rtol=1e-10, atol=1e-12)
            for method in ("Radau", "Rodas4")}
    traj = runs["Radau"]
    assert traj.status == "finished", traj.message
    names = [n for _, n in traj.events]
    assert names[:4] == ["touch", "leave", "touch", "leave"]
    (t1, _), (t2, _), (t3, _), (t4, _) = traj.events[:4]
    first = (traj.t > t1) & (traj.t < t2)
    assert traj["floor.z"][first].max() > 4e-3 and np.all(traj["floor.Fn"][first] == 0.0)
    assert traj.E_diss[traj.t <= t2].max() == 0.0
    second = (traj.t > t3) & (traj.t < t4)
    assert traj["floor.Fn"][second].max() > 10.0
    assert traj.E_diss[traj.t >= t4].min() > 0.0
    theta = traj["leg.q.hinge"]
    assert theta[second].max() < 0.0                     # turned back before the bottom (θ = 0)
    assert max(abs(j) for _, _, j in traj.jumps) < 1e-12
    assert traj.relative_residual < 1e-8
    rodas = runs["Rodas4"]
    assert [n for _, n in rodas.events] == names
    np.testing.assert_allclose([t for t, _ in rodas.events], [t for t, _ in traj.events], atol=1e-8)


# --------------------------------------------------------------------------------------------
# SCVS friction: the 20-sim formula, the Stribeck curve, passivity
# --------------------------------------------------------------------------------------------
def scvs_from_model(block, v_values, Fn_expected=None, gamma=0.6, **friction):
    """μ(v) from the compiled block model's friction output at the static normal penetration,
    with the block moving at tangential speed v."""
    p = block.params(dict(gamma=gamma, **friction))
    d = 9.81 * math.cos(gamma) / 1e6
    mus = []
    for v in v_values:
        x = [-d * math.sin(gamma), -d * math.cos(gamma), v * math.cos(gamma), -v * math.sin(gamma)]
        out = outputs_at(block, x, p)
        mus.append(out["friction.mu"])
        assert out["friction.Ft"] == pytest.approx(-out["ground.Fn"] * out["friction.mu"], rel=1e-14)
    return np.array(mus)


def test_scvs_law_equals_the_literal_20sim_formula(block):
    """The library's SCVS force (compiled, read from the block model's outputs at v) equals the
    literal 20-sim formula [SCVS] to 1e-13 relative (1e-15 N absolute) at v = 0, ±1e-9, around
    the tanh slope, around v_st and at large |v|, for the thesis values and for another set."""
    v = np.array([0.0, 1e-9, -1e-9, 1e-4, -2e-3, 5e-3, 0.01, -0.02, 0.02, 0.05, -0.3, 1.0, 7.0])
    for fr in (THESIS_FRICTION, {"mu_st": 0.9, "mu_c": 0.3, "mu_v": 0.2, "s": 80.0, "v_st": 0.1}):
        mu = scvs_from_model(block, v, **fr)
        Fn = 9.81 * math.cos(0.6)
        np.testing.assert_allclose(-Fn * mu, scvs_literal(v, Fn, fr["mu_st"], fr["mu_c"], fr["mu_v"],
                                                          fr["s"], fr["v_st"]),
                                   rtol=1e-13, atol=1e-15)


def test_stribeck_curve_has_its_documented_shape(block):
    """μ(v) (thesis values): 0 at v = 0; odd; slope μ_st·s + μ_v at 0 (at v = 1e-6, 1e-5);
    a peak below μ_st at a speed below v_st; μ_c + (μ_st tanh(s v_st) − μ_c)/e + μ_v v_st at v = v_st
    (1e-12); decreasing from the peak to ≈ 3 v_st; then within 1e-3 of μ_c + μ_v v and
    increasing."""
    fr = THESIS_FRICTION
    v = np.concatenate([[0.0], np.geomspace(1e-6, 5.0, 400)])
    mu = scvs_from_model(block, v)
    mu_neg = scvs_from_model(block, -v[1:])
    assert mu[0] == 0.0
    np.testing.assert_allclose(mu_neg, -mu[1:], rtol=1e-14)
    assert mu[1] / v[1] == pytest.approx(fr["mu_st"] * fr["s"] + fr["mu_v"], rel=1e-5)
    k = int(np.argmax(mu))
    assert fr["mu_c"] < mu[k] < fr["mu_st"] and v[k] < fr["v_st"]
    at_vst = scvs_from_model(block, [fr["v_st"]])[0]
    assert at_vst == pytest.approx(fr["mu_c"] + (fr["mu_st"] * math.tanh(fr["s"] * fr["v_st"]) - fr["mu_c"])
                                   / math.e + fr["mu_v"] * fr["v_st"], rel=1e-12)
    falling = (v > v[k]) & (v < 2.5 * fr["v_st"])
    assert np.all(np.diff(mu[falling]) < 0)
    large = v > 3 * fr["v_st"]
    assert np.all(np.abs(mu[large] - (fr["mu_c"] + fr["mu_v"] * v[large])) < 1e-3)
    after = v > 4 * fr["v_st"]
    assert np.all(np.diff(mu[after]) > 0)


_V, _MU_ST, _MU_C, _MU_V, _S, _V_ST = sp.symbols("v mu_st mu_c mu_v s v_st", real=True)
_MU = sp.lambdify((_V, _MU_ST, _MU_C, _MU_V, _S, _V_ST),
                  scvs_coefficient(_V, _MU_ST, _MU_C, _MU_V, _S, _V_ST), "math")


@settings(max_examples=200, deadline=None)
@given(v=st.floats(-50, 50), mu_c=st.floats(0, 1), extra=st.floats(0, 1), mu_v=st.floats(0, 1),
       s=st.floats(0, 1e4), v_st=st.floats(1e-4, 1.0))
def test_friction_power_is_non_negative(v, mu_c, extra, mu_v, s, v_st):
    """μ(v)·v ≥ 0 for any v and parameters with 0 ≤ μ_c ≤ μ_st, μ_v, s ≥ 0, v_st > 0, so the
    friction power Fn μ(v) v is ≥ 0 for Fn ≥ 0 [SCVS]; and the library's form equals the
    literal formula to 1e-13 of the size of its terms (μ_st + μ_c + μ_v |v|: the literal formula
    cancels μ_c − μ_c near v = 0)."""
    mu_st = mu_c + extra
    value = _MU(v, mu_st, mu_c, mu_v, s, v_st)
    assert value * v >= 0.0
    literal = -float(scvs_literal(v, 1.0, mu_st, mu_c, mu_v, s, v_st))
    assert abs(value - literal) <= 1e-13 * (mu_st + mu_c + mu_v * abs(v))


# --------------------------------------------------------------------------------------------
# Block on an incline: sliding and (regularized) sticking
# --------------------------------------------------------------------------------------------
def incline_reference(gamma, t_end, fr=THESIS_FRICTION):
    """v(t), s(t) from m v' = m g sin γ − μ(v) m g cos γ, v(0) = 0 [incline] (solve_ivp, Radau)."""
    def rhs(t, y):
        mu = -scvs_literal(y[0], 1.0, fr["mu_st"], fr["mu_c"], fr["mu_v"], fr["s"], fr["v_st"])
        return [G * math.sin(gamma) - mu * G * math.cos(gamma), y[0]]
    sol = solve_ivp(rhs, (0, t_end), [0.0, 0.0], method="Radau", rtol=1e-12, atol=1e-14,
                    dense_output=True)
    return sol


def block_run(block, gamma, t_end=1.0):
    traj = block.simulate(t_end, params={"gamma": gamma}, method="Rodas4", rtol=1e-10, atol=1e-13)
    assert traj.status == "finished", traj.message
    return traj


def test_block_slides_with_the_closed_form_acceleration(block):
    """γ = 0.6 rad (tan γ = 0.68 > μ_st = 0.5): the block slides. Its normal force stays
    m g cos γ (1e-8 relative: it starts at the static penetration); at every step after the
    Stribeck peak its tangential acceleration (from the model's right-hand side) equals
    g (sin γ − μ(v) cos γ) with the 20-sim μ at the reached speed (1e-7 relative); and its speed
    and distance at 1 s match the independent 1-D integration [incline] (1e-7 relative)."""
    gamma = 0.6
    traj = block_run(block, gamma)
    t_dir = np.array([math.cos(gamma), -math.sin(gamma)])
    fn = traj["ground.Fn"]
    np.testing.assert_allclose(fn, G * math.cos(gamma), rtol=1e-8)
    p = block.params({"gamma": gamma})
    pn = block.native_params(p)
    later = traj.t > 0.1
    v = traj["friction.v"]
    fr = THESIS_FRICTION
    assert v[later].min() > 0.1
    for k in np.nonzero(later)[0][::10]:
        xdot = np.asarray(block.functions.rhs(traj.t[k], np.ascontiguousarray(traj.y[:, k]), pn))
        a = t_dir @ xdot[2:4]                                   # m = 1 kg
        mu = -scvs_literal(v[k], 1.0, fr["mu_st"], fr["mu_c"], fr["mu_v"], fr["s"], fr["v_st"])
        assert a == pytest.approx(G * (math.sin(gamma) - mu * math.cos(gamma)), rel=1e-7)
    ref = incline_reference(gamma, 1.0)
    assert v[-1] == pytest.approx(ref.y[0, -1], rel=1e-7)
    assert traj["ground.s"][-1] - traj["ground.s"][0] == pytest.approx(ref.y[1, -1], rel=1e-7)
    assert traj.relative_residual < 1e-9


def test_block_sticks_within_the_regularization_when_tan_gamma_below_mu_st(block):
    """γ = 0.3 rad (tan γ = 0.31 < μ_st): the smooth SCVS law holds the block at the creep speed
    v* solving μ(v*) = tan γ (brentq on the literal formula), v* < v_st/10, reached within 20 ms
    and kept to 1e-7 relative until 1 s; distance after 1 s ≈ v* · 1 s. The friction power
    equals the loss of potential energy (ledger, 1e-9)."""
    gamma = 0.3
    fr = THESIS_FRICTION
    traj = block_run(block, gamma)

    def excess(v):
        return -scvs_literal(v, 1.0, fr["mu_st"], fr["mu_c"], fr["mu_v"], fr["s"], fr["v_st"]) - math.tan(gamma)
    v_star = brentq(excess, 1e-9, 0.005, xtol=1e-16, rtol=1e-15)
    assert v_star < fr["v_st"] / 10
    v = traj["friction.v"]
    settled = traj.t > 0.02
    np.testing.assert_allclose(v[settled], v_star, rtol=1e-7)
    assert traj["ground.s"][-1] - traj["ground.s"][0] == pytest.approx(v_star * 1.0, rel=2e-2)
    assert traj.relative_residual < 1e-9


# --------------------------------------------------------------------------------------------
# Springs: variable stiffness (supplied energy), modes, state modulation; linear spring-damper
# --------------------------------------------------------------------------------------------
def test_variable_stiffness_supplied_energy_equals_half_kdot_z_squared(model_run):
    """models/variable_stiffness_spring (K(t) = K1 + (K2 − K1)(1 − cos ω t)/2, D = 2α√(mK)): the
    ledger's supplied energy equals ∫ ½ K̇ z² dt and the dissipated one ∫ D ż² dt, both by
    adaptive quadrature of the dense output (1e-8 relative); the ledger closes (1e-9)."""
    model, traj = model_run("variable_stiffness_spring")
    m, K1, K2, w, alpha = 3.1, 6000.0, 8000.0, 10.0, 0.15
    iq, ip = model.state_index("spring.q"), model.state_index("mass.p")

    def K(t):
        return K1 + (K2 - K1) * (1 - math.cos(w * t)) / 2

    def supplied(t):
        return 0.5 * (K2 - K1) * w * math.sin(w * t) / 2 * traj.sol(t)[iq] ** 2

    def dissipated(t):
        return 2 * alpha * math.sqrt(m * K(t)) * (traj.sol(t)[ip] / m) ** 2

    T = traj.t[-1]
    breaks = list(np.linspace(0, T, 81))
    e_in = sum(quad(supplied, a, b, epsabs=1e-15, epsrel=1e-11, limit=200)[0]
               for a, b in itertools.pairwise(breaks))
    e_diss = sum(quad(dissipated, a, b, epsabs=1e-15, epsrel=1e-11, limit=200)[0]
                 for a, b in itertools.pairwise(breaks))
    assert abs(traj.E_in[-1]) > 1e-4
    assert traj.E_in[-1] == pytest.approx(e_in, rel=1e-8)
    assert traj.E_diss[-1] == pytest.approx(e_diss, rel=1e-8)
    assert traj.relative_residual < 1e-9


def test_variable_stiffness_compiles_the_modulation_power_symbolically():
    """The compiler books P_in = ½ K̇ z² for K(t) (symbolic identity) and nothing else."""
    sym = symbolic(io.load("variable_stiffness_spring"))
    par = {s.name: s for s in sym.params}
    q = sym.states[sym.state_names.index("spring.q")]
    K = par["K1"] + (par["K2"] - par["K1"]) * (1 - sp.cos(par["w"] * TIME)) / 2
    assert sp.simplify(sym.p_in - sp.diff(K, TIME) * (q - par["L0"]) ** 2 / 2) == 0


def spring_with(name: str, stiffness: str, extra_params=(), other=False, **spring) -> ph.Model:
    """Mass m on a VariableSpringDamper; optionally a second, independent oscillator 'other'
    (mass mo on a linear C) whose position modulates the stiffness."""
    m = ph.Model(name)
    for par, value in (("m", 3.1), ("K1", 6000.0), ("K2", 8000.0), ("q0", 0.01), *extra_params):
        m.parameter(par, value)
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance="m"))
    m.add("spring", VariableSpringDamper(stiffness=stiffness, q0="q0", **spring))
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    if other:
        m.add("jo", ph.OneJunction())
        m.add("mo", ph.I(inertance=1.0, p0=0.0))
        m.add("other", ph.C(stiffness=100.0, q0=0.3))
        m.connect("jo", "mo.p")
        m.connect("jo", "other.p")
    return m


def test_stiffness_switched_by_an_event_books_the_jump_as_supplied(isolated_cache):
    """K = K1 + (K2 − K1)·late, with the mode parameter late set to 1 by an event (when the
    mass first stops, the spring at its extreme): the action returns
    Reset(params, energy="supplied"), and E_in jumps by ½ (K2 − K1) z² at the event (1e-12
    relative); the ledger closes across it (1e-9)."""
    model = compile_model(spring_with("vss_mode", "K1 + (K2 - K1)*late", [("late", 0.0)], damping=2.0),
                          backend="python")
    ip, iq = model.state_index("mass.p"), model.state_index("spring.q")
    stopped = ph.Event("stopped", lambda t, x, p: x[ip], direction=1, terminal=True)
    fired = []

    def switch(t, x, p):
        fired.append((t, x[iq]))
        return ph.Reset(params={"late": 1.0}, energy="supplied")

    traj = model.simulate(0.2, events=[stopped], actions={"stopped": switch}, method="Radau",
                          rtol=1e-11, atol=1e-13)
    assert traj.status == "finished" and len(fired) >= 1
    t_e, z_e = fired[0]
    jump = next(j for t, name, j in traj.jumps if name == "stopped")
    assert jump == pytest.approx(0.5 * 2000.0 * z_e**2, rel=1e-12)
    assert traj.E_in[traj.t > t_e].min() == pytest.approx(jump, rel=1e-12)
    assert traj.relative_residual < 1e-9


def test_stiffness_modulated_by_another_state_with_abs_is_booked_and_closes(isolated_cache):
    """The thesis's §3.2 form K = K1 + (K2 − K1)|φ|/φ_max with φ another component's state
    (a second oscillator's elongation): the Abs is rewritten as a Piecewise (no Dirac delta in
    the Jacobian), the compiler books P_in = ½ z² ∂K/∂φ φ̇ (checked against ∫ by quadrature of
    the dense output, 1e-8 relative) and the ledger closes (1e-9)."""
    model = compile_model(spring_with("vss_abs", "K1 + (K2 - K1)*Abs(other.q)/phi_max",
                                      [("phi_max", 0.3)], other=True, alpha=0.15, mass="m"),
                          backend="python")
    traj = model.simulate(1.0, method="Radau", dense_output=True, rtol=1e-11, atol=1e-13)
    assert traj.status == "finished"
    iq, io_q, io_p = (model.state_index(n) for n in ("spring.q", "other.q", "mo.p"))

    def p_in(t):
        x = traj.sol(t)
        return 0.5 * x[iq] ** 2 * (2000.0 / 0.3) * np.sign(x[io_q]) * x[io_p] / 1.0

    breaks = np.linspace(0, 1.0, 81)
    e_in = sum(quad(p_in, a, b, epsabs=1e-14, epsrel=1e-12, limit=200)[0] for a, b in itertools.pairwise(breaks))
    assert abs(traj.E_in[-1]) > 1e-5
    assert traj.E_in[-1] == pytest.approx(e_in, rel=1e-8)
    assert traj.relative_residual < 1e-9


def test_linear_spring_damper_equals_separate_c_and_r(isolated_cache):
    """SpringDamper(K, D, rest length L0) on a mass equals the textbook C ∥ R model
    (models/mass_spring_damper: k = 4, c = 0.4, x0 = 0.1) shifted by L0: final momentum and
    elongation agree to 1e-9 after 20 s; alpha/mass give D = 2 α √(m K)."""
    m = ph.Model("sd_linear")
    m.parameter("k", 4.0)
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0))
    m.add("sd", SpringDamper(stiffness="k", damping=0.4, rest_length=0.7, q0=0.8))
    m.connect("j", "mass.p")
    m.connect("j", "sd.p")
    mine = compile_model(m, backend="python").simulate(20.0, method="Radau", rtol=1e-11, atol=1e-13)
    ref = compile_model(io.load("mass_spring_damper"), backend="python").simulate(
        20.0, method="Radau", rtol=1e-11, atol=1e-13)
    assert mine["sd.z"][-1] == pytest.approx(ref["spring.q"][-1], abs=1e-9)
    assert mine["mass.p"][-1] == pytest.approx(ref["mass.p"][-1], abs=1e-9)
    assert mine.relative_residual < 1e-9
    rule = ph.Model("sd_rule")
    rule.add("j", ph.OneJunction())
    rule.add("mass", ph.I(inertance=1.0))
    rule.add("sd", SpringDamper(stiffness=4.0, alpha=0.1, mass=1.0, q0=0.1))
    rule.connect("j", "mass.p")
    rule.connect("j", "sd.p")
    compiled = compile_model(rule, backend="python")
    assert outputs_at(compiled, [0.0, 0.1], compiled.params())["sd.D"] == pytest.approx(0.4, rel=1e-15)


# --------------------------------------------------------------------------------------------
# Energy residual of every model of this library, both integrators, and the command line
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", CONTACT_MODELS)
def test_energy_ledger_closes_with_rodas4_and_radau(compile_named, model_settings, model_run,
                                                    name):
    """Each model with its [simulation] tolerances closes its ledger within its
    energy_tolerance with the compiled Rodas4 loop (python back end; KV with atol 1e-11, see its
    file) and with Radau; the two agree on the final state to 1e-5 of its scale. (Where the
    Radau run is the file's own settings, it is the session's run of the file, ``model_run``,
    which variable_stiffness_spring's quadrature test made already: its dense output keeps the
    interpolants, the steps are the same.)"""
    sim = model_settings(name)
    model = compile_named(name)
    t_end = float(sim["t_end"])
    atol = max(sim["atol"], 1e-11) if name.endswith("kelvin_voigt") else sim["atol"]
    files_own = sim["method"] == "Radau" and atol == sim["atol"] and "max_step" not in sim
    runs = [model.simulate(t_end, method="Rodas4", rtol=sim["rtol"], atol=atol),
            model_run(name)[1] if files_own else
            model.simulate(t_end, method="Radau", rtol=sim["rtol"], atol=atol)]
    for traj in runs:
        assert traj.status == "finished", traj.message
        assert traj.relative_residual < float(sim["energy_tolerance"]), traj.ledger()
    scale = np.maximum(np.abs(runs[1].x).max(axis=0), 1e-3)
    assert np.all(np.abs(runs[0].x_final - runs[1].x_final) <= 1e-5 * scale)


def test_check_energy_command_passes_on_the_contact_models(energy_check):
    """``porthamiltonian --backend c check-energy`` passes the four models (the session's
    run over every shipped model, tests/conftest.py)."""
    for name in CONTACT_MODELS:
        assert energy_check.line(name)["ok"], energy_check.line(name)["text"]

"""Sensitivities of a run, Φ(t) = ∂x(t)/∂x₀ (simulate(..., sensitivity=...)): the variational
equation integrated by the compiled loops (porthamiltonian/integrators/rosenbrock_loop.py and
.c) and the saltation matrices at events (porthamiltonian/saltation.py), against closed forms
and independent computations:

* linear systems: Φ(t) = expm(A t), A written from the physics (not from the generated Jacobian);
* a nonlinear pendulum and a double pendulum: central finite differences of whole runs, and the
  variational equation integrated as one ODE (x, Φ) by scipy's DOP853 at rtol 1e-13;
* a bouncing ball: Φ across a bounce, at a stop on the ground and from apex to apex, in closed
  form (free flight z'' = −g, the bounce v⁺ = −e v⁻);
* the three back ends agree, the trajectory is the same bit for bit with and without Φ, the
  method keeps its order on Φ, and Φ's error is at the level of the tolerance.
"""
from __future__ import annotations

import itertools
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp
from scipy.linalg import expm

import porthamiltonian as ph
from porthamiltonian import compile_model, io
from porthamiltonian.errors import ModelError, OptionError
from porthamiltonian.simulation.saltation import (
    compose,
    saltation_matrix,
    section_jacobian,
    section_projection,
    surface_lift,
)

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "unit"))
from test_events import MASS, E, G, ball_model

#: the numba loops are checked in .ci/run's numba pass (conftest: ``numba_loop``)
NUMBA = pytest.param("numba", marks=pytest.mark.numba_loop)
BACKENDS = ("python", NUMBA, "c")


def _linear(name: str) -> tuple[ph.CompiledModel, np.ndarray]:
    """A linear model and its A (state order of the model), written from the physics:
    mass_spring_damper (p = m v, q): ṗ = −k q − c p/m, q̇ = p/m; dc_motor (flux linkage λ = L i,
    rotor momentum p = J ω): λ̇ = V − R λ/L − k p/J, ṗ = k λ/L − b p/J."""
    model = compile_model(io.load(name), backend="c")
    d = dict(zip(model.param_names, model.param_defaults))
    if name == "mass_spring_damper":
        A = {("mass.p", "mass.p"): -d["c"] / d["m"], ("mass.p", "spring.q"): -d["k"],
             ("spring.q", "mass.p"): 1 / d["m"]}
    else:
        L, J = d["L_a"], d["J"]
        A = {("winding_inductance.p", "winding_inductance.p"): -d["R_a"] / L,
             ("winding_inductance.p", "rotor.p"): -d["k_m"] / J,
             ("rotor.p", "winding_inductance.p"): d["k_m"] / L,
             ("rotor.p", "rotor.p"): -d["b"] / J}
    out = np.zeros((model.n_states, model.n_states))
    for (a, b), v in A.items():
        out[model.state_index(a), model.state_index(b)] = v
    return model, out


@pytest.mark.parametrize("name, t_end", [("mass_spring_damper", 10.0), ("dc_motor", 0.2)])
def test_linear_system_phi_is_the_matrix_exponential(name, t_end):
    """Φ(T) = expm(A T) to 1e-9 relative at rtol 1e-10 (Rodas5P), on an oscillator and on the
    stiff dc motor (time constants 0.5 ms and ~40 ms); also at every stored point."""
    model, A = _linear(name)
    traj = model.simulate(t_end, rtol=1e-10, atol=1e-12, sensitivity=True)
    sens = traj.sensitivity
    ref = expm(A * t_end)
    assert np.max(np.abs(sens.final - ref)) < 1e-9 * np.max(np.abs(ref))
    for k in range(0, len(traj.t), max(1, len(traj.t) // 20)):
        refk = expm(A * traj.t[k])
        assert np.max(np.abs(sens.phi[k] - refk)) < 1e-9 * np.max(np.abs(refk))
    assert sens.seeds.shape == (2, 2) and sens.phi.shape == (len(traj.t), 2, 2)


@pytest.mark.parametrize("method", ["Rodas5P", "Rodas4"])
def test_phi_error_follows_the_tolerance(method):
    """Φ has its own error control (sub-steps of the steps chosen for x, which stay as they are):
    max|Φ − expm(AT)| / max|expm| <= 3 rtol over rtol 1e-6 ... 1e-10 on both linear models
    (measured: at most 1.9 rtol), and the largest error estimate of an accepted sub-step is at
    most 10 rtol, the sub-steps' tolerance (Sensitivity.error <= 10)."""
    for name, t_end in (("mass_spring_damper", 10.0), ("dc_motor", 0.2)):
        model, A = _linear(name)
        ref = expm(A * t_end)
        for rtol in (1e-6, 1e-8, 1e-10):
            sens = model.simulate(t_end, method=method, rtol=rtol, atol=rtol * 1e-2,
                                  sensitivity=True).sensitivity
            error = np.max(np.abs(sens.final - ref)) / np.max(np.abs(ref))
            assert error <= 3 * rtol and sens.error <= 10.0, (name, rtol, error, sens.error)


def test_phi_is_resolved_where_x_does_not_move():
    """From the equilibrium x = 0 the oscillator does not move and x's steps grow to the whole
    span (11 points over 10 s); Φ's own sub-steps still give expm(AT) to 1e-7 at rtol 1e-8, and
    the trajectory is the one without sensitivities."""
    model, A = _linear("mass_spring_damper")
    still = model.simulate(10.0, x0=np.zeros(2), rtol=1e-8, atol=1e-10, sensitivity=True)
    plain = model.simulate(10.0, x0=np.zeros(2), rtol=1e-8, atol=1e-10)
    assert len(still.t) < 20 and np.array_equal(still.t, plain.t)
    ref = expm(A * 10.0)
    assert np.max(np.abs(still.sensitivity.final - ref)) < 1e-7 * np.max(np.abs(ref))


def _variational_reference(model, y0, p, t_end, seeds):
    """(x, Φ) at t_end from scipy's DOP853 on the variational system (x' = f, Φ' = J Φ) as one ODE
    at rtol 1e-13 — an independent integrator and formulation."""
    n, k = len(y0), seeds.shape[1]
    f, jac = model.functions.rhs, model.functions.jac
    pn = model.native_params(p)

    def rhs(t, z):
        y = z[:n]
        phi = np.asarray(jac(t, y, pn)) @ z[n:].reshape(n, k)
        return np.concatenate([f(t, y, pn), phi.ravel()])

    phi0 = np.vstack([seeds, np.zeros((2, k))])
    sol = solve_ivp(rhs, (0.0, t_end), np.concatenate([y0, phi0.ravel()]), method="DOP853",
                    rtol=1e-13, atol=1e-15)
    return sol.y[:n, -1], sol.y[n:, -1].reshape(n, k)[: model.n_states]


@pytest.mark.parametrize("backend", BACKENDS)
def test_pendulum_against_finite_differences_and_the_variational_ode(backend):
    """The nonlinear pendulum released at 1.2 rad (amplitude-dependent period): Φ(3 s) agrees with
    central differences of whole runs at rtol 1e-13 (step 1e-4: truncation ~1e-9) to 1e-7, and
    with the variational ODE integrated by DOP853 at 1e-13 to 1e-9 relative; on every back end."""
    model = compile_model(io.load("pendulum"), backend=backend)
    p = model.params({"theta0": 1.2})
    x0 = model.initial_state(p)
    traj = model.simulate(3.0, x0=x0, params={"theta0": 1.2}, rtol=1e-11, atol=1e-13,
                          sensitivity=True)
    phi = traj.sensitivity.final
    _, ref = _variational_reference(model, model.augment(x0), p, 3.0, np.eye(2))
    assert np.max(np.abs(phi - ref)) < 1e-9 * np.max(np.abs(ref))
    if backend == "c":          # the finite differences: 4 more runs, on the fast back end
        fd = np.empty((2, 2))
        for j in range(2):
            e = np.zeros(2)
            e[j] = 1e-4
            runs = [model.simulate(3.0, x0=x0 + s * e, params={"theta0": 1.2}, rtol=1e-13,
                                   atol=1e-15).x_final for s in (1, -1)]
            fd[:, j] = (runs[0] - runs[1]) / 2e-4
        assert np.max(np.abs(phi - fd)) < 1e-7 * np.max(np.abs(fd))


@pytest.mark.parametrize("other", ["c", NUMBA])
def test_back_ends_agree_and_the_trajectory_is_unchanged(other):
    """The pendulum's Φ from the numba and C loops agrees with the python loop's to 1e-9 (the
    same algorithm; the generated arithmetic differs in the last bits); with sensitivities the
    trajectory is the same, bit for bit, as without, on each back end (Φ does not enter the
    step-size control)."""
    finals = []
    for backend in ("python", other):
        model = compile_model(io.load("pendulum"), backend=backend)
        kwargs = {"params": {"theta0": 1.2}, "rtol": 1e-10, "atol": 1e-12}
        with_phi = model.simulate(3.0, sensitivity=True, **kwargs)
        without = model.simulate(3.0, **kwargs)
        assert np.array_equal(with_phi.t, without.t) and np.array_equal(with_phi.y, without.y)
        finals.append(with_phi.sensitivity.final)
    assert np.max(np.abs(finals[1] - finals[0])) < 1e-9 * np.max(np.abs(finals[0]))


def _fixed_step_phi(model, method: str, t_end: float, h: float) -> np.ndarray:
    """Φ(t_end) from the variational loop of ``method`` with constant steps h."""
    p = model.param_defaults
    y0 = model.augment(model.initial_state(p))
    n = len(y0)
    out = model.functions.variational[method](
        0.0, y0, t_end, p, 0.5, np.full(n, 1e10), h, h, np.zeros(0, dtype=np.int64),
        np.zeros(0, dtype=bool), -1, 0.0, model.n_states, 1e12, 10**6, 10**5,
        0.0 if model.autonomous else 1e-7, np.eye(n)[:, : model.n_states].copy(),
        np.zeros((0, model.n_states)))
    assert out[0] == 0
    return out[15][: model.n_states]


@pytest.mark.parametrize("name, method, order, h", [
    ("double_pendulum", "Rodas5P", 5, 0.02), ("double_pendulum", "Rodas4", 4, 0.01),
    ("modulated_spring", "Rodas5P", 5, 0.01)])
def test_phi_converges_at_the_order_of_the_method(name, method, order, h):
    """With constant steps h, h/2, h/4 Φ's error at t = 1 falls by 2^order (within 0.4): the
    variational step is the method itself on Φ' = A(t)Φ (modulated_spring: time-dependent
    stiffness, A'(t) includes ∂J/∂t). Reference: the variational ODE by DOP853 at 1e-13."""
    model = compile_model(io.load(name), backend="c")
    p = model.param_defaults
    y0 = model.augment(model.initial_state(p))
    _, ref = _variational_reference(model, y0, p, 1.0, np.eye(model.n_states))
    errors = [np.max(np.abs(_fixed_step_phi(model, method, 1.0, step) - ref))
              for step in (h, h / 2, h / 4)]
    for a, b in itertools.pairwise(errors):
        assert abs(math.log2(a / b) - order) < 0.4, errors


# --- events: the bouncing ball ---------------------------------------------------------------
def _ball(apex: bool = False) -> ph.CompiledModel:
    model = ball_model(ground_event=True)
    if apex:                    # the top of a flight: the momentum falls through 0
        model.event("apex", "ball.p", direction=-1)
    return compile_model(model, backend="c")


def _bounce(model):
    """The bounce v⁺ = −e v⁻ with its Jacobian."""
    ip = model.state_index("ball.p")
    R = np.eye(2)
    R[ip, ip] = -E

    def bounce(t, x, p):
        return ph.Reset(x=R @ x, jacobian=R)

    return bounce


def _to_state(model, J_zv: np.ndarray) -> np.ndarray:
    """A Jacobian in (height z, velocity v) as one in the model's states (q = z, p = m v)."""
    iq, ip = model.state_index("height.q"), model.state_index("ball.p")
    T = np.zeros((2, 2))            # state = T (z, v)
    T[iq, 0], T[ip, 1] = 1.0, MASS
    return T @ J_zv @ np.linalg.inv(T)


def _x0(model, z0: float, v0: float) -> np.ndarray:
    x = np.zeros(2)
    x[model.state_index("height.q")], x[model.state_index("ball.p")] = z0, MASS * v0
    return x


Z, V = sp.symbols("z v", real=True)
W = sp.sqrt(V**2 + 2 * G * Z)            # the speed at the ground from (z, v)
T_HIT = (V + W) / G                      # the time of the first bounce


def test_ball_phi_across_a_bounce_matches_the_closed_form():
    """From (z₀, v₀) = (1 m, 0.5 m/s) to T = 1 s, one bounce on the way: with the bounce at
    t_c = (v₀ + w)/g, w = √(v₀² + 2 g z₀), z(T) = e w (T − t_c) − g (T − t_c)²/2 and
    v(T) = e w − g (T − t_c); their Jacobian by (z₀, v₀) equals Φ(T) to 1e-10 relative; the
    saltation matrix is R + (f⁺ − R f⁻) g_xᵀ/(g_x f⁻) with the ground's g_x = e_q."""
    model = _ball()
    T = 1.0
    traj = model.simulate(T, x0=_x0(model, 1.0, 0.5), actions={"ground": _bounce(model)},
                          rtol=1e-11, atol=1e-13, sensitivity=True)
    assert [name for _, name in traj.events] == ["ground"]
    zT = E * W * (T - T_HIT) - G * (T - T_HIT) ** 2 / 2
    vT = E * W - G * (T - T_HIT)
    exact = np.array(sp.Matrix([zT, vT]).jacobian([Z, V]).subs({Z: 1.0, V: 0.5}), dtype=float)
    ref = _to_state(model, exact)
    sens = traj.sensitivity
    assert np.max(np.abs(sens.final - ref)) < 1e-10 * np.max(np.abs(ref))
    (cross,) = sens.crossings
    iq = model.state_index("height.q")
    np.testing.assert_allclose(cross.guard_gradient, np.eye(2)[iq], atol=1e-9)
    assert cross.guard_rate == 0.0 and not cross.stop
    S = saltation_matrix(cross.f_minus, cross.f_plus, cross.guard_gradient, cross.reset_jacobian)
    np.testing.assert_allclose(cross.saltation, S, rtol=1e-14)
    np.testing.assert_allclose(cross.phi_plus, S @ cross.phi_minus, rtol=1e-14)
    # the reset's Jacobian alone (no correction for the shifted crossing time) is wrong by O(1)
    after = sens.final @ np.linalg.inv(cross.phi_plus)           # the flow from the bounce to T
    reset_only = after @ cross.reset_jacobian @ cross.phi_minus
    assert np.max(np.abs(reset_only - ref)) > 0.1 * np.max(np.abs(ref))


def test_ball_stopping_at_the_bounce_gives_the_impact_map():
    """A run that stops at the bounce (the action's ``stop``) ends on the ground: its final Φ is
    the Jacobian of the state just after the bounce, (0, e w), by (z₀, v₀) — the saltation with
    f⁺ = 0, R_x (I − f⁻ g_xᵀ/(g_x f⁻)) — to 1e-10."""
    model = _ball()
    bounce = _bounce(model)

    def bounce_and_stop(t, x, p):
        r = bounce(t, x, p)
        return ph.Reset(x=r.x, jacobian=r.jacobian, stop=True)

    traj = model.simulate(2.0, x0=_x0(model, 1.0, 0.5), actions={"ground": bounce_and_stop},
                          rtol=1e-11, atol=1e-13, sensitivity=True)
    assert traj.status == "event"
    exact = np.array(sp.Matrix([0 * Z, E * W]).jacobian([Z, V]).subs({Z: 1.0, V: 0.5}),
                     dtype=float)
    sens = traj.sensitivity
    assert np.max(np.abs(sens.final - _to_state(model, exact))) < 1e-10
    np.testing.assert_array_equal(sens.phi[-1], sens.final)   # the point after the bounce
    assert sens.crossings[-1].stop and np.all(sens.crossings[-1].f_plus == 0)


def test_ball_apex_to_apex_map_is_e_squared():
    """Apex to apex: the height after a bounce is e² times the height before (h' = e² h). The run
    starts at (z₀, v₀ > 0), passes the first apex (an action that changes nothing: S = I),
    bounces and stops at the second apex (v = 0): there ∂z/∂(z₀, v₀) = e² (1, v₀/g) (as
    h = z₀ + v₀²/2g) and ∂v/∂x₀ = 0 (the section v = 0); on the section, coordinate z, the
    map's Jacobian is e²."""
    model = _ball(apex=True)
    z0, v0 = 0.6, 1.5
    count = []

    def apex(t, x, p):
        count.append(t)
        return ph.Reset(stop=len(count) == 2)

    traj = model.simulate(5.0, x0=_x0(model, z0, v0), actions={"ground": _bounce(model),
                                                              "apex": apex},
                          rtol=1e-11, atol=1e-13, sensitivity=True)
    assert [name for _, name in traj.events] == ["apex", "ground", "apex"]
    final = traj.sensitivity.final
    ref = _to_state(model, np.array([[E**2, E**2 * v0 / G], [0.0, 0.0]]))
    assert np.max(np.abs(final - ref)) < 1e-10
    first = traj.sensitivity.crossings[0]
    np.testing.assert_array_equal(first.saltation, np.eye(2))
    # in section coordinates: the section v = 0 parametrized by z (the lift) and its projection
    iq, ip = model.state_index("height.q"), model.state_index("ball.p")
    lift = surface_lift(np.eye(2)[ip], [iq])
    project = np.eye(2)[[iq]]
    # the map from the first apex: compose the flow from there with the stop's projection
    start = traj.sensitivity.crossings[0]
    k0 = np.searchsorted(traj.t, start.t, side="right")        # the point after the first apex
    from_apex = final @ np.linalg.inv(traj.sensitivity.phi[k0])
    assert section_jacobian(from_apex, project, lift)[0, 0] == pytest.approx(E**2, rel=1e-10)


def test_saltation_helpers():
    """The formulas on numbers: the projection along f onto g = 0 annihilates f and keeps the
    surface's tangent; compose multiplies in order; a grazing crossing gives NaN."""
    f, g = np.array([1.0, 2.0, 0.5]), np.array([0.0, 1.0, 1.0])
    P = section_projection(f, g)
    np.testing.assert_allclose(P @ f, 0.0, atol=1e-15)
    tangent = np.array([1.0, 1.0, -1.0])
    np.testing.assert_allclose(P @ tangent, tangent, atol=1e-15)
    np.testing.assert_allclose(g @ P, 0.0, atol=1e-15)
    A, B, C = (np.random.default_rng(k).normal(size=(3, 3)) for k in range(3))
    np.testing.assert_allclose(compose([A, B, C], [np.eye(3), 2 * np.eye(3)]), 2 * C @ B @ A)
    assert np.all(np.isnan(saltation_matrix(np.array([1.0, 0.0, 0.0]), f, g)))
    X = surface_lift(g, [0, 1])
    np.testing.assert_allclose(g @ X, 0.0, atol=1e-15)


def test_sensitivity_arguments_are_checked():
    model = _ball()
    with pytest.raises(OptionError, match="sensitivity"):
        model.simulate(1.0, sensitivity=np.ones((3, 1)))
    with pytest.raises(OptionError, match="finite"):
        model.simulate(1.0, sensitivity=np.full((2, 1), np.nan))
    with pytest.raises(ModelError, match="compiled method"):
        model.simulate(1.0, method="Radau", sensitivity=True)
    with pytest.raises(ModelError, match="gave no Jacobian"):
        model.simulate(1.0, actions={"ground": lambda t, x, p: ph.Reset(x=-x)}, sensitivity=True)
    seeds = model.simulate(0.1, sensitivity=[1.0, 0.0]).sensitivity.seeds
    assert seeds.shape == (2, 1)


def test_plastic_impact_jacobian():
    """impact_jacobian of the double pendulum's tip stopping (a plastic impact, G = J_tip): the
    momentum columns equal the linear map p⁺ = (I − Gᵀ(G M⁻¹ Gᵀ)⁻¹ G M⁻¹) p⁻ written with
    explicit inverses; the configuration columns (through M(q), G(q)) agree with a five-point
    difference of the map at a 100x larger step to 1e-8, within the estimated error plus that;
    positions are unchanged (identity rows)."""
    from porthamiltonian.simulation.impact import impact_jacobian, model_impact

    model = compile_model(io.load("double_pendulum"), backend="c")
    p = model.param_defaults
    x = np.array([0.7, -0.4, 0.3, -0.2])      # (q_shoulder, q_elbow, p_shoulder, p_elbow)
    d = impact_jacobian(model, x, p, ["arm.J.tip"], "arm.M")
    M = model.matrix("arm.M", 0.0, x, p)
    G = model.matrix("arm.J.tip", 0.0, x, p)
    Mi = np.linalg.inv(M)
    exact = np.eye(2) - G.T @ np.linalg.inv(G @ Mi @ G.T) @ G @ Mi
    np.testing.assert_allclose(d.value[2:, 2:], exact, atol=1e-12)
    np.testing.assert_array_equal(d.value[:2], np.eye(4)[:2])

    def momenta(q):
        return model_impact(model, np.concatenate([q, x[2:]]), p, ["arm.J.tip"],
                            "arm.M").x_plus[2:]

    h = 1e-3
    for j in range(2):
        e = np.zeros(2)
        e[j] = h
        five = (8 * (momenta(x[:2] + e) - momenta(x[:2] - e))
                - (momenta(x[:2] + 2 * e) - momenta(x[:2] - 2 * e))) / (12 * h)
        assert np.all(np.abs(d.value[2:, j] - five) <= d.error[2:, j] + 1e-8)
    assert d.max_error < 1e-8


def test_the_documented_example_runs():
    """docs/sensitivity.md's example: the ball dropped from 1 m bounces once within 1 s; its final
    Φ is the closed form of test_ball_phi_across_a_bounce_matches_the_closed_form at (1 m, 0)."""
    text = (Path(__file__).resolve().parents[2] / "docs" / "sensitivity.md").read_text()
    code = text.split("```python\n", 1)[1].split("```", 1)[0]
    scope: dict = {}
    exec(compile(code, "docs/sensitivity.md", "exec"), scope)  # noqa: S102 (the repository's own docs)
    s, model = scope["s"], scope["ball"]
    T = 1.0
    zT = E * W * (T - T_HIT) - G * (T - T_HIT) ** 2 / 2
    vT = E * W - G * (T - T_HIT)
    exact = np.array(sp.Matrix([zT, vT]).jacobian([Z, V]).subs({Z: 1.0, V: 0.0}), dtype=float)
    assert np.max(np.abs(s.final - _to_state(model, exact))) < 1e-6
    assert s.phi.shape[1:] == (2, 2) and len(s.crossings) == 1 and s.error <= 10

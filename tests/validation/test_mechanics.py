"""Validation of the multibody component (porthamiltonian.mechanics.Multibody) against closed forms
and independent derivations.

Each test names its reference and its tolerance. Models: models/pendulum.toml,
models/double_pendulum.toml, models/slider_arm.toml, models/walker_skeleton.toml, and a
6-coordinate walker skeleton with prismatic legs built here in Python (``walker6_model``).

References
----------
[Landau] L. D. Landau, E. M. Lifshitz, *Mechanics*, 3rd ed., 1976: §11 (period of a
         one-dimensional oscillation), problem 1 of §11 (pendulum period through the complete
         elliptic integral K), §29 (first anharmonic correction 1 + θ0²/16).
[Goldstein] H. Goldstein, C. Poole, J. Safko, *Classical Mechanics*, 3rd ed., 2002: §1.2
         (centre of mass moves as a particle under the external forces only), §8.1 (Hamilton's
         equations, p = ∂L/∂q̇).
[sympy.mechanics] sympy.physics.mechanics.LagrangesMethod: an independent Lagrangian derivation
         of the double pendulum (reference frames, points, rigid bodies), not the library's code.
[Garcia] M. Garcia, A. Chatterjee, A. Ruina, M. Coleman, "The simplest walking model", J. Biomech.
         Eng. 120 (1998): the compass-gait mass matrix (hip point mass, legs, point feet), written
         out by hand below for the skeleton of the thesis's walker (Table 2.3).

The Multibody type is registered by ``import porthamiltonian.mechanics`` (done here); loading a model
file should not need that import — see ``test_model_files_load_in_a_fresh_process`` and
``test_check_energy_passes_on_the_mechanics_models``, which run in fresh interpreters.
"""
from __future__ import annotations

import itertools
import math
import subprocess
import sys

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import quad
from scipy.special import ellipk

import porthamiltonian as ph
import porthamiltonian.mechanics
from porthamiltonian import Event, compile_model, io
from porthamiltonian.mechanics import Multibody

MECHANICS_MODELS = ["pendulum", "double_pendulum", "slider_arm", "walker_skeleton"]


def _pn(model, p):
    return model.native_params(p)


def outputs_at(model, x, p, t=0.0) -> dict[str, float]:
    """The named outputs of ``model`` at one model state."""
    values = model.functions.outputs(t, model.augment(x), _pn(model, p))
    return dict(zip(model.output_names, np.asarray(values, dtype=float)))


def rhs_at(model, x, p, t=0.0) -> np.ndarray:
    """dx/dt of the model states at one point."""
    return np.asarray(model.functions.rhs(t, model.augment(x), _pn(model, p)))[: model.n_states]


# --------------------------------------------------------------------------------------------
# Shipped model files, from a fresh interpreter
# --------------------------------------------------------------------------------------------
def test_model_files_load_in_a_fresh_process():
    """``io.load`` of a model file whose component type is "Multibody" works in a process that
    did not import porthamiltonian.mechanics (as the command line and any user script do)."""
    code = ("from porthamiltonian import io\n"
            f"for name in {MECHANICS_MODELS!r}:\n"
            "    io.load(name)\n"
            "print('loaded')\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         check=False)
    assert run.returncode == 0 and "loaded" in run.stdout, run.stdout + run.stderr


def test_check_energy_passes_on_the_mechanics_models(energy_check):
    """``porthamiltonian check-energy`` (C back end, a fresh interpreter: the session's run
    over every shipped model, tests/conftest.py) closes the energy balance of each mechanics
    model with its own [simulation] settings and energy_tolerance."""
    for name in MECHANICS_MODELS:
        assert f"ok   {name}" in energy_check.run.stdout, energy_check.run.stdout


# --------------------------------------------------------------------------------------------
# Pendulum: period, small and large amplitude
# --------------------------------------------------------------------------------------------
def pendulum_periods(model, theta0, l, g, r_g=0.0, periods=3):
    """Periods of models/pendulum.toml released from theta0 at rest, from successive downward
    zero crossings of θ (a non-terminal event located by root finding on the DOP853 interpolant,
    rtol 1e-13)."""
    iq = model.state_index("pendulum.q.pivot")
    l_eq = (l**2 + r_g**2) / l
    t_end = (periods + 0.5) * 4 * math.sqrt(l_eq / g) * ellipk(math.sin(theta0 / 2) ** 2)
    crossing = Event("down", lambda t, x, p: x[iq], direction=-1, terminal=False)
    traj = model.simulate(t_end, params={"theta0": theta0, "l": l, "g": g, "r_g": r_g},
                          events=[crossing], method="DOP853", rtol=1e-13, atol=1e-15)
    assert traj.status == "finished", traj.message
    times = np.array([t for t, name in traj.events if name == "down"])
    assert len(times) == periods + 1, times
    return np.diff(times), traj


@pytest.mark.parametrize("r_g", [0.0, 0.3])
def test_pendulum_small_amplitude_period(compile_named, r_g):
    """θ0 = 0.01 rad: T = 2π√(l_eq/g) [Landau §11] to 1e-4 relative; with the first anharmonic
    correction, T = 2π√(l_eq/g)(1 + θ0²/16) [Landau §29], to 1e-9 relative (the next term of
    the series of K, 11θ0⁴/3072 = 3.6e-11, is what remains: it is resolved too, to 1e-12, with
    the two-term series). l_eq = (l² + r_g²)/l is the equivalent length of a body of radius of
    gyration r_g about its centre of mass (r_g = 0: point mass)."""
    model = compile_named("pendulum")
    theta0, l, g = 0.01, 0.8, 9.81
    periods, _ = pendulum_periods(model, theta0, l, g, r_g)
    T0 = 2 * math.pi * math.sqrt((l**2 + r_g**2) / l / g)
    for T in periods:
        assert abs(T - T0) / T0 < 1e-4, (T, T0)
        assert abs(T - T0 * (1 + theta0**2 / 16)) / T0 < 1e-9, (T, T0 * (1 + theta0**2 / 16))
        series = T0 * (1 + theta0**2 / 16 + 11 * theta0**4 / 3072)
        assert abs(T - series) / T0 < 1e-12, (T, series)


def test_pendulum_large_amplitude_period_is_the_elliptic_integral(compile_named):
    """θ0 = 2 rad: T = 4√(l/g) K(k), k = sin(θ0/2) [Landau §11 problem 1] (scipy's ellipk takes
    m = k²), to 1e-10 relative (asked: 1e-7; measured ~1e-14) for each of three successive
    periods; the energy ledger closes to 1e-10."""
    model = compile_named("pendulum")
    theta0, l, g = 2.0, 1.3, 9.81
    periods, traj = pendulum_periods(model, theta0, l, g)
    T_exact = 4 * math.sqrt(l / g) * ellipk(math.sin(theta0 / 2) ** 2)
    assert np.max(np.abs(periods - T_exact)) / T_exact < 1e-10, (periods, T_exact)
    assert traj.relative_residual < 1e-10


# --------------------------------------------------------------------------------------------
# Double pendulum against sympy.physics.mechanics
# --------------------------------------------------------------------------------------------
DP_PARAMS = ("m1", "l1", "m2", "l2", "g")


@pytest.fixture(scope="module")
def double_pendulum_reference():
    """The double pendulum of models/double_pendulum.toml derived with sympy.physics.mechanics
    [sympy.mechanics]: rods of mass m_i, length l_i, centre of mass at l_i/2 and inertia
    m_i l_i²/12 (about every axis, as in the model file), joint angles q1 (rod 1 from the
    downward vertical) and q2 (rod 2 relative to rod 1), both about +y; gravity −g ẑ.

    Returns numeric functions of (q1, q2, u1, u2, m1, l1, m2, l2, g): the mass matrix M(q) of
    the Lagrangian, the forcing F(q, u) (M q̈ = F), Ṁ(q, u) = dM/dt, and the energy T + V."""
    import sympy.physics.mechanics as me

    q1, q2 = me.dynamicsymbols("q1 q2")
    u1, u2 = me.dynamicsymbols("q1 q2", 1)
    m1, l1, m2, l2, g = sp.symbols("m1 l1 m2 l2 g", positive=True)
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [q1, N.y])
    B = A.orientnew("B", "Axis", [q2, A.y])
    O = me.Point("O")
    O.set_vel(N, 0)
    G1 = O.locatenew("G1", -l1 / 2 * A.z)
    E = O.locatenew("E", -l1 * A.z)
    G2 = E.locatenew("G2", -l2 / 2 * B.z)
    G1.v2pt_theory(O, N, A)
    E.v2pt_theory(O, N, A)
    G2.v2pt_theory(E, N, B)
    I1, I2 = m1 * l1**2 / 12, m2 * l2**2 / 12
    rod1 = me.RigidBody("rod1", G1, A, m1, (me.inertia(A, I1, I1, I1), G1))
    rod2 = me.RigidBody("rod2", G2, B, m2, (me.inertia(B, I2, I2, I2), G2))
    rod1.potential_energy = m1 * g * G1.pos_from(O).dot(N.z)
    rod2.potential_energy = m2 * g * G2.pos_from(O).dot(N.z)
    lagrangian = me.Lagrangian(N, rod1, rod2)
    lm = me.LagrangesMethod(lagrangian, [q1, q2])
    lm.form_lagranges_equations()
    M, F = lm.mass_matrix, lm.forcing
    t = me.dynamicsymbols._t
    Mdot = M.diff(t)
    energy = (me.kinetic_energy(N, rod1, rod2) + me.potential_energy(rod1, rod2))
    Q1, Q2, U1, U2 = sp.symbols("Q1 Q2 U1 U2")
    plain = {u1: U1, u2: U2}
    plain_q = {q1: Q1, q2: Q2}

    def numeric(expr):
        expr = sp.sympify(expr).subs(plain).subs(plain_q)
        assert not expr.atoms(sp.Derivative) and not expr.atoms(sp.Function) - expr.atoms(
            sp.sin, sp.cos), expr
        return sp.lambdify((Q1, Q2, U1, U2, m1, l1, m2, l2, g), expr, "numpy")

    return {"M": numeric(M), "F": numeric(F), "Mdot": numeric(Mdot), "E": numeric(energy)}


def test_double_pendulum_matches_sympy_mechanics(compile_named, double_pendulum_reference):
    """At 100 random states (angles in [−π, π], joint velocities in [−5, 5] rad/s) and random
    parameters (×0.5–2 the defaults): the library's mass matrix ``arm.M`` equals the Lagrangian's
    M(q) [sympy.mechanics], and with the library state (q, p = M q̇) the library's right-hand side
    gives q̇ and ṗ = d/dt(M q̇) = Ṁ q̇ + M q̈ = Ṁ q̇ + F(q, q̇), each to 1e-10 relative to the
    size of the compared terms; H equals T + V of the sympy model to 1e-12."""
    model = compile_named("double_pendulum")
    ref = double_pendulum_reference
    idx = [model.state_index(n) for n in ("arm.q.shoulder", "arm.q.elbow_joint",
                                          "arm.p.shoulder", "arm.p.elbow_joint")]
    rng = np.random.default_rng(31)
    defaults = model.params()
    for _ in range(100):
        values = {name: defaults[model.param_names.index(name)] * rng.uniform(0.5, 2.0)
                  for name in DP_PARAMS}
        p = model.params(values)
        args_p = [values[n] for n in DP_PARAMS]
        q = rng.uniform(-math.pi, math.pi, 2)
        u = rng.uniform(-5.0, 5.0, 2)
        M_ref = np.asarray(ref["M"](*q, *u, *args_p), dtype=float)
        x = np.zeros(model.n_states)
        x[idx[:2]] = q
        x[idx[2:]] = M_ref @ u
        M_lib = model.matrix("arm.M", 0.0, x, p)
        assert np.max(np.abs(M_lib - M_ref)) <= 1e-10 * np.max(np.abs(M_ref)), (M_lib, M_ref)
        dx = rhs_at(model, x, p)
        assert np.max(np.abs(dx[idx[:2]] - u)) <= 1e-10 * np.max(np.abs(u))
        Mdot = np.asarray(ref["Mdot"](*q, *u, *args_p), dtype=float)
        F = np.asarray(ref["F"](*q, *u, *args_p), dtype=float).ravel()
        pdot_ref = Mdot @ u + F
        scale = np.max(np.abs(Mdot @ u)) + np.max(np.abs(F))
        assert np.max(np.abs(dx[idx[2:]] - pdot_ref)) <= 1e-10 * scale, (dx[idx[2:]], pdot_ref)
        H = model.energy(0.0, x, p)[0]
        E_ref = float(ref["E"](*q, *u, *args_p))
        assert abs(H - E_ref) <= 1e-12 * max(1.0, abs(E_ref)), (H, E_ref)


@pytest.mark.parametrize("backend", ["python", pytest.param("numba", marks=pytest.mark.numba_loop)])
def test_double_pendulum_conserves_energy_over_20_s(double_pendulum_reference, backend):
    """Released from (1.2, −0.6) rad at rest (chaotic regime), DOP853 at rtol 1e-11 for 20 s:
    the ledger residual |H − H(0)| stays below 1e-8 of the energy scale, and so does the drift of
    the independently computed T + V of the sympy model along the stored steps, for the python
    and numba back ends."""
    model = compile_model(io.load("double_pendulum"), backend=backend)
    traj = model.simulate(20.0, method="DOP853", rtol=1e-11, atol=1e-12)
    assert traj.status == "finished", traj.message
    assert traj.relative_residual < 1e-8, traj.ledger()
    p = model.params()
    args_p = [p[model.param_names.index(n)] for n in DP_PARAMS]
    iq = [model.state_index("arm.q.shoulder"), model.state_index("arm.q.elbow_joint")]
    energies = []
    for x in traj.x[:: max(1, len(traj.t) // 200)]:
        u = rhs_at(model, x, p)[iq]
        energies.append(float(double_pendulum_reference["E"](*x[iq], *u, *args_p)))
    energies = np.array(energies)
    assert np.max(np.abs(energies - energies[0])) < 1e-8 * traj.energy_scale
    # the motion is not trivial: the elbow turns by more than 1 rad
    assert np.ptp(traj["arm.q.elbow_joint"]) > 1.0


# --------------------------------------------------------------------------------------------
# Walker skeleton: compass-gait mass matrix and free fall
# --------------------------------------------------------------------------------------------
WALKER = {"M": 3.0, "m_l": 0.01, "m_f": 0.1, "L": 0.7, "g": 9.81}


def walker4_mass_matrix(q, M, m_l, m_f, L, **_):
    """Compass-gait mass matrix [Garcia; the thesis's Table 2.3] in (hip x, hip z, θ1, θ2), θ_i the
    absolute leg angles from the downward vertical, positive about +y (a foot at
    (x − L sin θ, z − L cos θ)). Uniform legs (m_l, centre at L/2, inertia m_l L²/12), point
    feet m_f at the leg ends, point hip mass M. From T = ½ Σ m |ṙ|² + ½ Σ I θ̇²:
      M_xx = M_zz = M + 2 m_l + 2 m_f,  M_xz = 0,
      M_xθi = −a cos θi,  M_zθi = a sin θi,  a = L (m_l/2 + m_f),
      M_θiθi = m_l L²/4 + m_l L²/12 + m_f L² = L² (m_l/3 + m_f),  M_θ1θ2 = 0."""
    _, _, t1, t2 = q
    mt = M + 2 * m_l + 2 * m_f
    a = L * (m_l / 2 + m_f)
    J = L**2 * (m_l / 3 + m_f)
    return np.array([[mt, 0, -a * math.cos(t1), -a * math.cos(t2)],
                     [0, mt, a * math.sin(t1), a * math.sin(t2)],
                     [-a * math.cos(t1), a * math.sin(t1), J, 0],
                     [-a * math.cos(t2), a * math.sin(t2), 0, J]])


def walker6_mass_matrix(q, M, m_l, m_f, L, **_):
    """The 6-coordinate skeleton (hip x, z, θ1, θ2, d1, d2): each foot slides along its leg axis,
    at distance r_i = L + d_i from the hip, the leg itself (centre at L/2) does not stretch:
      M_xx = M_zz = M + 2 m_l + 2 m_f,
      M_xθi = −(m_l L/2 + m_f r_i) cos θi,  M_zθi = (m_l L/2 + m_f r_i) sin θi,
      M_xdi = −m_f sin θi,  M_zdi = −m_f cos θi,
      M_θiθi = m_l L²/3 + m_f r_i²,  M_didi = m_f,  M_θidi = 0, legs uncoupled."""
    _, _, t1, t2, d1, d2 = q
    mt = M + 2 * m_l + 2 * m_f
    out = np.zeros((6, 6))
    out[0, 0] = out[1, 1] = mt
    for th, d, i, k in ((t1, d1, 2, 4), (t2, d2, 3, 5)):
        r = L + d
        s, c = math.sin(th), math.cos(th)
        out[0, i] = out[i, 0] = -(m_l * L / 2 + m_f * r) * c
        out[1, i] = out[i, 1] = (m_l * L / 2 + m_f * r) * s
        out[0, k] = out[k, 0] = -m_f * s
        out[1, k] = out[k, 1] = -m_f * c
        out[i, i] = m_l * L**2 / 3 + m_f * r**2
        out[k, k] = m_f
    return out


def walker6_model() -> ph.Model:
    """The walker skeleton of models/walker_skeleton.toml with each foot on a prismatic joint
    along its leg axis (axis [0, 0, −1] in the leg frame at the leg end: d > 0 lengthens the
    leg): 6 coordinates walker.q.hip.x|z, theta1, theta2, ext1, ext2. No springs: a bare
    skeleton, for the mass matrix and the energy balance."""
    model = ph.Model("walker6_skeleton")  # compass-walker skeleton with prismatic (telescopic) legs
    units = {"M": "kg", "m_l": "kg", "m_f": "kg", "L": "m", "g": "m/s^2"}
    for name, value in WALKER.items():
        model.parameter(name, value, units[name])
    leg = {"mass": "m_l", "com": [0, 0, "-L/2"], "inertia": ["m_l*L**2/12"] * 3}
    bodies = {"hip_body": {"mass": "M", "inertia": 0},
              "leg1": dict(leg), "leg2": dict(leg),
              "foot1_body": {"mass": "m_f", "inertia": 0, "points": {"foot1": [0, 0, 0]}},
              "foot2_body": {"mass": "m_f", "inertia": 0, "points": {"foot2": [0, 0, 0]}}}
    joints = {"hip": {"type": "translational", "parent": "world", "child": "hip_body",
                      "axes": ["x", "z"], "q0": [1.0, 0.7405]},
              "theta1": {"type": "revolute", "parent": "hip_body", "child": "leg1", "axis": "y",
                         "q0": 0.15},
              "theta2": {"type": "revolute", "parent": "hip_body", "child": "leg2", "axis": "y",
                         "q0": -0.15},
              "ext1": {"type": "prismatic", "parent": "leg1", "child": "foot1_body",
                       "axis": [0, 0, -1], "origin": [0, 0, "-L"]},
              "ext2": {"type": "prismatic", "parent": "leg2", "child": "foot2_body",
                       "axis": [0, 0, -1], "origin": [0, 0, "-L"]}}
    model.add("walker", Multibody(bodies=bodies, joints=joints, gravity=[0, 0, "-g"], plane="xz"))
    return model


@pytest.fixture(scope="module")
def walker6(isolated_cache):
    return compile_model(walker6_model(), backend="python")


W4_Q = ["walker.q.hip.x", "walker.q.hip.z", "walker.q.theta1", "walker.q.theta2"]
W6_Q = W4_Q + ["walker.q.ext1", "walker.q.ext2"]


@pytest.mark.parametrize("variant", ["4 coordinates", "6 coordinates"])
def test_walker_mass_matrix_matches_hand_derivation(compile_named, walker6, variant):
    """``walker.M`` of the 4-coordinate skeleton (models/walker_skeleton.toml) and of the
    6-coordinate one (``walker6_model``) equal ``walker4_mass_matrix`` / ``walker6_mass_matrix``
    at 100 random states (angles in [−π, π], hip in [−2, 2] m, extensions in [−0.2, 0.2] m,
    momenta random) and random parameters (×0.5–2) to 1e-12 relative to max |M|. The state
    order is the joint order (hip x, z, θ1, θ2[, d1, d2])."""
    model = compile_named("walker_skeleton") if variant == "4 coordinates" else walker6
    names, hand = (W4_Q, walker4_mass_matrix) if variant == "4 coordinates" else \
        (W6_Q, walker6_mass_matrix)
    assert model.state_names[: len(names)] == names
    rng = np.random.default_rng(7)
    n = len(names)
    for _ in range(100):
        values = {k: v * rng.uniform(0.5, 2.0) for k, v in WALKER.items()}
        p = model.params(values)
        q = np.concatenate([rng.uniform(-2, 2, 2), rng.uniform(-math.pi, math.pi, 2),
                            rng.uniform(-0.2, 0.2, n - 4)])
        x = np.concatenate([q, rng.normal(size=n)])
        M_lib = model.matrix("walker.M", 0.0, x, p)
        M_hand = hand(q, **values)
        assert np.max(np.abs(M_lib - M_hand)) <= 1e-12 * np.max(np.abs(M_hand)), (M_lib, M_hand)


def test_walker_foot_jacobians_match_hand_derivation(compile_named):
    """``walker.J.foot1`` / ``walker.J.foot2`` (for impact maps) are the Jacobians of the foot
    positions (x − L sin θi, z − L cos θi) in (x, z, θ1, θ2): rows [1, 0, −L cos θ1, 0] and
    [0, 1, L sin θ1, 0] for foot 1 (and θ2 in the fourth column for foot 2), to 1e-14; the
    outputs walker.foot1.x|z equal the positions to 1e-14."""
    model = compile_named("walker_skeleton")
    L = WALKER["L"]
    p = model.params()
    rng = np.random.default_rng(3)
    for _ in range(20):
        q = np.concatenate([rng.uniform(-2, 2, 2), rng.uniform(-math.pi, math.pi, 2)])
        x = np.concatenate([q, np.zeros(4)])
        out = outputs_at(model, x, p)
        for i, th in ((1, q[2]), (2, q[3])):
            J = model.matrix(f"walker.J.foot{i}", 0.0, x, p)
            expected = np.zeros((2, 4))
            expected[0, 0] = expected[1, 1] = 1
            expected[0, 1 + i] = -L * math.cos(th)
            expected[1, 1 + i] = L * math.sin(th)
            assert np.max(np.abs(J - expected)) < 1e-14, (i, J, expected)
            assert abs(out[f"walker.foot{i}.x"] - (q[0] - L * math.sin(th))) < 1e-14
            assert abs(out[f"walker.foot{i}.z"] - (q[1] - L * math.cos(th))) < 1e-14


def _walker_com(model, x, p, legs_extend):
    """Centre of mass (x, z) of the whole skeleton from the point outputs: hip, feet, and the
    leg centres at hip + L/2 (foot − hip)/|foot − hip| (at the midpoint when the legs do not
    extend)."""
    out = outputs_at(model, x, p)
    v = dict(zip(model.param_names, p))
    hip = np.array([x[0], x[1]])
    total = v["M"] * hip
    for i in (1, 2):
        foot = np.array([out[f"walker.foot{i}.x"], out[f"walker.foot{i}.z"]])
        axis = (foot - hip) / np.linalg.norm(foot - hip)
        centre = hip + v["L"] / 2 * axis if legs_extend else (hip + foot) / 2
        total = total + v["m_l"] * centre + v["m_f"] * foot
    return total / (v["M"] + 2 * v["m_l"] + 2 * v["m_f"])


@pytest.mark.parametrize("variant", ["4 coordinates", "6 coordinates"])
def test_walker_free_fall_centre_of_mass_is_a_parabola(compile_named, walker6, variant):
    """Without contact only gravity acts, so the centre of mass of the whole skeleton falls as a
    particle [Goldstein §1.2]: with zero total momentum at t = 0 (p_hip.x = p_hip.z = 0: the
    momenta conjugate to the hip translation are the total linear momentum) and swinging legs,
    z_com(t) = z_com(0) − g t²/2 and x_com(t) = x_com(0), to 1e-10 m over 0.6 s (DOP853, rtol
    1e-12), while each leg turns by more than 0.5 rad and the hip itself does not follow the
    parabola (its deviation exceeds 1 mm). The ledger closes to 1e-10."""
    model = compile_named("walker_skeleton") if variant == "4 coordinates" else walker6
    p = model.params()
    g = WALKER["g"]
    x0 = model.initial_state(p)
    x0[model.state_index("walker.p.theta1")] = 0.3
    x0[model.state_index("walker.p.theta2")] = -0.2
    if variant == "6 coordinates":
        x0[model.state_index("walker.p.ext1")] = 0.01
    t_end = 0.6
    traj = model.simulate(t_end, x0=x0, method="DOP853", rtol=1e-12, atol=1e-13,
                          dense_output=True)
    assert traj.status == "finished", traj.message
    assert traj.relative_residual < 1e-10
    extend = variant == "6 coordinates"
    com0 = _walker_com(model, x0, p, extend)
    hip_dev = 0.0
    for t in np.linspace(0.0, t_end, 31):
        x = traj.sol(t)
        com = _walker_com(model, x, p, extend)
        assert abs(com[0] - com0[0]) < 1e-10, (t, com, com0)
        assert abs(com[1] - (com0[1] - g * t**2 / 2)) < 1e-10, (t, com, com0)
        hip_dev = max(hip_dev, abs(x[1] - (x0[1] - g * t**2 / 2)))
    xf = traj.x_final
    for name in ("walker.q.theta1", "walker.q.theta2"):
        assert abs(xf[model.state_index(name)] - x0[model.state_index(name)]) > 0.5
    assert hip_dev > 1e-3


# --------------------------------------------------------------------------------------------
# Slider arm: spring-damper on the rail
# --------------------------------------------------------------------------------------------
def test_slider_arm_energy_balance(model_run, model_settings):
    """models/slider_arm.toml with its own settings: the ledger H − H(0) + E_diss − E_in stays
    below its energy_tolerance (1e-8) of the energy scale while the damper dissipates more than a
    tenth of the initial energy (so the balance is not trivially closed), and E_diss equals
    ∫ c ṡ² dt computed from the dense output by quadrature, to 1e-7 relative."""
    model, traj = model_run("slider_arm")
    sim = model_settings("slider_arm")
    assert traj.status == "finished", traj.message
    assert traj.relative_residual < float(sim["energy_tolerance"]), traj.ledger()
    E_diss = traj.ledger()["dissipated"]
    p = model.params()
    H_rest = model.energy(0.0, np.zeros(model.n_states), p)[0]  # cart at 0, arm hanging, at rest
    assert E_diss > 0.1 * (traj.H[0] - H_rest), (E_diss, traj.H[0], H_rest)
    c = p[model.param_names.index("c")]
    i_s = model.state_index("arm.q.slide")

    def power(t):
        return c * rhs_at(model, traj.sol(t), p, t)[i_s] ** 2

    t_end = float(sim["t_end"])
    grid = np.linspace(0.0, t_end, 41)
    quadrature = sum(quad(power, a, b, epsabs=0, epsrel=1e-12, limit=200)[0]
                     for a, b in itertools.pairwise(grid))
    assert abs(quadrature - E_diss) < 1e-7 * E_diss, (quadrature, E_diss)


def test_slider_arm_centre_of_mass_moves_under_the_rail_force_only(model_run):
    """The rail spring-damper is the only horizontal external force (gravity is vertical and the
    rail's reaction is normal to it), so m_tot ẍ_com = −k s − c ṡ [Goldstein §1.2]. Integrated
    twice from rest at t = 0: m_tot (x_com(t) − x_com(0)) = −k ∫₀ᵗ (t − σ) s dσ − c (∫₀ᵗ s dσ −
    t s(0)), with x_com from the point outputs (cart centre and arm centre, positions only) and
    s(σ) from the dense output, checked at t = 2, 5 and 10 s to 1e-9 of m_tot·s(0). Also the
    momentum conjugate to the rail coordinate is the total horizontal momentum:
    p_s = m_c ṡ + m_a ẋ_arm-centre, to 1e-12."""
    model, traj = model_run("slider_arm")
    p = model.params()
    v = dict(zip(model.param_names, p))
    mt = v["m_c"] + v["m_a"]
    i_s = model.state_index("arm.q.slide")

    def com_x(x):
        out = outputs_at(model, x, p)
        return (v["m_c"] * out["arm.cart_centre.x"] + v["m_a"] * out["arm.link_centre.x"]) / mt

    def s(t):
        return traj.sol(t)[i_s]

    x0 = traj.sol(0.0)
    s0 = x0[i_s]
    com0 = com_x(x0)
    for t in (2.0, 5.0, 10.0):
        grid = np.linspace(0.0, t, int(8 * t) + 1)
        int_s = sum(quad(s, a, b, epsabs=0, epsrel=1e-12)[0] for a, b in itertools.pairwise(grid))
        int_ts = sum(quad(lambda u, t=t: (t - u) * s(u), a, b, epsabs=0, epsrel=1e-12)[0]
                     for a, b in itertools.pairwise(grid))
        expected = -v["k"] * int_ts - v["c"] * (int_s - t * s0)
        got = mt * (com_x(traj.sol(t)) - com0)
        assert abs(got - expected) < 1e-9 * mt * abs(s0), (t, got, expected)
    # generalized momentum of the rail = total horizontal momentum (velocities by the chain rule
    # of the point outputs along the state equations: a central difference in time)
    rng = np.random.default_rng(5)
    for _ in range(10):
        x = np.array(traj.sol(rng.uniform(0.0, 10.0)))
        dx = rhs_at(model, x, p)
        h = 1e-6
        plus, minus = outputs_at(model, x + h * dx, p), outputs_at(model, x - h * dx, p)
        vel = {k: (plus[k] - minus[k]) / (2 * h) for k in ("arm.cart_centre.x", "arm.link_centre.x")}
        momentum = v["m_c"] * vel["arm.cart_centre.x"] + v["m_a"] * vel["arm.link_centre.x"]
        p_s = x[model.state_index("arm.p.slide")]
        assert abs(momentum - p_s) < 1e-8 * max(1.0, abs(p_s)), (momentum, p_s)


def test_slider_arm_spring_pulls_the_cart_back(compile_named):
    """Sign of the joint port (bond "arm.slide -> rail"): with the arm hanging still and the
    cart displaced by s > 0, the rail force on the cart is −k s, i.e. ṗ_s = −k s at rest."""
    model = compile_named("slider_arm")
    p = model.params()
    x = np.zeros(model.n_states)
    x[model.state_index("arm.q.slide")] = 0.2
    x[model.state_index("spring.q")] = 0.2
    dx = rhs_at(model, x, p)
    k = p[model.param_names.index("k")]
    assert dx[model.state_index("arm.p.slide")] == pytest.approx(-k * 0.2, rel=1e-14)
    assert dx[model.state_index("arm.p.hinge")] == 0.0


# --------------------------------------------------------------------------------------------
# Power balance at random states
# --------------------------------------------------------------------------------------------
def _power_scale(model, t, x, p, h=1e-6):
    """Σ_i |∂H/∂x_i ẋ_i| + P_diss + |P_in|: the size of the terms of the power balance
    (∂H/∂x_i by central differences)."""
    y = model.augment(x)
    pn = _pn(model, p)
    dx = np.asarray(model.functions.rhs(t, y, pn))
    total = 0.0
    for i in range(model.n_states):
        e = np.zeros_like(y)
        e[i] = h * max(1.0, abs(y[i]))
        dH = (model.functions.energy(t, y + e, pn)[0] - model.functions.energy(t, y - e, pn)[0])
        total += abs(dH / (2 * e[i]) * dx[i])
    _, p_diss, p_in = model.energy(t, y, p)
    return total + abs(p_diss) + abs(p_in)


@pytest.mark.parametrize("name", MECHANICS_MODELS + ["walker6"])
def test_power_balance_vanishes_at_random_states(compile_named, walker6, name):
    """CompiledModel.power_balance (dH/dt along ẋ by a central difference, minus P_in plus
    P_diss) is below 1e-9 of the power scale (sum of the absolute power terms |∂H/∂x_i ẋ_i| +
    P_diss + |P_in|) at 50 random states (coordinates in [−2, 2], momenta in [−1, 1]) with
    random parameters (×0.5–2 the defaults)."""
    model = walker6 if name == "walker6" else compile_named(name)
    rng = np.random.default_rng(11)
    n = model.n_states
    defaults = model.params()
    worst = 0.0
    for _ in range(50):
        p = defaults * rng.uniform(0.5, 2.0, len(defaults))
        x = np.array([rng.uniform(-2, 2) if ".q." in s or s.endswith(".q") else rng.uniform(-1, 1)
                      for s in model.state_names])
        assert len(x) == n
        balance = model.power_balance(0.0, x, p)
        scale = _power_scale(model, 0.0, x, p)
        worst = max(worst, abs(balance) / scale)
    assert worst < 1e-9, worst  # measured ≤ 1e-10

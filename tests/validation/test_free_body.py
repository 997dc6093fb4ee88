"""Validation of the free rigid body in Lie–Poisson form (``FreeBody``).

Checked against independent references, each named in its test:

* conservation of kinetic energy and of |L| for the torque-free body [MR ch. 15; LL §36];
* stability of steady rotation about the major and minor principal axes and instability about the
  intermediate one [MR §15.10; LL §37, problem 1];
* the body angular velocity against scipy's solve_ivp on Euler's equations I ω̇ = (I ω) × ω [LL
  §36, eq. 36.5] written here independently (the only check that catches a sign error in the
  Lie–Poisson term: energy and |L| are conserved with either sign), and the orientation against
  an independent integration of Ṙ = R ω̃ with scipy's quaternion convention;
* the centre of mass under uniform gravity against the closed-form parabola [LL §31: the centre
  of mass moves as a particle of mass m under the total external force];
* the energy ledger: pointwise power balance dH/dt = P_in − P_diss (numeric), and the residual of
  the shipped model's own simulation below its energy_tolerance;
* the sign of the ``body`` port, both orientations, with test-only screw elements: a viscous
  screw damper (ω and |v| decay as e^{−c t/I} and e^{−c t/m}) and a constant body wrench source
  (ṗ = F on a non-rotating body).

Tolerances are stated in each test, relative to a named scale. Integration: DOP853 at
rtol = 1e-12, atol = 1e-14 unless stated.

References
----------
[MR] J. E. Marsden, T. S. Ratiu, *Introduction to Mechanics and Symmetry*, 2nd ed., Springer 1999,
     ch. 15 (the free rigid body; Lie–Poisson form; §15.10 stability of rotations).
[LL] L. D. Landau, E. M. Lifshitz, *Mechanics*, 3rd ed., Pergamon 1976, §31, §36–37.
[SB] S. Stramigioli, H. Bruyninckx, *Geometry and Screw Theory for Robotics*, IEEE ICRA 2001
     tutorial (body momentum equation Ṗ = ad*_T P + W).
"""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import porthamiltonian as ph
from porthamiltonian import compile_model
from porthamiltonian.mechanics import FreeBody

TIGHT = {"method": "DOP853", "rtol": 1e-12, "atol": 1e-14}
XYZ = ("x", "y", "z")

# body with an offset centre of mass and a full (non-principal) inertia matrix, for the tests
# where the body-frame origin is not the centre of mass
# kg m^2: SPD, and a body's (principal moments 0.884, 1.663, 2.453 obey the triangle inequality)
I_FULL = np.array([[0.9, 0.1, -0.05], [0.1, 1.7, 0.2], [-0.05, 0.2, 2.4]])
COM = np.array([0.1, -0.05, 0.2])                                             # m, body frame
QUAT0 = np.array([0.9, 0.2, -0.3, 0.25]) / np.linalg.norm([0.9, 0.2, -0.3, 0.25])  # (w, x, y, z)


def offset_body_model() -> ph.Model:
    """A FreeBody whose every datum is a parameter (one compile serves all cases)."""
    m = ph.Model("offset_free_body")   # free body with offset CoM and full inertia matrix
    m.parameter("m", 2.5, "kg")
    m.parameter("g", 9.81, "m/s^2")
    names = {}
    for i in range(3):
        for j in range(i, 3):
            names[(i, j)] = names[(j, i)] = f"I{i + 1}{j + 1}"
            m.parameter(f"I{i + 1}{j + 1}", float(I_FULL[i, j]), "kg*m^2")
    for a, c in zip(XYZ, COM):
        m.parameter(f"c{a}", float(c), "m")
    for a, r in zip(XYZ, [0.3, -0.2, 1.0]):
        m.parameter(f"r{a}0", r, "m")
    for a, q in zip("wxyz", QUAT0):
        m.parameter(f"q{a}0", float(q))
    for a, w in zip(XYZ, [0.7, -1.1, 0.5]):
        m.parameter(f"w{a}0", w, "rad/s")
    for a, v in zip(XYZ, [1.2, 0.4, 3.0]):
        m.parameter(f"v{a}0", v, "m/s")
    m.add("body", FreeBody(
        mass="m", inertia=[[names[(i, j)] for j in range(3)] for i in range(3)],
        com=[f"c{a}" for a in XYZ], gravity=[0, 0, "-g"],
        position0=[f"r{a}0" for a in XYZ], quaternion0=[f"q{a}0" for a in "wxyz"],
        omega0=[f"w{a}0" for a in XYZ], v0=[f"v{a}0" for a in XYZ]))
    return m


@pytest.fixture(scope="module")
def shipped(compile_named):
    """models/free_rigid_body.toml compiled (I = 1, 2, 3 kg m², no gravity, com at the origin)."""
    return compile_named("free_rigid_body")


@pytest.fixture(scope="module")
def offset(isolated_cache):
    return compile_model(offset_body_model(), backend="python")


def omega_of(model, traj) -> np.ndarray:
    """Body angular velocity over the stored times, shape (len(t), 3)."""
    return np.column_stack([traj[f"body.omega.{a}"] for a in XYZ])


def euler_reference(I, w0, t, sign=+1):
    """ω(t) from I ω̇ = sign · (I ω) × ω [LL eq. 36.5 for sign = +1], solve_ivp DOP853 at
    rtol 1e-13, together with R(t) from Ṙ = R ω̃ (R(0) = 1), written without the library."""
    I = np.asarray(I, dtype=float)

    def rhs(_, y):
        w, R = y[:3], y[3:].reshape(3, 3)
        wdot = np.linalg.solve(I, sign * np.cross(I @ w, w))
        W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        return np.concatenate([wdot, (R @ W).ravel()])

    sol = solve_ivp(rhs, (t[0], t[-1]), np.concatenate([w0, np.eye(3).ravel()]), method="DOP853",
                    t_eval=t, rtol=1e-13, atol=1e-15)
    assert sol.success, sol.message
    return sol.y[:3].T, sol.y[3:].T.reshape(-1, 3, 3)


# --------------------------------------------------------------------------------------------
# Torque-free body: conservation laws
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("w0", [(1e-3, 1.0, 1e-3), (0.4, -0.8, 0.6)],
                         ids=["intermediate_axis_flip", "generic"])
def test_torque_free_body_conserves_kinetic_energy_and_angular_momentum(shipped, w0):
    """Torque-free, I = diag(1, 2, 3): the kinetic energy ½ ωᵀ I ω and |L| = |I ω| are constants
    of the motion [MR ch. 15; LL §36]; over 20 s their relative deviation from the closed-form
    initial values stays below 1e-8 (DOP853, rtol 1e-12)."""
    I = np.array([1.0, 2.0, 3.0])
    w0 = np.array(w0)
    params = dict(zip(("wx0", "wy0", "wz0"), w0))
    traj = shipped.simulate(20.0, params=params, **TIGHT)
    assert traj.status == "finished", traj.message
    T_exact = 0.5 * np.sum(I * w0**2)
    L_exact = np.linalg.norm(I * w0)
    assert np.max(np.abs(traj["body.T"] - T_exact)) / T_exact < 1e-8
    assert np.max(np.abs(traj["body.L_norm"] - L_exact)) / L_exact < 1e-8
    assert traj.relative_residual < 1e-8


def test_offset_translating_body_conserves_energy_momentum_and_L_about_com(offset):
    """Torque-free (g = 0) body with offset centre of mass, full inertia matrix and a translation:
    kinetic energy, |L_c| (about the centre of mass) and the world linear momentum R(q) p are
    conserved [LL §31, §36]: relative deviation < 1e-8 over 20 s."""
    traj = offset.simulate(20.0, params={"g": 0.0}, **TIGHT)
    assert traj.status == "finished", traj.message
    for name in ("body.T", "body.L_norm"):
        values = traj[name]
        assert np.max(np.abs(values - values[0])) / abs(values[0]) < 1e-8, name
    quat = np.column_stack([traj[f"body.q.{a}"] for a in "xyzw"])     # scipy: scalar last
    p_body = np.column_stack([traj[f"body.p.{a}"] for a in XYZ])
    p_world = Rotation.from_quat(quat).apply(p_body)
    assert np.max(np.linalg.norm(p_world - p_world[0], axis=1)) / np.linalg.norm(p_world[0]) < 1e-8


# --------------------------------------------------------------------------------------------
# Stability of steady rotations (tennis-racket theorem)
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("axis, stable", [(0, True), (1, False), (2, True)],
                         ids=["minor_axis_x", "intermediate_axis_y", "major_axis_z"])
def test_rotation_about_major_and_minor_axes_is_stable_about_intermediate_unstable(shipped, axis,
                                                                                   stable):
    """I = diag(1, 2, 3), spin 1 rad/s about one principal axis, the other two components of ω
    perturbed by 1e-3 rad/s [MR §15.10; LL §37 problem 1]. Over 20 s (DOP853, rtol 1e-10,
    sampled every 0.01 s) the perturbation |ω_⊥| stays below 10× its initial size about the minor
    and major axes, and grows by more than 100× about the intermediate one (linear growth rate
    √((I2 − I1)(I3 − I2)/(I1 I3)) = 0.577/s, e^{11.5} ≈ 1e5 before saturating at O(1))."""
    w0 = np.full(3, 1e-3)
    w0[axis] = 1.0
    traj = shipped.simulate(20.0, params=dict(zip(("wx0", "wy0", "wz0"), w0)), method="DOP853",
                            rtol=1e-10, atol=1e-12, t_eval=np.linspace(0.0, 20.0, 2001))
    assert traj.status == "finished", traj.message
    omega = omega_of(shipped, traj)
    others = [k for k in range(3) if k != axis]
    growth = np.max(np.linalg.norm(omega[:, others], axis=1)) / np.linalg.norm(w0[others])
    if stable:
        assert growth < 10, f"perturbation grew by {growth:.3g}"
    else:
        assert growth > 100, f"perturbation grew by only {growth:.3g}"


# --------------------------------------------------------------------------------------------
# Against Euler's equations, integrated independently
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("w0", [(1e-3, 1.0, 1e-3), (0.4, -0.8, 0.6)],
                         ids=["intermediate_axis_flip", "generic"])
def test_body_angular_velocity_matches_euler_equations_solve_ivp(shipped, w0):
    """ω(t) of the Lie–Poisson model equals scipy's solve_ivp on I ω̇ = (I ω) × ω [LL eq. 36.5]
    to 1e-7 rad/s (|ω| ≈ 1 rad/s) over 10 s, I = diag(1, 2, 3). The attitude R(q(t)) (scipy's
    Rotation.from_quat, Hamilton convention, body to world) equals the independent integration of
    Ṙ = R ω̃ to 1e-7. The same reference with the opposite sign of the gyroscopic term,
    I ω̇ = ω × (I ω), is more than 1e-2 away: this test discriminates the sign."""
    t = np.linspace(0.0, 10.0, 501)
    w0 = np.array(w0)
    traj = shipped.simulate(10.0, params=dict(zip(("wx0", "wy0", "wz0"), w0)), t_eval=t, **TIGHT)
    assert traj.status == "finished", traj.message
    assert np.array_equal(traj.t, t)
    omega = omega_of(shipped, traj)
    ref, R_ref = euler_reference(np.diag([1.0, 2.0, 3.0]), w0, t)
    assert np.max(np.abs(omega - ref)) < 1e-7
    quat = np.column_stack([traj[f"body.q.{a}"] for a in "xyzw"])
    assert np.max(np.abs(Rotation.from_quat(quat).as_matrix() - R_ref)) < 1e-7
    wrong, _ = euler_reference(np.diag([1.0, 2.0, 3.0]), w0, t, sign=-1)
    assert np.max(np.abs(omega - wrong)) > 1e-2


def test_offset_body_angular_velocity_matches_euler_about_com(offset):
    """With the body-frame origin away from the centre of mass, a full inertia matrix and a
    translation (g = 0), ω(t) still obeys Euler's equations with the inertia about the centre of
    mass, I_c ω̇ = (I_c ω) × ω [LL §36] (the p × v and ω × c couplings of the Lie–Poisson form
    must cancel exactly): equal to the independent solve_ivp integration to 1e-7 rad/s over 10 s."""
    t = np.linspace(0.0, 10.0, 501)
    traj = offset.simulate(10.0, params={"g": 0.0}, t_eval=t, **TIGHT)
    assert traj.status == "finished", traj.message
    ref, _ = euler_reference(I_FULL, np.array([0.7, -1.1, 0.5]), t)
    assert np.max(np.abs(omega_of(offset, traj) - ref)) < 1e-7


# --------------------------------------------------------------------------------------------
# Gravity: the centre of mass follows the parabola
# --------------------------------------------------------------------------------------------
def test_centre_of_mass_follows_free_fall_parabola(offset):
    """Under uniform gravity the centre of mass moves as a particle [LL §31]:
    c_W(t) = c_W(0) + V t + ½ g t², with c_W(0) = r0 + R0 c and V = R0 (v0 + ω0 × c), R0 from
    scipy's Rotation.from_quat (independent of the library). Over 3 s (44 m of fall) the error
    stays below 1e-9 m; the quaternion norm stays 1 to 1e-8; |L_c| (gravity exerts no torque about
    the centre of mass) is conserved to 1e-9 relative, and the energy ledger closes to 1e-9."""
    t = np.linspace(0.0, 3.0, 301)
    traj = offset.simulate(3.0, t_eval=t, **TIGHT)
    assert traj.status == "finished", traj.message
    R0 = Rotation.from_quat(np.roll(QUAT0, -1)).as_matrix()
    w0, v0, r0 = np.array([0.7, -1.1, 0.5]), np.array([1.2, 0.4, 3.0]), np.array([0.3, -0.2, 1.0])
    g = np.array([0.0, 0.0, -9.81])
    V = R0 @ (v0 + np.cross(w0, COM))
    expected = (r0 + R0 @ COM) + np.outer(t, V) + 0.5 * np.outer(t**2, g)
    com = np.column_stack([traj[f"body.com.{a}"] for a in XYZ])
    assert np.max(np.abs(com - expected)) < 1e-9
    assert np.max(np.abs(traj["body.q_norm"] - 1.0)) < 1e-8
    L = traj["body.L_norm"]
    assert np.max(np.abs(L - L[0])) / L[0] < 1e-9
    assert traj.relative_residual < 1e-9
    assert np.ptp(traj["body.V"]) > 100.0      # gravity did exchange energy with the motion


# --------------------------------------------------------------------------------------------
# Energy ledger
# --------------------------------------------------------------------------------------------
def test_power_balance_holds_pointwise_at_random_states(offset):
    """dH/dt − P_in + P_diss = 0 along the state equations (CompiledModel.power_balance, central
    difference) at 30 random states, including non-unit quaternions (|q| in [0.5, 2]) for which
    R(q) is the rotation of q/|q|: below 1e-7 of the gravity power |⟨W_g, T⟩| + 1 W exchanged."""
    rng = np.random.default_rng(20240611)
    p = offset.params()
    x0 = offset.initial_state(p)
    iq = [offset.state_index(f"body.q.{a}") for a in "wxyz"]
    ir = [offset.state_index(f"body.r.{a}") for a in XYZ]
    m, g = 2.5, 9.81
    for _ in range(30):
        x = x0.copy()
        x[:6] = rng.uniform(-3.0, 3.0, 6)
        x[ir] = rng.uniform(-5.0, 5.0, 3)
        q = rng.normal(size=4)
        x[iq] = q / np.linalg.norm(q) * rng.uniform(0.5, 2.0)
        out = offset.functions.outputs(0.0, offset.augment(x), offset.native_params(p))
        # the gravity power m g·V_com, V_com from the twist and the attitude
        omega = np.array([out[offset.output_index(f"body.omega.{a}")] for a in XYZ])
        v = np.array([out[offset.output_index(f"body.v.{a}")] for a in XYZ])
        R = Rotation.from_quat(np.roll(x[iq], -1)).as_matrix()
        scale = abs(m * g * (R @ (v + np.cross(omega, COM)))[2]) + 1.0
        assert abs(offset.power_balance(0.0, x, p)) < 1e-7 * scale


def test_shipped_model_energy_residual_below_its_tolerance(model_run, model_settings):
    """models/free_rigid_body.toml simulated with its own [simulation] settings (DOP853, rtol
    1e-10, 20 s): max |H − H(0) + E_diss − E_in| / energy scale < its energy_tolerance (1e-8);
    nothing is dissipated or supplied."""
    sim = model_settings("free_rigid_body")
    _, traj = model_run("free_rigid_body")
    assert traj.status == "finished", traj.message
    assert traj.relative_residual < float(sim["energy_tolerance"]), traj.ledger()
    assert traj.ledger()["dissipated"] == 0.0 and traj.ledger()["supplied"] == 0.0


# --------------------------------------------------------------------------------------------
# The body port and its sign
# --------------------------------------------------------------------------------------------
@ph.register
class ScrewDamper(ph.Component):
    """Test-only viscous screw damper W = c T on a screw port (power in); dissipates c |T|²."""

    kind = "TestFreeBodyScrewDamper"
    arguments = {"c": ph.Arg("damping (N m s and N s/m)")}

    def ports(self):
        return [ph.Port("p", "screw", 6, "in", "body")]

    def build(self, b, c):
        port = b.port("p")
        b.equation(port.e, c * port.f, "W = c T")
        b.dissipate(port.power)


@ph.register
class ScrewSource(ph.Component):
    """Test-only constant wrench source (power out): e = (τ, f) given."""

    kind = "TestFreeBodyScrewSource"
    arguments = {"wrench": ph.Arg("wrench (N m, N)", symbolic=False)}

    def ports(self):
        return [ph.Port("p", "screw", 6, "out", "body")]

    def build(self, b, wrench):
        port = b.port("p")
        b.equation(port.e, sp.Matrix([b.parse(w, "wrench") for w in wrench]), "W = given")
        b.supply(port.power)


def test_port_out_of_body_into_damper_decays_spin_and_speed():
    """Bond body.body -> damper.p (the body is the tail: the damper's wrench c T acts on the body
    as −c T). Spin about the principal axis z (I3 = 3) with velocity along x (m = 2), com at the
    origin: L ∥ ω, so I3 ω̇ = −c ω and m d|v|/dt = −c |v| [LL §36 with τ = −c ω]:
    ω_z = ω0 e^{−c t/I3}, |v| = v0 e^{−c t/m}, to 1e-9 relative over 5 s; the dissipated energy
    books the loss (residual < 1e-9)."""
    model = ph.Model("damped_body")
    model.add("body", FreeBody(mass=2.0, inertia=[1.0, 2.0, 3.0], gravity=[0, 0, 0],
                               omega0=[0, 0, 1.5], v0=[0.8, 0, 0]))
    model.add("damper", ScrewDamper(c=0.4))
    model.connect("body.body", "damper.p")
    compiled = compile_model(model, backend="python")
    t = np.linspace(0.0, 5.0, 51)
    traj = compiled.simulate(5.0, t_eval=t, **TIGHT)
    assert traj.status == "finished", traj.message
    omega_z = traj["body.omega.z"]
    speed = np.linalg.norm([traj[f"body.v.{a}"] for a in XYZ], axis=0)
    assert np.max(np.abs(omega_z - 1.5 * np.exp(-0.4 * t / 3.0))) / 1.5 < 1e-9
    assert np.max(np.abs(speed - 0.8 * np.exp(-0.4 * t / 2.0))) / 0.8 < 1e-9
    assert traj.E_diss[-1] > 0.5 * traj.h0
    assert traj.relative_residual < 1e-9


def test_port_from_source_into_body_pushes_it():
    """Bond source.p -> body.body (the body is the head: the effort is the wrench applied to it).
    A constant body force F = (0, 0, 2) N and torque τ = (0.3, 0, 0) N m on a body at rest with
    the CoM at the origin: ṗ = F + p × ω, L̇ = τ + L × ω + p × v; for the first instants
    p ≈ F t, L ≈ τ t. Checked by the initial slopes at t = 1e-3 s (O(t²) terms < 1e-6
    relative), and the supplied energy equals the stored energy (residual < 1e-9 over 2 s)."""
    model = ph.Model("pushed_body")
    model.add("source", ScrewSource(wrench=[0.3, 0, 0, 0, 0, 2.0]))
    model.add("body", FreeBody(mass=2.0, inertia=[1.0, 2.0, 3.0], gravity=[0, 0, 0]))
    model.connect("source.p", "body.body")
    compiled = compile_model(model, backend="python")
    traj = compiled.simulate(1e-3, t_eval=np.array([0.0, 1e-3]), **TIGHT)
    p_z, L_x = traj["body.p.z"][-1], traj["body.L.x"][-1]
    assert abs(p_z - 2.0e-3) / 2.0e-3 < 1e-6 and abs(L_x - 0.3e-3) / 0.3e-3 < 1e-6
    long = compiled.simulate(2.0, **TIGHT)
    assert long.status == "finished", long.message
    assert long.ledger()["supplied"] > 1.0
    assert long.relative_residual < 1e-9

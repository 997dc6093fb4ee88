"""Validation of the Multibody's 3D joints (spherical, free, universal) against closed forms and
independent integrations.

References
----------
[Goldstein] H. Goldstein, C. Poole, J. Safko, *Classical Mechanics*, 3rd ed., 2002, §5.7: the heavy
    symmetric top. With u = cos θ, a = C ω₃ / A, b = p_φ / A, α = 2E'/A, β = 2 m g l / A (A, C the
    transverse and axial moments about the fixed point), u̇² = f(u) = (1 − u²)(α − β u) − (b − a u)²;
    released at θ₀ with θ̇ = φ̇ = 0, θ nutates between θ₀ and the root u₁ of
    β (1 − u²) = a² (u₀ − u) in [−1, u₀]. Steady precession at θ: m g l = φ̇ (C ω₃ − A φ̇ cos θ)
    (eq. 5.75), whose slow root is m g l / (C ω₃) (1 + O(A m g l cos θ / (C ω₃)²)).
[Euler] Euler's equations of a rigid body about a fixed point, I ω̇ = (I ω) × ω + τ, with the
    gravity torque τ = (l e₃) × (Rᵀ m g) in body axes and q̇ = ½ q ⊗ (0, ω): integrated here with
    scipy (DOP853, rtol 1e-12), independently of the library.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

import porthamiltonian as ph
from porthamiltonian import io

TOP = {"m": 1.0, "l": 0.1, "A_c": 0.004, "C": 0.006, "g": 9.81, "theta0": 0.5}



def _body_inertia(A: np.ndarray) -> list:
    """A random inertia that a body can have: tr(S) 1 − S of the second moment S = A Aᵀ +
    0.005·1 of a mass distribution (positive definite, its principal moments obeying the
    triangle inequality; a random symmetric positive definite matrix need not)."""
    S = A @ A.T + 0.005 * np.eye(3)
    return (np.trace(S) * np.eye(3) - S).tolist()

def axis_of(quaternion: np.ndarray) -> np.ndarray:
    """World direction of body z for quaternions (w, x, y, z) along the last axis (normalised)."""
    w, x, y, z = (quaternion / np.linalg.norm(quaternion, axis=-1, keepdims=True)).T
    return np.array([2 * (x * z + w * y), 2 * (y * z - w * x), w**2 - x**2 - y**2 + z**2]).T


@pytest.fixture(scope="module")
def top(isolated_cache):
    """The shipped top on the C back end (the runs at rtol 1e-12 take a third of the python back
    end's CPU; the suite's check-energy run has built it into the shared cache)."""
    return ph.compile_model(io.load("heavy_top"), backend="c")


def run_top(top, t_end: float, **params):
    traj = top.simulate(t_end, params=params, method="DOP853", rtol=1e-12, atol=1e-14,
                        dense_output=True)
    return traj


def test_nutation_bounds_match_the_closed_form(top):
    """Released at θ₀ = 0.5 rad spinning at ω₃ = 60 rad/s without precession: over 1 s (four
    nutation periods) θ stays within [θ₀, θ₁] and reaches both, θ₁ from [Goldstein]'s cubic; the
    extremes (located on the dense output) agree to 1e-8 rad."""
    traj = run_top(top, 1.0, omega3=60.0)
    A = TOP["A_c"] + TOP["m"] * TOP["l"] ** 2
    a, beta, u0 = TOP["C"] * 60.0 / A, 2 * TOP["m"] * TOP["g"] * TOP["l"] / A, math.cos(0.5)
    u1 = (a**2 - math.sqrt(a**4 - 4 * beta * (a**2 * u0 - beta))) / (2 * beta)
    theta1 = math.acos(u1)
    iq = [top.state_index(f"top.q.tip.{c}") for c in ("qw", "qx", "qy", "qz")]

    def theta(t):
        return math.acos(axis_of(traj.sol(t)[iq])[2])

    ts = np.linspace(0, 1.0, 4001)
    th = np.array([theta(t) for t in ts])
    assert th.min() >= 0.5 - 1e-9 and th.max() <= theta1 + 1e-9
    k = int(np.argmax(th))
    peak = -minimize_scalar(lambda t: -theta(t), bounds=(ts[k - 1], ts[k + 1]), method="bounded",
                            options={"xatol": 1e-12}).fun
    assert peak == pytest.approx(theta1, abs=1e-8)
    k = int(np.argmin(th[len(th) // 4:])) + len(th) // 4           # a later return to θ₀
    low = minimize_scalar(theta, bounds=(ts[k - 1], ts[k + 1]), method="bounded",
                          options={"xatol": 1e-12}).fun
    assert low == pytest.approx(0.5, abs=1e-8)


@pytest.mark.parametrize("omega3", [300.0, 1000.0])
def test_fast_top_precesses_at_mgl_over_C_omega3(top, omega3):
    """Started at the slow root of m g l = φ̇ (C ω₃ − A φ̇ cos θ₀) the top precesses steadily: the
    azimuth of its axis turns at that rate (to 1e-9 relative over 2 s; measured 4e-12 and
    1.4e-11) and θ stays at θ₀ (1e-8 rad); the rate is m g l / (C ω₃) (1 + ε + O(ε²)),
    ε = A m g l cos θ₀ / (C ω₃)² the fast-top correction (ε = 3.7e-3 and 3.3e-4 here):
    |rate / (m g l / (C ω₃)) − 1 − ε| < 3 ε² (the series gives 2 ε²)."""
    A = TOP["A_c"] + TOP["m"] * TOP["l"] ** 2
    mgl, C = TOP["m"] * TOP["g"] * TOP["l"], TOP["C"]
    c0 = math.cos(TOP["theta0"])
    slow = (C * omega3 - math.sqrt((C * omega3) ** 2 - 4 * A * c0 * mgl)) / (2 * A * c0)
    traj = run_top(top, 2.0, omega3=omega3, phidot0=slow)
    iq = [top.state_index(f"top.q.tip.{c}") for c in ("qw", "qx", "qy", "qz")]
    ts = np.linspace(0, 2.0, 201)
    axes = axis_of(traj.sol(ts)[iq].T)
    phi = np.unwrap(np.arctan2(axes[:, 1], axes[:, 0]))
    rate = np.polyfit(ts, phi, 1)[0]
    assert rate == pytest.approx(slow, rel=1e-9)
    assert np.max(np.abs(np.arccos(axes[:, 2]) - TOP["theta0"])) < 1e-8
    eps = A * mgl * c0 / (C * omega3) ** 2
    assert abs(rate / (mgl / (C * omega3)) - 1 - eps) < 3 * eps**2


def test_top_follows_eulers_equations(top):
    """The top of the nutation test (ω₃ = 60 rad/s) against [Euler] integrated by scipy: the
    world direction of the symmetry axis agrees to 1e-8 at 50 times over 2 s, and the body angular
    velocity (the joint's flow) to 1e-7 rad/s."""
    A = TOP["A_c"] + TOP["m"] * TOP["l"] ** 2
    inertia = np.diag([A, A, TOP["C"]])
    weight = np.array([0, 0, -TOP["m"] * TOP["g"]])
    lever = np.array([0, 0, TOP["l"]])

    def euler(t, y):
        w, q = y[:3], y[3:]
        R = np.array(rotation(q))
        torque = np.cross(lever, R.T @ weight)
        wdot = np.linalg.solve(inertia, np.cross(inertia @ w, w) + torque)
        qw, u = q[0], q[1:]
        return np.concatenate([wdot, [-u @ w / 2], (qw * w + np.cross(u, w)) / 2])

    q0 = [math.cos(0.25), math.sin(0.25), 0, 0]
    ts = np.linspace(0, 2.0, 50)
    ref = solve_ivp(euler, (0, 2.0), [0, 0, 60.0, *q0], method="DOP853", rtol=1e-12,
                    atol=1e-14, t_eval=ts)
    traj = run_top(top, 2.0, omega3=60.0)
    iq = [top.state_index(f"top.q.tip.{c}") for c in ("qw", "qx", "qy", "qz")]
    X = traj.sol(ts)
    assert np.max(np.abs(axis_of(X[iq].T) - axis_of(ref.y[3:].T))) < 1e-8
    iw = [top.output_index(f"top.tip.f{i}") for i in range(3)]
    pn = top.native_params(top.params(omega3=60.0))
    flows = np.array([np.asarray(top.functions.outputs(t, top.augment(x), pn))[iw]
                      for t, x in zip(ts, X.T)])
    assert np.max(np.abs(flows - ref.y[:3].T)) < 1e-7


def rotation(q):
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q / np.linalg.norm(q)
    return [[w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z]]


# --------------------------------------------------------------------------------------------
# Free joints: the Lie–Poisson floating base
# --------------------------------------------------------------------------------------------
INERTIA = [[0.3, 0.01, -0.02], [0.01, 0.5, 0.03], [-0.02, 0.03, 0.7]]


def floating_tree(gravity=(0, 0, 0), bodies: int = 2, gain: float = 1.0) -> ph.Model:
    """A base on a free joint from the world (full inertia, off-centre mass); with bodies = 2 an
    arm on a spherical joint at the base's corner (0.2, −0.1, 0.3) m, with a tip point."""
    m = ph.Model(f"floating{bodies}")
    body = {"base": {"mass": 2.0, "com": [0.1, -0.05, 0.2], "inertia": INERTIA}}
    joint = {"float": {"type": "free", "parent": "world", "child": "base",
                       "q0": [0.3, -0.2, 1.0, 0.9, 0.1, -0.3, 0.2],
                       "v0": [0.4, -0.7, 1.3, 0.5, 0.2, -0.1]}}
    if bodies == 2:
        body["arm"] = {"mass": 0.7, "com": [0, 0, -0.25], "inertia": [0.03, 0.03, 0.004],
                       "points": {"arm_tip": [0, 0, -0.5]}}
        joint["shoulder"] = {"type": "spherical", "parent": "base", "child": "arm",
                             "origin": [0.2, -0.1, 0.3], "q0": [0.8, 0.3, 0.5, 0.1],
                             "v0": [2.0, -1.0, 0.5]}
    m.add("mb", ph.Multibody(bodies=body, joints=joint, gravity=list(gravity),
                             quaternion_gain=gain))
    return m


def world_momenta(model, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Total linear momentum and angular momentum about the world origin (world axes) from the
    free root's states: its momenta are the whole tree's, in the base's frame about its origin."""
    idx = {c: model.state_index(f"mb.q.float.{c}") for c in ("x", "y", "z", "qw", "qx", "qy", "qz")}
    ip = [model.state_index(f"mb.p.float.{c}") for c in ("wx", "wy", "wz", "vx", "vy", "vz")]
    P, L = [], []
    for x in X:
        R = np.array(rotation(x[[idx["qw"], idx["qx"], idx["qy"], idx["qz"]]]))
        r = x[[idx["x"], idx["y"], idx["z"]]]
        p = R @ x[ip[3:]]
        P.append(p)
        L.append(R @ x[ip[:3]] + np.cross(r, p))
    return np.array(P), np.array(L)


@pytest.mark.parametrize("bodies", [1, 2])
def test_floating_tree_conserves_momentum_energy_and_quaternion_norm(bodies, isolated_cache):
    """Without gravity, over 5 s (DOP853, rtol 1e-11): the total linear momentum and the
    angular momentum about the world origin stay at their initial values to 1e-9 of their size,
    the energy to 1e-10 of the ledger's scale, and every joint quaternion's norm to 1e-9."""
    model = ph.compile_model(floating_tree(bodies=bodies), backend="python")
    traj = model.simulate(5.0, method="DOP853", rtol=1e-11, atol=1e-13)
    P, L = world_momenta(model, traj.x)
    assert np.max(np.abs(P - P[0])) < 1e-9 * np.linalg.norm(P[0])
    assert np.max(np.abs(L - L[0])) < 1e-9 * np.linalg.norm(L[0])
    assert traj.relative_residual < 1e-10
    assert np.ptp(traj["H"]) < 1e-10 * traj.energy_scale
    for name in [n for n in model.output_names if n.endswith("q_norm")]:
        assert np.max(np.abs(traj[name] - 1)) < 1e-9
    assert np.ptp(traj["mb.arm_tip.z"] if bodies == 2 else traj["mb.q.float.qx"]) > 0.1


def test_quaternion_norm_is_pulled_back_and_changes_nothing_physical(isolated_cache):
    """Started with the base's quaternion scaled to norm 1.2, the norm relaxes to 1 at the
    quaternion_gain rate k = 1/s (d|q|²/dt = k (1 − |q|²) |q|², so |q|²(t) = 1 / (1 − c e^{−kt}),
    c = 1 − 1/1.44; checked at t = 3 s to 1e-6), while the
    motion is that of the unscaled start (arm tip to 1e-9 m, base momenta to 1e-9): R, V and M
    depend on q/|q| only, and the pull acts along q."""
    model = ph.compile_model(floating_tree(gravity=(0, 0, -9.81)), backend="python")
    x0 = model.initial_state()
    iq = [model.state_index(f"mb.q.float.{c}") for c in ("qw", "qx", "qy", "qz")]
    scaled = x0.copy()
    scaled[iq] *= 1.2
    runs = [model.simulate(3.0, x0=x, method="DOP853", rtol=1e-11, atol=1e-13, dense_output=True)
            for x in (x0, scaled)]
    norm2 = runs[1]["mb.float.q_norm"][-1] ** 2
    decay = (1 - 1 / 1.44) * math.exp(-3.0)
    assert norm2 == pytest.approx(1 / (1 - decay), abs=1e-6)
    ts = np.linspace(0, 3.0, 31)
    tip = [np.array([model.functions.outputs(t, model.augment(x), model.native_params(
        model.param_defaults)) for t, x in zip(ts, run.sol(ts).T)]) for run in runs]
    it = [model.output_index(f"mb.arm_tip.{c}") for c in "xyz"]
    assert np.max(np.abs(tip[0][:, it] - tip[1][:, it])) < 1e-9
    ip = [model.state_index(f"mb.p.float.{c}") for c in ("wx", "wy", "wz", "vx", "vy", "vz")]
    assert np.max(np.abs(runs[0].sol(ts)[ip] - runs[1].sol(ts)[ip])) < 1e-9


def test_free_joint_is_the_lie_poisson_free_body(isolated_cache):
    """A single body on a free joint under skew gravity has the state equations of FreeBody
    (mechanics/free_body.py, validated against Euler's equations in test_free_body.py): momenta
    (L, p) in the body frame, position and unit quaternion, at 5 random states to 1e-13 of the
    largest rate."""
    com, g = [0.1, -0.05, 0.2], [0.3, -0.2, -9.81]
    free = ph.Model("freebody")
    free.add("b", ph.mechanics.FreeBody(mass=2.0, inertia=INERTIA, com=com, gravity=g))
    tree = ph.Model("freejoint")
    tree.add("mb", ph.Multibody(bodies={"body": {"mass": 2.0, "com": com, "inertia": INERTIA}},
                                joints={"j": {"type": "free", "parent": "world", "child": "body"}},
                                gravity=g))
    a, b = (ph.compile_model(m, backend="python") for m in (free, tree))
    rng = np.random.default_rng(7)
    for _ in range(5):
        momenta, r, q = rng.normal(size=6), rng.normal(size=3), rng.normal(size=4)
        q /= np.linalg.norm(q)
        fa = np.asarray(a.functions.rhs(0, a.augment(np.concatenate([momenta, r, q])),
                                        a.native_params(a.param_defaults)))[:13]
        fb = np.asarray(b.functions.rhs(0, b.augment(np.concatenate([r, q, momenta])),
                                        b.native_params(b.param_defaults)))[:13]
        assert np.max(np.abs(fa - np.concatenate([fb[7:], fb[:7]]))) < 1e-13 * np.max(np.abs(fa))


# --------------------------------------------------------------------------------------------
# A floating 3-body tree against sympy.physics.mechanics
# --------------------------------------------------------------------------------------------
def _rx(a):
    return np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])


def _ry(a):
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


def _rz(a):
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])


def _qmul(a, b):
    return np.array([a[0] * b[0] - a[1:] @ b[1:], *(a[0] * b[1:] + b[0] * a[1:] + np.cross(a[1:], b[1:]))])


def euler_quaternion(psi):
    """Quaternion of R = Rx(ψ₁) Ry(ψ₂) Rz(ψ₃) (body-fixed x, y, z angles); complex ψ allowed."""
    halves = [np.array([np.cos(a / 2), *(np.sin(a / 2) * np.array(e))])
              for a, e in zip(psi, ((1, 0, 0), (0, 1, 0), (0, 0, 1)))]
    return _qmul(_qmul(halves[0], halves[1]), halves[2])


def euler_rates_matrix(psi):
    """E(ψ) with ω = E ψ̇, ω the body-axis angular velocity of Rx(ψ₁) Ry(ψ₂) Rz(ψ₃)."""
    R23 = _ry(psi[1]) @ _rz(psi[2])
    return np.column_stack([R23.T @ [1, 0, 0], _rz(psi[2]).T @ [0, 1, 0], [0, 0, 1]])


def _floating_specs(seed: int):
    """(Multibody model, reference joint table, gravity): a base on a free joint from the world,
    an arm on a universal joint (skew axes) and a head on a spherical joint, both on the base;
    random masses, centres of mass, inertias, offsets and gravity. The reference writes the free
    joint as three prismatic joints along the world axes and three revolute joints about the
    body-fixed x, y, z axes, the spherical joint as three revolute ones (massless bodies in
    between), the universal joint as two revolute ones."""
    rng = np.random.default_rng(seed)

    def body():
        A = rng.normal(size=(3, 3)) * 0.1
        return {"mass": float(rng.uniform(0.5, 2.0)), "com": rng.uniform(-0.2, 0.2, 3).tolist(),
                "inertia": _body_inertia(A)}

    base, arm, head = body(), body(), body()
    a1, a2 = (tuple(v / np.linalg.norm(v)) for v in rng.normal(size=(2, 3)))
    o1, o2 = rng.uniform(-0.3, 0.3, 3).tolist(), rng.uniform(-0.3, 0.3, 3).tolist()
    gravity = [float(rng.uniform(-1, 1)), float(rng.uniform(-1, 1)), -9.81]
    model = ph.Model("floating3")
    model.add("mb", ph.Multibody(
        bodies={"base": base, "arm": arm, "head": head},
        joints={"float": {"type": "free", "parent": "world", "child": "base"},
                "uni": {"type": "universal", "parent": "base", "child": "arm",
                        "axes": [list(a1), list(a2)], "origin": o1},
                "ball": {"type": "spherical", "parent": "base", "child": "head",
                         "origin": o2}},
        gravity=gravity))
    massless = {"mass": 0.0, "com": [0, 0, 0], "inertia": np.zeros((3, 3)).tolist()}
    zero = [0.0, 0.0, 0.0]
    ref = {}
    parent = "world"
    for name, kind, axis, b in (("fx", "prismatic", "x", massless), ("fy", "prismatic", "y", massless),
                                ("fz", "prismatic", "z", massless), ("f1", "revolute", "x", massless),
                                ("f2", "revolute", "y", massless), ("f3", "revolute", "z", base)):
        ref[name] = {"type": kind, "parent": parent, "axis": axis, "origin": zero, "body": b}
        parent = name
    ref["u1"] = {"type": "revolute", "parent": "f3", "axis": a1, "origin": o1, "body": massless}
    ref["u2"] = {"type": "revolute", "parent": "u1", "axis": a2, "origin": zero, "body": arm}
    ref["h1"] = {"type": "revolute", "parent": "f3", "axis": "x", "origin": o2, "body": massless}
    ref["h2"] = {"type": "revolute", "parent": "h1", "axis": "y", "origin": zero, "body": massless}
    ref["h3"] = {"type": "revolute", "parent": "h2", "axis": "z", "origin": zero, "body": head}
    return model, ref, gravity


def _velocity_map(qr):
    """A(q) with our velocities = A · the reference's joint rates (orders: ours (ω, v) of the
    base in its axes, the universal joint's two rates, the head's relative ω in its axes;
    the reference's ẋ, ẏ, ż, ψ̇₁₋₃, the two rates, φ̇₁₋₃)."""
    A = np.zeros((11, 11), dtype=complex)
    A[0:3, 3:6] = euler_rates_matrix(qr[3:6])
    A[3:6, 0:3] = (_rx(qr[3]) @ _ry(qr[4]) @ _rz(qr[5])).T
    A[6:8, 6:8] = np.eye(2)
    A[8:11, 8:11] = euler_rates_matrix(qr[8:11])
    return A


@pytest.mark.parametrize("seed", [1, 2])
def test_floating_three_body_tree_matches_sympy_mechanics(seed, isolated_cache):
    """The Multibody's mass matrix, momenta, ṗ (Lie–Poisson rows of the free joint, Euler-type rows
    of the spherical one), q̇ (quaternion rates, ṙ = R v) and H at three random states against
    the reference of mechanics_reference.py written in ordinary coordinates (positions, body-fixed
    x-y-z angles), mapped to the quasi-velocities by A (ours = A · reference rates):
    M = A⁻ᵀ M_ref A⁻¹, p = A⁻ᵀ p_ref and ṗ = A⁻ᵀ (ṗ_ref − Ȧᵀ p), Ȧ along the motion by complex step
    (Hamilton's equations are covariant under this change of velocities). Tolerance 1e-10
    relative to the largest entry of each."""
    from mechanics_reference import Reference

    model, spec, gravity = _floating_specs(seed)
    compiled = ph.compile_model(model, backend="python")
    reference = Reference(spec, gravity)
    rng = np.random.default_rng(seed + 50)
    h = 1e-30
    for _ in range(3):
        qr = np.concatenate([rng.uniform(-1, 1, 3), rng.uniform(-1.2, 1.2, 3), rng.uniform(-1, 1, 2),
                             rng.uniform(-1.2, 1.2, 3)])
        ur = rng.uniform(-1, 1, 11)
        M_ref, H_ref, pdot_ref = reference.values(qr, ur)
        A = _velocity_map(qr).real
        Ainv = np.linalg.inv(A)
        p = Ainv.T @ M_ref @ ur
        Adot = _velocity_map(qr + 1j * h * ur).imag / h
        pdot = Ainv.T @ (pdot_ref - Adot.T @ p)
        x = np.concatenate([qr[0:3], euler_quaternion(qr[3:6]), qr[6:8],
                            euler_quaternion(qr[8:11]), p])
        assert compiled.state_names[:13] == [
            *(f"mb.q.float.{c}" for c in ("x", "y", "z", "qw", "qx", "qy", "qz")),
            "mb.q.uni.a1", "mb.q.uni.a2", *(f"mb.q.ball.{c}" for c in ("qw", "qx", "qy", "qz"))]
        M = compiled.matrix("mb.M", 0.0, x, compiled.param_defaults)
        assert np.max(np.abs(M - Ainv.T @ M_ref @ Ainv)) < 1e-10 * np.max(np.abs(M))
        xdot = np.asarray(compiled.functions.rhs(0.0, compiled.augment(x), compiled.native_params(
            compiled.param_defaults)))[:24]
        assert np.max(np.abs(xdot[13:] - pdot)) < 1e-10 * np.max(np.abs(pdot))
        qdot = np.concatenate([ur[0:3], euler_quaternion(qr[3:6] + 1j * h * ur[3:6]).imag / h,
                               ur[6:8], euler_quaternion(qr[8:11] + 1j * h * ur[8:11]).imag / h])
        assert np.max(np.abs(xdot[:13] - qdot)) < 1e-10 * np.max(np.abs(qdot))
        H = compiled.energy(0.0, x, compiled.param_defaults)[0]
        assert H == pytest.approx(H_ref, rel=1e-10)


# --------------------------------------------------------------------------------------------
# Records, names and errors
# --------------------------------------------------------------------------------------------
def test_joint_records_equal_the_tables_and_name_the_coordinates():
    """Free, Spherical and Universal records build the same equations as the plain tables; the
    coordinates and momenta are named as docs/model-files.md says."""
    from porthamiltonian.mechanics import Free, RigidBody, Spherical, Universal

    bodies = {"base": {"mass": 2.0, "inertia": [0.1, 0.2, 0.3]},
              "arm": {"mass": 0.5, "com": [0, 0, -0.2], "inertia": [0.01, 0.01, 0.002]},
              "head": {"mass": 0.3, "inertia": [0.001, 0.001, 0.001]}}
    tables = {"float": {"type": "free", "parent": "world", "child": "base",
                        "q0": [0, 0, 1, 1, 0, 0, 0]},
              "uni": {"type": "universal", "parent": "base", "child": "arm", "axes": ["x", "y"],
                      "q0": [0.1, -0.2]},
              "ball": {"type": "spherical", "parent": "base", "child": "head",
                       "origin": [0, 0, 0.3], "v0": [0, 0, 1.0]}}
    records = {"float": Free(parent="world", child="base", q0=[0, 0, 1, 1, 0, 0, 0]),
               "uni": Universal(parent="base", child="arm", axes=("x", "y"), q0=[0.1, -0.2]),
               "ball": Spherical(parent="base", child="head", origin=[0, 0, 0.3], v0=[0, 0, 1.0])}
    systems = []
    for joints in (tables, records):
        m = ph.Model("records")
        m.add("mb", ph.Multibody(bodies={k: RigidBody(**v) for k, v in bodies.items()},
                                 joints=joints, gravity=[0, 0, -9.81]))
        systems.append(ph.symbolic(m))
    assert [str(e) for e in systems[0].rhs] == [str(e) for e in systems[1].rhs]
    assert systems[0].state_names == [
        *(f"mb.q.float.{c}" for c in ("x", "y", "z", "qw", "qx", "qy", "qz")),
        "mb.q.uni.x", "mb.q.uni.y", *(f"mb.q.ball.{c}" for c in ("qw", "qx", "qy", "qz")),
        *(f"mb.p.float.{c}" for c in ("wx", "wy", "wz", "vx", "vy", "vz")),
        "mb.p.uni.x", "mb.p.uni.y", *(f"mb.p.ball.{c}" for c in ("wx", "wy", "wz"))]


@pytest.mark.parametrize("joint, message", [
    ({"type": "universal", "axes": ["x"]}, "needs axes"),
    ({"type": "universal", "axes": ["x", [2, 0, 0]]}, "parallel axes"),
    ({"type": "spherical", "q0": [1, 0, 0]}, "q0 needs 4 value"),
    ({"type": "spherical", "q0": [0, 0, 0, 0]}, "must not be zero"),
    ({"type": "free", "v0": [0, 0, 0]}, "v0 needs 6 value"),
])
def test_bad_3d_joints_are_refused_naming_the_joint(joint, message):
    model = ph.Model("bad")
    with pytest.raises(ph.errors.ModelError, match=message) as info:
        model.add("mb", ph.Multibody(bodies={"b": {"mass": 1.0, "inertia": [1, 1, 1]}},
                                     joints={"j": {"parent": "world", "child": "b", **joint}}))
        ph.symbolic(model)
    assert "'j'" in str(info.value)

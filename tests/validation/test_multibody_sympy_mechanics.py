"""The recursive Multibody against an independent derivation with sympy.physics.mechanics.

For random mechanisms (masses U(0.5, 2) kg, link lengths U(0.3, 0.8) m, off-axis centres of
mass, random symmetric positive definite inertia matrices, random joint offsets and gravity) the
same tree is written once as a Multibody and once with sympy.physics.mechanics (reference frames
oriented about the joint axes, points located from the joint origins, their velocities by
v2pt/v1pt theory, rigid bodies, the potential −Σ m gᵀ r_c; see :class:`Reference`). From the
latter: M(q) from the bodies' partial velocities (Kane's method: M_jk = Σ m ∂v_c/∂u_j·∂v_c/∂u_k +
∂ω/∂u_j·I·∂ω/∂u_k), H = T + V and Hamilton's ṗ = ∂L/∂q|_q̇ (L = T − V, [Goldstein] §8.1) by
complex-step differentiation. At three random states (q ~ U(−1, 1), q̇ ~ U(−1, 1), p = M q̇)
the compiled model's mass matrix, q̇ (its first n state derivatives), ṗ and H must agree to 1e-10
relative to the largest entry of each.

Mechanisms: planar chains of 3 and 6 links (revolute about y), spatial chains of 3 and 6 links
(revolute joints about x, y, z and skew axes in turn), and a non-planar tree: two branches on
revolute joints about different axes, a prismatic joint along a skew axis and a weld.

[Goldstein] H. Goldstein, C. Poole, J. Safko, *Classical Mechanics*, 3rd ed., 2002.
"""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from sympy.physics import mechanics as me

import porthamiltonian as ph

AXES = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}


def random_spec(kind: str, seed: int) -> dict:
    """Joints (parents first) of a random mechanism: name -> {type, parent, axis, origin, body}."""
    rng = np.random.default_rng(seed)
    skew = [tuple(a / np.linalg.norm(a)) for a in rng.normal(size=(4, 3))]
    if kind.startswith("planar"):
        axes = ["y"] * int(kind[-1])
    elif kind.startswith("spatial"):
        axes = (["x", "y", "z", skew[0], "y", skew[1]])[: int(kind[-1])]
    else:
        axes = None
    joints: dict[str, dict] = {}

    def body():
        A = rng.normal(size=(3, 3)) * 0.1
        length = float(rng.uniform(0.3, 0.8))
        return {"mass": float(rng.uniform(0.5, 2.0)), "length": length,
                "com": [float(rng.uniform(-0.1, 0.1)), float(rng.uniform(-0.1, 0.1)), -length / 2],
                "inertia": (A @ A.T + 0.01 * np.eye(3)).tolist()}

    def add(name, jtype, parent, axis):
        origin = [0.0, 0.0, 0.0] if parent == "world" else [
            float(rng.uniform(-0.05, 0.05)), float(rng.uniform(-0.05, 0.05)),
            -joints[parent]["body"]["length"]]
        joints[name] = {"type": jtype, "parent": parent, "axis": axis, "origin": origin,
                        "body": body()}

    if axes is not None:
        for i, axis in enumerate(axes):
            add(f"j{i}", "revolute", "world" if i == 0 else f"j{i - 1}", axis)
    else:                                    # the tree
        add("root", "revolute", "world", "z")
        add("left", "revolute", "root", "x")
        add("left2", "revolute", "left", skew[2])
        add("right", "revolute", "root", skew[3])
        add("slide", "prismatic", "right", skew[0])
        add("tool", "weld", "left2", None)
    return joints


def multibody(spec: dict, gravity) -> ph.Model:
    bodies, joints = {}, {}
    for name, j in spec.items():
        bodies[f"b_{name}"] = {"mass": j["body"]["mass"], "com": j["body"]["com"],
                               "inertia": j["body"]["inertia"]}
        joints[name] = {"type": j["type"], "parent": "world" if j["parent"] == "world"
                        else f"b_{j['parent']}", "child": f"b_{name}", "origin": j["origin"]}
        if j["axis"] is not None:
            joints[name]["axis"] = list(j["axis"]) if isinstance(j["axis"], tuple) else j["axis"]
    model = ph.Model("mechanics_check")
    model.add("mb", ph.Multibody(bodies=bodies, joints=joints, gravity=list(gravity)))
    return model


class Reference:
    """The mechanism in sympy.physics.mechanics: frames oriented about the joint axes
    (``orient_axis``), their angular velocities and the points' velocities set joint by joint
    (``set_ang_vel``, ``v2pt_theory``, ``v1pt_theory``), rigid bodies, and each body's partial
    velocities ∂v_c/∂u_j, ∂ω/∂u_j (Kane's ``partial_velocity``). Every vector is kept in the
    frames sympy forms it in; for the numbers, the relative orientations (``dcm``) and the vector
    components are lambdified and composed with numpy, so that they take complex q.

    ``values(q, v)`` gives M(q) = Σ m Jᵥᵀ Jᵥ + J_ωᵀ I J_ω (the Hessian of T), H = T + V and
    Hamilton's ṗ = ∂L/∂q|_q̇ (L = ½ q̇ᵀ M q̇ − V) by complex-step differentiation (step 1e-30:
    no cancellation, exact to round-off)."""

    def __init__(self, spec: dict, gravity):
        N = me.ReferenceFrame("N")
        O = me.Point("O")
        O.set_vel(N, 0)
        zero = sp.Integer(0) * N.x
        frames, origins, self.parent = {"world": N}, {"world": O}, {}
        qs, us, bodies = [], [], []
        for name, j in spec.items():
            parent_frame, parent_origin = frames[j["parent"]], origins[j["parent"]]
            frame = me.ReferenceFrame(f"F_{name}")
            joint_point = parent_origin.locatenew(
                f"J_{name}", sum((c * e for c, e in zip(j["origin"], parent_frame)), zero))
            joint_point.v2pt_theory(parent_origin, N, parent_frame)
            axis = AXES[j["axis"]] if isinstance(j["axis"], str) else j["axis"]
            axis_vec = None if axis is None else sum(
                (float(c) * e for c, e in zip(axis, parent_frame)), zero)
            if j["type"] == "weld":
                frame.orient_axis(parent_frame, parent_frame.x, 0)
                frame.set_ang_vel(parent_frame, zero)
                origin = joint_point
            else:
                q, u = sp.symbols(f"q_{name} u_{name}", real=True)
                qs.append(q)
                us.append(u)
                if j["type"] == "revolute":
                    frame.orient_axis(parent_frame, axis_vec, q)
                    frame.set_ang_vel(parent_frame, u * axis_vec)
                    origin = joint_point
                else:
                    frame.orient_axis(parent_frame, parent_frame.x, 0)
                    frame.set_ang_vel(parent_frame, zero)
                    origin = joint_point.locatenew(f"P_{name}", q * axis_vec)
                    origin.set_vel(parent_frame, u * axis_vec)
                    origin.v1pt_theory(joint_point, N, parent_frame)
            frames[name], origins[name] = frame, origin
            self.parent[frame] = parent_frame
            com = origin.locatenew(f"C_{name}", sum(
                (c * e for c, e in zip(j["body"]["com"], frame)), zero))
            com.v2pt_theory(origin, N, frame)
            bodies.append((me.RigidBody(f"B_{name}", com, frame, j["body"]["mass"],
                                        (frame.x | frame.x, com)),
                           np.array(j["body"]["inertia"])))
        self.N, self.n = N, len(qs)

        def numeric(expr):
            return sp.lambdify([qs], expr, "numpy")

        self.dcm = {f: numeric(p.dcm(f)) for f, p in self.parent.items()}   # p coords <- f
        g = gravity[0] * N.x + gravity[1] * N.y + gravity[2] * N.z
        self.bodies = []
        for rb, inertia in bodies:
            vc, w = me.partial_velocity([rb.masscenter.vel(N), rb.frame.ang_vel_in(N)], us, N)
            self.bodies.append((float(rb.mass), inertia, rb.frame,
                                [self._parts(x, numeric) for x in vc],
                                [self._parts(x, numeric) for x in w]))
        self.potential = self._parts(-sum((rb.mass * rb.masscenter.pos_from(O).dot(g)
                                           for rb, _ in bodies), sp.Integer(0)) * N.x, numeric)

    @staticmethod
    def _parts(vector, numeric):
        return [(frame, numeric(components)) for components, frame in vector.args]

    def _in_N(self, parts, q, rotations):
        out = np.zeros(3, dtype=complex)
        for frame, components in parts:
            out += rotations(frame) @ np.asarray(components(q), dtype=complex).reshape(3)
        return out

    def mass_and_potential(self, q):
        cache = {self.N: np.eye(3, dtype=complex)}

        def rotation(frame):                     # N coordinates <- frame coordinates
            if frame not in cache:
                cache[frame] = rotation(self.parent[frame]) @ np.asarray(
                    self.dcm[frame](q), dtype=complex)
            return cache[frame]

        M = np.zeros((self.n, self.n), dtype=complex)
        for mass, inertia, frame, vc, w in self.bodies:
            Jv = np.array([self._in_N(x, q, rotation) for x in vc]).T
            Jw = rotation(frame).T @ np.array([self._in_N(x, q, rotation) for x in w]).T
            M += mass * Jv.T @ Jv + Jw.T @ inertia @ Jw
        return M, self._in_N(self.potential, q, rotation)[0]

    def values(self, q: np.ndarray, v: np.ndarray):
        M, V = self.mass_and_potential(q.astype(complex))
        h = 1e-30
        pdot = []
        for k in range(self.n):
            Mk, Vk = self.mass_and_potential(q + 1j * h * np.eye(self.n)[k])
            pdot.append((v @ Mk @ v / 2 - Vk).imag / h)
        return M.real, float((v @ M @ v / 2 + V).real), np.array(pdot)


CASES = ["planar3", "planar6", "spatial3", "spatial6", "tree"]


@pytest.mark.parametrize("kind", CASES)
def test_multibody_matches_sympy_mechanics(kind, isolated_cache):
    seed = CASES.index(kind) + 100
    spec = random_spec(kind, seed)
    rng = np.random.default_rng(seed)
    gravity = [float(rng.uniform(-1, 1)), float(rng.uniform(-1, 1)), -9.81]
    model = ph.compile_model(multibody(spec, gravity), backend="python")
    reference = Reference(spec, gravity)
    n = model.n_states // 2
    q_names = [f"mb.q.{name}" for name, j in spec.items() if j["type"] != "weld"]
    assert model.state_names[:n] == q_names
    for _ in range(3):
        q, v = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
        M, H, pdot = reference.values(q, v)
        x = np.concatenate([q, M @ v])
        M_model = model.matrix("mb.M", 0.0, x, model.param_defaults)
        assert np.max(np.abs(M_model - M)) <= 1e-10 * np.max(np.abs(M))
        xdot = np.asarray(model.functions.rhs(0.0, model.augment(x), model.native_params(
            model.param_defaults)))[: 2 * n]
        assert np.max(np.abs(xdot[:n] - v)) <= 1e-10 * np.max(np.abs(v))
        assert np.max(np.abs(xdot[n:] - pdot)) <= 1e-10 * np.max(np.abs(pdot))
        assert abs(model.energy(0.0, x, model.param_defaults)[0] - H) <= 1e-10 * abs(H)

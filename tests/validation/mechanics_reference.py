"""An independent derivation of a tree's mass matrix, energy and Hamilton's ṗ with
sympy.physics.mechanics, for the multibody validation tests (test_multibody_sympy_mechanics.py,
test_joints_3d.py).

A mechanism is a table of joints, parents first: name -> {type ("revolute", "prismatic",
"weld"), parent (a joint name or "world"), axis ("x", "y", "z" or a unit 3-vector in the parent's
frame), origin (parent frame), body: {mass, com, inertia (3x3 about the centre of mass)}}; each
joint carries the body of the same name. Massless bodies (mass 0) make multi-axis joints.
"""
from __future__ import annotations

import numpy as np
import sympy as sp
from sympy.physics import mechanics as me

AXES = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}


class Reference:
    """The mechanism in sympy.physics.mechanics: frames oriented about the joint axes
    (``orient_axis``), their angular velocities and the points' velocities set joint by joint
    (``set_ang_vel``, ``v2pt_theory``, ``v1pt_theory``), rigid bodies, and each body's partial
    velocities ∂v_c/∂u_j, ∂ω/∂u_j (Kane's ``partial_velocity``). Every vector is kept in the
    frames sympy forms it in; for the numbers, the relative orientations (``dcm``) and the vector
    components are lambdified — all in one function, evaluated once per q (a ``lambdify`` per
    array costs ~20 % more CPU for the whole derivation; the arrays' code, and so the numbers,
    are the same) — and composed with numpy, so that they take complex q.

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

        arrays: list = []               # every array the numbers need, lambdified at the end

        def numeric(expr) -> int:
            """The index of ``expr`` in the arrays the lambdified function returns."""
            arrays.append(expr)
            return len(arrays) - 1

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
        self.arrays = sp.lambdify([qs], arrays, "numpy")

    @staticmethod
    def _parts(vector, numeric):
        return [(frame, numeric(components)) for components, frame in vector.args]

    @staticmethod
    def _in_N(parts, arrays, rotations):
        out = np.zeros(3, dtype=complex)
        for frame, components in parts:
            out += rotations(frame) @ np.asarray(arrays[components], dtype=complex).reshape(3)
        return out

    def mass_and_potential(self, q):
        arrays = self.arrays(q)
        cache = {self.N: np.eye(3, dtype=complex)}

        def rotation(frame):                     # N coordinates <- frame coordinates
            if frame not in cache:
                cache[frame] = rotation(self.parent[frame]) @ np.asarray(
                    arrays[self.dcm[frame]], dtype=complex)
            return cache[frame]

        M = np.zeros((self.n, self.n), dtype=complex)
        for mass, inertia, frame, vc, w in self.bodies:
            Jv = np.array([self._in_N(x, arrays, rotation) for x in vc]).T
            Jw = rotation(frame).T @ np.array([self._in_N(x, arrays, rotation) for x in w]).T
            M += mass * Jv.T @ Jv + Jw.T @ inertia @ Jw
        return M, self._in_N(self.potential, arrays, rotation)[0]

    def values(self, q: np.ndarray, v: np.ndarray):
        M, V = self.mass_and_potential(q.astype(complex))
        h = 1e-30
        pdot = []
        for k in range(self.n):
            Mk, Vk = self.mass_and_potential(q + 1j * h * np.eye(self.n)[k])
            pdot.append((v @ Mk @ v / 2 - Vk).imag / h)
        return M.real, float((v @ M @ v / 2 + V).real), np.array(pdot)

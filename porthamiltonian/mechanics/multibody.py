"""Multibody trees in joint-space Hamiltonian form (DESIGN.md §4).

A :class:`Multibody` component holds rigid bodies joined by revolute, prismatic, translational and
weld joints in a tree rooted at the world frame. It compiles to

    q̇ = v,   M(q) v = p   (solved numerically, never inverted symbolically),
    ṗ_k = ½ vᵀ (∂M/∂q_k) v − ∂V/∂q_k + Q_k,
    H = ½ pᵀ v + V(q),

where M(q) = Σ_i J_iᵀ 𝕀_i J_i from the body Jacobians J_i (adjoint chain: the column of joint
DOF k in body i's Jacobian is Ad(H_i⁻¹ H_k) ξ_k, ξ_k the joint's unit twist in its own frame),
𝕀_i the spatial inertia in body frame i, V the gravity potential, and Q the generalized forces from
the ports.

Frames and conventions
----------------------
* Frame names follow :mod:`porthamiltonian.mechanics.screw`; twists (ω, v), wrenches (τ, f).
* A joint sits at ``origin`` (in the parent body's frame, m); its child body's frame has its origin
  at the joint and coincides with the parent's frame (shifted to ``origin``) when the joint
  coordinate is zero. Revolute: rotation by q (rad) about ``axis`` (right hand); prismatic: shift by
  q (m) along ``axis``; translational: shifts along several axes (one coordinate each, named by the
  axis, e.g. ``axes = ["x", "z"]``); weld: fixed.
* Body data are in the body's frame: ``mass`` (kg), ``com`` (m), ``inertia`` about the centre of
  mass (kg m², a 3x3 matrix, three principal values, or 0 for a point mass), ``points`` (named
  points, m).
* ``gravity`` is the acceleration of gravity in the world frame (m/s²), default (0, 0, −9.81).

States: ``<name>.q.<joint>`` (and ``<name>.q.<joint>.<axis>`` for translational joints) and the
conjugate momenta ``<name>.p.<...>``.

Ports (all optional, orientation set by the bond):
* one per joint with coordinates, named as the joint: effort = generalized force (N m or N),
  flow = joint velocity; dimension = its number of coordinates;
* one per body point, named as the point: effort = force (N), flow = velocity of the point (m/s),
  both in world coordinates (x, y, z), or (x, z) when ``plane = "xz"``;
* one per body frame (``frames``: origin in the body frame, axes parallel to the body's), named as
  the frame: screw domain, effort = wrench (τ, f), flow = twist (ω, v) of that frame, both in the
  frame's own coordinates.
When the bond points into the multibody, the effort is the force applied to it; when it points
out, the effort is the force the multibody exerts on the element (so an element can be connected
directly: ``connect("walker.foot", "contact.p")``).

Outputs: ``<name>.<point>.x|y|z`` (world position of each point), ``<name>.T`` and ``<name>.V``
(kinetic and potential energy, J). Matrices: ``<name>.M`` (mass matrix) and ``<name>.J.<point>``
(point Jacobian in world coordinates), for impact maps.

Limits: kinematic loops are not supported (each body has exactly one parent joint); bodies are
given by their inertial data, not by shapes.
"""
from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np
import sympy as sp

from ..component import Arg, Builder, Component, register
from ..errors import ModelError, UnknownComponentError
from ..ports import DOMAINS, Port
from .bodies import as_tables, expression_fields
from .kinematics import Frame, Rotation, Vector

_AXES = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}
_JOINT_TYPES = ("revolute", "prismatic", "translational", "weld")


def _axis(value: Any, where: str, path: tuple = ()) -> tuple:
    if isinstance(value, str) and value in _AXES:
        return _AXES[value]
    try:
        vec = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: axis must be 'x', 'y', 'z' or three numbers, got {value!r}",
                         path=path) from None
    if vec.shape != (3,) or not np.linalg.norm(vec) > 0:
        raise ModelError(f"{where}: axis must be a non-zero 3-vector, got {value!r}", path=path)
    vec = vec / np.linalg.norm(vec)
    return tuple(sp.nsimplify(v) if float(v).is_integer() else float(v) for v in vec)


def _vector3(value: Any, where: str, path: tuple = ()) -> list:
    if value is None:
        return [0, 0, 0]
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ModelError(f"{where}: expected three components [x, y, z], got {value!r}", path=path)
    return list(value)


@register
class Multibody(Component):
    """A tree of rigid bodies and joints in joint-space port-Hamiltonian form.

    See the module docstring for frames, states, ports, outputs and sign conventions.

    Parameters
    ----------
    bodies : name -> {mass, com, inertia, points}; values are numbers or expressions.
    joints : name -> {type, parent ("world" or a body), child (a body), axis | axes, origin,
        q0, v0}; ``q0``/``v0`` are the initial coordinate(s) and velocity(ies).
    gravity : [gx, gy, gz] in m/s², default [0, 0, "-9.81"].
    plane : "xz" for planar models: point ports carry (x, z) components only.
    """

    kind = "Multibody"
    arguments = {
        "bodies": Arg("name -> {mass, com, inertia, points}", symbolic=False),
        "joints": Arg("name -> {type, parent, child, axis/axes, origin, q0, v0}", symbolic=False),
        "gravity": Arg("gravity acceleration in world coordinates (m/s^2)", symbolic=False,
                       default=None),
        "plane": Arg("'xz' for planar point ports (x, z)", symbolic=False, default=None),
    }

    def __init__(self, **args: Any):
        if "bodies" in args and "joints" in args:
            args["bodies"], args["joints"] = as_tables(args["bodies"], args["joints"])
        super().__init__(**args)
        self._validate()

    # --- structure --------------------------------------------------------------------------------
    def _validate(self) -> None:
        bodies, joints = self.value("bodies"), self.value("joints")
        if not isinstance(bodies, Mapping) or not bodies:
            raise ModelError("Multibody needs 'bodies': a table name -> {mass, com, inertia, points}",
                             path=("bodies",))
        if not isinstance(joints, Mapping) or not joints:
            raise ModelError("Multibody needs 'joints': a table name -> {type, parent, child, ...}",
                             path=("joints",))
        for name, body in bodies.items():
            where = f"Multibody body {name!r}"
            extra = set(body) - {"mass", "com", "inertia", "points", "frames"}
            if extra:
                raise ModelError(f"{where}: unknown field(s) {', '.join(sorted(extra))}; fields: "
                                 "mass, com, inertia, points, frames",
                                 path=("bodies", name, min(extra)))
            if "mass" not in body:
                raise ModelError(f"{where} needs a mass (kg)", path=("bodies", name))
            mass = body["mass"]
            if isinstance(mass, (int, float)) and not mass > 0:
                raise ModelError(f"{where}: mass must be positive, got {mass}",
                                 path=("bodies", name, "mass"))
            self._inertia(body.get("inertia", 0), where, ("bodies", name, "inertia"))
            _vector3(body.get("com"), f"{where} com", ("bodies", name, "com"))
            for key in ("points", "frames"):
                for point, pos in (body.get(key) or {}).items():
                    _vector3(pos, f"{where} point/frame {point!r}", ("bodies", name, key, point))
        parent_of: dict[str, str] = {}
        for name, joint in joints.items():
            where = f"Multibody joint {name!r}"
            extra = set(joint) - {"type", "parent", "child", "axis", "axes", "origin", "q0", "v0"}
            if extra:
                raise ModelError(f"{where}: unknown field(s) {', '.join(sorted(extra))}; fields: type, "
                                 "parent, child, axis (revolute, prismatic), axes (translational), "
                                 "origin, q0, v0", path=("joints", name, min(extra)))
            jtype = joint.get("type")
            if jtype not in _JOINT_TYPES:
                raise ModelError(f"{where}: type must be one of {', '.join(_JOINT_TYPES)}, got {jtype!r}",
                                 path=("joints", name, "type"))
            parent, child = joint.get("parent"), joint.get("child")
            if parent != "world" and parent not in bodies:
                raise UnknownComponentError(f"{where}: parent {parent!r} is neither 'world' nor a body "
                                            f"({', '.join(bodies)})", path=("joints", name, "parent"))
            if child not in bodies:
                raise UnknownComponentError(f"{where}: child {child!r} is not a body ({', '.join(bodies)})",
                                            path=("joints", name, "child"))
            if child in parent_of:
                raise ModelError(
                    f"{where}: body {child!r} already hangs on joint {parent_of[child]!r}; a second "
                    "joint would close a kinematic loop, which is not supported (model the loop "
                    "with a stiff spring-damper between two points instead)",
                    path=("joints", name, "child"))
            parent_of[child] = name
            if jtype in ("revolute", "prismatic"):
                _axis(joint.get("axis"), where, ("joints", name, "axis"))
            if jtype == "translational":
                axes = joint.get("axes")
                if not isinstance(axes, list) or not axes:
                    raise ModelError(f"{where}: a translational joint needs axes, e.g. ['x', 'z']",
                                     path=("joints", name))
                for ax in axes:
                    if ax not in _AXES:
                        raise ModelError(f"{where}: translational axes are 'x', 'y' or 'z', got {ax!r}",
                                         path=("joints", name, "axes"))
        orphans = [b for b in bodies if b not in parent_of]
        if orphans:
            raise ModelError(f"Multibody bodies {', '.join(orphans)} hang on no joint; attach them "
                             "(a weld joint fixes a body to its parent)", path=("bodies", orphans[0]))
        for body in bodies:  # every chain must reach the world
            seen, node = set(), body
            while node != "world":
                if node in seen:
                    raise ModelError(f"Multibody joints form a cycle through body {body!r}; a tree "
                                     "rooted at 'world' is required")
                seen.add(node)
                node = joints[parent_of[node]]["parent"]
        names = [p for b in bodies.values()
                 for p in [*(b.get("points") or {}), *(b.get("frames") or {})]]
        coord_joints = [j for j, d in joints.items() if d["type"] != "weld"]
        dup = {n for n in names + coord_joints if (names + coord_joints).count(n) > 1}
        if dup:
            raise ModelError(f"Multibody port names must be unique; repeated: {', '.join(sorted(dup))}")
        if self.value("gravity") is not None:
            _vector3(self.value("gravity"), "Multibody gravity", ("gravity",))
        if self.value("plane") not in (None, "xz"):
            raise ModelError("Multibody plane must be 'xz' or absent", path=("plane",))
        self._parent_of = parent_of

    @staticmethod
    def _inertia(value: Any, where: str, path: tuple = ()) -> Any:
        """Inertia as a 3x3 nested list (point mass: 0), validated where numeric."""
        if isinstance(value, (int, float)) and value == 0:
            return 0
        if isinstance(value, (list, tuple)) and len(value) == 3 and not isinstance(value[0], (list, tuple)):
            value = [[value[0], 0, 0], [0, value[1], 0], [0, 0, value[2]]]
        if not (isinstance(value, (list, tuple)) and len(value) == 3
                and all(isinstance(r, (list, tuple)) and len(r) == 3 for r in value)):
            raise ModelError(f"{where}: inertia must be 0 (point mass), three principal moments or "
                             f"a 3x3 matrix, got {value!r}", path=path)
        try:
            numeric = np.array(value, dtype=float)
        except (TypeError, ValueError):
            return value
        if not np.allclose(numeric, numeric.T) or np.linalg.eigvalsh(numeric).min() <= 0:
            raise ModelError(f"{where}: rotational inertia must be symmetric positive definite (or 0 "
                             f"for a point mass), got eigenvalues {np.linalg.eigvalsh(numeric).round(12).tolist()}",
                             path=path)
        return value

    def expression_fields(self) -> Iterator[tuple[tuple, Any, str, tuple[str, ...]]]:
        """The expressions nested in the bodies, joints and gravity, with their key paths (see
        :meth:`Component.expression_fields` and :func:`.bodies.expression_fields`)."""
        for path, value, what in expression_fields(self.value("bodies"), self.value("joints"),
                                                   self.value("gravity")):
            yield path, value, what, ()

    def _coordinates(self) -> list[tuple[str, str, tuple, str]]:
        """(joint, coordinate label, axis, kind) for every joint coordinate, in joint order."""
        out = []
        for name, joint in self.value("joints").items():
            if joint["type"] in ("revolute", "prismatic"):
                kind = "rotation" if joint["type"] == "revolute" else "translation"
                out.append((name, name, _axis(joint["axis"], name), kind))
            elif joint["type"] == "translational":
                out += [(name, f"{name}.{ax}", _AXES[ax], "translation") for ax in joint["axes"]]
        return out

    def _point_dims(self) -> list[str]:
        return ["x", "z"] if self.value("plane") == "xz" else ["x", "y", "z"]

    def ports(self) -> list[Port]:
        ports = []
        coords = self._coordinates()
        for name in self.value("joints"):
            mine = [c for c in coords if c[0] == name]
            if mine:
                domain = "rotation" if mine[0][3] == "rotation" else "translation"
                ports.append(Port(name, domain, len(mine), None, "joint", f"joint {name}",
                                  optional=True))
        for body_name, body in self.value("bodies").items():
            for point in body.get("points") or {}:
                ports.append(Port(point, "translation", len(self._point_dims()), None, "world",
                                  f"point {point} of body {body_name}", optional=True))
            for frame in body.get("frames") or {}:
                ports.append(Port(frame, "screw", 6, None, frame,
                                  f"frame {frame} of body {body_name}: wrench (τ, f) / twist (ω, v) "
                                  "in the frame's own coordinates", optional=True))
        return ports

    # --- equations --------------------------------------------------------------------------------
    def build(self, b: Builder, bodies: dict[str, Any], joints: dict[str, Any],
              gravity: list | None, plane: str | None) -> None:
        coords = self._coordinates()
        joint_q0: dict[str, list] = {}
        for name, joint in joints.items():
            n = sum(1 for c in coords if c[0] == name)
            for key in ("q0", "v0"):
                value = joint.get(key, 0)
                values = value if isinstance(value, list) else [value] * n
                if len(values) != n:
                    raise ModelError(f"Multibody joint {name!r}: {key} needs {n} value(s), got {value!r}",
                                     path=("joints", name, key))
                joint_q0.setdefault(name, [])
                joint_q0[name].append([b.parse(v, f"joint {name!r} {key}") for v in values])
        q = [b.state(f"q.{label}", DOMAINS[kind].displacement_unit,
                     joint_q0[j][0][[c for c in coords if c[0] == j].index((j, label, ax, kind))])
             for j, label, ax, kind in coords]
        index = {(c[0], c[1]): k for k, c in enumerate(coords)}

        # kinematics (kept compact, see .kinematics): world frames of the bodies, and per body
        # the columns of its Jacobian: angular velocity (world) and velocity of a body-fixed point
        # as functions of the joint axes, both as sums of rotated constant vectors
        frames: dict[str, Frame] = {"world": Frame.world()}
        axes: dict[str, dict[int, tuple[str, Vector, Vector]]] = {"world": {}}
        for jname in self._tree_order():
            joint = joints[jname]
            frame = frames[joint["parent"]].compose(shift=[
                b.parse(v, f"joint {jname!r} origin")
                for v in _vector3(joint.get("origin"), f"joint {jname!r} origin")])
            columns = dict(axes[joint["parent"]])
            for (j, label, ax, kind) in (c for c in coords if c[0] == jname):
                k = index[(j, label)]
                axis = Vector.of(ax, frame.R)                  # joint axis, world coordinates
                columns[k] = (kind, axis, frame.p)
                if kind == "rotation":
                    frame = frame.compose(R=Rotation.about(ax, q[k]))
                else:
                    frame = frame.compose(shift=[a * q[k] for a in ax])
            frames[joint["child"]] = frame
            axes[joint["child"]] = columns

        # M(q) = Σ_i [m_i J_v,iᵀ J_v,i + J_ω,iᵀ R_i I_c,i R_iᵀ J_ω,i]: the spatial-inertia form
        # about each centre of mass, with every entry formed by relative rotations
        n = len(coords)
        M = sp.zeros(n, n)
        V = sp.Integer(0)
        g = sp.Matrix([b.parse(v, "gravity") for v in (gravity or [0, 0, "-9.81"])])
        points: dict[str, sp.Matrix] = {}
        frames_twist: dict[str, sp.Matrix] = {}   # frame port -> 6 x n twist Jacobian (frame axes)
        for body_name, body in bodies.items():
            frame = frames[body_name]
            mass = b.parse(body["mass"], f"body {body_name!r} mass")
            if mass != 0:               # > 0, or written as 0 (a massless body, e.g. "0*m")
                b.require(mass, ">", f"body {body_name!r} mass")
            com = [b.parse(v, f"body {body_name!r} com") for v in _vector3(body.get("com"), "com")]
            c_world = frame.point(com)
            linear, angular = {}, {}
            for k, (kind, axis, origin) in axes[body_name].items():
                if kind == "rotation":
                    angular[k] = axis
                    linear[k] = axis.cross(c_world - origin)
                else:
                    linear[k] = axis
            inertia = self._inertia(body.get("inertia", 0), f"body {body_name!r}")
            I_c = None if inertia == 0 else sp.Matrix(
                [[b.parse(v, f"body {body_name!r} inertia") for v in row] for row in inertia])
            body_axes = {k: w.in_frame(frame.R).matrix() for k, w in angular.items()}
            for j, lin_j in linear.items():
                for k, lin_k in linear.items():
                    if k < j:
                        continue
                    entry = mass * lin_j.dot(lin_k)
                    if I_c is not None and j in body_axes and k in body_axes:
                        entry += (body_axes[j].T * I_c * body_axes[k])[0, 0]
                    M[j, k] += entry
                    if k != j:
                        M[k, j] += entry
            V -= mass * (g.T * c_world.matrix())[0, 0]
            for point, pos in (body.get("points") or {}).items():
                points[point] = frame.point([b.parse(v, f"point {point!r}")
                                             for v in _vector3(pos, point)]).matrix()
            for name, pos in (body.get("frames") or {}).items():
                J_w = sp.zeros(3, n)
                for k, w in angular.items():
                    J_w[:, k] = w.in_frame(frame.R).matrix()        # body-axes angular velocity
                origin = frame.point([b.parse(v, f"frame {name!r}") for v in _vector3(pos, name)])
                J_o = origin.matrix().jacobian(q)
                frames_twist[name] = sp.Matrix.vstack(J_w, frame.R.matrix.T * J_o)
        M = M.applyfunc(sp.expand)

        # initial momenta p0 = M(q0) v0 (a product, no inversion)
        q0 = {q[k]: joint_q0[c[0]][0][[d for d in coords if d[0] == c[0]].index(c)]
              for k, c in enumerate(coords)}
        v0 = sp.Matrix([joint_q0[c[0]][1][[d for d in coords if d[0] == c[0]].index(c)]
                        for c in coords])
        p0 = M.xreplace(q0) * v0
        p = [b.state(f"p.{c[1]}", DOMAINS[c[3]].momentum_unit, p0[k])
             for k, c in enumerate(coords)]

        # intermediates keep the generated code local: mass-matrix entries, their derivatives
        # (for the Coriolis terms ½ vᵀ ∂M/∂q_k v) and the point Jacobians are computed once, and
        # the Jacobian of the state equations goes through them by the chain rule
        Mw = sp.zeros(n, n)
        dM: dict[int, list[tuple[int, int, sp.Expr]]] = {k: [] for k in range(n)}
        for i in range(n):
            for j in range(i, n):
                Mw[i, j] = Mw[j, i] = b.intermediate(f"M.{i}.{j}", M[i, j])
                for k in range(n):
                    d = sp.diff(M[i, j], q[k])
                    if d != 0:
                        dM[k].append((i, j, b.intermediate(f"dM.{i}.{j}.{k}", d)))
        v = b.implicit("v", Mw, sp.Matrix(p))
        vvec = sp.Matrix(v)

        Q = [sp.Integer(0)] * n
        dims = [("x", 0), ("y", 1), ("z", 2)]
        keep = [i for name, i in dims if name in self._point_dims()]
        point_jacobians: dict[str, sp.Matrix] = {}
        for point, pos in points.items():
            Jp = sp.Matrix([pos[i] for i in keep]).jacobian(q)
            point_jacobians[point] = sp.Matrix(Jp.rows, Jp.cols, lambda r, c, point=point, Jp=Jp:
                                               b.intermediate(f"J.{point}.{r}.{c}", Jp[r, c]))
        for port_name, pv in b.built.ports.items():
            s = b.sign(port_name)
            if port_name in frames_twist:
                J_T = frames_twist[port_name].applyfunc(sp.expand)
                J_T = sp.Matrix(6, n, lambda r, c, J_T=J_T, port_name=port_name:
                                b.intermediate(f"JT.{port_name}.{r}.{c}", J_T[r, c]))
                b.equation(sp.Matrix(pv.f), J_T * vvec, "frame twist = J_T(q) v")
                gen = J_T.T * sp.Matrix(pv.e)
                Q = [Q[k] + s * gen[k] for k in range(n)]
            elif port_name in points:
                Jp = point_jacobians[port_name]
                efforts = sp.Matrix(pv.e) if pv.port.dim > 1 else sp.Matrix([pv.e])
                flows = sp.Matrix(pv.f) if pv.port.dim > 1 else sp.Matrix([pv.f])
                b.equation(flows, Jp * vvec, "point velocity = J(q) v")
                gen = Jp.T * efforts
                Q = [Q[k] + s * gen[k] for k in range(n)]
            else:
                ks = [index[(c[0], c[1])] for c in coords if c[0] == port_name]
                efforts = [pv.e] if pv.port.dim == 1 else list(pv.e)
                flows = [pv.f] if pv.port.dim == 1 else list(pv.f)
                for k, e, f in zip(ks, efforts, flows):
                    b.equation(f, v[k], "joint velocity")
                    Q[k] = Q[k] + s * e
        for k in range(n):
            b.equation(b.der(q[k]), v[k], "dq/dt = v, M(q) v = p")
            coriolis = sum(((v[i] * v[j] if i != j else v[i] ** 2 / 2) * d for i, j, d in dM[k]),
                           sp.Integer(0))
            gravity_force = b.intermediate(f"dV.{k}", -sp.diff(V, q[k]))
            b.equation(b.der(p[k]), coriolis + gravity_force + Q[k],
                       "dp/dt = 1/2 v' dM/dq v - dV/dq + Q")
        kinetic = (sp.Matrix(p).T * vvec)[0, 0] / 2
        b.energy(kinetic + V)
        b.output("T", kinetic, "J")
        b.output("V", V, "J")
        for point, pos in points.items():
            for name, i in dims:
                b.output(f"{point}.{name}", pos[i], "m")
            b.matrix(f"J.{point}", point_jacobians[point])
        b.matrix("M", Mw)

    def _tree_order(self) -> list[str]:
        joints = self.value("joints")
        order, placed = [], {"world"}
        while len(order) < len(joints):
            for name, joint in joints.items():
                if name not in order and joint["parent"] in placed:
                    order.append(name)
                    placed.add(joint["child"])
        return order

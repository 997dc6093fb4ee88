"""Multibody trees in joint-space Hamiltonian form.

A :class:`Multibody` component holds rigid bodies joined by revolute, prismatic, translational,
universal, spherical, free and weld joints (:mod:`.joints`) in a tree rooted at the world frame.
With coordinates q, velocities v (joint rates, or the quasi-velocities of a quaternion joint: the
relative angular velocity, or twist, in the child's axes) and their momenta p it compiles to

    q̇ = K(q) v,   M(q) v = p   (solved numerically, never inverted symbolically),
    ṗ_s = Π_kᵀ ad_{T_k} S_s − ∂V/∂(S_s) + Q_s   for every unit twist S_s of every joint k,
    H = ½ pᵀ v + V(q),

with K the identity for revolute and prismatic coordinates and the quaternion kinematics
q̇ = ½ q ⊗ (0, ω) (and ṙ = R v) otherwise, V the gravity potential and Q the generalized forces
from the ports. For a revolute or prismatic joint Π_kᵀ ad_{T_k} S_k is ∂T/∂q_k at fixed velocities
(= ½ vᵀ ∂M/∂q_k v); for the rotations of a quaternion joint it also holds the gyroscopic term of
the quasi-velocities (Euler's L̇ = L × ω for one body); for a free joint from the world the rows are
the Lie–Poisson equation Ṗ = ad_Tᵀ P + W of the whole tree's momentum in the base's frame, as in
:mod:`.free_body`. Everything is formed recursively over the tree: the links' relative poses,
the composite (subtree) inertias and M(q) by the composite-rigid-body recursion; with v solved,
the body twists T_k (root to tip) and the subtree momenta Π_k (tip to root); gravity from the
subtree masses and first moments (never by differentiating M's entries). Two formulations give
the same numbers (docs/multibody.md):

* ``formulation = "kernel"``: one compiled recursive kernel (:mod:`.kernel`, ``kernel.c``) over
  the tree's numeric tables (:mod:`.kernel_tables`): axes, offsets, masses and inertias are
  run-time parameters, the generated code holds a table entry per link whatever the axes, and
  the Jacobian passes through the kernel by its forward-mode tangents;
* ``formulation = "symbolic"``: the recursion written out as compiler intermediates
  (:mod:`.tree`): exact zeros fold (a planar walker's code is small and fast), the code grows as
  about N² along an N-link chain, and much faster with axes that are not coordinate axes; the
  Jacobian follows by the chain rule through the intermediates;
* ``"auto"`` (default): the kernel when an axis is not along a coordinate axis or the tree has
  more than :data:`KERNEL_LINKS` links (and its tables depend on parameters only), else
  symbolic; a tree with ``loops`` or ``constraints`` goes to the kernel only when it has more
  than :data:`KERNEL_LINKS` links (:func:`auto_kernel`), where the kernel solves the
  constrained equations too (:func:`.constrained.constrain_kernel`).

Frames and conventions
----------------------
* Frame names follow :mod:`porthamiltonian.mechanics.screw`; twists (ω, v), wrenches (τ, f).
* A joint sits at ``origin`` (in the parent body's frame, m); its child body's frame has its origin
  at the joint and coincides with the parent's frame (shifted to ``origin``) at zero coordinates
  (identity quaternion). Revolute: rotation by q (rad) about ``axis`` (right hand); prismatic:
  shift by q (m) along ``axis``; translational: shifts along several axes (one coordinate each,
  named by the axis, e.g. ``axes = ["x", "z"]``); universal: rotations about ``axes[0]`` then
  ``axes[1]``; spherical: the rotation of a unit quaternion; free: a shift (parent axes) and a
  rotation; weld: fixed. :mod:`.joints` lists the coordinates, velocities and ports of each type.
* Body data are in the body's frame: ``mass`` (kg), ``com`` (m), ``inertia`` about the centre of
  mass (kg m², a 3x3 matrix, three principal values, or 0 for a point mass), ``points`` (named
  points, m).
* ``gravity`` is the acceleration of gravity in the world frame (m/s²), default (0, 0, −9.81).
* A quaternion's rotation is that of q/|q|: a drift of |q| changes nothing physical, and the
  term ``quaternion_gain``/2 (1 − |q|²) q of its rate (along q, no work) pulls |q| back to 1.

States: ``<name>.q.<coordinate>`` and the momenta ``<name>.p.<velocity>`` (labels in
:mod:`.joints`: ``<joint>``, ``<joint>.<axis>``, ``<joint>.qw`` …, ``<joint>.wx`` …).

Ports (all optional, orientation set by the bond):
* one per joint with velocities, named as the joint: effort = generalized force (N m, N, or a
  wrench for a free joint), flow = the joint's velocities; dimension = their number;
* one per body point, named as the point: effort = force (N), flow = velocity of the point (m/s),
  both in world coordinates (x, y, z), or (x, z) when ``plane = "xz"``;
* one per body frame (``frames``: origin in the body frame, axes parallel to the body's), named as
  the frame: screw domain, effort = wrench (τ, f), flow = twist (ω, v) of that frame, both in the
  frame's own coordinates;
* one per world-aligned body frame (``world_frames``: origin fixed in the body frame, axes
  parallel to the world's), named as the frame: screw domain, effort = wrench (τ about the
  frame's origin, f), flow = (ω, v) with ω the body's angular velocity and v the velocity of the
  origin, all in world coordinates (x, y, z); with ``plane = "xz"`` the three planar components
  (τ_y, f_x, f_z) and (ω_y, v_x, v_z). This is the port of the 3D contacts and frictions
  (:mod:`porthamiltonian.library.contact3d`): a sphere's centre, where the contact needs the
  body's rotation as well as the centre's velocity.
When the bond points into the multibody, the effort is the force applied to it; when it points
out, the effort is the force the multibody exerts on the element (so an element can be connected
directly: ``connect("walker.foot", "contact.p")``).

Outputs: ``<name>.v.<velocity>`` (each velocity v = ∂H/∂p, rad/s or m/s; its rate, the
acceleration ``<name>.a.<velocity>`` of a revolute, prismatic, translational or universal joint,
is evaluated exactly by the compiled model: ``CompiledModel.accelerations``, ``traj[...]``),
``<name>.<point>.x|y|z`` (world position of each point and world frame, m), ``<name>.T`` and
``<name>.V`` (kinetic and potential energy, J), ``<name>.<joint>.q_norm`` (|q| of each quaternion
joint), and each body's pose (for :mod:`porthamiltonian.interfaces.viewer`): ``<name>.<body>.pose.x|y|z``
(the origin of its frame, world coordinates, m) and ``<name>.<body>.pose.qw|qx|qy|qz`` (the unit
quaternion of its orientation, Hamilton, scalar first, body to world: x_W = p + R(q) x_B), for
planar models too.
Matrices: ``<name>.M`` (mass matrix, M v = p) and ``<name>.J.<point>`` (the point's velocity is
J v, world coordinates), for impact maps.

Closed loops and constraints (:mod:`.closure`, :mod:`.constrained`): a ``loops`` table of
loop-closing joints (any joint type but free, between two bodies or a body and the world) and a
``constraints`` table (a point held on a point or a world position, a locked joint, a disc or a
ball rolling without slipping), each row G(q) v = 0 (and φ(q) = 0 when holonomic) enforced by a
multiplier λ solved from the index-reduced equations in the generated code, with the drift
stabilized at the rate ``constraint_gain``. Outputs ``<name>.reaction.<constraint>.<row>`` (the
constraint forces and torques), ``<name>.phi.<constraint>.<row>`` (the residuals),
``<name>.velocity.<constraint>.<row>`` (G v), ``<name>.active.<constraint>``; matrices
``<name>.G``, ``<name>.G.<constraint>`` (for impacts onto a constraint) and ``<name>.S`` (the
rows' switches).

Limits: bodies are given by their inertial data, not by shapes.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import Any

import numpy as np
import sympy as sp

from ..errors import ModelError, UnknownComponentError
from ..modeling.component import Arg, Builder, Component, register
from ..modeling.ports import Port
from . import closure, constrained
from .bodies import as_tables, expression_fields
from .inertia import numeric_problem, require_consistent
from .joints import Joint, joint, quaternion_slice, units
from .kernel_tables import FRAME, POINT, WORLD_FRAME, KernelTree, Site
from .kinematics import ZERO3, add, cross, dot, named, scale, written_out
from .poisson import poisson_rates
from .tree import COORDINATES, DOFS, Link, Tree, coordinate_rates, quaternion_rotation

#: the largest number of links (one per joint velocity; spherical and free joints count one)
#: that ``formulation = "auto"`` writes out as symbolic code when every axis is a coordinate axis
#: (every shipped model: compliant_leg_walker_3d has 9)
KERNEL_LINKS = 9
FORMULATIONS = ("auto", "kernel", "symbolic")


def auto_kernel(axes: list, parametric: bool, closed: bool = False) -> bool:
    """What ``formulation = "auto"`` picks for a tree of elementary links with these ``axes``
    (None for a link without one): the kernel when its tables depend on parameters only
    (``parametric``) and there are more than :data:`KERNEL_LINKS` links, or, without loops or
    constraints (``closed``), an axis is not along a coordinate axis (±). A small closed tree
    is written out (the shipped loop models: the saddle-point solve in generated code is the
    faster there); a large one goes to the kernel, which builds the 10-loop ladder of
    benchmarks/bench_closed_loops.py (30 links) in about half the CPU time of the written-out
    equations and runs it at about 1/3 of the open tree's speed per step (benchmarks/RESULTS.md)."""
    generic = any(axis is not None and sum(1 for a in axis if a != 0) > 1 for axis in axes)
    return parametric and (len(axes) > KERNEL_LINKS or (generic and not closed))


def _formulation(value: Any) -> None:
    if value not in FORMULATIONS:
        raise ModelError(f"Multibody formulation must be one of {', '.join(FORMULATIONS)}, got "
                         f"{value!r}")


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
    formulation : "kernel", "symbolic" or "auto" (default; see the module docstring).
    """

    kind = "Multibody"
    arguments = {
        "bodies": Arg("name -> {mass, com, inertia, points}", symbolic=False),
        "joints": Arg("name -> {type, parent, child, axis/axes, origin, q0, v0}", symbolic=False),
        "gravity": Arg("gravity acceleration in world coordinates (m/s^2)", symbolic=False,
                       default=None),
        "plane": Arg("'xz' for planar point ports (x, z)", symbolic=False, default=None),
        "quaternion_gain": Arg("rate at which a spherical or free joint's quaternion is pulled "
                               "back to unit norm", "1/s", default=1, rule=">="),
        "loops": Arg("name -> {type, parent, child, origin, child_origin, axis/axes, active}: "
                     "loop-closing joints", symbolic=False, default=None),
        "constraints": Arg("name -> {type: point|lock|rolling|sphere, ...}: constraints on "
                           "points, joints and the ground", symbolic=False, default=None),
        "constraint_gain": Arg("rate at which a constraint's drift (position and velocity "
                               "error) decays", "1/s", default=10, rule=">="),
        "formulation": Arg("'kernel' (the compiled recursion over the tree's tables), 'symbolic' "
                           "(the recursion written out as code) or 'auto'", symbolic=False,
                           default="auto", check=_formulation),
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
        if "world" in bodies:
            raise ModelError("Multibody body 'world': 'world' is the fixed frame that joints hang "
                             "from (parent = \"world\"), so no body may be called that; rename "
                             "the body", path=("bodies", "world"))
        for name, body in bodies.items():
            where = f"Multibody body {name!r}"
            extra = set(body) - {"mass", "com", "inertia", "points", "frames", "world_frames"}
            if extra:
                raise ModelError(f"{where}: unknown field(s) {', '.join(sorted(extra))}; fields: "
                                 "mass, com, inertia, points, frames, world_frames",
                                 path=("bodies", name, min(extra)))
            if "mass" not in body:
                raise ModelError(f"{where} needs a mass (kg)", path=("bodies", name))
            mass = body["mass"]
            if isinstance(mass, (int, float)) and not mass > 0:
                raise ModelError(f"{where}: mass must be positive, got {mass}",
                                 path=("bodies", name, "mass"))
            self._inertia(body.get("inertia", 0), where, ("bodies", name, "inertia"),
                          planar=self.value("plane") == "xz")
            _vector3(body.get("com"), f"{where} com", ("bodies", name, "com"))
            for key in ("points", "frames", "world_frames"):
                for point, pos in (body.get(key) or {}).items():
                    _vector3(pos, f"{where} point/frame {point!r}", ("bodies", name, key, point))
        parent_of: dict[str, str] = {}
        for name, table in joints.items():
            where = f"Multibody joint {name!r}"
            extra = set(table) - {"type", "parent", "child", "axis", "axes", "origin", "q0", "v0"}
            if extra:
                raise ModelError(f"{where}: unknown field(s) {', '.join(sorted(extra))}; fields: type, "
                                 "parent, child, axis (revolute, prismatic), axes (translational, "
                                 "universal), origin, q0, v0", path=("joints", name, min(extra)))
            joint(name, table)                      # type, axis, axes
            parent, child = table.get("parent"), table.get("child")
            if parent != "world" and parent not in bodies:
                raise UnknownComponentError(f"{where}: parent {parent!r} is neither 'world' nor a body "
                                            f"({', '.join(bodies)})", path=("joints", name, "parent"))
            if child not in bodies:
                raise UnknownComponentError(f"{where}: child {child!r} is not a body ({', '.join(bodies)})",
                                            path=("joints", name, "child"))
            if child in parent_of:
                raise ModelError(
                    f"{where}: body {child!r} already hangs on joint {parent_of[child]!r}; a second "
                    "joint would close a kinematic loop: declare it in the multibody's 'loops' "
                    "table instead (a loop-closing joint)", path=("joints", name, "child"))
            parent_of[child] = name
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
                 for p in [*(b.get("points") or {}), *(b.get("frames") or {}),
                           *(b.get("world_frames") or {})]]
        coord_joints = [j for j, d in joints.items() if d["type"] != "weld"]
        dup = {n for n in names + coord_joints if (names + coord_joints).count(n) > 1}
        if dup:
            raise ModelError(f"Multibody port names must be unique; repeated: {', '.join(sorted(dup))}")
        if self.value("gravity") is not None:
            _vector3(self.value("gravity"), "Multibody gravity", ("gravity",))
        if self.value("plane") not in (None, "xz"):
            raise ModelError("Multibody plane must be 'xz' or absent", path=("plane",))
        closure.validate(self.value("loops"), self.value("constraints"), bodies, joints,
                         {point: body_name for body_name, (point, _) in self._points()})
        self._parent_of = parent_of

    def _points(self) -> Iterator[tuple[str, tuple[str, Any]]]:
        """(body, (point, local position)) of every point, frame and world frame."""
        for body_name, body in self.value("bodies").items():
            for key in ("points", "frames", "world_frames"):
                for point, pos in (body.get(key) or {}).items():
                    yield body_name, (point, pos)

    @staticmethod
    def _inertia(value: Any, where: str, path: tuple = (), planar: bool = False) -> Any:
        """Inertia as a 3x3 nested list (point mass: 0), checked where numeric
        (:func:`.inertia.numeric_problem`: physically consistent; in the x-z plane I_yy >= 0)."""
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
        problem = numeric_problem(numeric, planar=planar)
        if problem is not None:
            raise ModelError(f"{where}: {problem} (or 0 for a point mass)", path=path)
        return value

    def expression_fields(self) -> Iterator[tuple[tuple, Any, str, tuple[str, ...]]]:
        """The expressions nested in the bodies, joints and gravity, with their key paths (see
        :meth:`Component.expression_fields` and :func:`.bodies.expression_fields`)."""
        for path, value, what in expression_fields(self.value("bodies"), self.value("joints"),
                                                   self.value("gravity")):
            yield path, value, what, ()
        for path, value, what in closure.expression_fields(self.value("loops"),
                                                           self.value("constraints")):
            yield path, value, what, ()

    def _joints(self) -> list[Joint]:
        """The joints' structures, in the order of the table."""
        return [joint(name, table) for name, table in self.value("joints").items()]

    def _point_dims(self) -> list[str]:
        return ["x", "z"] if self.value("plane") == "xz" else ["x", "y", "z"]

    def ports(self) -> list[Port]:
        ports = []
        for spec in self._joints():
            if spec.velocities and spec.domain is not None:    # (a fixed joint has neither)
                ports.append(Port(spec.name, spec.domain, len(spec.velocities), None, "joint",
                                  f"joint {spec.name}", optional=True))
        for body_name, body in self.value("bodies").items():
            for point in body.get("points") or {}:
                ports.append(Port(point, "translation", len(self._point_dims()), None, "world",
                                  f"point {point} of body {body_name}", optional=True))
            for frame in body.get("frames") or {}:
                ports.append(Port(frame, "screw", 6, None, frame,
                                  f"frame {frame} of body {body_name}: wrench (τ, f) / twist (ω, v) "
                                  "in the frame's own coordinates", optional=True))
            for frame in body.get("world_frames") or {}:
                ports.append(Port(frame, "screw", 3 if self.value("plane") == "xz" else 6, None, "world",
                                  f"world-aligned frame {frame} of body {body_name}: wrench "
                                  "(τ, f) / twist (ω, v) in world coordinates", optional=True))
        return ports

    # --- equations --------------------------------------------------------------------------------
    def build(self, b: Builder, bodies: dict[str, Any], joints: dict[str, Any],
              gravity: list | None, plane: str | None, quaternion_gain: sp.Expr,
              loops: dict | None, constraints: dict | None, constraint_gain: sp.Expr,
              formulation: str) -> None:
        specs = self._joints()
        q0, v0 = self._initial(b, joints, specs)
        links, placement = self._links(b, joints, specs)
        g = [b.parse(v, "gravity") for v in (gravity or [0, 0, "-9.81"])]
        static_first = list(ZERO3)          # first moment of the bodies welded to the world
        for name, body in bodies.items():
            where = f"body {name!r}"
            mass = b.parse(body["mass"], f"{where} mass")
            if mass != 0:               # > 0, or written as 0 (a massless body, e.g. "0*m")
                b.require(mass, ">", f"{where} mass")
            com = [b.parse(v, f"{where} com") for v in _vector3(body.get("com"), "com")]
            inertia = self._inertia(body.get("inertia", 0), where, planar=plane == "xz")
            I_c = None if inertia == 0 else [[b.parse(v, f"{where} inertia") for v in row]
                                             for row in inertia]
            if I_c is not None:
                require_consistent(b, I_c, f"{where} inertia", planar=plane == "xz")
            link, offset = placement[name]
            if link is None:
                static_first = add(static_first, scale(mass, add(offset, com)))
            else:
                link.add_body(mass, add(offset, com), I_c)
        sites = self._sites(b, bodies, placement)
        if self._kernel(b, formulation, links, g, static_first, sites,
                        closed=bool(loops or constraints)):
            self._build_kernel(b, bodies, plane, quaternion_gain, specs, q0, v0, links,
                               placement, g, static_first, sites, constraint_gain)
        else:
            self._build_symbolic(b, bodies, joints, plane, quaternion_gain, specs, q0, v0,
                                 links, placement, g, static_first, constraint_gain)

    def _states(self, b: Builder, specs: list[Joint], q0: list, p0: list) -> tuple[list, list]:
        """The states: the coordinates q (initial q0) and momenta p (initial p0)."""
        coordinates = [label for spec in specs for label in spec.coordinates]
        velocities = [label for spec in specs for label in spec.velocities]
        q_units = [u for spec in specs for u in units(spec)[0]]
        p_units = [u for spec in specs for u in units(spec)[1]]
        q = [b.state(f"q.{label}", unit, value)
             for label, unit, value in zip(coordinates, q_units, q0)]
        p = [b.state(f"p.{label}", unit, value)
             for label, unit, value in zip(velocities, p_units, p0)]
        return q, p

    def _sites(self, b: Builder, bodies: dict[str, Any], placement: dict) -> dict[str, tuple]:
        """Every point and frame: name -> (link or None, position in the link's frame, kind)."""
        out = {}
        for body_name, body in bodies.items():
            link, offset = placement[body_name]
            for key, kind in (("points", POINT), ("frames", FRAME), ("world_frames", WORLD_FRAME)):
                what = "point" if key == "points" else "frame"
                for name, pos in (body.get(key) or {}).items():
                    local = add(offset, [b.parse(c, f"{what} {name!r}") for c in _vector3(pos, name)])
                    out[name] = (link, local, kind)
        return out

    def _kernel(self, b: Builder, formulation: str, links: list[Link], g: list,
                static_first: list, sites: dict[str, tuple], closed: bool) -> bool:
        """Whether the tree is evaluated by the kernel (see the module docstring). The
        port-Hamiltonian form's cut build (``b.ph``) writes the Poisson structure out
        symbolically in either formulation: it needs the kinematics only (v = ∂H/∂p stands for
        the kernel's M⁻¹p), and ∇H comes from the kernel's tangents. With loops or constraints
        (``closed``) the kernel also solves the constrained equations (``mb_constrained``)."""
        if formulation == "symbolic" or b.ph is not None:
            return False
        tables = [*g, *static_first, *(c for _, local, _ in sites.values() for c in local)]
        for link in links:
            tables += [*link.offset, link.mass, *link.first, *(e for row in link.inertia for e in row)]
        stray = [e for e in tables if not b.parametric(e)]
        if formulation == "kernel":
            if stray:
                raise ModelError(f"Multibody formulation 'kernel': the tree's masses, inertias, "
                                 f"offsets, points and gravity must depend on parameters only, "
                                 f"not {stray[0]}; use formulation = 'symbolic'",
                                 path=("formulation",))
            return True
        return auto_kernel([link.axis for link in links], parametric=not stray, closed=closed)

    def _build_kernel(self, b: Builder, bodies: dict[str, Any], plane: str | None,
                      quaternion_gain: sp.Expr, specs: list[Joint], q0: list, v0: list,
                      links: list[Link], placement: dict, g: list, static_first: list,
                      sites: dict[str, tuple], constraint_gain: sp.Expr) -> None:
        """The tree evaluated by the recursive kernel over its numeric tables
        (:mod:`.kernel_tables`); the ports, outputs and rates around it as in the symbolic
        formulation; the loops and constraints enforced by the kernel's constrained entry on
        rows written out from the tree's positions only (:func:`.constrained.constrain_kernel`)."""
        nq = sum(len(spec.coordinates) for spec in specs)
        tree = KernelTree(b, links, g, static_first, nq)
        n = tree.nv
        p0 = tree.momenta(q0, v0) if any(value != 0 for value in v0) else [sp.Integer(0)] * n
        q, p = self._states(b, specs, q0, p0)
        moving = {name: Site(link, tuple(local), kind)
                  for name, (link, local, kind) in sites.items() if link is not None}
        v, Q, potential, per_site = tree.state(q, p, list(moving.values()))
        at = dict(zip(moving, per_site))
        Q = list(Q)

        posed = [name for name in bodies if placement[name][0] is not None]
        poses = dict(zip(posed, tree.poses(q, [Site(placement[name][0], tuple(placement[name][1]))
                                              for name in posed]))) if posed else {}
        for body_name in bodies:                    # poses, for the 3D viewer
            origin, quaternion = poses.get(body_name, (placement[body_name][1], [1, 0, 0, 0]))
            for axis, value in zip("xyz", origin):
                b.output(f"{body_name}.pose.{axis}", value, "m")
            for label, value in zip(("qw", "qx", "qy", "qz"), quaternion):
                b.output(f"{body_name}.pose.{label}", value, "1")

        dims = [i for i, axis in enumerate("xyz") if axis in self._point_dims()]
        rotations = [1] if plane == "xz" else [0, 1, 2]
        points = [name for name, (_, _, kind) in sites.items() if kind == POINT]
        jacobians = dict(zip([x for x in points if x in moving],
                             tree.jacobians(q, [moving[x] for x in points if x in moving])
                             if any(x in moving for x in points) else []))
        loads: list[tuple[Site, list, list]] = []
        for name, (link, local, kind) in sites.items():
            pv, s = b.port(name), b.sign(name)
            efforts = list(pv.e) if pv.port.dim > 1 else [pv.e]
            if kind == FRAME:
                b.equation(sp.Matrix(pv.f), sp.Matrix(at[name][:6]) if link is not None
                           else sp.zeros(6, 1), "frame twist (ω, v), frame axes")
                if link is not None and b.connected(name):
                    loads.append((moving[name], [s * e for e in efforts[:3]],
                                  [s * e for e in efforts[3:]]))
                continue
            if link is None:
                x, omega, velocity = local, list(ZERO3), list(ZERO3)
            else:
                x = at[name][:3]
                omega, velocity = (at[name][3:6], at[name][6:9]) if kind == WORLD_FRAME else (
                    list(ZERO3), at[name][3:6])
            for i, axis in enumerate("xyz"):
                b.output(f"{name}.{axis}", x[i], "m")
            torque, force = [sp.S.Zero] * 3, [sp.S.Zero] * 3
            if kind == POINT:
                b.matrix(f"J.{name}", jacobians[name][dims, :] if link is not None
                         else sp.zeros(len(dims), n))
                b.equation(sp.Matrix(pv.f if pv.port.dim > 1 else [pv.f]),
                           sp.Matrix([velocity[i] for i in dims]), "point velocity (world)")
                for i, e in zip(dims, efforts):
                    force[i] = s * e
            else:
                b.equation(sp.Matrix(pv.f), sp.Matrix([omega[i] for i in rotations]
                                                      + [velocity[i] for i in dims]),
                           "world-aligned frame twist (ω, v), world axes")
                for i, e in zip(rotations + [3 + i for i in dims], efforts):
                    if i < 3:
                        torque[i] = s * e
                    else:
                        force[i - 3] = s * e
            if link is not None and b.connected(name):
                loads.append((moving[name], torque, force))
        if loads:
            Q = [a + c for a, c in zip(Q, tree.load(q, loads))]

        quaternions: dict[Link, Any] = {}

        def rotation(link: Link) -> Any:            # (once per link: the loops ask again)
            if link not in quaternions:
                c = link.coordinate
                quaternions[link] = quaternion_rotation(q[c + 3:c + 7], b.intermediate,
                                                        f"mb.{link.name}.rot")
            return quaternions[link]

        rates = coordinate_rates(links, q, v, quaternion_gain, rotation)
        close = None
        if self.value("loops") or self.value("constraints"):
            def close(Q: list, rates: list) -> tuple[list, list]:
                geometry = Tree(links, self._maker(b))
                geometry.positions(q)
                geometry.world()
                rows = self._rows(b, geometry, placement, specs, q)
                return constrained.constrain_kernel(
                    b, rows, q, v, Q, rates,
                    lambda w: coordinate_rates(links, q, w, 0, rotation), constraint_gain,
                    f"Multibody {b.name!r}", tree.constrained)
        self._finish(b, specs, q, p, v, Q, rates, potential, tree.mass_matrix(q), close)

    @staticmethod
    def _maker(b: Builder) -> Callable[[str, Any], Any]:
        """The tree's intermediate maker: ``mb.<name>`` (atoms and their negatives as they are)."""
        def make(name: str, expr: Any) -> Any:
            expr = sp.sympify(expr)
            if expr.is_Atom or (expr.is_Mul and len(expr.args) == 2 and expr.args[0] == -1
                                and expr.args[1].is_Atom):
                return expr
            return b.intermediate(f"mb.{name}", expr)
        return make

    def _build_symbolic(self, b: Builder, bodies: dict[str, Any], joints: dict[str, Any],
                        plane: str | None, quaternion_gain: sp.Expr, specs: list[Joint],
                        q0: list, v0: list, links: list[Link], placement: dict, g: list,
                        static_first: list, constraint_gain: sp.Expr) -> None:
        """The tree's recursion written out as compiler intermediates (:mod:`.tree`); in the
        port-Hamiltonian form's cut build (``b.ph``), its Poisson structure
        (:mod:`.poisson`); the loops and constraints enforced (:mod:`.constrained`)."""
        n = sum(len(spec.velocities) for spec in specs)
        # initial momenta p0 = M(q0) v0, as S_kᵀ Π_k of the same recursion written out
        p0 = [sp.Integer(0)] * n
        if any(value != 0 for value in v0):
            start = Tree(links, written_out)
            start.positions(q0)
            start.velocities(v0)
            p0 = start.generalized_momenta()
        q, p = self._states(b, specs, q0, p0)
        make = self._maker(b)
        tree = Tree(links, make)
        tree.positions(q)
        tree.world()
        tree.composites()
        M = tree.mass_matrix()
        if b.ph is None:
            v = b.implicit("v", M, sp.Matrix(p))
        else:                       # the pH form's cut build: v = ∂H/∂p (mechanics/poisson.py)
            v = [b.ph.eta(pk) for pk in p]
        tree.velocities(v)
        tree.gravity(g)
        if b.ph is None:
            Q = [a + c for a, c in zip(tree.velocity_forces(), tree.gravity_forces())]
        else:
            Q = poisson_rates(specs, joints, tree.coordinate_rates(q, v, 0), q, p,
                              [b.ph.eta(qk) for qk in q], v, f"Multibody {b.name!r}")
        first = list(static_first)                  # Σ m c over all bodies, world frame
        for root in (link for link in links if link.parent is None):
            P = tree.pos[root]
            first = add(first, scale(P.cmass, P.world_p), P.world_R.apply(P.cfirst))
        potential = -dot(g, first)

        tree.orientations()
        for body_name in bodies:                    # poses, for the 3D viewer
            link, offset = placement[body_name]
            origin, quaternion = (offset, [1, 0, 0, 0]) if link is None else (
                tree.point(link, offset), tree.pos[link].world_q)
            for axis, value in zip("xyz", origin):
                b.output(f"{body_name}.pose.{axis}", value, "m")
            for label, value in zip(("qw", "qx", "qy", "qz"), quaternion):
                b.output(f"{body_name}.pose.{label}", value, "1")

        dims = [i for i, axis in enumerate("xyz") if axis in self._point_dims()]
        for body_name, body in bodies.items():
            link, offset = placement[body_name]
            for point, pos in (body.get("points") or {}).items():
                local = add(offset, [b.parse(c, f"point {point!r}") for c in _vector3(pos, point)])
                J = sp.zeros(3, n)
                if link is None:
                    x, velocity = local, list(ZERO3)
                else:
                    x = named(make, f"at.{point}", tree.point(link, local))
                    velocity = named(make, f"at.{point}.velocity", tree.point_velocity(link, local))
                    for k, column in tree.columns(link, x):
                        J[:, k] = sp.Matrix(column)
                for i, axis in enumerate("xyz"):
                    b.output(f"{point}.{axis}", x[i], "m")
                b.matrix(f"J.{point}", J[dims, :])
                pv, s = b.port(point), b.sign(point)
                efforts = list(pv.e) if pv.port.dim > 1 else [pv.e]
                force = [sp.S.Zero] * 3
                for i, e in zip(dims, efforts):
                    force[i] = e
                b.equation(sp.Matrix(pv.f if pv.port.dim > 1 else [pv.f]),
                           sp.Matrix([velocity[i] for i in dims]), "point velocity (world)")
                if link is not None:
                    for k, value in tree.load(link, x, ZERO3, force):
                        Q[k] = Q[k] + s * value
            for frame, pos in (body.get("frames") or {}).items():
                pv, s = b.port(frame), b.sign(frame)
                local = add(offset, [b.parse(c, f"frame {frame!r}") for c in _vector3(pos, frame)])
                if link is None:
                    b.equation(sp.Matrix(pv.f), sp.zeros(6, 1), "frame twist (fixed)")
                    continue
                w, lin = tree.twist[link]
                b.equation(sp.Matrix(pv.f), sp.Matrix(w + add(lin, cross(w, local))),
                           "frame twist (ω, v), frame axes")
                R = tree.pos[link].world_R
                x = named(make, f"at.{frame}", tree.point(link, local))
                for k, value in tree.load(link, x, R.apply(list(pv.e[:3])), R.apply(list(pv.e[3:]))):
                    Q[k] = Q[k] + s * value
            for frame, pos in (body.get("world_frames") or {}).items():
                local = add(offset, [b.parse(c, f"frame {frame!r}") for c in _vector3(pos, frame)])
                pv, s = b.port(frame), b.sign(frame)
                rotations = [1] if plane == "xz" else [0, 1, 2]
                if link is None:
                    x, omega, velocity = local, list(ZERO3), list(ZERO3)
                else:
                    x = named(make, f"at.{frame}", tree.point(link, local))
                    omega = tree.pos[link].world_R.apply(tree.twist[link][0])
                    velocity = tree.point_velocity(link, local)
                for i, axis in enumerate("xyz"):
                    b.output(f"{frame}.{axis}", x[i], "m")
                b.equation(sp.Matrix(pv.f), sp.Matrix([omega[i] for i in rotations]
                                                      + [velocity[i] for i in dims]),
                           "world-aligned frame twist (ω, v), world axes")
                if link is None:
                    continue
                torque, force = list(ZERO3), list(ZERO3)
                for i, e in zip(rotations + [3 + i for i in dims], pv.e):
                    if i < 3:
                        torque[i] = e
                    else:
                        force[i - 3] = e
                for k, value in tree.load(link, x, torque, force):
                    Q[k] = Q[k] + s * value
        rates = tree.coordinate_rates(q, v, quaternion_gain if b.ph is None else 0)
        close = None
        if self.value("loops") or self.value("constraints"):
            def close(Q: list, rates: list) -> tuple[list, list]:
                rows = self._rows(b, tree, placement, specs, q)
                return constrained.constrain(b, rows, q, v, M, tree.velocity_products, Q, rates,
                                             lambda w: tree.coordinate_rates(q, w, 0),
                                             constraint_gain, f"Multibody {b.name!r}")
        self._finish(b, specs, q, p, v, Q, rates, potential, M, close)

    def _finish(self, b: Builder, specs: list[Joint], q: list, p: list, v: list, Q: list,
                rates: list, potential: Any, M: sp.Matrix,
                close: Callable[[list, list], tuple[list, list]] | None = None) -> None:
        """The joint ports, the state equations, the velocities as outputs, the energy and its
        parts, the quaternion norms and the mass matrix (both formulations); ``close`` maps the
        generalized forces (joint ports' efforts included) and coordinate rates to those with
        the loops and constraints enforced."""
        Q = list(Q)
        start_index = 0
        for spec in specs:
            indices = range(start_index, start_index + len(spec.velocities))
            start_index += len(spec.velocities)
            if not spec.velocities:
                continue
            pv, s = b.port(spec.name), b.sign(spec.name)
            efforts = [pv.e] if pv.port.dim == 1 else list(pv.e)
            flows = [pv.f] if pv.port.dim == 1 else list(pv.f)
            for k, e, f in zip(indices, efforts, flows):
                b.equation(f, v[k], "joint velocity")
                Q[k] = Q[k] + s * e
        if close is not None:
            rates, Q = close(Q, rates)
        for k in range(len(q)):
            b.equation(b.der(q[k]), rates[k], "dq/dt from the joint velocities, M(q) v = p")
        for k in range(len(p)):
            b.equation(b.der(p[k]), Q[k], "dp/dt = Π'ad_T S - dV/dq + Q")
        rate_units = {"N*m*s": "rad/s", "N*s": "m/s"}
        velocities = [label for spec in specs for label in spec.velocities]
        p_units = [u for spec in specs for u in units(spec)[1]]
        for label, unit, vk in zip(velocities, p_units, v):
            b.output(f"v.{label}", vk, rate_units.get(unit, ""))
        kinetic = (sp.Matrix(p).T * sp.Matrix(v))[0, 0] / 2
        b.energy(kinetic + potential)
        b.output("T", kinetic, "J")
        b.output("V", potential, "J")
        coordinates = [label for spec in specs for label in spec.coordinates]
        for spec in specs:
            span = quaternion_slice(spec)
            if span is not None:
                c = coordinates.index(spec.coordinates[0])
                quat = q[c + span.start:c + span.stop]
                b.output(f"{spec.name}.q_norm", sp.sqrt(dot(quat[1:], quat[1:]) + quat[0] ** 2),
                         "1")
        b.matrix("M", M)

    def _rows(self, b: Builder, tree: Tree, placement: dict, specs: list[Joint], q: list
              ) -> list[closure.Row]:
        """The rows of the loops and constraints (:mod:`.closure`) on ``tree`` (after
        :meth:`.tree.Tree.world`: its positions only)."""
        velocity_index, coordinate, k, c = {}, {}, 0, 0
        for spec in specs:
            velocity_index[spec.name] = list(range(k, k + len(spec.velocities)))
            coordinate[spec.name] = q[c:c + len(spec.coordinates)]
            k, c = k + len(spec.velocities), c + len(spec.coordinates)
        points = {point: (body, pos) for body, (point, pos) in self._points()}
        closures = closure.Closures(tree, placement, self._maker(b), b.parse, velocity_index,
                                    coordinate, points)
        return closures.rows(self.value("loops"), self.value("constraints"))

    def _initial(self, b: Builder, joints: dict[str, Any], specs: list[Joint]
                 ) -> tuple[list[Any], list[Any]]:
        """q0 and v0 per coordinate and velocity (expressions in the parameters); a quaternion
        is normalised."""
        out: tuple[list, list] = ([], [])
        for spec in specs:
            for key, labels, default, column in (("q0", spec.coordinates, spec.q0, out[0]),
                                                 ("v0", spec.velocities, spec.v0, out[1])):
                if not labels:
                    continue
                value = joints[spec.name].get(key)
                items = list(default) if value is None else (
                    value if isinstance(value, list) else [value] * len(labels))
                if len(items) != len(labels):
                    raise ModelError(f"Multibody joint {spec.name!r}: {key} needs {len(labels)} "
                                     f"value(s) ({', '.join(labels)}), got {value!r}",
                                     path=("joints", spec.name, key))
                parsed = [b.parse(x, f"joint {spec.name!r} {key}") for x in items]
                where = quaternion_slice(spec) if key == "q0" else None
                if where is not None:
                    quat = parsed[where]
                    norm = sp.sqrt(sum(x**2 for x in quat))
                    if norm == 0:
                        raise ModelError(f"Multibody joint {spec.name!r}: the quaternion in q0 must "
                                         "not be zero (identity: [1, 0, 0, 0])",
                                         path=("joints", spec.name, key))
                    b.require(norm**2, ">", f"joint {spec.name!r} q0 (the squared norm of its "
                              "quaternion; identity: [1, 0, 0, 0])")
                    parsed[where] = [x / norm for x in quat]
                column += parsed
        return out

    def _links(self, b: Builder, joints: dict[str, Any], specs: list[Joint]
               ) -> tuple[list[Link], dict[str, tuple[Link | None, list[Any]]]]:
        """The elementary links (parents first) and the placement of every body: (its link,
        or None for the world, and its origin in the link's frame)."""
        first: dict[str, tuple[int, int]] = {}
        velocity = coordinate = 0
        for spec in specs:
            first[spec.name] = (velocity, coordinate)
            velocity += len(spec.velocities)
            coordinate += len(spec.coordinates)
        by_name = {spec.name: spec for spec in specs}
        placement: dict[str, tuple[Link | None, list]] = {}
        links: list[Link] = []
        for jname in self._tree_order():
            table, spec = joints[jname], by_name[jname]
            link, offset = (None, list(ZERO3)) if table["parent"] == "world" \
                else placement[table["parent"]]
            offset = add(offset, [b.parse(v, f"joint {jname!r} origin")
                                  for v in _vector3(table.get("origin"), f"joint {jname!r} origin")])
            velocity, coordinate = first[jname]
            for kind, axis, label in spec.links:
                new = Link(label, link, offset, kind, axis, velocity, coordinate)
                velocity += DOFS[kind]
                coordinate += COORDINATES[kind]
                if link is not None:
                    link.children.append(new)
                links.append(new)
                link, offset = new, list(ZERO3)
            placement[table["child"]] = (link, offset)
        return links, placement

    def _tree_order(self) -> list[str]:
        joints = self.value("joints")
        order: list[str] = []
        placed = {"world"}
        while len(order) < len(joints):
            for name, table in joints.items():
                if name not in order and table["parent"] in placed:
                    order.append(name)
                    placed.add(table["child"])
        return order

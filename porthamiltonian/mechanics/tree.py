"""The recursive joint-space dynamics of a tree of rigid bodies (used by :mod:`.multibody`).

A tree is a list of *links*, each a rigid frame moved by one joint relative to its parent link
(or to the world): bodies welded together share a link; translational and universal joints are
chains of massless links with one coordinate each. Link k's frame has its origin on joint k;
relative to its parent λ it is placed by ``H_λk = (Rᵏ, pᵏ)``: ``Rᵏ = Rot(a_k, q_k)``, ``pᵏ = o_k``
(revolute: o_k the joint origin in λ's frame), ``Rᵏ = 1``, ``pᵏ = o_k + a_k q_k`` (prismatic),
``Rᵏ = R(q/|q|)`` of a quaternion (spherical; free: and ``pᵏ = o_k + r``). Everything is
computed in the links' own frames, so every quantity is formed from relative rotations and
link-sized offsets (no cancellation between large absolute positions; a foot of 1e-9 of the
hip's mass keeps its digits). Twists ``T = (ω, v)`` and wrenches ``W = (τ, f)`` as in
:mod:`.screw`. Each joint has constant unit twists S in its link's frame, one per velocity:
``(a_k, 0)`` (revolute), ``(0, a_k)`` (prismatic), ``(e_i, 0)`` (spherical: the velocities are
the relative angular velocity in the link's axes), ``(e_i, 0), (0, e_i)`` (free: the relative
twist); ``X_k W = (Rᵏ τ + pᵏ × Rᵏ f, Rᵏ f)`` carries a wrench from frame k to its parent's frame.

Position level: the composite (subtree) inertia about each link origin, tip to root,
``𝕀ᶜ_k = 𝕀_k + Σ_children X_c 𝕀ᶜ_c X_cᵀ`` (in mass m, first moment h = m c and rotational
inertia J about the origin), and the mass matrix by the composite-rigid-body recursion

    F = 𝕀ᶜ_k S,   M = Sᵀ F within joint k,   M_iS = S_iᵀ F for each unit twist S_i of an ancestor

(the latter with F carried to world axes and S_i acting at the ancestor's origin).

Velocity level, with the velocities v solved from M v = p: root to tip the body twists
``T_k = X_kᵀ T_λ + Σ S v`` (``ω_k = Rᵏᵀ ω_λ + …``, ``v_k = Rᵏᵀ (v_λ + ω_λ × pᵏ) + …``), tip to
root the subtree momenta ``Π_k = 𝕀_k T_k + Σ_children X_c Π_c``; the momentum of each velocity
is ``Sᵀ Π_k`` and its rate in Hamilton's equations has the velocity term

    Π_kᵀ ad_{T_k} S,    ad_T = [[ω̃, 0], [ṽ, ω̃]].

For a revolute or prismatic joint this is ∂T/∂q at fixed velocities (moving the joint at fixed
velocities changes the twist of every body beyond it by ad_{T_k} S, in frame k). For the
quasi-velocities of a quaternion joint, Hamel's equations add to ∂T/∂(rotation about e_i) the
term (π × ω_rel)_i of the joint's angular momentum π; the two together are again Π_kᵀ ad_{T_k} S
(for one free body this is Euler's L̇ = L × ω; for a free root the rows are the Lie–Poisson
Ṗ = ad_Tᵀ P). Gravity, ``g_k = Rᵏᵀ g_λ`` in each frame, acts on the subtree beyond joint k as
the wrench ``(hᶜ_k × g_k, mᶜ_k g_k)``, whose work along S is ``Sᵀ (hᶜ_k × g_k, mᶜ_k g_k)``.

Each step is O(1) (O(N) intermediates, plus one product per entry of M), so the generated code
grows as N² along an N-link chain where differentiating M's entries grows as N⁴–N⁵. World poses
``(R⁰_k, p⁰_k)`` (world axes and origin of each link) serve M's off-diagonal entries and the
outputs: point positions, velocities and Jacobians, and the links' poses (with the unit
quaternion of R⁰_k).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import sympy as sp

from ..errors import ModelError
from .kinematics import ZERO3, Make, Rotation, add, cross, dot, named, scale, sub

Vec = list


#: the unit twists of each joint kind, in the link's frame: ("rotation" | "translation", axis)
_UNIT = ((1, 0, 0), (0, 1, 0), (0, 0, 1))
DOFS = {"rotation": 1, "translation": 1, "spherical": 3, "free": 6}
COORDINATES = {"rotation": 1, "translation": 1, "spherical": 4, "free": 7}


@dataclass(eq=False)
class Link:
    """A rigid frame moved by a joint relative to its parent (see the module docstring).

    ``offset``: the joint origin o in the parent's frame (the world's for a root); ``kind``:
    "rotation" (about ``axis`` through the origin, coordinate the angle), "translation" (along
    ``axis``), "spherical" (any rotation about the origin: a quaternion (w, x, y, z), velocities
    the angular velocity relative to the parent in this link's axes) or "free" (position r in
    the parent's axes and a quaternion; velocities the relative twist (ω, v) in this link's
    axes); ``axis``: unit 3-tuple in the parent's axes (the same in this link's);
    ``index``/``coordinate``: the first velocity and coordinate index of the joint. ``mass``,
    ``first`` (first moment Σ m c) and ``inertia`` (3x3 about the link origin) sum the link's
    bodies, in the link's frame.
    """

    name: str
    parent: Link | None
    offset: Vec
    kind: str
    axis: tuple[Any, ...] | None
    index: int
    coordinate: int
    mass: Any = 0
    first: Vec = field(default_factory=lambda: list(ZERO3))
    inertia: list = field(default_factory=lambda: [[sp.S.Zero] * 3 for _ in range(3)])
    children: list[Link] = field(default_factory=list)

    @property
    def screws(self) -> list[tuple[str, tuple]]:
        """The joint's unit twists S (link frame): rotations about / translations along axes
        through the link origin, one per velocity."""
        if self.kind in ("rotation", "translation"):
            return [(self.kind, self.joint_axis)]
        turns = [("rotation", e) for e in _UNIT]
        return turns if self.kind == "spherical" else turns + [("translation", e) for e in _UNIT]

    @property
    def joint_axis(self) -> tuple[Any, ...]:
        """The ``axis`` of a rotation or translation joint."""
        if self.axis is None:
            raise ModelError(f"link {self.name!r}: its {self.kind} joint has no axis")
        return self.axis

    def add_body(self, mass: Any, com: Sequence, inertia: Sequence[Sequence] | None) -> None:
        """Add a body of ``mass`` with centre of mass ``com`` (link frame) and rotational inertia
        ``inertia`` about its centre of mass (link axes; None: a point mass)."""
        self.mass = self.mass + mass
        self.first = add(self.first, scale(mass, com))
        c2 = dot(com, com)
        for i in range(3):
            for j in range(3):
                shift = mass * ((c2 if i == j else 0) - com[i] * com[j])
                self.inertia[i][j] = self.inertia[i][j] + shift + (inertia[i][j] if inertia else 0)

    @property
    def root(self) -> Link:
        """The link at the base of this link's branch (its ancestor hanging on the world)."""
        link = self
        while link.parent is not None:
            link = link.parent
        return link

    def path(self) -> list[Link]:
        """This link and its ancestors, from this link to the root."""
        out: list[Link] = []
        link: Link | None = self
        while link is not None:
            out.append(link)
            link = link.parent
        return out


def quaternion_rotation(quaternion: Sequence, make: Make, name: str) -> Rotation:
    """The rotation of the unit quaternion q/|q| (Hamilton, (w, x, y, z)), for any q ≠ 0:
    R = R_quad(q) / |q|², entries as intermediates ``name.R<i><j>``."""
    w, x, y, z = quaternion
    n2 = make(f"{name}.n2", w**2 + x**2 + y**2 + z**2)
    quad = ((w**2 + x**2 - y**2 - z**2, 2 * (x * y - w * z), 2 * (x * z + w * y)),
            (2 * (x * y + w * z), w**2 - x**2 + y**2 - z**2, 2 * (y * z - w * x)),
            (2 * (x * z - w * y), 2 * (y * z + w * x), w**2 - x**2 - y**2 + z**2))
    return Rotation(rows=tuple(tuple(make(f"{name}.R{i}{j}", quad[i][j] / n2) for j in range(3))
                               for i in range(3)))


def quaternion_rate(quaternion: Sequence, omega: Sequence, gain: Any = 0) -> Vec:
    """q̇ = ½ q ⊗ (0, ω) (ω in the rotated frame) + gain/2 (1 − |q|²) q: the second term, along q,
    pulls |q| back to 1 at the rate ``gain`` (1/s) and does no work (R depends on q/|q| only)."""
    w, x, y, z = quaternion
    u = [x, y, z]
    radial = gain * (1 - (w**2 + x**2 + y**2 + z**2)) / 2
    vector = add(scale(w, omega), cross(u, omega))
    return [-dot(u, omega) / 2 + radial * w] + [vector[i] / 2 + radial * u[i] for i in range(3)]


def coordinate_rates(links: Sequence[Link], q: Sequence, v: Sequence, gain: Any,
                     rotation: Any) -> list:
    """q̇ of every coordinate from the velocities: v itself for a revolute or prismatic joint;
    the quaternion rate (with the normalising ``gain``) and ṙ = Rᵏ v_lin for the others, where
    ``rotation(link)`` gives a free link's :class:`Rotation` Rᵏ."""
    out = []
    for link in links:
        c, k = link.coordinate, link.index
        if link.kind in ("rotation", "translation"):
            out.append(v[k])
        elif link.kind == "spherical":
            out += quaternion_rate(q[c:c + 4], v[k:k + 3], gain)
        else:
            out += rotation(link).apply(v[k + 3:k + 6])
            out += quaternion_rate(q[c + 3:c + 7], v[k:k + 3], gain)
    return out


def _shift_inertia(mass: Any, first: Sequence, inertia: Sequence[Sequence], R: Rotation,
                   p: Sequence) -> tuple[Vec, list]:
    """First moment and rotational inertia (upper triangle) of a body given in a frame rotated
    by R and shifted by p relative to the frame of the result: h' = R h + m p,
    J' = R J Rᵀ + m (|p|² 1 − p pᵀ) + 2 (p·R h) 1 − p (R h)ᵀ − (R h) pᵀ."""
    h = R.apply(first)
    J = R.congruence(inertia)
    p2, ph = dot(p, p), 2 * dot(p, h)
    J2 = [[sp.Add(J[i][j], mass * ((p2 if i == j else 0) - p[i] * p[j]), (ph if i == j else 0),
                  -p[i] * h[j], -h[i] * p[j]) if j >= i else None for j in range(3)]
          for i in range(3)]
    return add(h, scale(mass, p)), J2


def _symmetric(upper: list) -> list:
    for i in range(3):
        for j in range(i):
            upper[i][j] = upper[j][i]
    return upper


@dataclass
class _Pos:
    """Position-level quantities of a link (its own frame unless said otherwise); those after
    ``p`` are set by the passes of :class:`Tree` that compute them (unset before)."""

    R: Rotation                   # Rᵏ, relative to the parent
    p: Vec                        # pᵏ, origin in the parent's frame
    g: Vec = field(init=False)    # gravity
    cmass: Any = None             # composite mass, first moment, inertia about the origin
    cfirst: Vec = field(init=False)
    cinertia: list[list[Any]] = field(init=False)
    world_R: Rotation = field(init=False)
    world_p: Vec = field(init=False)
    world_q: Vec = field(init=False)    # unit quaternion (w, x, y, z) of world_R


def _product(a: Sequence, b: Sequence) -> Vec:
    """The Hamilton product a ⊗ b of quaternions (w, x, y, z): R(a ⊗ b) = R(a) R(b)."""
    vector = add(scale(a[0], b[1:]), scale(b[0], a[1:]), cross(a[1:], b[1:]))
    return [a[0] * b[0] - dot(a[1:], b[1:]), *vector]


def _spatial_inertia(link: Link, w: Sequence, lin: Sequence) -> tuple[Vec, Vec]:
    """𝕀_k (ω, v) = (J ω + h × v, m v + ω × h) of the link's own bodies (h = m c, J about the
    origin, link frame): its momentum for a twist, its wrench of inertia for an acceleration."""
    return (add([dot(link.inertia[i], w) for i in range(3)], cross(link.first, lin)),
            add(scale(link.mass, lin), cross(w, link.first)))


def _twist(screw: tuple[str, tuple]) -> tuple[Vec, Vec]:
    """A unit twist as (angular, linear) 3-vectors."""
    kind, axis = screw
    return (list(axis), list(ZERO3)) if kind == "rotation" else (list(ZERO3), list(axis))


class Tree:
    """The recursion over ``links`` (parents before children). See the module docstring.

    ``make(name, expr)`` turns a quantity into a named intermediate (or returns it as is).
    """

    def __init__(self, links: list[Link], make: Make):
        self.links = links
        self.make = make
        self.n = sum(DOFS[link.kind] for link in links)
        self.pos: dict[Link, _Pos] = {}
        self.twist: dict[Link, tuple[Vec, Vec]] = {}
        self.momentum: dict[Link, tuple[Vec, Vec]] = {}
        self.coordinates: list = []
        self._v: list = []                  # the velocities of the last :meth:`velocities`

    # --- position level -------------------------------------------------------------------------
    def positions(self, q: Sequence) -> None:
        """Relative poses of the links at coordinates ``q``."""
        self.coordinates = list(q)
        for link in self.links:
            c = link.coordinate
            if link.kind == "rotation":
                R, p = Rotation.turn(link.joint_axis, q[c], self.make, link.name), list(link.offset)
            elif link.kind == "translation":
                R, p = Rotation(), add(link.offset, scale(q[c], link.joint_axis))
            elif link.kind == "spherical":
                R, p = quaternion_rotation(q[c:c + 4], self.make, link.name), list(link.offset)
            else:
                R = quaternion_rotation(q[c + 3:c + 7], self.make, link.name)
                p = add(link.offset, q[c:c + 3])
            self.pos[link] = _Pos(R, p)

    def coordinate_rates(self, q: Sequence, v: Sequence, gain: Any) -> list:
        """q̇ of every coordinate from the velocities (:func:`coordinate_rates`)."""
        return coordinate_rates(self.links, q, v, gain, lambda link: self.pos[link].R)

    def carry(self, link: Link, torque: Sequence, force: Sequence) -> tuple[Vec, Vec]:
        """X_k W: the wrench (torque about link k's origin, force; k's frame) in the parent's
        frame, torque about the parent's origin."""
        P = self.pos[link]
        f = P.R.apply(force)
        return add(P.R.apply(torque), cross(P.p, f)), f

    def composites(self) -> None:
        """Composite (subtree) mass, first moment and inertia of every link, tip to root."""
        make = self.make
        for link in reversed(self.links):
            P = self.pos[link]
            mass, first, inertia = link.mass, list(link.first), [list(r) for r in link.inertia]
            for child in link.children:
                C = self.pos[child]
                h, J = _shift_inertia(C.cmass, C.cfirst, C.cinertia, C.R, C.p)
                mass = mass + C.cmass
                first = add(first, h)
                inertia = [[inertia[i][j] + J[i][j] if j >= i else None for j in range(3)]
                           for i in range(3)]
            P.cmass = make(f"{link.name}.mc", mass)
            P.cfirst = named(make, f"{link.name}.hc", first)
            P.cinertia = _symmetric([[make(f"{link.name}.Jc{i}{j}", inertia[i][j]) if j >= i
                                      else None for j in range(3)] for i in range(3)])

    def _world_column(self, joint: Link, screw: tuple[str, tuple], x: Sequence
                      ) -> tuple[Vec, Vec]:
        """The unit twist ``screw`` of ``joint`` acting on the world point x: (angular velocity,
        velocity of x), world axes."""
        P = self.pos[joint]
        axis = P.world_R.apply(screw[1])
        if screw[0] == "rotation":
            return axis, cross(axis, sub(x, P.world_p))
        return list(ZERO3), axis

    def mass_matrix(self) -> sp.Matrix:
        """M(q) by the composite-rigid-body recursion (after :meth:`composites` and
        :meth:`world`); entries ``M.<i>.<j>`` (intermediates). The block of a joint with itself
        is formed in its link's frame, F = 𝕀ᶜ S, M = Sᵀ F; an ancestor's entries are
        a⁰·(τ⁰ + (p⁰_k − p⁰_i) × f⁰) (rotation about a⁰ through p⁰_i) or a⁰·f⁰ (translation) with
        the wrench F in world axes: one product per entry."""
        M = sp.zeros(self.n, self.n)
        for link in self.links:
            P = self.pos[link]
            J, h, m = P.cinertia, P.cfirst, P.cmass
            screws = link.screws
            wrenches = []
            for a, u in map(_twist, screws):
                wrenches.append((add([dot(J[i], a) for i in range(3)], cross(h, u)),
                                 add(scale(m, u), cross(a, h))))
            for s, (torque, force) in enumerate(wrenches):
                k = link.index + s
                for t, (a, u) in enumerate(map(_twist, screws[:s + 1])):
                    i = link.index + t
                    M[i, k] = M[k, i] = self.make(f"M.{i}.{k}", dot(a, torque) + dot(u, force))
            if link.parent is None:
                continue
            for s, (torque, force) in enumerate(wrenches):
                k = link.index + s
                torque = named(self.make, f"{link.name}.F{s}.t", P.world_R.apply(torque))
                force = named(self.make, f"{link.name}.F{s}.f", P.world_R.apply(force))
                for holder in link.parent.path():
                    for t, screw in enumerate(holder.screws):
                        w, lin = self._world_column(holder, screw, P.world_p)
                        i = holder.index + t
                        M[i, k] = M[k, i] = self.make(f"M.{i}.{k}", dot(w, torque) + dot(lin, force))
        return M

    def gravity(self, g_world: Sequence) -> None:
        """Gravity in each link's frame, root to tip: g_k = Rᵏᵀ g_λ."""
        for link in self.links:
            P = self.pos[link]
            g = g_world if link.parent is None else self.pos[link.parent].g
            P.g = named(self.make, f"{link.name}.g", P.R.apply_T(g))

    def gravity_forces(self) -> list:
        """−∂V/∂q along every unit twist, S_kᵀ (hᶜ_k × g_k, mᶜ_k g_k) (after :meth:`gravity`)."""
        out = [sp.S.Zero] * self.n
        for link in self.links:
            P = self.pos[link]
            for s, (a, u) in enumerate(map(_twist, link.screws)):
                out[link.index + s] = dot(a, cross(P.cfirst, P.g)) + P.cmass * dot(u, P.g)
        return out

    # --- world poses and points -----------------------------------------------------------------
    def world(self) -> None:
        """World axes R⁰_k and origins p⁰_k of the links, root to tip."""
        for link in self.links:
            P = self.pos[link]
            if link.parent is None:
                P.world_R, P.world_p = P.R, list(P.p)
                continue
            W = self.pos[link.parent]
            P.world_p = named(self.make, f"{link.name}.o", add(W.world_p, W.world_R.apply(P.p)))
            P.world_R = W.world_R.then(P.R, self.make, f"{link.name}.world")

    def orientations(self) -> None:
        """The unit quaternion (w, x, y, z; Hamilton, R⁰_k = R(q)) of every link's world axes,
        root to tip (after :meth:`world`): (cos θ/2, sin θ/2 a) of the accumulated angle θ while
        the rotations share one axis a (intermediates ``name.world.hc``, ``name.world.hs``), else
        the parent's quaternion times the joint's — (cos q/2, sin q/2 a) for a revolute link, q/|q|
        for a quaternion joint, 1 for a translation (``name.world.q<w|x|y|z>``)."""
        make = self.make
        for link in self.links:
            P = self.pos[link]
            parent = [sp.S.One, *ZERO3] if link.parent is None else self.pos[link.parent].world_q
            if link.kind == "translation":
                P.world_q = parent
            elif P.world_R.axis is not None:
                name, half = f"{link.name}.world", P.world_R.angle / 2
                P.world_q = [make(f"{name}.hc", sp.cos(half)),
                             *scale(make(f"{name}.hs", sp.sin(half)), P.world_R.axis)]
            else:
                if link.kind == "rotation":
                    half = self.pos[link].R.angle / 2
                    step = [make(f"{link.name}.hc", sp.cos(half)),
                            *scale(make(f"{link.name}.hs", sp.sin(half)), link.joint_axis)]
                else:
                    c = link.coordinate + (3 if link.kind == "free" else 0)
                    quaternion = self.coordinates[c:c + 4]
                    norm = make(f"{link.name}.qn", sp.sqrt(dot(quaternion, quaternion)))
                    step = [x / norm for x in quaternion]
                P.world_q = named(make, f"{link.name}.world.q", _product(parent, step), "wxyz")

    def point(self, link: Link, local: Sequence) -> Vec:
        """World position of a link-fixed point given in the link frame."""
        P = self.pos[link]
        return add(P.world_p, P.world_R.apply(local))

    def load(self, link: Link, x: Sequence, torque: Sequence, force: Sequence) -> list:
        """The generalized forces of a wrench on ``link`` applied at the world point x (torque
        and force in world axes) on every velocity: (velocity index, S⁰ᵀ W) for the unit twists
        of the joints from ``link`` to its root."""
        out = []
        for joint in link.path():
            for t, screw in enumerate(joint.screws):
                w, lin = self._world_column(joint, screw, x)
                out.append((joint.index + t, dot(w, torque) + dot(lin, force)))
        return out

    def columns(self, link: Link, x: Sequence) -> list:
        """(velocity index, ∂ẋ/∂v in world axes) of a point x fixed to ``link``."""
        out = []
        for joint in link.path():
            for t, screw in enumerate(joint.screws):
                out.append((joint.index + t, self._world_column(joint, screw, x)[1]))
        return out

    # --- velocity level -------------------------------------------------------------------------
    def velocities(self, v: Sequence) -> None:
        """Body twists T_k root to tip and subtree momenta Π_k tip to root."""
        make = self.make
        self._v = list(v)
        for link in self.links:
            P = self.pos[link]
            if link.parent is None:
                w, lin = list(ZERO3), list(ZERO3)
            else:
                w0, v0 = self.twist[link.parent]
                w, lin = P.R.apply_T(w0), P.R.apply_T(add(v0, cross(w0, P.p)))
            for s, (a, u) in enumerate(map(_twist, link.screws)):
                w, lin = add(w, scale(v[link.index + s], a)), add(lin, scale(v[link.index + s], u))
            self.twist[link] = (named(make, f"{link.name}.w", w), named(make, f"{link.name}.v", lin))
        for link in reversed(self.links):
            w, lin = self.twist[link]
            L, p = _spatial_inertia(link, w, lin)
            for child in link.children:
                Lc, pc = self.carry(child, *self.momentum[child])
                L, p = add(L, Lc), add(p, pc)
            self.momentum[link] = (named(make, f"{link.name}.L", L), named(make, f"{link.name}.p", p))

    def velocity_forces(self) -> list:
        """Π_kᵀ ad_{T_k} S for every unit twist S of every joint: ∂T/∂q at fixed velocities for
        a revolute or prismatic joint; for the rotations of a spherical or free joint the same
        expression is ∂T/∂(rotation about the axis) plus the gyroscopic term π × ω of the
        joint's quasi-velocities (Euler's L̇ = L × ω for one body; for a free root the whole
        row is the Lie–Poisson term ad_Tᵀ Π)."""
        out = [sp.S.Zero] * self.n
        for link in self.links:
            w, lin = self.twist[link]
            L, p = self.momentum[link]
            for s, (a, u) in enumerate(map(_twist, link.screws)):
                out[link.index + s] = dot(L, cross(w, a)) + dot(p, add(cross(w, u), cross(lin, a)))
        return out

    def velocity_products(self) -> list:
        """Ṁ(q) v, the time derivative of M along q̇ = K(q) v times v, by one more pass over
        the tree (after :meth:`velocities`), not by differentiating M's entries: with
        Newton–Euler's M v̇ = ṗ − Ṁ v = Q − C(q, v) (Q the applied and gravity forces, C the
        velocity-product forces of the recursive Newton–Euler algorithm at zero joint
        accelerations and zero gravity; Featherstone, *Rigid Body Dynamics Algorithms*, 2008,
        §5.3) and Hamilton's ṗ = Π_kᵀ ad_{T_k} S + Q, Ṁ v = Π_kᵀ ad_{T_k} S + C. C root to tip:
        the spatial accelerations ``A_k = X_kᵀ A_λ + T_k × S v`` (the motion cross product
        ``(ω, v) × (a, u) = (ω × a, ω × u + v × a)``; every S is constant in its link's frame),
        the wrenches ``F_k = 𝕀_k A_k + T_k ×* 𝕀_k T_k`` (``(ω, v) ×* (τ, f) = (ω × τ + v × f,
        ω × f)``), carried tip to root, and ``C = Sᵀ F_k``; units of p / s (N m, N)."""
        make = self.make
        accel: dict[Link, tuple[Vec, Vec]] = {}
        wrench: dict[Link, tuple[Vec, Vec]] = {}
        for link in self.links:
            P = self.pos[link]
            w, lin = self.twist[link]
            if link.parent is None:
                alpha, acc = list(ZERO3), list(ZERO3)
            else:
                a0, c0 = accel[link.parent]
                alpha, acc = P.R.apply_T(a0), P.R.apply_T(add(c0, cross(a0, P.p)))
            for s, (a, u) in enumerate(map(_twist, link.screws)):
                vs = self._v[link.index + s]
                alpha = add(alpha, scale(vs, cross(w, a)))
                acc = add(acc, scale(vs, add(cross(w, u), cross(lin, a))))
            accel[link] = (named(make, f"{link.name}.A", alpha), named(make, f"{link.name}.Av", acc))
        for link in reversed(self.links):
            w, lin = self.twist[link]
            L, p = _spatial_inertia(link, w, lin)
            tau, f = _spatial_inertia(link, *accel[link])
            tau, f = add(tau, cross(w, L), cross(lin, p)), add(f, cross(w, p))
            for child in link.children:
                tc, fc = self.carry(child, *wrench[child])
                tau, f = add(tau, tc), add(f, fc)
            wrench[link] = (named(make, f"{link.name}.Ft", tau), named(make, f"{link.name}.Ff", f))
        out = self.velocity_forces()
        for link in self.links:
            tau, f = wrench[link]
            for s, (a, u) in enumerate(map(_twist, link.screws)):
                out[link.index + s] = out[link.index + s] + dot(a, tau) + dot(u, f)
        return out

    def generalized_momenta(self) -> list:
        """S_kᵀ Π_k for every unit twist (= M(q) v)."""
        out = [sp.S.Zero] * self.n
        for link in self.links:
            L, p = self.momentum[link]
            for s, (a, u) in enumerate(map(_twist, link.screws)):
                out[link.index + s] = dot(a, L) + dot(u, p)
        return out

    def point_velocity(self, link: Link, local: Sequence) -> Vec:
        """World velocity of the link-fixed point at ``local`` (link frame)."""
        w, lin = self.twist[link]
        return self.pos[link].world_R.apply(add(lin, cross(w, local)))

"""The recursive joint-space dynamics of a tree of rigid bodies (used by :mod:`.multibody`).

A tree is a list of *links*, each a rigid frame moved by one joint coordinate relative to its
parent link (or to the world): bodies welded together share a link, a translational joint with
several axes is a chain of massless links. Every quantity is expressed in a *reference frame*
per subtree hanging on the world: world axes, origin at the origin of the subtree's root link
(so the numbers do not grow with the distance the mechanism travelled). With

* ``R_k``, ``r_k``: axes and origin of link k (world axes, reference origin);
* ``S_k = (a_k, u_k)``: the unit twist of joint k, ``(a, r_k × a)`` for a revolute joint about
  the unit axis a through r_k, ``(0, a)`` for a prismatic one; twists ``(ω, v)`` and wrenches
  ``(τ, f)`` as in :mod:`.screw` (v and τ at the reference origin);
* ``𝕀_k = [[J_k, h̃_k], [−h̃_k, m_k 1]]``: the spatial inertia of link k's bodies (mass m, first
  moment h = m c, rotational inertia J about the reference origin);

the position level is, root to tip, ``R_k = R_λ Rot(a, q_k)``, ``r_k = r_λ + R_λ (o_k + a q_k)``;
then tip to root the composite (subtree) inertias ``𝕀ᶜ_k = 𝕀_k + Σ_children 𝕀ᶜ_c`` (all in one
frame: plain sums), and the mass matrix by the composite-rigid-body recursion

    F_j = 𝕀ᶜ_j S_j,      M_ij = S_iᵀ F_j   (i = j or an ancestor of j; 0 otherwise).

The velocity level, with the velocities v solved from M v = p, is root to tip
``T_k = T_λ + S_k v_k`` (body twists) and tip to root ``Π_k = 𝕀_k T_k + Σ_children Π_c`` (subtree
momenta); the generalized momentum is ``p_k = S_kᵀ Π_k`` and the velocity term of Hamilton's
equations

    ∂T/∂q_k |_v = Π_kᵀ ad_{T_k} S_k,    ad_T = [[ω̃, 0], [ṽ, ω̃]]

(derivation: moving joint k at fixed velocities changes the twist of every body beyond it by
``ad_{T_k} S_k``; the expression is the same in every frame, Ad being a Lie-algebra
homomorphism). Gravity g (world) acts on the subtree beyond joint k as the wrench
``(hᶜ_k × g, mᶜ_k g)``, so ``−∂V/∂q_k = S_kᵀ (hᶜ_k × g, mᶜ_k g)``.

Each step is O(1) in the number of links (O(N) intermediates, and the N(N+1)/2 entries of M),
so the generated code grows as N² along an N-link chain where differentiating M's entries
grows as N⁴–N⁵.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import sympy as sp

from .kinematics import ZERO3, Make, Rotation, add, cross, dot, named, scale, sub

Vec = list


@dataclass(eq=False)
class Link:
    """A rigid frame moved by one joint coordinate (see the module docstring).

    ``offset``: the link origin at q = 0 in the parent's frame (the world's for a root);
    ``kind``: "rotation" (about ``axis`` through the origin) or "translation" (along ``axis``);
    ``axis``: unit 3-tuple in the parent's axes; ``index``: the coordinate's index.
    ``mass``, ``first`` (first moment m c, link frame) and ``inertia`` (3x3 about the link origin,
    link axes) sum the link's bodies.
    """

    name: str
    parent: Link | None
    offset: Vec
    kind: str
    axis: tuple
    index: int
    mass: Any = 0
    first: Vec = field(default_factory=lambda: list(ZERO3))
    inertia: list = field(default_factory=lambda: [[sp.Integer(0)] * 3 for _ in range(3)])
    children: list[Link] = field(default_factory=list)

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
        link = self
        while link.parent is not None:
            link = link.parent
        return link

    def path(self) -> list[Link]:
        """This link and its ancestors, from this link to the root."""
        out, link = [], self
        while link is not None:
            out.append(link)
            link = link.parent
        return out


@dataclass
class _Pos:
    """Position-level quantities of a link, in its subtree's reference frame."""

    R: Rotation
    r: Vec
    a: Vec
    u: Vec
    mass: Any
    first: Vec
    inertia: list
    cmass: Any = None
    cfirst: Vec | None = None
    cinertia: list | None = None
    F: Vec | None = None


class Tree:
    """The recursion over ``links`` (parents before children). See the module docstring.

    ``make(name, expr)`` turns a quantity into a named intermediate (or returns it as is);
    ``q``, ``v`` are the coordinates and velocities (symbols, or values for the initial state).
    """

    def __init__(self, links: list[Link], make: Make):
        self.links = links
        self.make = make
        self.pos: dict[Link, _Pos] = {}
        self.twist: dict[Link, tuple[Vec, Vec]] = {}
        self.momentum: dict[Link, tuple[Vec, Vec]] = {}

    # --- position level -------------------------------------------------------------------------
    def positions(self, q: Sequence) -> None:
        make = self.make
        for link in self.links:
            name, qk = link.name, q[link.index]
            parent = self.pos.get(link.parent) if link.parent is not None else None
            R_parent = parent.R if parent else Rotation()
            shift = link.offset if link.kind == "rotation" else add(link.offset, scale(qk, link.axis))
            if parent is None:
                r = list(ZERO3)                                      # the reference origin
            else:
                r = named(make, f"{name}.r", add(parent.r, R_parent.apply(shift)))
            a = [sp.sympify(x) for x in R_parent.apply(link.axis)]
            a = named(make, f"{name}.a", a) if not R_parent.is_identity else a
            if link.kind == "rotation":
                R = R_parent.about(link.axis, qk, make, name)
                u = named(make, f"{name}.u", cross(r, a))
                S = (a, u)
            else:
                R = R_parent
                S = (list(ZERO3), a)
            h_local = R.apply(link.first)
            first = named(make, f"{name}.h", add(h_local, scale(link.mass, r)))
            J = R.congruence(link.inertia)
            r2, rh = dot(r, r), 2 * dot(r, h_local)
            inertia = [[make(f"{name}.J{i}{j}", sp.Add(
                J[i][j], link.mass * ((r2 if i == j else 0) - r[i] * r[j]),
                (rh if i == j else 0), -r[i] * h_local[j], -h_local[i] * r[j]))
                if j >= i else None for j in range(3)] for i in range(3)]
            for i in range(3):
                for j in range(i):
                    inertia[i][j] = inertia[j][i]
            self.pos[link] = _Pos(R, r, S[0], S[1], link.mass, first, inertia)

    def composites(self) -> None:
        """Subtree inertias 𝕀ᶜ_k (tip to root) and F_k = 𝕀ᶜ_k S_k (after :meth:`positions`)."""
        make = self.make
        for link in reversed(self.links):
            P = self.pos[link]
            kids = [self.pos[c] for c in link.children]
            if kids:
                P.cmass = make(f"{link.name}.mc", sp.Add(P.mass, *(k.cmass for k in kids)))
                P.cfirst = named(make, f"{link.name}.hc", add(P.first, *(k.cfirst for k in kids)))
                P.cinertia = [[make(f"{link.name}.Jc{i}{j}", sp.Add(
                    P.inertia[i][j], *(k.cinertia[i][j] for k in kids))) if j >= i else None
                    for j in range(3)] for i in range(3)]
                for i in range(3):
                    for j in range(i):
                        P.cinertia[i][j] = P.cinertia[j][i]
            else:
                P.cmass, P.cfirst, P.cinertia = P.mass, P.first, P.inertia
            a, u = P.a, P.u
            torque = add([dot(P.cinertia[i], a) for i in range(3)], cross(P.cfirst, u))
            force = add(scale(P.cmass, u), cross(a, P.cfirst))
            P.F = named(make, f"{link.name}.F", torque + force, labels="abcdef")

    def mass_matrix(self) -> sp.Matrix:
        """M(q): entries ``M.<i>.<j>`` (intermediates) for i = j or i an ancestor of j."""
        n = len(self.links)
        M = sp.zeros(n, n)
        for link in self.links:
            F = self.pos[link].F
            for anc in link.path():
                P = self.pos[anc]
                i, j = sorted((anc.index, link.index))
                M[i, j] = M[j, i] = self.make(f"M.{i}.{j}", dot(P.a, F[:3]) + dot(P.u, F[3:]))
        return M

    def gravity_forces(self, g: Sequence) -> list:
        """−∂V/∂q_k = S_kᵀ (hᶜ_k × g, mᶜ_k g) for every coordinate (g in world axes)."""
        out = [sp.Integer(0)] * len(self.links)
        for link in self.links:
            P = self.pos[link]
            out[link.index] = dot(P.a, cross(P.cfirst, g)) + P.cmass * dot(P.u, g)
        return out

    def first_moment_world(self, origins: dict[Link, Vec]) -> Vec:
        """Σ m_b c_b over all links, about the world origin (world axes); ``origins`` maps each
        root link to its origin in the world."""
        out = list(ZERO3)
        for root, origin in origins.items():
            P = self.pos[root]
            out = add(out, P.cfirst, scale(P.cmass, origin))
        return out

    # --- points ---------------------------------------------------------------------------------
    def point(self, link: Link, local: Sequence) -> Vec:
        """A link-fixed point given in the link frame, relative to the reference origin."""
        P = self.pos[link]
        return add(P.r, P.R.apply(local))

    def column(self, joint: Link, x: Sequence) -> Vec:
        """∂x/∂q_joint of a point x (reference frame) beyond ``joint``: a × (x − r) or a."""
        P = self.pos[joint]
        if joint.kind == "rotation":
            return cross(P.a, sub(x, P.r))
        return list(P.u)

    def rotate_to_link(self, link: Link, vector: Sequence) -> Vec:
        return self.pos[link].R.apply_T(vector)

    def rotate_from_link(self, link: Link, vector: Sequence) -> Vec:
        return self.pos[link].R.apply(vector)

    # --- velocity level -------------------------------------------------------------------------
    def velocities(self, v: Sequence) -> None:
        """Body twists T_k root to tip and subtree momenta Π_k tip to root."""
        make = self.make
        for link in self.links:
            P = self.pos[link]
            w0, v0 = self.twist[link.parent] if link.parent is not None else (ZERO3, ZERO3)
            vk = v[link.index]
            w = named(make, f"{link.name}.w", add(w0, scale(vk, P.a)))
            lin = named(make, f"{link.name}.v", add(v0, scale(vk, P.u)))
            self.twist[link] = (w, lin)
        for link in reversed(self.links):
            P = self.pos[link]
            w, lin = self.twist[link]
            L = add([dot(P.inertia[i], w) for i in range(3)], cross(P.first, lin))
            p = add(scale(P.mass, lin), cross(w, P.first))
            for child in link.children:
                L = add(L, self.momentum[child][0])
                p = add(p, self.momentum[child][1])
            self.momentum[link] = (named(make, f"{link.name}.L", L),
                                   named(make, f"{link.name}.p", p))

    def velocity_forces(self) -> list:
        """∂T/∂q_k at fixed velocities, Π_kᵀ ad_{T_k} S_k, for every coordinate."""
        out = [sp.Integer(0)] * len(self.links)
        for link in self.links:
            P = self.pos[link]
            w, lin = self.twist[link]
            L, p = self.momentum[link]
            out[link.index] = dot(L, cross(w, P.a)) + dot(p, add(cross(w, P.u), cross(lin, P.a)))
        return out

    def generalized_momenta(self) -> list:
        """p_k = S_kᵀ Π_k for every coordinate (= M(q) v)."""
        out = [sp.Integer(0)] * len(self.links)
        for link in self.links:
            P = self.pos[link]
            L, p = self.momentum[link]
            out[link.index] = dot(P.a, L) + dot(P.u, p)
        return out

    def point_velocity(self, link: Link, x: Sequence) -> Vec:
        """Velocity (world axes) of the link-fixed point at x (reference frame)."""
        w, lin = self.twist[link]
        return add(lin, cross(w, x))

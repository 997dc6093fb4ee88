"""A Multibody's tree as the numeric tables of the recursive kernel, and the calls it makes.

The kernel (:mod:`.kernel`, ``kernel.c``) evaluates the dynamics of :mod:`.tree` for any tree
from two tables: integers (the structure: sizes, each link's parent, kind, first velocity and
first coordinate, each site's link and kind) and numbers (each link's axis, joint origin, mass,
first moment and inertia about its origin; gravity; the first moment of the bodies welded to the
world; each site's position in its link). Here the numbers are expressions in the model's
parameters (``"m_leg"``, ``"-l/2"``, an axis (0.6, 0, 0.8)): the generated code evaluates them at
run time and hands them to the kernel, so that the code does not depend on their values —
axes, offsets and inertias are run-time parameters like masses — and its size grows with the
number of links and sites only, by a table entry each.

:class:`KernelTree` declares the calls of one Multibody (see
:meth:`porthamiltonian.modeling.component.Builder.call`): the state (velocities, momentum rates,
potential, the sites' kinematics), the loads of its ports' wrenches, and, without derivatives,
the mass matrix, the points' Jacobians, the bodies' poses and the initial momenta.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import sympy as sp

from ..modeling.component import Builder
from .tree import DOFS, Link

#: kernel link kinds (kernel.py)
KINDS = {"rotation": 0, "translation": 1, "spherical": 2, "free": 3}
#: kernel site kinds: a point (world position and velocity), a frame (twist in its link's axes;
#: a wrench in its link's axes for a load), a world frame (position, angular velocity and
#: velocity in world axes)
POINT, FRAME, WORLD_FRAME = 0, 1, 2
_OUTPUTS = {POINT: 6, FRAME: 6, WORLD_FRAME: 9}


@dataclass(frozen=True)
class Site:
    """A point or frame fixed to ``link`` at ``local`` (link frame, m), of ``kind``."""

    link: Link
    local: tuple
    kind: int = POINT


@dataclass
class KernelTree:
    """The kernel calls of one Multibody with ``links`` (parents first), ``gravity`` (world,
    m/s²) and ``static_first`` (first moment of the bodies welded to the world, kg m)."""

    b: Builder
    links: list[Link]
    gravity: Sequence
    static_first: Sequence
    nq: int
    nv: int = field(init=False)
    _index: dict = field(init=False)

    def __post_init__(self) -> None:
        self.nv = sum(DOFS[link.kind] for link in self.links)
        self._index = {link: k for k, link in enumerate(self.links)}

    def table(self, sites: Sequence[Site]) -> tuple[list[int], list]:
        """The integer table and the constants of a call on ``sites``."""
        ints = [len(self.links), self.nv, self.nq, len(sites)]
        numbers: list = []
        for link in self.links:
            ints += [-1 if link.parent is None else self._index[link.parent], KINDS[link.kind],
                     link.index, link.coordinate]
            J = link.inertia
            numbers += [*(link.axis or (0, 0, 0)), *link.offset, link.mass, *link.first,
                        J[0][0], J[1][1], J[2][2], J[0][1], J[0][2], J[1][2]]
        numbers += [*self.gravity, *self.static_first]
        for site in sites:
            ints += [self._index[site.link], site.kind]
            numbers += list(site.local)
        return ints, numbers

    def _call(self, name: str, entry: str, sites: Sequence[Site], inputs: list,
              n_outputs: int) -> list:
        ints, numbers = self.table(sites)
        return self.b.call(name, "multibody", entry, ints, numbers, inputs, n_outputs)

    def state(self, q: Sequence, p: Sequence, sites: Sequence[Site]) -> tuple[list, list, Any, list]:
        """(v, momentum rates without port loads, V, per site its outputs) at the state (q, p):
        a point's world position and velocity (6), a frame's twist (ω, v) in its link's axes
        (6), a world frame's position, angular velocity and velocity in world axes (9)."""
        n = self.nv
        count = 2 * n + 1 + sum(_OUTPUTS[site.kind] for site in sites)
        out = self._call("mb.state", "mb_state", sites, [*q, *p], count)
        per_site, k = [], 2 * n + 1
        for site in sites:
            per_site.append(out[k:k + _OUTPUTS[site.kind]])
            k += _OUTPUTS[site.kind]
        return out[:n], out[n:2 * n], out[2 * n], per_site

    def load(self, q: Sequence, wrenches: Sequence[tuple[Site, Sequence, Sequence]]) -> list:
        """The generalized forces of wrenches (site, torque, force) about the sites, in world
        axes (a FRAME site: its link's axes)."""
        sites = [site for site, _, _ in wrenches]
        inputs = [*q]
        for _, torque, force in wrenches:
            inputs += [*torque, *force]
        return self._call("mb.load", "mb_load", sites, inputs, self.nv)

    def mass_matrix(self, q: Sequence) -> sp.Matrix:
        """M(q) (no derivatives: for the named matrix)."""
        n = self.nv
        return sp.Matrix(n, n, self._call("mb.M", "mb_mass", [], list(q), n * n))

    def jacobians(self, q: Sequence, sites: Sequence[Site]) -> list[sp.Matrix]:
        """Per site the world Jacobian of its velocity (3 x nv; no derivatives)."""
        n = self.nv
        out = self._call("mb.J", "mb_jacobians", sites, list(q), 3 * n * len(sites))
        return [sp.Matrix(3, n, out[3 * n * i:3 * n * (i + 1)]) for i in range(len(sites))]

    def poses(self, q: Sequence, sites: Sequence[Site]) -> list[tuple[list, list]]:
        """Per site its world position and the unit quaternion (w, x, y, z) of its link's axes
        (no derivatives: for outputs)."""
        out = self._call("mb.poses", "mb_poses", sites, list(q), 7 * len(sites))
        return [(out[7 * i:7 * i + 3], out[7 * i + 3:7 * i + 7]) for i in range(len(sites))]

    def constrained(self, inputs: list, m: int, pattern: Sequence[tuple[int, int]]) -> list:
        """The constrained momentum rates, the multipliers and the position correction (see
        :func:`.constrained.constrain_kernel` for ``inputs``; m rows, ``pattern`` the (row,
        column) of each entry of G given): 2 nv + m outputs."""
        ints, numbers = self.table([])
        ints += [m, len(pattern), *(j for entry in pattern for j in entry)]
        return self.b.call("mb.constrained", "multibody", "mb_constrained", ints, numbers,
                           inputs, 2 * self.nv + m, after="mb.state")

    def momenta(self, q: Sequence, v: Sequence) -> list:
        """M(q) v (for the initial momenta from parameter expressions)."""
        return self._call("mb.p0", "mb_momenta", [], [*q, *v], self.nv)


__all__ = ["FRAME", "KINDS", "POINT", "WORLD_FRAME", "KernelTree", "Site"]

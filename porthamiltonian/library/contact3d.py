"""Compliant normal contact in 3D: Hunt–Crossley and Kelvin–Voigt, a point or a sphere on a surface.

The laws are those of :mod:`.contact` (the same functions, :func:`~.contact.hunt_crossley` and
:func:`~.contact.kelvin_voigt`: one definition); this module gives them a 3D geometry and a
screw port, so that the friction of :mod:`.friction3d` can act on a rolling sphere's material
point.

Connection
----------
One power port ``p`` (screw domain, dimension 6, world coordinates, orientation ``"in"``), bonded
from a world-aligned frame of a :class:`~porthamiltonian.mechanics.Multibody` at the sphere's
centre (a body's ``world_frames``; for a point contact, the point itself, radius 0):
``"ball.centre -> floor.p"``. The port's flow is (ω, v): the body's angular velocity (rad/s) and
the centre's velocity (m/s); its effort is (τ, f): the wrench the body exerts on the contact,
torque about the centre (N m) and force (N); all in world coordinates (x, y, z), z up. The centre's
position is read as signals ``x``, ``y``, ``z`` (the frame's outputs, e.g. ``x = "ball.centre.x"``).
The friction at the same sphere bonds its own world frame at the centre (two frame names may sit
at one point), or shares the port through a 1-junction.

With ``plane = "xz"`` the component is planar (a circle, or a point, in the x-z plane of a
``plane = "xz"`` multibody): the port has dimension 3, flow (ω_y, v_x, v_z), effort (τ_y, f_x,
f_z), and ``y`` is not used.

Geometry (units m; see :mod:`.surfaces` for the surfaces' frames and signs)
-------------------------------------------------------------------------
The surfaces are those of the planar contact, extruded along world y: ``plane``, ``slope``
(descending towards +x by ``slope`` γ) and ``step`` (the slope with a step down). The unit outward
normal is n = (sin γ, 0, cos γ). The contact point is the sphere's point nearest the surface,
P = c − r n (c the centre, r the ``radius``, ≥ 0; r = 0 is a point contact), and the penetration
is z = n·(P_s − P) = r − (distance of the centre above the surface), positive inside the ground;
its rate is ż = −n·v (the step's edge aside, as in 2D: place the step where no penetrating
contact crosses it). On the ``step`` surface the step is looked up at the contact point's x.

Law (units: z m, ż m/s, F N) and energy role
--------------------------------------------
The force on the body is F n at the contact point, i.e. at the centre with no torque (n passes
through the centre). Port effort: the reaction (0, −F n), so the power into the contact is
e·f = F ż. F, the stored energy and the dissipated power are those of the planar law (see
:mod:`.contact`): Hunt–Crossley F = (K + λ ż) zⁿ clipped at F ≥ 0, stored K z₊^{n+1}/(n+1),
dissipated λ zⁿ ż² (or −K zⁿ ż while clipped, ≥ 0); Kelvin–Voigt F = K z + B ż. The stored energy
is booked with ``via_ports=True`` (paid through the port), the dissipation as dissipated.
``active`` (0/1, a mode parameter) switches the contact as in 2D.

Outputs: ``Fn`` (N), ``z`` (m, a touchdown guard), ``zdot`` (m/s), ``px``, ``py``, ``pz`` (the
contact point, m), ``s`` (its coordinate along the downhill tangent, m), ``nx``, ``ny``, ``nz``
(the unit normal, read by a friction element), ``r`` (the radius, m).

Errors (:class:`~porthamiltonian.errors.ParameterValueError`, naming the component and argument):
a stiffness, damping, radius or ``active`` < 0, an exponent ≤ 0, an unknown surface or
``plane``.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

import sympy as sp

from ..errors import ParameterValueError
from ..modeling.component import Arg, Builder, Component, register
from ..modeling.ports import Port
from .contact import (
    HUNT_CROSSLEY_ARGUMENTS,
    KELVIN_VOIGT_ARGUMENTS,
    MODE_ARGUMENTS,
    Law,
    hunt_crossley,
    kelvin_voigt,
    split_law,
)
from .surfaces import make_surface, surface_arguments

Vec = list[Any]

#: Arguments shared by the 3D contact and friction components.
PLANE = Arg("'xz' for a planar contact (port (ω_y, v_x, v_z)); absent: 3D", symbolic=False,
            default=None)


def check_plane(plane: Any, where: str) -> None:
    """Refuse a ``plane`` other than absent or "xz"."""
    if plane not in (None, "xz"):
        raise ParameterValueError(f"{where} argument 'plane' must be 'xz' or absent, got {plane!r}")


def port_dim(plane: Any) -> int:
    """The dimension of a 3D contact's screw port: 6, or 3 in the x-z plane."""
    return 3 if plane == "xz" else 6


def twist(flow: sp.Matrix, plane: Any) -> tuple[Vec, Vec]:
    """(ω, v) as world 3-vectors from a port's flow (planar: (ω_y, v_x, v_z))."""
    f = list(flow)
    if plane == "xz":
        return [0, f[0], 0], [f[1], 0, f[2]]
    return f[:3], f[3:]


def wrench(torque: Vec, force: Vec, plane: Any) -> sp.Matrix:
    """A port effort from a world torque and force (planar: (τ_y, f_x, f_z))."""
    if plane == "xz":
        return sp.Matrix([torque[1], force[0], force[2]])
    return sp.Matrix([*torque, *force])


class _Contact3D(Component):
    """Shared part of the 3D normal contacts (port, geometry, outputs)."""

    def ports(self) -> list[Port]:
        return [Port("p", "screw", port_dim(self.value("plane")), "in", "world",
                     "sphere centre: effort = wrench (τ, f) of the body on the contact, flow = "
                     "twist (ω, v), world axes")]

    def _contact(self, b: Builder, x: sp.Expr, y: sp.Expr, z: sp.Expr, radius: sp.Expr,
                 surface: str, slope: sp.Expr, height: sp.Expr, step_height: sp.Expr,
                 step_x: sp.Expr, plane: Any, law: Callable[[sp.Expr, sp.Expr], Law]) -> None:
        where = f"{self.kind} {b.name!r}"
        check_plane(plane, where)
        surf = make_surface(surface, where, slope=slope, height=height, step_height=step_height,
                            step_x=step_x)
        nx, nz = surf.normal
        n = [nx, 0, nz]
        port = b.port("p")
        _, v = twist(port.f, plane)
        px, py, pz = (c - radius * ni for c, ni in zip((x, y, z), n))
        pen = surf.penetration(px, pz)
        rate = surf.penetration_rate(v[0], v[2])
        force, pushed, energy, dissipation = split_law(b, law, pen, rate)
        b.equation(port.e, wrench([0, 0, 0], [-pushed * ni for ni in n], plane),
                   "e = (0, -Fn n): reaction of the normal force, through the centre")
        b.energy(energy, via_ports=True)
        b.dissipate(dissipation)
        for name, expr, unit in (("Fn", force, "N"), ("z", pen, "m"), ("zdot", rate, "m/s"),
                                 ("px", px, "m"), ("py", py, "m"), ("pz", pz, "m"),
                                 ("s", surf.arc(px, pz), "m"), ("nx", nx, "1"), ("ny", 0, "1"),
                                 ("nz", nz, "1"), ("r", radius, "m")):
            b.output(name, expr, unit)


_GEOMETRY = {
    "x": Arg("world x of the sphere's centre (a signal, e.g. 'ball.centre.x')", "m"),
    "y": Arg("world y of the sphere's centre (a signal; not used with plane = 'xz')", "m",
             default=0),
    "z": Arg("world z of the sphere's centre (a signal)", "m"),
    "radius": Arg("sphere radius r (0: a point contact)", "m", default=0, rule=">="),
}
_MODE = {**MODE_ARGUMENTS, "plane": PLANE}


@register
class HuntCrossley3D(_Contact3D):
    """Hunt–Crossley contact of a sphere (or point) with a surface, in 3D (or the x-z plane).

    Ports: ``p`` (screw, (ω, v) / (τ, f), world axes, in): a multibody's world-aligned frame at
    the centre. Parameters: ``x``, ``y``, ``z`` (centre position signals), ``radius`` r (m),
    ``stiffness`` K (N/mⁿ), ``damping`` λ (N·s/m^{n+1}), ``exponent`` n, the surface, ``active``,
    ``plane``. Energy: K z₊^{n+1}/(n+1) stored; λ zⁿ ż² dissipated. See the module docstring.
    """

    kind = "HuntCrossley3D"
    arguments = {
        **_GEOMETRY,
        **HUNT_CROSSLEY_ARGUMENTS,
        **surface_arguments(),
        **_MODE,
    }

    def build(self, b: Builder, x: sp.Expr, y: sp.Expr, z: sp.Expr, radius: sp.Expr,
              stiffness: sp.Expr, damping: sp.Expr, exponent: sp.Expr, surface: str,
              slope: sp.Expr, height: sp.Expr, step_height: sp.Expr, step_x: sp.Expr,
              active: sp.Expr, plane: Any) -> None:
        self._contact(b, x, y, z, radius, surface, slope, height, step_height, step_x, plane,
                      lambda pen, rate: hunt_crossley(pen, rate, stiffness, damping, exponent,
                                                      active))


@register
class KelvinVoigt3D(_Contact3D):
    """Kelvin–Voigt contact of a sphere (or point) with a surface, in 3D (or the x-z plane).

    A drop-in alternative to :class:`HuntCrossley3D` (``damping`` is B, N·s/m; no exponent;
    ``clip`` default true). Energy: ½ K z₊² stored; B ż² dissipated (−K z ż while clipped).
    """

    kind = "KelvinVoigt3D"
    arguments = {
        **_GEOMETRY,
        **KELVIN_VOIGT_ARGUMENTS,
        **surface_arguments(),
        **_MODE,
    }

    def build(self, b: Builder, x: sp.Expr, y: sp.Expr, z: sp.Expr, radius: sp.Expr,
              stiffness: sp.Expr, damping: sp.Expr, clip: bool, surface: str, slope: sp.Expr,
              height: sp.Expr, step_height: sp.Expr, step_x: sp.Expr, active: sp.Expr,
              plane: Any) -> None:
        if not isinstance(clip, bool):
            raise ParameterValueError(f"KelvinVoigt3D {b.name!r} argument 'clip' must be true or "
                                      f"false, got {clip!r}")
        self._contact(b, x, y, z, radius, surface, slope, height, step_height, step_x, plane,
                      lambda pen, rate: kelvin_voigt(pen, rate, stiffness, damping, clip, active))


__all__ = ["HuntCrossley3D", "KelvinVoigt3D"]

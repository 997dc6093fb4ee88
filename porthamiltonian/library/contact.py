"""Compliant normal contact: Hunt–Crossley and Kelvin–Voigt, between a body point and a surface.

Connection
----------
A contact has one power port ``p`` (translation, dimension 2: world (x, z) components, orientation
``"in"``), bonded to a body point of a :class:`~porthamiltonian.mechanics.Multibody` with
``plane = "xz"``, directly (``"walker.foot1 -> floor.p"``) or through a 1-junction shared with a
friction element (``"walker.foot1 -> j"``, ``"j -> floor.p"``, ``"j -> friction.p"``). The body's
point port is then the bond's tail, so the port effort e is the force the body exerts on the
contact and the port flow f is the point's velocity (m/s). The contact reads the point's position
as signals, ``x = "walker.foot1.x"`` and ``z = "walker.foot1.z"`` (the multibody's outputs), and
its velocity from the port flow: position and port must name the same point.

Arc feet (the thesis's nominal walker, docs/walkers.md): bond the foot's centre point and give
the contact point as an expression, e.g. ``z = "walker.foot1.z - R"`` (the thesis: R below the centre along the world
vertical) or ``x = "walker.foot1.x - R*sin(gamma)"``, ``z = "walker.foot1.z - R*cos(gamma)"``
(along the surface normal). With the normal offset the penetration of the circle is exactly
R − (distance of the centre from the surface), whose rate is −n·(centre velocity): the port flow,
so the ledger closes. (A friction element on that port sees the centre's tangential velocity,
not the rolling foot's material point's, t·ċ + ω R; a port at the material point is the walker
model's business.)

Law (units: z m, ż m/s, F N)
----------------------------
With the surface's unit outward normal n and the penetration z = n·(P_s − P) (positive inside the
ground, see :mod:`porthamiltonian.library.surfaces`), ż = −n·f:

* Hunt–Crossley (``HuntCrossley``): F = K zⁿ + λ zⁿ ż for z > 0, clipped at F ≥ 0 (no pulling:
  F = 0 while K + λ ż < 0, a fast separation), F = 0 for z ≤ 0. K in N/mⁿ, λ in N·s/m^{n+1}, n > 0
  (n = 1 in the thesis's App. A; 3/2 for Hertzian spheres). The force is continuous at touchdown.
  For n < 1 the force's derivative (the Jacobian) is unbounded at z = 0⁺.
* Kelvin–Voigt (``KelvinVoigt``): F = K z + B ż for z > 0 (K N/m, B N·s/m), F = 0 for z ≤ 0;
  clipped at F ≥ 0 unless ``clip = false``. The force jumps to B ż at touchdown, and without
  clipping it is tensile (F < 0) just before separation: the classic objection to this law.
  The jump is a discontinuity of the right-hand side: the compiled Rodas4 loop, which controls
  the error of the ledger states too, may fail to step across it at very small ``atol``
  (1e-12 J with E_diss = 0 at a first impact; 1e-11 passes); Radau steps across it.

The force on the body is F·n (along the outward normal); the port effort is its reaction,
e = −F·n, so the power into the contact is e·f = F ż.

Energy role
-----------
Stored: H_c = K z₊^{n+1}/(n+1) (Kelvin–Voigt: ½ K z₊²), z₊ = max(z, 0), booked with
``b.energy(..., via_ports=True)``: H_c depends on the body's coordinates through z, and the power
that changes it is paid through the contact's own port (not a modulation).
Dissipated: the port power minus dH_c/dt, i.e. (F − K z₊ⁿ) ż:
λ z₊ⁿ ż² while the law holds (B ż² for Kelvin–Voigt), and −K z₊ⁿ ż while clipped (F = 0 then
means K + λ ż < 0, so ż < 0 and this is > 0: the spring energy released in a separation faster
than the damper allows is dissipated). So P_diss ≥ 0 at all times and the ledger closes.

Contact modes
-------------
``active`` (default 1) multiplies force, stored energy and dissipation. Give it a model
parameter (a mode flag ``c1`` with values 0/1) that event actions set, to let a user rule decide
when a contact may start (item 6 of issue 4, the thesis's scuffing rule, its §2.3.1: a
contact starts only when the foot crosses the surface *and* is in front of the other foot; it ends
when the foot rises above the surface). While inactive, a point passes through the surface with
no force. Switch the flag at z = 0 (guards on the penetration, rising for touchdown, falling for
lift-off), where the stored energy is zero, so that the switch does not change H; otherwise the
jump of H is booked by the simulator at the event (as dissipated, or as supplied with
``Reset(energy="supplied")``). A resting contact chatters around z = 0: give lift-off guards a
small margin (e.g. ``-z - 1e-6``).

Outputs (``<name>.<output>``; other components and analyses read them by name)
------------------------------------------------------------------------------
``Fn`` normal force on the body (N, ≥ 0 when clipped), ``z`` signed penetration (m, < 0 above
the surface: a smooth event guard), ``zdot`` its rate (m/s), ``px``/``pz`` the contact point's
world position (m), ``s`` and ``vt`` its tangential coordinate (m) and velocity (m/s, downhill
positive), ``nx``/``nz`` and ``tx``/``tz`` the surface's unit normal and tangent (a friction
element reads the tangent of the contact whose ``Fn`` it uses). Model events and outputs read
them too: a touchdown guard is simply ``floor.z``.

Errors (:class:`~porthamiltonian.errors.ParameterValueError`, naming the component and argument):
a stiffness, damping or ``active`` < 0, an exponent n ≤ 0 (numbers when the model compiles,
parameter values whenever they are bound: :mod:`porthamiltonian.modeling.constraints`), an unknown surface.

References
----------
K. H. Hunt, F. R. E. Crossley, "Coefficient of restitution interpreted as damping in
vibroimpact", J. Appl. Mech. 42 (1975) 440–445. D. W. Marhefka, D. E. Orin, "A compliant contact
model with nonlinear damping for simulation of robotic systems", IEEE Trans. SMC-A 29 (1999)
566–572 (the clipping, and the exact restitution relation used by the tests).
20-sim contact model of the thesis, App. A (``Fn = Kp*z + Kd*z*zdot``, 0 when
negative).
"""
from __future__ import annotations

from collections.abc import Callable

import sympy as sp

from ..errors import ParameterValueError
from ..modeling.component import Arg, Builder, Component, register
from ..modeling.differentiation import derivative
from ..modeling.ports import Port
from .surfaces import Surface, make_surface, surface_arguments

_POINT = {
    "x": Arg("world x of the contact point (a signal, e.g. 'walker.foot1.x')", "m"),
    "z": Arg("world z of the contact point (a signal, e.g. 'walker.foot1.z')", "m"),
}
#: argument tables shared by the planar and the 3D contacts (library/contact3d.py)
MODE_ARGUMENTS = {"active": Arg("contact mode flag (0 or 1; a parameter switched by events)", "1",
                                default=1, rule=">=")}
HUNT_CROSSLEY_ARGUMENTS = {
    "stiffness": Arg("contact stiffness K", "N/m^n", rule=">="),
    "damping": Arg("Hunt-Crossley damping λ", "N*s/m^(n+1)", default=0, rule=">="),
    "exponent": Arg("exponent n of the penetration (1: App. A; 3/2: Hertz)", "1", default=1,
                    rule=">"),
}
KELVIN_VOIGT_ARGUMENTS = {
    "stiffness": Arg("contact stiffness K", "N/m", rule=">="),
    "damping": Arg("contact damping B", "N*s/m", default=0, rule=">="),
    "clip": Arg("clip the force at F >= 0 (false: tensile force possible at separation)",
                symbolic=False, default=True),
}


Law = tuple[sp.Expr, sp.Expr, sp.Expr]


def hunt_crossley(pen: sp.Expr, rate: sp.Expr, K: sp.Expr, lam: sp.Expr, n: sp.Expr,
                  active: sp.Expr) -> Law:
    """The Hunt–Crossley law of the module docstring: (normal force F (N, ≥ 0), stored energy
    (J), dissipated power (W, ≥ 0)) for the penetration ``pen`` (m, > 0 inside) and its rate
    ``rate`` (m/s). Shared by the planar and the 3D contacts (:mod:`.contact3d`)."""
    z_pos = sp.Piecewise((pen, pen > 0), (0, True))        # z₊ = max(z, 0), no Heaviside
    law = K + lam * rate                                    # F / zⁿ
    pushing = law > 0
    force = active * z_pos**n * sp.Piecewise((law, pushing), (0, True))
    energy = active * K * z_pos ** (n + 1) / (n + 1)
    dissipation = active * z_pos**n * sp.Piecewise((lam * rate**2, pushing), (-K * rate, True))
    return force, energy, dissipation


def kelvin_voigt(pen: sp.Expr, rate: sp.Expr, K: sp.Expr, B: sp.Expr, clip: bool,
                 active: sp.Expr) -> Law:
    """The Kelvin–Voigt law of the module docstring, as :func:`hunt_crossley`: (F, stored
    energy, dissipated power); ``clip`` refuses a tensile force."""
    law = K * pen + B * rate
    inside = pen > 0
    z_pos = sp.Piecewise((pen, inside), (0, True))
    if clip:
        force = active * sp.Piecewise((law, inside & (law > 0)), (0, True))
        dissipation = active * sp.Piecewise((B * rate**2, inside & (law > 0)),
                                            (-K * pen * rate, inside), (0, True))
    else:
        force = active * sp.Piecewise((law, inside), (0, True))
        dissipation = active * sp.Piecewise((B * rate**2, inside), (0, True))
    return force, active * K * z_pos**2 / 2, dissipation


def split_law(b: Builder, law: Callable[[sp.Expr, sp.Expr], Law], pen: sp.Expr, rate: sp.Expr
              ) -> tuple[sp.Expr, sp.Expr, sp.Expr, sp.Expr]:
    """A contact ``law`` (:func:`hunt_crossley`, :func:`kelvin_voigt`) at the penetration ``pen``
    and its rate: (normal force, the normal force as the builder takes it, energy, dissipated
    power). The latter is the force, or in the port-Hamiltonian form's cut build its elastic
    part ∂E/∂z (stored
    through the body's coordinates, :meth:`Builder.stored_via_ports`) plus the rest, a
    dissipator of the penetration rate ż (λ zⁿ ż, or −K zⁿ while the force is clipped: its
    power is the law's dissipated power)."""
    force, energy, dissipation = law(pen, rate)
    if b.ph is None:
        return force, force, energy, dissipation
    z = sp.Dummy("z", real=True)                    # ∂E/∂z of the law's energy at z = pen
    elastic = derivative(law(z, rate)[1], z).xreplace({z: pen})
    pushed = b.stored_via_ports(elastic) + b.resistive(force - elastic, rate, "normal")
    return force, pushed, energy, dissipation


class _Contact(Component):
    """Shared part of the normal contact laws (port, surface, kinematics, outputs)."""

    def ports(self) -> list[Port]:
        return [Port("p", "translation", 2, "in", "world",
                     "contact point: effort = force of the body on the contact, flow = velocity")]

    def _kinematics(self, b: Builder, x: sp.Expr, z: sp.Expr, surface: str, slope: sp.Expr,
                    height: sp.Expr, step_height: sp.Expr, step_x: sp.Expr, stiffness: sp.Expr,
                    damping: sp.Expr, active: sp.Expr) -> tuple[Surface, sp.Expr, sp.Expr]:
        where = f"{self.kind} {b.name!r}"
        surf = make_surface(surface, where, slope=slope, height=height, step_height=step_height,
                            step_x=step_x)
        port = b.port("p")
        vx, vz = port.f[0], port.f[1]
        pen = surf.penetration(x, z)
        rate = surf.penetration_rate(vx, vz)
        nx, nz = surf.normal
        tx, tz = surf.tangent
        for name, expr, unit in (("z", pen, "m"), ("zdot", rate, "m/s"), ("px", x, "m"),
                                 ("pz", z, "m"), ("s", surf.arc(x, z), "m"),
                                 ("vt", surf.tangential_velocity(vx, vz), "m/s"),
                                 ("nx", nx, "1"), ("nz", nz, "1"), ("tx", tx, "1"), ("tz", tz, "1")):
            b.output(name, expr, unit)
        return surf, pen, rate

    def _finish(self, b: Builder, surf: Surface, law: Callable[[sp.Expr, sp.Expr], Law],
                pen: sp.Expr, rate: sp.Expr) -> None:
        nx, nz = surf.normal
        force, pushed, energy, dissipation = split_law(b, law, pen, rate)
        b.equation(b.port("p").e, sp.Matrix([-pushed * nx, -pushed * nz]),
                   "e = -Fn n (reaction of the normal force on the body)")
        b.energy(energy, via_ports=True)
        b.dissipate(dissipation)
        b.output("Fn", force, "N")


@register
class HuntCrossley(_Contact):
    """Hunt–Crossley normal contact F = K zⁿ + λ zⁿ ż (z > 0), clipped at F ≥ 0.

    Ports: ``p`` (translation, (x, z), in): bond a body point to it (see the module docstring).
    Parameters: ``stiffness`` K (N/mⁿ), ``damping`` λ (N·s/m^{n+1}), ``exponent`` n (> 0,
    default 1), ``x``/``z`` the point's position signals, the surface (``surface``, ``slope``,
    ``height``, ``step_height``, ``step_x``), ``active`` the mode flag.
    Energy: K z₊^{n+1}/(n+1). Dissipation: λ zⁿ ż², or −K zⁿ ż while clipped (≥ 0).
    References: Hunt & Crossley 1975; Marhefka & Orin 1999.
    """

    kind = "HuntCrossley"
    arguments = {
        **_POINT,
        **HUNT_CROSSLEY_ARGUMENTS,
        **surface_arguments(),
        **MODE_ARGUMENTS,
    }

    def build(self, b: Builder, x: sp.Expr, z: sp.Expr, stiffness: sp.Expr, damping: sp.Expr,
              exponent: sp.Expr, surface: str, slope: sp.Expr, height: sp.Expr, step_height: sp.Expr,
              step_x: sp.Expr, active: sp.Expr | None) -> None:
        surf, pen, rate = self._kinematics(b, x, z, surface, slope, height, step_height, step_x,
                                           stiffness, damping, active)
        self._finish(b, surf, lambda z, zdot: hunt_crossley(z, zdot, stiffness, damping,
                                                            exponent, active), pen, rate)


@register
class KelvinVoigt(_Contact):
    """Kelvin–Voigt normal contact F = K z + B ż (z > 0), clipped at F ≥ 0 unless ``clip = false``.

    A drop-in alternative to :class:`HuntCrossley` (same port and arguments, ``damping`` is B here
    and there is no ``exponent``): swapping the law is one line of a model file.
    Parameters: ``stiffness`` K (N/m), ``damping`` B (N·s/m), ``clip`` (default true).
    Energy: ½ K z₊². Dissipation: B ż² (law), −K z ż (clipped), both ≥ 0.
    """

    kind = "KelvinVoigt"
    arguments = {
        **_POINT,
        **KELVIN_VOIGT_ARGUMENTS,
        **surface_arguments(),
        **MODE_ARGUMENTS,
    }

    def build(self, b: Builder, x: sp.Expr, z: sp.Expr, stiffness: sp.Expr, damping: sp.Expr,
              clip: bool, surface: str, slope: sp.Expr, height: sp.Expr, step_height: sp.Expr,
              step_x: sp.Expr, active: sp.Expr | None) -> None:
        if not isinstance(clip, bool):
            raise ParameterValueError(f"KelvinVoigt {b.name!r} argument 'clip' must be true or "
                                      f"false, got {clip!r}")
        surf, pen, rate = self._kinematics(b, x, z, surface, slope, height, step_height, step_x,
                                           stiffness, damping, active)
        self._finish(b, surf, lambda z, zdot: kelvin_voigt(z, zdot, stiffness, damping, clip,
                                                           active), pen, rate)


__all__ = ["HuntCrossley", "KelvinVoigt", "hunt_crossley", "kelvin_voigt", "split_law"]

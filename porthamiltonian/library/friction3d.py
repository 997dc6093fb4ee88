"""SCVS friction in 3D: a vector law in the tangent plane, on a sphere's material contact point,
with optional rolling resistance and spin friction.

Connection
----------
One power port ``p`` (screw domain, dimension 6, world coordinates, orientation ``"in"``), bonded
from the multibody's world-aligned frame at the centre of the sphere whose normal contact
(:mod:`.contact3d`) gives the normal force: ``normal_force = "floor.Fn"``. Flow (ω, v): the
body's angular velocity and the centre's velocity; effort (τ, f): the wrench of the body on the
friction about the centre; world axes (``plane = "xz"``: (ω_y, v_x, v_z) and (τ_y, f_x, f_z)).
The friction reads that contact's unit normal n (its outputs ``nx``, ``ny``, ``nz``) and acts at
the point −r n from the centre, r = ``radius`` (m, default 0: friction at the port's point
itself). For a rolling sphere give the contact's radius; a point r' ≠ r lets a model put the
friction at a chosen material point (e.g. a foot's sole point, at radius 0 from its own frame).

Slip (m/s)
----------
The material point's velocity u = v + ω × (−r n); the slip is its tangential part
v_s = u − (n·u) n, of speed a = |v_s|. Rolling without slipping is v_s = 0 (on a plane:
v = −ω × (−r n), |v| = r |ω_t|).

Law (N; the 1D law of :mod:`.friction`, one definition: :func:`~.friction.scvs_coefficient`)
------------------------------------------------------------------------------------------
The force on the body at the contact point is F_t = −Fn μ(a) v_s / a, with μ the SCVS
coefficient (odd, μ(0) = 0): along −v_s, of magnitude Fn μ(|v_s|), so that on a line it is
exactly the 1D law. μ(a)/a is smooth and even in a (its terms are tanh(s a)/a, (1 − E)/a and μ_v),
with limit μ_st s + μ_v at a = 0: the law is regularised at zero slip exactly as the 1D law is (a
slope s of its tanh), and its Jacobian at a = 0 is −Fn (μ_st s + μ_v) times the tangential
projector. The speed is computed as a = √(v_s·v_s + 1e-200), which is |v_s| to the last bit for
|v_s| > 1e-92 m/s and keeps every back end (the Python one raises on a division by zero) away
from 0/0 at exactly zero slip (a sphere at rest, a foot in the air moving straight down).
Fn is max(Fn, 0). The slip, a, μ(a), μ(a)/a and max(Fn, 0) are declared as intermediates (of
the port's flow): computed once per evaluation and differentiated by the chain rule, never
expanded into the state equations (a sphere's code generation took 12 s with them expanded).

Optional torques (N m; each 0 by default)
-----------------------------------------
* Rolling resistance: τ_roll = −Fn c_r tanh(k |ω_t|) ω_t / |ω_t|, ω_t = ω − (n·ω) n the rolling
  rate, ``rolling`` c_r (m, the lever arm: the rolling-resistance coefficient times r).
* Spin friction (drilling): τ_spin = −Fn c_s tanh(k ω_n) n, ω_n = n·ω, ``spin`` c_s (m).
``angular_slope`` k (s/rad, default 100) regularises both at zero rate as s does the slip.

Energy role
-----------
A pure dissipator, no state: the port effort is the reaction of the wrench on the body,
(−(−r n) × F_t − τ_roll − τ_spin, −F_t), so the power into the element is
e·f = −F_t·u − (τ_roll + τ_spin)·ω = Fn (μ(a) a + c_r tanh(k|ω_t|)|ω_t| + c_s tanh(k ω_n) ω_n)
≥ 0, all booked as dissipated.

Outputs: ``Ft`` (magnitude of the friction force, N), ``v`` (slip speed a, m/s), ``vx``, ``vy``,
``vz`` (slip velocity, m/s), ``mu`` (μ(a)).

Errors: as :class:`~.friction.SCVSFriction` (no normal force, a normal force that is not one
contact's ``Fn``, coefficients < 0, v_st ≤ 0, μ_c > μ_st), and a radius, ``rolling``, ``spin``
or ``angular_slope`` < 0.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import sympy as sp

from ..modeling.component import Arg, Builder, Component, register
from ..modeling.ports import Port
from .contact3d import PLANE, check_plane, port_dim, twist, wrench
from .friction import SCVSFriction, normal_force_source, scvs_coefficient

#: ε² added under the square root of a speed: a = √(v·v + ε²) equals |v| to the last bit for
#: |v| > 1e-92 (m/s or rad/s) and keeps a, a² and a³ (the Jacobian's) nonzero at v = 0.
_EPSILON2 = sp.Float("1e-200")


def _speed(squared: sp.Expr) -> sp.Expr:
    return sp.sqrt(squared + _EPSILON2)


def _dot(a: Sequence[Any], b: Sequence[Any]) -> sp.Expr:
    return sum(x * y for x, y in zip(a, b))


def _cross(a: Sequence[Any], b: Sequence[Any]) -> list[Any]:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


@register
class SCVSFriction3D(Component):
    """SCVS friction as a vector law in a contact's tangent plane, at a sphere's contact point.

    Ports: ``p`` (screw, world axes, in) at the sphere's centre. Parameters: ``normal_force``
    (a 3D contact's Fn), ``radius`` r (m), ``mu_st``, ``mu_c`` (1), ``mu_v`` (s/m), ``slope`` (s/m),
    ``v_st`` (m/s), ``rolling``, ``spin`` (m), ``angular_slope`` (s/rad), ``plane``.
    Dissipation: Fn (μ(a) a + rolling and spin terms) ≥ 0. See the module docstring.
    """

    kind = "SCVSFriction3D"
    arguments = {
        **SCVSFriction.arguments,
        "radius": Arg("distance r from the port's point to the contact point, along -n (the "
                      "sphere's radius)", "m", default=0, rule=">="),
        "rolling": Arg("rolling-resistance lever arm c_r (torque Fn c_r)", "m", default=0,
                       rule=">="),
        "spin": Arg("spin-friction lever arm c_s (torque Fn c_s about n)", "m", default=0,
                    rule=">="),
        "angular_slope": Arg("steepness k of tanh(k ω) of the rolling and spin torques", "s/rad",
                             default=100, rule=">="),
        "plane": PLANE,
    }
    relations = SCVSFriction.relations

    def ports(self) -> list[Port]:
        return [Port("p", "screw", port_dim(self.value("plane")), "in", "world",
                     "sphere centre: effort = wrench (τ, f) of the body on the friction, flow = "
                     "twist (ω, v), world axes")]

    def build(self, b: Builder, normal_force: sp.Expr | None, mu_st: sp.Expr, mu_c: sp.Expr,
              mu_v: sp.Expr, slope: sp.Expr, v_st: sp.Expr, radius: sp.Expr, rolling: sp.Expr,
              spin: sp.Expr, angular_slope: sp.Expr, plane: Any) -> None:
        where = f"SCVSFriction3D {b.name!r}"
        check_plane(plane, where)
        contact, normal_force = normal_force_source(self, where, normal_force)
        n = [sp.Symbol(f"{contact}.n{axis}", real=True) for axis in "xyz"]
        port = b.port("p")
        omega, v = twist(port.f, plane)
        lever = [-radius * ni for ni in n]                       # centre -> contact point
        u = [a + c for a, c in zip(v, _cross(omega, lever))]
        un = _dot(n, u)
        # the slip, its speed and the law as intermediates (of the port's flow): computed once,
        # differentiated by the chain rule, never expanded into the state equations
        slip = [b.intermediate(f"slip_{axis}", ui - un * ni) for axis, ui, ni in zip("xyz", u, n)]
        a = b.intermediate("speed", _speed(_dot(slip, slip)))
        mu = b.intermediate("mu", scvs_coefficient(a, mu_st, mu_c, mu_v, slope, v_st))
        g = b.intermediate("mu_over_speed", mu / a)              # smooth and even in a
        fn = b.intermediate("Fn", sp.Piecewise((normal_force, normal_force > 0), (0, True)))
        force = [-fn * g * si for si in slip]                    # on the body, at the point
        wn = _dot(n, omega)
        wt = [wi - wn * ni for wi, ni in zip(omega, n)]
        rate = _speed(_dot(wt, wt))
        roll = sp.tanh(angular_slope * rate) / rate
        torque = [c - fn * rolling * roll * w - fn * spin * sp.tanh(angular_slope * wn) * ni
                  for c, w, ni in zip(_cross(lever, force), wt, n)]
        b.equation(port.e, b.resistive(wrench([-t for t in torque], [-f for f in force], plane),
                                       port.f, "friction"),
                   "e = -(wrench of the friction on the body about the centre)")
        b.dissipate(fn * (g * _dot(slip, slip) + rolling * roll * _dot(wt, wt)
                          + spin * sp.tanh(angular_slope * wn) * wn))
        b.output("Ft", fn * g * a, "N")
        b.output("v", a, "m/s")
        for axis, s in zip("xyz", slip):
            b.output(f"v{axis}", s, "m/s")
        b.output("mu", mu, "1")


__all__ = ["SCVSFriction3D"]

"""A spring–damper between two body points, or a body point and a fixed anchor (3D or x-z plane).

20-sim's spring–damper between two points of a 3D mechanism: a linear spring along the line
between the points (e.g. Andrews' squeezer's spring, from a point of a body to a fixed anchor), or
with zero rest length an isotropic one (a stiff spring–damper closing a kinematic loop, the
compliant alternative to a loop-closing joint, :mod:`porthamiltonian.mechanics.closure`).

Connection
----------
Ports ``a`` and ``b`` (translation, dimension 3, or 2 with ``plane = "xz"``: components (x, z);
world coordinates; orientation set by the bond), each bonded from a multibody's point
(``"mb.tip -> spring.a"``): flow = the point's velocity (m/s), effort = the force the body exerts
on the spring at that point (N) — the spring pulls the body with minus the effort. The points'
positions are read as signals ``a`` and ``b`` (lists of three expressions, e.g.
``["mb.tip.x", "mb.tip.y", "mb.tip.z"]``; planar: y is not read). With ``anchor`` (a fixed world
point, numbers or expressions in parameters) instead of ``b`` there is no port ``b``.

Law (SI units) and energy role
------------------------------
With d = x_a − x_b and the rest length L0:

* L0 ≠ 0 (along the line): L = |d|, u = d / L, F = K (L − L0) + D L̇ with L̇ = u·(v_a − v_b);
  efforts e_a = F u, e_b = −F u. Stored ½ K (L − L0)², dissipated D L̇².
* L0 = 0 (isotropic, the default): F = K d + D ḋ (a vector, ḋ = v_a − v_b); e_a = F, e_b = −F.
  Stored ½ K |d|², dissipated D |ḋ|². Smooth where the points meet (no direction needed).

The stored energy is a function of the bodies' coordinates paid through the ports
(``via_ports``). Outputs: ``L`` (m), ``F`` (the tension along the line, N; L0 = 0: |F|).

Errors: a stiffness, damping or rest length < 0 (ParameterValueError); signals of the wrong
length, or both ``b`` and ``anchor`` (ModelError).
"""
from __future__ import annotations

from typing import Any

import sympy as sp

from ..errors import ModelError
from ..modeling.component import Arg, Builder, Component, register
from ..modeling.ports import Port

_DIMS = {None: (0, 1, 2), "xz": (0, 2)}


def _position(value: Any, where: str, what: str) -> list:
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ModelError(f"{where}: {what} must be three expressions [x, y, z], got {value!r}",
                         path=(what,))
    return list(value)


@register
class PointSpringDamper(Component):
    """A linear spring–damper between two points (or a point and a fixed anchor); see the
    module docstring for ports, law, signs and energy.

    Parameters: ``stiffness`` K (N/m), ``damping`` D (N·s/m), ``rest_length`` L0 (m; 0: an
    isotropic zero-length spring), ``position_a``, ``position_b`` (signals), ``anchor`` (a fixed
    point instead of ``position_b``), ``plane`` ("xz" or absent).
    """

    kind = "PointSpringDamper"
    arguments = {
        "stiffness": Arg("stiffness K", "N/m", rule=">="),
        "damping": Arg("damping D", "N*s/m", default=0, rule=">="),
        "rest_length": Arg("rest length L0 (0: isotropic zero-length spring)", "m", default=0,
                           rule=">="),
        "position_a": Arg("position of point a, [x, y, z] (signals)", symbolic=False),
        "position_b": Arg("position of point b, [x, y, z] (signals)", symbolic=False,
                          default=None),
        "anchor": Arg("a fixed world point instead of b, [x, y, z]", symbolic=False,
                      default=None),
        "plane": Arg("'xz' for planar ports (x, z)", symbolic=False, default=None),
    }
    vector_arguments = ("position_a", "position_b", "anchor")

    def __init__(self, **args: Any):
        super().__init__(**args)
        where = "PointSpringDamper"
        if (self.value("position_b") is None) == (self.value("anchor") is None):
            raise ModelError(f"{where}: give exactly one of 'position_b' (a second point) and "
                             "'anchor' (a fixed world point)", path=("position_b",))
        if self.value("plane") not in _DIMS:
            raise ModelError(f"{where}: plane must be 'xz' or absent", path=("plane",))
        for what in ("position_a", "position_b", "anchor"):
            if self.value(what) is not None:
                _position(self.value(what), where, what)

    def ports(self) -> list[Port]:
        dim = len(_DIMS[self.value("plane")])
        names = ["a"] if self.value("anchor") is not None else ["a", "b"]
        return [Port(n, "translation", dim, None, "world",
                     f"point {n}: flow its velocity, effort the force of the body on the spring")
                for n in names]

    def build(self, b: Builder, stiffness: sp.Expr, damping: sp.Expr, rest_length: sp.Expr,
              position_a: list, position_b: list | None, anchor: list | None,
              plane: str | None) -> None:
        dims = _DIMS[plane]
        other = position_b if position_b is not None else anchor
        xa = [b.parse(v, "argument 'position_a'") for v in position_a]
        xb = [b.parse(v, f"argument {'position_b' if position_b is not None else 'anchor'!r}")
              for v in other or []]
        pa = b.port("a")
        va = list(pa.f)
        vb = list(b.port("b").f) if position_b is not None else [0] * len(dims)
        d = [xa[i] - xb[i] for i in dims]
        rate = [x - y for x, y in zip(va, vb)]
        if rest_length == 0:
            force = [b.stored_via_ports(stiffness * di) + b.resistive(damping * ri, ri,
                                                                      f"damper{k}")
                     for k, (di, ri) in enumerate(zip(d, rate))]
            length = sp.sqrt(sum(x**2 for x in d))
            energy = stiffness * sum(x**2 for x in d) / 2
            dissipated = damping * sum(x**2 for x in rate)
            tension = sp.sqrt(sum(f**2 for f in force))
        else:
            length = b.intermediate("L", sp.sqrt(sum(x**2 for x in d)))
            u = [b.intermediate(f"u{k}", x / length) for k, x in enumerate(d)]
            speed = b.intermediate("Ldot", sum(ui * ri for ui, ri in zip(u, rate)))
            tension = (b.stored_via_ports(stiffness * (length - rest_length))
                       + b.resistive(damping * speed, speed, "damper"))
            force = [tension * ui for ui in u]
            energy = stiffness * (length - rest_length) ** 2 / 2
            dissipated = damping * speed**2
        b.equation(pa.e, sp.Matrix(force), "e_a = the spring's force on the body, reversed")
        if position_b is not None:
            b.equation(b.port("b").e, sp.Matrix([-f for f in force]), "e_b = -e_a")
        b.energy(energy, via_ports=True)
        b.dissipate(dissipated)
        b.output("L", length, "m")
        b.output("F", tension, "N")


__all__ = ["PointSpringDamper"]

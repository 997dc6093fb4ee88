"""Ground surfaces for contact laws: plane, slope, and slope with a step down.

A surface is a plain helper (not a component): a contact component builds one from its arguments
(``surface``, ``slope``, ``height``, ``step_height``, ``step_x``) with :func:`make_surface`, then
asks it for the penetration of a point and for the surface's unit normal and tangent, all as
sympy expressions in the point's world coordinates and the model's parameters.

Frames, units and signs
-----------------------
* Planar world frame (x, z), m: x horizontal, z up (gravity along −z), as the ``plane = "xz"``
  point ports of :class:`~porthamiltonian.mechanics.Multibody`.
* ``slope`` γ (rad): the surface descends towards +x, z_s(x) = height − x tan γ (a walker walks
  downhill towards +x). γ = 0 is horizontal.
* Unit outward normal n = (sin γ, cos γ) (out of the ground, into the air); unit tangent
  t = (cos γ, −sin γ) (along the surface, pointing downhill, towards +x). (t, n) is a right-handed
  pair in the x-z plane seen from −y, and t·n = 0.
* Penetration (m), measured along the normal, positive inside the ground, negative above it:
  z_pen = n·(P_s − P) for a point P and any point P_s of the surface, i.e.
  z_pen = height·cos γ − (x sin γ + z cos γ) for the plane/slope through (0, height).
  Its rate is ż_pen = −n·v for a point moving with velocity v.
* Tangential coordinate s = t·P (m, increasing downhill) and tangential velocity v_t = t·v, used
  by friction and by touchdown rules ("this foot is in front of the other": s1 > s2).

Surfaces
--------
``"plane"``  horizontal, z_s = height. Takes no slope and no step.
``"slope"``  z_s(x) = height − x tan γ.
``"step"``   the slope with a step down of vertical height h (``step_height``, m, h ≥ 0) at
             x = x_step (``step_x``, m): z_s(x) = height − x tan γ − h·[x ≥ x_step]. The lower part
             is parallel to the upper one, so n and t are the same; its penetration is
             z_pen − h cos γ (h cos γ is the normal distance between the two planes). The edge is
             a discontinuity of the penetration in x (a Piecewise of x): a point that crosses the
             edge *while penetrating* sees its stored contact energy jump, which the energy ledger
             does not book. Place the step where the contacting points do not cross it (for a
             step-down test: ahead of the stance foot, before the swing foot's landing point).

Reference: the thesis's compliant contact (App. A) measured the penetration along the
world vertical from the arc foot's lowest point; along the surface normal (here) is the
geometrically consistent choice, and the two agree to O(γ²) on the thesis's slopes
(γ ≈ 0.009 rad).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import sympy as sp

from ..errors import ParameterValueError
from ..modeling.expressions import as_expr

#: The surfaces a contact may use, with one line each (for messages and docs).
SURFACES: dict[str, str] = {
    "plane": "horizontal plane z = height",
    "slope": "plane of angle slope (rad) descending towards +x, through (0, height)",
    "step": "slope with a step down of step_height (m) at x = step_x (m)",
}


@dataclass(frozen=True)
class Surface:
    """A ground surface in the x-z plane (see the module docstring for frames and signs).

    Attributes are sympy expressions (numbers or parameter expressions): ``gamma`` the slope angle
    (rad), ``height`` the surface's elevation at x = 0 (m), ``step_height`` h (m) and ``step_x``
    (m) for the ``"step"`` kind (0 otherwise).
    """

    kind: str
    gamma: sp.Expr = sp.S.Zero
    height: sp.Expr = sp.S.Zero
    step_height: sp.Expr = sp.S.Zero
    step_x: sp.Expr = sp.S.Zero

    @property
    def normal(self) -> tuple[sp.Expr, sp.Expr]:
        """Unit outward normal (n_x, n_z) = (sin γ, cos γ)."""
        return sp.sin(self.gamma), sp.cos(self.gamma)

    @property
    def tangent(self) -> tuple[sp.Expr, sp.Expr]:
        """Unit tangent (t_x, t_z) = (cos γ, −sin γ), pointing downhill (towards +x)."""
        return sp.cos(self.gamma), -sp.sin(self.gamma)

    def drop(self, x: sp.Expr) -> sp.Expr:
        """Vertical drop of the surface below the upper plane at x: h·[x ≥ x_step] (m)."""
        if self.kind != "step":
            return sp.S.Zero
        return sp.Piecewise((sp.S.Zero, x < self.step_x), (self.step_height, True))

    def elevation(self, x: sp.Expr) -> sp.Expr:
        """Surface height z_s(x) (m)."""
        return self.height - x * sp.tan(self.gamma) - self.drop(x)

    def penetration(self, x: sp.Expr, z: sp.Expr) -> sp.Expr:
        """Signed penetration of the point (x, z) along the normal (m): > 0 inside the ground."""
        nx, nz = self.normal
        return (self.height - self.drop(x)) * nz - (x * nx + z * nz)

    def penetration_rate(self, vx: sp.Expr, vz: sp.Expr) -> sp.Expr:
        """ż_pen = −n·v (m/s) for a point velocity (vx, vz) (the step's edge aside)."""
        nx, nz = self.normal
        return -(vx * nx + vz * nz)

    def arc(self, x: sp.Expr, z: sp.Expr) -> sp.Expr:
        """Tangential coordinate s = t·(x, z) (m), increasing downhill."""
        tx, tz = self.tangent
        return x * tx + z * tz

    def tangential_velocity(self, vx: sp.Expr, vz: sp.Expr) -> sp.Expr:
        """v_t = t·v (m/s), positive downhill."""
        tx, tz = self.tangent
        return vx * tx + vz * tz


def make_surface(kind: Any, where: str, *, slope: sp.Expr = sp.S.Zero,
                 height: sp.Expr = sp.S.Zero, step_height: sp.Expr = sp.S.Zero,
                 step_x: sp.Expr = sp.S.Zero) -> Surface:
    """Build a :class:`Surface` from a component's arguments, checking them.

    ``where`` names the component for messages (e.g. ``"HuntCrossley 'floor'"``).

    Raises
    ------
    ParameterValueError : unknown ``kind``; a slope given to a ``"plane"``; a step given to a
        ``"plane"`` or ``"slope"``. (A step height < 0 is refused by the contact's argument rule,
        see :func:`surface_arguments`.)
    """
    if kind not in SURFACES:
        raise ParameterValueError(
            f"{where} argument 'surface': unknown surface {kind!r}; surfaces: "
            + "; ".join(f"{k!r} ({v})" for k, v in SURFACES.items()))
    given = {"slope": slope, "step_height": step_height, "step_x": step_x}
    allowed = {"plane": set(), "slope": {"slope"}, "step": {"slope", "step_height", "step_x"}}[kind]
    extra = [name for name, value in given.items() if name not in allowed and value != 0]
    if extra:
        raise ParameterValueError(
            f"{where}: surface {kind!r} takes no {', '.join(extra)}; use surface = "
            f"{'step' if 'step_height' in extra or 'step_x' in extra else 'slope'!r}")
    return Surface(kind, as_expr(slope), as_expr(height), as_expr(step_height), as_expr(step_x))


def surface_arguments() -> Mapping[str, Any]:
    """The component arguments that describe a surface (shared by the contact laws)."""
    from ..modeling.component import Arg

    return {
        "surface": Arg("surface kind: " + ", ".join(SURFACES), symbolic=False, default="plane"),
        "slope": Arg("slope angle γ, surface descending towards +x", "rad", default=0),
        "height": Arg("surface elevation at x = 0", "m", default=0),
        "step_height": Arg("vertical drop h of the step (surface 'step')", "m", default=0,
                           rule=">="),
        "step_x": Arg("x position of the step's edge (surface 'step')", "m", default=0),
    }



__all__ = ["SURFACES", "Surface", "make_surface", "surface_arguments"]

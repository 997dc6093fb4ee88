"""Readable names, units and meanings of a walker's quantities, for tables, plots and the CLI.

A walker's numbers carry machine names (``walker.v.hip_joint.x``, ``energy_dissipated_per_step``);
a reader wants "hip velocity along the slope, m/s". :func:`describe` gives a :class:`Quantity`
(label, unit, meaning) for every name an analysis reports:

* the gait metrics (:data:`METRICS`) and the thesis's section coordinates (:data:`SECTION`:
  θ, θ̇, φ, φ̇, the hip's velocity, ...), from fixed tables;
* the model's own coordinates ``<multibody>.q.<joint>[.<axis>]`` and rates ``<multibody>.v...``,
  from the joint's type (revolute: rad and rad/s; prismatic, translational: m and m/s);
* the model's parameters, from the model file (``unit`` and ``doc`` of ``[parameters]``).

Units are SI unless the model file says ``units = "nondimensional"`` in its ``[model]`` table
(:func:`is_nondimensional`; the simplest walker, g = l = M = 1): then :func:`shown_unit` labels every
non-angular unit "nondim." rather than pretending its numbers are metres and seconds.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from ..core.hybrid import Foot, WalkerSpec
    from ..core.protocol import Walker

__all__ = ["METRICS", "SECTION", "Described", "Quantity", "describe", "foot_radius", "is_nondimensional",
           "parameter", "pretty_unit", "shown_unit", "unit_of"]


@dataclass(frozen=True)
class Quantity:
    """A quantity as a reader sees it: ``label`` (short, readable: "θ stance-leg angle"), ``unit``
    (SI, as in the model files: ``"m/s^2"``, ``"1"`` for a ratio, ``""`` when unknown) and
    ``doc`` (one phrase of meaning)."""

    label: str
    unit: str
    doc: str


#: the gait metrics (:mod:`walker_library.metrics`)
METRICS: dict[str, Quantity] = {
    "step_period": Quantity("step period", "s", "time from one heel strike to the next"),
    "step_length": Quantity("step length", "m",
                            "distance along the slope between successive stance feet"),
    "speed": Quantity("speed", "m/s", "mean walking speed along the slope"),
    "energy_dissipated_per_step": Quantity(
        "energy dissipated per step", "J",
        "energy the ledger books as dissipated in one step (impacts, contact damping, friction)"),
    "potential_released_per_step": Quantity(
        "potential energy released per step", "J",
        "drop of the potential energy over one step (equals the dissipation on a periodic gait)"),
    "max_theta": Quantity("max |θ|", "rad", "largest stance-leg angle over a step"),
    "max_phi": Quantity("max |φ|", "rad", "largest angle between the legs over a step"),
    "cost_of_transport": Quantity(
        "cost of transport", "1",
        "energy dissipated per weight and distance; sin γ for a passive walker on a slope γ"),
    "energy_residual_per_step": Quantity(
        "ledger residual per step", "J",
        "largest |H − H(0) + E_diss − E_in| over a step: the integration error of the energy"),
}

#: the thesis's section coordinates and the other derived quantities of a section state
SECTION: dict[str, Quantity] = {
    "theta": Quantity("θ stance-leg angle", "rad",
                      "stance leg to the slope normal; > 0 with the stance foot ahead of the hip"),
    "theta_dot": Quantity("θ̇ stance-leg rate", "rad/s",
                          "rate of θ; < 0 while walking down the slope"),
    "phi": Quantity("φ angle between the legs", "rad", "swing leg to stance leg; φ = 2θ at heel "
                    "strike"),
    "phi_dot": Quantity("φ̇ rate between the legs", "rad/s", "rate of φ"),
    "hip_vx": Quantity("hip velocity along the slope", "m/s", "the hip's velocity, x component "
                       "(down the slope)"),
    "hip_vz": Quantity("hip velocity normal to the slope", "m/s",
                       "the hip's velocity, z component (along the slope normal)"),
    "hip_speed": Quantity("hip speed", "m/s", "magnitude of the hip's velocity"),
    "hub_speed": Quantity("hub speed", "m/s", "magnitude of the hub's velocity"),
    "ankle_lead": Quantity("leading ankle", "", "coordinate of the leading foot's ankle joint"),
    "ankle_trail": Quantity("trailing ankle", "", "coordinate of the trailing foot's ankle joint"),
    "ankle_lead_dot": Quantity("leading ankle rate", "", "rate of the leading ankle joint"),
    "ankle_trail_dot": Quantity("trailing ankle rate", "", "rate of the trailing ankle joint"),
    "trail_contact_force": Quantity("trailing foot's contact force", "N",
                                    "normal contact force on the trailing foot"),
}

_JOINT_UNITS = {"revolute": ("rad", "rad/s", "angle"), "prismatic": ("m", "m/s", "extension"),
                "translational": ("m", "m/s", "position")}
_SUPERSCRIPT = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")


class Described(Protocol):
    """What the labels read of a walker: its file's description and the name of its multibody
    component (``""``: none). A :class:`~walker_library.core.HybridWalker` is one; so is a
    stand-in made from the file alone (no compilation). Where a function takes
    ``Described | None``, None gives the file-independent labels."""

    @property
    def spec(self) -> WalkerSpec:
        """The walker file's description (its model, feet, section, units)."""

    @property
    def multibody(self) -> str:
        """The name of the model's multibody component (``""``: none)."""

    @property
    def joint_types(self) -> Mapping[str, str]:
        """The multibody's joints' types by joint name (``"revolute"``, ``"prismatic"``, …;
        empty without a multibody)."""


def is_nondimensional(walker: Described | None) -> bool:
    """True when the walker's model file declares ``units = "nondimensional"`` in ``[model]``."""
    return walker is not None and walker.spec.units == "nondimensional"


def pretty_unit(unit: str) -> str:
    """A model file's unit as printed: ``"N*s/m^2"`` -> ``"N·s/m²"``; ``""`` -> ``""``."""
    out = unit.replace("*", "·")
    while "^" in out:
        head, _, tail = out.partition("^")
        digits = ""
        while tail and (tail[0].isdigit() or (tail[0] == "-" and not digits)):
            digits, tail = digits + tail[0], tail[1:]
        out = head + digits.translate(_SUPERSCRIPT) + tail
    return out


def shown_unit(unit: str, nondimensional: bool = False) -> str:
    """The unit as shown to a reader: :func:`pretty_unit`, or in a nondimensional model
    ``"nondim."`` for everything but angles (rad, rad/s stay: angles have no scale)."""
    if nondimensional and unit not in ("rad", "1", ""):
        return "nondim."
    return pretty_unit(unit)


def _joint(walker: Described | None, name: str) -> tuple[str, str, str] | None:
    """(kind "q"/"v", joint, axis) of a multibody coordinate or rate name, else None."""
    mb = walker.multibody if walker is not None else ""
    for kind in ("q", "v"):
        prefix = f"{mb}.{kind}."
        if mb and name.startswith(prefix):
            joint, _, axis = name[len(prefix):].partition(".")
            return kind, joint, axis
    return None


def _coordinate(walker: Described | None, name: str) -> Quantity | None:
    parsed = _joint(walker, name)
    if parsed is None or walker is None:
        return None
    kind, joint, axis = parsed
    jtype = walker.joint_types.get(joint, "")
    q_unit, v_unit, what = _JOINT_UNITS.get(jtype, ("", "", "coordinate"))
    along = {"x": " along the slope", "z": " normal to the slope"}.get(axis, f" {axis}" if axis else "")
    if kind == "q":
        return Quantity(f"{joint} {what}{along}", q_unit, f"{jtype or 'joint'} {joint}")
    rate = "velocity" if jtype == "translational" else "rate"
    return Quantity(f"{joint} {rate}{along}", v_unit, f"{jtype or 'joint'} {joint}")


def unit_of(walker: Described | None, name: str) -> str:
    """The SI unit of a section coordinate or derived quantity (``""`` when unknown): a
    multibody coordinate's from its joint, a thesis coordinate's from the first model coordinate
    of its defining expression (``ankle_lead = "walker.q.ankle1"``: the ankle joint's)."""
    coordinate = _coordinate(walker, name)
    if coordinate is not None:
        return coordinate.unit
    known = SECTION.get(name) or METRICS.get(name)
    if known is not None and known.unit:
        return known.unit
    from porthamiltonian.errors import ExpressionError
    from porthamiltonian.modeling.expressions import parse_text
    for thesis_name, text in walker.spec.section.thesis if walker is not None else ():
        if thesis_name != name:
            continue
        try:
            used = sorted(parse_text(str(text), f"thesis coordinate {name!r}").names)
        except ExpressionError:
            return ""
        for other in used:
            found = _coordinate(walker, other)
            if found is not None and found.unit:
                return found.unit
    return ""


def describe(walker: Described | None, name: str) -> Quantity:
    """The :class:`Quantity` of a name an analysis reports for ``walker`` (module docstring);
    an unknown name gets itself as label and an empty unit."""
    if name in METRICS:
        return METRICS[name]
    coordinate = _coordinate(walker, name)
    if coordinate is not None:
        return coordinate
    known = SECTION.get(name)
    if known is not None:
        return Quantity(known.label, known.unit or unit_of(walker, name), known.doc)
    return Quantity(name.replace("_", " "), unit_of(walker, name), "")


def parameter(walker: Walker, name: str) -> Quantity:
    """A parameter's :class:`Quantity` from the model file (label: its name)."""
    spec = walker.specs.get(name)
    if spec is None:
        return Quantity(name, "", "")
    return Quantity(name, spec.unit, spec.doc)


def foot_radius(walker: Described, foot: Foot, values: dict[str, float]) -> float:
    """The radius (m) of an arc foot: how far below its point the foot's contact reads the
    surface (a contact ``z = "<point>.z - R"`` -> R; a contact with a ``radius``, the circle or
    sphere of the 3D contacts about the frame its ``z`` reads, which the walker files put at the
    foot's point -> that radius), 0 for a point foot (no contact component, or a contact whose
    height is not a point's height minus a constant)."""
    from porthamiltonian.errors import ExpressionError, ModelError
    from porthamiltonian.modeling.expressions import parse_text
    if not foot.contact:
        return 0.0
    try:
        contact = walker.spec.model.component(foot.contact)
        from porthamiltonian.modeling.component import Component  # (on use: sympy)

        if not isinstance(contact, Component):  # a sub-model is no contact
            return 0.0
        args = contact.args
        if "radius" in args:
            radius = parse_text(str(args["radius"]), f"contact {foot.contact!r} radius")
            value = radius.evaluate(values)
            return value if math.isfinite(value) and value > 0 else 0.0
        z_text = args.get("z")
        expr = parse_text(str(z_text), f"contact {foot.contact!r} z")
        height = f"{foot.point}.z"
        low = expr.evaluate({**values, height: 0.0})
        high = expr.evaluate({**values, height: 1.0})
    except (ExpressionError, ModelError, ArithmeticError, ValueError, AttributeError, KeyError):
        return 0.0
    if not (math.isfinite(low) and abs(high - low - 1.0) < 1e-12):
        return 0.0
    return max(0.0, -low)

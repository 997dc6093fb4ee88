"""Power ports, energy domains and the one sign convention of the library.

Sign convention (stated once, used everywhere)
----------------------------------------------
A bond joins two ports and carries an effort vector ``e`` and a flow vector ``f`` of the same
dimension. Its power ``P = e · f`` flows from the bond's *tail* to its *head* (the half-arrow of
a bond graph). ``Model.connect(a, b)`` draws the bond from port ``a`` (tail) to port ``b`` (head).

Each port has an orientation seen from its own component:

``"in"``
    power ``e · f`` is positive *into* the component (storages, dissipators): the port may only be
    the head of a bond.
``"out"``
    power ``e · f`` is positive *out of* the component (sources, the far side of a transformer,
    body points that act on the elements attached to them): the port may only be the tail.
``None``
    free: the bond decides (junction ports). The port then behaves as ``"in"`` when it is the head
    of its bond and as ``"out"`` when it is the tail.

Domains give names and units to effort and flow. Two ports connect only when their domains and
dimensions are equal.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from ..errors import DimensionMismatchError, DomainMismatchError, ModelError, OrientationError
from .expressions import check_name

Orientation = Literal["in", "out"] | None


@dataclass(frozen=True)
class Domain:
    """An energy domain: what effort and flow mean and their SI units."""

    name: str
    effort: str
    flow: str
    effort_unit: str
    flow_unit: str

    @property
    def displacement_unit(self) -> str:
        """Unit of the time integral of the flow (a C storage's state: m, rad, A*s, ...)."""
        return _integral(self.flow_unit)

    @property
    def momentum_unit(self) -> str:
        """Unit of the time integral of the effort (an I storage's state: N*s, N*m*s, ...)."""
        return _integral(self.effort_unit)


def _integral(unit: str) -> str:
    """The unit of a quantity's time integral: ``"m/s"`` -> ``"m"``, ``"N"`` -> ``"N*s"``; ""
    when the unit is not one unit (the screw domain's ``"N*m | N"``)."""
    if not unit or "|" in unit:
        return ""
    return unit[:-2] if unit.endswith("/s") else f"{unit}*s"


DOMAINS: dict[str, Domain] = {
    d.name: d
    for d in (
        Domain("translation", "force", "velocity", "N", "m/s"),
        Domain("rotation", "torque", "angular velocity", "N*m", "rad/s"),
        Domain("electric", "voltage", "current", "V", "A"),
        Domain("hydraulic", "pressure", "volume flow", "Pa", "m^3/s"),
        Domain("magnetic", "magnetomotive force", "flux rate", "A", "V"),
        Domain("thermal", "temperature", "entropy flow", "K", "W/K"),
        Domain("screw", "wrench (torque, force)", "twist (angular, linear velocity)",
               "N*m | N", "rad/s | m/s"),
        Domain("stiffness", "z^2/2 (dH/dK of a spring's energy K z^2/2)",
               "stiffness rate dK/dt", "m^2", "N/(m*s)"),
    )
}


def domain(name: str) -> Domain:
    """Return the :class:`Domain` called ``name`` or raise naming the known ones."""
    try:
        return DOMAINS[name]
    except KeyError:
        raise ModelError(
            f"unknown domain {name!r}; known domains: {', '.join(sorted(DOMAINS))}"
        ) from None


@dataclass(frozen=True)
class Port:
    """A power port declared by a component.

    Parameters
    ----------
    name : port name, unique within its component.
    domain : energy domain name (see :data:`DOMAINS`).
    dim : number of effort (and flow) components.
    orientation : ``"in"``, ``"out"`` or ``None`` (free); see the module docstring.
    frame : name of the frame in which vector efforts/flows are expressed, if any.
    description : one line for ``show`` and error messages.
    optional : the port may stay unconnected; it then carries zero effort (no force, no power).
    """

    name: str
    domain: str = "translation"
    dim: int = 1
    orientation: Orientation = "in"
    frame: str | None = None
    description: str = ""
    optional: bool = False

    def __post_init__(self) -> None:
        check_name(self.name, "port name")
        domain(self.domain)
        if self.dim < 1:
            raise ModelError(f"port {self.name!r}: dimension must be >= 1, got {self.dim}")
        if self.orientation not in ("in", "out", None):
            raise ModelError(
                f"port {self.name!r}: orientation must be 'in', 'out' or None, got {self.orientation!r}"
            )


def check_bond(tail_name: str, tail: Port, head_name: str, head: Port) -> None:
    """Check that a bond from ``tail`` to ``head`` is admissible; raise a :class:`ConnectError`.

    ``tail_name``/``head_name`` are the full ``component.port`` names used in messages.
    """
    if tail.domain != head.domain:
        raise DomainMismatchError(
            f"cannot connect {tail_name} ({tail.domain}) to {head_name} ({head.domain}): "
            "domains differ; put a transformer or gyrator (TF/GY) between them"
        )
    if tail.dim != head.dim:
        raise DimensionMismatchError(
            f"cannot connect {tail_name} (dimension {tail.dim}) to {head_name} "
            f"(dimension {head.dim}): dimensions differ"
        )
    if tail.orientation == "in" or head.orientation == "out":
        raise OrientationError(_orientation_message(tail_name, tail, head_name, head))


def _orientation_message(tail_name: str, tail: Port, head_name: str, head: Port) -> str:
    """Why a bond from ``tail`` to ``head`` contradicts a port's orientation, and the fix: the
    reversed bond when it is admissible, else a junction between the two (two ports that both
    take power in, or both give it out, cannot share a bond in either direction)."""
    if tail.orientation == "in":
        problem = (f"cannot draw a bond out of {tail_name}: its power is defined positive into "
                   "its component")
    else:
        problem = (f"cannot draw a bond into {head_name}: its power is defined positive out of "
                   "its component")
    if tail.orientation != "out" and head.orientation != "in":
        return f"{problem}; use connect({head_name!r}, {tail_name!r})"
    if tail.orientation == "in":
        other, ends = head_name, f"connect('j', {tail_name!r}) and connect('j', {head_name!r})"
        both = "into"
    else:
        other, ends = tail_name, f"connect({tail_name!r}, 'j') and connect({head_name!r}, 'j')"
        both = "out of"
    return (f"{problem}, and so is {other}'s: both ports take power {both} their components, so "
            "no bond joins them in either direction; join them through a junction: add one, "
            "model.add('j', OneJunction()) for a common flow (a mass and a spring moving "
            f"together) or ZeroJunction() for a common effort, then {ends}")

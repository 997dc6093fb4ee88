"""A walker's hybrid behaviour as data: the ``[walker]`` table of a model file, and its dataclasses.

A walker is a :class:`~porthamiltonian.Model` (its components, bonds and events, as for any
model) plus a :class:`WalkerSpec`: which feet it has, which parameters are discrete *modes*, the
*rules* that say what each model event does (touchdown, lift-off, the scuffing rule, mid-stance,
heel strike, a fall), the relabelling of coordinates at heel strike, the Poincaré section, the
thesis's angles, an initial guess, parameter ranges, the step-down terrain and the integrator
settings. Expressions are text, parsed by :func:`porthamiltonian.modeling.expressions.parse` over
the model's own names (parameters, states, port variables and outputs such as
``walker.foot1.x`` or ``floor1.z``); nothing is evaluated as Python. ``docs/walkers.md`` is the
reference of the table and of every shipped walker.

The dataclasses hold the table as written (text and numbers; :meth:`WalkerSpec.to_table` writes
it back, and reading that gives the same spec). :func:`~.reading.walker_spec` reads a table
against the model's frozen description and attaches the expressions parsed once
(:class:`Parsed`: each an :class:`Expr` with its text, its sympy form, and where it is for
messages); :func:`~.plan.walker_plan` checks them against the names the compiled model will
have and turns them into the walker's plan.
"""
from __future__ import annotations

import math
import re
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from numbers import Integral
from typing import TYPE_CHECKING, Any, Literal, NamedTuple

from porthamiltonian.errors import ModelError, OptionError
from porthamiltonian.modeling.expressions import parse

if TYPE_CHECKING:
    import sympy as sp

    from porthamiltonian.modeling.model import Model, ModelDescription

__all__ = ["Comparison", "Completion", "Expr", "Foot", "Integration", "Interval", "Parsed",
           "Rule", "Section", "Terrain", "WalkerSpec", "parse_condition", "parse_equation",
           "parse_interval"]

Value = str | float
#: where a jump of H at an event is booked (:class:`porthamiltonian.Reset`)
Booking = Literal["dissipated", "supplied"]

#: the comparison operators of a rule's conditions
COMPARISONS = ("<=", ">=", "==", "!=", "<", ">")
_COMPARISON = re.compile(r"(<=|>=|==|!=|<|>)")
_EQUALS = re.compile(r"(?<![<>=!])=(?!=)")
_INTERVAL = re.compile(r"^\s*([\[(])\s*([^,]+?)\s*,\s*([^,]+?)\s*([\])])\s*(integer)?\s*$")


# --- the description -----------------------------------------------------------------------------
def _pairs(value: Any) -> tuple:
    """A mapping (or pairs) as a tuple of (key, value) pairs, in order."""
    if isinstance(value, Mapping):
        return tuple(value.items())
    return tuple((k, v) for k, v in value)


@dataclass(frozen=True)
class Foot:
    """A foot: the multibody ``point`` that touches the surface (outputs ``<point>.x``,
    ``<point>.z``: position in the slope frame, m) and, for a compliant walker, its ``contact``
    component (a normal contact whose penetration ``<contact>.z`` the touchdown and lift-off
    events watch)."""

    name: str
    point: str
    contact: str | None = None


@dataclass(frozen=True)
class Rule:
    """What a model event does (a transition of the mode machine).

    on : the model event (its guard and direction are in the model's ``[[events]]``), or
        ``"start"``: applied once at the start of every walk.
    when : conditions ``"lhs OP rhs"`` (OP one of ``< <= > >= == !=``) on the model's outputs,
        states and parameters, all evaluated just before the event; the rule applies when all
        hold. Of the rules on one event the first that applies fires; none: nothing happens.
    set : new values of mode parameters (numbers or expressions, evaluated before the event).
    foot : the foot that strikes (heel-strike rules): its point gives the step length.
    impact : a plastic impact at this multibody point (rigid walkers): the point stops, the
        multibody's pinned root joint is released, and :attr:`WalkerSpec.relabel` re-pins the
        model at the point (the swing leg becomes the stance leg). Constraints of the multibody
        that are active (a locked knee) stay satisfied through it: their rows join the impact.
    engage : a plastic impact onto the multibody's constraint (or loop) of this name,
        ``"<multibody>.<constraint>"`` (a knee strike onto its lock): the generic impact map with
        the constraint's rows and those already active; the constraint's switch (its ``active``
        mode parameter) is set to 1. No relabelling.
    heel_strike : the rule ends a step; the state just after it lies on the Poincaré section.
    fall : the rule ends the walk as a fall (reason: the event's name).
    energy : where a jump of H at the event is booked (``"dissipated"`` or ``"supplied"``).
    """

    on: str
    when: tuple[str, ...] = ()
    set: tuple[tuple[str, Value], ...] = ()
    foot: str | None = None
    impact: str | None = None
    heel_strike: bool = False
    fall: bool = False
    energy: Booking = "dissipated"
    engage: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "when", tuple(self.when))
        object.__setattr__(self, "set", _pairs(self.set))


@dataclass(frozen=True)
class Completion:
    """How one state coordinate of a section state is completed from the section coordinates:
    ``value`` (an expression of positions and parameters) or ``such_that`` (an equation
    ``"lhs = rhs"`` solved for the coordinate; one side may be a section coordinate that is not a
    state, e.g. a contact force)."""

    coordinate: str
    value: Value | None = None
    such_that: str | None = None


@dataclass(frozen=True)
class Section:
    """The Poincaré section: the state just after every heel strike (the rules with
    ``heel_strike``), in the labelling where ``stance`` is the foot that has just struck.

    coordinates : its independent coordinates, named by state: a multibody coordinate
        (``walker.q.leg1``), a joint rate (``walker.v.leg1``, m/s or rad/s), another state, or a
        quantity that a ``such_that`` completion defines.
    complete : the other state coordinates of a state on the section, in order (the multibody
        momenta follow from the rates, p = M(q) v).
    thesis : the thesis's section coordinates, linear in ``coordinates`` (an invertible map).
    labelling : a condition that holds in the section's labelling (e.g. ``"lead == 1"``); a state
        where it does not hold is relabelled (:attr:`WalkerSpec.relabel`) before it is read.
    basin : ``"fixed_point"`` (basin grid points keep the fixed point's other coordinates) or
        ``"guess"`` (they are made like the initial guess with theta0, theta_dot0 the grid point
        and phi_dot0 the gait's).
    """

    coordinates: tuple[str, ...]
    complete: tuple[Completion, ...] = ()
    thesis: tuple[tuple[str, str], ...] = ()
    stance: str = ""
    labelling: str | None = None
    basin: str = "fixed_point"

    def __post_init__(self) -> None:
        object.__setattr__(self, "coordinates", tuple(self.coordinates))
        object.__setattr__(self, "complete", tuple(self.complete))
        object.__setattr__(self, "thesis", _pairs(self.thesis))


@dataclass(frozen=True)
class Integration:
    """Integrator settings of a walk: back end (``"auto"``: the framework's choice), method, rtol,
    atol, max_step (s), max_step_time (s: no heel strike within it is a fall), the Newton
    tolerance of the gait search (section units), and max_steps_per_stride, the integrator's
    steps each stride may take (more end the stride as a fall that says so, e.g. a stiffness so
    large that a stride would take hours and gigabytes: the shipped walkers take 170-5 200
    steps per stride; HybridWalker.walk)."""

    backend: str = "auto"
    method: str = "Rodas4"
    rtol: float = 1e-8
    atol: float = 1e-10
    max_step: float = 0.01
    max_step_time: float = 3.0
    gait_tolerance: float = 1e-10
    max_steps_per_stride: int = 100_000

    def walk_time(self, n_steps: Any, name: str = "n_steps") -> float:
        """The time a run of ``n_steps`` strides may take, n × max_step_time (s), for a whole
        number n >= 1 whose time is a float64; else an OptionError naming ``name`` (0 steps
        reached the integrator as t_end = 0, 10**400 raised OverflowError)."""
        most = sys.float_info.max / self.max_step_time
        if (isinstance(n_steps, bool) or not isinstance(n_steps, Integral)
                or not 1 <= int(n_steps) <= most):
            raise OptionError(f"{name} must be a whole number from 1 to {most:.3g} (the time, "
                              f"{name} × max_step_time = {self.max_step_time:g} s, a float64), "
                              f"got {n_steps!r}")
        return int(n_steps) * self.max_step_time


@dataclass(frozen=True)
class Terrain:
    """The step-down terrain: ``drop``, the parameter that ``walk(..., ground_drop=h)`` sets to h
    (m) for the rules to use, and ``surfaces``, the parameters that hold surface heights (m,
    along the slope normal)."""

    drop: str
    surfaces: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "surfaces", tuple(self.surfaces))


@dataclass(frozen=True)
class WalkerSpec:
    """A walker: its model and its hybrid description (see the module docstring and
    docs/walkers.md). Mappings are stored as tuples of pairs, in order; dicts are accepted.

    angles : the thesis's θ (stance-leg angle to the slope normal) and φ (angle between the legs)
        of any state, linear in the multibody coordinates; their rates use the same coefficients.
    relabel : new value of each exchanged coordinate (and mode parameter) as a linear expression
        of the old ones: the swing leg becomes the stance leg (a signed permutation for a
        symmetric walker). Coordinates not named keep their value.
    guess : a rough section state to start the gait search from (expressions in parameters and
        in the helper quantities ``guess_where``, defined in order from parameters and the
        helpers above them).
    ranges : valid values of parameters, ``"(low, high)"`` with ``[``/``]`` for closed ends and
        an optional ``integer``.
    mass, leg_length : expressions in parameters (kg, m): the total mass (the weight of the
        cost of transport) and the leg length (the scale of the step-down grid).
    hip : the multibody point whose position and speed are reported as the hip's.
    source, description : the walker file (for messages) and its ``[model] description``.
    units : the file's ``[model] units``: ``"nondimensional"`` when its numbers are ratios
        (e.g. g = l = 1), else ``""`` (SI).
    frozen : the model's frozen description the table was read against; parsed : the table's
        expressions parsed (:class:`Parsed`). Both are set by the reader
        (:func:`~.reading.walker_spec`); a spec built in Python has neither until it is read.
    """

    model: Model = field(compare=False)
    feet: tuple[Foot, ...]
    modes: tuple[tuple[str, Value], ...]
    rules: tuple[Rule, ...]
    section: Section
    angles: tuple[tuple[str, str], ...]
    terrain: Terrain
    relabel: tuple[tuple[str, Value], ...] = ()
    guess: tuple[tuple[str, Value], ...] = ()
    guess_where: tuple[tuple[str, str], ...] = ()
    ranges: tuple[tuple[str, str], ...] = ()
    integration: Integration = Integration()
    mass: str = "0"
    leg_length: str = "1"
    hip: str = ""
    source: str = field(default="<python>", compare=False)
    description: str = field(default="", compare=False)
    units: str = field(default="", compare=False)
    frozen: ModelDescription | None = field(default=None, compare=False, repr=False)
    parsed: Parsed | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        for name in ("modes", "angles", "relabel", "guess", "guess_where", "ranges"):
            object.__setattr__(self, name, _pairs(getattr(self, name)))
        object.__setattr__(self, "feet", tuple(self.feet))
        object.__setattr__(self, "rules", tuple(self.rules))

    @property
    def name(self) -> str:
        """The walker's name: its model's."""
        return self.model.name

    @property
    def mode_names(self) -> tuple[str, ...]:
        """Parameters the walker sets itself (never the user): the modes and the drop."""
        return (*(k for k, _ in self.modes), self.terrain.drop)

    def foot(self, name: str) -> Foot:
        """The foot called ``name``."""
        return next(f for f in self.feet if f.name == name)

    def to_table(self) -> dict[str, Any]:
        """The ``[walker]`` table of this description (what :func:`walker_spec` reads)."""
        out: dict[str, Any] = {"mass": self.mass, "leg_length": self.leg_length}
        if self.hip:
            out["hip"] = self.hip
        out["integration"] = {f.name: getattr(self.integration, f.name)
                              for f in fields(Integration)}
        out["feet"] = {f.name: {"point": f.point, **({"contact": f.contact} if f.contact else {})}
                       for f in self.feet}
        out["modes"] = dict(self.modes)
        out["terrain"] = {"drop": self.terrain.drop, "surfaces": list(self.terrain.surfaces)}
        rules = []
        for r in self.rules:
            d: dict[str, Any] = {"on": r.on}
            if r.when:
                d["if"] = list(r.when)
            if r.set:
                d["set"] = dict(r.set)
            for key in ("foot", "impact", "engage"):
                if getattr(r, key):
                    d[key] = getattr(r, key)
            for key in ("heel_strike", "fall"):
                if getattr(r, key):
                    d[key] = True
            if r.energy != "dissipated":
                d["energy"] = r.energy
            rules.append(d)
        out["rules"] = rules
        if self.relabel:
            out["relabel"] = dict(self.relabel)
        s = self.section
        sec: dict[str, Any] = {"stance": s.stance, "coordinates": list(s.coordinates)}
        if s.labelling:
            sec["labelling"] = s.labelling
        if s.basin != "fixed_point":
            sec["basin"] = s.basin
        sec["thesis"] = dict(s.thesis)
        # every entry a table, so that a TOML writer keeps their order (it puts plain keys first)
        sec["complete"] = {c.coordinate: ({"value": c.value} if c.such_that is None
                                          else {"such_that": c.such_that}) for c in s.complete}
        out["section"] = sec
        out["angles"] = dict(self.angles)
        if self.guess:
            out["guess"] = dict(self.guess)
            if self.guess_where:
                out["guess"]["where"] = dict(self.guess_where)
        if self.ranges:
            out["ranges"] = dict(self.ranges)
        return out


# --- the table's expressions, parsed ----------------------------------------------------------------
@dataclass(frozen=True)
class Expr:
    """One expression of a walker table, parsed once.

    text : as written (a number, or text in the expression language). value : its sympy form
    (a parameter is the symbol of its name, a dotted name — a state, port variable or output,
    ``walker.foot1.x`` — the symbol of that name). where : what it is, for messages
    (``"[[walker.rules]] #3 set 'c1'"``). path : its key path in ``[walker]`` (for the line).
    """

    text: Value
    value: sp.Expr
    where: str
    path: tuple[str | int, ...]

    @property
    def constant(self) -> float | None:
        """The number, when the table gives a number (not an expression)."""
        if isinstance(self.text, (int, float)) and not isinstance(self.text, bool):
            return float(self.text)
        return None

    @property
    def dotted(self) -> set[str]:
        """The dotted names it reads (states, port variables, outputs)."""
        return {str(s) for s in self.value.free_symbols if "." in str(s)}


@dataclass(frozen=True)
class Comparison:
    """A condition ``lhs OP rhs`` (a rule's ``if``, the section's ``labelling``), both sides
    parsed; it holds when ``lhs - rhs`` compares with 0 by ``op``."""

    text: str
    lhs: Expr
    op: str
    rhs: Expr

    @property
    def difference(self) -> str:
        """``"(lhs) - (rhs)"``, the expression the walker evaluates."""
        return f"({self.lhs.text}) - ({self.rhs.text})"


class Interval(NamedTuple):
    """A parameter range: ``low < value < high`` (``<=`` at a closed end), a whole number if
    ``integer``."""

    low: float
    high: float
    low_closed: bool
    high_closed: bool
    integer: bool


@dataclass(frozen=True)
class Parsed:
    """The expressions of a :class:`WalkerSpec`, parsed once by the reader.

    evaluated : every expression a walk evaluates (the modes' start values, the rules' conditions
        and values, the completions, the labelling, the mass and leg length), in the table's
        order. conditions : per rule, its conditions; labelling : the section's (or None).
    guess : the initial guess of each guessed section coordinate, the helpers substituted (an
        expression in parameters). thesis, angles, relabel : as in the spec, parsed (linear maps,
        checked against the model's coordinates by :func:`~.plan.walker_plan`). ranges : the
        parameters' ranges.
    """

    evaluated: tuple[Expr, ...]
    conditions: tuple[tuple[Comparison, ...], ...]
    labelling: Comparison | None
    guess: tuple[tuple[str, Expr], ...]
    thesis: tuple[tuple[str, Expr], ...]
    angles: tuple[tuple[str, Expr], ...]
    relabel: tuple[tuple[str, Expr], ...]
    ranges: tuple[tuple[str, Interval], ...]


# --- small grammars -------------------------------------------------------------------------------
def parse_condition(text: str) -> tuple[str, str, str]:
    """``"lhs OP rhs"`` -> (lhs, OP, rhs); exactly one comparison operator."""
    if not isinstance(text, str):
        raise ModelError(f"a condition is a string \"lhs OP rhs\", got {text!r}")
    found = _COMPARISON.findall(text)
    if len(found) != 1:
        raise ModelError(f"condition {text!r} must compare two expressions with exactly one of "
                         f"{' '.join(COMPARISONS)} (e.g. \"walker.foot1.x > walker.foot2.x\")")
    lhs, rhs = _COMPARISON.split(text)[::2]
    if not lhs.strip() or not rhs.strip():
        raise ModelError(f"condition {text!r} needs an expression on both sides of {found[0]}")
    return lhs.strip(), found[0], rhs.strip()


def parse_equation(text: str) -> tuple[str, str]:
    """``"lhs = rhs"`` -> (lhs, rhs)."""
    parts = _EQUALS.split(text) if isinstance(text, str) else []
    if len(parts) != 2 or _COMPARISON.search(text) or not all(p.strip() for p in parts):
        raise ModelError(f"such_that {text!r} must be one equation \"lhs = rhs\" (e.g. "
                         "\"floor1.z = 1e-9\")")
    return parts[0].strip(), parts[1].strip()


def parse_interval(text: str) -> Interval:
    """``"(low, high)"`` (``[``/``]`` closed, bounds numbers, ``inf``, or constants such as
    ``pi/4``; an optional ``integer``) -> its :class:`Interval`."""
    m = _INTERVAL.match(text) if isinstance(text, str) else None
    if not m:
        raise ModelError(f"range {text!r} must read \"(low, high)\" with [ or ] for a closed end "
                         "and an optional 'integer', e.g. \"(0, inf)\", \"[3, 1000) integer\"")
    bounds = []
    for part in (m.group(2), m.group(3)):
        word = part.strip().lower()
        if word in ("inf", "+inf", "-inf"):
            bounds.append(-math.inf if word.startswith("-") else math.inf)
            continue
        value = parse(part, {}, f"range bound {part!r}")
        if not value.is_number or not value.is_real:
            raise ModelError(f"range bound {part!r} must be a number")
        bounds.append(float(value))
    if not bounds[0] < bounds[1]:
        raise ModelError(f"range {text!r}: low must be below high")
    return Interval(bounds[0], bounds[1], m.group(1) == "[", m.group(4) == "]", bool(m.group(5)))

"""A walker's hybrid behaviour as data: the ``[walker]`` table of a model file, and its dataclasses.

A walker is a :class:`~porthamiltonian.Model` (its components, bonds and events, as for any
model) plus a :class:`WalkerSpec`: which feet it has, which parameters are discrete *modes*, the
*rules* that say what each model event does (touchdown, lift-off, the scuffing rule, mid-stance,
heel strike, a fall), the relabelling of coordinates at heel strike, the Poincaré section, the
thesis's angles, an initial guess, parameter ranges, the step-down terrain and the integrator
settings. Expressions are text, parsed by :func:`porthamiltonian.expressions.parse` over the
model's own names (parameters, states, port variables and outputs such as ``walker.foot1.x`` or
``floor1.z``); nothing is evaluated as Python. ``docs/walkers.md`` is the reference of the table
and of every shipped walker.

:func:`walker_spec` reads a ``[walker]`` table (a mapping as TOML gives it) into a
:class:`WalkerSpec`; :meth:`WalkerSpec.to_table` writes it back (load -> save -> load gives the
same spec). :func:`walker_library.names.check_names` checks every name against the model's
compiled-to-be names, before anything is compiled. Every problem of a table is collected and
raised as one :class:`~porthamiltonian.errors.ModelFileError` that names the file, the line (when
the TOML text is known) and the part (``[[walker.rules]] #3 condition ...``).

The numeric side — the mode machine, the section's lift and projection, the stride recorder — is
:mod:`walker_library.machine` and :mod:`walker_library.core`.
"""
from __future__ import annotations

import difflib
import math
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, fields
from typing import Any

import sympy as sp

from porthamiltonian import Model
from porthamiltonian.errors import ModelError, ModelFileError
from porthamiltonian.interfaces.io import locate
from porthamiltonian.modeling.expressions import parse

__all__ = ["Completion", "Foot", "Integration", "Rule", "Section", "Terrain", "WalkerSpec",
           "expand", "parse_condition", "parse_equation", "parse_interval", "walker_spec"]

Value = str | float

#: the comparison operators of a rule's conditions
COMPARISONS = ("<=", ">=", "==", "!=", "<", ">")
_COMPARISON = re.compile(r"(<=|>=|==|!=|<|>)")
_EQUALS = re.compile(r"(?<![<>=!])=(?!=)")
_INTERVAL = re.compile(r"^\s*([\[(])\s*([^,]+?)\s*,\s*([^,]+?)\s*([\])])\s*(integer)?\s*$")
_ENERGY = ("dissipated", "supplied")


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
        model at the point (the swing leg becomes the stance leg).
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
    energy: str = "dissipated"

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
    atol, max_step (s), max_step_time (s: no heel strike within it is a fall), and the Newton
    tolerance of the gait search (section units)."""

    backend: str = "auto"
    method: str = "Rodas4"
    rtol: float = 1e-8
    atol: float = 1e-10
    max_step: float = 0.01
    max_step_time: float = 3.0
    gait_tolerance: float = 1e-10


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
    """

    model: Model = field(compare=False)
    feet: tuple[Foot, ...]
    modes: tuple[tuple[str, Value], ...]
    rules: tuple[Rule, ...]
    section: Section
    angles: tuple[tuple[str, str], ...]
    terrain: Terrain
    relabel: tuple[tuple[str, str], ...] = ()
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
            for key in ("foot", "impact"):
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


def parse_interval(text: str) -> tuple[float, float, bool, bool, bool]:
    """``"(low, high)"`` (``[``/``]`` closed, bounds numbers, ``inf``, or constants such as
    ``pi/4``; an optional ``integer``) -> (low, high, low_closed, high_closed, integer)."""
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
    return bounds[0], bounds[1], m.group(1) == "[", m.group(4) == "]", bool(m.group(5))


# --- reading a [walker] table ------------------------------------------------------------------------
class Problems:
    """Collects the problems of a ``[walker]`` table; raises them as one ModelFileError."""

    def __init__(self, source: str, text: str):
        self.source, self.text = source, text
        self.items: list[tuple[int | None, str]] = []

    def add(self, message: str, *path: str | int, table: str = "walker") -> None:
        """Record a problem about the key at ``path`` of ``[table]`` (its line when known)."""
        line = locate(self.text, table, *path) if self.text else None
        self.items.append((line, message))

    def raise_if_any(self) -> None:
        """Raise the problems recorded so far as one ModelFileError (none: return)."""
        if not self.items:
            return
        if len(self.items) == 1:
            line, msg = self.items[0]
            raise ModelFileError(f"{self.source}{f', line {line}' if line else ''}: {msg}")
        lines = "\n".join(f"  {f'line {line}: ' if line else ''}{msg}" for line, msg in self.items)
        raise ModelFileError(f"{self.source}: {len(self.items)} problems in its [walker] table "
                             f"(see docs/walkers.md):\n{lines}")


def suggestion(name: str, known: Iterable[str]) -> str:
    """The hint ' (did you mean ...?)' for a misspelt name, or an empty string."""
    close = difflib.get_close_matches(str(name), [str(k) for k in known], n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


_TOP = ("mass", "leg_length", "hip", "integration", "feet", "modes", "terrain", "rules",
        "relabel", "section", "angles", "guess", "ranges")
_RULE_KEYS = ("on", "if", "set", "foot", "impact", "heel_strike", "fall", "energy")
_SECTION_KEYS = ("stance", "coordinates", "complete", "thesis", "labelling", "basin")


def _is_value(v: Any) -> bool:
    return isinstance(v, str) or (isinstance(v, (int, float)) and not isinstance(v, bool))


def walker_spec(model: Model, table: Mapping[str, Any], *, source: str = "<python>",
                text: str = "", description: str = "", units: str = "") -> WalkerSpec:
    """Read a ``[walker]`` table (as TOML gives it) for ``model`` into a :class:`WalkerSpec`.

    Checks the table's structure and the names it uses that the model declares without being
    compiled (components, parameters, events); :func:`check_names` checks the rest. ``text`` (the
    file's TOML) lets the errors name lines. Raises one ModelFileError listing every problem.
    """
    bad = Problems(source, text)
    if not isinstance(table, Mapping):
        bad.add("[walker] must be a table (see docs/walkers.md)")
        bad.raise_if_any()
    for key in table:
        if key not in _TOP:
            bad.add(f"[walker] has no part {key!r}{suggestion(key, _TOP)}; its parts: "
                    f"{', '.join(_TOP)}", key)
    params = set(model.parameters)
    comps = {name for name, _ in model.components()}
    events = {e.name for e in model.events}

    def string(value: Any, where: str, *path, default: str | None = None) -> str:
        if value is None and default is not None:
            return default
        if not isinstance(value, str) or not value.strip():
            bad.add(f"{where} must be a non-empty string, got {value!r}", *path)
            return default or ""
        return value

    def mapping(key: str) -> Mapping:
        value = table.get(key, {})
        if not isinstance(value, Mapping):
            bad.add(f"[walker.{key}] must be a table, got {value!r}", key)
            return {}
        return value

    # integration
    raw = mapping("integration")
    opts: dict[str, Any] = {}
    allowed = {f.name: f.type for f in fields(Integration)}
    for key, value in raw.items():
        if key not in allowed:
            bad.add(f"[walker.integration] has no key {key!r}{suggestion(key, allowed)}; keys: "
                    f"{', '.join(allowed)}", "integration", key)
        elif key in ("backend", "method"):
            opts[key] = string(value, f"[walker.integration] {key}", "integration", key)
        elif not (_is_value(value) and not isinstance(value, str) and value > 0
                  and math.isfinite(value)):
            bad.add(f"[walker.integration] {key} must be a positive number, got {value!r}",
                    "integration", key)
        else:
            opts[key] = float(value)
    integration = Integration(**opts)

    # feet
    feet = []
    for name, foot in mapping("feet").items():
        if not isinstance(foot, Mapping) or "point" not in foot:
            bad.add(f"foot {name!r} must be a table {{ point = \"<multibody>.<point>\", contact = "
                    "\"<contact component>\" }", "feet", name)
            continue
        extra = sorted(set(foot) - {"point", "contact"})
        if extra:
            bad.add(f"foot {name!r}: unknown key {extra[0]!r}; keys: point, contact", "feet", name)
        point = string(foot.get("point"), f"foot {name!r} point", "feet", name)
        contact = foot.get("contact")
        if contact is not None:
            contact = string(contact, f"foot {name!r} contact", "feet", name)
            if contact and contact not in comps:
                bad.add(f"foot {name!r}: contact {contact!r} is not a component of the model"
                        f"{suggestion(contact, comps)}; components: {', '.join(sorted(comps))}",
                        "feet", name)
        feet.append(Foot(str(name), point, contact))
    if not feet:
        bad.add("[walker.feet] must name the feet: foot = { point = \"walker.foot\" }", "feet")
    foot_names = {f.name for f in feet}

    # modes and terrain
    modes = []
    for name, value in mapping("modes").items():
        if name not in params:
            bad.add(f"mode {name!r} is not a parameter of the model{suggestion(name, params)}; "
                    "declare it under [parameters]", "modes", name)
        if not _is_value(value):
            bad.add(f"mode {name!r}: its start value must be a number or an expression",
                    "modes", name)
        modes.append((str(name), value))
    mode_set = {k for k, _ in modes}
    ter = mapping("terrain")
    drop = string(ter.get("drop"), "[walker.terrain] drop", "terrain", default="")
    if drop and drop not in params:
        bad.add(f"[walker.terrain] drop {drop!r} is not a parameter of the model",
                "terrain", "drop")
    surfaces = ter.get("surfaces", [])
    if not isinstance(surfaces, list) or not all(isinstance(s, str) for s in surfaces):
        bad.add("[walker.terrain] surfaces must be a list of parameter names", "terrain",
                "surfaces")
        surfaces = []
    for s in surfaces:
        if s not in mode_set:
            bad.add(f"[walker.terrain] surface {s!r} is not a mode", "terrain", "surfaces")
    terrain = Terrain(drop, tuple(surfaces))
    settable = mode_set

    # rules
    raw_rules = table.get("rules", [])
    if not isinstance(raw_rules, list) or not raw_rules:
        bad.add("[[walker.rules]] must list what the events do (one table per rule)", "rules")
        raw_rules = []
    rules = []
    for i, r in enumerate(raw_rules):
        where = f"[[walker.rules]] #{i + 1}"
        if not isinstance(r, Mapping):
            bad.add(f"{where} must be a table", "rules", i)
            continue
        for key in r:
            if key not in _RULE_KEYS:
                bad.add(f"{where}: unknown key {key!r}{suggestion(key, _RULE_KEYS)}; keys: "
                        f"{', '.join(_RULE_KEYS)}", "rules", i, key)
        on = string(r.get("on"), f"{where} on", "rules", i)
        if on and on != "start" and on not in events:
            bad.add(f"{where}: on = {on!r} is not an event of the model{suggestion(on, events)}; "
                    f"events: {', '.join(sorted(events)) or 'none'} (or \"start\")", "rules", i,
                    "on")
        when = r.get("if", [])
        if isinstance(when, str):
            when = [when]
        if not isinstance(when, list):
            bad.add(f"{where}: 'if' must be a list of conditions", "rules", i, "if")
            when = []
        for cond in when:
            try:
                parse_condition(cond)
            except ModelError as err:
                bad.add(f"{where} 'if': {err}", "rules", i, "if")
        sets = r.get("set", {})
        if not isinstance(sets, Mapping):
            bad.add(f"{where}: 'set' must be a table mode = value", "rules", i, "set")
            sets = {}
        for name, value in sets.items():
            if name not in settable:
                bad.add(f"{where}: set {name!r}: only modes are set by rules{suggestion(name, settable)}"
                        f"; modes: {', '.join(sorted(settable)) or 'none'}", "rules", i, "set")
            if not _is_value(value):
                bad.add(f"{where}: set {name!r} must be a number or an expression", "rules", i,
                        "set")
        flags = {}
        for key in ("heel_strike", "fall"):
            flags[key] = r.get(key, False)
            if not isinstance(flags[key], bool):
                bad.add(f"{where}: {key} must be true or false", "rules", i, key)
                flags[key] = False
        foot = r.get("foot")
        if foot is not None and foot not in foot_names:
            bad.add(f"{where}: foot {foot!r} is not one of the feet ({', '.join(sorted(foot_names))})",
                    "rules", i, "foot")
        if flags["heel_strike"] and foot is None:
            bad.add(f"{where}: a heel-strike rule needs foot = the foot that strikes", "rules", i)
        impact = r.get("impact")
        if impact is not None:
            impact = string(impact, f"{where} impact", "rules", i, "impact")
        energy = r.get("energy", "dissipated")
        if energy not in _ENERGY:
            bad.add(f"{where}: energy must be \"dissipated\" or \"supplied\", got {energy!r}",
                    "rules", i, "energy")
            energy = "dissipated"
        rules.append(Rule(on, tuple(when), dict(sets), foot, impact, flags["heel_strike"],
                          flags["fall"], energy))
    if raw_rules and not any(r.heel_strike for r in rules):
        bad.add("[[walker.rules]]: no rule has heel_strike = true (the section is crossed at "
                "heel strike)", "rules")
    if any(r.impact for r in rules) and "relabel" not in table:
        bad.add("an impact rule re-pins the model at the striking foot: [walker.relabel] must say "
                "how the coordinates change", "rules")

    # relabel, angles, guess, ranges: tables of strings/values
    relabel = [(k, v) for k, v in mapping("relabel").items()]
    for k, v in relabel:
        if not _is_value(v):
            bad.add(f"relabel {k!r} must be an expression of the old coordinates", "relabel", k)
    angles = list(mapping("angles").items())
    for k, v in angles:
        if k not in ("theta", "phi"):
            bad.add(f"[walker.angles] defines theta and phi only, not {k!r}", "angles", k)
        if not isinstance(v, str):
            bad.add(f"angle {k!r} must be an expression of the coordinates", "angles", k)
    if not any(k == "theta" for k, _ in angles):
        bad.add("[walker.angles] needs theta (the stance leg's angle to the slope normal)",
                "angles")
    guess = [(k, v) for k, v in mapping("guess").items() if k != "where"]
    where = mapping("guess").get("where", {})
    if not isinstance(where, Mapping) or not all(isinstance(v, str) for v in where.values()):
        bad.add("[walker.guess.where] must be a table helper = expression", "guess", "where")
        where = {}
    for k, v in guess:
        if not _is_value(v):
            bad.add(f"guess of {k!r} must be a number or an expression", "guess", k)
    ranges = []
    for k, v in mapping("ranges").items():
        if k not in params:
            bad.add(f"range of {k!r}: not a parameter of the model{suggestion(k, params)}",
                    "ranges", k)
        try:
            parse_interval(v)
        except ModelError as err:
            bad.add(f"range of {k!r}: {err}", "ranges", k)
        ranges.append((k, v))

    # section
    sec = mapping("section")
    for key in sec:
        if key not in _SECTION_KEYS:
            bad.add(f"[walker.section] has no key {key!r}{suggestion(key, _SECTION_KEYS)}; keys: "
                    f"{', '.join(_SECTION_KEYS)}", "section", key)
    coords = sec.get("coordinates", [])
    if not isinstance(coords, list) or not coords or not all(isinstance(c, str) for c in coords):
        bad.add("[walker.section] coordinates must be a non-empty list of names", "section",
                "coordinates")
        coords = []
    if len(set(coords)) != len(coords):
        bad.add("[walker.section] coordinates repeat a name", "section", "coordinates")
    stance = string(sec.get("stance"), "[walker.section] stance", "section", default="")
    if stance and stance not in foot_names:
        bad.add(f"[walker.section] stance {stance!r} is not one of the feet", "section", "stance")
    complete = []
    raw_complete = sec.get("complete", {})
    if not isinstance(raw_complete, Mapping):
        bad.add("[walker.section.complete] must be a table coordinate = value", "section",
                "complete")
        raw_complete = {}
    for k, v in raw_complete.items():
        if isinstance(v, Mapping) and set(v) == {"value"} and _is_value(v["value"]):
            complete.append(Completion(k, value=v["value"]))
        elif isinstance(v, Mapping):
            if set(v) != {"such_that"}:
                bad.add(f"completion of {k!r}: a table holds one key, such_that = \"lhs = rhs\" "
                        "(or value = ...)", "section", "complete", k)
                continue
            try:
                parse_equation(v["such_that"])
            except ModelError as err:
                bad.add(f"completion of {k!r}: {err}", "section", "complete", k)
            complete.append(Completion(k, such_that=v["such_that"]))
        elif _is_value(v):
            complete.append(Completion(k, value=v))
        else:
            bad.add(f"completion of {k!r} must be an expression or {{ such_that = \"...\" }}",
                    "section", "complete", k)
    thesis = sec.get("thesis", {})
    if not isinstance(thesis, Mapping) or not all(isinstance(v, str) for v in thesis.values()):
        bad.add("[walker.section] thesis must be a table name = expression", "section", "thesis")
        thesis = {}
    if thesis and len(thesis) != len(coords):
        bad.add(f"[walker.section] thesis has {len(thesis)} coordinates for a section of "
                f"{len(coords)}: the thesis's coordinates are an invertible map of the section's",
                "section", "thesis")
    labelling = sec.get("labelling")
    if labelling is not None:
        try:
            parse_condition(labelling)
        except ModelError as err:
            bad.add(f"[walker.section] labelling: {err}", "section", "labelling")
        if not relabel:
            bad.add("[walker.section] labelling needs [walker.relabel]", "section", "labelling")
    basin = sec.get("basin", "fixed_point")
    if basin not in ("fixed_point", "guess"):
        bad.add(f"[walker.section] basin must be \"fixed_point\" or \"guess\", got {basin!r}",
                "section", "basin")
    section = Section(tuple(coords), tuple(complete), dict(thesis), stance, labelling, basin)

    mass = string(table.get("mass"), "[walker] mass", "mass", default="0")
    leg = string(table.get("leg_length"), "[walker] leg_length", "leg_length", default="1")
    hip = string(table.get("hip"), "[walker] hip", "hip", default="") if "hip" in table else ""
    bad.raise_if_any()
    return WalkerSpec(model, tuple(feet), tuple(modes), tuple(rules), section, tuple(angles),
                      terrain, tuple(relabel), tuple(guess), tuple(where.items()), tuple(ranges),
                      integration, mass, leg, hip, source, description, units)


def expand(text: Value, where: Iterable[tuple[str, str]], params: Iterable[str]) -> str:
    """``text`` with the helper quantities ``where`` (name, expression, in order) substituted:
    one expression in the parameters (for the compiler)."""
    names = {p: sp.Symbol(p, real=True) for p in params}
    helpers: dict[str, sp.Expr] = {}
    for k, v in where:
        helpers[k] = parse(v, {**names, **helpers}, f"guess helper {k!r}")
    return str(parse(text, {**names, **helpers}, "guess"))

"""Reading a ``[walker]`` table: one reader per part, every expression parsed once.

:func:`walker_spec` reads a table (a mapping as TOML gives it) against the model's frozen
description into a :class:`~.hybrid.WalkerSpec`, part by part (integration, feet, modes,
terrain, rules, relabel, angles, guess, ranges, section, mass and leg length), as
:mod:`porthamiltonian.interfaces.io` reads a model file. Each reader checks its part's structure
and the names the model declares without being compiled (components, parameters, events), and
parses its expressions once with :func:`~porthamiltonian.modeling.expressions.parse`: parameters
as their symbols, a dotted name of one of the model's components (``walker.foot1.x``) as the
symbol of that name — whether the compiled model has it is checked by
:func:`~.plan.walker_plan`, against the model's :func:`~porthamiltonian.compiler.layout`. The
parsed expressions go with the spec (:class:`~.hybrid.Parsed`). Every problem is collected and
raised as one :class:`~porthamiltonian.errors.ModelFileError` that names the file, the line
(when the TOML text is known) and the part (``[[walker.rules]] #3 condition ...``).
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any

from porthamiltonian.backends import BACKENDS
from porthamiltonian.errors import ModelError, ModelFileError, OptionError
from porthamiltonian.modeling.expressions import parse
from porthamiltonian.simulation.options import check_method, check_rtol

from .hybrid import (
    Comparison,
    Completion,
    Expr,
    Foot,
    Integration,
    Interval,
    Parsed,
    Rule,
    Section,
    Terrain,
    Value,
    WalkerSpec,
    parse_condition,
    parse_equation,
    parse_interval,
)
from .problems import Problems, suggestion

if TYPE_CHECKING:
    import sympy as sp

    from porthamiltonian.interfaces.io import ModelFile
    from porthamiltonian.modeling.model import Model, ModelDescription

__all__ = ["engaged", "file_spec", "walker_spec"]

_TOP = ("mass", "leg_length", "hip", "integration", "feet", "modes", "terrain", "rules",
        "relabel", "section", "angles", "guess", "ranges")
_RULE_KEYS = ("on", "if", "set", "foot", "impact", "engage", "heel_strike", "fall", "energy")
_SECTION_KEYS = ("stance", "coordinates", "complete", "thesis", "labelling", "basin")
_ENERGY = ("dissipated", "supplied")
#: what the expression parser says of an unknown name, and what a walker table says instead
_DECLARE = ("(declare model parameters under [parameters])",
            "(outputs, states and parameters of the model)")


def _is_value(v: Any) -> bool:
    return isinstance(v, str) or (isinstance(v, (int, float)) and not isinstance(v, bool))


@dataclass
class _Reading:
    """What the readers share: the table, the model's description, the problems found, and the
    expressions parsed so far (those a walk evaluates)."""

    table: Mapping[str, Any]
    frozen: ModelDescription
    bad: Problems
    evaluated: list[Expr] = field(default_factory=list)

    def __post_init__(self) -> None:
        import sympy as sp  # the table's expressions are parsed into sympy

        self._symbol = sp.Symbol
        self.symbols = {p: sp.Symbol(p, real=True) for p in self.frozen.parameters}
        self.scope = self.frozen.in_scope("")
        self.components = set(self.frozen.components)

    def dotted(self, ref: str) -> sp.Symbol | None:
        """A dotted name of one of the model's components, as its symbol (checked later)."""
        return self._symbol(ref, real=True) if ref.split(".")[0] in self.scope else None

    def expr(self, value: Value, where: str, *path: str | int, extra: Mapping | None = None,
             dotted: bool = True, evaluated: bool = False) -> Expr | None:
        """``value`` parsed over the parameters (and ``extra`` names); dotted names of the
        model's components allowed when ``dotted``. A problem is recorded (None returned)."""
        try:
            value_ = parse(value, {**self.symbols, **(extra or {})}, where,
                           self.dotted if dotted else None)
        except ModelError as err:
            self.bad.add(str(err).replace(*_DECLARE), *path)
            return None
        out = Expr(value, value_, where, tuple(path))
        if evaluated:
            self.evaluated.append(out)
        return out

    def string(self, value: Any, where: str, *path: str | int, default: str | None = None) -> str:
        """``value`` if it is a non-empty string, else a problem (and ``default``)."""
        if value is None and default is not None:
            return default
        if not isinstance(value, str) or not value.strip():
            self.bad.add(f"{where} must be a non-empty string, got {value!r}", *path)
            return default or ""
        return value

    def mapping(self, key: str) -> Mapping:
        """``[walker.<key>]`` (empty if absent; a problem if it is not a table)."""
        value = self.table.get(key, {})
        if not isinstance(value, Mapping):
            self.bad.add(f"[walker.{key}] must be a table, got {value!r}", key)
            return {}
        return value

    def comparison(self, text: Any, where: str, *path: str | int) -> Comparison | None:
        """A condition ``lhs OP rhs``, both sides parsed (a walk evaluates them)."""
        try:
            lhs, op, rhs = parse_condition(text)
        except ModelError as err:
            self.bad.add(f"{where}: {err}", *path)
            return None
        left, right = (self.expr(side, f"{where} {text!r}", *path, evaluated=True)
                       for side in (lhs, rhs))
        return None if left is None or right is None else Comparison(text, left, op, right)


def file_spec(record: ModelFile) -> WalkerSpec:
    """The :class:`WalkerSpec` of a model file read by :func:`porthamiltonian.io.reads`: its
    ``[walker]`` table read against its model. Raises ModelFileError (file, line, part) for a
    file that is not a walker file or whose ``[walker]`` table is wrong."""
    table = record.sections.get("walker")
    if table is None:
        raise ModelFileError(f"{record.source}: not a walker file: it has no [walker] table (a "
                             "walker is a model plus its hybrid description; see "
                             "docs/walkers.md)")
    return walker_spec(record.model, table, source=record.source, text=record.text,
                       description=record.description, units=str(record.meta.get("units", "")),
                       frozen=record.frozen)


def walker_spec(model: Model, table: Mapping[str, Any], *, source: str = "<python>",
                text: str = "", description: str = "", units: str = "",
                frozen: ModelDescription | None = None) -> WalkerSpec:
    """Read a ``[walker]`` table (as TOML gives it) for ``model`` into a :class:`WalkerSpec`
    with its expressions parsed (module docstring). ``frozen``: the model's frozen description
    when the caller has it (a model file's reader does), else the model is frozen here;
    ``text`` (the file's TOML) lets the errors name lines. Raises one ModelFileError listing
    every problem."""
    r = _Reading(table, frozen if frozen is not None else model.freeze(), Problems(source, text))
    if not isinstance(table, Mapping):
        r.bad.add("[walker] must be a table (see docs/walkers.md)")
        r.bad.raise_if_any()
    for key in table:
        if key not in _TOP:
            r.bad.add(f"[walker] has no part {key!r}{suggestion(key, _TOP)}; its parts: "
                      f"{', '.join(_TOP)}", key)
    integration = _read_integration(r)
    feet = _read_feet(r)
    modes = _read_modes(r)
    terrain = _read_terrain(r, modes)
    rules, conditions = _read_rules(r, feet, {k for k, _ in modes})
    relabel = _read_relabel(r)
    angles = _read_angles(r)
    guess, where, guessed = _read_guess(r)
    ranges, intervals = _read_ranges(r)
    section, thesis, labelling = _read_section(r, feet, relabel)
    mass, leg, hip = _read_scalars(r)
    r.bad.raise_if_any()
    parsed = Parsed(tuple(r.evaluated), conditions, labelling, guessed, thesis, angles, relabel,
                    intervals)
    return WalkerSpec(model, tuple(feet), tuple(modes), tuple(rules), section,
                      tuple((k, str(e.text)) for k, e in angles), terrain,
                      tuple((k, e.text) for k, e in relabel), guess, where, ranges, integration,
                      mass, leg, hip, source, description, units, r.frozen, parsed)


# --- the readers, one per part ---------------------------------------------------------------------
def _read_integration(r: _Reading) -> Integration:
    """``[walker.integration]``: back end and method (strings), the rest positive numbers
    (max_steps_per_stride a whole one)."""
    opts: dict[str, Any] = {}
    allowed = [f.name for f in fields(Integration)]
    for key, value in r.mapping("integration").items():
        if key not in allowed:
            r.bad.add(f"[walker.integration] has no key {key!r}{suggestion(key, allowed)}; keys: "
                      f"{', '.join(allowed)}", "integration", key)
        elif key == "backend":
            if value not in ("auto", *BACKENDS):
                r.bad.add(f"[walker.integration] backend must be \"auto\" or one of "
                          f"{', '.join(BACKENDS)}, got {value!r}", "integration", key)
            else:
                opts[key] = value
        elif key == "method":
            try:
                opts[key] = check_method(value)
            except OptionError as err:
                r.bad.add(f"[walker.integration] {err}", "integration", key)
        elif not (_is_value(value) and not isinstance(value, str) and value > 0
                  and math.isfinite(value)):
            r.bad.add(f"[walker.integration] {key} must be a positive number, got {value!r}",
                      "integration", key)
        elif key == "max_steps_per_stride":
            if isinstance(value, bool) or not isinstance(value, int) or value > 10**9:
                r.bad.add(f"[walker.integration] max_steps_per_stride must be a whole number of "
                          f"steps up to 1e9, got {value!r}", "integration", key)
            else:
                opts[key] = value
        elif key == "rtol":
            try:
                opts[key] = check_rtol(value)
            except OptionError as err:
                r.bad.add(f"[walker.integration] {err}", "integration", key)
        else:
            opts[key] = float(value)
    return Integration(**opts)


def _read_feet(r: _Reading) -> list[Foot]:
    """``[walker.feet]``: name = { point, contact } (the contact a component of the model)."""
    feet = []
    for name, foot in r.mapping("feet").items():
        if not isinstance(foot, Mapping) or "point" not in foot:
            r.bad.add(f"foot {name!r} must be a table {{ point = \"<multibody>.<point>\", contact "
                      "= \"<contact component>\" }", "feet", name)
            continue
        extra = sorted(set(foot) - {"point", "contact"})
        if extra:
            r.bad.add(f"foot {name!r}: unknown key {extra[0]!r}; keys: point, contact", "feet",
                      name)
        point = r.string(foot.get("point"), f"foot {name!r} point", "feet", name)
        contact = foot.get("contact")
        if contact is not None:
            contact = r.string(contact, f"foot {name!r} contact", "feet", name)
            if contact and contact not in r.components:
                r.bad.add(f"foot {name!r}: contact {contact!r} is not a component of the model"
                          f"{suggestion(contact, r.components)}; components: "
                          f"{', '.join(sorted(r.components))}", "feet", name)
        feet.append(Foot(str(name), point, contact))
    if not feet:
        r.bad.add("[walker.feet] must name the feet: foot = { point = \"walker.foot\" }", "feet")
    return feet


def _read_modes(r: _Reading) -> list[tuple[str, Value]]:
    """``[walker.modes]``: parameters the rules set, with their start values (parsed)."""
    modes = []
    for name, value in r.mapping("modes").items():
        if name not in r.symbols:
            r.bad.add(f"mode {name!r} is not a parameter of the model"
                      f"{suggestion(name, r.symbols)}; declare it under [parameters]",
                      "modes", name)
        if not _is_value(value):
            r.bad.add(f"mode {name!r}: its start value must be a number or an expression",
                      "modes", name)
        else:
            r.expr(value, f"mode {name!r} start value", "modes", name, evaluated=True)
        modes.append((str(name), value))
    return modes


def _read_terrain(r: _Reading, modes: list[tuple[str, Value]]) -> Terrain:
    """``[walker.terrain]``: the drop parameter and the surfaces (modes)."""
    ter = r.mapping("terrain")
    drop = ter.get("drop")
    if drop is None:
        r.bad.add("[walker.terrain] drop is missing: the parameter the step-down test sets to the "
                  "height of the drop (m), e.g. drop = \"step_down\"", "terrain")
        drop = ""
    else:
        drop = r.string(drop, "[walker.terrain] drop", "terrain", "drop", default="")
    if drop and drop not in r.symbols:
        r.bad.add(f"[walker.terrain] drop {drop!r} is not a parameter of the model",
                  "terrain", "drop")
    surfaces = ter.get("surfaces", [])
    if not isinstance(surfaces, list) or not all(isinstance(s, str) for s in surfaces):
        r.bad.add("[walker.terrain] surfaces must be a list of parameter names", "terrain",
                  "surfaces")
        surfaces = []
    mode_names = {k for k, _ in modes}
    for s in surfaces:
        if s not in mode_names:
            r.bad.add(f"[walker.terrain] surface {s!r} is not a mode", "terrain", "surfaces")
    return Terrain(drop, tuple(surfaces))


def _read_rules(r: _Reading, feet: list[Foot],
                modes: set[str]) -> tuple[list[Rule], tuple[tuple[Comparison, ...], ...]]:
    """``[[walker.rules]]``: what each event does; the rules and their parsed conditions."""
    raw = r.table.get("rules", [])
    if not isinstance(raw, list) or not raw:
        r.bad.add("[[walker.rules]] must list what the events do (one table per rule)", "rules")
        raw = []
    rules, conditions = [], []
    for i, entry in enumerate(raw):
        if not isinstance(entry, Mapping):
            r.bad.add(f"[[walker.rules]] #{i + 1} must be a table", "rules", i)
            continue
        rule, conds = _read_rule(r, i, entry, {f.name for f in feet}, modes)
        rules.append(rule)
        conditions.append(conds)
    if raw and not any(rule.heel_strike for rule in rules):
        r.bad.add("[[walker.rules]]: no rule has heel_strike = true (the section is crossed at "
                  "heel strike)", "rules")
    if any(rule.impact for rule in rules) and "relabel" not in r.table:
        r.bad.add("an impact rule re-pins the model at the striking foot: [walker.relabel] must "
                  "say how the coordinates change", "rules")
    return rules, tuple(conditions)


def _read_rule(r: _Reading, i: int, entry: Mapping, feet: set[str],
               modes: set[str]) -> tuple[Rule, tuple[Comparison, ...]]:
    """One rule (``#i + 1``) and its parsed conditions."""
    where = f"[[walker.rules]] #{i + 1}"
    events = {e.name for e in r.frozen.events}
    for key in entry:
        if key not in _RULE_KEYS:
            r.bad.add(f"{where}: unknown key {key!r}{suggestion(key, _RULE_KEYS)}; keys: "
                      f"{', '.join(_RULE_KEYS)}", "rules", i, key)
    on = r.string(entry.get("on"), f"{where} on", "rules", i)
    if on and on != "start" and on not in events:
        r.bad.add(f"{where}: on = {on!r} is not an event of the model{suggestion(on, events)}; "
                  f"events: {', '.join(sorted(events)) or 'none'} (or \"start\")", "rules", i,
                  "on")
    when = entry.get("if", [])
    when = [when] if isinstance(when, str) else when
    if not isinstance(when, list):
        r.bad.add(f"{where}: 'if' must be a list of conditions", "rules", i, "if")
        when = []
    conds = [r.comparison(c, f"{where} condition", "rules", i, "if") for c in when]
    sets = _read_sets(r, where, i, entry.get("set", {}), modes)
    flags = {}
    for key in ("heel_strike", "fall"):
        flags[key] = entry.get(key, False)
        if not isinstance(flags[key], bool):
            r.bad.add(f"{where}: {key} must be true or false", "rules", i, key)
            flags[key] = False
    foot = entry.get("foot")
    if foot is not None:
        foot = r.string(foot, f"{where} foot", "rules", i, "foot") or None
    if foot is not None and foot not in feet:
        r.bad.add(f"{where}: foot {foot!r} is not one of the feet ({', '.join(sorted(feet))})",
                  "rules", i, "foot")
    if flags["heel_strike"] and "foot" not in entry:
        r.bad.add(f"{where}: a heel-strike rule needs foot = the foot that strikes", "rules", i)
    impact = entry.get("impact")
    if impact is not None:
        impact = r.string(impact, f"{where} impact", "rules", i, "impact")
    engage = entry.get("engage")
    if engage is not None:
        engage = r.string(engage, f"{where} engage", "rules", i, "engage")
        _check_engage(r, where, i, engage, impact, sets, modes)
    energy = entry.get("energy", "dissipated")
    if energy not in _ENERGY:
        r.bad.add(f"{where}: energy must be \"dissipated\" or \"supplied\", got {energy!r}",
                  "rules", i, "energy")
        energy = "dissipated"
    rule = Rule(on, tuple(when), tuple(sets.items()), foot, impact, flags["heel_strike"],
                flags["fall"], energy, engage or None)
    return rule, tuple(c for c in conds if c is not None)


def engaged(frozen: ModelDescription, target: str) -> tuple[str, str, Mapping] | None:
    """(multibody, name, entry) of the loop or constraint ``target`` (``"<multibody>.<name>"``)
    of the model ``frozen``, or None."""
    from porthamiltonian.mechanics import Multibody

    mb, _, name = target.partition(".")
    comp = frozen.components.get(mb)
    if not isinstance(comp, Multibody):
        return None
    for table in ("constraints", "loops"):
        entry = (comp.value(table) or {}).get(name)
        if isinstance(entry, Mapping):
            return mb, name, entry
    return None


def _check_engage(r: _Reading, where: str, i: int, target: str, impact: Any,
                  sets: Mapping[str, Value], modes: set[str]) -> None:
    """A rule's ``engage``: a loop or constraint of a multibody, switched by a mode (its
    ``active`` a mode parameter, which the rule sets to 1 itself); never with ``impact``."""
    if not target:
        return
    path = ("rules", i, "engage")
    if impact is not None:
        r.bad.add(f"{where}: a rule applies one impact: at a point (impact) or onto a constraint "
                  "(engage), not both; write two rules on two events", *path)
    found = engaged(r.frozen, target)
    if found is None:
        known = _switchable(r.frozen)
        r.bad.add(f"{where}: engage {target!r} is not a loop or constraint of a multibody"
                  f"{suggestion(target, known)}; write \"<multibody>.<constraint>\" "
                  f"(known: {', '.join(known) or 'none'})", *path)
        return
    switch = found[2].get("active", 1)
    if not (isinstance(switch, str) and switch.strip() in modes):
        r.bad.add(f"{where}: engage {target!r}: its 'active' is {switch!r}, not a mode; a "
                  "switched constraint reads a mode parameter (active = \"knee_locked\", "
                  "declared under [walker.modes]) that the rule sets to 1", *path)
    elif switch.strip() in sets:
        r.bad.add(f"{where}: engage {target!r} sets its switch {switch.strip()!r} to 1 itself: "
                  "remove it from 'set'", *path)


def _switchable(frozen: ModelDescription) -> list[str]:
    """``<multibody>.<name>`` of every loop and constraint of the model."""
    from porthamiltonian.mechanics import Multibody

    return [f"{mb}.{name}" for mb, comp in frozen.components.items()
            if isinstance(comp, Multibody)
            for table in ("constraints", "loops") for name in (comp.value(table) or {})]


def _read_sets(r: _Reading, where: str, i: int, sets: Any, modes: set[str]) -> dict[str, Value]:
    """A rule's ``set``: mode = value (parsed: a walk evaluates it)."""
    if not isinstance(sets, Mapping):
        r.bad.add(f"{where}: 'set' must be a table mode = value", "rules", i, "set")
        return {}
    for name, value in sets.items():
        if name not in modes:
            r.bad.add(f"{where}: set {name!r}: only modes are set by rules"
                      f"{suggestion(name, modes)}; modes: {', '.join(sorted(modes)) or 'none'}",
                      "rules", i, "set")
        if not _is_value(value):
            r.bad.add(f"{where}: set {name!r} must be a number or an expression", "rules", i,
                      "set")
        else:
            r.expr(value, f"{where} set {name!r}", "rules", i, "set", evaluated=True)
    return dict(sets)


def _read_relabel(r: _Reading) -> tuple[tuple[str, Expr], ...]:
    """``[walker.relabel]``: coordinate (or mode) = expression of the old ones (parsed)."""
    out = []
    for k, v in r.mapping("relabel").items():
        if not _is_value(v):
            r.bad.add(f"relabel {k!r} must be an expression of the old coordinates", "relabel", k)
            continue
        parsed = r.expr(v, f"relabel {k!r}", "relabel", k)
        if parsed is not None:
            out.append((str(k), parsed))
    return tuple(out)


def _read_angles(r: _Reading) -> tuple[tuple[str, Expr], ...]:
    """``[walker.angles]``: theta (and phi) as expressions of the multibody coordinates."""
    out = []
    for k, v in r.mapping("angles").items():
        if k not in ("theta", "phi"):
            r.bad.add(f"[walker.angles] defines theta and phi only, not {k!r}", "angles", k)
        if not isinstance(v, str):
            r.bad.add(f"angle {k!r} must be an expression of the coordinates", "angles", k)
            continue
        parsed = r.expr(v, f"angle {k!r}", "angles", k)
        if parsed is not None:
            out.append((str(k), parsed))
    if not any(k == "theta" for k in r.mapping("angles")):
        r.bad.add("[walker.angles] needs theta (the stance leg's angle to the slope normal)",
                  "angles")
    return tuple(out)


def _read_guess(r: _Reading) -> tuple[tuple[tuple[str, Value], ...], tuple[tuple[str, str], ...],
                                      tuple[tuple[str, Expr], ...]]:
    """``[walker.guess]``: (the guess, its helpers, each guess parsed with the helpers
    substituted: an expression in parameters)."""
    table = r.mapping("guess")
    where = table.get("where", {})
    if not isinstance(where, Mapping) or not all(isinstance(v, str) for v in where.values()):
        r.bad.add("[walker.guess.where] must be a table helper = expression", "guess", "where")
        where = {}
    helpers: dict[str, sp.Expr] = {}
    for k, v in where.items():
        parsed = r.expr(v, f"guess helper {k!r}", "guess", "where", k, extra=helpers,
                        dotted=False)
        if parsed is not None:
            helpers[k] = parsed.value
    guess, parsed_guess = [], []
    for k, v in table.items():
        if k == "where":
            continue
        guess.append((k, v))
        if not _is_value(v):
            r.bad.add(f"guess of {k!r} must be a number or an expression", "guess", k)
            continue
        parsed = r.expr(v, f"guess of {k!r}", "guess", k, extra=helpers, dotted=False)
        if parsed is not None:
            parsed_guess.append((k, parsed))
    return tuple(guess), tuple(where.items()), tuple(parsed_guess)


def _read_ranges(r: _Reading) -> tuple[tuple[tuple[str, str], ...],
                                       tuple[tuple[str, Interval], ...]]:
    """``[walker.ranges]``: parameter = "(low, high)" (the texts, and the intervals)."""
    ranges, intervals = [], []
    for k, v in r.mapping("ranges").items():
        if k not in r.symbols:
            r.bad.add(f"range of {k!r}: not a parameter of the model{suggestion(k, r.symbols)}",
                      "ranges", k)
        try:
            intervals.append((k, parse_interval(v)))
        except ModelError as err:
            r.bad.add(f"range of {k!r}: {err}", "ranges", k)
        ranges.append((k, v))
    return tuple(ranges), tuple(intervals)


def _read_section(r: _Reading, feet: list[Foot], relabel: tuple) -> tuple[
        Section, tuple[tuple[str, Expr], ...], Comparison | None]:
    """``[walker.section]``: (the section, its thesis coordinates parsed, its labelling)."""
    sec = r.mapping("section")
    for key in sec:
        if key not in _SECTION_KEYS:
            r.bad.add(f"[walker.section] has no key {key!r}{suggestion(key, _SECTION_KEYS)}; "
                      f"keys: {', '.join(_SECTION_KEYS)}", "section", key)
    coords = sec.get("coordinates", [])
    if not isinstance(coords, list) or not coords or not all(isinstance(c, str) for c in coords):
        r.bad.add("[walker.section] coordinates must be a non-empty list of names", "section",
                  "coordinates")
        coords = []
    if len(set(coords)) != len(coords):
        r.bad.add("[walker.section] coordinates repeat a name", "section", "coordinates")
    stance = sec.get("stance")
    if stance is None:
        r.bad.add("[walker.section] stance is missing: the foot that stands on the surface at "
                  f"the section, one of {', '.join(f.name for f in feet) or 'the feet'}", "section")
        stance = ""
    else:
        stance = r.string(stance, "[walker.section] stance", "section", "stance", default="")
    if stance and stance not in {f.name for f in feet}:
        r.bad.add(f"[walker.section] stance {stance!r} is not one of the feet", "section",
                  "stance")
    complete = _read_completions(r, sec.get("complete", {}), coords)
    thesis, parsed_thesis = _read_thesis(r, sec.get("thesis", {}), coords)
    labelling = sec.get("labelling")
    parsed_labelling = None
    if labelling is not None:
        parsed_labelling = r.comparison(labelling, "[walker.section] labelling", "section",
                                        "labelling")
        if not relabel:
            r.bad.add("[walker.section] labelling needs [walker.relabel]", "section", "labelling")
    basin = sec.get("basin", "fixed_point")
    if basin not in ("fixed_point", "guess"):
        r.bad.add(f"[walker.section] basin must be \"fixed_point\" or \"guess\", got {basin!r}",
                  "section", "basin")
    section = Section(tuple(coords), tuple(complete), tuple(thesis.items()), stance, labelling, basin)
    return section, parsed_thesis, parsed_labelling


def _read_completions(r: _Reading, raw: Any, coords: list[str]) -> list[Completion]:
    """``[walker.section.complete]``: coordinate = value, or { such_that = "lhs = rhs" } (the
    sides that are not section coordinates parsed)."""
    if not isinstance(raw, Mapping):
        r.bad.add("[walker.section.complete] must be a table coordinate = value", "section",
                  "complete")
        return []
    out = []
    for k, v in raw.items():
        where, path = f"completion of {k!r}", ("section", "complete", k)
        if isinstance(v, Mapping) and set(v) == {"value"} and _is_value(v["value"]):
            v = v["value"]
        if _is_value(v):
            r.expr(v, where, *path, evaluated=True)
            out.append(Completion(k, value=v))
        elif isinstance(v, Mapping) and set(v) == {"such_that"}:
            try:
                sides = parse_equation(v["such_that"])
            except ModelError as err:
                r.bad.add(f"{where}: {err}", *path)
                continue
            for side in sides:
                if side not in coords:
                    r.expr(side, where, *path, evaluated=True)
            out.append(Completion(k, such_that=v["such_that"]))
        elif isinstance(v, Mapping):
            r.bad.add(f"{where}: a table holds one key, such_that = \"lhs = rhs\" (or value = ...)",
                      *path)
        else:
            r.bad.add(f"{where} must be an expression or {{ such_that = \"...\" }}", *path)
    return out


def _read_thesis(r: _Reading, thesis: Any, coords: list[str]) -> tuple[
        dict[str, str], tuple[tuple[str, Expr], ...]]:
    """``[walker.section] thesis``: name = expression of the section coordinates (parsed; a
    plain coordinate name is a name here too)."""
    if not isinstance(thesis, Mapping) or not all(isinstance(v, str) for v in thesis.values()):
        r.bad.add("[walker.section] thesis must be a table name = expression", "section", "thesis")
        return {}, ()
    if thesis and len(thesis) != len(coords):
        r.bad.add(f"[walker.section] thesis has {len(thesis)} coordinates for a section of "
                  f"{len(coords)}: the thesis's coordinates are an invertible map of the "
                  "section's", "section", "thesis")
    plain = {n: r._symbol(n, real=True) for n in coords if "." not in n}
    parsed = []
    for k, v in thesis.items():
        expr = r.expr(v, f"thesis coordinate {k!r}", "section", "thesis", extra=plain)
        if expr is not None:
            parsed.append((str(k), expr))
    return dict(thesis), tuple(parsed)


def _read_scalars(r: _Reading) -> tuple[str, str, str]:
    """``[walker] mass``, ``leg_length`` (expressions in parameters, parsed) and ``hip``."""
    if "g" not in r.symbols:
        r.bad.add("the walker's weight (the cost of transport) is [walker] mass times the "
                  "parameter g: declare g (m/s^2) under [parameters]", "mass")
    out = []
    for key, default in (("mass", "0"), ("leg_length", "1")):
        value = r.string(r.table.get(key), f"[walker] {key}", key, default=default)
        r.expr(value, f"[walker] {key}", key, dotted=False, evaluated=True)
        out.append(value)
    hip = (r.string(r.table.get("hip"), "[walker] hip", "hip", default="")
           if "hip" in r.table else "")
    return out[0], out[1], hip

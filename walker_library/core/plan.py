"""A walker's plan: its table checked against the names its model compiles to, as frozen records.

:func:`walker_plan` takes a read :class:`~.hybrid.WalkerSpec` (its expressions parsed) and the
model's :class:`~porthamiltonian.compiler.Layout` (the parameters, states and outputs the compiled
model will have, from the symbolic compiler, kept in the cache) and gives a :class:`WalkerPlan`,
before anything is compiled:

* :class:`ModelNames` — the names the model provides, its multibody, coordinates, points and
  pinned root joint;
* the checks: every dotted name an expression reads is a state or an output of the model; the
  feet, the hip and the impact points are points of the multibody; the section's coordinates are
  states, joint rates or quantities a completion defines, and fix every rate; the thesis's
  coordinates are an invertible linear map of the section's; the angles are linear in the
  multibody coordinates; the relabelling is an invertible affine map (a signed permutation for a
  symmetric walker); the parameter ranges agree with the components' constraints;
* :class:`SectionMap` (the section's lift and projection, the thesis's map, the angles),
  :class:`RelabelMap`, the :class:`TransitionPlan` of every rule, the modes' start values, the
  initial guess, the parameters' :class:`~.protocol.ParameterSpec`;
* the walker's outputs: one model output per distinct expression a walk evaluates (the rules'
  conditions and values, the modes' start values, the completions, the labelling, the guess, the
  total mass, the leg length, the relabelling's offsets), named ``hybrid_e<k>``, added to the
  model's description (:attr:`WalkerPlan.description`, compiled by :mod:`.walker`): a walk
  evaluates no expression from a file in Python.

Every problem is collected and raised as one :class:`~porthamiltonian.errors.ModelFileError`
naming the file, the line and the part.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np

from porthamiltonian.compiler import Layout
from porthamiltonian.errors import ModelFileError
from porthamiltonian.interfaces.io import locate
from porthamiltonian.modeling.constraints import Constraint
from porthamiltonian.modeling.expressions import Expression, parse_text

from .hybrid import Booking, Expr, Interval, Parsed, WalkerSpec, parse_equation
from .problems import Problems, suggestion
from .protocol import ParameterSpec
from .reading import engaged
from .resets import Floating, floating_model

if TYPE_CHECKING:
    import sympy as sp

    from porthamiltonian.modeling.model import ModelDescription

# The records import no sympy (a walker restored from its snapshot uses them); the checks that
# need it (linear maps, the thesis's inverse) import it when they run.

__all__ = ["BodiesMass", "ChangePlan", "ConditionPlan", "ModelNames", "Projected", "RelabelMap", "SectionMap",
           "SolveState", "TransitionPlan", "WalkerPlan", "walker_plan"]

#: prefix of the outputs the walker adds to its model (one per evaluated expression)
PREFIX = "hybrid"
_NONLINEAR = "a linear expression"


# --- the records -----------------------------------------------------------------------------------
@dataclass(frozen=True)
class ModelNames:
    """The names a model provides once compiled (its :class:`~porthamiltonian.compiler.Layout`):
    parameters, states, outputs (port variables and component outputs), the multibody's name,
    its coordinates (``<mb>.q.<c>`` without the prefix), its points and its pinned root joint
    (a revolute joint from the world, if it has exactly one), and its joints' types (joint,
    type) in the file's order (what the reports' units and labels read)."""

    params: tuple[str, ...]
    states: tuple[str, ...]
    outputs: tuple[str, ...]
    multibody: str
    coordinates: tuple[str, ...]
    points: tuple[str, ...]
    root_joint: str | None
    joint_types: tuple[tuple[str, str], ...]

    @classmethod
    def of(cls, frozen: ModelDescription, layout: Layout) -> ModelNames:
        """The names of the model ``frozen`` whose compiled form has ``layout``."""
        from porthamiltonian.mechanics import Multibody

        mbs = [name for name, c in frozen.components.items() if isinstance(c, Multibody)]
        mb = mbs[0] if len(mbs) == 1 else ""
        states = layout.state_names
        coords = tuple(s[len(mb) + 3:] for s in states if mb and s.startswith(f"{mb}.q."))
        points: tuple[str, ...] = ()
        root = None
        types: tuple[tuple[str, str], ...] = ()
        if mb:
            comp = frozen.components[mb]
            bodies, joints = comp.value("bodies"), comp.value("joints")
            points = tuple(p for b in bodies.values() for p in (b.get("points") or {}))
            roots = [j for j, d in joints.items() if d.get("parent") == "world"]
            root = (roots[0] if len(roots) == 1 and joints[roots[0]].get("type") == "revolute"
                    else None)
            types = tuple((str(j), str(d.get("type", ""))) for j, d in joints.items())
        return cls(layout.param_names, states, layout.output_names, mb, coords, points, root,
                   types)

    @property
    def point_names(self) -> set[str]:
        """The multibody's points by full name (``walker.foot1``)."""
        return {f"{self.multibody}.{p}" for p in self.points}

    @property
    def position_states(self) -> list[str]:
        """Every state but the multibody's momenta (what a relabelling maps)."""
        return [s for s in self.states if not s.startswith(f"{self.multibody}.p.")]

    @property
    def rates(self) -> list[str]:
        """The joint rates ``<mb>.v.<c>`` (section coordinates that are not states)."""
        return [f"{self.multibody}.v.{c}" for c in self.coordinates]


@dataclass(frozen=True)
class ConditionPlan:
    """``text`` holds when the walker output ``output`` (lhs − rhs) compares with 0 by ``op``."""

    text: str
    output: str
    op: str


@dataclass(frozen=True)
class ChangePlan:
    """``name`` (a mode; a section coordinate of the guess; in the section's lift, a state
    coordinate or joint rate) takes ``constant``, or the value of the walker output ``output``."""

    name: str
    constant: float | None = None
    output: str | None = None


@dataclass(frozen=True)
class TransitionPlan:
    """One rule: the event it acts on (``"start"``: once at the start of a walk), its conditions,
    the modes it sets, the multibody point of its plastic impact (rigid walkers) or the
    multibody's constraint it engages (a knee strike: the impact onto the constraint, its switch
    among the changes), and whether it ends a step or the walk (see :class:`~.hybrid.Rule`)."""

    name: str
    event: str
    conditions: tuple[ConditionPlan, ...]
    changes: tuple[ChangePlan, ...]
    impact: str | None
    heel_strike: bool
    fall: bool
    energy: Booking
    foot: str | None
    engage: str | None = None


@dataclass(frozen=True)
class SolveState:
    """A lift step: state coordinate ``name`` is solved for so that the walker output ``output``
    equals the section coordinate ``given`` (0 when ``given`` is None)."""

    name: str
    output: str
    given: str | None = None


@dataclass(frozen=True)
class Projected:
    """A section coordinate read from a state: the walker output ``output`` that a completion
    defines it by, or (``output`` None) the state coordinate or joint rate of its name."""

    name: str
    output: str | None = None


@dataclass(frozen=True)
class SectionMap:
    """The Poincaré section: its coordinates and the thesis's (``to_thesis`` maps the first to the
    second, ``from_thesis`` back; rows of numbers), how a section state is lifted to a model state
    (:class:`ChangePlan`, :class:`SolveState`, in order, then p = M(q) v) and projected back
    (:class:`Projected`), the labelling condition, and the thesis's angles (coefficients over the
    multibody coordinates)."""

    coordinates: tuple[str, ...]
    thesis_names: tuple[str, ...]
    to_thesis: tuple[tuple[float, ...], ...]
    from_thesis: tuple[tuple[float, ...], ...]
    lift: tuple[ChangePlan | SolveState, ...]
    project: tuple[Projected, ...]
    labelling: ConditionPlan | None
    angles: Mapping[str, tuple[float, ...]]


@dataclass(frozen=True)
class RelabelMap:
    """The relabelling as an affine map over ``space`` (the position states, then the modes):
    rows ``A``, offsets ``b`` (numbers, or the walker outputs of offsets that depend on
    parameters)."""

    space: tuple[str, ...]
    A: tuple[tuple[float, ...], ...]
    b: tuple[float | str, ...]


@dataclass(frozen=True)
class BodiesMass:
    """The multibody's bodies' masses (kg), each an expression in parameters (parsed for the
    numeric evaluator), against which ``[walker] mass`` is checked at every parameter set;
    ``where``: the file and line of ``[walker] mass``, for the error."""

    masses: tuple[Expression, ...]
    prefix: str
    where: str

    def total(self, values: Mapping[str, float]) -> float:
        """The bodies' total mass (kg) at the parameter values ``values`` (by full name)."""
        local = {k[len(self.prefix):]: v for k, v in values.items() if k.startswith(self.prefix)}
        return float(sum(m.evaluate(local) for m in self.masses))

    def check(self, mass: float, values: Mapping[str, float]) -> None:
        """ModelFileError unless ``mass`` (the walker's, kg) is the bodies' total."""
        total = self.total(values)
        if not math.isclose(mass, total, rel_tol=1e-9, abs_tol=1e-12):
            raise ModelFileError(
                f"{self.where}: [walker] mass gives {mass:.10g} kg but the multibody's bodies weigh "
                f"{total:.10g} kg in total: the cost of transport divides by the walker's weight, "
                "so [walker] mass must be the bodies' total mass (write the sum of their masses)")


@dataclass(frozen=True)
class WalkerPlan:
    """Everything a walker is, checked, before compilation (see the module docstring).

    spec : the read table. names : the model's names. description : the model's description with
    the walker's outputs (``outputs``: name -> expression), what :mod:`.walker` compiles.
    section, relabel (None without one), transitions : the records above. start : the modes'
    start values. guess : per section coordinate, a number or the output of its expression (in
    parameters).
    mass, leg_length : the outputs of the total mass (kg) and the leg length (m). drop : the
    terrain's drop parameter. parameters : the user-settable parameters with their ranges.
    floating : the multibody with its pin released, for the plastic impact (rigid walkers).
    bodies : the bodies' masses, which ``[walker] mass`` must add up to.
    """

    spec: WalkerSpec
    names: ModelNames
    description: ModelDescription
    outputs: Mapping[str, str]
    section: SectionMap
    relabel: RelabelMap | None
    transitions: tuple[TransitionPlan, ...]
    start: tuple[ChangePlan, ...]
    guess: tuple[ChangePlan, ...]
    mass: str
    leg_length: str
    drop: str
    parameters: Mapping[str, ParameterSpec]
    floating: Floating | None
    bodies: BodiesMass

    @property
    def legged(self) -> bool:
        """True when the thesis's θ and φ are defined."""
        return all(k in self.section.angles for k in ("theta", "phi"))


# --- the plan --------------------------------------------------------------------------------------
class _Outputs:
    """The walker's outputs: ``add(text)`` gives the name of the output that evaluates ``text``
    (one per distinct text, named in order)."""

    def __init__(self) -> None:
        self.exprs: dict[str, str] = {}
        self._names: dict[str, str] = {}

    def add(self, text: Any) -> str:
        """The name of the output that evaluates ``text`` (added if new)."""
        text = str(text)
        if text not in self._names:
            self._names[text] = f"{PREFIX}_e{len(self.exprs)}"
            self.exprs[self._names[text]] = text
        return self._names[text]

    def value(self, name: str, value: Any) -> ChangePlan:
        """``name`` takes ``value``: a number as it is, an expression as its output."""
        const = _number(value)
        return ChangePlan(name, const) if const is not None else ChangePlan(name, None,
                                                                            self.add(value))


def walker_plan(spec: WalkerSpec, layout: Layout, text: str = "") -> WalkerPlan:
    """The plan of the read ``spec`` (its ``parsed`` expressions) for the model whose compiled
    form has ``layout`` (module docstring). ``text``: the file's TOML, for lines in errors.
    Raises one ModelFileError listing every problem."""
    if spec.parsed is None or spec.frozen is None:
        raise TypeError("walker_plan takes a spec read by walker_spec (its expressions parsed)")
    bad = Problems(spec.source, text)
    names = ModelNames.of(spec.frozen, layout)
    if not names.multibody:
        bad.add("a walker's model needs exactly one Multibody component (its bodies and joints)")
        bad.raise_if_any()
    parsed = spec.parsed
    _check_evaluated(bad, parsed.evaluated, names)
    _check_points(bad, spec, names)
    _check_section(bad, spec, names)
    bad.raise_if_any()                 # what follows reads the section's coordinates
    to_thesis, from_thesis = _thesis(bad, spec, parsed, names)
    angles = _angles(bad, parsed, names)
    relabel = _relabel(bad, spec, parsed, names)
    parameters = _parameters(bad, spec, spec.frozen, parsed.ranges, layout.constraints)
    bad.raise_if_any()

    ex = _Outputs()
    transitions = _transitions(spec, parsed, ex)
    start = tuple(ex.value(k, v) for k, v in spec.modes)
    lift, project = _lift(spec, ex)
    labelling = (ConditionPlan(parsed.labelling.text, ex.add(parsed.labelling.difference),
                               parsed.labelling.op) if parsed.labelling is not None else None)
    guessed = dict(parsed.guess)
    guess = tuple(_guess(n, guessed.get(n), ex) for n in spec.section.coordinates)
    mass, leg = ex.add(spec.mass), ex.add(spec.leg_length)
    if relabel is not None:
        relabel = RelabelMap(relabel.space, relabel.A,
                             tuple(ex.add(b) if isinstance(b, str) else b for b in relabel.b))
    section = SectionMap(spec.section.coordinates,
                         tuple(k for k, _ in spec.section.thesis) or spec.section.coordinates,
                         to_thesis, from_thesis, lift, project, labelling,
                         MappingProxyType(angles))
    floating = None
    if any(r.impact for r in spec.rules):
        floating = floating_model(spec.frozen, names.multibody, names.root_joint or "",
                                  spec.hip.split(".", 1)[1])
    return WalkerPlan(spec, names, spec.frozen.with_outputs(ex.exprs),
                      MappingProxyType(dict(ex.exprs)), section, relabel, transitions, start, guess,
                      mass, leg, spec.terrain.drop, MappingProxyType(parameters), floating,
                      _bodies(spec, spec.frozen, names.multibody, text))


def _bodies(spec: WalkerSpec, frozen: ModelDescription, mb: str, text: str) -> BodiesMass:
    """The multibody's bodies' masses, for the check of ``[walker] mass``."""
    bodies = frozen.components[mb].value("bodies")
    masses = tuple(parse_text(str(b.get("mass", 0)), f"body {name!r} mass")
                   for name, b in bodies.items())
    line = locate(text, "walker", "mass") if text else None
    return BodiesMass(masses, frozen.scopes[mb], f"{spec.source}{f', line {line}' if line else ''}")


def _number(value: Any) -> float | None:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    return None


def _guess(name: str, expr: Expr | None, ex: _Outputs) -> ChangePlan:
    """A guessed coordinate: a number, or the output of its expression in parameters (the
    helpers substituted; 0 when the table gives no guess)."""
    if expr is None:
        return ChangePlan(name, None, ex.add(0))
    const = expr.constant
    return ChangePlan(name, const) if const is not None else ChangePlan(name, None,
                                                                        ex.add(expr.value))


def _transitions(spec: WalkerSpec, parsed: Parsed, ex: _Outputs) -> tuple[TransitionPlan, ...]:
    """The rules as transitions; their conditions' and values' outputs, in the table's order."""
    out = []
    for i, (rule, conds) in enumerate(zip(spec.rules, parsed.conditions)):
        conditions = tuple(ConditionPlan(c.text, ex.add(c.difference), c.op) for c in conds)
        changes = tuple(ex.value(k, v) for k, v in rule.set)
        engage = None
        if rule.engage:
            found = engaged(spec.frozen, rule.engage) if spec.frozen is not None else None
            if found is not None:         # the reader checked it: a constraint with a mode switch
                engage = found[1]
                changes += (ChangePlan(str(found[2]["active"]).strip(), 1.0),)
        out.append(TransitionPlan(f"{rule.on}#{i + 1}", rule.on, conditions, changes,
                                  rule.impact, rule.heel_strike, rule.fall, rule.energy, rule.foot,
                                  engage))
    return tuple(out)


def _lift(spec: WalkerSpec, ex: _Outputs) -> tuple[tuple[ChangePlan | SolveState, ...],
                                                  tuple[Projected, ...]]:
    """The lift's steps (the completions in order) and the projection's entries."""
    coords = spec.section.coordinates
    defined: dict[str, str] = {}
    lift: list[ChangePlan | SolveState] = []
    for c in spec.section.complete:
        if c.such_that is None:
            lift.append(ex.value(c.coordinate, c.value))
            continue
        lhs, rhs = parse_equation(c.such_that)
        if rhs in coords or lhs in coords:
            given, expr = (rhs, lhs) if rhs in coords else (lhs, rhs)
            defined[given] = ex.add(expr)
            lift.append(SolveState(c.coordinate, defined[given], given))
        else:
            lift.append(SolveState(c.coordinate, ex.add(f"({lhs}) - ({rhs})")))
    return tuple(lift), tuple(Projected(n, defined.get(n)) for n in coords)


# --- the checks ------------------------------------------------------------------------------------
def _unknown(bad: Problems, expr: Expr, unknown: Iterable[str], known: Iterable[str]) -> None:
    """Record that ``expr`` reads names the model does not have."""
    shown = repr(expr.text)
    shown = shown if len(shown) <= 120 else shown[:100] + "..." + shown[-12:]
    bad.add(f"{expr.where}: unknown name(s) {', '.join(sorted(set(unknown)))} in {shown}; known "
            f"names here: {', '.join(sorted(n for n in known if '.' not in n)) or 'none'} "
            "(outputs, states and parameters of the model)", *expr.path)


def _check_names(bad: Problems, expr: Expr, allowed: Iterable[str], params: Sequence[str]) -> bool:
    """Whether ``expr`` reads only the names ``allowed``, the parameters ``params`` and time;
    else a problem."""
    allowed = set(allowed)
    plain = {str(s) for s in expr.value.free_symbols if "." not in str(s)} - {"t"}
    unknown = (expr.dotted - allowed) | (plain - set(params) - allowed)
    if unknown:
        _unknown(bad, expr, unknown, params)
    return not unknown


def _check_evaluated(bad: Problems, evaluated: Sequence[Expr], names: ModelNames) -> None:
    """Every expression a walk evaluates reads states, outputs and parameters of the model."""
    known = set(names.states) | set(names.outputs)
    for expr in evaluated:
        _check_names(bad, expr, known, names.params)


def _check_points(bad: Problems, spec: WalkerSpec, names: ModelNames) -> None:
    """The feet, the hip and the impact points are points of the multibody."""
    mb, points = names.multibody, names.point_names
    for f in spec.feet:
        if f.point not in points:
            bad.add(f"foot {f.name!r}: point {f.point!r} is not a point of the multibody "
                    f"{mb!r}; points: {', '.join(names.points)}", "feet", f.name)
    if spec.hip and spec.hip not in points:
        bad.add(f"[walker] hip {spec.hip!r} is not a point of the multibody {mb!r}", "hip")
    if not spec.hip and any(r.impact is not None for r in spec.rules):
        bad.add(f"[walker] hip is missing: a walker with impact rules needs it, the point of the "
                f"multibody {mb!r} at the hip (the free base of the impacts' model)", "hip")
    for i, r in enumerate(spec.rules):
        if r.impact is None:
            continue
        where = f"[[walker.rules]] #{i + 1}"
        if r.impact not in points:
            bad.add(f"{where}: impact point {r.impact!r} is not a point of the multibody",
                    "rules", i, "impact")
        if names.root_joint is None:
            bad.add(f"{where}: an impact releases the pinned root joint: the multibody needs "
                    "one revolute joint from 'world'", "rules", i, "impact")
        else:
            _check_floating_constraints(bad, spec, names, where, i)
    for i, r in enumerate(spec.rules):
        if r.engage and r.engage.partition(".")[0] != mb:
            bad.add(f"[[walker.rules]] #{i + 1}: engage {r.engage!r} is not a constraint of the "
                    f"walker's multibody {mb!r}", "rules", i, "engage")


def _check_floating_constraints(bad: Problems, spec: WalkerSpec, names: ModelNames, where: str,
                                i: int) -> None:
    """An impact rule's multibody may have loops and constraints (their active rows join the
    impact) only away from the pinned root body and the joints on it: the impact releases the
    root, re-hangs those joints from a free base at the hip and moves the root body's frame
    there (:func:`~.resets.floating_model`), so a loop or lock written in those frames would
    change meaning."""
    if spec.frozen is None:           # walker_plan refuses a spec without it
        return
    comp = spec.frozen.components[names.multibody]
    joints = comp.value("joints")
    root_body = joints[names.root_joint]["child"]
    on_root = {j for j, d in joints.items() if d.get("parent") == root_body} | {names.root_joint}
    for table in ("constraints", "loops"):
        for name, entry in (comp.value(table) or {}).items():
            touches = ({entry.get("parent"), entry.get("child"), entry.get("body")} & {root_body}
                       or entry.get("joint") in on_root)
            if touches:
                bad.add(f"{where}: the impact releases the pinned root joint "
                        f"{names.root_joint!r}, but {table[:-1]} {name!r} is written on the root "
                        f"body {root_body!r} or a joint on it; attach it to other bodies (the "
                        "swing leg's) or make the rule's impact a plain point impact without it",
                        "rules", i, "impact")


def _check_section(bad: Problems, spec: WalkerSpec, names: ModelNames) -> None:
    """The section's coordinates, completions and guess name states, rates and defined
    quantities, and fix every joint rate."""
    sec, mb = spec.section, names.multibody
    q_states, rates = names.position_states, names.rates
    defined = set()
    for c in sec.complete:
        if c.such_that is not None:
            defined |= {side for side in parse_equation(c.such_that) if side in sec.coordinates}
    wrong = [n for n in sec.coordinates if n not in q_states and n not in rates and n not in defined]
    for name in wrong:
        bad.add(f"section coordinate {name!r} is not a state of the model"
                f"{suggestion(name, [*q_states, *rates])}: a section coordinate is a state "
                f"({', '.join(q_states[:4])}, ...), a joint rate ({mb}.v.<joint>), or a "
                "quantity a such_that completion defines", "section", "coordinates")
    if wrong:          # what follows reads the section's coordinates: one report is enough
        bad.raise_if_any()
    for k, _ in spec.guess:
        if k not in sec.coordinates:
            bad.add(f"guess of {k!r}: not a section coordinate", "guess", k)
    unguessed = [n for n in sec.coordinates if n not in dict(spec.guess)]
    if spec.guess and unguessed:
        bad.add(f"[walker.guess] gives no value for the section coordinate(s) "
                f"{', '.join(unguessed)}", "guess")
    for c in sec.complete:
        if c.coordinate not in q_states and c.coordinate not in rates:
            bad.add(f"completion of {c.coordinate!r}: not a state coordinate of the model",
                    "section", "complete", c.coordinate)
    given = set(sec.coordinates) | {c.coordinate for c in sec.complete}
    missing = [r for r in rates if r not in given]
    if missing:
        bad.add(f"the section does not fix the rate(s) {', '.join(missing)}: give them as section "
                "coordinates or completions", "section")


def _linear(expr: sp.Expr, variables: list[sp.Symbol],
            constants: Iterable[sp.Symbol] = ()) -> tuple[list[float], float | str] | None:
    """(coefficients, constant) of an expression that is affine in ``variables`` with numeric
    coefficients, else None. The constant is a number, or (when it depends on the symbols
    ``constants``, e.g. parameters) the text of its expression."""
    import sympy as sp

    coeffs = []
    for v in variables:
        d = sp.diff(expr, v)
        if d.free_symbols:
            return None
        coeffs.append(float(d))
    rest = sp.sympify(expr).xreplace({v: sp.Integer(0) for v in variables})
    if rest.free_symbols - set(constants):
        return None
    return coeffs, (float(rest) if rest.is_number else str(rest))


def _symbols(names: Iterable[str]) -> list[sp.Symbol]:
    import sympy as sp

    return [sp.Symbol(n, real=True) for n in names]


def _thesis(bad: Problems, spec: WalkerSpec, parsed: Parsed, names: ModelNames) -> tuple[
        tuple[tuple[float, ...], ...], tuple[tuple[float, ...], ...]]:
    """The section -> thesis matrix and its inverse (exact: the maps are rational); identity
    without a thesis."""
    coords = spec.section.coordinates
    eye = tuple(tuple(1.0 if i == j else 0.0 for j in range(len(coords)))
                for i in range(len(coords)))
    if not spec.section.thesis:
        return eye, eye
    zsyms = _symbols(coords)
    rows = []
    for k, expr in parsed.thesis:
        ok = _check_names(bad, expr, coords, names.params)
        lin = _linear(expr.value, zsyms) if ok else None
        if ok and (lin is None or lin[1] != 0):
            bad.add(f"thesis coordinate {k!r} = {expr.text!r} must be {_NONLINEAR} of the "
                    "section coordinates without a constant", "section", "thesis")
        rows.append(lin[0] if lin else [0.0] * len(zsyms))
    import sympy as sp

    T = sp.Matrix([[sp.nsimplify(c) for c in row] for row in rows])
    if len(rows) != len(zsyms) or T.det() == 0:
        if len(rows) == len(zsyms):
            bad.add("the thesis's section coordinates are not an invertible map of the section's",
                    "section", "thesis")
        return tuple(map(tuple, rows)), eye
    return tuple(map(tuple, rows)), tuple(map(tuple, T.inv().applyfunc(float).tolist()))


def _angles(bad: Problems, parsed: Parsed, names: ModelNames) -> dict[str, tuple[float, ...]]:
    """θ, φ as coefficients over the multibody coordinates."""
    coords = [f"{names.multibody}.q.{c}" for c in names.coordinates]
    qsyms = _symbols(coords)
    out = {}
    for k, expr in parsed.angles:
        if not _check_names(bad, expr, coords, names.params):
            continue
        lin = _linear(expr.value, qsyms)
        if lin is None:
            bad.add(f"angle {k!r} = {expr.text!r} must be {_NONLINEAR} of the multibody "
                    "coordinates", "angles", k)
            continue
        out[k] = tuple(lin[0])
    return out


def _relabel(bad: Problems, spec: WalkerSpec, parsed: Parsed,
             names: ModelNames) -> RelabelMap | None:
    """The relabelling: an invertible affine map of the position states and the modes, each
    kind mapped among its own (offsets: numbers, or expressions in parameters)."""
    if not parsed.relabel:
        return None
    modes = list(spec.mode_names)
    q_states = names.position_states
    space = [*q_states, *modes]
    syms = _symbols(space)
    params = _symbols(names.params)
    index = {n: i for i, n in enumerate(space)}
    coord_names = {f"{names.multibody}.q.{c}" for c in names.coordinates}
    A = [[1.0 if i == j else 0.0 for j in range(len(space))] for i in range(len(space))]
    b: list[float | str] = [0.0] * len(space)
    ok = True
    for k, expr in parsed.relabel:
        if k not in index:
            bad.add(f"relabel {k!r}: not a state coordinate or mode of the model"
                    f"{suggestion(k, space)}", "relabel", k)
            ok = False
            continue
        if not _check_names(bad, expr, q_states, names.params):
            ok = False
            continue
        lin = _linear(expr.value, syms, params)
        if lin is None:
            bad.add(f"relabel {k!r} = {expr.text!r} must be {_NONLINEAR} of the coordinates (a "
                    "signed permutation for a symmetric walker)", "relabel", k)
            ok = False
            continue
        kind = k in modes
        if any(c and ((space[j] in modes) != kind or (k in coord_names) != (space[j] in coord_names))
               for j, c in enumerate(lin[0])):
            bad.add(f"relabel {k!r} = {expr.text!r} mixes multibody coordinates, other states "
                    "and modes: each maps among its own kind", "relabel", k)
            ok = False
        A[index[k]], b[index[k]] = lin[0], lin[1]
    if ok and abs(_det(A)) < 1e-12:
        culprit = _repeated(A, index, [k for k, _ in spec.relabel], space)
        bad.add(f"the relabelling is not a permutation of the coordinates (nor any invertible "
                f"map): {culprit!r} = {dict(spec.relabel)[culprit]!r} gives a value another "
                "coordinate already gets", "relabel", culprit)
    return RelabelMap(tuple(space), tuple(map(tuple, A)), tuple(b))


def _repeated(A: list[list[float]], index: dict[str, int], named: list[str],
              space: list[str]) -> str:
    """The first relabelled coordinate whose row repeats what the others give."""
    rows = [A[i] for i, n in enumerate(space) if n not in named]
    for k in named:
        rank = np.linalg.matrix_rank(np.array(rows)) if rows else 0
        rows.append(A[index[k]])
        if np.linalg.matrix_rank(np.array(rows)) == rank:
            return k
    return named[-1]


def _det(rows: list[list[float]]) -> float:
    return float(np.linalg.det(np.array(rows, dtype=float))) if rows else 1.0


# --- the parameters ------------------------------------------------------------------------------
#: a component's constraint on one parameter, as the interval it allows (rule, closed end)
_ALLOWS = {">": ("low", False), ">=": ("low", True), "<=": ("high", True)}


def _constraint_bounds(constraints: Sequence[Constraint],
                       params: Iterable[str]) -> dict[str, list[tuple[Constraint, float]]]:
    """The components' constraints that bound one parameter by a number (``m_leg > 0``), by
    parameter. (Relations between arguments and bounds on expressions stay with the compiled
    model's check of every parameter vector.)"""
    out: dict[str, list[tuple[Constraint, float]]] = {}
    names = set(params)
    for c in constraints:
        if c.bound_name or c.rule not in _ALLOWS or c.expression.strip() not in names:
            continue
        try:
            bound = float(c.bound)
        except ValueError:
            continue
        if math.isfinite(bound):
            out.setdefault(c.expression.strip(), []).append((c, bound))
    return out


def _refused(interval: Interval, rule: str, bound: float) -> str | None:
    """What of ``interval`` the constraint ``value rule bound`` refuses (text), or None."""
    side, closed = _ALLOWS[rule]
    if side == "low":
        if interval.low < bound:
            return f"< {bound:g}"
        return f"= {bound:g}" if interval.low == bound and interval.low_closed and not closed else None
    if interval.high > bound:
        return f"> {bound:g}"
    return None


def _tightened(interval: Interval, rule: str, bound: float) -> Interval:
    """``interval`` narrowed to what the constraint ``value rule bound`` allows."""
    side, closed = _ALLOWS[rule]
    if side == "low" and (bound > interval.low or (bound == interval.low and not closed)):
        return interval._replace(low=bound, low_closed=closed)
    if side == "high" and bound < interval.high:
        return interval._replace(high=bound, high_closed=closed)
    return interval


def _interval_text(interval: Interval) -> str:
    lo, hi = ("[" if interval.low_closed else "("), ("]" if interval.high_closed else ")")
    return (f"{lo}{interval.low:g}, {interval.high:g}{hi}"
            + (" integer" if interval.integer else ""))


def _parameters(bad: Problems, spec: WalkerSpec, frozen: ModelDescription,
                ranges: Sequence[tuple[str, Interval]],
                constraints: Sequence[Constraint]) -> dict[str, ParameterSpec]:
    """The user-settable parameters (the model's, less the modes) with their ranges: one
    parameter system. A ``[walker.ranges]`` entry must not admit a value a component's
    constraint refuses (``m_leg`` in [0, inf) where a body's mass must be > 0: a problem naming
    both and the range to write); a parameter without an entry gets the range its components'
    constraints allow."""
    given = dict(ranges)
    texts = dict(spec.ranges)
    modes = set(spec.mode_names)
    bounds = _constraint_bounds(constraints, frozen.parameters)
    out = {}
    for name, par in frozen.parameters.items():
        if name in modes:
            continue
        interval = given.get(name, Interval(-math.inf, math.inf, False, False, False))
        allowed, limits = interval, []
        refusals: dict[str, list[str]] = {}
        for c, bound in bounds.get(name, ()):
            rule = f"component {c.component!r} {c.argument} must be {c.rule} {bound:g}"
            refused = _refused(interval, c.rule, bound) if name in given else None
            if refused:
                refusals.setdefault(refused, []).append(rule)
            if _tightened(allowed, c.rule, bound) != allowed:
                allowed = _tightened(allowed, c.rule, bound)
                limits.append(rule)
        for refused, rules in refusals.items():
            bad.add(f"range of {name!r} {texts[name]!r} admits {name} {refused}, which the "
                    f"components refuse ({'; '.join(rules)}); write "
                    f"{_interval_text(allowed)!r}", "ranges", name)
        low, high, low_closed, high_closed, integer = allowed
        out[name] = ParameterSpec(name, par.value, par.unit, par.doc, "", low, high, low_closed,
                                  high_closed, integer, "; ".join(limits))
    return out

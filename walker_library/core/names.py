"""The names a walker's model provides, and the checks of its description against them.

:class:`ModelNames` lists what the compiled model will have (from the model's symbolic form,
:func:`porthamiltonian.symbolic`, without compiling it); :func:`check_names` parses every
expression of a :class:`~.hybrid.WalkerSpec` — the events' guards, the rules' conditions and
values, the completions, the guess — over those names, and checks that the section's
coordinates are states, that the thesis's coordinates and the angles are linear, and that the
relabelling is an invertible linear map (a signed permutation for a symmetric walker). It returns
those linear maps for :mod:`walker_library.core`; every problem is collected and raised as one
:class:`~porthamiltonian.errors.ModelFileError` naming the file, the line and the part.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from porthamiltonian import Model
from porthamiltonian.errors import ModelError
from porthamiltonian.modeling.expressions import parse

from .hybrid import Problems, WalkerSpec, parse_condition, parse_equation, suggestion

__all__ = ["ModelNames", "check_names"]


@dataclass(frozen=True)
class ModelNames:
    """The names a model provides once compiled (from :func:`porthamiltonian.symbolic`):
    parameters, states, outputs (port variables and component outputs), the multibody's name,
    its coordinates (``<mb>.q.<c>`` without the prefix), its points and its pinned root joint
    (a revolute joint from the world, if it has exactly one)."""

    params: tuple[str, ...]
    states: tuple[str, ...]
    outputs: tuple[str, ...]
    multibody: str
    coordinates: tuple[str, ...]
    points: tuple[str, ...]
    root_joint: str | None

    @classmethod
    def of(cls, model: Model, params: Sequence[str], states: Sequence[str],
           outputs: Sequence[str]) -> ModelNames:
        """The names of ``model`` given those its compiled form declares: parameters, states
        and outputs (:class:`porthamiltonian.compiler.SymbolicModel`'s ``param_names``,
        ``state_names`` and ``outputs``)."""
        from porthamiltonian import Multibody
        mbs = [name for name, c in model.components() if isinstance(c, Multibody)]
        mb = mbs[0] if len(mbs) == 1 else ""
        coords = tuple(s[len(mb) + 3:] for s in states if mb and s.startswith(f"{mb}.q."))
        points, root = (), None
        if mb:
            comp = model.component(mb)
            bodies, joints = comp.value("bodies"), comp.value("joints")
            points = tuple(p for b in bodies.values() for p in (b.get("points") or {}))
            roots = [j for j, d in joints.items() if d.get("parent") == "world"]
            root = roots[0] if len(roots) == 1 and joints[roots[0]].get("type") == "revolute" \
                else None
        return cls(tuple(params), tuple(states), tuple(outputs), mb, coords, points, root)


_NONLINEAR = "a linear expression"


def _linear(expr: sp.Expr, variables: list[sp.Symbol],
            constants: Iterable[sp.Symbol] = ()) -> tuple[list[float], float | str] | None:
    """(coefficients, constant) of an expression that is affine in ``variables`` with numeric
    coefficients, else None. The constant is a number, or (when it depends on the symbols
    ``constants``, e.g. parameters) the text of its expression."""
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


def check_names(spec: WalkerSpec, names: ModelNames, text: str = "") -> dict[str, Any]:
    """Check every name and expression of ``spec`` against the model's ``names``; return the
    linear maps the core needs (``relabel``: matrix and offsets — numbers, or expressions in
    parameters — over state coordinates and modes;
    ``thesis``: the section -> thesis matrix; ``angles``: coefficients over the multibody
    coordinates). Raises one ModelFileError listing every problem (file, line, part)."""
    bad = Problems(spec.source, text)
    params = {p: sp.Symbol(p, real=True) for p in names.params}
    known = set(names.states) | set(names.outputs)

    def dotted(ref: str) -> sp.Symbol | None:
        return sp.Symbol(ref, real=True) if ref in known else None

    def check(value: Any, where: str, *path, extra: Mapping[str, sp.Symbol] | None = None,
              resolve=dotted) -> sp.Expr | None:
        try:
            return parse(value, {**params, **(extra or {})}, where, resolve)
        except ModelError as err:
            bad.add(str(err).replace("(declare model parameters under [parameters])",
                                     "(outputs, states and parameters of the model)"), *path)
            return None

    if not names.multibody:
        bad.add("a walker's model needs exactly one Multibody component (its bodies and joints)")
        bad.raise_if_any()
    mb = names.multibody
    # events: their guards read the model's outputs (compiled-to-be names)
    for i, ev in enumerate(spec.model.events):
        try:
            parse(ev.guard, params, f"event {ev.name!r} guard", dotted)
        except ModelError as err:
            bad.add(f"{err}; a guard may read the model's outputs, states and parameters",
                    i, "guard", table="events")
    for f in spec.feet:
        if f.point not in {f"{mb}.{p}" for p in names.points}:
            bad.add(f"foot {f.name!r}: point {f.point!r} is not a point of the multibody "
                    f"{mb!r}; points: {', '.join(names.points)}", "feet", f.name)
    if spec.hip and spec.hip not in {f"{mb}.{p}" for p in names.points}:
        bad.add(f"[walker] hip {spec.hip!r} is not a point of the multibody {mb!r}", "hip")
    for k, v in spec.modes:
        check(v, f"mode {k!r} start value", "modes", k)
    for i, r in enumerate(spec.rules):
        where = f"[[walker.rules]] #{i + 1}"
        for cond in r.when:
            lhs, _, rhs = parse_condition(cond)
            for side in (lhs, rhs):
                check(side, f"{where} condition {cond!r}", "rules", i, "if")
        for k, v in r.set:
            check(v, f"{where} set {k!r}", "rules", i, "set")
        if r.impact is not None:
            if r.impact not in {f"{mb}.{p}" for p in names.points}:
                bad.add(f"{where}: impact point {r.impact!r} is not a point of the multibody",
                        "rules", i, "impact")
            if names.root_joint is None:
                bad.add(f"{where}: an impact releases the pinned root joint: the multibody needs "
                        "one revolute joint from 'world'", "rules", i, "impact")
    if "g" not in params:
        bad.add("the walker's weight (the cost of transport) is [walker] mass times the "
                "parameter g: declare g (m/s^2) under [parameters]", "mass")
    for expr, where, path in ((spec.mass, "[walker] mass", ("mass",)),
                              (spec.leg_length, "[walker] leg_length", ("leg_length",))):
        parsed = check(expr, where, *path, resolve=lambda ref: None)
        if parsed is not None and parsed.free_symbols - set(params.values()):
            bad.add(f"{where} must depend on parameters only", *path)
    helpers: dict[str, sp.Expr] = {}
    for k, v in spec.guess_where:
        parsed = check(v, f"guess helper {k!r}", "guess", "where", k, extra=helpers,
                       resolve=lambda ref: None)
        if parsed is not None:
            helpers[k] = parsed
    for k, v in spec.guess:
        check(v, f"guess of {k!r}", "guess", k, extra=helpers, resolve=lambda ref: None)

    # coordinates
    q_states = [s for s in names.states if not s.startswith(f"{mb}.p.")]
    coord_names = [f"{mb}.q.{c}" for c in names.coordinates]
    rates = [f"{mb}.v.{c}" for c in names.coordinates]
    defined = set()
    for c in spec.section.complete:
        if c.such_that is not None:
            lhs, rhs = parse_equation(c.such_that)
            defined |= {side for side in (lhs, rhs) if side in spec.section.coordinates}
    wrong = [n for n in spec.section.coordinates
             if n not in q_states and n not in rates and n not in defined]
    for name in wrong:
        bad.add(f"section coordinate {name!r} is not a state of the model"
                f"{suggestion(name, [*q_states, *rates])}: a section coordinate is a state "
                f"({', '.join(q_states[:4])}, ...), a joint rate ({mb}.v.<joint>), or a "
                "quantity a such_that completion defines", "section", "coordinates")
    if wrong:          # what follows reads the section's coordinates: one report is enough
        bad.raise_if_any()
    for k, _ in spec.guess:
        if k not in spec.section.coordinates:
            bad.add(f"guess of {k!r}: not a section coordinate", "guess", k)
    unguessed = [n for n in spec.section.coordinates if n not in dict(spec.guess)]
    if spec.guess and unguessed:
        bad.add(f"[walker.guess] gives no value for the section coordinate(s) "
                f"{', '.join(unguessed)}", "guess")
    for c in spec.section.complete:
        if c.coordinate not in q_states and c.coordinate not in rates:
            bad.add(f"completion of {c.coordinate!r}: not a state coordinate of the model",
                    "section", "complete", c.coordinate)
        if c.such_that is not None:
            for side in parse_equation(c.such_that):
                if side not in spec.section.coordinates:
                    check(side, f"completion of {c.coordinate!r}", "section", "complete",
                          c.coordinate)
        else:
            check(c.value, f"completion of {c.coordinate!r}", "section", "complete", c.coordinate)
    if spec.section.labelling:
        for side in parse_condition(spec.section.labelling)[::2]:
            check(side, "[walker.section] labelling", "section", "labelling")
    given = set(spec.section.coordinates) | {c.coordinate for c in spec.section.complete}
    missing = [r for r in rates if r not in given]
    if missing:
        bad.add(f"the section does not fix the rate(s) {', '.join(missing)}: give them as section "
                "coordinates or completions", "section")

    out: dict[str, Any] = {}
    # the thesis's section coordinates: linear, invertible
    zsyms = {n: sp.Symbol(f"__z{i}", real=True) for i, n in enumerate(spec.section.coordinates)}
    if spec.section.thesis:
        rows = []
        for k, v in spec.section.thesis:
            expr = check(v, f"thesis coordinate {k!r}", "section", "thesis",
                         extra={n: z for n, z in zsyms.items() if "." not in n},
                         resolve=lambda ref: zsyms.get(ref))
            lin = None if expr is None else _linear(expr, list(zsyms.values()))
            if expr is not None and (lin is None or lin[1] != 0):
                bad.add(f"thesis coordinate {k!r} = {v!r} must be {_NONLINEAR} of the section "
                        "coordinates without a constant", "section", "thesis")
            rows.append(lin[0] if lin else [0.0] * len(zsyms))
        T = sp.Matrix([[sp.nsimplify(c) for c in row] for row in rows])
        if len(rows) == len(zsyms) and T.det() == 0:
            bad.add("the thesis's section coordinates are not an invertible map of the section's",
                    "section", "thesis")
            T = None
        out["thesis"] = rows
        # the inverse, exact (the maps are rational): from_thesis(to_thesis(z)) == z
        out["thesis_inverse"] = (T.inv().applyfunc(float).tolist()
                                 if T is not None and len(rows) == len(zsyms) else None)
    # angles: linear in the multibody coordinates
    qsyms = {n: sp.Symbol(f"__q{i}", real=True) for i, n in enumerate(coord_names)}
    angle_rows = {}
    for k, v in spec.angles:
        expr = check(v, f"angle {k!r}", "angles", k, resolve=lambda ref: qsyms.get(ref))
        lin = None if expr is None else _linear(expr, list(qsyms.values()))
        if expr is not None and lin is None:
            bad.add(f"angle {k!r} = {v!r} must be {_NONLINEAR} of the multibody coordinates",
                    "angles", k)
        angle_rows[k] = lin
    out["angles"] = angle_rows
    # relabelling: an invertible affine map of state coordinates and modes
    if spec.relabel:
        modes = list(spec.mode_names)
        space = [*q_states, *modes]
        syms = {n: sp.Symbol(f"__r{i}", real=True) for i, n in enumerate(space)}
        index = {n: i for i, n in enumerate(space)}
        A = [[1.0 if i == j else 0.0 for j in range(len(space))] for i in range(len(space))]
        b = [0.0] * len(space)
        ok = True
        for k, v in spec.relabel:
            if k not in index:
                bad.add(f"relabel {k!r}: not a state coordinate or mode of the model"
                        f"{suggestion(k, space)}", "relabel", k)
                ok = False
                continue
            expr = check(v, f"relabel {k!r}", "relabel", k, resolve=lambda ref: syms.get(ref),
                         extra={m: syms[m] for m in modes})
            lin = None if expr is None else _linear(expr, list(syms.values()), params.values())
            if expr is not None and lin is None:
                bad.add(f"relabel {k!r} = {v!r} must be {_NONLINEAR} of the coordinates (a signed "
                        "permutation for a symmetric walker)", "relabel", k)
            if lin is None:
                ok = False
                continue
            kind = k in modes
            for j, c in enumerate(lin[0]):
                if c and ((space[j] in modes) != kind or
                          (k in coord_names) != (space[j] in coord_names)):
                    bad.add(f"relabel {k!r} = {v!r} mixes multibody coordinates, other states "
                            "and modes: each maps among its own kind", "relabel", k)
                    ok = False
                    break
            A[index[k]], b[index[k]] = lin[0], lin[1]
        if ok and abs(_det(A)) < 1e-12:
            named = [k for k, _ in spec.relabel]
            rows = [A[i] for i, n in enumerate(space) if n not in named]
            culprit = named[-1]
            for k in named:                   # the first entry that repeats what others give
                rank = np.linalg.matrix_rank(np.array(rows)) if rows else 0
                rows.append(A[index[k]])
                if np.linalg.matrix_rank(np.array(rows)) == rank:
                    culprit = k
                    break
            bad.add(f"the relabelling is not a permutation of the coordinates (nor any invertible "
                    f"map): {culprit!r} = {dict(spec.relabel)[culprit]!r} gives a value another "
                    "coordinate already gets", "relabel", culprit)
        out["relabel"] = (space, A, b)
    bad.raise_if_any()
    return out


def _det(rows: list[list[float]]) -> float:
    return float(np.linalg.det(np.array(rows, dtype=float))) if rows else 1.0

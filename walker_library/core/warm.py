"""A walker's warm start: its plan kept as plain data, restored without sympy or networkx.

Loading a walker file (:func:`~.files.load_walker`) reads the model (its components' laws built
with sympy, its graph with networkx), reads and parses the ``[walker]`` table, checks the plan
and compiles the model: about a second before the first stride, where the walk itself takes
milliseconds. What a walk needs of all that is plain data: the plan's records (:mod:`.plan`:
names, the section's maps, the rules as transitions, the parameters and their ranges), the
table as read (:class:`~.hybrid.WalkerSpec` without its model) and the compiled models' cache
keys. :func:`keep` stores them after a load as a snapshot
(:func:`porthamiltonian.compiler.remember`: JSON in the compiled-model cache, verified by its
sha256, keyed by the file's text and path, the back end asked for, the package's version and
sources and the C compiler); :func:`restore` rebuilds the walker from it and reopens its compiled
models (:func:`porthamiltonian.compiler.reopen`), importing neither sympy nor networkx.

A restored walker is the walker the file gives, with three parts read when first used: the
model (``walker.spec.model``), the model's description with the walker's outputs
(``walker.plan.description``) and the floating multibody of a rigid walker's impact
(``walker.plan.floating.model``) stand for the same objects of the file's full read (of the
text the snapshot was keyed by, not of the file as it may be by then), done on the first access
to one of them (e.g. by a report's figures). Nothing that a walk, a gait analysis or a sweep case
reads needs them.

The snapshot is data: its records are rebuilt from a fixed list of record classes
(:data:`RECORDS`) with their field names, expressions from text by the expression parser; a
document that does not fit is ignored (the walker is loaded the long way and a new snapshot
stored). Only walkers whose components all come from the package are kept: a component class
defined elsewhere (a user's) could change without the package's sources changing.
"""
from __future__ import annotations

import dataclasses
import functools
import numbers
from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import Any, cast

from porthamiltonian.backends import candidates
from porthamiltonian.compiler import (
    compiled_record,
    deferred,
    package_made,
    recall,
    remember,
    reopen,
    snapshot_key,
)
from porthamiltonian.errors import ModelError
from porthamiltonian.interfaces import io as ph_io
from porthamiltonian.modeling.expressions import Expression, parse_text

from .hybrid import Completion, Foot, Integration, Rule, Section, Terrain, WalkerSpec
from .plan import (
    BodiesMass,
    ChangePlan,
    ConditionPlan,
    ModelNames,
    Projected,
    RelabelMap,
    SectionMap,
    SolveState,
    TransitionPlan,
    WalkerPlan,
)
from .protocol import ParameterSpec
from .reading import file_spec
from .resets import Floating
from .walker import CompiledWalker, HybridWalker, bind_walker, plan_walker

__all__ = ["KIND", "RECORDS", "keep", "restore"]

#: the snapshot's kind (:func:`porthamiltonian.compiler.snapshot_key`)
KIND = "walker"
#: the record classes a snapshot may hold, by name
RECORDS: Mapping[str, type] = MappingProxyType({cls.__name__: cls for cls in (
    Foot, Rule, Completion, Section, Integration, Terrain, ModelNames, ConditionPlan, ChangePlan,
    TransitionPlan, SolveState, Projected, SectionMap, RelabelMap, ParameterSpec)})
#: the fields of a WalkerSpec kept (its model and what was read from it are not)
_SPEC_FIELDS = ("feet", "modes", "rules", "section", "angles", "terrain", "relabel", "guess",
                "guess_where", "ranges", "integration", "mass", "leg_length", "hip", "source",
                "description", "units")
#: the fields of a WalkerPlan kept as records (the spec, the description, the floating
#: multibody and the bodies' masses are kept apart)
_PLAN_FIELDS = ("names", "outputs", "section", "relabel", "transitions", "start", "guess",
                "mass", "leg_length", "drop", "parameters")


class _Unfit(Exception):
    """A snapshot document that does not hold what this version writes."""


# --- records <-> JSON ------------------------------------------------------------------------------
def _encode(value: Any) -> Any:
    """A record value as JSON data: records as ``{"@": class, "f": fields}``, mappings as
    ``{"@m": {...}}``, tuples as lists, expressions as ``{"@e": text}``."""
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, numbers.Real):            # a sympy Float of a map's coefficients
        return float(value)
    if isinstance(value, Expression):
        return {"@e": value.text}
    if dataclasses.is_dataclass(value) and type(value).__name__ in RECORDS:
        return {"@": type(value).__name__,
                "f": {f.name: _encode(getattr(value, f.name)) for f in dataclasses.fields(value)}}
    if isinstance(value, Mapping):
        return {"@m": {str(k): _encode(v) for k, v in value.items()}}
    if isinstance(value, (tuple, list)):
        return [_encode(v) for v in value]
    raise TypeError(f"a walker snapshot cannot hold {type(value).__name__}")


def _decode(value: Any) -> Any:
    """The record value of :func:`_encode`'s data (lists as tuples); _Unfit when it is not."""
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, list):
        return tuple(_decode(v) for v in value)
    if isinstance(value, dict) and len(value) == 1 and isinstance(value.get("@m"), dict):
        return MappingProxyType({k: _decode(v) for k, v in value["@m"].items()})
    if isinstance(value, dict) and len(value) == 1 and isinstance(value.get("@e"), str):
        return parse_text(value["@e"], "a walker snapshot's expression")
    if isinstance(value, dict) and set(value) == {"@", "f"} and isinstance(value["f"], dict):
        cls = RECORDS.get(value["@"]) if isinstance(value["@"], str) else None
        if cls is None or set(value["f"]) != {f.name for f in dataclasses.fields(cls)}:
            raise _Unfit(f"record {value['@']!r}")
        return cls(**{k: _decode(v) for k, v in value["f"].items()})
    raise _Unfit(type(value).__name__)


# --- the parts read when first used ---------------------------------------------------------------
def _full_read(text: str, source: str) -> Callable[[], WalkerPlan]:
    """A function giving the plan of the walker file ``text`` (read from ``source``) read in
    full, once, when first called."""

    @functools.cache
    def plan() -> WalkerPlan:
        record = ph_io.reads(text, source)
        return plan_walker(file_spec(record), record.text)

    return plan


# --- keep and restore ------------------------------------------------------------------------------
def _key(source: str, text: str, backend: str | None) -> str:
    return snapshot_key(KIND, {"source": source, "text": text, "backend": backend},
                        ("walker_library",), "auto")


def keep(walker: HybridWalker, source: str, text: str, backend: str | None) -> None:
    """Store the snapshot of ``walker``, just loaded from the file ``text`` read from ``source``
    with the back end ``backend`` asked for (None: the file's), when it can be restored as it is:
    its components all the package's, its back end the one asked for (not a fallback)."""
    plan, compiled = walker.plan, walker.compiled
    wanted = backend or plan.spec.integration.backend
    try:
        if compiled.model.backend != candidates(wanted)[0]:
            return
    except ModelError:
        return
    if not package_made(plan.description.components.values()):
        return
    try:
        data = _snapshot(plan, compiled)
    except (TypeError, ValueError):            # a record this version cannot keep: not kept
        return
    remember(_key(source, text, backend), KIND, data)


def _snapshot(plan: WalkerPlan, compiled: CompiledWalker) -> dict[str, Any]:
    """The snapshot's data of ``plan`` and ``compiled`` (module docstring)."""
    spec = plan.spec
    return {
        "name": spec.name,
        "spec": {f: _encode(getattr(spec, f)) for f in _SPEC_FIELDS},
        "plan": {f: _encode(getattr(plan, f)) for f in _PLAN_FIELDS},
        "bodies": {"masses": _encode(plan.bodies.masses), "prefix": plan.bodies.prefix,
                   "where": plan.bodies.where},
        "floating": (None if plan.floating is None else
                     {"root": plan.floating.root, "rehung": list(plan.floating.rehung)}),
        "model": compiled_record(compiled.model),
        "floating_model": (None if compiled.floating is None
                           else compiled_record(compiled.floating)),
    }


def restore(source: str, text: str, backend: str | None, *,
            values: Mapping[str, float] | None = None,
            options: Integration | None = None) -> HybridWalker | None:
    """The walker of the file ``text`` (read from ``source``; back end ``backend`` asked for,
    None: the file's) from its snapshot, with the parameter ``values`` and integrator
    ``options`` as :func:`~.files.load_walker` takes them; None when there is no usable snapshot
    (then the file is loaded in full). Imports neither sympy nor networkx."""
    try:
        key = _key(source, text, backend)
    except ModelError:
        return None
    data = recall(key, KIND)
    if data is None:
        return None
    full = _full_read(text, source)
    try:
        spec_fields = {f: _decode(data["spec"][f]) for f in _SPEC_FIELDS}
        plan_fields = {f: _decode(data["plan"][f]) for f in _PLAN_FIELDS}
        bodies = BodiesMass(_decode(data["bodies"]["masses"]), str(data["bodies"]["prefix"]),
                            str(data["bodies"]["where"]))
        name = str(data["name"])
        spec = WalkerSpec(model=deferred(lambda: full().spec.model, name=name), **spec_fields)
        floating = None
        if data["floating"] is not None:     # (then the file's full read has one too)
            floating = Floating(deferred(lambda: cast(Floating, full().floating).model),
                                str(data["floating"]["root"]),
                                tuple(str(j) for j in data["floating"]["rehung"]))
        plan = WalkerPlan(spec=spec, description=deferred(lambda: full().description),
                          floating=floating, bodies=bodies, **plan_fields)
    except (_Unfit, KeyError, TypeError, ValueError, ModelError):
        return None
    model = reopen(data["model"], lambda: full().description)
    floating_model = (None if data["floating_model"] is None
                      else reopen(data["floating_model"],
                                  lambda: cast(Floating, full().floating).model.freeze()))
    if model is None or (data["floating_model"] is not None) != (floating_model is not None):
        return None
    return HybridWalker(plan, bind_walker(plan, model, floating_model), values=values,
                        options=options or spec.integration)

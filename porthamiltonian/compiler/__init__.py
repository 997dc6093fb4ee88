"""Symbolic compiler: model graph -> port-Hamiltonian state equations + energy ledger -> code.

Pipeline: :meth:`Model.freeze` (then ``validate``) -> :func:`structure.build_system` ->
:func:`structure.solve` (causality, loops, dependent storages) -> :func:`assemble.assemble` (state
equations, H, P_diss, P_in) -> :func:`codegen.program` (cse, RHS and exact Jacobians together) ->
:mod:`.printers` (Python and C) -> cache -> back end. :mod:`.phform` derives the explicit
port-Hamiltonian form from a second, cut build of the same model (``ph=True``); its functions
are an add-on of the model's cache entry, compiled beside the model's own (:func:`_with_addon`),
as is ``out_jac`` (the declared outputs' Jacobian), built on a first linearization.
"""
from __future__ import annotations

import atexit
import contextlib
import dataclasses
import json
import os
import shlex
import sys
import time
import warnings
from collections import OrderedDict
from collections.abc import Callable, Mapping, Sequence
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, TypeVar

from .. import backends, collector
from ..backends import native
from ..errors import CompilerError, ModelError
from ..modeling.constraints import Constraint
from ..simulation.compiled import CompiledModel, EventInfo, ModelMeta
from ..simulation.sampling import DiscreteBlock
from . import cache
from .literals import printable
from .snapshots import deferred, package_made, recall, remember, snapshot_key

if TYPE_CHECKING:
    from pathlib import Path

    from ..modeling.model import Model, ModelDescription
    from .assemble import SymbolicModel
    from .codegen import Program
    from .structure import Solution

# The symbolic stages (sympy) and the model builder (networkx) are imported by the functions
# that run them: a compiled model reopened from the cache (:func:`reopen`) needs neither (nor,
# on the C back end, the Python and numba back ends' loaders).


def __getattr__(name: str) -> Any:
    """``power_balance`` and ``SymbolicModel`` (of :mod:`.assemble`), imported on first use."""
    if name in ("power_balance", "SymbolicModel"):
        from . import assemble

        return getattr(assemble, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _frozen(model: Model | ModelDescription) -> ModelDescription:
    """The frozen description of ``model`` (a model, or its description already)."""
    from ..modeling.model import Model

    return model.freeze() if isinstance(model, Model) else model

#: why the C back end failed in this process (``"auto"`` does not try to build again)
_C_FAILED: list[str] = []


@collector.paused()
def symbolic(model: Model | ModelDescription) -> SymbolicModel:
    """Run the symbolic part of the compiler (no code generation, no cache): validate the frozen
    description (every problem at once, :meth:`~porthamiltonian.modeling.model.ModelDescription.validate`),
    then structure, assembly. Errors carry the path of what they are about
    (:attr:`~porthamiltonian.errors.ModelError.path`)."""
    return _symbolic_model(_frozen(model), claim=False)


def _symbolic_model(description: ModelDescription, claim: bool) -> SymbolicModel:
    """:func:`symbolic` of a frozen description; ``claim``: for a build that reports its time
    (:func:`compile_model`), whose ``solved_earlier`` then holds the seconds of a structure
    solve an earlier call made and no build reported (:func:`_solved`)."""
    from .assemble import assemble
    from .phform import ph_form

    solution, earlier = _solved(description.validate(), claim)
    sym = assemble(solution)
    sym.ph_maker = lambda: ph_form(description, sym, _solved(description)[0])
    sym.solved_earlier = earlier
    return sym


#: the solved structures (:func:`structure.build_system` + :func:`structure.solve`, most of the
#: symbolic work) of the last models of this process, by everything but their events and model
#: outputs, which only :func:`assemble` reads: a walker asks for its model's :func:`layout` (for
#: the names its description may use), then compiles it with its own outputs (walker_library.core).
_SOLVED: OrderedDict[str, _Solved] = OrderedDict()
_SOLVED_KEPT = 4


@dataclasses.dataclass
class _Solved:
    """An entry of :data:`_SOLVED`: the component classes it was solved with, the solution, and
    the seconds its solve took while no build line has reported them (a layout's solve)."""

    classes: tuple[type, ...]
    solution: Solution
    unreported: float


def _solved(description: ModelDescription, claim: bool = False) -> tuple[Solution, float]:
    """``solve(build_system(description))``, reused from :data:`_SOLVED` when only the events
    or the model outputs differ (the component classes themselves must be the same objects),
    and the seconds of an earlier call's solve that ``claim`` (a build reporting its time, which
    counts a solve made now itself) takes over: once, so that no two build lines count them."""
    from .structure import Solution, build_system, solve

    bare = dataclasses.replace(description, events=(), outputs=MappingProxyType({}), scopes=(
        MappingProxyType({k: v for k, v in description.scopes.items()
                          if not k.startswith(("event:", "output:"))})))
    key = bare.canonical()
    classes = tuple(type(c) for c in description.components.values())
    hit = _SOLVED.get(key)
    if hit is not None and len(hit.classes) == len(classes) and all(
            a is b for a, b in zip(hit.classes, classes)):
        _SOLVED.move_to_end(key)
        earlier = hit.unreported if claim else 0.0
        if claim:
            hit.unreported = 0.0
        return Solution(dataclasses.replace(hit.solution.system, flat=description),
                        hit.solution.order), earlier
    start = time.perf_counter()
    solution = solve(build_system(description))
    _SOLVED[key] = _Solved(classes, solution, 0.0 if claim else time.perf_counter() - start)
    while len(_SOLVED) > _SOLVED_KEPT:
        _SOLVED.popitem(last=False)
    return solution, 0.0


@dataclasses.dataclass(frozen=True)
class Layout:
    """The names a model compiles to, known after the symbolic stage (no code generated):
    its parameters, states and outputs (port variables, component outputs, energy parts, model
    outputs) in the compiled model's order, and the components' constraints on parameter
    values."""

    name: str
    param_names: tuple[str, ...]
    state_names: tuple[str, ...]
    output_names: tuple[str, ...]
    constraints: tuple[Constraint, ...] = ()

    def to_json(self) -> dict[str, Any]:
        """The record as a JSON table (``layout.json`` of a cache entry)."""
        return {"name": self.name, "param_names": list(self.param_names),
                "state_names": list(self.state_names), "output_names": list(self.output_names),
                "constraints": [c.to_dict() for c in self.constraints]}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Layout:
        """The record of a :meth:`to_json` table; KeyError or TypeError when it is not one."""
        params, states, outputs = (tuple(data[k]) for k in
                                   ("param_names", "state_names", "output_names"))
        if not all(isinstance(n, str) for names in (params, states, outputs) for n in names):
            raise TypeError("a name is not a string")
        constraints = tuple(Constraint.from_dict(c) for c in data["constraints"])
        return cls(str(data["name"]), params, states, outputs, constraints)


#: the file of a cache entry holding its model's :class:`Layout`
_LAYOUT_FILE = "layout.json"


@collector.paused()
def layout(model: Model | ModelDescription, use_cache: bool = True) -> Layout:
    """The :class:`Layout` of ``model`` (a model, or its frozen description): the symbolic
    compiler's names without code generation, for checking names against a model before it is
    compiled (a walker's description). Kept in the model's cache entry (``layout.json``,
    verified by its sha256 like every cached file), so that a model seen before needs no
    symbolic work; the solved structure is reused by the compile that usually follows
    (:func:`_solved`). Raises the model's errors as :func:`symbolic` does."""
    description = _frozen(model)
    key = cache.model_key(description)
    stored = cache.load_verified(key, _LAYOUT_FILE) if use_cache else None
    if stored is not None:
        try:
            return Layout.from_json(json.loads(stored))
        except (KeyError, TypeError, ValueError, AttributeError):
            pass                          # another version's file: computed and written again
    sym = symbolic(description)
    found = Layout(sym.name, tuple(sym.param_names), tuple(sym.state_names), tuple(sym.outputs),
                   tuple(sym.constraints))
    if use_cache:
        cache.store(key, _LAYOUT_FILE, json.dumps(found.to_json(), indent=1))
    return found


@collector.paused()
def compile_model(model: Model | ModelDescription, backend: str = "auto",
                  use_cache: bool = True, *, jac_p: Sequence[str] | None = None,
                  ph: bool = False) -> CompiledModel:
    """Compile ``model`` (a model, or its frozen description) for numeric simulation.

    Parameters
    ----------
    backend : ``"auto"`` (``"c"`` when a C compiler works or the model's library is cached, else
        numba when installed, else python — with a one-line :class:`~porthamiltonian.backends.
        BackendWarning` saying why C is not used; ``$PORTHAMILTONIAN_BACKEND`` may name the
        back end ``"auto"`` means), ``"c"``, ``"numba"`` or ``"python"``.
    use_cache : reuse and store the generated code (and the C library) in the on-disk cache
        (keyed by a model hash; see :mod:`porthamiltonian.compiler.cache`); ``False`` writes
        nothing there (everything is built in a private temporary folder removed at exit).

    A build that does work prints one line on stderr (``building NAME: symbolic 0.3 s, code
    0.6 s, C 0.7 s, 41 kB``; none when everything came from the cache, none when
    ``$PORTHAMILTONIAN_QUIET`` is set). With ``backend="c"``, a missing or failing C compiler
    raises :class:`~porthamiltonian.errors.CompilerError` (the command and the file holding
    its output).
    jac_p : parameter names: also generate ``jac_p``, the exact ∂ẋ/∂p by those parameters
        (``CompiledModel.parameter_jacobian``; :func:`.codegen.jacobian_function`).
    ph : also generate the explicit port-Hamiltonian form (:mod:`.phform`): the matrices and the
        vector [∇H; z; u] at a point (``CompiledModel.ph_matrices``; a compiled model asks for
        them itself, once, when they are first needed). Its functions are an add-on of the
        model's cache entry (:func:`_with_addon`): generated and compiled on their own, into a
        library (or module) beside the model's, which is not built again; a build of the
        add-on prints a line of its own (``building NAME, port-Hamiltonian form: ...``).
    """
    from ..modeling.model import Model, ModelDescription

    if not isinstance(model, (Model, ModelDescription)):
        hint = (f"; to compile a model file, read it first: compile_model(io.load({model!r}))"
                if isinstance(model, str) else "")
        raise ModelError(f"compile_model takes a Model (or its ModelDescription), got "
                         f"{type(model).__name__} {model!r:.80}{hint}")
    order = backends.candidates(backend)
    description = _frozen(model)
    key = cache.model_key(description, {"jac_p": list(jac_p)} if jac_p else None)
    meta, bodies = _cached(key) if use_cache else (None, {})
    times: dict[str, float] = {}
    pending: dict[str, native.Pending] = {}     # the C compiles running in the background
    prog = sym = None
    with contextlib.ExitStack() as held:
        if meta is None and use_cache:
            held.enter_context(cache.building(key))    # one process builds, the others wait
            meta, bodies = _cached(key)                # built by another while this one waited
        held.callback(_close_all, pending)
        if meta is None:
            from . import estimate
            from .printers import c_source

            estimate.check(description, backends.report)      # refused, or announced, before work
            if order[0] == "c":             # the loops compile while the code is made
                _prepare_loops(use_cache)
            start = time.perf_counter()
            sym = _symbolic_model(description, claim=True)
            # (with the part of it a layout of this model did before: a walker's)
            times["symbolic"] = time.perf_counter() - start + sym.solved_earlier
            compiles = order[0] == "c" and not _C_FAILED
            start = time.perf_counter()
            prog = _program(sym, jac_p)
            bodies = {"c": c_source(prog)}          # the Python body: when a back end needs it
            times["code"] = time.perf_counter() - start
            if compiles:                   # the model's units compile while the rest is done
                pending.update(_start_units(bodies["c"], key))
            meta = _meta(sym, prog, jac_p)
            if use_cache:
                cache.write(key, meta.to_json(), bodies)

        def load(name: str) -> backends.Functions:
            nonlocal sym
            if name != "c" and "python" not in bodies:
                bodies["python"], made = _python_body(key, description, prog, jac_p, use_cache,
                                                      times)
                sym = sym or made                   # for the add-on below, not made again
            return _load(name, key, meta, bodies, use_cache, times, explicit=len(order) == 1,
                         pending=pending)

        name, functions = _first_that_loads(order, load)
    _report(meta.name, times, bodies["c" if name == "c" else "python"], name)
    docs = {par_name: par.doc for par_name, par in description.parameters.items()}
    compiled = CompiledModel(meta, functions, bodies["c" if name == "c" else "python"], key,
                             c_source=bodies["c"],
                             param_docs=[docs.get(n, "") for n in meta.param_names],
                             input_docs=[description.inputs[n].doc for n in meta.input_names],
                             output_expressions={n: description.outputs[n]
                                                 for n in meta.declared_outputs
                                                 if n in description.outputs},
                             rebuild=_rebuilder(lambda: description, backend, use_cache,
                                                list(jac_p or [])))
    if ph:
        compiled = _with_addon(compiled, _PH, lambda: description, use_cache, order, sym)
    return compiled


def _rebuilder(description: Callable[[], ModelDescription], backend: str, use_cache: bool,
               jac_p: list[str]) -> Callable[..., CompiledModel]:
    """A compiled model's ``rebuild`` (:meth:`CompiledModel.extended`): the model with more
    generated functions. Add-ons alone (``ph=True``, ``out_jac=True``: :data:`_ADDONS`) are
    added to the model as it is (:func:`_with_addon`); other options (``jac_p``) compile the
    model again, with its form when it has it (``description()``: its description, made when
    first needed)."""
    def rebuild(model: CompiledModel, **more: Any) -> CompiledModel:
        if more.keys() <= _ADDONS.keys():
            for name in _ADDONS:
                if more.get(name):
                    model = _with_addon(model, name, description, use_cache,
                                        backends.candidates(backend))
            return model
        merged: dict[str, Any] = {"jac_p": jac_p, "ph": model.ph_layout is not None, **more}
        return compile_model(description(), backend=backend, use_cache=use_cache, **merged)
    return rebuild


def _report(model: str, times: Mapping[str, float], body: str | None = None, backend: str = "",
            what: str = "") -> None:
    """The build line on stderr when ``times`` holds work (none when everything came from the
    cache): ``building NAME[, what]: symbolic 0.3 s, code 0.6 s, C 0.7 s, 41 kB`` (the size of
    ``body``, the code the back end ``backend`` runs, when given)."""
    if not times:
        return
    parts = [f"{k} {v:.1f} s" for k, v in times.items()]
    if body is not None:
        note = " (numba compiles it at the first call)" if backend == "numba" else ""
        parts[-1] += f", {len(body.encode()) / 1000:.0f} kB{note}"
    backends.report(f"building {printable(model)}{f', {what}' if what else ''}: "
                    f"{', '.join(parts)}")


#: the name of the port-Hamiltonian form's add-on (:func:`_with_addon`)
_PH = "ph"
#: the add-ons of a model's cache entry (:func:`_with_addon`), by name: what their build line
#: calls them
_ADDONS = {_PH: "port-Hamiltonian form", "out_jac": "output Jacobian"}


@dataclasses.dataclass(frozen=True)
class _AddOn:
    """An add-on of a model's cache entry: functions generated from the model after its own
    ones and compiled beside them, never into the model's library (:func:`_with_addon`).
    ``name`` (:data:`_ADDONS`); ``shapes``: the result shape of each of its functions;
    ``layout``: what the port-Hamiltonian form's adds to the model's metadata
    (:attr:`ModelMeta.ph`; None for the others); ``kernels``: the kernels its code calls;
    ``bodies``: its code by language (``"c"``; ``"python"`` once a back end needed it).

    Its files in the model's entry, each with its sha256 in the manifest like every file
    there (:mod:`.cache`): ``addon-<name>.json`` (the record), ``addon-<name>.c`` and
    ``addon-<name>.py`` (the bodies), and what the back ends make of them: the C unit
    ``m<key>_<name>_c.c`` and library ``m<key>_<name>_c_<platform>_..._<compiler>.so``, the
    modules ``m<key>_<name>_python.py`` and ``m<key>_<name>_numba.py``."""

    name: str
    shapes: Mapping[str, tuple[int, ...]]
    layout: dict[str, Any] | None
    kernels: tuple[str, ...]
    bodies: dict[str, str]


#: the suffix of an add-on's file (:func:`_addon_file`): its record, its bodies by language
_ADDON_SUFFIXES = {"": "json", "c": "c", "python": "py"}


def _addon_file(name: str, language: str = "") -> str:
    """The file of add-on ``name`` in its model's entry: its record, or its body in
    ``language``."""
    return f"addon-{name}.{_ADDON_SUFFIXES[language]}"


def _stored_addon(key: str, name: str) -> _AddOn | None:
    """The add-on ``name`` of entry ``key`` (:class:`_AddOn`) when its record and C body are
    in the cache, intact (a damaged file is reported, removed and built again) and of this
    version's form; else None. Its Python body when it has one."""
    record = cache.load_verified(key, _addon_file(name))
    if record is None:
        return None
    c_body = cache.load_verified(key, _addon_file(name, "c"))
    if c_body is None:
        return None
    python_body = cache.load_verified(key, _addon_file(name, "python"))
    try:
        data = json.loads(record)
        shapes = {str(k): tuple(int(n) for n in v) for k, v in dict(data["shapes"]).items()}
        bodies = {"c": c_body.decode(), **({} if python_body is None else
                                            {"python": python_body.decode()})}
        layout = None if data["layout"] is None else dict(data["layout"])
        return _AddOn(name, MappingProxyType(shapes), layout,
                      tuple(str(k) for k in data["kernels"]), bodies)
    except (KeyError, TypeError, ValueError, AttributeError):
        return None                 # another version's record: built and stored again


def _store_addon(key: str, addon: _AddOn) -> None:
    """Store the add-on in entry ``key``: its bodies, then its record (a reader that finds the
    record finds the bodies)."""
    for language, body in addon.bodies.items():
        cache.store(key, _addon_file(addon.name, language), body)
    cache.store(key, _addon_file(addon.name), json.dumps(
        {"shapes": {k: list(v) for k, v in addon.shapes.items()}, "layout": addon.layout,
         "kernels": list(addon.kernels)}, indent=1))


def _made_addon(name: str, description: ModelDescription, sym: SymbolicModel | None,
                times: dict[str, float], python: bool) -> _AddOn:
    """The add-on ``name`` of the model of ``description`` (its symbolic model ``sym`` when
    this process made it already; else the symbolic stage runs now), printed as C and, with
    ``python``, as Python (the times go into ``times``): the port-Hamiltonian form
    (:func:`.phform.ph_form`) and its functions (:func:`.phform.ph_program`), or ``out_jac``
    (:func:`.codegen.output_jacobian_program`)."""
    from .codegen import output_jacobian_program
    from .phform import ph_form, ph_program
    from .printers import c_source, kernels, python_source

    start = time.perf_counter()
    if sym is None:
        sym = _symbolic_model(description, claim=True)
        start -= sym.solved_earlier
    form = ph_form(description, sym, _solved(description)[0]) if name == _PH else None
    times["symbolic"] = times.get("symbolic", 0.0) + time.perf_counter() - start
    start = time.perf_counter()
    prog = output_jacobian_program(sym) if form is None else ph_program(sym, form)
    bodies = {"c": c_source(prog), **({"python": python_source(prog)} if python else {})}
    times["code"] = times.get("code", 0.0) + time.perf_counter() - start
    return _AddOn(name, MappingProxyType({fn.name: tuple(fn.shape) for fn in prog.functions}),
                  None if form is None else form.layout(), tuple(kernels(prog)), bodies)


@collector.paused()
def _with_addon(compiled: CompiledModel, name: str,
                description: Callable[[], ModelDescription], use_cache: bool,
                order: Sequence[str], sym: SymbolicModel | None = None) -> CompiledModel:
    """``compiled`` with the functions of its cache entry's add-on ``name`` in
    ``functions.extra`` — the port-Hamiltonian form's (``ph_M0``, ``ph_grad``, ``ph_values``;
    its layout in ``meta.ph``), or ``out_jac`` —: the add-on (:class:`_AddOn`) from the
    cache, or built when missing — the symbolic stage (``sym`` when this process made it
    already), the add-on's functions alone generated and compiled into a library (or module)
    of their own — under the add-on's build lock; the model's own functions and library are
    kept as they are. The back end is the model's (a C build of the add-on that fails under
    ``"auto"``, ``order``, falls back as :func:`compile_model` does, for the add-on alone)."""
    key, meta = compiled.key, compiled.meta
    times: dict[str, float] = {}
    addon = _stored_addon(key, name) if use_cache else None
    candidates = list(order[order.index(compiled.backend):] if compiled.backend in order
                      else [compiled.backend])
    with _building(f"{key}_{name}", use_cache):
        if addon is None and use_cache:
            addon = _stored_addon(key, name)       # built by another while this one waited
        if addon is None:
            addon = _made_addon(name, description(), sym, times, python=candidates[0] != "c")
            if use_cache:
                _store_addon(key, addon)
        made = addon

        def load(backend: str) -> dict[str, Callable[..., Any]]:
            nonlocal made
            if backend != "c" and "python" not in made.bodies:
                made = _made_addon(name, description(), sym, times, python=True)
                if use_cache:
                    cache.store(key, _addon_file(name, "python"), made.bodies["python"])
            return _load_addon(backend, key, meta, made, use_cache, times,
                               explicit=len(candidates) == 1)

        backend, functions = _first_that_loads(candidates, load)
        addon = made
    _report(meta.name, times, addon.bodies["c" if backend == "c" else "python"], backend,
            _ADDONS[name])
    return compiled.with_extra(functions, addon.shapes, ph=addon.layout)


def _load_addon(backend: str, key: str, meta: ModelMeta, addon: _AddOn, use_cache: bool,
                times: dict[str, float], explicit: bool) -> dict[str, Callable[..., Any]]:
    """The add-on's functions on the back end ``backend`` (the model ``meta``'s layout), built
    (and cached) when missing as :func:`_load` builds the model's: a C library of its own
    (:func:`_c_library`: the add-on's unit, linked with the kernels it calls), or a module of
    its own."""
    shapes = dict(addon.shapes)
    n, n_params = meta.shapes["rhs"][0], slot_count(meta)
    if backend != "c":
        from ..backends import module
        from . import numba_cache

        text = module.addon_text(addon.bodies["python"], backend)
        path = cache.backend_module(key, backend, text, use_cache, addon=addon.name)
        return module.load_addon(path, backend, list(shapes), source=text, attach=(
            numba_cache.verified_caches(path.parent) if backend == "numba" else None))
    stem = f"{key}_{addon.name}"
    unit = native.addon_unit(addon.bodies["c"], stem)
    return _c_library(key, stem, unit,
                      lambda: [native.start_object(unit, _unit_name(stem).removesuffix(".c"))],
                      addon.kernels,
                      lambda path: native.load_addon(path, shapes, n, n_params, stem),
                      use_cache, times, explicit)


#: what a back end's loading gives (:func:`_first_that_loads`, :func:`_c_library`)
_Loaded = TypeVar("_Loaded")


def _first_that_loads(order: Sequence[str], load: Callable[[str], _Loaded]
                      ) -> tuple[str, _Loaded]:
    """``(name, load(name))`` for the first back end of ``order`` whose ``load`` raises no
    :class:`CompilerError`: a failure falls back to the next one (the first failure of this
    process recorded in :data:`_C_FAILED` and announced, :func:`backends.fell_back`); the last
    one's is raised."""
    for i, name in enumerate(order[:-1]):
        try:
            return name, load(name)
        except CompilerError as err:
            if not _C_FAILED:
                _C_FAILED.append(str(err))
                backends.fell_back(str(err), order[i + 1])
    return order[-1], load(order[-1])


def _close_all(pending: Mapping[str, native.Pending]) -> None:
    """Wait for the background compiles ``pending`` and remove their temporary folders."""
    for job in pending.values():
        job.close()


def _program(sym: SymbolicModel, jac_p: Sequence[str] | None) -> Program:
    """The program of ``sym`` (with ``jac_p``)."""
    from .codegen import program

    return program(sym, jac_p=list(jac_p or []))


def _meta(sym: SymbolicModel, prog: Program, jac_p: Sequence[str] | None) -> ModelMeta:
    """The compiled model's metadata (``meta.json`` of its cache entry)."""
    from .printers import kernels

    return ModelMeta(
        name=sym.name, state_names=tuple(sym.state_names), param_names=tuple(sym.param_names),
        param_defaults=tuple(float(v) for v in sym.param_defaults),
        param_units=tuple(sym.param_units),
        output_names=tuple(sym.outputs),
        events=tuple(EventInfo(ev.name, ev.direction, ev.terminal) for ev, _ in sym.events),
        equations=tuple(sym.equations), hamiltonian=str(sym.hamiltonian),
        matrices=tuple(sym.matrices),
        shapes=MappingProxyType({fn.name: tuple(fn.shape) for fn in prog.functions}),
        autonomous=_autonomous(sym), energy_parts=tuple(sym.energy_parts),
        constraints=tuple(sym.constraints), units=MappingProxyType(dict(sym.units)),
        input_names=tuple(sym.input_names), input_units=tuple(sym.input_units),
        state_roles=tuple(sym.state_roles),
        declared_outputs=tuple(sym.declared_outputs), jac_p=tuple(jac_p or ()),
        discrete=tuple(DiscreteBlock(c, period, tuple(str(s) for s in states), f"update_{j}")
                       for j, (c, period, states, _) in enumerate(sym.discrete)),
        kernels=tuple(kernels(prog)), unavailable=MappingProxyType(dict(prog.unavailable)))


def _python_body(key: str, description: ModelDescription, prog: Program | None,
                 jac_p: Sequence[str] | None, use_cache: bool,
                 times: dict[str, float]) -> tuple[str, SymbolicModel | None]:
    """The model's Python body (``body.py``), printed when a back end first needs it (the
    python and numba back ends): from ``prog``, this build's program, or, for an entry that a
    C build stored without it, from the program made again; stored in the entry (its time added
    to ``times["code"]``). With the symbolic model made for it (None when ``prog`` was given),
    which an add-on built next reuses."""
    from .printers import python_source

    start = time.perf_counter()
    sym = None
    if prog is None:
        sym = _symbolic_model(description, claim=True)
        prog = _program(sym, jac_p)
    text = python_source(prog)
    times["code"] = times.get("code", 0.0) + time.perf_counter() - start
    if use_cache:
        cache.store(key, cache.PYTHON_BODY, text)
    return text, sym


def compiled_record(compiled: CompiledModel) -> dict[str, Any]:
    """What :func:`reopen` needs to open ``compiled`` again from the cache, as plain data: its
    cache key, back end and generated extras, and the parameters', inputs' and outputs' texts
    that come from its description (for a snapshot, :mod:`.snapshots`)."""
    return {"key": compiled.key, "backend": compiled.backend,
            "jac_p": list(compiled.jac_p_names), "ph": compiled.ph_layout is not None,
            "param_docs": list(compiled.param_docs), "input_docs": list(compiled.input_docs),
            "output_expressions": dict(compiled.output_expressions)}


def reopen(record: Mapping[str, Any],
           description: Callable[[], ModelDescription]) -> CompiledModel | None:
    """The compiled model of ``record`` (:func:`compiled_record`) from the cache, without the
    symbolic compiler (no sympy, no networkx): its metadata and code verified as
    :func:`compile_model` verifies them, its library loaded (built when only the library is
    missing), with its port-Hamiltonian form's add-on when the record has it. None when the
    entry (or that add-on) is gone or damaged, or the back end cannot load it: the caller
    compiles the model as usual. ``description`` gives the model's description when it is
    needed after all (a compiled model extended with ``ph=True`` or ``jac_p``)."""
    try:
        key, name = str(record["key"]), str(record["backend"])
        jac_p = [str(n) for n in record["jac_p"]]
        ph = bool(record["ph"])
        docs = {k: [str(d) for d in record[k]] for k in ("param_docs", "input_docs")}
        outputs = {str(k): str(v) for k, v in dict(record["output_expressions"]).items()}
    except (KeyError, TypeError, ValueError):
        return None
    if name not in backends.BACKENDS or not cache.model_key_form(key):
        return None
    meta, bodies = _cached(key)
    addon = _stored_addon(key, _PH) if ph else None
    if meta is None or list(meta.jac_p) != jac_p or (ph and addon is None) or (
            name != "c" and "python" not in bodies):    # (a C build's entry: compiled again)
        return None
    if addon is not None and name != "c" and "python" not in addon.bodies:
        return None
    times: dict[str, float] = {}
    try:
        functions = _load(name, key, meta, bodies, True, times, explicit=True)
        extra = {} if addon is None else _load_addon(name, key, meta, addon, True, times,
                                                     explicit=True)
    except CompilerError:
        return None
    _report(meta.name, times)
    compiled = CompiledModel(meta, functions, bodies["c" if name == "c" else "python"], key,
                             c_source=bodies["c"], param_docs=docs["param_docs"],
                             input_docs=docs["input_docs"], output_expressions=outputs,
                             rebuild=_rebuilder(description, name, True, jac_p))
    return compiled if addon is None else compiled.with_extra(extra, addon.shapes,
                                                              ph=addon.layout)


def _cached(key: str) -> tuple[ModelMeta | None, dict[str, str]]:
    """The cache entry's (metadata, code bodies), or (None, {}) on a miss; an entry whose
    metadata is not this version's record is a miss (it is rebuilt and written again)."""
    hit = cache.read(key)
    if hit is None:
        return None, {}
    try:
        return ModelMeta.from_json(hit[0]), hit[1]
    except (KeyError, TypeError, ValueError, AttributeError):
        return None, {}


def _load(name: str, key: str, meta: ModelMeta, bodies: dict[str, str], use_cache: bool,
          times: dict[str, float], explicit: bool,
          pending: Mapping[str, native.Pending] | None = None) -> backends.Functions:
    """The back end ``name``'s functions, building (and caching) what is missing; the C
    compile time (the time waited for it) goes into ``times``. The C library links the objects
    of the model's units (:func:`native.model_units`: one, or two compiled at once when a core
    is free) with the
    integration loops' object (:func:`native.loop_source`, one for every model) and the objects
    of the kernels it calls, each compiled once and cached; ``pending``: the compiles of the
    model's units :func:`compile_model` started in the background (``"model"``, ``"model1"``),
    waited for here."""
    if name != "c":
        from ..backends import module
        from . import numba_cache

        text = module.module_text(bodies["python"], name)
        path = cache.backend_module(key, name, text, use_cache)
        if name == "python":
            return module.load(path, name, len(meta.matrices), extra_functions(meta), source=text)
        return module.load(path, name, len(meta.matrices), extra_functions(meta), source=text,
                           attach=numba_cache.verified_caches(path.parent),
                           loops=numba_cache.loop_module(use_cache))
    # one process builds a missing library, the others wait for it and load it from the cache
    with _building(key, use_cache):
        return _load_c(key, meta, bodies, use_cache, times, explicit, pending or {})


def _load_c(key: str, meta: ModelMeta, bodies: dict[str, str], use_cache: bool,
            times: dict[str, float], explicit: bool,
            pending: Mapping[str, native.Pending]) -> backends.Functions:
    """The C back end's functions (:func:`_load`), under the model's build lock."""
    shapes = dict(meta.shapes)
    n_params = slot_count(meta)

    def units() -> list[native.Pending]:
        return [job for name, job in pending.items() if name.startswith("model")] or list(
            _start_units(bodies["c"], key).values())

    return _c_library(key, key, native.model_unit(bodies["c"], key=key), units, meta.kernels,
                      lambda path: native.load(path, shapes, n_params, key), use_cache, times,
                      explicit)



def _c_library(key: str, stem: str, unit: str, units: Callable[[], list[native.Pending]],
               kernels: Sequence[str], loader: Callable[[Path], _Loaded], use_cache: bool,
               times: dict[str, float], explicit: bool) -> _Loaded:
    """The C library ``stem`` of entry ``key`` (the model's: ``stem`` is ``key``, linked with
    the integration loops' object; an add-on's: ``<key>_<add-on>``) as ``loader`` loads it:
    the cached one, verified by its sha256 and then by ``loader``'s self-check (a library
    that fails it is removed and built again), else built now: its translation unit ``unit``
    stored in the entry (``m<stem>_c.c``, where a failure's log goes), the compiles of
    ``units()`` waited for and linked with the objects of the ``kernels`` it calls (the C
    compile time goes into ``times``), stored, loaded."""
    identity = native.compiler_identity()
    lib_name = native.library_name(stem, identity or "none")
    cached = cache.verified_path(key, lib_name) if use_cache else None
    if cached is not None:
        try:
            return loader(cached)
        except CompilerError as err:
            cache.warn(f"compiled-model cache: {err}; the library is removed and rebuilt")
            cache.discard(key, cached.name)
    if _C_FAILED and not explicit:
        raise CompilerError(_C_FAILED[0])
    source = cache.store(key, _unit_name(stem), unit, use_cache)
    log_dir = source.parent if cache.kept(source) else None     # failures: the model's log
    try:
        objects = tuple(_kernel_object(kernel, use_cache, times, log_dir, source)
                        for kernel in kernels)
        if stem == key:
            objects += (_loop_object(use_cache, times, log_dir, source),)
        start = time.perf_counter()
        jobs = units()
        try:
            data, _ = native.link((*(job.wait(log_dir, source)[0] for job in jobs),
                                   *objects), source.stem, log_dir, source)
        finally:
            for job in jobs:
                job.close()
        seconds = time.perf_counter() - start
    except CompilerError as err:
        # no working compiler now: this model's library built by another compiler will do,
        # after its self-check (a cached library needs no compiler)
        earlier = _earlier_library(key, stem, loader) if use_cache else None
        if earlier is None:
            raise
        if identity is not None:        # a compiler that fails (none at all: nothing to say)
            warnings.warn(f"{err}; using this model's C library built earlier by another "
                          "compiler (it passed its self-check)", backends.BackendWarning,
                          stacklevel=4)
        return earlier
    times["C"] = times.get("C", 0.0) + seconds
    path = cache.store(key, lib_name, data, use_cache)
    try:
        return loader(path)
    except CompilerError as err:
        cache.discard(key, lib_name)
        raise CompilerError(f"the C compiler ({shlex.join(native.compiler() or ['?'])}) built a "
                            f"library that fails its self-check: {err}. Set CC to a working C "
                            "compiler, or choose the numba or python back end") from None


def _earlier_library(key: str, stem: str, loader: Callable[[Path], _Loaded]) -> _Loaded | None:
    """A library ``stem`` of entry ``key`` (:func:`_c_library`) for this machine that another
    compiler built, loaded by ``loader`` after its self-check (one that fails it is removed);
    None when there is none."""
    for name in cache.recorded(key, native.library_prefix(stem)):
        path = cache.verified_path(key, name)
        if path is None:
            continue
        try:
            return loader(path)
        except CompilerError as err:
            cache.warn(f"compiled-model cache: {err}; the library is removed")
            cache.discard(key, name)
    return None


def _building(key: str, use_cache: bool) -> contextlib.AbstractContextManager[None]:
    """The build lock of ``key`` (a model's, an object's: :func:`cache.building`) when the
    cache is used; nothing to hold without it (nothing is shared)."""
    return cache.building(key) if use_cache else contextlib.nullcontext()


def _start_units(body: str, key: str) -> dict[str, native.Pending]:
    """Start compiling the model's units (:func:`native.model_units`: one, or two at once for
    a long body when a core is free) in the background, by name (``model``, ``model1``)."""
    stem = _unit_name(key).removesuffix(".c")
    units = native.model_units(body, key, split=native.split_units())
    return {f"model{i or ''}": native.start_object(text, f"{stem}{f'_{i}' if i else ''}")
            for i, text in enumerate(units)}


def _unit_name(stem: str) -> str:
    """The file name of the C translation unit of the library ``stem`` (:func:`_c_library`)
    in its cache entry."""
    return f"m{stem}_c.c"


def _loop_name(fmu: bool = False) -> str:
    return f"loops_fmu_{sys.platform}.o" if fmu else f"loops_{sys.platform}.o"


#: the loops' object compiling in the background (:func:`prepare`), by the id of the process
#: that started it: (its cache key, the compile)
_LOOPS: dict[int, tuple[str, native.Pending]] = {}


def prepare(backend: str = "auto") -> None:
    """Start compiling the C back end's integration loops (:func:`native.loop_source`: one
    object for every model) in the background when ``backend`` would try C first and the
    object is not cached yet, so that the compiler works while the model is read and built
    (``load_walker`` calls it before it reads a walker file); the next :func:`compile_model`
    on C waits for it and caches it. Nothing when it is cached or already compiling, or when
    the C back end failed in this process."""
    if backends.candidates(backend)[0] == "c":
        _prepare_loops(use_cache=True)


def _prepare_loops(use_cache: bool) -> None:
    """:func:`prepare` for a build on C (``use_cache``: look for the object in the cache)."""
    if _C_FAILED or os.getpid() in _LOOPS:
        return
    text = native.loop_source()
    key = native.object_key(text)
    if use_cache and cache.verified_path(key, _loop_name()) is not None:
        return
    _LOOPS[os.getpid()] = (key, native.start_object(text, "loops"))


@atexit.register
def _stop_loops() -> None:
    """At exit: stop this process's loops compile that no build waited for."""
    found = _LOOPS.pop(os.getpid(), None)
    if found is not None:
        found[1].close(stop=True)


def _loop_object(use_cache: bool, times: dict[str, float], log_dir: Path | None,
                 model_source: Path, fmu: bool = False, advice: str = native.ADVICE) -> Path:
    """The integration loops' object (:func:`native.loop_source`; ``fmu``: its FMU variant):
    cached, or the background compile :func:`prepare` started waited for (not for ``fmu``), or
    compiled now (the time waited added to ``times["C"]``); a failure is logged as the model's
    (``log_dir``, named after ``model_source``). Under the object's build lock
    (:func:`cache.building`): a process that finds it stored by another meanwhile stops its
    own compile. ``advice``: what a compiler failure's message ends with."""
    text = native.loop_source(fmu)
    key = native.object_key(text)
    found = None if fmu else _LOOPS.pop(os.getpid(), None)
    pending = found[1] if found is not None and found[0] == key else None
    if found is not None and pending is None:       # started for another compiler
        found[1].close(stop=True)
    # one process stores the object, the others wait and read it (their own compiles stopped)
    with _building(key, use_cache):
        path = cache.verified_path(key, _loop_name(fmu)) if use_cache else None
        if path is None:
            start = time.perf_counter()
            data = (pending.result(log_dir, model_source)[0] if pending is not None
                    else native.compile_object(text, "loops", log_dir, model_source,
                                               advice)[0])
            times["C"] = times.get("C", 0.0) + time.perf_counter() - start
            path = cache.store(key, _loop_name(fmu), data, use_cache)
        elif pending is not None:
            pending.close(stop=True)
    return path


def fmu_objects(kernels: Sequence[str], log_as: Path, advice: str) -> tuple[Path, ...]:
    """The objects an FMU's binary is linked with (:mod:`porthamiltonian.fmu.export`): the
    integration loops' FMU variant (:func:`native.loop_source`: hidden, Rosenbrock alone) and
    the compiled kernels the model calls (hidden already: the C back end's objects), each from
    the cache or compiled now and cached, once per compiler for every FMU; a compiler failure
    is logged beside ``log_as`` (the FMU's unit), its message ending with ``advice``."""
    times: dict[str, float] = {}
    return (*(_kernel_object(kernel, True, times, None, log_as, advice) for kernel in kernels),
            _loop_object(True, times, None, log_as, fmu=True, advice=advice))


def _kernel_object(kernel: str, use_cache: bool, times: dict[str, float], log_dir: Path | None,
                   model_source: Path, advice: str = native.ADVICE) -> Path:
    """The compiled object of ``kernel`` (:mod:`porthamiltonian.mechanics.sources`), from the
    cache (an entry of its own, keyed by its source and the compiler) or compiled now (its time
    added to ``times["C"]``; a failure logged as the model's): one compile serves every model
    that calls the kernel, and one process compiles it while the others wait under its build
    lock (:func:`cache.building`). ``advice``: what a compiler failure's message ends with."""
    from ..mechanics.sources import c_object_source  # (the mechanics import sympy)

    text = c_object_source(kernel)
    key = native.object_key(text)
    name = f"{kernel}_{sys.platform}.o"
    with _building(key, use_cache):                 # (as the loops')
        path = cache.verified_path(key, name) if use_cache else None
        if path is None:
            data, seconds = native.compile_object(text, kernel, log_dir, model_source, advice)
            times["C"] = times.get("C", 0.0) + seconds
            path = cache.store(key, name, data, use_cache)
    return path


native.linked_objects = fmu_objects     # (for porthamiltonian.fmu, an earlier stage)


def slot_count(meta: ModelMeta) -> int:
    """The length of the parameter vector of a compiled model's functions: its parameters and
    two slots per input (:func:`.codegen.input_slots`)."""
    return len(meta.param_names) + 2 * len(meta.input_names)


def extra_functions(meta: ModelMeta) -> list[str]:
    """The generated functions beyond the standard ones (``jac_u``, ``out_jac``, ``jac_p``,
    the pH form's), by name, from a compiled model's metadata."""
    standard = {"rhs", "jac", "energy", "outputs", "guards", "initial"}
    return [name for name in meta.shapes if name not in standard
            and not name.startswith("matrix_")]


def _autonomous(sym: SymbolicModel) -> bool:
    """True when the state equations do not depend on time explicitly."""
    import sympy

    from ..modeling.expressions import TIME

    exprs = [*sym.rhs, *(e for _, e in sym.intermediates)]
    exprs += [e for _, A, b in sym.blocks for e in (*A, *b)]
    return not any(TIME in sympy.sympify(e).free_symbols for e in exprs)


__all__ = ["Layout", "SymbolicModel", "compile_model", "compiled_record", "deferred", "fmu_objects",
           "layout", "package_made", "power_balance", "prepare", "recall", "remember", "reopen",
           "snapshot_key", "symbolic"]

"""Symbolic compiler: model graph -> port-Hamiltonian state equations + energy ledger -> code.

Pipeline: :meth:`Model.freeze` (then ``validate``) -> :func:`structure.build_system` ->
:func:`structure.solve` (causality, loops, dependent storages) -> :func:`assemble.assemble` (state
equations, H, P_diss, P_in) -> :func:`codegen.program` (cse, RHS and Jacobian together) ->
:mod:`.printers` (Python and C) -> cache -> back end.
"""
from __future__ import annotations

import dataclasses
import sys
import time
from collections import OrderedDict
from types import MappingProxyType

import sympy

from .. import backends
from ..backends import module, native
from ..errors import CompilerError
from ..mechanics.sources import c_object_source
from ..modeling.model import Model, ModelDescription
from ..simulation.compiled import CompiledModel
from . import cache
from .assemble import SymbolicModel, assemble, power_balance
from .codegen import program
from .literals import printable
from .printers import c_source, kernels, python_source
from .structure import Solution, build_system, solve

#: why the C back end failed in this process (``"auto"`` does not try to build again)
_C_FAILED: list[str] = []


def symbolic(model: Model | ModelDescription) -> SymbolicModel:
    """Run the symbolic part of the compiler (no code generation, no cache): validate the frozen
    description (every problem at once, :meth:`~porthamiltonian.modeling.model.ModelDescription.validate`),
    then structure, assembly. Errors carry the path of what they are about
    (:attr:`~porthamiltonian.errors.ModelError.path`)."""
    description = model.freeze() if isinstance(model, Model) else model
    return assemble(_solved(description.validate()))


#: the solved structures (:func:`structure.build_system` + :func:`structure.solve`, most of the
#: symbolic work) of the last models of this process, by everything but their events and model
#: outputs, which only :func:`assemble` reads: a walker runs the compiler on its model without
#: them (for the names its description may use), then with its own outputs (walker_library.core)
_SOLVED: OrderedDict[str, tuple[tuple[type, ...], Solution]] = OrderedDict()
_SOLVED_KEPT = 4


def _solved(description: ModelDescription) -> Solution:
    """``solve(build_system(description))``, reused from :data:`_SOLVED` when only the events
    or the model outputs differ (the component classes themselves must be the same objects)."""
    bare = dataclasses.replace(description, events=(), outputs=MappingProxyType({}), scopes=(
        MappingProxyType({k: v for k, v in description.scopes.items()
                          if not k.startswith(("event:", "output:"))})))
    key = bare.canonical()
    classes = tuple(type(c) for c in description.components.values())
    hit = _SOLVED.get(key)
    if hit is not None and len(hit[0]) == len(classes) and all(
            a is b for a, b in zip(hit[0], classes)):
        _SOLVED.move_to_end(key)
        solution = hit[1]
        return Solution(dataclasses.replace(solution.system, flat=description), solution.order)
    solution = solve(build_system(description))
    _SOLVED[key] = (classes, solution)
    while len(_SOLVED) > _SOLVED_KEPT:
        _SOLVED.popitem(last=False)
    return solution


def compile_model(model: Model | ModelDescription, backend: str = "auto",
                  use_cache: bool = True) -> CompiledModel:
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
    """
    order = backends.candidates(backend)
    description = model.freeze() if isinstance(model, Model) else model
    key = cache.model_key(description)
    hit = cache.read(key) if use_cache else None
    times: dict[str, float] = {}
    pending = None
    if hit is None:
        start = time.perf_counter()
        sym = symbolic(description)
        times["symbolic"] = time.perf_counter() - start
        if order[0] == "c" and not _C_FAILED:       # the loops compile while the code is made
            pending = _start_loop(len(sym.states) + 2, max(len(sym.events), 1), use_cache)
        start = time.perf_counter()
        prog = program(sym)
        bodies = {"python": python_source(prog), "c": c_source(prog)}
        times["code"] = time.perf_counter() - start
        meta = {
            "name": sym.name, "state_names": sym.state_names, "param_names": sym.param_names,
            "param_defaults": sym.param_defaults, "param_units": sym.param_units,
            "output_names": list(sym.outputs),
            "events": [{"name": ev.name, "direction": ev.direction, "terminal": ev.terminal}
                       for ev, _ in sym.events],
            "equations": sym.equations, "hamiltonian": str(sym.hamiltonian),
            "matrices": list(sym.matrices),
            "shapes": {fn.name: list(fn.shape) for fn in prog.functions},
            "autonomous": _autonomous(sym),
            "energy_parts": sym.energy_parts,
            "constraints": [c.to_dict() for c in sym.constraints],
            "units": sym.units,
            "kernels": kernels(prog),
        }
        if use_cache:
            cache.write(key, meta, bodies)
    else:
        meta, bodies = hit
    try:
        for i, name in enumerate(order):
            try:
                functions = _load(name, key, meta, bodies, use_cache, times,
                                  explicit=len(order) == 1, pending=pending)
            except CompilerError as err:
                if len(order) == 1:
                    raise
                if not _C_FAILED:
                    _C_FAILED.append(str(err))
                    backends.fell_back(str(err), order[i + 1])
                continue
            break
    finally:
        if pending is not None:
            pending.close()
    if times:
        parts = [f"{k} {v:.1f} s" for k, v in times.items()]
        size = len(bodies["c" if name == "c" else "python"].encode()) / 1000
        note = " (numba compiles it at the first call)" if name == "numba" else ""
        backends.report(f"building {printable(meta['name'])}: {', '.join(parts)}, "
                        f"{size:.0f} kB{note}")
    return CompiledModel(meta, functions, bodies["c" if name == "c" else "python"], key)


def _load(name: str, key: str, meta: dict, bodies: dict[str, str], use_cache: bool,
          times: dict[str, float], explicit: bool,
          pending: native.Pending | None = None) -> backends.Functions:
    """The back end ``name``'s functions, building (and caching) what is missing; the C
    compile time (the time waited for it) goes into ``times``. The C library links the model's
    unit with the integration loops' object (:func:`native.loop_source`, by the model's sizes)
    and the objects of the kernels it calls, each compiled once and cached."""
    if name != "c":
        text = module.module_text(bodies["python"], name)
        path = cache.backend_module(key, name, text, use_cache)
        return module.load(path, name, len(meta["matrices"]))
    shapes = {k: tuple(v) for k, v in meta["shapes"].items()}
    lib_name = native.library_name(key)
    path = cache.verified_path(key, lib_name) if use_cache else None
    if path is None:
        if _C_FAILED and not explicit:
            raise CompilerError(_C_FAILED[0])
        source = cache.store(key, f"m{key}_c.c", bodies["c"], use_cache)
        log_dir = source.parent if cache.kept(source) else None   # failures: the model's log
        objects = tuple(_kernel_object(name, use_cache, times, log_dir, source)
                        for name in meta.get("kernels", ()))
        objects += (_loop_object(meta, use_cache, times, pending, log_dir, source),)
        data, seconds = native.build(source, log_dir, objects)
        times["C"] = times.get("C", 0.0) + seconds
        path = cache.store(key, lib_name, data, use_cache)
    try:
        return native.load(path, shapes, len(meta["param_names"]))
    except OSError as err:
        raise CompilerError(f"the C library {path} cannot be loaded ({err}); remove it to "
                            "rebuild it, or choose the numba or python back end") from None


def _loop_name() -> str:
    return f"loops_{sys.platform}.o"


def _start_loop(n: int, n_guards: int, use_cache: bool) -> native.Pending | None:
    """Start compiling the loops' object for these sizes unless it is cached."""
    text = native.loop_source(n, n_guards)
    if use_cache and cache.verified_path(native.object_key(text), _loop_name()) is not None:
        return None
    return native.start_object(text, "loops")


def _loop_object(meta: dict, use_cache: bool, times: dict[str, float],
                 pending: native.Pending | None, log_dir, model_source):
    """The integration loops' object for the model's sizes: cached, or the background compile
    ``pending`` waited for, or compiled now (the time waited added to ``times["C"]``); a
    failure is logged as the model's (``log_dir``, named after ``model_source``)."""
    text = native.loop_source(meta["shapes"]["rhs"][0], meta["shapes"]["guards"][0])
    key = native.object_key(text)
    path = cache.verified_path(key, _loop_name()) if use_cache else None
    if path is None:
        start = time.perf_counter()
        data = (pending.result(log_dir, model_source)[0] if pending is not None
                else native.compile_object(text, "loops", log_dir, model_source)[0])
        times["C"] = times.get("C", 0.0) + time.perf_counter() - start
        path = cache.store(key, _loop_name(), data, use_cache)
    return path


def _kernel_object(kernel: str, use_cache: bool, times: dict[str, float], log_dir,
                   model_source):
    """The compiled object of ``kernel`` (:mod:`porthamiltonian.mechanics.sources`), from the
    cache (an entry of its own, keyed by its source and the compiler) or compiled now (its time
    added to ``times["C"]``; a failure logged as the model's): one compile serves every model
    that calls the kernel."""
    text = c_object_source(kernel)
    key = native.object_key(text)
    name = f"{kernel}_{sys.platform}.o"
    path = cache.verified_path(key, name) if use_cache else None
    if path is None:
        data, seconds = native.compile_object(text, kernel, log_dir, model_source)
        times["C"] = times.get("C", 0.0) + seconds
        path = cache.store(key, name, data, use_cache)
    return path


def _autonomous(sym: SymbolicModel) -> bool:
    """True when the state equations do not depend on time explicitly."""
    from ..modeling.expressions import TIME

    exprs = [*sym.rhs, *(e for _, e in sym.intermediates)]
    exprs += [e for _, A, b in sym.blocks for e in (*A, *b)]
    return not any(TIME in sympy.sympify(e).free_symbols for e in exprs)


__all__ = ["SymbolicModel", "compile_model", "power_balance", "symbolic"]

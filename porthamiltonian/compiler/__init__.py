"""Symbolic compiler: model graph -> port-Hamiltonian state equations + energy ledger -> code.

Pipeline: :meth:`Model.flatten` -> :func:`structure.build_system` -> :func:`structure.solve`
(causality, loops, dependent storages) -> :func:`assemble.assemble` (state equations, H, P_diss,
P_in) -> :func:`codegen.generate` (cse, RHS and Jacobian together) -> cache -> back end.

A model that is not in the cache yet is built once (seconds to a minute for a walker); the
logger ``porthamiltonian.build`` says so at INFO level when the build starts and, if it took a
second or more, when it ends (the command lines print it on stderr).
"""
from __future__ import annotations

import logging
import time

import sympy

from ..backends import load, resolve, source_with_header
from ..compiled import CompiledModel
from ..errors import ModelError, ModelFileError
from ..model import Model
from . import cache
from .assemble import SymbolicModel, assemble, power_balance
from .codegen import generate
from .structure import build_system, solve


def symbolic(model: Model) -> SymbolicModel:
    """Run the symbolic part of the compiler (no code generation, no cache)."""
    flat = model.flatten()
    if not flat.components:
        raise ModelError(f"model {model.name!r} is empty: it has no components; add some (in a "
                         "model file: [components.NAME] tables with a type) before compiling")
    return assemble(solve(build_system(flat)))


def compile_model(model: Model, backend: str = "auto", use_cache: bool = True) -> CompiledModel:
    """Compile ``model`` for numeric simulation.

    Parameters
    ----------
    backend : ``"auto"`` (numba when installed, else python), ``"python"`` or ``"numba"``.
    use_cache : reuse and store the generated code in the on-disk cache (keyed by a model hash;
        see :mod:`porthamiltonian.compiler.cache`); ``False`` writes nothing there (the module is
        built in a private temporary folder removed at exit).
    """
    backend = resolve(backend)
    key = cache.model_key(model)
    hit = cache.read(key) if use_cache else None
    started = None
    if hit is None:
        started = time.perf_counter()
        BUILD_LOG.info("building model %s (once: symbolic compilation, code generation%s; "
                       "cached for later runs) ...", model.name,
                       ", numba compilation" if backend == "numba" else "")
        try:
            sym = symbolic(model)
        except ModelFileError:
            raise
        except ModelError as err:
            if model.source is None:
                raise
            raise ModelFileError(f"{model.source}: {err}") from None
        body = generate(sym)
        meta = {
            "name": sym.name, "state_names": sym.state_names, "param_names": sym.param_names,
            "param_defaults": sym.param_defaults, "param_units": sym.param_units,
            "output_names": list(sym.outputs),
            "events": [{"name": ev.name, "direction": ev.direction, "terminal": ev.terminal}
                       for ev, _ in sym.events],
            "equations": sym.equations, "hamiltonian": str(sym.hamiltonian),
            "matrices": list(sym.matrices),
            "autonomous": _autonomous(sym),
            "energy_parts": sym.energy_parts,
            "constraints": [c.to_dict() for c in sym.constraints],
            "units": sym.units,
        }
        if use_cache:
            cache.write(key, meta, body)
    else:
        meta, body = hit
    path = cache.backend_module(key, backend, source_with_header(body, backend), use_cache)
    compiled = CompiledModel(meta, load(path, backend, len(meta["matrices"])), body, key)
    if started is not None and time.perf_counter() - started >= 1.0:
        BUILD_LOG.info("built model %s in %.0f s", model.name, time.perf_counter() - started)
    return compiled


#: progress of model builds (INFO: a build starts, a build ended)
BUILD_LOG = logging.getLogger("porthamiltonian.build")


def _autonomous(sym: SymbolicModel) -> bool:
    """True when the state equations do not depend on time explicitly."""
    from ..expressions import TIME

    exprs = [*sym.rhs, *(e for _, e in sym.intermediates)]
    exprs += [e for _, A, b in sym.blocks for e in (*A, *b)]
    return not any(TIME in sympy.sympify(e).free_symbols for e in exprs)


__all__ = ["SymbolicModel", "compile_model", "power_balance", "symbolic"]

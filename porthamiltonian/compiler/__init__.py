"""Symbolic compiler: model graph -> port-Hamiltonian state equations + energy ledger -> code.

Pipeline: :meth:`Model.freeze` (then ``validate``) -> :func:`structure.build_system` ->
:func:`structure.solve` (causality, loops, dependent storages) -> :func:`assemble.assemble` (state
equations, H, P_diss, P_in) -> :func:`codegen.generate` (cse, RHS and Jacobian together) -> cache
-> back end.
"""
from __future__ import annotations

import sympy

from ..backends import load, resolve, source_with_header
from ..compiled import CompiledModel
from ..model import Model, ModelDescription
from . import cache
from .assemble import SymbolicModel, assemble, power_balance
from .codegen import generate
from .structure import build_system, solve


def symbolic(model: Model | ModelDescription) -> SymbolicModel:
    """Run the symbolic part of the compiler (no code generation, no cache): validate the frozen
    description (every problem at once, :meth:`~porthamiltonian.model.ModelDescription.validate`),
    then structure, assembly. Errors carry the path of what they are about
    (:attr:`~porthamiltonian.errors.ModelError.path`)."""
    description = model.freeze() if isinstance(model, Model) else model
    return assemble(solve(build_system(description.validate())))


def compile_model(model: Model | ModelDescription, backend: str = "auto",
                  use_cache: bool = True) -> CompiledModel:
    """Compile ``model`` (a model, or its frozen description) for numeric simulation.

    Parameters
    ----------
    backend : ``"auto"`` (numba when installed, else python), ``"python"`` or ``"numba"``.
    use_cache : reuse and store the generated code in the on-disk cache (keyed by a model hash;
        see :mod:`porthamiltonian.compiler.cache`); ``False`` writes nothing there (the module is
        built in a private temporary folder removed at exit).
    """
    backend = resolve(backend)
    description = model.freeze() if isinstance(model, Model) else model
    key = cache.model_key(description)
    hit = cache.read(key) if use_cache else None
    if hit is None:
        sym = symbolic(description)
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
        }
        if use_cache:
            cache.write(key, meta, body)
    else:
        meta, body = hit
    path = cache.backend_module(key, backend, source_with_header(body, backend), use_cache)
    return CompiledModel(meta, load(path, backend, len(meta["matrices"])), body, key)


def _autonomous(sym: SymbolicModel) -> bool:
    """True when the state equations do not depend on time explicitly."""
    from ..expressions import TIME

    exprs = [*sym.rhs, *(e for _, e in sym.intermediates)]
    exprs += [e for _, A, b in sym.blocks for e in (*A, *b)]
    return not any(TIME in sympy.sympify(e).free_symbols for e in exprs)


__all__ = ["SymbolicModel", "compile_model", "power_balance", "symbolic"]

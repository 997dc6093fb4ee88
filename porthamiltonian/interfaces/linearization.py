"""``porthamiltonian linearize`` and ``porthamiltonian show --ph``: a model file's linear model at
its operating point, and its port-Hamiltonian form, as text or JSON.

The operating point: the model file's ``[linearize]`` table (``states`` and ``inputs`` by name,
``trim`` — find an equilibrium from those states, true by default when the table is there —
``free_inputs`` for the trim, ``t``), each value overridden by ``--at NAME=VALUE`` (a state or an
input), ``--trim`` / ``--no-trim``; without a table, the model's initial state with every input
0, as given. Parameters by ``--set``. The result (:class:`~porthamiltonian.simulation.linearize.
LinearModel`) prints as named matrices, or as JSON with the keys ``A``, ``B``, ``C``, ``D``
(nested lists), ``states``, ``inputs``, ``outputs`` (names), ``eigenvalues`` ([re, im] pairs),
the point (``t``, ``x``, ``u``), ``xdot_norm`` (|ẋ| there) and ``trim`` (how it was found).
"""
from __future__ import annotations

import argparse
import json
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ..batch.values import to_jsonable
from ..errors import ModelError
from . import io

if TYPE_CHECKING:
    from ..simulation.compiled import CompiledModel
    from ..simulation.linearize import LinearModel


def operating_point(record: io.ModelFile, compiled: CompiledModel, at: Mapping[str, float],
                    trim: bool | None, params: Mapping[str, float]
                    ) -> tuple[LinearModel, dict[str, Any]]:
    """The linearization of ``compiled`` at the file's operating point with the overrides
    ``at`` (state or input name -> value) and ``trim`` (None: the file's choice); and how the
    point was found."""
    table = dict(record.linearize)
    states = dict(table.get("states", {}))
    inputs = {name: 0.0 for name in compiled.input_names}
    inputs.update(table.get("inputs", {}))
    for name, value in at.items():
        if name in compiled.input_names:
            inputs[name] = value
        elif name in compiled.state_names:
            states[name] = value
        else:
            raise ModelError(f"--at {name}: not a state or an input of model {compiled.name!r}; "
                             f"states: {', '.join(compiled.state_names)}; inputs: "
                             f"{', '.join(compiled.input_names) or 'none'}")
    unknown = [n for n in states if n not in compiled.state_names] + [
        n for n in inputs if n not in compiled.input_names]
    if unknown:
        raise ModelError(f"{record.source}: [linearize] names {', '.join(unknown)}, which the "
                         f"model does not have (states: {', '.join(compiled.state_names)}; "
                         f"inputs: {', '.join(compiled.input_names) or 'none'})")
    do_trim = bool(table.get("trim", bool(table))) if trim is None else trim
    t = float(table.get("t", 0.0))
    p = compiled.params(params)
    x = compiled.initial_state(p, states)
    how: dict[str, Any] = {"trim": do_trim}
    if do_trim:
        result = compiled.trim(x, inputs, params, t=t,
                               free_inputs=list(table.get("free_inputs", [])))
        if not result.success:
            raise ModelError(f"model {compiled.name!r}: trim found no equilibrium from the "
                             f"given point ({result.message}); give a better starting point "
                             "([linearize] states, --at) or --no-trim")
        x, inputs = result.x, dict(zip(compiled.input_names, result.u.tolist()))
        how.update(iterations=result.iterations, residual=result.residual)
    return compiled.linearize(x, inputs, params, t), how


def _matrix_text(name: str, M: np.ndarray, rows: tuple[str, ...], cols: tuple[str, ...]) -> str:
    if M.size == 0:
        return f"{name} = [] ({M.shape[0]} x {M.shape[1]})"
    width = max([len(c) for c in cols] + [12])
    head = " " * 24 + "".join(f"{c[-width:]:>{width + 1}}" for c in cols)
    lines = [f"{name} =", head]
    for label, row in zip(rows, M):
        lines.append(f"  {label[-22:]:22s}" + "".join(f"{v:>{width + 1}.6g}" for v in row))
    return "\n".join(lines)


def run_linearize(args: argparse.Namespace, at: Mapping[str, float],
                  params: Mapping[str, float]) -> int:
    """``porthamiltonian linearize``: (A, B, C, D) at the operating point (text or JSON);
    ``at`` and ``params`` parsed from ``--at`` and ``--set``."""
    record = io.read(args.model)
    compiled = record.compile(backend=args.backend)
    with record.located():
        lin, how = operating_point(record, compiled, at, args.trim, params)
    if args.json:
        print(json.dumps(to_jsonable({**lin.to_dict(), "model": compiled.name, "trim": how}),
                         indent=1, allow_nan=False))
        return 0
    print(f"{compiled.name}: linearized at t = {lin.t:g}"
          f"{' (an equilibrium found by trim)' if how['trim'] else ''}; |dx/dt| there = "
          f"{lin.xdot_norm:.3g}")
    print("  point: " + ", ".join(f"{n} = {v:.10g}" for n, v in zip(lin.states, lin.x)))
    if lin.inputs:
        print("  inputs: " + ", ".join(f"{n} = {v:.10g}" for n, v in zip(lin.inputs, lin.u)))
    for name, M, rows, cols in (("A", lin.A, lin.states, lin.states),
                                ("B", lin.B, lin.states, lin.inputs),
                                ("C", lin.C, lin.outputs, lin.states),
                                ("D", lin.D, lin.outputs, lin.inputs)):
        print(_matrix_text(name, M, rows, cols))
    print("eigenvalues of A: " + ", ".join(
        f"{v.real:.6g}{v.imag:+.6g}j" if v.imag else f"{v.real:.6g}" for v in lin.eigenvalues))
    return 0


def add_linearize_parser(sub: argparse._SubParsersAction, parents: list, model_help: str
                         ) -> argparse.ArgumentParser:
    """Add the ``linearize`` command to the ``porthamiltonian`` parser (the caller sets its
    ``func``)."""
    p = sub.add_parser("linearize", parents=parents,
                       help="linearize a model at its operating point: A, B, C, D, eigenvalues",
                       description="Linearize MODEL (exact Jacobians) at the operating point of "
                                   "its [linearize] table, or the one given with --at.")
    p.add_argument("model", help=model_help)
    p.add_argument("--at", action="append", default=[], metavar="NAME=VALUE",
                   help="a state or input value at the operating point (repeatable)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--trim", dest="trim", action="store_true", default=None,
                       help="find an equilibrium from the point first")
    group.add_argument("--no-trim", dest="trim", action="store_false",
                       help="linearize at the point as given")
    return p


__all__ = ["add_linearize_parser", "operating_point", "run_linearize"]

"""The FMU's variables, built from a compiled model's layouts.

One row per variable (:class:`Variable`): its name, value reference (unique over all types, as
FMI 3.0 asks; FMI 2.0 allows it), type, causality, variability, initial, start value, unit and
description, and what it designates in the C runtime (``kind`` and ``index``: a parameter, a
state, a state derivative, a named output, the energy ledger, an event's guard, count or time, a
rule counter, a co-simulation setting). :func:`variable_table` builds it in a fixed order:

=================================  ==========================  ===================================
variables                          causality / variability     notes
=================================  ==========================  ===================================
``time``                           independent                 value reference 0
parameters                         parameter / tunable, fixed  fixed: read by the initial state only
inputs (``[inputs]``)              input / continuous          start: ``inputs=`` of the export
modes (set by event rules)         local / discrete            start value settable before init
states, then ``ledger.E_diss``,    local (ledger: output) /    start: the model's initial state
``ledger.E_in``                    continuous                  (or ``x0``)
``der(<state>)``                   local / continuous          calculated
named outputs                      output (or local) /         ``outputs=`` chooses which are FMI
                                   continuous                  outputs (default: the declared
                                                               outputs, else all)
``ledger.H``, ``ledger.residual``  output / continuous         H, and H − H(t0) + E_diss − E_in
``events.<e>.indicator``           local / continuous          the guard (FMI 3.0 event indicator)
``events.<e>.count``, ``.time``    output / discrete           Integer, Real
``<counter>.count``, ``.time``     output / discrete           rule counters (a walker's steps)
``solver.rtol|atol|max_step``      parameter / fixed           co-simulation FMUs
=================================  ==========================  ===================================

An input reads two slots of the parameter vector, u = a + b·t (the compiled model's input
slots): the runtime writes them from the value the importer sets (and, FMI 2.0 co-simulation, its
time derivative).
"""
from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ExportError
from .program import EventProgram

if TYPE_CHECKING:
    from ..simulation.compiled import CompiledModel

__all__ = ["Variable", "dynamic_parameters", "variable_table"]

#: the C runtime's kinds (ph_fmu.h), by name
KINDS = ("time", "param", "state", "rate", "output", "energy", "residual", "indicator",
         "event_time", "event_count", "counter_time", "counter_count", "solver", "input")
_FUNCTION = re.compile(r"^static void (\w+)\(", re.MULTILINE)
_PARAM = re.compile(r"\bp\[(\d+)\]")
_DIRECTIONS = {1: "rises through 0", -1: "falls through 0", 0: "crosses 0"}


@dataclass(frozen=True)
class Variable:
    """One FMU variable (see the module docstring). ``start`` is None for calculated
    variables; ``derivative_of`` the value reference of the state a derivative belongs to;
    ``access``: ``"read"``, ``"before_init"`` (a start value) or ``"tunable"``."""

    name: str
    vr: int
    type: str
    causality: str
    variability: str
    initial: str | None
    start: float | None
    unit: str
    description: str
    kind: str
    index: int
    derivative_of: int | None = None
    access: str = "read"


def dynamic_parameters(c_source: str, n_params: int) -> set[int]:
    """The parameters (indices) that the model's dynamics read: its right-hand side, Jacobian,
    energy, outputs, guards or matrices, as the generated C reads them (``p[i]``); the others are
    read by the initial state only, or by nothing."""
    starts = [(m.start(), m.group(1)) for m in _FUNCTION.finditer(c_source)]
    used: set[int] = set()
    for (start, name), (end, _) in zip(starts, [*starts[1:], (len(c_source), "")]):
        if name != "initial":
            used.update(int(i) for i in _PARAM.findall(c_source, start, end))
    return {i for i in used if i < n_params}


def _output_description(name: str, expression: str | None) -> str:
    if expression is not None:
        return f"declared output of the model: {expression}"
    parts = name.split(".")
    if len(parts) >= 3 and parts[-1] in ("e", "f"):
        port = ".".join(parts[:-1])
        return f"{'effort' if parts[-1] == 'e' else 'flow'} of port {port}"
    return f"output {name} of the model"


def variable_table(model: CompiledModel, *, program: EventProgram, param_start: np.ndarray,
                   x_start: np.ndarray, states_from_parameters: bool, outputs: Sequence[str],
                   solver: Sequence[float], cosimulation: bool, method: str) -> list[Variable]:
    """The FMU's variables (see the module docstring) of ``model``.

    program : the event rules (its modes become discrete variables, its counters outputs).
    param_start, x_start : start values of the parameters, then of the inputs (their slots: the
        value at t = 0 and the rate; the rate is 0 here), and of the model states;
        ``states_from_parameters``: the FMU computes the initial state from the parameters
        (else the states start at ``x_start``).
    outputs : the named outputs that are FMI outputs (the others are local variables).
    solver : rtol, atol, max_step of the co-simulation integrator ``method`` (variables only
        when ``cosimulation``).
    """
    rows: list[Variable] = []

    def add(name: str, type_: str, causality: str, variability: str, initial: str | None,
            start: float | None, unit: str, description: str, kind: str, index: int,
            derivative_of: int | None = None, access: str = "read") -> int:
        rows.append(Variable(name, len(rows), type_, causality, variability, initial, start,
                             unit, description, kind, index, derivative_of, access))
        return len(rows) - 1

    add("time", "Real", "independent", "continuous", None, None, "s", "simulation time",
        "time", 0)
    modes = set(program.modes)
    dynamic = dynamic_parameters(model.c_source, len(model.param_names))
    for i, name in enumerate(model.param_names):
        unit, doc = model.param_units[i], model.param_docs[i]
        value = float(param_start[i])
        if i in modes:
            add(name, "Real", "local", "discrete", "exact", value, unit,
                f"mode (set by the event rules){': ' + doc if doc else ''}", "param", i,
                access="before_init")
        elif i in dynamic:
            add(name, "Real", "parameter", "tunable", "exact", value, unit, doc, "param", i,
                access="tunable")
        else:
            role = ("sets the initial state only" if states_from_parameters else
                    "unused here: it sets the model's initial state, and this FMU's states have "
                    "start values of their own")
            add(name, "Real", "parameter", "fixed", "exact", value, unit,
                f"{doc}{' ' if doc else ''}({role})", "param", i, access="before_init")
    n_par = len(model.param_names)
    for k, name in enumerate(model.input_names):
        add(name, "Real", "input", "continuous", None, float(param_start[n_par + k]),
            model.input_units[k], model.input_docs[k] or f"input {name} of the model", "input",
            k, access="tunable")
    n = model.n_states
    ledger = (("ledger.E_diss", "energy dissipated since the start (the ledger's E_diss)"),
              ("ledger.E_in", "energy supplied since the start (the ledger's E_in)"))
    states = []
    discrete = {s: block.component for block in model.discrete for s in block.states}
    for i, name in enumerate(model.state_names):
        doc = (f"held value of the discrete-time block {discrete[name]} (changes at its "
               "sampling instants only)" if name in discrete else "model state")
        states.append(add(name, "Real", "local", "continuous", "exact", float(x_start[i]),
                          model.units.get(name, ""), doc, "state", i, access="before_init"))
    for j, (name, doc) in enumerate(ledger):
        states.append(add(name, "Real", "output", "continuous", "exact", 0.0, "J", doc,
                          "state", n + j))
    for i, vr in enumerate(states):
        state = rows[vr]
        unit = _rate_unit(state.unit)
        doc = ("power dissipated (P_diss)" if i == n else "power supplied (P_in)" if i == n + 1
               else f"time derivative of {state.name}")
        add(f"der({state.name})", "Real", "local", "continuous", "calculated", None, unit, doc,
            "rate", i, derivative_of=vr)
    chosen = set(outputs)
    expressions = model.output_expressions
    for i, name in enumerate(model.output_names):
        expression = expressions.get(name)
        unit = model.units.get(name) or model.units.get((expression or "").strip(), "")
        add(name, "Real", "output" if name in chosen else "local", "continuous", "calculated",
            None, unit, _output_description(name, expression), "output", i)
    add("ledger.H", "Real", "output", "continuous", "calculated", None, "J",
        "stored energy: the Hamiltonian H (its expression: documentation/index.html)",
        "energy", 0)
    add("ledger.residual", "Real", "output", "continuous", "calculated", None, "J",
        "energy balance residual H(t) - H(t0) + E_diss - E_in (zero up to the integration error)",
        "residual", 0)
    for k, ev in enumerate(model.events):
        add(f"events.{ev.name}.indicator", "Real", "local", "continuous", "calculated", None, "",
            f"guard of event {ev.name}: it fires when this {_DIRECTIONS.get(ev.direction, '')}",
            "indicator", k)
    for k, ev in enumerate(model.events):
        add(f"events.{ev.name}.count", "Integer", "output", "discrete", "calculated", None, "",
            f"how often event {ev.name} fired since the start", "event_count", k)
        add(f"events.{ev.name}.time", "Real", "output", "discrete", "calculated", None, "s",
            f"the time event {ev.name} last fired (0 before it first does)", "event_time", k)
    for c, (name, doc) in enumerate(program.counters):
        add(f"{name}.count", "Integer", "output", "discrete", "calculated", None, "",
            f"how often: {doc}", "counter_count", c)
        add(f"{name}.time", "Real", "output", "discrete", "calculated", None, "s",
            f"the time of the last one: {doc} (0 before the first)", "counter_time", c)
    if cosimulation:
        rtol, atol, max_step = (float(v) for v in solver)
        for j, (name, value, unit, doc) in enumerate((
                ("solver.rtol", rtol, "1", (f"co-simulation: relative tolerance of the FMU's "
                 f"{method} integrator (a tolerance the importer gives replaces it)")),
                ("solver.atol", atol, "", "co-simulation: absolute tolerance of every state"),
                ("solver.max_step", max_step, "s", "co-simulation: largest integration step"))):
            add(name, "Real", "parameter", "fixed", "exact", value, unit, doc, "solver", j,
                access="before_init")
    _check_names(rows, model.name)
    return rows


def _rate_unit(unit: str) -> str:
    if not unit or unit == "1":
        return "1/s" if unit == "1" else ""
    return f"{unit}/s"


def _check_names(rows: Sequence[Variable], model: str) -> None:
    seen: dict[str, str] = {}
    clashes = []
    for v in rows:
        if v.name in seen:
            clashes.append(f"{v.name!r} ({seen[v.name]} and {v.kind})")
        seen[v.name] = v.kind
    if clashes:
        raise ExportError(f"model {model!r}: FMU variable names clash: {', '.join(clashes)}; "
                          "rename the parameter, output or event")
    bad = [v.name for v in rows if v.start is not None and not math.isfinite(v.start)]
    if bad:
        raise ExportError(f"model {model!r}: start values are not finite: {', '.join(bad)}")

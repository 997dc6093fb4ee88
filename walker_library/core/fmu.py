"""A walker as an FMU: its model with its mode machine inside, as C.

The mode machine (:mod:`.machine`) of a compliant-contact walker only switches modes: its rules
compare compiled outputs with 0 and set mode parameters to constants or compiled outputs. That
is data the FMU runtime runs (:class:`porthamiltonian.fmu.EventProgram`): :func:`walker_program`
writes each :class:`~.machine.Transition` as an :class:`~porthamiltonian.fmu.EventRule` (same
event, conditions, changes and energy booking; a fall ends the run; a heel strike counts under
``walker.heel_strike``: the FMU's outputs ``walker.heel_strike.count`` and
``walker.heel_strike.time`` give the step times). The walker's own expressions (its
``hybrid_e*`` outputs) stay local variables.

A rigid walker's impact rule is a reset map computed in Python (the plastic impact from the
floating multibody's matrices, then the relabelling): it cannot run in an FMU and is refused
with an :class:`~porthamiltonian.errors.ExportError` saying so.

:func:`export_walker_fmu` starts the FMU where :meth:`~.walker.HybridWalker.walk` starts: the
section state (default: the walker's initial guess) lifted to a model state, the modes at their
start values (the start rules apply when the FMU's initialization ends), the walker's integration
settings as the co-simulation settings, and a stop time of ``steps`` × ``max_step_time``. With
the same stop time the co-simulation FMU's heel strikes are those of ``walk(z, steps)``.
"""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from porthamiltonian.errors import ExportError
from porthamiltonian.fmu import EventProgram, EventRule, RuleChange, RuleCondition, export_fmu
from porthamiltonian.integrators import TABLEAUS

if TYPE_CHECKING:
    from .walker import HybridWalker

__all__ = ["HEEL_STRIKE", "export_walker_fmu", "walker_program"]

#: the counter of the heel strikes (FMU outputs ``walker.heel_strike.count`` / ``.time``)
HEEL_STRIKE = "walker.heel_strike"
#: the prefix of the walker's own outputs (its evaluated expressions)
_INTERNAL = "hybrid_"


def walker_program(walker: HybridWalker) -> EventProgram:
    """The walker's mode machine as an :class:`~porthamiltonian.fmu.EventProgram`; an
    :class:`~porthamiltonian.errors.ExportError` for a rule with an impact (a reset map)."""
    impacts = [tr.name for tr in walker.machine.transitions if tr.impact is not None]
    if impacts:
        raise ExportError(
            f"walker {walker.name!r} cannot be exported to an FMU: its rule(s) "
            f"{', '.join(impacts)} apply a rigid impact, a reset map of the state computed in "
            "Python (the plastic impact from the floating multibody's mass matrix, then the "
            "relabelling), which cannot run inside an FMU. Walkers whose events only switch "
            "modes (compliant contacts, e.g. compass_walker) export")
    rules = []
    for tr in walker.machine.transitions:
        rules.append(EventRule(
            tr.event_index,
            tuple(RuleCondition(c.output, c.op, c.text) for c in tr.conditions),
            tuple(RuleChange(ch.index, ch.constant, ch.output) for ch in tr.changes),
            energy=tr.energy, stop=tr.fall, counter=HEEL_STRIKE if tr.heel_strike else None,
            name=tr.name))
    return EventProgram(tuple(rules), ((HEEL_STRIKE, "heel strikes (each ends a step)"),),
                        source=f"walker {walker.name}")


def export_walker_fmu(walker: HybridWalker, path: str | os.PathLike[str], *, fmi: int | str = 2,
                      kind: str = "cs", z: np.ndarray | None = None, steps: int = 5,
                      ground_drop: float = 0.0) -> Path:
    """Write ``walker`` as an FMU at ``path`` (see the module docstring).

    z : the section state the walk starts from (default: the walker's initial guess).
    steps : the DefaultExperiment's stop time is ``steps`` × ``max_step_time`` (the time
        :meth:`~.walker.HybridWalker.walk` gives ``steps`` steps).
    ground_drop : the step-down height (m) of the walk (the terrain's drop parameter).
    fmi, kind : as :func:`porthamiltonian.fmu.export_fmu` (default: co-simulation, where the
        FMU's own stiff integrator locates the contacts' events).
    """
    program = walker_program(walker)
    m, o = walker.model, walker.options
    stop_time = o.walk_time(steps, "steps")
    z = walker.initial_guess() if z is None else np.asarray(z, dtype=float)
    p0 = walker.start_params(ground_drop)
    x0 = walker.lift(z, p0)
    method = o.method if o.method in TABLEAUS else "Rodas5P"
    return export_fmu(
        m, path, fmi=fmi, kind=kind, program=program, x0=x0,
        params=dict(zip(m.param_names, p0.tolist())),
        outputs=[name for name in m.output_names if not name.startswith(_INTERNAL)],
        method=method, rtol=o.rtol, atol=o.atol,
        max_step=o.max_step if math.isfinite(o.max_step) else math.inf,
        stop_time=stop_time, description=walker.doc)

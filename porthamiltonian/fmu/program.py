"""What a model's events do inside an FMU, as data: rules that C can run.

:func:`porthamiltonian.simulate` takes event *actions*, Python callables, which an FMU cannot
carry. An :class:`EventProgram` says the same for the actions that only switch modes: for each
event an ordered list of :class:`EventRule` — conditions on the model's outputs (each output
compared with 0), new values of mode parameters (constants, or outputs evaluated just before the
event), where the jump of H is booked (dissipated or supplied energy), whether the run ends, and
a counter the rule counts under (a walker's heel strikes). The first rule of an event whose
conditions hold fires, as :class:`walker_library.core.machine.ModeMachine` does; rules on the
event ``-1`` apply once at the start. A rule never moves the state: a reset map (a rigid impact)
is Python-level and refused (:func:`check_actions`).

The program indexes the compiled model's outputs and parameters; :meth:`EventProgram.check`
verifies every index against the model, so a program made for one model is refused by another.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..errors import ExportError

if TYPE_CHECKING:
    from ..simulation.compiled import CompiledModel

#: a rule condition's comparison of an output with 0 (the C runtime's codes, ph_fmu.h)
OPERATORS = ("<", "<=", ">", ">=", "==", "!=")

__all__ = ["OPERATORS", "EventProgram", "EventRule", "RuleChange", "RuleCondition",
           "check_actions"]


@dataclass(frozen=True)
class RuleCondition:
    """Output ``output`` (an index into the model's outputs) compared with 0 by ``op``;
    ``text`` says it in words for the FMU's documentation."""

    output: int
    op: str
    text: str = ""


@dataclass(frozen=True)
class RuleChange:
    """Parameter ``param`` (an index) takes ``constant``, or the value of output ``output``
    just before the event."""

    param: int
    constant: float | None = None
    output: int | None = None


@dataclass(frozen=True)
class EventRule:
    """One rule: on event ``event`` (its index among the model's events; -1: at the start),
    when all ``conditions`` hold, apply ``changes``; book a jump of H as ``energy``
    (``"dissipated"`` or ``"supplied"``); ``stop`` ends the run; ``counter`` names the counter
    it counts under (FMU outputs ``<counter>.count`` and ``<counter>.time``), or None;
    ``name`` is shown in the FMU's documentation and log."""

    event: int
    conditions: tuple[RuleCondition, ...] = ()
    changes: tuple[RuleChange, ...] = ()
    energy: str = "dissipated"
    stop: bool = False
    counter: str | None = None
    name: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "conditions", tuple(self.conditions))
        object.__setattr__(self, "changes", tuple(self.changes))


@dataclass(frozen=True)
class EventProgram:
    """The rules of a model's events (see the module docstring).

    rules : in order; of the rules of one event the first whose conditions hold fires.
    counters : the counters' names and descriptions, in order (each rule's ``counter`` one of
        them).
    source : who made it (the FMU's documentation says so), e.g. ``"walker compass_walker"``.
    """

    rules: tuple[EventRule, ...] = ()
    counters: tuple[tuple[str, str], ...] = ()
    source: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "rules", tuple(self.rules))
        object.__setattr__(self, "counters", tuple(tuple(c) for c in self.counters))

    @property
    def modes(self) -> tuple[int, ...]:
        """The parameters the rules change (indices, sorted): discrete states in an FMU."""
        return tuple(sorted({c.param for r in self.rules for c in r.changes}))

    def actions(self) -> tuple[int, ...]:
        """The events that have rules (indices, sorted): terminal inside the FMU."""
        return tuple(sorted({r.event for r in self.rules if r.event >= 0}))

    def check(self, model: CompiledModel) -> None:
        """Every index against ``model``'s events, outputs and parameters, every operator and
        energy booking; an :class:`~porthamiltonian.errors.ExportError` listing every problem."""
        problems = []
        n_events, n_out, n_par = len(model.events), len(model.output_names), len(model.param_names)
        counters = [name for name, _ in self.counters]
        if len(set(counters)) != len(counters):
            problems.append(f"counter names repeat: {counters}")
        for i, r in enumerate(self.rules):
            where = f"rule {i + 1}{f' ({r.name})' if r.name else ''}"
            if not -1 <= r.event < n_events:
                problems.append(f"{where}: event index {r.event} (the model has {n_events} "
                                "events; -1 is the start)")
            if r.energy not in ("dissipated", "supplied"):
                problems.append(f"{where}: energy must be 'dissipated' or 'supplied', got "
                                f"{r.energy!r}")
            if r.counter is not None and r.counter not in counters:
                problems.append(f"{where}: counter {r.counter!r} is not declared "
                                f"(counters: {', '.join(counters) or 'none'})")
            for c in r.conditions:
                if not 0 <= c.output < n_out or c.op not in OPERATORS:
                    problems.append(f"{where}: condition on output {c.output} with {c.op!r} "
                                    f"(outputs 0..{n_out - 1}; operators {' '.join(OPERATORS)})")
            for ch in r.changes:
                if not 0 <= ch.param < n_par:
                    problems.append(f"{where}: change of parameter {ch.param} (parameters "
                                    f"0..{n_par - 1})")
                if (ch.output is None) == (ch.constant is None):
                    problems.append(f"{where}: a change takes a constant or an output, not "
                                    "both or neither")
                elif ch.output is not None and not 0 <= ch.output < n_out:
                    problems.append(f"{where}: change from output {ch.output} (outputs "
                                    f"0..{n_out - 1})")
                elif ch.constant is not None and not math.isfinite(ch.constant):
                    problems.append(f"{where}: change to a non-finite constant {ch.constant}")
            if r.event < 0 and (r.stop or r.counter is not None):
                problems.append(f"{where}: a start rule only sets modes (no stop, no counter)")
        if problems:
            raise ExportError(f"the event program{f' of {self.source}' if self.source else ''} "
                              f"does not fit model {model.name!r}:\n  " + "\n  ".join(problems))


def check_actions(model: CompiledModel, events: Sequence[Any] = (),
                  actions: Mapping[str, Callable] | None = None) -> None:
    """Refuse Python-level events and actions (the arguments :func:`porthamiltonian.simulate`
    takes): an FMU runs compiled C only, and a Python callable cannot be carried into it."""
    if events:
        names = ", ".join(repr(getattr(e, "name", e)) for e in events)
        raise ExportError(
            f"model {model.name!r}: Python-level event(s) {names} cannot be exported to an FMU: "
            "their guards are Python callables, and an FMU runs only the model's compiled C code. "
            "Declare the event in the model ([[events]] in a model file, Model.event(...) in "
            "Python) so that its guard is compiled")
    if actions:
        names = ", ".join(repr(k) for k in actions)
        raise ExportError(
            f"model {model.name!r}: the action(s) of event(s) {names} are Python callables and "
            "cannot be exported to an FMU (an FMU runs only compiled C code). Actions that switch "
            "modes can be given as data instead: program=EventProgram(...) "
            "(porthamiltonian.fmu); a reset map that moves the state (a rigid impact) cannot be "
            "exported")


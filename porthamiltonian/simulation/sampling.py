"""Breakpoints of a run: input samples, the sampling instants of discrete-time blocks, and the
times a compiled loop with sensitivities stores its solution at (``simulate(..., t_eval=...,
sensitivity=...)``; without sensitivities a compiled run samples its steps' interpolant there).

The simulator integrates from one breakpoint to the next, the compiled loop (or scipy's solver)
stopping exactly on it (its ``t_end``), then acts and goes on:

* an input sample time (:meth:`porthamiltonian.simulation.inputs.InputPlan.breakpoints`): the
  input slots of the next piece are set (a held value, a piece of a linear interpolation);
* a sampling instant t_k = t₀ + k·T of a discrete-time block (a discrete controller, a
  zero-order hold; :mod:`porthamiltonian.library.signals`), T its period (the block's output
  ``<block>.T``, read at the start of the run): the block's generated update ``update_<j>(t, x,
  p)`` gives the new values of its discrete states from the state just before t_k, which are
  held until the next sample. Blocks sampled at the same instant all update from the state
  before it (a chain of discrete blocks has a one-sample delay per link), in declaration order.

t₀ is the start of the run; the first sample (k = 0) is taken there, before integrating, the last
one at the largest t_k < t_end. t_k is computed as t₀ + k·T (never accumulated), so the samples
fall exactly on k·T after the start, whatever the number of steps between them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ModelError

if TYPE_CHECKING:
    from .compiled import CompiledModel
    from .inputs import InputPlan


@dataclass(frozen=True)
class DiscreteBlock:
    """A discrete-time block of a compiled model: its component name, the output giving its
    sample period T (s), its discrete states (names, in the order of its update's result) and
    its generated update function's name."""

    component: str
    period: str
    states: tuple[str, ...]
    update: str


class Breakpoints:
    """The breakpoints of one run from ``t_start`` to ``t_end`` (see the module docstring)."""

    def __init__(self, model: CompiledModel, plan: InputPlan | None, t_start: float,
                 t_end: float, y: np.ndarray, p: np.ndarray, stops: np.ndarray | None = None):
        self.model, self.plan = model, plan
        self.input_times = plan.breakpoints(t_start, t_end) if plan is not None else np.empty(0)
        if stops is not None:           # a compiled loop's t_eval: it stops on them, no action
            inside = np.asarray(stops, dtype=float)
            inside = inside[(inside > t_start) & (inside < t_end)]
            self.input_times = np.unique(np.concatenate([self.input_times, inside]))
            self.input_starts: set[float] | None = set(plan.breakpoints(t_start, t_end).tolist()) if plan else set()
        else:
            self.input_starts = None
        self._next_input = 0
        self.t0, self.t_end = t_start, t_end
        self.periods: list[float] = []
        for block in model.discrete:
            period = model.output(block.period, t_start, y, p)
            if not (math.isfinite(period) and period > 0):
                raise ModelError(f"discrete block {block.component!r}: its sample period must be "
                                 f"a finite number > 0, got {period!r}")
            self.periods.append(period)
        self._k = [0] * len(self.periods)          # the next sample of each block

    def __bool__(self) -> bool:
        return bool(len(self.input_times) or self.periods)

    def _sample_time(self, j: int) -> float:
        return self.t0 + self._k[j] * self.periods[j]

    def next(self, t: float) -> float:
        """The first breakpoint after ``t``, or t_end."""
        candidates = [self.t_end]
        while self._next_input < len(self.input_times) and self.input_times[self._next_input] <= t:
            self._next_input += 1
        if self._next_input < len(self.input_times):
            candidates.append(float(self.input_times[self._next_input]))
        for j in range(len(self.periods)):
            while self._sample_time(j) <= t:
                self._k[j] += 1          # (after an event exactly at a sampling instant)
            if self._sample_time(j) < self.t_end:
                candidates.append(self._sample_time(j))
        return min(candidates)

    def due(self, t: float) -> tuple[bool, list[int]]:
        """At the breakpoint ``t``: (whether an input piece starts, the discrete blocks sampled);
        advances past them."""
        starts = (self._next_input < len(self.input_times)
                  and self.input_times[self._next_input] == t)
        if starts:
            self._next_input += 1
            if self.input_starts is not None:
                starts = t in self.input_starts
        blocks = [j for j in range(len(self.periods)) if self._sample_time(j) == t]
        for j in blocks:
            self._k[j] += 1
        return starts, blocks


def sample(model: CompiledModel, blocks: list[int], t: float, y: np.ndarray,
           p: np.ndarray) -> np.ndarray:
    """The integration state after the sampling of the discrete ``blocks`` (indices into
    ``model.discrete``) at time ``t``: each block's update from ``y`` (the state before t),
    written into its discrete states."""
    out = np.array(y, dtype=float)
    pn = model.native_params(p)
    for j in blocks:
        block = model.discrete[j]
        values = np.asarray(model.functions.extra[block.update](t, np.ascontiguousarray(y), pn))
        for name, value in zip(block.states, values):
            out[model.state_index(name)] = value
    if not np.all(np.isfinite(out)):
        raise ModelError(f"the sampling at t = {t:g} gave a non-finite state: {out}")
    return out


__all__ = ["Breakpoints", "DiscreteBlock", "sample"]

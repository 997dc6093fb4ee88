"""Binding a model's inputs at run time: constants, samples, callables.

A model declares inputs (``[inputs]`` in a model file, ``Model.input``); ``simulate(...,
inputs={name: binding})`` binds every one of them, each to

* a number: a constant;
* :class:`Samples` ``(t, values, hold)``: ``hold="zoh"`` holds each value from its time until the
  next sample (the last one to the end of the run; the first sample must be at or before the
  start), ``hold="linear"`` interpolates linearly between samples (which must cover the whole
  span);
* a callable ``u(t, x)`` of the time (s) and the model state x (scipy's ``fun(t, y)`` convention)
  returning the input's value: evaluated at every right-hand-side call, so it runs on the scipy
  path (``method="auto"`` picks Radau; the stiff methods then estimate the Jacobian by finite
  differences, since u's dependence on x is unknown).

``inputs`` may also be one callable ``u(t, x)`` returning all inputs (an array of length m, in the
order of ``model.input_names``), or an array of m constants. A controller compiled with the model
is not bound here: it is part of the model (its output bound to the input in the model, see
``Model.bind_input`` and :mod:`porthamiltonian.library.signals`).

How a binding reaches the compiled code: input k of m reads u_k(t) = p[P + k] + p[P + m + k]·t
from two slots of the parameter vector (:func:`porthamiltonian.compiler.codegen.input_slots`).
A constant and a held sample set the first slot; a piece of a linear interpolation both. The
simulator stops the compiled loop at every sample time (a breakpoint, see :class:`InputPlan`),
sets the slots of the next piece and goes on, so the compiled loops run unchanged.

Errors are :class:`~porthamiltonian.errors.InputError` naming the input: an input left unbound,
an unknown name, a value that is not a finite number, samples of the wrong shape, not increasing,
or not covering the span, a callable returning the wrong shape.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from numbers import Real
from typing import Any, Literal

import numpy as np

from ..errors import InputError

HOLDS = ("zoh", "linear")


@dataclass(frozen=True)
class Samples:
    """Samples of one input: increasing times ``t`` (s) and ``values`` (one per time, the
    input's SI unit), held (``hold="zoh"``) or interpolated linearly (``hold="linear"``) between
    them. Checked when made: equal lengths, at least one sample (two for ``linear``), finite,
    strictly increasing times."""

    t: Any
    values: Any
    hold: Literal["zoh", "linear"] = "zoh"

    def __post_init__(self) -> None:
        t = np.array(self.t, dtype=float) if _numeric(self.t) else None
        v = np.array(self.values, dtype=float) if _numeric(self.values) else None
        if t is None or v is None:
            raise InputError("Samples takes arrays of numbers: Samples(t=[...], values=[...])")
        if self.hold not in HOLDS:
            raise InputError(f"Samples hold must be one of {', '.join(HOLDS)}, got "
                             f"{self.hold!r}")
        if t.ndim != 1 or v.shape != t.shape:
            raise InputError(f"Samples: times and values must be 1-D and of equal length, got "
                             f"shapes {t.shape} and {v.shape}")
        least = 2 if self.hold == "linear" else 1
        if len(t) < least:
            raise InputError(f"Samples with hold={self.hold!r} need at least {least} sample(s), "
                             f"got {len(t)}")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
            raise InputError("Samples: times and values must be finite")
        if np.any(np.diff(t) <= 0):
            raise InputError("Samples: times must be strictly increasing")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "values", v)

    def value(self, t: float) -> float:
        """The signal at time ``t`` (s), as the simulation sees it."""
        k = int(np.searchsorted(self.t, t, side="right")) - 1
        k = min(max(k, 0), len(self.t) - 1)
        if self.hold == "zoh" or k == len(self.t) - 1:
            return float(self.values[k])
        slope = (self.values[k + 1] - self.values[k]) / (self.t[k + 1] - self.t[k])
        return float(self.values[k] + slope * (t - self.t[k]))

    def piece(self, t: float) -> tuple[float, float]:
        """(value at t = 0, rate) of the piece of the signal that starts at ``t``: u = a + b·t."""
        k = int(np.searchsorted(self.t, t, side="right")) - 1
        k = min(max(k, 0), len(self.t) - 1)
        if self.hold == "zoh" or k == len(self.t) - 1:
            return float(self.values[k]), 0.0
        slope = float((self.values[k + 1] - self.values[k]) / (self.t[k + 1] - self.t[k]))
        return float(self.values[k] - slope * self.t[k]), slope


def _numeric(value: Any) -> bool:
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        return False
    return array.dtype.kind in "iuf"


@dataclass(frozen=True)
class InputPlan:
    """The inputs of one run, checked: per input its binding, and what the simulator needs —
    :meth:`breakpoints` (the sample times inside the span, where the compiled loop stops and
    the slots change), :meth:`slots` (the slot values of the piece starting at a time) and
    :attr:`callable` (for callables: the parameter vector at (t, x), scipy path only)."""

    names: tuple[str, ...]
    n_params: int
    bindings: tuple[Any, ...]          # per input: float, Samples or callable
    joint: Callable[..., Any] | None = None      # one callable for all inputs

    @property
    def m(self) -> int:
        """The number of inputs."""
        return len(self.names)

    @property
    def has_callable(self) -> bool:
        """True when some input is bound to a callable (the run needs a scipy method)."""
        return self.joint is not None or any(callable(b) for b in self.bindings)

    def breakpoints(self, t_start: float, t_end: float) -> np.ndarray:
        """The sample times strictly inside (t_start, t_end), sorted, without repeats."""
        times = [b.t for b in self.bindings if isinstance(b, Samples)]
        if not times:
            return np.empty(0)
        all_t = np.unique(np.concatenate(times))
        return all_t[(all_t > t_start) & (all_t < t_end)]

    def slots(self, p: np.ndarray, t: float) -> np.ndarray:
        """``p`` with the input slots of the pieces that start at ``t`` (callables: zero; their
        values come from :meth:`at`)."""
        p = np.array(p, dtype=float)
        P, m = self.n_params, self.m
        for k, b in enumerate(self.bindings):
            if isinstance(b, Samples):
                p[P + k], p[P + m + k] = b.piece(t)
            elif callable(b) or self.joint is not None:
                p[P + k], p[P + m + k] = 0.0, 0.0
            else:
                p[P + k], p[P + m + k] = float(b), 0.0
        return p

    def at(self, t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """``p`` with every callable input's slot set to its value at (t, x) (x: model state)."""
        P, m = self.n_params, self.m
        if self.joint is not None:
            values = _call(self.joint, t, x, (m,), "inputs")
            p = np.array(p, dtype=float)
            p[P:P + m] = values
            return p
        p = np.array(p, dtype=float)
        for k, b in enumerate(self.bindings):
            if callable(b):
                p[P + k] = float(_call(b, t, x, (), self.names[k]))
        return p

    def values(self, t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The inputs' values at (t, x) under the slots ``p`` (callables evaluated)."""
        p = self.at(t, x, p) if self.has_callable else p
        P, m = self.n_params, self.m
        return np.asarray(p[P:P + m]) + np.asarray(p[P + m:P + 2 * m]) * t


def _call(fn: Callable[..., Any], t: float, x: np.ndarray, shape: tuple[int, ...],
          what: str) -> np.ndarray:
    """``fn(t, x)`` as a float array of ``shape``; InputError naming ``what`` otherwise."""
    value = fn(t, np.array(x, dtype=float))
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"input {what!r}: the callable returned {value!r}, not a number") from None
    if array.shape != shape and not (shape == () and array.shape == (1,)):
        raise InputError(f"input {what!r}: the callable returned shape {array.shape}, expected "
                         f"{shape or 'a scalar'}")
    if not np.all(np.isfinite(array)):
        raise InputError(f"input {what!r}: the callable returned a non-finite value at "
                         f"t = {t:g}: {array}")
    return array.reshape(shape)


def plan_inputs(names: list[str], n_params: int, inputs: Any, t_start: float,
                t_end: float) -> InputPlan | None:
    """Check ``inputs`` (``simulate``'s argument) against the model's input ``names`` and the
    span; the :class:`InputPlan`, or None for a model without inputs (then ``inputs`` must be
    None or empty). Raises :class:`~porthamiltonian.errors.InputError` (see the module
    docstring)."""
    listed = ", ".join(names) or "none"
    if not names:
        if inputs is None or (isinstance(inputs, Mapping) and not inputs):
            return None
        raise InputError(f"the model has no inputs, but inputs were given: {_shown(inputs)}")
    if inputs is None:
        raise InputError(f"the model's inputs {listed} are not bound: pass inputs={{name: "
                         "value} to simulate (a number, Samples(t, values, hold), or a "
                         "callable u(t, x)), or bind them in the model (Model.bind_input)")
    m = len(names)
    if callable(inputs) and not isinstance(inputs, Mapping):
        return InputPlan(tuple(names), n_params, (None,) * m, joint=inputs)
    if not isinstance(inputs, Mapping):
        array = np.asarray(inputs, dtype=float) if _numeric(inputs) else None
        if array is None or array.shape != (m,):
            raise InputError(f"inputs must be a mapping {{name: binding}}, one callable, or "
                             f"{m} numbers (the inputs {listed}); got {_shown(inputs)}")
        inputs = dict(zip(names, array.tolist()))
    unknown = [k for k in inputs if k not in names]
    if unknown:
        raise InputError(f"the model has no input(s) {', '.join(map(str, unknown))}; its "
                         f"inputs: {listed}")
    missing = [k for k in names if k not in inputs]
    if missing:
        raise InputError(f"input(s) {', '.join(missing)} not bound; bind every input of the "
                         f"model ({listed})")
    bindings = []
    for name in names:
        b = inputs[name]
        if isinstance(b, Samples):
            if b.t[0] > t_start:
                raise InputError(f"input {name!r}: the samples start at t = {b.t[0]:g}, after "
                                 f"the start of the run t = {t_start:g}; give a sample at or "
                                 "before it")
            if b.hold == "linear" and b.t[-1] < t_end:
                raise InputError(f"input {name!r}: the samples end at t = {b.t[-1]:g}, before "
                                 f"the end of the run t = {t_end:g}; linear interpolation needs "
                                 "samples covering the span")
        elif callable(b):
            pass
        elif isinstance(b, Real) and not isinstance(b, bool):
            try:
                value = float(b)
            except OverflowError:       # an integer beyond the float range: not finite
                value = math.inf
            if not math.isfinite(value):
                raise InputError(f"input {name!r} must be finite, got {b!r}")
            b = value
        else:
            raise InputError(f"input {name!r}: bind it to a number, Samples(t, values, hold) "
                             f"or a callable u(t, x); got {_shown(b)}")
        bindings.append(b)
    return InputPlan(tuple(names), n_params, tuple(bindings))


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:70] + "..."


__all__ = ["HOLDS", "InputPlan", "Samples", "plan_inputs"]

"""Checks of the numerical options of the public entry points (``simulate`` and the model file's
``[simulation]`` table): one rule per option, one :class:`~porthamiltonian.errors.OptionError`
naming the option, the rule and the value. No work starts with an option outside its rule
(a NaN tolerance used to hang the step loop, a negative one to return wrong numbers marked
"finished").

Rules
-----
* ``t_start``, ``t_end``: finite numbers, ``t_end > t_start``.
* ``rtol``: a finite number with ``RTOL_MIN <= rtol < 1`` (100 float64 epsilons, the smallest
  relative error a step can honour, as scipy also requires).
* ``atol``: a finite number > 0, or one per model state.
* ``max_step``: a number > 0 (``inf``: no bound); ``first_step``: finite, > 0 and at most the span.
* ``t_eval``: finite, non-decreasing times inside [t_start, t_end].
* ``max_events``, ``max_steps``: integers >= 1; ``divergence_bound``: a number > 0.
* ``jacobian``, ``dense_output``: booleans; ``method``: ``"auto"`` or one of :data:`METHODS`.
* ``sensitivity``: False, True (every model state), finite seed directions (n x m, m >= 1),
  parameter names (every model state and those parameters), or a
  :class:`~porthamiltonian.simulation.saltation.Seeds`.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from numbers import Integral, Real
from typing import Any

import numpy as np

from ..errors import OptionError
from ..integrators import COMPILED_METHODS
from .saltation import Seeds

#: the integration methods by name: the compiled loops, then scipy's
METHODS = (*COMPILED_METHODS, "Radau", "BDF", "LSODA", "RK45", "DOP853")

#: The smallest relative tolerance accepted (100 float64 epsilons).
RTOL_MIN = 100 * float(np.finfo(float).eps)


def is_real(value: Any) -> bool:
    """``value`` is a real number (int, float, numpy's scalars), not a bool."""
    return isinstance(value, Real) and not isinstance(value, bool)


def check_number(name: str, value: Any, *, positive: bool = False, finite: bool = True,
           below: float | None = None, at_least: float | None = None) -> float:
    """``value`` as a float, after checking it is a number satisfying the rule; else OptionError
    naming ``name``."""
    if not is_real(value):
        raise OptionError(f"{name} must be a number, got {type(value).__name__} {value!r}")
    try:
        x = float(value)
    except OverflowError:               # an integer beyond the float range: not finite
        x = math.inf if value > 0 else -math.inf
    rules = []
    if finite:
        rules.append("finite")
    if positive:
        rules.append("> 0")
    if at_least is not None:
        rules.append(f">= {at_least:g}")
    if below is not None:
        rules.append(f"< {below:g}")
    ok = not math.isnan(x) and (math.isfinite(x) or not finite)
    ok = ok and (x > 0 or not positive) and (at_least is None or x >= at_least)
    ok = ok and (below is None or x < below)
    if not ok:
        raise OptionError(f"{name} must be {' and '.join(rules) or 'a number, not NaN'}, got "
                          f"{value!r}")
    return x


def check_integer(name: str, value: Any, at_least: int = 1) -> int:
    """``value`` as an int, after checking it is an integer >= ``at_least``; else OptionError."""
    if not isinstance(value, Integral) or isinstance(value, bool) or value < at_least:
        raise OptionError(f"{name} must be an integer >= {at_least}, got {value!r}")
    return int(value)


def check_flag(name: str, value: Any) -> bool:
    """``value`` as a bool, after checking it is True or False; else OptionError."""
    if not isinstance(value, (bool, np.bool_)):
        raise OptionError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def check_method(value: Any) -> str:
    """An integration method: ``"auto"`` or one of :data:`METHODS`."""
    if value != "auto" and value not in METHODS:
        raise OptionError(f"unknown method {value!r}; choose 'auto' or one of {', '.join(METHODS)}")
    return str(value)


def check_rtol(value: Any) -> float:
    """A relative tolerance: finite, ``RTOL_MIN <= rtol < 1``."""
    x = check_number("rtol", value, positive=True, below=1.0)
    if x < RTOL_MIN:
        raise OptionError(f"rtol must be >= {RTOL_MIN:.3g} (100 float64 epsilons: a step cannot "
                          f"be more accurate than that), got {value!r}")
    return x


def check_atol(value: Any, n_states: int) -> float | np.ndarray:
    """An absolute tolerance: a finite number > 0, or one per model state."""
    if is_real(value):
        return check_number("atol", value, positive=True)
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise OptionError(f"atol must be a number or one number per state, got {value!r}") from None
    if arr.shape != (n_states,):
        raise OptionError(f"atol must be a scalar or have one value per state ({n_states}), got "
                          f"shape {arr.shape}")
    if not np.all(np.isfinite(arr) & (arr > 0)):
        raise OptionError(f"atol must be finite and > 0 for every state, got {arr.tolist()}")
    return arr


def check_t_eval(value: Any, t_start: float, t_end: float) -> np.ndarray:
    """Output times: finite, non-decreasing, inside [t_start, t_end]."""
    try:
        times = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise OptionError(f"t_eval must be an array of times, got {value!r}") from None
    if times.ndim != 1:
        raise OptionError(f"t_eval must be a one-dimensional array of times, got shape {times.shape}")
    if not np.all(np.isfinite(times)):
        raise OptionError("t_eval must hold finite times")
    if len(times) and (times[0] < t_start or times[-1] > t_end or np.any(np.diff(times) < 0)):
        raise OptionError(f"t_eval must be non-decreasing times inside [t_start, t_end] = "
                          f"[{t_start:g}, {t_end:g}], got [{times.min():g} ... {times.max():g}]"
                          f"{' (not sorted)' if np.any(np.diff(times) < 0) else ''}")
    return times


def check_sensitivity(value: Any, n_states: int) -> Seeds | None:
    """What the sensitivities differentiate, as :class:`~.saltation.Seeds` with the state
    directions an n x m0 array: None for False (or None); the identity (n x n) for True; the given n x m
    array of finite numbers (a vector: one direction); for parameter names (strings), the
    identity and those parameters; a ``Seeds`` checked likewise (its ``initial``: n x k)."""
    if isinstance(value, Seeds):
        states = (np.eye(n_states) if value.states is True else np.zeros((n_states, 0))
                  if value.states is False else _directions(value.states, n_states))
        names = _parameter_names(value.parameters)
        if states.shape[1] + len(names) == 0:
            raise OptionError("sensitivity: Seeds with no state directions and no parameters "
                              "differentiates nothing")
        initial = None
        if value.initial is not None:
            initial = np.array(value.initial, dtype=float)
            if initial.ndim == 1 and len(names) == 1:
                initial = initial[:, None]
            if initial.shape != (n_states, len(names)) or not np.all(np.isfinite(initial)):
                raise OptionError(f"sensitivity: Seeds.initial must be finite, {n_states} x "
                                  f"{len(names)} (dx0/dp, one column per parameter), got "
                                  f"shape {np.shape(value.initial)}")
        return Seeds(states, names, initial)
    if value is None or isinstance(value, (bool, np.bool_)):
        return Seeds(np.eye(n_states)) if value else None
    if isinstance(value, (list, tuple)) and value and all(isinstance(v, str) for v in value):
        return Seeds(np.eye(n_states), _parameter_names(value))
    return Seeds(_directions(value, n_states))


def _parameter_names(names: Any) -> tuple[str, ...]:
    """The differentiated parameters' names: distinct strings."""
    if isinstance(names, str) or not all(isinstance(v, str) for v in names):
        raise OptionError(f"sensitivity parameters must be a list of parameter names, got "
                          f"{names!r}")
    checked: tuple[str, ...] = tuple(names)
    if len(set(checked)) != len(checked):
        raise OptionError(f"sensitivity parameters must be distinct, got {list(checked)}")
    return checked


def _directions(value: Any, n_states: int) -> np.ndarray:
    """Seed directions: an n x m array of finite numbers (a vector: one direction)."""
    try:
        seeds = np.array(value, dtype=float)
    except OverflowError:               # an integer beyond the float range: not finite
        raise OptionError("sensitivity directions must be finite") from None
    except (TypeError, ValueError):
        raise OptionError(f"sensitivity must be True, False or an array of directions "
                          f"({n_states} x m), got {value!r}") from None
    if seeds.ndim == 1:
        seeds = seeds[:, None]
    if seeds.ndim != 2 or seeds.shape[0] != n_states or seeds.shape[1] < 1:
        raise OptionError(f"sensitivity directions must have shape ({n_states}, m) with m >= 1 "
                          f"(one column per direction in the model state), got shape "
                          f"{seeds.shape}")
    if not np.all(np.isfinite(seeds)):
        raise OptionError("sensitivity directions must be finite")
    return seeds


def check_simulation(n_states: int, t_end: Any, x0: Any, params: Any, *, t_start: Any,
                     method: Any, rtol: Any, atol: Any, max_step: Any, first_step: Any,
                     jacobian: Any, actions: Any, events: Any, t_eval: Any, dense_output: Any,
                     max_events: Any, max_steps: Any, divergence_bound: Any,
                     sensitivity: Any = False) -> dict[str, Any]:
    """Check every argument of :func:`porthamiltonian.simulation.simulate.simulate`; return them converted
    (floats, arrays). Raises OptionError naming the first wrong one."""
    t0 = check_number("t_start", t_start)
    t1 = check_number("t_end", t_end)
    if not t1 > t0:
        raise OptionError(f"t_end must be > t_start ({t0:g}), got {t1:g}")
    if not isinstance(method, str):
        raise OptionError(f"method must be a string (e.g. 'Radau'), got {method!r}")
    if x0 is not None and not isinstance(x0, Mapping):
        try:                            # its length: CompiledModel.augment, naming the states
            np.asarray(x0, dtype=float)
        except (TypeError, ValueError):
            raise OptionError(f"x0 must be None, a mapping {{state: value}} or {n_states} "
                              f"numbers, got {x0!r}") from None
    if params is not None and not isinstance(params, Mapping):
        raise OptionError(f"params must be a mapping {{name: value}}, got {type(params).__name__}")
    for name, value in (("actions", actions),):
        if value is not None and not (isinstance(value, Mapping)
                                      and all(callable(a) for a in value.values())):
            raise OptionError(f"{name} must be a mapping event name -> callable, got {value!r}")
    if events is not None and not isinstance(events, (list, tuple)):
        raise OptionError(f"events must be a list of Event, got {type(events).__name__}")
    out: dict[str, Any] = {
        "t_start": t0, "t_end": t1, "rtol": check_rtol(rtol), "atol": check_atol(atol, n_states),
        "max_step": check_number("max_step", max_step, positive=True, finite=False),
        "first_step": None if first_step is None else check_number(
            "first_step", first_step, positive=True),
        "jacobian": check_flag("jacobian", jacobian),
        "dense_output": check_flag("dense_output", dense_output),
        "t_eval": None if t_eval is None else check_t_eval(t_eval, t0, t1),
        "max_events": check_integer("max_events", max_events),
        "max_steps": check_integer("max_steps", max_steps),
        "divergence_bound": check_number("divergence_bound", divergence_bound, positive=True,
                                        finite=False),
        "sensitivity": check_sensitivity(sensitivity, n_states),
    }
    if out["first_step"] is not None and out["first_step"] > t1 - t0:
        raise OptionError(f"first_step must be at most the span t_end - t_start = {t1 - t0:g}, "
                          f"got {first_step!r}")
    return out


__all__ = ["RTOL_MIN", "check_atol", "check_flag", "check_integer", "check_number", "check_rtol",
           "check_sensitivity", "check_simulation", "check_t_eval"]

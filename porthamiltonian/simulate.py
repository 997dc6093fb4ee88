"""Hybrid simulation: stiff integration with the analytic Jacobian, events, modes and resets.

The integration state is the model state followed by the ledger states E_diss and E_in
(see :mod:`porthamiltonian.compiler.assemble`). Discrete modes are parameters (contact flags,
stance leg...) that an event action changes; a reset map changes the state. Every jump of the
Hamiltonian at a reset is booked in the ledger (as dissipated energy by default, e.g. a plastic
impact; as supplied energy when the action says so, e.g. a controller switching a stiffness), so
the residual r = H(t) − H(0) + E_diss − E_in stays closed across events.

The step loop is our own, over scipy's public step-wise solvers (``scipy.integrate.Radau``, ``BDF``,
``LSODA``, ``RK45``, ``DOP853``), rather than ``solve_ivp``: all guards are evaluated by one compiled
call per step, the step's interpolant is built only when a guard changes sign (or when dense output
is asked for), divergence is a cheap per-step check, a guard that has just fired is kept on its new
side at the restart (no re-firing at the same crossing), non-terminal events are recorded, and a
failing step keeps everything integrated before it. A failing or diverging integration ends with a
status in the :class:`Trajectory`, never with an exception from inside scipy.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.integrate as si
from scipy.integrate import OdeSolution
from scipy.optimize import brentq

from .compiled import CompiledModel
from .errors import ModelError, StateError
from .options import check_simulation
from .trajectory import Segment, Trajectory

METHODS = ("Rodas4", "Rodas5P", "Radau", "BDF", "LSODA", "RK45", "DOP853")
#: the methods whose whole step loop is compiled with the model (Functions.loops)
_COMPILED = ("Rodas4", "Rodas5P")
_STIFF = ("Radau", "BDF", "LSODA")
_EPS = np.finfo(float).eps


@dataclass
class Reset:
    """What an event action returns.

    x : new model state (length n), or None to keep it.
    params : parameters (modes) to change, by name.
    stop : end the simulation after this event.
    energy : where a jump of H is booked: ``"dissipated"`` (E_diss += H⁻ − H⁺) or
        ``"supplied"`` (E_in += H⁺ − H⁻).
    """

    x: np.ndarray | None = None
    params: Mapping[str, float] | None = None
    stop: bool = False
    energy: Literal["dissipated", "supplied"] = "dissipated"


#: An event action: (t, model state x, parameter vector p) -> Reset.
Action = Callable[[float, np.ndarray, np.ndarray], Reset]


@dataclass
class Event:
    """A Python-level event: guard g(t, x, p) on the model state; fires when g crosses zero."""

    name: str
    guard: Callable[[float, np.ndarray, np.ndarray], float]
    direction: int = 0
    terminal: bool = True


def simulate(model: CompiledModel, t_end: float, x0=None, params: Mapping[str, float] | None = None,
             *, t_start: float = 0.0, method: str = "auto", rtol: float = 1e-8,
             atol: float | np.ndarray = 1e-10,
             max_step: float = math.inf, first_step: float | None = None, jacobian: bool = True,
             actions: Mapping[str, Action] | None = None, events: list[Event] | None = None,
             t_eval: np.ndarray | None = None, dense_output: bool = False,
             max_events: int = 100_000, max_steps: int = 10_000_000,
             divergence_bound: float = 1e12) -> Trajectory:
    """Simulate ``model`` from ``t_start`` to ``t_end``.

    Parameters
    ----------
    x0 : initial model state: an array (length n), a mapping ``{state name: value}`` overriding
        the components' initial values, or None for those values.
    params : parameter values by name (defaults for the others).
    rtol, atol : tolerances; ``atol`` a scalar or one value per model state (e.g. tiny masses with
        tiny momenta); the ledger states E_diss, E_in get the largest of them.
    method : ``"auto"`` (default: Rodas5P, or Radau when Python events, ``t_eval`` or dense
        output are asked for), ``"Rodas5P"`` or ``"Rodas4"`` (stiff, L-stable Rosenbrock methods
        of order 5 and 4 whose whole step loop is compiled with the model: the fast path with
        the C or numba back end; model events only, no ``t_eval`` or dense output; Rodas5P
        takes fewer steps at the same accuracy, benchmarks/RESULTS.md), or a scipy method:
        Radau, BDF, LSODA (stiff, given the analytic Jacobian unless ``jacobian=False``), RK45,
        DOP853.
    actions : event name -> action (model events or ``events``). An event without action is
        recorded; if it is terminal, the simulation stops there.
    events : extra Python-level events.
    t_eval : times at which to store the solution (default: every accepted step).
    dense_output : keep the interpolants, for :meth:`Trajectory.sol` (costs time).
    max_events, max_steps : bounds (a chattering guard ends the run with status "failed").
    divergence_bound : the run ends with status "diverged" when max|x| exceeds it.

    Every argument is checked first (:mod:`porthamiltonian.options`): a wrong type or a value
    outside its rule (a NaN, zero or negative tolerance, ``rtol >= 1``, ``t_eval`` outside the
    span) raises :class:`~porthamiltonian.errors.OptionError` naming it, before any work.
    """
    checked = check_simulation(
        model.n_states, t_end, x0, params, t_start=t_start, method=method, rtol=rtol, atol=atol,
        max_step=max_step, first_step=first_step, jacobian=jacobian, actions=actions,
        events=events, t_eval=t_eval, dense_output=dense_output, max_events=max_events,
        max_steps=max_steps, divergence_bound=divergence_bound)
    t_start, t_end, rtol, atol, max_step, first_step, t_eval = (checked[k] for k in (
        "t_start", "t_end", "rtol", "atol", "max_step", "first_step", "t_eval"))
    if method == "auto":
        method = "Radau" if (events or t_eval is not None or dense_output) else "Rodas5P"
    if method not in METHODS:
        raise ModelError(f"unknown method {method!r}; choose 'auto' or one of {', '.join(METHODS)}")
    p = model.params(params)
    if x0 is None or isinstance(x0, Mapping):
        x = model.initial_state(p, x0)
    else:
        x = np.array(x0, dtype=float)
    y = model.augment(x)
    if not np.all(np.isfinite(y)):
        raise StateError(f"model {model.name!r}: initial state is not finite: {x}")
    py_events = list(events or [])
    names = [e.name for e in model.events] + [e.name for e in py_events]
    actions = dict(actions or {})
    unknown = set(actions) - set(names)
    if unknown:
        raise ModelError(f"actions for unknown event(s) {', '.join(sorted(unknown))}; events: "
                         f"{', '.join(names) or 'none'}")
    direction = np.array([e.direction for e in model.events] + [e.direction for e in py_events])
    terminal = np.array([e.terminal or e.name in actions for e in [*model.events, *py_events]],
                        dtype=bool)
    t_eval = None if t_eval is None else np.asarray(t_eval, dtype=float)
    if method in _COMPILED and (py_events or t_eval is not None or dense_output):
        raise ModelError(f"method {method!r} (a compiled loop) takes model events only and no "
                         "t_eval or dense_output; use a scipy method (e.g. Radau) for those")
    run = _Run(model, method, rtol, atol, max_step, first_step, jacobian and method in _STIFF,
               py_events, direction, terminal, t_eval, dense_output, divergence_bound, max_steps)
    traj = Trajectory(model)
    traj.h0 = float(model.energy(t_start, y, p)[0])
    t, fired, n_events = t_start, None, 0
    n = model.n_states
    while True:
        t_restart = t
        status, t, y, k = run.segment(traj, t, y, p, t_end, fired)
        if status != "event":
            return traj
        name = names[k]
        traj.record_event(t, name)
        n_events += 1
        if n_events > max_events:
            traj.finish("failed", f"more than {max_events} events (last {name!r} at t = {t:.6g}): "
                                  "the guard chatters; add hysteresis to it")
            return traj
        action = actions.get(name)
        if action is None:
            traj.finish("event", f"terminal event {name!r} at t = {t:.6g}")
            return traj
        reset = action(t, y[:n].copy(), p.copy())
        h_before = float(model.energy(t, y, p)[0])
        moved = reset.x is not None and not np.array_equal(np.asarray(reset.x, dtype=float), y[:n])
        if reset.params:
            p = model.params(dict(zip(model.param_names, p)) | dict(reset.params))
        if reset.x is not None:
            new_x = np.asarray(reset.x, dtype=float)
            if new_x.shape != (n,) or not np.all(np.isfinite(new_x)):
                raise StateError(f"action for event {name!r} returned an invalid state {new_x}")
            y = y.copy()
            y[:n] = new_x
        jump = float(model.energy(t, y, p)[0]) - h_before
        y = y.copy()
        if reset.energy == "dissipated":
            y[n] -= jump
        else:
            y[n + 1] += jump
        traj.record_jump(t, name, jump)
        traj.add(Segment(np.array([t]), y[:, None].copy(), p.copy(), None), 0, 0, 0)
        if reset.stop:
            traj.finish("event", f"stopped by the action of event {name!r} at t = {t:.6g}")
            return traj
        if t >= t_end:
            traj.finish("finished", "reached t_end")
            return traj
        # a guard that fired after some integration and whose state was not moved sits on its
        # root: keep it on its new side at the restart so that it does not fire again at the same
        # crossing. After a reset that moved the state, or an event at the very start of a segment,
        # guards are taken as they are (a state put back onto a guard and pushed across it again
        # fires again: a chattering contact, caught by max_events)
        fired = None if (moved or t == t_restart) else k


class _Run:
    """The step loop of one simulation (one continuous segment per call to :meth:`segment`)."""

    def __init__(self, model, method, rtol, atol, max_step, first_step, use_jac, py_events,
                 direction, terminal, t_eval, dense, bound, max_steps):
        self.model, self.method = model, method
        atol = np.asarray(atol, dtype=float)
        if atol.ndim == 1:
            if atol.shape != (model.n_states,):
                raise ModelError(f"atol must be a scalar or have one value per state "
                                 f"({model.n_states}), got shape {atol.shape}")
            # the ledger states: scaled like the largest state tolerance (scipy methods)
            atol = np.concatenate([atol, [atol.max(), atol.max()]])
        self.options = {"rtol": rtol, "atol": atol if atol.ndim else float(atol),
                        "max_step": max_step}
        if first_step is not None:
            self.options["first_step"] = first_step
        self.use_jac = use_jac
        self.py_events = py_events
        self.direction, self.terminal = direction, terminal
        self.t_eval, self.dense, self.bound = t_eval, dense, bound
        self.max_steps = max_steps
        self.n_model_events = len(model.events)
        self.steps = 0
        self.h_next: dict[int, float] = {}

    def guards(self, t, y, pn, p):
        n = self.model.n_states
        g = np.asarray(self.model.functions.guards(t, y, pn))[: self.n_model_events]
        if self.py_events:
            g = np.concatenate([g, [e.guard(t, y[:n], p) for e in self.py_events]])
        return g

    def segment(self, traj, t0, y0, p, t_end, fired):
        """Integrate from (t0, y0) until t_end or a terminal event; returns (status, t, y, k)."""
        if self.method in _COMPILED:
            return self.segment_compiled(traj, t0, y0, p, t_end, fired)
        model, n = self.model, self.model.n_states
        f = model.functions
        pn = model.native_params(p)
        rhs, jacf = f.rhs, f.jac

        def fun(t, y):
            return rhs(t, y, pn)

        options = dict(self.options)
        if self.use_jac:
            options["jac"] = lambda t, y: jacf(t, y, pn)
        solver = getattr(si, self.method)(fun, t0, y0, t_end, **options)
        ts, ys, interpolants = [t0], [y0], []
        if self.t_eval is not None:
            ts, ys = [], []
            self._eval_at(ts, ys, None, t0, t0, y0, include_start=True)
        has_events = len(self.direction) > 0
        g_old = self.guards(t0, y0, pn, p) if has_events else None
        if fired is not None:  # keep a guard that just fired on its new side at the restart
            side = self.direction[fired] or -np.sign(traj.pre_event_sign or 1.0)
            g_old[fired] = side * max(abs(g_old[fired]), 1e-300)

        def close(status, message, t_last, y_last, k=-1):
            traj.add(Segment(np.array(ts), np.array(ys).T if ys else np.empty((n + 2, 0)), p.copy(),
                             OdeSolution([s.t_old for s in interpolants] + [interpolants[-1].t],
                                         interpolants) if (self.dense and interpolants) else None),
                     solver.nfev, solver.njev, solver.nlu)
            if status != "event":
                traj.finish(status, message)
            return status, t_last, y_last, k

        while True:
            t_old = solver.t
            try:
                with np.errstate(all="ignore"):
                    message = solver.step()
            except (ValueError, ArithmeticError, np.linalg.LinAlgError) as err:
                return close("failed", f"integration failed at t = {t_old:.6g}: {err}", t_old, None)
            self.steps += 1
            if solver.status == "failed":
                return close("failed", f"{self.method} failed at t = {t_old:.6g}: {message}",
                             t_old, None)
            t_new, y_new = solver.t, solver.y
            if not np.all(np.isfinite(y_new)) or np.max(np.abs(y_new[:n])) > self.bound:
                return close("diverged", f"max|x| exceeded {self.bound:g} (or became non-finite) "
                             f"near t = {t_new:.6g}", t_old, None)
            step_sol = None
            if self.dense or self.t_eval is not None:
                step_sol = solver.dense_output()
                if self.dense:
                    interpolants.append(step_sol)
            if has_events:
                g_new = self.guards(t_new, y_new, pn, p)
                active = _active(g_old, g_new, self.direction)
                if len(active):
                    step_sol = step_sol or solver.dense_output()
                    roots = []
                    for k in active:
                        def gk(t, k=k):
                            return self.guards(t, step_sol(t), pn, p)[k]
                        roots.append((brentq(gk, t_old, t_new, xtol=4 * _EPS, rtol=4 * _EPS), k))
                    roots.sort()
                    for t_root, k in roots:
                        y_root = step_sol(t_root)
                        if self.terminal[k]:
                            traj.pre_event_sign = float(np.sign(g_old[k]))
                            self._eval_at(ts, ys, step_sol, t_old, t_root, y_root)
                            if self.t_eval is None:
                                ts.append(t_root)
                                ys.append(y_root)
                            if self.dense and interpolants:
                                interpolants[-1] = _Clipped(interpolants[-1], t_root)
                            return close("event", "", t_root, y_root, k)
                        traj.record_event(t_root, (
                            self.model.events[k].name if k < self.n_model_events
                            else self.py_events[k - self.n_model_events].name))
                g_old = g_new
            self._eval_at(ts, ys, step_sol, t_old, t_new, y_new)
            if self.t_eval is None:
                ts.append(t_new)
                ys.append(y_new.copy())
            if solver.status == "finished":
                return close("finished", "reached t_end", t_new, y_new)
            if self.steps >= self.max_steps:
                return close("failed", f"more than {self.max_steps} steps (t = {t_new:.6g})",
                             t_new, y_new)

    def segment_compiled(self, traj, t0, y0, p, t_end, fired):
        """The same as :meth:`segment` through the model's compiled loop of the method."""
        model, n = self.model, self.model.n_states
        pn = np.ascontiguousarray(p, dtype=float) if model.backend == "numba" else p.copy()
        mask_index, mask_sign = -1, 0.0
        if fired is not None:
            mask_index = fired
            mask_sign = float(self.direction[fired] or -np.sign(traj.pre_event_sign or 1.0))
        tgrad = 0.0 if model.autonomous else 1e-7 * max(1.0, abs(t0))
        t, y, h = t0, np.ascontiguousarray(y0, dtype=float), self.h_next.get(id(traj), 0.0)
        ts, ys = [np.array([t0])], [y[None, :].copy()]
        rtol = self.options["rtol"]
        atol = np.ascontiguousarray(np.broadcast_to(self.options["atol"], (n + 2,)), dtype=float)
        hmax = self.options["max_step"] if math.isfinite(self.options["max_step"]) else 1e300
        while True:
            with np.errstate(all="ignore"):
                (status, t, y, t_store, y_store, n_store, nfev, njev, nsteps, k, ev_t, ev_k, n_ev,
                 h) = model.functions.loops[self.method](t, y, t_end, pn, rtol, atol, h, hmax, self.direction,
                                            self.terminal, mask_index, mask_sign, n, self.bound,
                                            self.max_steps - self.steps, 4096, tgrad)
            self.steps += nsteps
            traj.nfev += nfev
            traj.njev += njev
            ts.append(t_store[:n_store].copy())
            ys.append(y_store[:n_store].copy())
            for j in range(n_ev):
                traj.record_event(float(ev_t[j]), self.model.events[int(ev_k[j])].name)
            mask_index = -1
            if status != 5:
                break
        self.h_next[id(traj)] = h
        traj.add(Segment(np.concatenate(ts), np.concatenate(ys).T, p.copy(), None), 0, 0, 0)
        if status == 0:
            traj.finish("finished", "reached t_end")
        elif status == 1:
            traj.pre_event_sign = -float(np.sign(self.direction[k])) if self.direction[k] else 0.0
            return "event", float(t), y.copy(), int(k)
        elif status == 2:
            traj.finish("failed", f"{self.method}: step size too small (or W singular) at t = {t:.6g}")
        elif status == 3:
            traj.finish("diverged", f"max|x| exceeded {self.bound:g} (or became non-finite) near "
                                    f"t = {t:.6g}")
        else:
            traj.finish("failed", f"more than {self.max_steps} steps (t = {t:.6g})")
        return traj.status, float(t), y, -1

    def _eval_at(self, ts, ys, step_sol, t_old, t_new, y_new, include_start=False):
        if self.t_eval is None:
            return
        te = self.t_eval
        mask = ((te >= t_old) if include_start else (te > t_old)) & (te <= t_new)
        for t in te[mask]:
            ts.append(float(t))
            ys.append(y_new.copy() if (step_sol is None or t == t_new) else step_sol(t))


class _Clipped:
    """A step interpolant whose step ended early at a terminal event."""

    def __init__(self, inner, t_end):
        self.inner, self.t_old, self.t = inner, inner.t_old, t_end

    def __call__(self, t):
        return self.inner(t)


def _active(g, g_new, direction):
    up = (g <= 0) & (g_new >= 0)
    down = (g >= 0) & (g_new <= 0)
    either = up | down
    mask = (up & (direction > 0)) | (down & (direction < 0)) | (either & (direction == 0))
    return np.nonzero(mask)[0]

"""Hybrid simulation: stiff integration with the analytic Jacobian, events, modes and resets.

The integration state is the model state followed by the ledger states E_diss and E_in
(see :mod:`porthamiltonian.compiler.assemble`). Discrete modes are parameters (contact flags,
stance leg...) that an event action changes; a reset map changes the state. Every jump of the
Hamiltonian at a reset is booked in the ledger (as dissipated energy by default, e.g. a plastic
impact; as supplied energy when the action says so, e.g. a controller switching a stiffness), so
the residual r = H(t) − H(0) + E_diss − E_in stays closed across events.

A failing or diverging integration ends with a status in the :class:`Trajectory`, never with an
exception from inside scipy.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.integrate import solve_ivp

from .compiled import CompiledModel
from .errors import ModelError, StateError
from .trajectory import Segment, Trajectory

METHODS = ("Radau", "BDF", "LSODA", "RK45", "DOP853")


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
             *, t_start: float = 0.0, method: str = "Radau", rtol: float = 1e-8, atol: float = 1e-10,
             max_step: float = math.inf, first_step: float | None = None, jacobian: bool = True,
             actions: Mapping[str, Action] | None = None, events: list[Event] | None = None,
             t_eval: np.ndarray | None = None, max_events: int = 100_000,
             divergence_bound: float = 1e12) -> Trajectory:
    """Simulate ``model`` from ``t_start`` to ``t_end``.

    Parameters
    ----------
    x0 : initial model state: an array (length n), a mapping ``{state name: value}`` overriding
        the components' initial values, or None for those values.
    params : parameter values by name (defaults for the others).
    method : a ``scipy.integrate.solve_ivp`` method; the stiff ones (Radau, BDF, LSODA) get the
        analytic Jacobian unless ``jacobian=False``.
    actions : event name -> action, for the model's events. A model event without action is
        recorded; if it is terminal, the simulation stops there.
    events : extra Python-level events.
    t_eval : times at which to store the solution (default: the integrator's steps).
    max_events : bound on events (protects against chattering).
    divergence_bound : the run ends with status "diverged" when max|x| exceeds it.
    """
    if method not in METHODS:
        raise ModelError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    if not (math.isfinite(t_end) and t_end > t_start):
        raise ModelError(f"t_end must be finite and > t_start ({t_start}), got {t_end}")
    p = model.params(params)
    if x0 is None or isinstance(x0, Mapping):
        x = model.initial_state(p, x0)
    else:
        x = np.array(x0, dtype=float)
    y = model.augment(x)
    if not np.all(np.isfinite(y)):
        raise StateError(f"model {model.name!r}: initial state is not finite: {x}")
    actions = dict(actions or {})
    unknown = set(actions) - {e.name for e in model.events}
    if unknown:
        raise ModelError(f"actions for unknown event(s) {', '.join(sorted(unknown))}; model events: "
                         f"{', '.join(e.name for e in model.events) or 'none'}")
    all_events = list(events or [])
    n = model.n_states
    f = model.functions
    traj = Trajectory(model)
    t = t_start
    h0 = float(model.energy(t, y, p)[0])
    traj.h0 = h0
    n_events = 0
    t_eval = None if t_eval is None else np.asarray(t_eval, dtype=float)
    while True:
        pn = model.native_params(p)
        fun = _rhs(f.rhs, pn)
        jac = _jac(f.jac, pn) if (jacobian and method in ("Radau", "BDF", "LSODA")) else None
        ev_funcs = []
        for i, ev in enumerate(model.events):
            g = _guard(f.guards, pn, i)
            g.terminal = ev.terminal or ev.name in actions
            g.direction = ev.direction
            ev_funcs.append(g)
        for ev in all_events:
            g = _py_guard(ev.guard, n, p)
            g.terminal, g.direction = ev.terminal, ev.direction
            ev_funcs.append(g)
        bound = _divergence(n, divergence_bound)
        ev_funcs.append(bound)
        seg_eval = None if t_eval is None else t_eval[(t_eval >= t) & (t_eval <= t_end)]
        options = {"rtol": rtol, "atol": atol, "max_step": max_step}
        if first_step is not None:
            options["first_step"] = first_step
        if jac is not None:
            options["jac"] = jac
        try:
            with np.errstate(all="ignore"):
                sol = solve_ivp(fun, (t, t_end), y, method=method, events=ev_funcs or None,
                                dense_output=True, t_eval=seg_eval, **options)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as err:
            traj.finish("failed", f"integration failed at t = {t:.6g}: {err}")
            return traj
        traj.add(Segment(sol.t, sol.y, p.copy(), sol.sol), sol.nfev, sol.njev, sol.nlu)
        if not np.all(np.isfinite(sol.y)):
            traj.finish("diverged", f"the state became non-finite near t = {sol.t[-1]:.6g}")
            return traj
        if sol.status == -1:
            traj.finish("failed", f"integrator {method} failed at t = {sol.t[-1]:.6g}: {sol.message}")
            return traj
        if sol.status == 0:
            traj.finish("finished", "reached t_end")
            return traj
        # a terminal event fired: find which (the earliest one at the final time)
        t = float(sol.t[-1])
        y = sol.y[:, -1].copy()
        fired = [k for k, te in enumerate(sol.t_events)
                 if len(te) and ev_funcs[k].terminal and te[-1] == sol.t[-1]]
        k = fired[0]
        if ev_funcs[k] is bound:
            traj.finish("diverged", f"max|x| exceeded {divergence_bound:g} at t = {t:.6g}")
            return traj
        name = (model.events[k].name if k < len(model.events) else all_events[k - len(model.events)].name)
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
        if reset.params:
            p = model.params(dict(zip(model.param_names, p)) | dict(reset.params))
        if reset.x is not None:
            new_x = np.asarray(reset.x, dtype=float)
            if new_x.shape != (n,) or not np.all(np.isfinite(new_x)):
                raise StateError(f"action for event {name!r} returned an invalid state {new_x}")
            y[:n] = new_x
        jump = float(model.energy(t, y, p)[0]) - h_before
        if reset.energy == "dissipated":
            y[n] -= jump
        else:
            y[n + 1] += jump
        traj.record_jump(t, name, jump)
        if reset.stop:
            traj.add(Segment(np.array([t]), y[:, None], p.copy(), None), 0, 0, 0)
            traj.finish("event", f"stopped by the action of event {name!r} at t = {t:.6g}")
            return traj
        if t >= t_end:
            traj.finish("finished", "reached t_end")
            return traj


def _rhs(rhs, pn):
    def fun(t, y):
        return rhs(t, y, pn)
    return fun


def _jac(jac, pn):
    def fun(t, y):
        return jac(t, y, pn)
    return fun


def _guard(guards, pn, i):
    def g(t, y):
        return guards(t, y, pn)[i]
    return g


def _py_guard(guard, n, p):
    def g(t, y):
        return guard(t, y[:n], p)
    return g


def _divergence(n, bound):
    def g(t, y):
        return bound - np.max(np.abs(y[:n]))
    g.terminal = True
    g.direction = -1
    return g

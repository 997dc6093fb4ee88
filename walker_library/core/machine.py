"""The mode machine: a walker's rules as immutable transitions that return simulation resets.

:class:`Transition` is one rule of :class:`~.hybrid.WalkerSpec` compiled against the walker's
model: the event it acts on (its guard ``g(t, x, p)`` is the model's compiled guard, crossed in
its ``direction``), its conditions (compiled outputs compared with 0), the mode parameters it
sets (constants or compiled outputs, evaluated just before the event), and an optional reset map
of the state (:class:`~.resets.ImpactMap`, :class:`~.resets.ConstraintImpact`). :meth:`Transition.apply` gives the state and the
parameters after it; :meth:`Transition.reset_jacobian` the Jacobian of the state map (the
identity without a reset), so that saltation matrices can be formed at every event.

:class:`ModeMachine` holds the transitions of a walker. For one walk it applies the ``start``
rules to the initial modes and gives :func:`porthamiltonian.simulate` one action per event
(:meth:`ModeMachine.actions`); every transition that fires is recorded in the walk's
:class:`WalkLog` (:class:`Fired`: time, transition, state and parameters before and after), and
the walk stops after the requested number of heel strikes (or earlier, at the first heel strike
after which the walk's stop predicate holds: :meth:`.walker.HybridWalker.walk`'s ``until``) or
at a fall.

For runs with sensitivities (:mod:`.variational`) the actions also give the derivatives of
what they do (:meth:`ModeMachine.actions` with ``derivatives``): the state map's Jacobian
``Reset.jacobian`` = ∂x⁺/∂x⁻ and, by the differentiated parameters, ``Reset.jacobian_p`` =
∂x⁺/∂p (the impact and the relabelling read masses, lengths, the new stance foot), and for each
mode set from an output (a stance foot's position) the gradient of its value by [x⁻, p]
(``Reset.params_jacobian``); modes set to constants (contact flags) have none. All in one
forward pass over the columns (the states, then the parameters): the impact by
:meth:`.resets.ImpactMap.tangents` (its linear solves differentiated exactly), the outputs a
mode is set from by fourth-order differences along the columns (:func:`porthamiltonian.
simulation.differences.directional`), their error estimates relative to each Jacobian's
largest entry recorded in the :class:`Fired` record (``info["jacobian_error"]``).
"""
from __future__ import annotations

import functools
import operator
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import cast

import numpy as np

from porthamiltonian import Reset
from porthamiltonian.simulation.compiled import CompiledModel
from porthamiltonian.simulation.differences import Derivative, directional

from .hybrid import Booking
from .resets import ConstraintImpact, ImpactMap

__all__ = ["Change", "Condition", "Fired", "ModeMachine", "Transition", "WalkLog"]

_OPS = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge,
        "==": operator.eq, "!=": operator.ne}


@dataclass(frozen=True)
class Condition:
    """``text`` holds when output ``output`` (lhs − rhs) compares with 0 by ``op``."""

    text: str
    output: int
    op: str

    def holds(self, y: np.ndarray) -> bool:
        """Whether the condition holds for the outputs ``y``."""
        return bool(_OPS[self.op](y[self.output], 0.0))


@dataclass(frozen=True)
class Change:
    """Mode parameter ``name`` (index ``index``) takes ``constant``, or the value of output
    ``output`` just before the event."""

    name: str
    index: int
    constant: float | None = None
    output: int | None = None

    def value(self, y: np.ndarray) -> float:
        """The new value, for the outputs ``y`` just before the event."""
        if self.output is not None:
            return float(y[self.output])
        return float(cast(float, self.constant))    # the plan sets one of the two


@dataclass(frozen=True)
class Transition:
    """One rule (see the module docstring). ``event_index`` is the event's index in the compiled
    model (-1 for ``start``); ``foot`` the foot that strikes (heel strikes)."""

    name: str
    event: str
    event_index: int
    direction: int
    conditions: tuple[Condition, ...]
    changes: tuple[Change, ...]
    impact: ImpactMap | ConstraintImpact | None = None
    heel_strike: bool = False
    fall: bool = False
    energy: Booking = "dissipated"
    foot: str | None = None

    def guard(self, model: CompiledModel, t: float, x: np.ndarray, p: np.ndarray) -> float:
        """The event's guard g(t, x, p); the transition can fire where it crosses 0 in
        :attr:`direction`."""
        return float(model.guards(t, x, p)[self.event_index])

    def applies(self, y: np.ndarray) -> bool:
        """All conditions hold for the outputs ``y`` (just before the event)."""
        return all(c.holds(y) for c in self.conditions)

    def params_after(self, p: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The parameter vector after the transition (its changes applied to ``p``)."""
        out = np.array(p, dtype=float)
        for c in self.changes:
            out[c.index] = c.value(y)
        return out

    def apply(self, t: float, x: np.ndarray, p: np.ndarray,
              y: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict]:
        """(state after, parameters after, the reset's record) for the state ``x`` and outputs
        ``y`` just before the event."""
        p_after = self.params_after(p, y)
        if self.impact is None:
            return np.array(x, dtype=float), p_after, {}
        x_after, info = self.impact(t, x, p, p_after)
        return x_after, p_after, info

    def reset_jacobian(self, t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """∂x⁺/∂x⁻ of the state map (the identity when the transition has no reset)."""
        if self.impact is None:
            return np.eye(len(x))
        y = self.impact.model.outputs(t, x, p)
        return self.impact.jacobian(t, x, p, self.params_after(p, y))


@dataclass(frozen=True)
class Fired:
    """A transition that fired: at time ``t``, from (x_minus, p_minus) to (x_plus, p_plus)."""

    t: float
    transition: Transition
    x_minus: np.ndarray
    p_minus: np.ndarray
    x_plus: np.ndarray
    p_plus: np.ndarray
    info: dict


@dataclass
class WalkLog:
    """What one walk's transitions did: every :class:`Fired` in order, and the heel strikes.
    The walk ends at its ``target``-th heel strike, or earlier at the first heel strike after
    which ``until(x_plus, p_plus)`` holds (``met`` then True)."""

    target: int
    until: Callable[[np.ndarray, np.ndarray], bool] | None = None
    fired: list[Fired] = field(default_factory=list)
    met: bool = False

    @property
    def heel_strikes(self) -> list[Fired]:
        """The fired transitions that ended a step."""
        return [f for f in self.fired if f.transition.heel_strike]

    def done(self, x: np.ndarray, p: np.ndarray) -> bool:
        """After a heel strike to state ``x`` with parameters ``p`` (already logged): whether the
        walk has its steps (the target reached, or ``until`` holds)."""
        if len(self.heel_strikes) >= self.target:
            return True
        self.met = self.until is not None and bool(self.until(x, p))
        return self.met


@dataclass(frozen=True)
class ModeMachine:
    """The transitions of a walker, by event (see the module docstring)."""

    model: CompiledModel
    transitions: tuple[Transition, ...]

    def on(self, event: str) -> tuple[Transition, ...]:
        """The transitions of ``event``, in the description's order."""
        return tuple(tr for tr in self.transitions if tr.event == event)

    @property
    def events(self) -> tuple[str, ...]:
        """The model events that have transitions."""
        return tuple(dict.fromkeys(tr.event for tr in self.transitions if tr.event != "start"))

    def first(self, event: str, y: np.ndarray) -> Transition | None:
        """The first transition of ``event`` that applies for outputs ``y``."""
        return next((tr for tr in self.on(event) if tr.applies(y)), None)

    def start(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The parameters after the ``start`` rule that applies at the initial state (if any)."""
        y = self.model.outputs(0.0, x, p)
        tr = self.first("start", y)
        return p if tr is None else tr.params_after(p, y)

    def fire(self, event: str, log: WalkLog, t: float, x: np.ndarray, p: np.ndarray,
             derivatives: Sequence[str] | None = None) -> Reset:
        """The action of ``event``: the first transition that applies, recorded in ``log``;
        with ``derivatives`` (parameter names, possibly none) also the derivatives of what it
        does (module docstring)."""
        y = self.model.outputs(t, x, p)
        tr = self.first(event, y)
        if tr is None:
            return Reset()
        x_after, p_after, info = tr.apply(t, x, p, y)
        extra: dict = {}
        if derivatives is not None:
            extra, info["jacobian_error"] = self._derivatives(tr, t, x, p, derivatives)
        log.fired.append(Fired(t, tr, np.array(x, dtype=float), np.array(p, dtype=float),
                               x_after, p_after, info))
        stop = tr.fall or (tr.heel_strike and log.done(x_after, p_after))
        names = self.model.param_names
        params = {names[c.index]: p_after[c.index] for c in tr.changes}
        return Reset(x=x_after if tr.impact is not None else None, params=params or None,
                     stop=stop, energy=tr.energy, **extra)

    def _derivatives(self, tr: Transition, t: float, x: np.ndarray, p: np.ndarray,
                     names: Sequence[str]) -> tuple[dict, float]:
        """The Reset fields of ``tr``'s derivatives at (t, x, p) by the parameters ``names``
        and the modes any transition sets from an output (module docstring), and the largest
        relative error estimate of the differences."""
        model = self.model
        x = np.asarray(x, dtype=float)
        p = np.asarray(p, dtype=float)
        n = len(x)
        wanted = sorted({model.param_names.index(name) for name in names}
                        | {c.index for t_ in self.transitions for c in t_.changes
                           if c.output is not None})
        errors: list[float] = []

        def relative(d: Derivative) -> np.ndarray:
            size = float(np.max(np.abs(d.value))) if d.value.size else 0.0
            errors.append(d.max_error / size if size > 0 else 0.0)
            return d.value

        out: dict = {}
        if not names:
            wanted = []
        K = n + len(wanted)                  # the columns: the states, then ``wanted``
        dx = np.zeros((n, K))
        dx[:, :n] = np.eye(n)
        dp = np.zeros((len(p), K))
        dp[wanted, range(n, K)] = 1.0
        needed = [c for c in tr.changes if c.output is not None]
        read = [int(c.output) for c in needed if c.output is not None]
        dy = np.zeros((len(model.output_names), K))
        if read and (tr.impact is not None or names):
            dy[read] = relative(directional(lambda w: model.outputs(t, w[:n], w[n:])[read],
                                            np.concatenate([x, p]), np.vstack([dx, dp])))
        if tr.impact is not None:
            y = model.outputs(t, x, p)
            dp_after = dp.copy()
            for c in tr.changes:
                dp_after[c.index] = dy[c.output] if c.output is not None else 0.0
            R, error = tr.impact.tangents(t, x, p, tr.params_after(p, y), dx, dp, dp_after)
            errors.append(error)
            out["jacobian"] = R[:, :n]
            if names:
                out["jacobian_p"] = {model.param_names[i]: R[:, n + k]
                                     for k, i in enumerate(wanted)}
        if not names:
            return out, max(errors, default=0.0)
        rows = {}
        for c in needed:
            row = np.zeros(n + len(p))
            row[:n] = dy[c.output, :n]
            row[n + np.array(wanted, dtype=int)] = dy[c.output, n:]
            rows[model.param_names[c.index]] = row
        if rows:
            out["params_jacobian"] = rows
        return out, max(errors, default=0.0)

    def actions(self, log: WalkLog, derivatives: Sequence[str] | None = None) -> dict:
        """One action per event that has transitions, for :func:`porthamiltonian.simulate`;
        with ``derivatives`` (parameter names; empty: the state's only) each gives the
        derivatives of what it does (module docstring)."""
        return {event: functools.partial(self.fire, event, log, derivatives=derivatives)
                for event in self.events}

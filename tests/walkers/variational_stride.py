"""A prototype of the exact stride Jacobian of a walker on the framework's sensitivities
(``simulate(..., sensitivity=...)``, porthamiltonian/saltation.py), outside walker_library (whose
stride-map modules another branch reworks), to show what the walker side must provide:

1. the seeds: X = ∂x₀/∂z, the derivative of the lift from section coordinates to the initial
   model state (here by differences of ``HybridWalker.lift``), so that the run integrates
   Φ = ∂x(t)/∂z directly (k columns instead of n);
2. the reset Jacobians: every action that moves the state returns ``Reset(jacobian=R_x)`` (here
   the rule's impact map differentiated by :func:`porthamiltonian.differences.jacobian`, which
   also estimates its error); actions that only switch modes need nothing (their saltation
   matrices come from the flows before and after and the guard's gradient);
3. the section event: the heel strike's action stops the run (``stop``), so that the run's
   ``sensitivity.final`` is the Jacobian of the state on the section (the flow projected along
   f onto the guard's surface, then the reset): ∂x⁺/∂z;
4. the projection's Jacobian Z = ∂z'/∂x⁺ at the final state (here by differences of
   ``HybridWalker.project``, which relabels): the stride map's Jacobian is Z · final.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from porthamiltonian import Reset
from porthamiltonian.differences import jacobian
from porthamiltonian.saltation import section_jacobian
from walker_library.core import HybridWalker
from walker_library.machine import WalkLog


@dataclass(frozen=True)
class StrideJacobian:
    """The stride map's Jacobian ``J`` (k x k) at z, the section state after the strides
    ``z_next``, the run's largest Φ error estimate (in rtol) and the largest error estimate of
    the difference Jacobians it used (lift, resets, projection)."""

    J: np.ndarray
    z_next: np.ndarray
    phi_error: float
    difference_error: float


def _with_reset_jacobians(walker: HybridWalker, log: WalkLog, errors: list[float]) -> dict:
    """The mode machine's actions, each returning the Jacobian of the state map it applied."""
    def wrap(event: str, action):
        def act(t: float, x: np.ndarray, p: np.ndarray) -> Reset:
            reset = action(t, x, p)
            if reset.x is None:
                return reset
            fired = log.fired[-1]
            tr = fired.transition
            d = jacobian(lambda xx: tr.impact(t, xx, p, fired.p_plus)[0], x, 1.0)
            errors.append(d.max_error)
            return replace(reset, jacobian=d.value)
        return act

    return {event: wrap(event, action) for event, action in walker.machine.actions(log).items()}


def stride_jacobian(walker: HybridWalker, z: np.ndarray, period: int = 1,
                    method: str = "Rodas5P") -> StrideJacobian:
    """The Jacobian of the stride map S^period at section state z from one run with
    sensitivities (module docstring)."""
    z = np.asarray(z, dtype=float)
    p0 = walker.start_params()
    lift = jacobian(lambda w: walker.lift(w, p0), z, 1.0)
    x0 = walker.lift(z, p0)
    p0 = walker.machine.start(x0, p0)
    log = WalkLog(period)
    errors = [lift.max_error]
    o = walker.options
    traj = walker.model.simulate(
        o.max_step_time * period, x0=x0, params=dict(zip(walker.model.param_names, p0)),
        method=method, rtol=o.rtol, atol=o.atol, max_step=o.max_step,
        actions=_with_reset_jacobians(walker, log, errors), max_events=100 * period + 100,
        sensitivity=lift.value)
    if len(log.heel_strikes) < period:
        raise RuntimeError(f"{walker.name}: the walker fell ({traj.message})")
    last = log.heel_strikes[-1]
    project = jacobian(lambda x: walker.project(x, last.p_plus), last.x_plus, 1.0)
    errors.append(project.max_error)
    J = section_jacobian(traj.sensitivity.final, project.value)
    return StrideJacobian(J, walker.project(last.x_plus, last.p_plus), traj.sensitivity.error,
                          max(errors))

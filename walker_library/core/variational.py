"""The exact stride-map Jacobian of a :class:`~.core.HybridWalker`: one run of a stride with the
framework's sensitivities (``simulate(..., sensitivity=X)``, :mod:`porthamiltonian.saltation`).

For the stride map S: z ↦ z' on the Poincaré section (z the section coordinates, x the model
state, x₀ = L(z) the lift, z' = P(x⁺) the projection with the relabelling),

    ∂z'/∂z = Z · Φ_final · X,

* X = ∂L/∂z (n × k), the seeds of the run, so that it integrates Φ = ∂x(t)/∂z directly (k
  columns instead of n);
* Φ_final: the run's sensitivities where it stops, at the heel strike that ends the stride —
  the variational equation Φ' = J Φ between events (the compiled Jacobian, integrated with the
  trajectory by the Rodas loops), at every event on the way the saltation matrix (contacts
  switching, mid-stance stiffness changes: a change of the vector field; an impact: the reset's
  Jacobian too), and at the heel strike the projection along the flow onto the guard's surface
  followed by the reset (the impact and/or the change of modes);
* Z = ∂P/∂x⁺ (k × n) at the state after the heel strike.

X, Z and the impact maps' Jacobians R_x come from central differences with error estimates
(:func:`porthamiltonian.differences.jacobian`: these maps are smooth and cheap); the largest of
their errors relative to the Jacobian's largest entry, ρ (~1e-11), bounds their contribution to
∂z'/∂z elementwise by 3ρ |Z| |Φ_final X| (first order: three factors, Z, X and the impacts'
R_x inside Φ_final, each in error by ρ relative at most). A period-k orbit's Jacobian is the product of its k strides' (each stride
its own run, from the section state the previous one reached), so that parameters a heel strike
sets from the state (a rigid walker's stance-foot position) never enter a differentiated flow.

The run uses the walker's compiled method, or Rodas5P when it integrates with a scipy method
(e.g. DOP853), at the walker's tolerances; the flow of the run is the
same as a stride's (to that tolerance), so its z' agrees with :meth:`HybridWalker.walk`'s.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, cast

import numpy as np

from porthamiltonian.integrators import COMPILED_METHODS
from porthamiltonian.simulation.differences import Derivative, jacobian
from porthamiltonian.simulation.options import check_integer, check_number
from porthamiltonian.simulation.saltation import Sensitivity, section_jacobian

from .machine import WalkLog

if TYPE_CHECKING:
    from .walker import HybridWalker

#: one stride's (z', ∂z'/∂z, Φ error, difference-error bound)
_Step = tuple[np.ndarray, np.ndarray, float, np.ndarray]

__all__ = ["StrideSensitivity", "stride_sensitivity"]


@dataclass(frozen=True)
class StrideSensitivity:
    """The Jacobian of S^period at z (section coordinates, k × k) from runs with sensitivities.

    z_next : S^period(z). jacobian : ∂S^period/∂z. phi_error : the largest error estimate of Φ's
    sub-steps over the runs, in units of rtol (:attr:`porthamiltonian.saltation.Sensitivity.error`).
    difference_error : the elementwise bound of the error that the difference Jacobians (lift,
    impacts, projection) bring into ``jacobian`` (module docstring; k × k). rtol : the runs' relative tolerance. method : the
    integrator. fell : the reason when a stride fell (then ``jacobian`` is None). stopped : the
    runs passed their deadline and were stopped (then ``jacobian`` is None).
    """

    z_next: np.ndarray | None
    jacobian: np.ndarray | None
    phi_error: float
    difference_error: np.ndarray | None
    rtol: float
    method: str
    fell: str = ""
    stopped: bool = False


class _TimeUp(Exception):
    """A run with sensitivities passed its deadline (raised by its progress callback)."""


def _until(deadline: float) -> Callable[[float, int], None] | None:
    """The progress callback of a run that stops it once ``time.perf_counter()`` passes
    ``deadline`` (the compiled loops call it between their batches of steps and at every event,
    about every 0.5 s of a stiff walker's run with sensitivities); None without a deadline."""
    if math.isinf(deadline):
        return None

    def check(t: float, steps: int) -> None:
        if time.perf_counter() > deadline:
            raise _TimeUp
    return check


def _relative(d: Derivative) -> float:
    """A difference Jacobian's largest error relative to its largest entry."""
    size = float(np.max(np.abs(d.value))) if d.value.size else 0.0
    return d.max_error / size if size > 0 else 0.0


def _one(walker: HybridWalker, z: np.ndarray, method: str, rtol: float,
         atol: np.ndarray, deadline: float) -> _Step | str:
    """(z', ∂z'/∂z, Φ error, difference-error bound) of one stride, or a fall reason (str):
    a state no stride starts from (``HybridWalker.start_state``) falls as in ``walk``."""
    p0 = walker.start_params()
    x0 = walker.start_state(z, p0)
    if isinstance(x0, str):
        return x0
    lift = jacobian(lambda w: walker.lift(w, p0), z, 1.0)
    p0 = walker.machine.start(x0, p0)
    log = WalkLog(1)
    o = walker.options
    traj = walker.model.simulate(
        o.max_step_time, x0=x0, params=dict(zip(walker.model.param_names, p0)), method=method,
        rtol=rtol, atol=atol, max_step=o.max_step, actions=walker.machine.actions(log, ()),
        max_events=200, max_steps=o.max_steps_per_stride, sensitivity=lift.value,
        progress=_until(deadline))
    strikes = log.heel_strikes
    if not strikes or any(f.transition.fall for f in log.fired):
        return f"no heel strike ({traj.message})"
    last = strikes[-1]
    project = jacobian(lambda x: walker.project(x, last.p_plus), last.x_plus, 1.0)
    errors = [_relative(lift), _relative(project),
              *(f.info.get("jacobian_error", 0.0) for f in log.fired)]
    sens = cast(Sensitivity, traj.sensitivity)      # a run given sensitivity= records it
    J = section_jacobian(sens.final, project.value)
    bound = 3.0 * max(errors) * (np.abs(project.value) @ np.abs(sens.final))
    return walker.project(last.x_plus, last.p_plus), J, sens.error, bound


def stride_sensitivity(walker: HybridWalker, z: np.ndarray, period: int = 1, *,
                       factor: float = 1.0, deadline: float = math.inf) -> StrideSensitivity:
    """The exact Jacobian of the stride map S^period at section state ``z`` (module docstring)
    at the walker's tolerances times ``factor`` (rtol at least 3e-14). A fall is a result
    (``fell``); so is a ``deadline`` (a ``time.perf_counter()``) passed during the runs
    (``stopped``: a stiff contact's run with sensitivities may take seconds)."""
    o = walker.options
    method = o.method if o.method in COMPILED_METHODS else "Rodas5P"
    factor = max(float(factor), 3e-14 / o.rtol)
    rtol, atol = o.rtol * factor, np.asarray(o.atol, dtype=float) * factor
    period = check_integer("period", period)
    deadline = check_number("deadline", deadline, finite=False)     # NaN: never passed
    z = np.asarray(z, dtype=float)
    J, E = np.eye(len(z)), np.zeros((len(z), len(z)))
    phi_err = 0.0
    for _ in range(period):
        try:
            out = _one(walker, z, method, rtol, atol, deadline)
        except _TimeUp:
            return StrideSensitivity(None, None, phi_err, None, rtol, method, stopped=True)
        if isinstance(out, str):
            return StrideSensitivity(None, None, phi_err, None, rtol, method, fell=out)
        z, Js, pe, Es = out
        with np.errstate(over="ignore", invalid="ignore"):  # a long unstable orbit's: inf
            J, E = Js @ J, Es @ np.abs(J) + np.abs(Js) @ E
        phi_err = max(phi_err, pe)
    return StrideSensitivity(z, J, phi_err, E, rtol, method)

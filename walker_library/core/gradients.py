"""A stride's derivatives by the section state and by parameters, from one run with the
framework's parameter sensitivities (:mod:`porthamiltonian.simulation.psensitivity`).

For one stride from section state z at parameters p (:mod:`.variational` for the notation),

    z' = S(z, p) = P(x⁺, p⁺),    x₀ = L(z, p),

one run seeded with ``Seeds(X, names, L_p)`` — X = ∂L/∂z, L_p = ∂L/∂p (the lift reads masses,
lengths, the modes' start values) — integrates ∂x/∂(z, p) through every event of the stride
(the mode machine's actions give the impact's ∂x⁺/∂x⁻ and ∂x⁺/∂p and the derivatives of the
modes they set from outputs: :meth:`.machine.ModeMachine.actions`); it ends on the heel strike's
surface, so that

    ∂z'/∂(z, p) = Z_x [Φ_final, S_final] + Z_p Π_final,

Z = ∂P/∂(x, p) by central differences at the state after the heel strike, Π_final the
dependence of the parameters in force on (z, p) (unit rows for p, and the new stance foot the
heel strike set). With it, the derivatives of what a stride measures (:mod:`.strides`):

* duration T: the heel strike's time sensitivity (:attr:`~porthamiltonian.simulation.
  saltation.Crossing.time_sensitivity`);
* step length L = o(x⁻, p⁻) − o₀(x₀, p₀), the striking foot's position along the slope just
  before the heel strike less the stance foot's at the start: o's gradient (central
  differences) with x⁻ on the heel strike's surface (Φ⁻ + f⁻ τ) and Π⁻;
* energy dissipated and supplied: the ledger's sensitivities (E_diss, E_in start at 0).

Returned in a :class:`StrideGradient`; :mod:`walker_library.analyses.gradients` chains the
strides of a period and solves for the fixed point's derivatives. A mode whose start value
reads a differentiated parameter is refused (its ∂p₀/∂p is not followed).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, cast

import numpy as np
from numpy.typing import ArrayLike

from porthamiltonian.errors import ModelError
from porthamiltonian.integrators import COMPILED_METHODS
from porthamiltonian.simulation.differences import Derivative, jacobian
from porthamiltonian.simulation.psensitivity import jac_p_build, output_gradient
from porthamiltonian.simulation.saltation import Seeds, Sensitivity

from .machine import WalkLog

if TYPE_CHECKING:
    from .walker import HybridWalker

__all__ = ["StrideGradient", "stride_gradient"]


@dataclass(frozen=True)
class StrideGradient:
    """One stride's values and their derivatives by the columns (the k section coordinates z,
    then the parameters ``names``): each ``d_*`` is a row of k + q.

    z_next : S(z, p); dz : ∂z'/∂(z, p) (k x (k + q)); duration (s), step_length (m),
    energy_dissipated, energy_supplied (J) and their rows ``d_duration`` ...; phi_error : Φ's
    largest error estimate (rtol units); difference_error : the largest relative error estimate
    of the difference Jacobians (lift, impacts, projection); rtol, method : the run's. fell :
    the reason when the stride fell (then the values are None).
    """

    names: tuple[str, ...]
    z_next: np.ndarray | None
    dz: np.ndarray | None
    duration: float | None
    d_duration: np.ndarray | None
    step_length: float | None
    d_step_length: np.ndarray | None
    energy_dissipated: float | None
    d_energy_dissipated: np.ndarray | None
    energy_supplied: float | None
    d_energy_supplied: np.ndarray | None
    phi_error: float
    difference_error: float
    rtol: float
    method: str
    fell: str = ""

    @property
    def jacobian(self) -> np.ndarray:
        """∂z'/∂z (k x k)."""
        dz = self._derivatives()
        return dz[:, :len(dz)]

    @property
    def parameters(self) -> np.ndarray:
        """∂z'/∂p (k x q)."""
        dz = self._derivatives()
        return dz[:, len(dz):]

    def _derivatives(self) -> np.ndarray:
        if self.dz is None:
            raise ModelError(f"the stride fell ({self.fell}): it has no derivatives")
        return self.dz


def _relative(d: Derivative) -> float:
    size = float(np.max(np.abs(d.value))) if d.value.size else 0.0
    return d.max_error / size if size > 0 else 0.0


def _start(walker: HybridWalker, z: np.ndarray, names: Sequence[str],
           values: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """(x₀, p₀) of a stride from z (p₀ after the start rules), at the parameters ``names`` =
    ``values`` (None: the walker's; names are model parameters, :func:`check_names`)."""
    p = None
    if values is not None:
        p = walker.run.p.copy()
        p[[walker.model.param_names.index(n) for n in names]] = values
    p0 = walker.start_params(p=p)
    x0 = walker.lift(z, p0)
    return x0, walker.machine.start(x0, p0)


def check_names(walker: HybridWalker, names: Sequence[str]) -> tuple[str, ...]:
    """``names`` if each is a parameter of the walker's model the user sets (not a mode);
    else a ModelError naming them."""
    names = tuple(names)
    model_names = walker.model.param_names
    bad = [n for n in names if n not in walker.parameters or n not in model_names
           or n in walker.mode_names]
    if bad or not names or len(set(names)) != len(names):
        raise ModelError(f"{walker.name}: cannot differentiate by {', '.join(bad) or names}: "
                         "give distinct parameters of the walker (not its modes); parameters: "
                         f"{', '.join(n for n in walker.parameters if n in model_names)}")
    return names


def stride_gradient(walker: HybridWalker, z: ArrayLike, names: Sequence[str], *,
                    factor: float = 1.0) -> StrideGradient:
    """One stride from section state ``z`` with its derivatives by z and by the parameters
    ``names`` (module docstring), at the walker's tolerances times ``factor``. A fall is a
    result (``fell``)."""
    names = check_names(walker, names)
    o = walker.options
    method = o.method if o.method in COMPILED_METHODS else "Rodas5P"
    factor = max(float(factor), 3e-14 / o.rtol)
    rtol, atol = o.rtol * factor, np.asarray(o.atol, dtype=float) * factor
    model = walker.model
    z = np.asarray(z, dtype=float)
    k, q, n = len(z), len(names), model.n_states
    index = [model.param_names.index(name) for name in names]
    p_user = walker.run.p[index]
    p_start = walker.start_params()
    lift = jacobian(lambda w: walker.lift(w, p_start), z, 1.0)
    x0, p0 = _start(walker, z, names, None)
    start = jacobian(lambda v: np.concatenate(_start(walker, z, names, v)), p_user, 1.0)
    x0_p, p0_p = start.value[:n], start.value[n:]
    unit = np.zeros_like(p0_p)
    unit[index, range(q)] = 1.0
    moved = np.abs(p0_p - unit) > 1e-6 * np.maximum(1.0, np.abs(p0_p))
    if np.any(moved):
        raise ModelError(f"{walker.name}: the start value of mode "
                         f"{model.param_names[int(np.nonzero(moved)[0][0])]} reads a "
                         f"differentiated parameter ({', '.join(names)}): not supported")
    log = WalkLog(1)
    traj = model.simulate(
        o.max_step_time, x0=x0, params=dict(zip(model.param_names, p0)), method=method,
        rtol=rtol, atol=atol, max_step=o.max_step, actions=walker.machine.actions(log, names),
        max_events=200, max_steps=o.max_steps_per_stride,
        sensitivity=Seeds(lift.value, names, x0_p))
    strikes = log.heel_strikes
    s = cast(Sensitivity, traj.sensitivity)         # a run given sensitivity= records it
    if not strikes or any(f.transition.fall for f in log.fired):
        return StrideGradient(
            names, z_next=None, dz=None, duration=None, d_duration=None, step_length=None,
            d_step_length=None, energy_dissipated=None, d_energy_dissipated=None,
            energy_supplied=None, d_energy_supplied=None, phi_error=s.error,
            difference_error=0.0, rtol=rtol, method=method,
            fell=f"no heel strike ({traj.message})")
    last = strikes[-1]
    # (a run with parameter sensitivities records these)
    final_parameters, pi, ledger = (cast(np.ndarray, a) for a in
                                    (s.final_parameters, s.final_params, s.final_ledger))
    final = np.hstack([s.final, final_parameters])
    live = np.flatnonzero(np.any(pi != 0.0, axis=1))

    def project_p(v: np.ndarray) -> np.ndarray:
        pp = last.p_plus.copy()
        pp[live] = v
        return walker.project(last.x_plus, pp)

    project = jacobian(lambda x: walker.project(x, last.p_plus), last.x_plus, 1.0)
    project_params = jacobian(project_p, last.p_plus[live], 1.0)
    dz = project.value @ final + project_params.value @ pi[live]
    crossing = s.crossings[-1]
    params_minus = cast(np.ndarray, crossing.params_minus)     # (likewise)
    # the step length: the striking foot just before the heel strike, the stance foot at start
    foot = walker.spec.foot(cast(str, last.transition.foot)).point   # a heel strike names it
    stance = walker.spec.foot(walker.spec.section.stance).point
    o_foot, o_stance = model.output_index(f"{foot}.x"), model.output_index(f"{stance}.x")
    on_surface = crossing.phi_minus + np.outer(crossing.f_minus, crossing.time_sensitivity)
    rows = np.flatnonzero(np.any(params_minus != 0.0, axis=1) | np.any(unit, axis=1))
    build = jac_p_build(model, names)          # the run's (compiled with ∂y/∂p)
    foot_x = output_gradient(model, o_foot, last.t, last.x_minus, last.p_minus, rows, build)
    stance_x = output_gradient(model, o_stance, 0.0, x0, p0, rows, build)
    pi0 = np.hstack([np.zeros((len(unit), k)), unit])
    d_length = (foot_x[0] @ on_surface + foot_x[1] @ params_minus
                - stance_x[0] @ np.hstack([lift.value, x0_p]) - stance_x[1] @ pi0)
    length = (model.outputs(last.t, last.x_minus, last.p_minus)[o_foot]
              - model.outputs(0.0, x0, p0)[o_stance])
    y_end = traj.y[:, -1]
    errors = [_relative(lift), _relative(start), _relative(project), _relative(project_params),
              *(f.info.get("jacobian_error", 0.0) for f in log.fired)]
    return StrideGradient(
        names, walker.project(last.x_plus, last.p_plus), dz, float(last.t),
        crossing.time_sensitivity.copy(), float(length), d_length, float(y_end[n]),
        ledger[0].copy(), float(y_end[n + 1]), ledger[1].copy(), s.error,
        max(errors), rtol, method)


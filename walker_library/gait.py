"""Gait analysis: find the walker's gait from a rough guess and describe it.

:func:`analyze_gait` is what ``walker gait`` runs:

1. Newton on S(z) − z (period 1) from the guess; if it converges to a stable fixed point, that is
   the gait.
2. Otherwise iterate the stride map from the guess (the walker's own motion): a fall gives status
   ``"fell"`` with the step at which it fell; a repeating sequence of period k ≤ max_period is
   refined by Newton on S^k(z) − z and gives status ``"periodic"`` with ``period_steps = k``.
3. Anything else is ``"no_fixed_point"``, reported with the last iterate (and Newton's).

Every result is a :class:`GaitResult`, serializable to JSON (SI units, named fields). Falls and
failed searches are results, never exceptions; only invalid input (unknown or out-of-range
parameters) raises.

:func:`walk` simulates n steps from a section state in one run (one energy ledger) and returns
the per-step records and the ledger residual (:class:`WalkResult`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .metrics import GaitMetrics, gait_metrics
from .poincare import (
    FixedPointResult,
    FloquetResult,
    WalkerFell,
    detect_period,
    find_fixed_point,
    floquet,
)
from .protocol import Stride, Walker
from .results import JSONResult, to_jsonable

__all__ = ["GaitResult", "WalkResult", "analyze_gait", "walk"]

_LEGGED_KEYS = ("theta", "theta_dot", "phi", "phi_dot")


@dataclass
class GaitResult(JSONResult):
    """A walker's gait (see :func:`analyze_gait`). SI units; angles in rad.

    status : "periodic", "fell" or "no_fixed_point". period_steps : k of a period-k gait (0 if none).
    stable : all Floquet multipliers inside the unit circle (None when not computed).
    fixed_point : section state just after heel strike, by name (model's own coordinates and the
        thesis's theta, theta_dot, phi, phi_dot); values null when there is no gait.
    fixed_points : the k section states of a period-k gait.
    floquet_multipliers : eigenvalues of the Jacobian of S^k (largest modulus first);
        multiplier_error : their estimated error. metrics : see :mod:`walker_library.metrics`.
    fell_at_step : the step (1-based) during which the walker fell, iterating from the guess.
    unstable_fixed_point : an unstable period-1 fixed point Newton found (its section state and
        multipliers; the message says so), else None: an unstable gait is reported as "fell" or
        "no_fixed_point" when the walker's own motion leaves it, as "periodic" with stable false
        when it stays on it (e.g. a 3D walker started in its invariant sagittal plane).
    last_iterate : the last section state reached when no gait was found (by name).
    newton : the period-1 Newton search (converged, residual, iterations, last iterate).
    """

    model: str
    status: str
    period_steps: int
    stable: bool | None
    fixed_point: dict
    fixed_points: list[dict]
    section: list[str]
    thesis_section: list[str]
    floquet_multipliers: list[complex]
    multiplier_error: float
    metrics: GaitMetrics
    steps: list[dict]
    fell_at_step: int | None
    fall_reason: str
    last_iterate: dict | None
    newton: dict
    unstable_fixed_point: dict | None
    parameters: dict
    message: str

    def to_dict(self) -> dict:
        d = {
            "model": self.model, "status": self.status, "period_steps": int(self.period_steps),
            "stable": self.stable, "fixed_point": self.fixed_point,
            "fixed_points": self.fixed_points, "section": self.section,
            "thesis_section": self.thesis_section,
            "floquet_multipliers": [{"re": float(np.real(m)), "im": float(np.imag(m))}
                                    for m in self.floquet_multipliers],
            "multiplier_error": self.multiplier_error,
        }
        d.update(self.metrics.to_dict())
        d.update({"steps": self.steps, "fell_at_step": self.fell_at_step,
                  "fall_reason": self.fall_reason, "last_iterate": self.last_iterate,
                  "newton": self.newton, "unstable_fixed_point": self.unstable_fixed_point,
                  "parameters": self.parameters, "message": self.message})
        return to_jsonable(d)

    def plot(self, walker: Walker | None = None, *, steps: int = 2):
        """Limit cycle and Floquet multipliers, a quick look (see
        :func:`walker_library.display.plot_gait`); returns the Axes."""
        from .display import plot_gait
        return plot_gait(self, walker, steps=steps)

    def _repr_html_(self) -> str:
        from .display import gait_html
        return gait_html(self)



def _named(walker: Walker, z) -> dict:
    return {k: float(v) for k, v in walker.section_state(np.asarray(z, dtype=float)).items()}


def _empty_point(walker: Walker) -> dict:
    keys = list(walker.section) + (list(_LEGGED_KEYS) if walker.legged else [])
    return {k: None for k in keys}


def _step_record(walker: Walker, s: Stride) -> dict:
    return {"status": s.status, "duration": s.duration, "step_length": s.step_length,
            "energy_dissipated": s.energy_dissipated, "potential_released": s.potential_released,
            "energy_residual": s.energy_residual, "max_theta": s.max_theta, "max_phi": s.max_phi,
            "reason": s.reason,
            "impact_energy_lost": s.info.get("impact_energy_lost"),
            "trailing_foot_normal_velocity": s.info.get("trailing_foot_normal_velocity"),
            "state_after": _named(walker, s.z_next) if s.z_next is not None else None}


def _newton_dict(walker: Walker, fp: FixedPointResult) -> dict:
    return {"converged": fp.converged, "residual": fp.residual, "iterations": fp.iterations,
            "period": fp.period, "message": fp.message, "last_iterate": _named(walker, fp.z)}


def analyze_gait(walker: Walker, guess=None, *, max_period: int = 8, fd_step: float = 1e-4,
                 tol: float | None = None, n_iterate: int = 200, period_tol: float = 1e-7,
                 max_iter: int = 30) -> GaitResult:
    """Find and describe the gait of ``walker`` starting from ``guess`` (default: the walker's own
    initial guess). See the module docstring for the steps and :class:`GaitResult` for the fields.

    fd_step : perturbation size h of the Floquet Jacobian (absolute, in the section coordinates'
        units; central differences at h and h/2, Richardson-extrapolated). The thesis (App. C)
        used 0.001 with one-sided differences; 1e-4 is the default here (measured: at h = 1e-3
        the simplest walker's multipliers are off by 1e-3 before extrapolation).
    tol : Newton tolerance on |S^k(z) − z|_∞ (default: the walker's ``gait_tolerance`` if it has
        one, else 1e-10). n_iterate, period_tol, max_period : period detection.
    """
    if tol is None:
        tol = float(getattr(walker, "gait_tolerance", 1e-10))
    z0 = np.asarray(walker.initial_guess() if guess is None else guess, dtype=float)
    base = {"model": walker.name, "section": list(walker.section),
            "thesis_section": list(walker.thesis_section), "parameters": dict(walker.parameters)}
    fp = find_fixed_point(walker, z0, period=1, tol=tol, max_iter=max_iter)
    newton = _newton_dict(walker, fp)
    unstable, found = None, ""
    if fp.converged:
        try:
            fl = floquet(walker, fp.z, period=1, step=fd_step)
        except WalkerFell:       # a perturbation of size fd_step falls: stability unknown here,
            fl = None            # so let the walker's own motion decide (period detection)
        if fl is not None and fl.stable:
            return _periodic(walker, fp, fl, newton, base, "stable period-1 gait")
        if fl is not None:
            unstable = {"fixed_point": _named(walker, fp.z),
                        "floquet_multipliers": [complex(m) for m in fl.multipliers]}
            found = (f"; Newton converged to an unstable period-1 fixed point (largest "
                     f"|Floquet multiplier| {max(abs(m) for m in fl.multipliers):.4g}: "
                     f"unstable_fixed_point)")
    pr = detect_period(walker, z0, max_period=max_period, n_steps=n_iterate, tol=period_tol)
    it = pr.iteration
    if pr.fell_at_step is not None:
        metrics = gait_metrics(it.strides[:-1], walker.weight)
        return GaitResult(status="fell", period_steps=0, stable=None,
                          fixed_point=_empty_point(walker), fixed_points=[],
                          floquet_multipliers=[], multiplier_error=math.nan, metrics=metrics,
                          steps=[_step_record(walker, s) for s in it.strides],
                          fell_at_step=pr.fell_at_step, fall_reason=it.fall_reason,
                          last_iterate=_named(walker, it.states[-1]), newton=newton,
                          unstable_fixed_point=unstable,
                          message=f"the walker fell during step {pr.fell_at_step} "
                                  f"({it.fall_reason}) iterating from the guess{found}", **base)
    if pr.period > 0:
        fpk = find_fixed_point(walker, it.states[-1], period=pr.period, tol=tol, max_iter=max_iter)
        if fpk.converged:
            try:
                flk = floquet(walker, fpk.z, period=pr.period, step=fd_step)
            except WalkerFell:
                flk = None
            if flk is not None:
                return _periodic(walker, fpk, flk, newton, base,
                                 f"{'' if flk.stable else 'unstable '}period-{pr.period} gait "
                                 f"found by iterating the stride map (largest |Floquet "
                                 f"multiplier| {max(abs(m) for m in flk.multipliers):.4g})",
                                 unstable)
    metrics = gait_metrics(it.strides[-max_period:], walker.weight)
    return GaitResult(status="no_fixed_point", period_steps=0, stable=None,
                      fixed_point=_empty_point(walker), fixed_points=[], floquet_multipliers=[],
                      multiplier_error=math.nan, metrics=metrics, steps=[],
                      fell_at_step=None, fall_reason="", last_iterate=_named(walker, it.states[-1]),
                      newton=newton, unstable_fixed_point=unstable,
                      message=f"no stable periodic gait of period <= {max_period} found: Newton "
                              f"{'converged to an unstable fixed point' if fp.converged else 'did not converge (' + fp.message + ')'}; "
                              f"{len(it.strides)} iterated steps repeat with no period <= {max_period} "
                              f"(closest relative distance {pr.distance:.2e})", **base)


def _periodic(walker: Walker, fp: FixedPointResult, fl: FloquetResult, newton: dict, base: dict,
              message: str, unstable: dict | None = None) -> GaitResult:
    strides = walker.walk(fp.z, fp.period, details=True)
    points = [_named(walker, fp.z)] + [_named(walker, s.z_next) for s in strides[:-1]]
    metrics = gait_metrics(strides, walker.weight)
    return GaitResult(status="periodic", period_steps=fp.period, stable=fl.stable,
                      fixed_point=points[0], fixed_points=points,
                      floquet_multipliers=[complex(m) for m in fl.multipliers],
                      multiplier_error=fl.error, metrics=metrics,
                      steps=[_step_record(walker, s) for s in strides], fell_at_step=None,
                      fall_reason="", last_iterate=None, newton=newton,
                      unstable_fixed_point=unstable, message=message, **base)


@dataclass
class WalkResult(JSONResult):
    """n steps walked in one simulation: per-step records, and the ledger over the whole run."""

    model: str
    steps_taken: int
    fell: bool
    fall_reason: str
    steps: list[dict]
    energy_dissipated: float
    potential_released: float
    max_energy_residual: float
    relative_energy_residual: float
    parameters: dict = field(default_factory=dict)


def walk(walker: Walker, z0=None, n_steps: int = 20) -> WalkResult:
    """Walk ``n_steps`` from ``z0`` (default: the initial guess) in one simulation and report the
    energy ledger: its residual H − H(0) + E_diss − E_in, absolute and relative to the energy scale."""
    z0 = np.asarray(walker.initial_guess() if z0 is None else z0, dtype=float)
    strides = walker.walk(z0, n_steps, record=True)
    traj = strides[-1].info.get("trajectory")
    fell = strides[-1].fell
    steps = [_step_record(walker, s) for s in strides]
    if traj is not None:
        residual = np.abs(traj.residual)
        max_res, rel = float(np.max(residual)), float(traj.relative_residual)
    else:
        max_res = rel = math.nan
    good = [s for s in strides if not s.fell]
    return WalkResult(walker.name, len(good), fell, strides[-1].reason if fell else "", steps,
                      float(sum(s.energy_dissipated for s in good)),
                      float(sum(s.potential_released for s in good)), max_res, rel,
                      dict(walker.parameters))

"""Walker analyses as sweep case functions: gait, step-down and basin of attraction per case.

The case functions run in sweep workers (:mod:`porthamiltonian.batch`): ``gait_case`` and
``step_down_case`` take walker parameters as the case (``{"slope": 0.009}``), ``basin_case`` one
initial section state (``{"theta": ..., "theta_dot": ...}``) with the walker's parameters in
``params``. Walkers and gaits come from a :class:`WalkerCache` — one per process
(:func:`walker_cache`) — so a worker builds and compiles a walker once (from the on-disk model
cache) and each case only rebinds its parameters. A basin's gait is computed once, in the main
process, by :func:`prepare_basin` and shipped to the workers as the sweep's shared argument: no
worker looks for the gait again.

:data:`ANALYSES` names them for ``walker sweep --analysis NAME``; their ``prepare`` functions
check every case against the walker's parameter specs before anything runs.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from porthamiltonian.batch import Analysis, SweepError
from porthamiltonian.batch.values import canonical
from porthamiltonian.errors import ParameterValueError
from porthamiltonian.simulation.options import check_integer, check_number

from ..core.protocol import Walker
from .gait import GaitResult, GaitStatus, analyze_gait, check_search
from .results import to_jsonable

# The step-down and basin analyses (:mod:`.robustness`) are imported by their case functions:
# the ``walker`` command reads :data:`ANALYSES` for its help, and a warm ``walker gait`` runs
# neither.

__all__ = ["ANALYSES", "WalkerCache", "basin_case", "gait_case", "gait_summary", "get_analysis",
           "prepare_basin", "prepare_walker", "step_down_case", "walker_cache"]


class WalkerCache:
    """Walkers by (model, back end) at their files' parameter values, and gaits by (model, back
    end, parameters, initial guess). ``backend`` None means the walker's own default."""

    def __init__(self) -> None:
        self._walkers: dict[tuple[str, str | None], Walker] = {}
        self._gaits: dict[tuple, GaitResult] = {}

    def walker(self, model: str, backend: str | None = None,
               params: Mapping[str, Any] | None = None) -> Walker:
        """The walker of ``model`` (a name from models/, a path or a builder name), built once,
        with ``params`` overriding its parameters."""
        key = (str(model), backend)
        if key not in self._walkers:
            from ..core.files import load_walker
            self._walkers[key] = load_walker(model, None, backend=backend)
        walker = self._walkers[key]
        return walker.with_parameters(**params) if params else walker

    def gait(self, model: str, backend: str | None = None,
             params: Mapping[str, Any] | None = None) -> tuple[Walker, GaitResult]:
        """The walker with ``params`` and its gait, found once. A ``guess`` entry of ``params``
        (a section state in the model's coordinates) starts the gait search there."""
        params = dict(params or {})
        guess = params.pop("guess", None)
        walker = self.walker(model, backend, params)
        key = (str(model), backend, tuple(sorted(walker.parameters.items())),
               None if guess is None else tuple(guess))
        if key not in self._gaits:
            self._gaits[key] = analyze_gait(walker, guess=guess)
        return walker, self._gaits[key]

    def clear_gaits(self) -> None:
        """Forget the gaits (keep the compiled walkers)."""
        self._gaits.clear()


_PROCESS_CACHE = WalkerCache()


def walker_cache() -> WalkerCache:
    """This process's :class:`WalkerCache` (forked workers inherit the parent's walkers)."""
    return _PROCESS_CACHE


_THESIS_KEYS = ("theta", "theta_dot", "phi", "phi_dot")


def gait_summary(walker: Walker, result: GaitResult) -> dict:
    """The main fields of a :class:`~walker_library.analyses.gait.GaitResult` as a flat dict (SI units,
    angles in rad): status, outcome, period_steps, stable, max_multiplier (largest |Floquet
    multiplier|),
    multiplier_error, step_period (s), step_length (m), speed (m/s), energy_dissipated_per_step
    (J), max_theta, max_phi (rad), cost_of_transport (1), the fixed point in the thesis's terms
    (``fixed_point.theta``, ``.theta_dot``, ``.phi``, ``.phi_dot``; a rimless wheel: theta and
    theta_dot), fell_at_step and message. Null where not defined (no gait)."""
    d = result.to_dict()
    mults = [abs(complex(m)) for m in result.floquet_multipliers]
    out = {"status": d["status"], "outcome": d["outcome"], "period_steps": d["period_steps"],
           "stable": d["stable"],
           "max_multiplier": max(mults) if mults else None,
           "multiplier_error": d["multiplier_error"]}
    for key in ("step_period", "step_length", "speed", "energy_dissipated_per_step", "max_theta",
                "max_phi", "cost_of_transport"):
        out[key] = d.get(key)
    keys = _THESIS_KEYS if walker.legged else ("theta", *walker.thesis_section)
    fixed_point = d.get("fixed_point") or {}
    for key in dict.fromkeys(keys):
        out[f"fixed_point.{key}"] = fixed_point.get(key)
    out["fell_at_step"] = d.get("fell_at_step")
    out["message"] = d.get("message", "")
    return to_jsonable(out)


def gait_case(case: Mapping[str, Any], *, model: str, backend: str | None = None,
              max_period: int = 8, fd_step: float | None = None, n_iterate: int = 200) -> dict:
    """Case function of ``--analysis gait``: the walker ``model`` with the case's values as
    parameter overrides, :func:`walker_library.analyses.gait.analyze_gait` from its initial guess, and
    :func:`gait_summary` of the result."""
    walker = walker_cache().walker(model, backend, case)
    result = analyze_gait(walker, max_period=max_period, fd_step=fd_step, n_iterate=n_iterate)
    return gait_summary(walker, result)


def step_down_case(case: Mapping[str, Any], *, model: str, backend: str | None = None,
                   resolution: float | None = None, h_max: float | None = None) -> dict:
    """Case function of ``--analysis step-down``: the gait and the step-down test of ``model``
    with the case's parameters (and an optional ``guess``: the section state to start the gait
    search from). Returns status ("ok", "no_gait"), max_step_down (m), contiguous,
    contiguous_limit (m), survived_intervals (m), first_failure (m), holes, and the gait's
    outcome, stability, speed (m/s), energy per step (J), step period (s), largest
    |multiplier|."""
    from .robustness import step_down

    walker, gait = walker_cache().gait(model, backend, case)
    r = step_down(walker, gait, resolution=resolution, h_max=h_max)
    mults = [abs(complex(m)) for m in gait.floquet_multipliers]
    m = gait.metrics
    return to_jsonable({"status": r.status, "max_step_down": r.max_step_down,
                        "contiguous": r.contiguous, "contiguous_limit": r.contiguous_limit,
                        "survived_intervals": r.survived_intervals,
                        "first_failure": r.first_failure,
                        "holes": r.holes, "gait_status": gait.status,
                        "gait_outcome": gait.outcome, "stable": gait.stable,
                        "period_steps": gait.period_steps,
                        "max_multiplier": max(mults) if mults else None,
                        "speed": m.speed, "step_period": m.step_period,
                        "step_length": m.step_length,
                        "energy_dissipated_per_step": m.energy_dissipated_per_step,
                        "message": r.message})


def basin_case(case: Mapping[str, Any], *, model: str, backend: str | None = None,
               params: Mapping[str, Any] | None = None, n_steps: int | None = None,
               tol: float = 1e-4, gait: GaitResult | None = None,
               method: str | None = "auto") -> dict:
    """Case function of ``--analysis basin``: one point of a basin of attraction. ``case`` holds
    the thesis ``theta`` (rad) and ``theta_dot`` (rad/s) of the initial section state;
    ``params`` the walker's parameters (e.g. the slope); ``gait`` the walker's gait with them
    (the sweep's shared argument; None: found here, once per process); ``method`` the
    integration of the walk (:func:`~.robustness.basin_walker`; the gait is the walker's own).
    Returns status "converged", "fell", "wandered", "invalid" or "no_gait", steps (to the first
    state within ``tol``, or to the fall), distance and reason."""
    from .robustness import (
        AnalysisStatus,
        basin_state,
        basin_walker,
        fixed_points,
        recovers,
        recovery_steps,
    )

    if gait is None:
        walker, gait = walker_cache().gait(model, backend, params)
    else:
        walker = walker_cache().walker(model, backend, params)
    if gait.status != GaitStatus.PERIODIC:
        return {"status": AnalysisStatus.NO_GAIT, "steps": 0, "message": gait.message}
    fps = fixed_points(walker, gait)
    n = recovery_steps(gait, tol) if n_steps is None else int(n_steps)
    try:
        z0 = basin_state(walker, fps[0], float(case["theta"]), float(case["theta_dot"]))
    except (ValueError, np.linalg.LinAlgError) as err:
        return {"status": "invalid", "steps": 0, "message": str(err)}
    r = recovers(basin_walker(walker, method), z0, fps, n_steps=n, tol=tol)
    return to_jsonable({"status": r.status, "steps": r.steps, "distance": r.distance,
                        "reason": r.reason})


def prepare_walker(cases: Sequence[Mapping[str, Any]], *, model: str,
                   backend: str | None = None, **options: Any) -> None:
    """Build the walker once (forked workers inherit it) and check every case's parameter names
    and values against the walker's specs, so a typo fails before the sweep starts."""
    walker = walker_cache().walker(model, backend)
    specs = walker.specs
    for index, case in enumerate(cases):
        try:
            unknown = sorted(set(case) - set(specs))
            if unknown:
                raise ParameterValueError(
                    f"unknown parameter(s) {', '.join(unknown)} of {walker.name}; "
                    f"parameters: {', '.join(specs)}")
            for name, value in case.items():
                specs[name].check(value)
        except ParameterValueError as err:
            raise ParameterValueError(f"case {index} {canonical(dict(case))}: {err}") from None


def prepare_gait(cases: Sequence[Mapping[str, Any]], *, model: str, backend: str | None = None,
                 max_period: int = 8, fd_step: float | None = None,
                 n_iterate: int = 200) -> None:
    """:func:`prepare_walker`, and the search's options checked
    (:func:`~walker_library.analyses.gait.check_search`) before any case runs."""
    prepare_walker(cases, model=model, backend=backend)
    check_search(max_period, n_iterate, fd_step)


def prepare_basin(cases: Sequence[Mapping[str, Any]], *, model: str, backend: str | None = None,
                  params: Mapping[str, Any] | None = None, n_steps: int | None = None,
                  tol: float = 1e-4, method: str | None = "auto") -> dict[str, Any]:
    """Build the walker with ``params`` (checked), check ``n_steps``, ``tol`` and ``method``,
    and find its gait once, here: the sweep's shared argument ``gait``, so that no worker looks
    for it again."""
    from .robustness import basin_walker

    if params is not None and not isinstance(params, Mapping):
        raise SweepError(f"--option params must be a JSON object of parameter values (e.g. "
                         f"params='{{\"slope\": 0.01}}'), got {params!r}")
    if n_steps is not None:
        check_integer("n_steps", n_steps)
    check_number("tol", tol, positive=True)
    for index, case in enumerate(cases):
        missing = [k for k in ("theta", "theta_dot") if k not in case]
        if missing:
            raise SweepError(f"case {index} {canonical(dict(case))}: a basin case needs "
                             f"{' and '.join(missing)} (rad, rad/s): --grid theta=... "
                             "--grid theta_dot=...")
    walker, gait = walker_cache().gait(model, backend, params)
    basin_walker(walker, method)
    return {"gait": gait}


ANALYSES: dict[str, Analysis] = {a.name: a for a in (
    Analysis("gait", gait_case,
             "gait of the walker for each case: fixed point, Floquet multipliers, metrics",
             prepare=prepare_gait, ok_statuses=(GaitStatus.PERIODIC,),
             columns=("period_steps", "stable", "max_multiplier", "step_length", "speed")),
    Analysis("step-down", step_down_case,
             "gait and step-down test for each case: max_step_down (m), contiguous, speed, "
             "energy per step", prepare=prepare_walker, ok_statuses=("ok",),
             columns=("gait_status", "max_step_down", "contiguous", "speed")),
    Analysis("basin", basin_case,
             "one basin-of-attraction point per case (theta, theta_dot; walker parameters in "
             "--option params={...}): converged, fell or wandered",
             prepare=prepare_basin, ok_statuses=("converged",),   # RecoveryStatus.CONVERGED
             columns=("steps", "distance")),
)}


def get_analysis(name: str) -> Analysis:
    """A walker analysis by name, or an ad-hoc one for ``"module:function"``."""
    if name in ANALYSES:
        return ANALYSES[name]
    if ":" in name:
        return Analysis.adhoc(name)
    raise SweepError(f"unknown analysis {name!r}; analyses: {', '.join(ANALYSES)} (or "
                     "module:function for a case function of your own)")

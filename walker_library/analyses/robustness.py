"""Robustness of a walker's gait (thesis §2.6; docs/walkers.md): step-down, basin of attraction,
Gait Sensitivity Norm. Generic over :class:`~.protocol.Walker`; every result serializes to JSON
(SI units, named fields).

Recovery criterion (shared by step-down and basin)
--------------------------------------------------
A disturbed walker *recovers* when, without falling, its section state after a step comes
within ``tol`` (∞-norm, in the model's section coordinates: rad, rad/s, m/s) of one of the gait's
fixed points (a period-k gait has k). The distance is checked after every step and the walk ends
at the first step within ``tol`` (the recovery's ``steps`` counts the steps to it), at a fall
(``steps`` counts the steps to it, the falling one included), or after ``n_steps`` steps in each of
at most 5 chunks: ``n_steps`` defaults to enough steps for a perturbation of the gait's size to
decay below ``tol`` at the gait's slowest Floquet multiplier ρ: n = ceil(log(tol/0.1)/log ρ) + 5,
clipped to [20, 300], and further chunks follow while the walker neither falls nor converges, so a
slow transient near the edge of the basin is not miscounted ("wandered" after 5 n_steps).

* :func:`step_down` — the surface drops by h once, before the next heel strike (``walk(...,
  ground_drop=h)``), starting on the gait's fixed point. h (in metres) is scanned upward on a
  grid of ``resolution`` (default 2e-4 of the leg length) over a window of at least twice the
  first failure, and on until ``n_beyond`` consecutive failures (or ``h_max``); then every
  boundary between a survived and a failed height is located by bisection to ``boundary_tol``
  (default 1e-5 m = 0.01 mm), so the answer does not depend on the grid (beyond missing a
  survived island narrower than it). ``contiguous_limit`` is the largest h with every drop up to
  it survived; ``survived_intervals`` the survived set found, ``[low, high]`` intervals (the
  first starts at 0; those after it lie beyond failed drops: the thesis's "chaotic"
  robustness); ``max_step_down`` the largest drop survived, ``contiguous`` whether it is the
  contiguous limit.
* :func:`basin` — a grid of initial section states around the fixed point in the thesis's
  scaled coordinates (θ/θ_scale, θ̇/θ̇_scale; θ_scale = 0.4 rad, θ̇_scale = 0.8 rad/s as in the
  thesis's Fig. 2.21); the other section coordinates follow the fixed point (φ keeps its offset
  from 2θ; a walker may define ``basin_state(z_star, theta, theta_dot)`` to complete a state
  consistently). Each point is ``"converged"`` or ``"fell"`` (or ``"wandered"``: neither).
  A basin's walks are integrated by :func:`basin_walker`: with ``method="auto"`` (the default)
  a walker whose own method is a compiled stiff one (Rodas4, Rodas5P, QBDF: the compliant-contact
  walkers) walks its points with QBDF, the compiled variable-order BDF that reuses its Jacobian,
  at the walker's own tolerances. A point's status needs its section state to a small fraction
  of ``tol``, not to the gait search's accuracy: on compass_walker at the file's rtol 1e-9 QBDF
  is 3.4x faster than Rodas5P per stride, at a section-state error of 2e-7 after 6 strides
  against Rodas5P's 9e-9 (reference: rtol 1e-12), and the 50 × 50 basin at slope 0.007 keeps
  all 2500 statuses and step counts (benchmarks/RESULTS.md, issue 26). A choice of this
  analysis, not the file's: the gait search and the step-down test (whose bisection to 0.01 mm
  pins numbers) keep the walker's own method; ``method=None`` keeps it for the basin too.
* :func:`gait_sensitivity_norm` — Hobbelen & Wisse (2007): the 2-norm of the response of gait
  indicators (step period, step length) to a unit step-down impulse, g_k = ∂(indicator of step k)
  /∂h summed over the steps until the response has decayed; by finite differences at h and h/2
  (the difference of the two is the error estimate).
"""
from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np

from porthamiltonian.batch.grids import MAX_CASES
from porthamiltonian.batch.progress import tick
from porthamiltonian.errors import CostError, ParameterValueError
from porthamiltonian.integrators import COMPILED_METHODS
from porthamiltonian.simulation.options import METHODS

from ..core.protocol import Walker
from ..core.walker import HybridWalker
from .gait import GaitResult, GaitStatus, analyze_gait
from .results import JSONResult

__all__ = [
    "AnalysisStatus",
    "BasinResult",
    "GSNResult",
    "RecoveryStatus",
    "StepDownResult",
    "basin",
    "basin_state",
    "basin_walker",
    "fixed_points",
    "gait_sensitivity_norm",
    "recovers",
    "recovery_steps",
    "step_down",
]


BASIN_METHOD = "QBDF"   #: the method a stiff walker's basin is walked with (basin_walker)


def fixed_points(walker: Walker, gait: GaitResult) -> np.ndarray:
    """The gait's k fixed points (a period-k gait) as rows of section states (model coordinates)."""
    return np.array([[p[k] for k in walker.section] for p in gait.fixed_points], dtype=float)


def _rho(gait: GaitResult) -> float:
    mults = [abs(complex(m)) for m in gait.floquet_multipliers]
    return max(mults) if mults else 0.9


def recovery_steps(gait: GaitResult, tol: float) -> int:
    """Default number of steps after a disturbance (see the module docstring)."""
    rho = min(max(_rho(gait), 1e-3), 0.999)
    n = math.ceil(math.log(tol / 0.1) / math.log(rho)) + 5
    n = max(20, min(300, n))
    k = max(1, int(gait.period_steps))
    return int(math.ceil(n / k) * k)


class RecoveryStatus(StrEnum):
    """How one disturbed walk ended (:func:`recovers`; a basin grid point's outcome). A ``str``:
    ``recovery.status == "fell"`` holds."""

    CONVERGED = "converged"  #: back within the tolerance of a fixed point of the gait
    FELL = "fell"            #: the walker fell
    WANDERED = "wandered"    #: neither, within the steps allowed (a slow transient, another attractor)


class AnalysisStatus(StrEnum):
    """Whether a robustness analysis (step-down, basin, Gait Sensitivity Norm) ran. A ``str``."""

    OK = "ok"                #: it ran (its numbers are the result)
    NO_GAIT = "no_gait"      #: the walker has no periodic gait to disturb
    FELL = "fell"            #: the walker fell in a walk the analysis needed (GSN)


@dataclass
class Recovery:
    """Outcome of one disturbed walk: ``status`` :class:`RecoveryStatus` "converged", "fell" or
    "wandered"."""

    status: RecoveryStatus
    steps: int
    distance: float
    reason: str = ""

    @property
    def survived(self) -> bool:
        return self.status == RecoveryStatus.CONVERGED


def recovers(walker: Walker, z0: np.ndarray, fixed_points: np.ndarray, *, n_steps: int, tol: float,
             ground_drop: float = 0.0, max_chunks: int = 5) -> Recovery:
    """Walk from ``z0`` (after a drop of ``ground_drop``) and classify the outcome: walks
    ``n_steps`` at a time, at most ``max_chunks`` times, until the state after a step is within
    ``tol`` of a fixed point ("converged"; checked after every step, the walk ends there), the
    walker falls ("fell"), or the steps run out ("wandered": a slow transient or another
    attractor). ``steps``: the steps walked (to the first within ``tol``, to the fall)."""
    z, total, d = np.asarray(z0, dtype=float), 0, math.nan

    def distance(z: np.ndarray) -> float:
        return float(np.min(np.max(np.abs(fixed_points - z[None, :]), axis=1)))

    for chunk in range(max_chunks):
        strides = walker.walk(z, n_steps, ground_drop=ground_drop if chunk == 0 else 0.0,
                              until=lambda z: distance(z) <= tol)
        tick("stride", len(strides))
        total += len(strides)
        last = strides[-1]
        if last.fell or last.z_next is None:
            return Recovery(RecoveryStatus.FELL, total, math.nan, last.reason)
        z = last.z_next
        d = distance(z)
        if d <= tol:
            return Recovery(RecoveryStatus.CONVERGED, total, d)
    return Recovery(RecoveryStatus.WANDERED, total, d)


def _gait_or_raise(walker: Walker, gait: GaitResult | None) -> GaitResult:
    return analyze_gait(walker) if gait is None else gait


# --- step-down ------------------------------------------------------------------------------------
@dataclass
class StepDownResult(JSONResult):
    """Result of :func:`step_down` (heights in m).

    status : :class:`AnalysisStatus` "ok", or "no_gait" when the walker has no periodic gait to
    disturb.
    max_step_down : largest drop survived (0.0 when even the first failed; None without a gait).
    contiguous : every drop below max_step_down survived. contiguous_limit : the largest drop
    with every smaller one survived. survived_intervals : the survived set, ``[low, high]``
    pairs in increasing order (each end the survived height nearest its boundary, to
    ``boundary_tol``). first_failure : the smallest height that failed (None if none did).
    holes : failed heights below max_step_down. window : the heights scanned (m).
    cases : one record per height walked (h, status, steps, distance, reason, and whether it was
    on the grid or a bisection). stopped : "" or where the scan stopped at its ``deadline``
    (the fields then describe the heights walked by then).
    """

    model: str
    status: AnalysisStatus
    max_step_down: float | None
    contiguous: bool
    contiguous_limit: float | None
    survived_intervals: list[list[float]]
    resolution: float
    boundary_tol: float
    window: float
    first_failure: float | None
    holes: list[float]
    n_steps: int
    tol: float
    cases: list[dict]
    fixed_point: dict
    parameters: dict
    seconds: float
    message: str
    stopped: str = ""


class _TimeUp(Exception):
    """A study's deadline passed before its next case."""


def _intervals(cases: list[dict]) -> list[list[float]]:
    """The survived heights as [low, high] intervals of consecutive survived cases (sorted by
    h; a drop of 0 counts as survived)."""
    out: list[list[float]] = []
    prev_ok = True
    for c in sorted(cases, key=lambda c: c["h"]):
        if c["survived"]:
            if prev_ok and out:
                out[-1][1] = c["h"]
            elif prev_ok:
                out.append([0.0, c["h"]])
            else:
                out.append([c["h"], c["h"]])
        prev_ok = c["survived"]
    return out


#: the step-down scan's heights are rounded to this many decimals of a metre (0.003, not
#: 0.0030000000000000005)
HEIGHT_DIGITS = 12


def _check_scan(resolution: float, h_max: float) -> None:
    """The step-down scan's grid (m) has heights to walk, distinct after their rounding, and
    at most :data:`~porthamiltonian.batch.grids.MAX_CASES` of them: a resolution above h_max
    walked none and reported "no drop survived"; one below the rounding walked h = 0 over and
    over (with no time limit, without end)."""
    if resolution > h_max:
        raise ParameterValueError(f"step_down: resolution ({resolution:g} m) is larger than "
                                  f"h_max ({h_max:g} m), so the scan would walk no height; give "
                                  "a resolution of at most h_max")
    rounding = 10.0 ** -HEIGHT_DIGITS
    if resolution < rounding:
        raise ParameterValueError(f"step_down: resolution ({resolution:g} m) is below "
                                  f"{rounding:g} m, to which the heights are rounded; give a "
                                  f"resolution of at least {rounding:g} m")
    if h_max / resolution > MAX_CASES:
        raise CostError(f"step_down: h_max / resolution = {h_max:g} m / {resolution:g} m makes "
                        f"up to {h_max / resolution:.3g} heights, more than {MAX_CASES:,} (each "
                        "a walk); give a coarser resolution or a lower h_max")


def step_down(walker: Walker, gait: GaitResult | None = None, *, resolution: float | None = None,
              h_max: float | None = None, n_beyond: int = 8, n_steps: int | None = None,
              tol: float = 1e-4, heights: Iterable[float] | None = None,
              boundary_tol: float = 1e-5,
              progress: Callable[[dict], None] | None = None,
              deadline: float = math.inf) -> StepDownResult:
    """The step-down test (module docstring). ``heights`` replaces the upward scan by an explicit
    list (all evaluated; the boundaries between them are still bisected unless
    ``boundary_tol`` is 0). ``progress`` is called with each case record as it finishes.
    ``deadline`` (a ``time.perf_counter()``): no height is started after it; the result is
    then that of the heights walked (``stopped`` says so; a walk under way ends first)."""
    leg = float(walker.leg_length)
    resolution = 2e-4 * leg if resolution is None else float(resolution)
    h_max = 0.1 * leg if h_max is None else float(h_max)
    if not (resolution > 0 and h_max > 0 and boundary_tol >= 0):
        raise ParameterValueError(f"step_down: resolution ({resolution!r} m) and h_max "
                                  f"({h_max!r} m) must be positive, boundary_tol "
                                  f"({boundary_tol!r} m) >= 0")
    if heights is None:
        _check_scan(resolution, h_max)            # before the gait search
    t0 = time.perf_counter()
    gait = _gait_or_raise(walker, gait)
    base: dict[str, Any] = {"model": walker.name, "parameters": dict(walker.parameters),
                            "tol": tol}
    if gait.status != GaitStatus.PERIODIC:
        return StepDownResult(status=AnalysisStatus.NO_GAIT, max_step_down=None, contiguous=False,
                              contiguous_limit=None, survived_intervals=[],
                              resolution=math.nan, boundary_tol=boundary_tol, window=0.0,
                              first_failure=None, holes=[], n_steps=0,
                              cases=[], fixed_point=gait.fixed_point,
                              seconds=time.perf_counter() - t0,
                              message=f"no periodic gait to disturb: {gait.message}", **base)
    n_steps = recovery_steps(gait, tol) if n_steps is None else int(n_steps)
    fps = fixed_points(walker, gait)
    z0 = fps[0]
    cases: list[dict] = []

    def run(h: float, kind: str) -> dict:
        if time.perf_counter() > deadline:
            raise _TimeUp
        r = recovers(walker, z0, fps, n_steps=n_steps, tol=tol, ground_drop=h)
        rec = {"h": h, "status": r.status, "survived": r.survived, "steps": r.steps,
               "distance": r.distance, "reason": r.reason, "kind": kind}
        cases.append(rec)
        if progress is not None:
            progress(rec)
        return rec

    step, top = resolution, h_max     # (floats here: the closure below reads them)

    def scan() -> None:
        if heights is not None:
            for h in sorted(float(h) for h in heights):
                run(h, "given")
        else:
            misses, k, first = 0, 1, None
            while k * step <= top * (1 + 1e-12):
                h = round(k * step, HEIGHT_DIGITS)
                ok = run(h, "grid")["survived"]
                misses = 0 if ok else misses + 1
                if not ok and first is None:
                    first = h
                if first is not None and h >= 2 * first and misses >= n_beyond:
                    break
                k += 1
        # each boundary between a survived and a failed height, bisected
        if boundary_tol > 0:
            points = sorted(cases, key=lambda c: c["h"])
            pairs = [(0.0, True, points[0]["h"], points[0]["survived"])] if points else []
            pairs += [(a["h"], a["survived"], b["h"], b["survived"])
                      for a, b in itertools.pairwise(points)]
            for lo, lo_ok, hi, hi_ok in pairs:
                if lo_ok == hi_ok:
                    continue
                while hi - lo > boundary_tol:
                    mid = 0.5 * (lo + hi)
                    if run(mid, "bisection")["survived"] == lo_ok:
                        lo = mid
                    else:
                        hi = mid

    stopped = ""
    try:
        scan()
    except _TimeUp:
        stopped = f"stopped at the time limit after {len(cases)} heights"
    if heights is not None:
        resolution = math.nan
    survived_intervals = _intervals(cases)
    survived = [c["h"] for c in cases if c["survived"]]
    failed = [c["h"] for c in cases if not c["survived"]]
    best = max(survived) if survived else 0.0
    holes = sorted(h for h in failed if h < best)
    contiguous = bool(survived) and not holes
    limit = survived_intervals[0][1] if survived_intervals and survived_intervals[0][0] == 0.0 \
        else 0.0
    window = max((c["h"] for c in cases), default=0.0)
    grid = (f"{resolution * 1e3:.3g} mm grid up to {window * 1e3:.3g} mm"
            if math.isfinite(resolution) else f"{len(cases)} heights")
    beyond = [iv for iv in survived_intervals if iv[0] > 0.0]
    message = ((f"{stopped}: " if stopped else "")
               + f"largest drop survived {best * 1e3:.3f} mm ({grid}, boundaries to "
               f"{boundary_tol * 1e3:g} mm); "
               + ("contiguous" if contiguous else
                  "no drop survived" if not survived else
                  f"contiguous up to {limit * 1e3:.3f} mm, then survived "
                  + ", ".join(f"{a * 1e3:.3f}–{b * 1e3:.3f} mm" for a, b in beyond)))
    if stopped and not cases:
        message = "stopped at the time limit before the first height: no drop measured"
    return StepDownResult(status=AnalysisStatus.OK, max_step_down=best, contiguous=contiguous,
                          contiguous_limit=limit, survived_intervals=survived_intervals,
                          resolution=resolution, boundary_tol=boundary_tol, window=window,
                          first_failure=min(failed) if failed else None,
                          holes=holes, n_steps=n_steps, cases=cases,
                          fixed_point=gait.fixed_points[0], seconds=time.perf_counter() - t0,
                          message=message, stopped=stopped, **base)


# --- basin of attraction -------------------------------------------------------------------------
def _method(walker: Walker) -> str:
    """The integration method of ``walker`` ("" for a walker that does not say)."""
    return walker.options.method if isinstance(walker, HybridWalker) else ""


def basin_walker(walker: Walker, method: str | None = "auto") -> Walker:
    """The walker a basin walks its points with (module docstring): ``method`` "auto" — QBDF,
    at the walker's own tolerances, when its own method is a compiled stiff one (Rodas4,
    Rodas5P, QBDF), else the walker as it is (a scipy method such as DOP853); a method name
    (one of :data:`porthamiltonian.simulation.options.METHODS`) — that one, at the walker's
    tolerances; None — the walker as it is."""
    if method is None or not isinstance(walker, HybridWalker):
        return walker
    if method == "auto":
        if walker.options.method not in COMPILED_METHODS:
            return walker
        method = BASIN_METHOD
    if method not in METHODS:
        raise ParameterValueError(f"basin: unknown integration method {method!r}; choose "
                                  f"'auto', None (the walker's own) or one of "
                                  f"{', '.join(METHODS)}")
    return walker if method == walker.options.method else walker.with_options(method=method)


def basin_state(walker: Walker, z_star: np.ndarray, theta: float, theta_dot: float) -> np.ndarray:
    """Section state with thesis θ, θ̇ set and the rest taken from the fixed point ``z_star``
    (φ keeps its offset from 2θ). A walker's own ``basin_state`` method takes precedence."""
    own = walker.basin_state(z_star, theta, theta_dot)
    if own is not None:
        return np.asarray(own, dtype=float)
    names = list(walker.thesis_section)
    w = np.array(walker.to_thesis(np.asarray(z_star, dtype=float)), dtype=float)
    named = walker.section_state(z_star)
    theta0 = named.get("theta", 0.0)
    if "theta" in names:
        w[names.index("theta")] = theta
    if "phi" in names:
        w[names.index("phi")] += 2.0 * (theta - theta0)
    if "theta_dot" not in names:
        raise ParameterValueError(f"{walker.name}: its section has no theta_dot; a basin in "
                                  f"(theta, theta_dot) needs one")
    w[names.index("theta_dot")] = theta_dot
    return np.asarray(walker.from_thesis(w), dtype=float)


@dataclass
class BasinResult(JSONResult):
    """Result of :func:`basin`: a grid over thesis θ (rad) and θ̇ (rad/s) around the fixed point,
    also given scaled (θ/theta_scale, θ̇/theta_dot_scale). ``status[i][j]`` for theta[i],
    theta_dot[j]: "converged", "fell", "wandered" (or "invalid" for a state the walker refuses,
    "not_run" for a point the time limit left out); ``steps[i][j]`` the steps it walked (to the
    first within ``tol``, to the fall: module docstring). ``fraction`` converged (of the points
    walked); ``radius`` the largest scaled distance r such that every grid point within r of
    the fixed point converged (the thesis's "biggest circle" measure, §2.6; a point not run
    counts as not converged); ``method`` the integration method the points were walked with
    (:func:`basin_walker`); ``stopped`` "" or where the grid stopped at its deadline."""

    model: str
    status: AnalysisStatus
    theta: list[float]
    theta_dot: list[float]
    theta_scale: float
    theta_dot_scale: float
    fixed_point: dict
    outcome: list[list[str]]
    steps: list[list[int]]
    fraction: float
    radius: float
    n_steps: int
    tol: float
    method: str
    parameters: dict
    seconds: float
    message: str
    stopped: str = ""


def check_basin_size(n: int, option: str = "n") -> None:
    """Refuse (:class:`~porthamiltonian.errors.CostError`) a basin grid of more than
    :data:`~porthamiltonian.batch.grids.MAX_CASES` points (``n`` per axis; ``option``: how the
    caller names ``n``): its tables are made before the first point is walked (n = 100 000
    asked for 10^10 entries and hung), and each point is a walk."""
    if n * n > MAX_CASES:
        raise CostError(f"basin: {option} = {n} makes a grid of {n * n:,} points, more than "
                        f"{MAX_CASES:,} (each point is a walk, and the grid's tables are made "
                        f"before the first); give {option} <= {math.isqrt(MAX_CASES)}, or run a "
                        "larger grid as a resumable sweep (walker sweep MODEL --analysis basin "
                        "--grid ... --max-cases N)")


def basin(walker: Walker, gait: GaitResult | None = None, *, n: int = 11,
          span: float | tuple[float, float] = 0.1,
          theta_scale: float = 0.4, theta_dot_scale: float = 0.8, n_steps: int | None = None,
          tol: float = 1e-4, method: str | None = "auto",
          progress: Callable[[dict], None] | None = None,
          deadline: float = math.inf) -> BasinResult:
    """Basin of attraction on an n × n grid of scaled section states within ±``span`` (scaled
    units; a pair gives the θ and θ̇ half-widths apart) of the fixed point (module docstring),
    evaluated serially; a parallel basin is a sweep
    over section states (:func:`walker_library.analyses.basin_case`). ``method``: the
    integration of the points' walks (:func:`basin_walker`; the gait is the walker's own).
    ``progress`` is called per grid point. ``deadline`` (a ``time.perf_counter()``): no point is
    started after it; those left are "not_run" (``stopped`` says so)."""
    check_basin_size(n)                        # before the gait search
    t0 = time.perf_counter()
    gait = _gait_or_raise(walker, gait)
    walking = basin_walker(walker, method)
    base: dict[str, Any] = {"model": walker.name, "parameters": dict(walker.parameters),
                            "tol": tol, "theta_scale": theta_scale,
                            "theta_dot_scale": theta_dot_scale,
                            "method": _method(walking)}
    if gait.status != GaitStatus.PERIODIC:
        return BasinResult(status=AnalysisStatus.NO_GAIT, theta=[], theta_dot=[], fixed_point=gait.fixed_point,
                           outcome=[], steps=[], fraction=math.nan, radius=math.nan, n_steps=0,
                           seconds=time.perf_counter() - t0,
                           message=f"no periodic gait: {gait.message}", **base)
    span_th, span_thd = ((float(span), float(span)) if isinstance(span, (int, float, np.number))
                         else (float(span[0]), float(span[1])))
    if n < 2 or not (span_th > 0 and span_thd > 0):
        raise ParameterValueError(f"basin: n ({n}) must be >= 2 and span ({span}) > 0")
    n_steps = recovery_steps(gait, tol) if n_steps is None else int(n_steps)
    fps = fixed_points(walker, gait)
    z_star = fps[0]
    fp = gait.fixed_points[0]
    s = np.linspace(-1.0, 1.0, n)
    thetas = fp["theta"] + theta_scale * span_th * s
    rates = fp["theta_dot"] + theta_dot_scale * span_thd * s
    outcome = [["not_run" for _ in range(n)] for _ in range(n)]
    steps = [[0 for _ in range(n)] for _ in range(n)]
    for i, th in enumerate(thetas):
        for j, thd in enumerate(rates):
            if time.perf_counter() > deadline:
                break
            try:
                z0 = basin_state(walker, z_star, float(th), float(thd))
            except (ValueError, np.linalg.LinAlgError):
                outcome[i][j] = "invalid"
                continue
            r = recovers(walking, z0, fps, n_steps=n_steps, tol=tol)
            outcome[i][j], steps[i][j] = r.status, r.steps
            if progress is not None:
                progress({"theta": float(th), "theta_dot": float(thd), "status": r.status})
    ok = np.array([[o == RecoveryStatus.CONVERGED for o in row] for row in outcome])
    walked = np.array([[o != "not_run" for o in row] for row in outcome])
    stopped = ("" if walked.all() else
               f"stopped at the time limit after {int(walked.sum())} of {walked.size} points")
    S1, S2 = np.meshgrid(span_th * s, span_thd * s, indexing="ij")
    dist = np.hypot(S1, S2)
    bad = dist[~ok]
    radius = float(bad.min()) if bad.size else float(dist.max())
    message = (f"{int(ok.sum())} of {int(walked.sum())} grid states converge to the gait"
               + (f" ({stopped})" if stopped else ""))
    return BasinResult(status=AnalysisStatus.OK, theta=thetas.tolist(), theta_dot=rates.tolist(),
                       fixed_point=fp, outcome=outcome, steps=steps,
                       fraction=float(ok.sum() / walked.sum()) if walked.any() else math.nan,
                       radius=radius, n_steps=n_steps, seconds=time.perf_counter() - t0,
                       message=message, stopped=stopped, **base)


# --- Gait Sensitivity Norm -----------------------------------------------------------------------
@dataclass
class GSNResult(JSONResult):
    """Gait Sensitivity Norm (Hobbelen & Wisse 2007) for a step-down disturbance (per m of drop).

    gsn : sqrt of the summed squares of the responses of all indicators (1/m · their units);
    by_indicator : the norm per indicator (step_period: s/m, step_length: m/m);
    response : g_k per indicator and step; error : difference between the h and h/2 estimates.
    """

    model: str
    status: AnalysisStatus
    gsn: float
    by_indicator: dict
    response: dict
    error: float
    h: float
    n_steps: int
    parameters: dict
    message: str


def gait_sensitivity_norm(walker: Walker, gait: GaitResult | None = None, *, h: float | None = None,
                          n_steps: int | None = None,
                          indicators: tuple[str, ...] = ("step_period", "step_length")) -> GSNResult:
    """GSN of the gait for a single step-down of size h (default 1e-5 of the leg length), by
    finite differences at h and h/2 (module docstring)."""
    gait = _gait_or_raise(walker, gait)
    base: dict[str, Any] = {"model": walker.name, "parameters": dict(walker.parameters)}
    if gait.status != GaitStatus.PERIODIC:
        return GSNResult(status=AnalysisStatus.NO_GAIT, gsn=math.nan, by_indicator={}, response={},
                         error=math.nan, h=math.nan, n_steps=0,
                         message=f"no periodic gait: {gait.message}", **base)
    leg = float(walker.leg_length)
    h = 1e-5 * leg if h is None else float(h)
    n_steps = recovery_steps(gait, 1e-8) if n_steps is None else int(n_steps)
    z0 = fixed_points(walker, gait)[0]
    attr = {"step_period": "duration", "step_length": "step_length"}

    def series(drop: float) -> dict | None:
        strides = walker.walk(z0, n_steps, ground_drop=drop)
        tick("stride", len(strides))
        if strides[-1].fell:
            return None
        return {k: np.array([getattr(s, attr[k]) for s in strides]) for k in indicators}

    runs = []
    for drop in (0.0, h, h / 2):
        run = series(drop)
        if run is None:
            return GSNResult(status=AnalysisStatus.FELL, gsn=math.nan, by_indicator={}, response={},
                             error=math.nan, h=h, n_steps=n_steps,
                             message=f"the walker fell after a drop of {drop:g} m", **base)
        runs.append(run)
    s0, s1, s2 = runs
    g1 = {k: (s1[k] - s0[k]) / h for k in indicators}
    g2 = {k: (s2[k] - s0[k]) / (h / 2) for k in indicators}
    by = {k: float(np.linalg.norm(g2[k])) for k in indicators}
    total = float(math.sqrt(sum(v * v for v in by.values())))
    total1 = float(math.sqrt(sum(float(np.linalg.norm(g1[k])) ** 2 for k in indicators)))
    return GSNResult(status=AnalysisStatus.OK, gsn=total, by_indicator=by,
                     response={k: g2[k].tolist() for k in indicators}, error=abs(total - total1),
                     h=h, n_steps=n_steps,
                     message=f"GSN {total:.6g} (indicators {', '.join(indicators)})", **base)

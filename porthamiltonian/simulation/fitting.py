"""Fitting a model's parameters to measured data: weighted least squares with the exact
Jacobian from the parameter sensitivities. Numeric, no sympy.

:func:`fit` minimises

    ½ Σ_k Σ_i w_ki² (y_k(t_ki; θ) − d_ki)²  +  ½ Σ_e Σ_j w_e² (τ_ej(θ) − T_ej)²

over the parameters θ: y_k an output of the model (a state, any named output: the
trajectory's ``traj[name]``) sampled at its own times t_ki (the data of each output has its own
times; a gap is simply a time without a sample, a NaN in a data frame), d_ki the data, w_ki its
weight (1/σ, σ the noise's standard deviation: default 1 for all); τ_ej the time of the j-th
occurrence of event e, T_ej the measured one (event times as data: a bounce, a touchdown). Every
residual's derivative is exact: one run with ``sensitivity=Seeds(False, θ)`` gives ∂x/∂θ at the
sample times (the loop stops on them: ``t_eval``) and every event's time sensitivity
(:attr:`~.saltation.Crossing.time_sensitivity`); an output's ∂y/∂x and ∂y/∂θ come from central
differences of the compiled outputs at each sample (states: exact rows). The minimiser is
scipy's ``least_squares`` (trust-region reflective, bounds, ``x_scale="jac"``), each evaluation
one simulation.

Identifiability: the weighted sensitivity matrix J (residuals by θ, each column scaled by |θ_j|)
is checked at the start and at the optimum: its rank is the number of singular values above
``rank_tol`` of the largest (default max(1e-6, 100 rtol): the sensitivities' own accuracy
resolves nothing below it). A rank below len(θ) means that the data cannot determine some
combination of the parameters (the null directions); :func:`fit` then does not fit, and its
result names the parameters in those directions (``identifiable`` False, ``unidentifiable``).

Statistics at the optimum (J the weighted Jacobian, N residuals, q parameters): the residual
variance s² = 2·cost/(N − q) (or 1 with ``absolute_sigma``: the weights are true 1/σ), the
covariance s² (JᵀJ)⁻¹ (from J's singular values), standard errors, and the confidence intervals
θ ± t_{(1+c)/2, N−q} · se (Student's t, confidence c: 0.95 by default), the correlations, and
the residuals per output; the convergence report is least_squares'.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ..errors import DataError, OptionError, ParameterValueError
from .psensitivity import jac_p_build, output_gradient
from .saltation import Seeds, Sensitivity
from .simulate import Reset

if TYPE_CHECKING:
    from .compiled import CompiledModel
    from .trajectory import Trajectory

__all__ = ["FitResult", "Series", "fit", "measurements"]


@dataclass(frozen=True)
class Series:
    """The samples of one output (or, for event times, one event): its name, the times t (s)
    and values y (the output's unit; an event's: its times again), the weight of each sample
    (1/σ)."""

    name: str
    t: np.ndarray
    y: np.ndarray
    weight: np.ndarray


def _weights(weights: Any, name: str, size: int) -> np.ndarray:
    """The weights of output ``name``'s ``size`` samples: ``weights[name]`` (a number or one per
    sample), else 1."""
    if weights is None or name not in weights:
        return np.ones(size)
    w = np.array(weights[name], dtype=float) * np.ones(size)
    if w.shape != (size,) or not np.all(np.isfinite(w)) or np.any(w < 0):
        raise OptionError(f"weights[{name!r}] must be a number >= 0 or {size} of them (1/sigma "
                          f"of each sample), got {weights[name]!r}")
    return w


def measurements(data: Any, weights: Mapping[str, Any] | None = None) -> list[Series]:
    """The data as :class:`Series`: a pandas data frame (a time column ``t`` or ``time``, else
    its index, and one column per output; NaN: no sample), a mapping with a ``t`` array and an
    array per output (NaN: no sample), or a mapping of output name -> (times, values). Each
    series keeps its finite samples; DataError when there are none, or a time is not finite,
    or the shapes disagree."""
    frames: dict[str, tuple[Any, Any]] = {}
    if hasattr(data, "columns") and hasattr(data, "index"):          # a pandas data frame
        columns = [str(c) for c in data.columns]
        tcol = next((c for c in ("t", "time") if c in columns), None)
        t = np.asarray(data[tcol] if tcol else data.index, dtype=float)
        frames = {c: (t, np.asarray(data[c], dtype=float)) for c in columns if c != tcol}
    elif isinstance(data, Mapping):
        if "t" in data:
            t = data["t"]
            frames = {str(k): (t, v) for k, v in data.items() if k != "t"}
        else:
            frames = {str(k): v for k, v in data.items()}
    else:
        raise DataError(f"data must be a data frame or a mapping of outputs, got "
                        f"{type(data).__name__}")
    out = []
    for name, pair in frames.items():
        try:
            t, y = (np.asarray(v, dtype=float) for v in pair)
        except (TypeError, ValueError):
            raise DataError(f"data for {name!r} must be numbers (times and values)") from None
        if t.ndim != 1 or t.shape != y.shape:
            raise DataError(f"data for {name!r}: {t.shape} times for {y.shape} values")
        if not np.all(np.isfinite(t)):
            raise DataError(f"data for {name!r}: a time is not a finite number")
        good = np.isfinite(y)
        if not np.any(good):
            raise DataError(f"data for {name!r}: no sample (every value missing)")
        out.append(Series(name, t[good], y[good], _weights(weights, name, int(good.sum()))))
    if not out:
        raise DataError("data: no output to fit")
    return out


@dataclass
class FitResult:
    """What :func:`fit` found (module docstring). SI units.

    params : the fitted parameters, in order; estimates, initial : their values; standard_errors,
    intervals ({name: [low, high]}, at ``confidence``), covariance, correlation (matrices in the
    order of ``params``); residuals ({output: weighted residuals, y − d times w}), rms ({output:
    RMS of the unweighted residuals}); n_data, dof (n_data − q), sigma (s, the residuals'
    standard deviation in weight units); cost (½ Σ r²); singular_values (of the scaled weighted
    Jacobian, largest first), rank, identifiable, unidentifiable (parameters in the null
    directions), null_directions (each {parameter: component}, relative units); converged,
    status, message, nfev, njev, optimality (the gradient's norm at the end: first-order
    optimality) — least_squares' report, or status ``"time_limit"`` when the fit's deadline
    stopped it (the estimates: the best point the runs reached); events ({event: [[model time,
    data time], ...]});
    trajectory : the run at the estimates (not in :meth:`to_dict`).
    """

    params: list[str]
    estimates: dict[str, float]
    initial: dict[str, float]
    standard_errors: dict[str, float] = field(default_factory=dict)
    intervals: dict[str, list[float]] = field(default_factory=dict)
    confidence: float = 0.95
    covariance: list[list[float]] = field(default_factory=list)
    correlation: list[list[float]] = field(default_factory=list)
    residuals: dict[str, list[float]] = field(default_factory=dict)
    rms: dict[str, float] = field(default_factory=dict)
    n_data: int = 0
    dof: int = 0
    sigma: float = math.nan
    cost: float = math.nan
    singular_values: list[float] = field(default_factory=list)
    rank: int = 0
    identifiable: bool = True
    unidentifiable: list[str] = field(default_factory=list)
    null_directions: list[dict[str, float]] = field(default_factory=list)
    converged: bool = False
    status: str = ""
    message: str = ""
    nfev: int = 0
    njev: int = 0
    optimality: float = math.nan
    events: dict[str, list[list[float]]] = field(default_factory=dict)
    trajectory: Trajectory | None = field(default=None, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """Every field but the trajectory (Python numbers, lists and dicts; NaN where a value
        is undefined: the command line writes it as null)."""
        return {k: v for k, v in self.__dict__.items() if k != "trajectory"}


class _Problem:
    """The residuals and their Jacobian of one fit (module docstring)."""

    def __init__(self, model: CompiledModel, series: list[Series], events: list[Series],
                 params: list[str], fixed: dict[str, float], options: dict[str, Any]):
        self.model, self.series, self.events, self.params = model, series, events, params
        self.fixed, self.options = fixed, options
        self.times = np.unique(np.concatenate([s.t for s in series])) if series else None
        self.last: Trajectory | None = None
        names = set(model.state_names) | set(model.output_names)
        unknown = [s.name for s in series if s.name not in names]
        if unknown:
            raise DataError(f"data names no state or output of model {model.name!r}: "
                            f"{', '.join(unknown)}; outputs: {', '.join(model.output_names[:40])}"
                            + (" ..." if len(model.output_names) > 40 else ""))
        bad = [e.name for e in events if e.name not in [ev.name for ev in model.events]]
        if bad:
            raise DataError(f"event data names no event of model {model.name!r}: "
                            f"{', '.join(bad)}; events: "
                            f"{', '.join(ev.name for ev in model.events) or 'none'}")

    def run(self, theta: np.ndarray) -> Trajectory:
        values = {**self.fixed, **dict(zip(self.params, theta.tolist()))}
        o = dict(self.options)
        actions = dict(o.pop("actions") or {})
        for e in self.events:       # an event with data stops the loop, so its time is exact
            actions.setdefault(e.name, _keep_going)
        t_end = o.pop("t_end")
        traj = self.model.simulate(t_end, params=values, actions=actions,
                                   t_eval=self.times, sensitivity=Seeds(False, self.params),
                                   **o)
        if not traj.success:
            raise DataError(f"the model's run at {values} ended with status {traj.status}: "
                            f"{traj.message}; give bounds that keep the parameters valid, or "
                            "other initial values")
        self.last = traj
        return traj

    def evaluate(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(weighted residuals, their Jacobian) at θ."""
        traj = self.run(theta)
        sens = cast(Sensitivity, traj.sensitivity)      # a run given sensitivity= records it
        model, q = self.model, len(self.params)
        S = np.stack([sens.parameters[p] for p in self.params], axis=2)   # (i, n, q)
        index = [model.param_names.index(p) for p in self.params]
        rows, jac = [], []
        t_all = traj.t
        build = jac_p_build(model, self.params)     # the run's (compiled with ∂y/∂p)
        for s in self.series:
            at = np.array([int(np.flatnonzero(t_all == t)[0]) for t in s.t])
            if s.name in model.state_names:
                k = model.state_index(s.name)
                value, d = traj.x[at, k], S[at, k, :]
            else:
                o = model.output_index(s.name)
                value, d = np.empty(len(at)), np.empty((len(at), q))
                for r, i in enumerate(at):
                    x, p = traj.x[i], traj.p_at(i)
                    value[r] = model.outputs(t_all[i], x, p)[o]
                    gx, gp = output_gradient(model, o, t_all[i], x, p, index, build)
                    d[r] = gx @ S[i] + gp[index]
            rows.append(s.weight * (value - s.y))
            jac.append(s.weight[:, None] * d)
        for e in self.events:
            crossings = [c for c in sens.crossings if c.event == e.name]
            value, d = np.empty(len(e.y)), np.zeros((len(e.y), q))
            for j in range(len(e.y)):
                if j < len(crossings):
                    value[j], d[j] = crossings[j].t, crossings[j].time_sensitivity[-q:]
                else:               # fewer occurrences than data: the run's end stands in
                    value[j] = traj.t_final + 1.0
            rows.append(e.weight * (value - e.y))
            jac.append(e.weight[:, None] * d)
        return np.concatenate(rows), np.vstack(jac)


def _keep_going(t: float, x: np.ndarray, p: np.ndarray) -> Reset:
    """The action of an event whose times are data: nothing changes."""
    return Reset()


def _rank(J: np.ndarray, theta: np.ndarray, params: list[str],
          tol: float) -> tuple[np.ndarray, int, list[str], list[dict[str, float]]]:
    """(singular values of J diag(|θ|), the rank, the parameters in null directions, the null
    directions)."""
    scale = np.where(np.abs(theta) > 0, np.abs(theta), 1.0)
    _, sv, Vt = np.linalg.svd(J * scale, full_matrices=False)
    rank = int(np.sum(sv > tol * sv[0])) if sv.size and sv[0] > 0 else 0
    null = Vt[rank:]
    names = [p for j, p in enumerate(params) if np.any(np.abs(null[:, j]) > 0.1)]
    directions = [{p: float(v[j]) for j, p in enumerate(params) if abs(v[j]) > 1e-3}
                  for v in null]
    return sv, rank, names, directions


def fit(model: CompiledModel, data: Any, params: Sequence[str], *,
        events: Mapping[str, Sequence[float] | np.ndarray] | None = None,
        bounds: Mapping[str, tuple[float, float]] | None = None,
        weights: Mapping[str, Any] | None = None, initial: Mapping[str, float] | None = None,
        values: Mapping[str, float] | None = None, x0: Any = None, t_start: float = 0.0,
        t_end: float | None = None, method: str = "Rodas5P", rtol: float = 1e-8,
        atol: float | np.ndarray = 1e-10, max_step: float = math.inf,
        actions: Mapping[str, Any] | None = None, inputs: Any = None, max_nfev: int = 100,
        confidence: float = 0.95, absolute_sigma: bool = False,
        rank_tol: float | None = None, deadline: float = math.inf,
        progress: Callable[[int, float], None] | None = None) -> FitResult:
    """Fit the parameters ``params`` of ``model`` to ``data`` (module docstring).

    data : measured outputs (:func:`measurements`: a data frame, or a mapping); events : event
        times as data, {event name: [times of its first, second, ... occurrence]};
    bounds : {parameter: (low, high)}; weights : {output or event: 1/σ (a number, or one per
        sample)}; initial : starting values (default: the model's); values : other parameters'
        values (held fixed); x0, t_start, method (a compiled one), rtol, atol, max_step,
        actions, inputs : as :func:`~.simulate.simulate`; t_end : the run's end (default: the
        last sample or event time); max_nfev : least_squares' limit of evaluations;
        confidence : of the intervals; absolute_sigma : the weights are true 1/σ (else the
        residual variance is estimated); rank_tol : of the identifiability check;
    deadline : a ``time.perf_counter()`` after which no run starts: the result is then the best
        point the runs reached (status ``"time_limit"``, not converged), its statistics there;
    progress : called after every run with the runs made and the cost ½ Σ r² at the run's
        point (e.g. to show that a long fit is alive).
    """
    from scipy.optimize import least_squares
    from scipy.stats import t as student

    params = list(params)
    if not params or len(set(params)) != len(params):
        raise OptionError(f"params must name distinct parameters to fit, got {params}")
    for p in params:
        model._param_index_of(p)
    if not 0.0 < confidence < 1.0:
        raise OptionError(f"confidence must lie in (0, 1), got {confidence!r}")
    series = measurements(data, weights) if data is not None else []
    event_series = []
    for name, given in (events or {}).items():
        times = np.asarray(given, dtype=float)
        if times.ndim != 1 or not times.size or not np.all(np.isfinite(times)):
            raise DataError(f"event data for {name!r} must be finite times, got {times!r}")
        event_series.append(Series(name, times, times, _weights(weights, name, times.size)))
    if not series and not event_series:
        raise DataError("fit: no data (neither outputs nor event times)")
    named = [s.name for s in series + event_series]
    unused = [name for name in (weights or {}) if name not in named]
    if unused:
        raise OptionError(f"weights for {', '.join(repr(n) for n in unused)}, which the data "
                          f"does not hold (its outputs and events: {', '.join(named)})")
    last = max(float(np.max(s.t)) for s in series + event_series)
    t_end = float(t_end) if t_end is not None else last + (0.0 if series else 1e-9 + 0.1 * last)
    start = model.params({**(values or {}), **(initial or {})})
    theta0 = np.array([start[model.param_names.index(p)] for p in params])
    fixed = {k: float(v) for k, v in (values or {}).items() if k not in params}
    lo = np.full(len(params), -np.inf)
    hi = np.full(len(params), np.inf)
    for name, (a, b) in (bounds or {}).items():
        if name not in params:
            raise OptionError(f"bounds for {name!r}, which is not fitted ({', '.join(params)})")
        lo[params.index(name)], hi[params.index(name)] = float(a), float(b)
        if not float(a) < float(b):
            raise OptionError(f"bounds for {name!r} must be (low, high) with low < high "
                              f"(-inf and inf allowed), got ({a!r}, {b!r})")
    if np.any(theta0 < lo) or np.any(theta0 > hi):
        raise OptionError(f"the initial values {dict(zip(params, theta0.tolist()))} lie "
                          "outside the bounds")
    options = {"x0": x0, "t_start": t_start, "t_end": t_end, "method": method, "rtol": rtol,
               "atol": atol, "max_step": max_step, "actions": actions, "inputs": inputs}
    problem = _Problem(model, series, event_series, params, fixed, options)
    tol = max(1e-6, 100.0 * rtol) if rank_tol is None else float(rank_tol)
    result = FitResult(params, dict(zip(params, theta0.tolist())),
                       dict(zip(params, theta0.tolist())), confidence=confidence)
    cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
    runs = [0]
    best: list[Any] = []        # the lowest cost so far: [cost, θ, r, J, its trajectory]

    def both(theta: np.ndarray, timed: bool = True) -> tuple[np.ndarray, np.ndarray]:
        key = theta.tobytes()
        if key not in cache:
            if timed and time.perf_counter() > deadline:
                raise _TimeUp
            try:
                cache.clear()
                cache[key] = problem.evaluate(theta)
            except ParameterValueError as err:
                raise DataError(f"the fit stepped to {dict(zip(params, theta.tolist()))}: "
                                f"{err}; give bounds that keep the parameters valid") from None
            r, J = cache[key]
            cost = 0.5 * float(r @ r)
            runs[0] += 1
            if not best or cost < best[0]:
                best[:] = [cost, theta.copy(), r, J, problem.last]
            if progress is not None:
                progress(runs[0], cost)
        return cache[key]

    def residuals(theta: np.ndarray) -> np.ndarray:
        return both(theta)[0]

    def jacobian(theta: np.ndarray) -> np.ndarray:
        return both(theta)[1]

    r0, J0 = both(theta0, timed=False)
    sv, rank, bad, directions = _rank(J0, theta0, params, tol)
    if rank < len(params):
        return _unidentifiable(result, sv, rank, bad, directions, len(r0), "start")
    try:
        res = least_squares(residuals, theta0, jac=jacobian, bounds=(lo, hi), x_scale="jac",
                            max_nfev=max_nfev, method="trf")
        x = res.x
        r, J = both(x, timed=False)
    except _TimeUp:
        res = None
        _, x, r, J, problem.last = best
    sv, rank, bad, directions = _rank(J, x, params, tol)
    result.estimates = dict(zip(params, x.tolist()))
    result.trajectory = problem.last
    if rank < len(params):
        return _unidentifiable(result, sv, rank, bad, directions, len(r), "optimum")
    n_data, q = len(r), len(params)
    dof = n_data - q
    s2 = 1.0 if absolute_sigma else (float(r @ r) / dof if dof > 0 else math.nan)
    _, s, Vt = np.linalg.svd(J, full_matrices=False)
    # singular values whose squares underflow (weights of 1e-308): errors beyond float64, inf
    # (correlations NaN), without numpy's "divide by zero" warnings on the user's screen
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        cov = (Vt.T / s ** 2) @ Vt * s2
        se = np.sqrt(np.diag(cov))
        correlation = cov / np.outer(se, se)
    k = float(student.ppf(0.5 + confidence / 2, dof)) if dof > 0 else math.nan
    result.standard_errors = dict(zip(params, se.tolist()))
    result.intervals = {p: [float(x[j] - k * se[j]), float(x[j] + k * se[j])]
                        for j, p in enumerate(params)}
    result.covariance = cov.tolist()
    result.correlation = correlation.tolist()
    offset = 0
    for s_ in series + event_series:
        part = r[offset:offset + len(s_.t)]
        offset += len(s_.t)
        result.residuals[s_.name] = part.tolist()
        w = np.where(s_.weight > 0, s_.weight, 1.0)
        result.rms[s_.name] = float(np.sqrt(np.mean((part / w) ** 2)))
    final = cast(Sensitivity, cast("Trajectory", problem.last).sensitivity)  # the last run's
    for e in event_series:
        crossings = [c.t for c in final.crossings if c.event == e.name]
        result.events[e.name] = [[float(crossings[j]) if j < len(crossings) else math.nan,
                                  float(t)] for j, t in enumerate(e.y)]
    result.n_data, result.dof, result.sigma = n_data, dof, math.sqrt(s2)
    result.singular_values, result.rank = sv.tolist(), rank
    if res is None:
        result.cost, result.converged, result.status = 0.5 * float(r @ r), False, "time_limit"
        result.message = (f"stopped at the time limit after {runs[0]} runs: the estimates are "
                          "the best point the runs reached, not an optimum")
        result.nfev = result.njev = runs[0]
        return result
    result.cost, result.optimality = float(res.cost), float(res.optimality)
    result.converged = bool(res.status > 0)
    result.status, result.message = _STATUS.get(res.status, "failed"), str(res.message)
    result.nfev, result.njev = int(res.nfev), int(res.njev or 0)
    return result


class _TimeUp(Exception):
    """A fit passed its deadline (raised before a run, caught around the minimiser)."""


_STATUS = {-1: "failed", 0: "max_nfev", 1: "gtol", 2: "ftol", 3: "xtol", 4: "ftol_xtol"}


def _unidentifiable(result: FitResult, sv: np.ndarray, rank: int, bad: list[str],
                    directions: list[dict[str, float]], n_data: int, where: str) -> FitResult:
    """The result of a fit refused because the data cannot determine ``bad``."""
    result.singular_values, result.rank = sv.tolist(), rank
    result.identifiable, result.unidentifiable = False, bad
    result.null_directions, result.n_data = directions, n_data
    result.status = "unidentifiable"
    combos = "; ".join(", ".join(f"{p} {v:+.3g}" for p, v in d.items()) for d in directions)
    result.message = (f"the data cannot determine {', '.join(bad)} (rank {rank} of "
                      f"{len(result.params)} at the {where}): they move the outputs only "
                      f"together along ({combos}) in relative units; fix all but one of them "
                      "(values=...), or add data that separates them")
    result.estimates = {p: (math.nan if p in bad else v) for p, v in result.estimates.items()}
    return result

"""Gait analysis: find the walker's gait without depending on luck, and describe it.

:func:`analyze_gait` is what ``walker gait`` runs. It collects the periodic orbits it can reach:

1. Newton on S(z) − z (period 1) from the guess (the given one, or the walker's own);
2. the walker's own motion from the guess (iterating the stride map): a fall is recorded with
   its step and reason; a repeating sequence of period k ≤ max_period is refined by Newton on
   S^k(z) − z;
3. unless a stable orbit was found already (or ``continuation=False``): the model file's
   nominal gait (its own guess at its own parameter values) continued to the requested
   parameters — a homotopy in the parameters that differ (:mod:`.continuation`), switching onto
   the period-doubled branch at the flips on the way (periods 1, 2, 4) — and the orbits at its
   end.

Under a time limit, when step 3 can run (continuation on, parameters that differ from the
file's), steps 1–2 get the first :data:`DIRECT_SHARE` of it and step 3 the rest: an extreme
parameter (a contact 1e9 times stiffer) can make Newton from the guess use any time it is given,
and the continuation, the step that reaches such parameters, would then never start.

Each orbit's Floquet multipliers come with error bounds (:func:`~.monodromy.floquet`: the
finite-difference step chosen per coordinate, so the verdict does not depend on a step the user
picks). The outcome, in ``outcome`` (and ``status``, the interface's three values):

* ``"stable_gait"`` (status "periodic", stable true): the stable orbit of lowest period;
* ``"unstable_orbits_only"`` (status "periodic", stable false): the orbits found, none stable,
  every one in ``orbits`` with its period and multipliers; the top-level fields describe the
  least unstable;
* ``"fell"`` (status "fell"): no orbit, and the walker falls from the guess (``fell_at_step``,
  ``fall_reason``);
* ``"no_periodic_orbit"`` (status "no_fixed_point"): no orbit from this guess, and no fall.

The top-level metrics (step period, length, speed, ...) are the reported orbit's, never the last
iterate's; null when there is no orbit. Every result is a :class:`GaitResult`, serializable to
JSON (SI units, named fields). Falls and failed searches are results, never exceptions; only
invalid input (unknown or out-of-range parameters, a malformed guess) raises.

:func:`section_guess` builds a full section state from a previous result and named values (the
``--guess FILE`` and ``--set COORDINATE=VALUE`` options); :func:`walk` simulates n steps from a
section state in one run (one energy ledger) and returns the per-step records and the ledger
residual (:class:`WalkResult`).
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np

from porthamiltonian.batch.progress import tick
from porthamiltonian.errors import ModelError
from porthamiltonian.simulation.options import check_integer, check_number, is_real

from ..core.protocol import Stride, Walker
from .metrics import GaitMetrics, gait_metrics
from .monodromy import FloquetResult, floquet
from .poincare import FixedPointResult, PeriodResult, WalkerFell, detect_period, find_fixed_point
from .results import JSONResult, to_jsonable, view

__all__ = ["DIRECT_SHARE", "GAIT_QUANTITIES", "TIME_LIMIT", "GaitOutcome", "GaitResult", "GaitStatus", "Orbit", "WalkResult",
           "analyze_gait", "gait_start", "section_guess", "walk"]

_LEGGED_KEYS = ("theta", "theta_dot", "phi", "phi_dot")
#: the default time limit of a gait search (s): its continuation from the nominal gait stops
#: there (a stiffness of 1e15 would otherwise be followed for hours)
TIME_LIMIT = 600.0
#: the part of a gait search's time limit that steps 1-2 (from the guess) may use when step 3
#: (the continuation from the nominal gait) can follow (module docstring)
DIRECT_SHARE = 0.5
#: the gait quantities that :mod:`.gradients` differentiates (and ``walker optimize`` takes as
#: objective), by their keys in ``walker gait --json``
GAIT_QUANTITIES = ("step_period", "speed", "step_length", "energy_dissipated_per_step",
                   "cost_of_transport", "max_multiplier_modulus")


@dataclass
class Orbit:
    """A periodic orbit found: its period (steps), fixed point (model section coordinates), its
    Floquet multipliers (:class:`~.monodromy.FloquetResult`) and how it was found."""

    period: int
    z: np.ndarray
    floquet: FloquetResult
    found_by: str

    @property
    def stable(self) -> bool:
        return self.floquet.stable


class GaitStatus(StrEnum):
    """The gait search's answer in the interface's three values (``walker gait --json``'s
    ``status``). A ``str``: ``gait.status == "periodic"`` holds."""

    PERIODIC = "periodic"              #: a periodic orbit was found (stable or not)
    FELL = "fell"                      #: no orbit, and the walker falls from the guess
    NO_FIXED_POINT = "no_fixed_point"  #: no orbit from this guess, and no fall


class GaitOutcome(StrEnum):
    """The gait search's answer in detail (``outcome``; module docstring)."""

    STABLE_GAIT = "stable_gait"                    #: status periodic, stable
    UNSTABLE_ORBITS_ONLY = "unstable_orbits_only"  #: status periodic, none stable
    FELL = "fell"                                  #: status fell
    NO_PERIODIC_ORBIT = "no_periodic_orbit"        #: status no_fixed_point


@dataclass
class GaitResult(JSONResult):
    """A walker's gait (see :func:`analyze_gait`). SI units; angles in rad.

    status : :class:`GaitStatus` "periodic", "fell" or "no_fixed_point"; outcome :
        :class:`GaitOutcome` "stable_gait", "unstable_orbits_only", "fell" or
        "no_periodic_orbit" (module docstring).
    period_steps : k of the reported period-k orbit (0 if none).
    stable : all its Floquet multipliers inside the unit circle (None without an orbit);
        stability_certain : their error bounds cannot change that verdict.
    fixed_point : its section state just after heel strike, by name (model's own coordinates and
        the thesis's theta, theta_dot, phi, phi_dot); values null when there is no orbit.
    fixed_points : the k section states of the orbit.
    floquet_multipliers : eigenvalues of the Jacobian of S^k (largest modulus first);
        multiplier_errors : their error bounds; multiplier_error : the largest.
    metrics : the orbit's (see :mod:`walker_library.analyses.metrics`).
    orbits : every orbit found (period, fixed point, multipliers, stable, how it was found).
    fell_at_step, fall_reason : the step (1-based) during which the walker fell iterating from
        the guess, and why (None, "" if it did not).
    last_iterate : the last section state reached iterating from the guess, when no orbit was
        found (by name). newton : the period-1 Newton search from the guess.
    unstable_fixed_point : the unstable period-1 orbit Newton found from the guess, if any.
    search : what was tried, in order.
    gradients : with ``walker gait --gradient``: {quantity: {parameter: derivative}} of the
        reported orbit (:mod:`.gradients`: step_period, speed, step_length,
        energy_dissipated_per_step, cost_of_transport, max_multiplier_modulus); gradient_errors
        the same layout (the multiplier's error bound); fixed_point_gradient {coordinate:
        {parameter: dz*/dp}}. None without.
    """

    model: str
    status: GaitStatus
    outcome: GaitOutcome
    period_steps: int
    stable: bool | None
    stability_certain: bool | None
    fixed_point: dict
    fixed_points: list[dict]
    section: list[str]
    thesis_section: list[str]
    floquet_multipliers: list[complex]
    multiplier_errors: list[float]
    multiplier_error: float
    metrics: GaitMetrics
    orbits: list[dict]
    steps: list[dict]
    fell_at_step: int | None
    fall_reason: str
    last_iterate: dict | None
    newton: dict
    unstable_fixed_point: dict | None
    search: list[str]
    parameters: dict
    message: str
    gradients: dict | None = None
    gradient_errors: dict | None = None
    fixed_point_gradient: dict | None = None

    def to_dict(self) -> dict:
        d = {
            "model": self.model, "status": self.status, "outcome": self.outcome,
            "period_steps": int(self.period_steps), "stable": self.stable,
            "stability_certain": self.stability_certain, "fixed_point": self.fixed_point,
            "fixed_points": self.fixed_points, "section": self.section,
            "thesis_section": self.thesis_section,
            "floquet_multipliers": [{"re": float(np.real(m)), "im": float(np.imag(m))}
                                    for m in self.floquet_multipliers],
            "multiplier_errors": self.multiplier_errors,
            "multiplier_error": self.multiplier_error,
        }
        d.update(self.metrics.to_dict())
        d.update({"orbits": self.orbits, "steps": self.steps, "fell_at_step": self.fell_at_step,
                  "fall_reason": self.fall_reason, "last_iterate": self.last_iterate,
                  "newton": self.newton, "unstable_fixed_point": self.unstable_fixed_point,
                  "search": self.search, "parameters": self.parameters, "message": self.message})
        if self.gradients is not None:
            d.update({"gradients": self.gradients, "gradient_errors": self.gradient_errors,
                      "fixed_point_gradient": self.fixed_point_gradient})
        return to_jsonable(d)

    def plot(self, walker: Walker | None = None, *, steps: int = 2) -> Any:
        """Limit cycle and Floquet multipliers, a quick look (the report's view,
        :func:`walker_library.report.display.plot_gait`); returns the Axes."""
        return view(self, "plot")(self, walker, steps=steps)

    def _repr_html_(self) -> str:
        return view(self, "html")(self)


def _named(walker: Walker, z: np.ndarray) -> dict:
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


def _nan_metrics() -> GaitMetrics:
    return gait_metrics([], 1.0)


# --- guesses -------------------------------------------------------------------------------------
def section_guess(walker: Walker, previous: Mapping | None = None,
                  values: Mapping[str, float] | None = None) -> np.ndarray | None:
    """A full section state (model coordinates) for the gait search: the fixed point of a
    previous result (``previous``: a ``walker gait --json`` document, or its ``fixed_point``),
    then ``values`` by name — model section coordinates (``walker.q.stance``) or the thesis's
    (``theta_dot``, ``phi``, ...; not both kinds) — over it, the rest from the walker's own
    guess. None when neither is given. Malformed input raises a ModelError naming the problem."""
    if previous is None and not values:
        return None
    model_names, thesis_names = list(walker.section), list(walker.thesis_section)
    z = np.asarray(walker.initial_guess(), dtype=float)
    if previous is not None:
        if not isinstance(previous, Mapping):
            raise ModelError("the guess must be a JSON object (a `walker gait --json` result or "
                             "its fixed_point)")
        point = previous.get("fixed_point", previous)
        if not isinstance(point, Mapping):
            raise ModelError("the guess's fixed_point must be an object of section coordinates")
        missing = [k for k in model_names if k not in point]
        if missing:
            raise ModelError(f"the guess has no value for {', '.join(missing)} (a {walker.name} "
                             f"section state names {', '.join(model_names)}); is it a result of "
                             f"another walker ({previous.get('model', '?')})?")
        z = np.array([_finite(point[k], k) for k in model_names])
    values = dict(values or {})
    unknown = [k for k in values if k not in model_names and k not in thesis_names]
    if unknown:
        raise ModelError(f"{', '.join(unknown)}: not a section coordinate of {walker.name}; its "
                         f"section: {', '.join(model_names)} (thesis: {', '.join(thesis_names)})")
    mine = {k: _finite(v, k) for k, v in values.items() if k in model_names}
    theirs = {k: _finite(v, k) for k, v in values.items() if k not in model_names}
    if mine and theirs:
        raise ModelError(f"give the guess in the model's section coordinates "
                         f"({', '.join(mine)}) or the thesis's ({', '.join(theirs)}), not both")
    for k, v in mine.items():
        z[model_names.index(k)] = v
    if theirs:
        w = np.asarray(walker.to_thesis(z), dtype=float)
        for k, v in theirs.items():
            w[thesis_names.index(k)] = v
        z = np.asarray(walker.from_thesis(w), dtype=float)
    return z


def _finite(value: Any, name: str) -> float:
    """``value`` as a float, or ModelError naming ``name``: a number (not a bool), finite as a
    float (a JSON integer has no bound: 10**400 raised OverflowError out of the check)."""
    number = math.nan
    if is_real(value):
        try:
            number = float(value)
        except OverflowError:
            pass
    if not math.isfinite(number):
        raise ModelError(f"guess: {name} must be a finite number, got {value!r}")
    return number


# --- the search ----------------------------------------------------------------------------------
class _Search:
    """The orbits found so far (deduplicated) and the record of what was tried."""

    def __init__(self, walker: Walker, fd_step: float | None, jacobian: str, tol: float):
        self.walker, self.fd_step, self.jacobian, self.tol = walker, fd_step, jacobian, tol
        self.orbits: list[Orbit] = []
        self.tried: list[str] = []
        self.period: PeriodResult | None = None     # the period detection from the guess
        self.stopped = ""       # why the search stopped at its time limit ("" if it did not)
        self.time_limit: float | None = None

    def out_of_time(self, where: str) -> None:
        """Record that the search stopped at its time limit, ``where``."""
        self.stopped = (f"the search stopped at its time limit ({self.time_limit:g} s; "
                        f"--time-limit) {where}")
        self.tried.append(self.stopped)

    def add(self, z: np.ndarray, period: int, found_by: str,
            fl: FloquetResult | None = None) -> Orbit | None:
        """Record the period-``period`` orbit through z (None if it is known or its multipliers
        cannot be computed: a perturbed stride falls)."""
        z = np.asarray(z, dtype=float)
        for o in self.orbits:
            if o.period == period and self._same(o, z):
                return None
        if fl is None:
            try:
                fl = floquet(self.walker, z, period=period, step=self.fd_step,
                             jacobian=self.jacobian)
            except WalkerFell:
                self.tried.append(f"the period-{period} orbit found by {found_by} has no "
                                  "multipliers: a stride needed for the Jacobian falls")
                return None
        orbit = Orbit(period, z, fl, found_by)
        self.orbits.append(orbit)
        self.tried.append(f"{found_by}: period-{period} orbit, max |λ| = {fl.max_modulus:.6g} "
                          f"± {fl.error:.1g} ({'stable' if fl.stable else 'unstable'})")
        return orbit

    def _same(self, o: Orbit, z: np.ndarray) -> bool:
        scale = 1e3 * self.tol + 1e-7 * (1.0 + float(np.max(np.abs(z))))
        if float(np.max(np.abs(o.z - z))) < scale:
            return True
        if o.period == 1:
            return False
        strides = self.walker.walk(o.z, o.period - 1)
        return any(s.z_next is not None and float(np.max(np.abs(s.z_next - z))) < scale
                   for s in strides)

    def stable(self) -> Orbit | None:
        good = [o for o in self.orbits if o.stable]
        return min(good, key=lambda o: (o.period, o.floquet.max_modulus)) if good else None


def _defaults(walker: Walker) -> dict[str, float]:
    return {k: s.value for k, s in walker.specs.items()}


def _changed(walker: Walker) -> dict[str, float]:
    """The walker's parameter values that differ from its model file's (step 3's homotopy)."""
    nominal_values = _defaults(walker)
    return {k: v for k, v in walker.parameters.items()
            if k in nominal_values and nominal_values[k] != v}


def _homotopy(search: _Search, walker: Walker, *, tol: float, max_iter: int, max_period: int,
              log: Callable[[str], None] | None, deadline: float) -> None:
    """Continue the model file's nominal gait to the walker's parameters (module docstring),
    until the search's ``deadline`` (time.perf_counter())."""
    nominal_values = _defaults(walker)
    changed = _changed(walker)
    nominal = walker.with_parameters(**nominal_values)
    start, _ = _direct(nominal, None, tol=tol, max_iter=max_iter, max_period=max_period,
                    search=_Search(nominal, search.fd_step, search.jacobian, tol))
    if start is None:
        search.tried.append("the model file's nominal gait: no stable orbit from its own guess "
                            "(homotopy continues stable gaits only)")
        return
    if not changed:
        search.add(start.z, start.period, "the model file's nominal gait", start.floquet)
        return
    names = ", ".join(f"{k} {nominal_values[k]:g} -> {v:g}" for k, v in changed.items())
    left = deadline - time.perf_counter()
    if left <= 0:
        search.out_of_time(f"before the continuation from the nominal gait ({names})")
        return
    if log is not None:
        log(f"continuing the model file's nominal gait: {names}")
    from .continuation import ParameterPath, continue_gait  # (only when a gait is continued)

    try:
        path = ParameterPath.homotopy(walker, nominal_values, walker.parameters)
        result = continue_gait(nominal, path, guess=start.z, period=start.period,
                               jacobian=search.jacobian, tol=tol, locate_tol=1e-4,
                               doublings=2, max_points=100, log=log,
                               time_limit=None if math.isinf(left) else left)
    except ModelError as err:
        search.tried.append(f"continuation from the nominal gait ({names}): {err}")
        return
    if result.stopped:
        reached = max((p.mu for br in result.branches for p in br.points), default=0.0)
        search.out_of_time(f"while continuing the model file's nominal gait ({names}), "
                           f"{100 * reached:.3g} % of the way")
    ends = 0
    for i, br in enumerate(result.branches):
        last = br.points[-1] if br.points else None
        if last is None or abs(last.mu - 1.0) > 1e-12:
            search.tried.append(f"continuation ({names}), branch {i} (period {br.period}): "
                                f"{br.end}")
            continue
        ends += 1
        search.add(last.z, br.period, f"continuation from the nominal gait ({names}), "
                                      f"branch {i} ({br.origin})")
    if not ends:
        search.tried.append(f"continuation from the nominal gait ({names}) reached no orbit "
                            "at the requested values")


def _direct(walker: Walker, guess: np.ndarray | None, *, tol: float, max_iter: int,
            max_period: int, search: _Search, n_iterate: int = 200, period_tol: float = 1e-7,
            deadline: float = math.inf,
            share: bool = False) -> tuple[Orbit | None, FixedPointResult]:
    """Steps 1–2 of the search from ``guess``: (the stable orbit found, or None; the period-1
    Newton search from the guess). The period detection is left in ``search.period``.
    ``deadline``: the search's, or (``share``) the end of the part of it steps 1-2 may use."""
    z0 = np.asarray(walker.initial_guess() if guess is None else guess, dtype=float)
    fp = find_fixed_point(walker, z0, period=1, tol=tol, max_iter=max_iter, deadline=deadline)
    search.tried.append(f"Newton (period 1) from the guess: {fp.message}")
    if fp.converged:
        orbit = search.add(fp.z, 1, "Newton from the guess")
        if orbit is not None and orbit.stable:
            search.period = None
            return orbit, fp
    if time.perf_counter() > deadline:
        if share:
            search.tried.append(f"the search from the guess stopped at {DIRECT_SHARE:.0%} of "
                                "the time limit (the continuation gets the rest)")
        else:
            search.out_of_time("after Newton from the guess")
        return search.stable(), fp
    pr = detect_period(walker, z0, max_period=max_period, n_steps=n_iterate, tol=period_tol)
    search.period = pr
    if pr.fell_at_step is not None:
        search.tried.append(f"iterating from the guess: the walker fell during step "
                            f"{pr.fell_at_step} ({pr.iteration.fall_reason})")
    elif pr.period > 0:
        fpk = find_fixed_point(walker, pr.iteration.states[-1], period=pr.period, tol=tol,
                               max_iter=max_iter, deadline=deadline)
        search.tried.append(f"iterating from the guess: period {pr.period}; Newton on S^"
                            f"{pr.period}: {fpk.message}")
        if fpk.converged:
            search.add(fpk.z, pr.period, "iterating from the guess")
    else:
        search.tried.append(f"iterating from the guess: {len(pr.iteration.strides)} steps, no "
                            f"period <= {max_period} (closest relative distance "
                            f"{pr.distance:.2e})")
    return search.stable(), fp


def check_search(max_period: Any, n_iterate: Any,
                 fd_step: Any) -> tuple[int, int, float | None]:
    """The options of :func:`analyze_gait` that a sweep passes through (``--option``), checked:
    ``max_period`` and ``n_iterate`` whole numbers >= 1, ``fd_step`` None or a finite number
    > 0; else an OptionError naming the option (a max_period of -1 or "x" was used as given,
    its error, if any, met only when period 1 failed)."""
    return (check_integer("max_period", max_period), check_integer("n_iterate", n_iterate),
            None if fd_step is None else check_number("fd_step", fd_step, positive=True))


def analyze_gait(walker: Walker, guess: np.ndarray | None = None, *, max_period: int = 8,
                 fd_step: float | None = None, tol: float | None = None, n_iterate: int = 200,
                 period_tol: float = 1e-7, max_iter: int = 30, continuation: bool = True,
                 jacobian: str = "variational", log: Callable[[str], None] | None = None,
                 time_limit: float | None = TIME_LIMIT) -> GaitResult:
    """Find and describe the gait of ``walker`` starting from ``guess`` (default: the walker's own
    initial guess). See the module docstring for the search and :class:`GaitResult` for the
    fields.

    jacobian : the stride map's Jacobian, "variational" (exact, the default) or "fd" (finite
        differences, the cross-check; :mod:`.monodromy`). fd_step : with "fd", where the
        finite-difference ladder starts (relative to max(|z_j|, 1e-3); default 1e-3): the step
        kept is chosen per coordinate, so this does not change the result beyond its error
        bounds. tol : Newton tolerance on |S^k(z) − z|_∞ (default: the walker's
        ``gait_tolerance`` if it has one, else 1e-10). n_iterate, period_tol, max_period :
        period detection. continuation : continue the model file's nominal gait to these
        parameters when no stable orbit is found otherwise. time_limit : seconds after which
        the search starts nothing new (default :data:`TIME_LIMIT`; None: no limit); what it
        found by then is the result, and ``search`` and the message say where it stopped.
        log : progress lines of the homotopy (where it goes, each point): the part of the
        search that can take long.
    """
    if time_limit is not None and not (is_real(time_limit) and math.isfinite(time_limit)
                                       and time_limit > 0):
        raise ModelError(f"time_limit must be a number of seconds > 0, got {time_limit!r}")
    max_period, n_iterate, fd_step = check_search(max_period, n_iterate, fd_step)
    deadline = math.inf if time_limit is None else time.perf_counter() + time_limit
    if tol is None:
        tol = float(walker.gait_tolerance)
    base: dict[str, Any] = {"model": walker.name, "section": list(walker.section),
                            "thesis_section": list(walker.thesis_section), "parameters": dict(walker.parameters)}
    search = _Search(walker, fd_step, jacobian, tol)
    search.time_limit = time_limit
    share = time_limit is not None and continuation and bool(_changed(walker))
    gait, fp = _direct(walker, guess, tol=tol, max_iter=max_iter, max_period=max_period,
                       search=search, n_iterate=n_iterate, period_tol=period_tol,
                       deadline=(time.perf_counter() + DIRECT_SHARE * time_limit
                                 if share and time_limit is not None else deadline),
                       share=share)
    pr = search.period
    if gait is None and continuation and not search.stopped:
        _homotopy(search, walker, tol=tol, max_iter=max_iter, max_period=max_period, log=log,
                  deadline=deadline)
        gait = search.stable()
    newton = _newton_dict(walker, fp)
    unstable = None
    if fp.converged:
        one = next((o for o in search.orbits if o.period == 1 and not o.stable
                    and float(np.max(np.abs(o.z - fp.z))) < 1e3 * tol + 1e-9), None)
        if one is not None:
            unstable = {"fixed_point": _named(walker, one.z),
                        "floquet_multipliers": [complex(m) for m in one.floquet.multipliers]}
    orbits = [{"period_steps": o.period, "stable": o.stable,
               "max_multiplier": o.floquet.max_modulus, "fixed_point": _named(walker, o.z),
               "floquet_multipliers": [complex(m) for m in o.floquet.multipliers],
               "multiplier_errors": o.floquet.errors.tolist(), "found_by": o.found_by}
              for o in search.orbits]
    fell = pr if pr is not None and pr.fell_at_step is not None else None
    common: dict[str, Any] = dict(
        orbits=orbits, newton=newton, unstable_fixed_point=unstable, search=list(search.tried),
        fell_at_step=fell.fell_at_step if fell is not None else None,
        fall_reason=fell.iteration.fall_reason if fell is not None else "", **base)
    if gait is not None or search.orbits:
        orbit = gait or min(search.orbits, key=lambda o: (o.floquet.max_modulus, o.period))
        outcome = (GaitOutcome.STABLE_GAIT if gait is not None
                   else GaitOutcome.UNSTABLE_ORBITS_ONLY)
        if gait is not None:
            message = f"stable period-{orbit.period} gait ({orbit.found_by})"
        else:
            message = (f"only unstable orbits found ({len(search.orbits)}: periods "
                       f"{', '.join(str(o.period) for o in search.orbits)}); reported: the least "
                       f"unstable, period {orbit.period} ({orbit.found_by})")
        if search.stopped:
            message += f"; {search.stopped}"
        return _periodic(walker, orbit, outcome, message, common)
    if fell is not None:
        it = fell.iteration
        return GaitResult(status=GaitStatus.FELL, outcome=GaitOutcome.FELL, period_steps=0,
                          stable=None,
                          stability_certain=None, fixed_point=_empty_point(walker),
                          fixed_points=[], floquet_multipliers=[], multiplier_errors=[],
                          multiplier_error=math.nan, metrics=_nan_metrics(),
                          steps=[_step_record(walker, s) for s in it.strides],
                          last_iterate=_named(walker, it.states[-1]),
                          message=f"no periodic orbit found, and the walker fell during step "
                                  f"{fell.fell_at_step} ({it.fall_reason}) iterating from the guess"
                                  + (f"; {search.stopped}" if search.stopped else ""),
                          **common)
    last = pr.iteration.states[-1] if pr is not None else fp.z
    return GaitResult(status=GaitStatus.NO_FIXED_POINT, outcome=GaitOutcome.NO_PERIODIC_ORBIT,
                      period_steps=0,
                      stable=None, stability_certain=None, fixed_point=_empty_point(walker),
                      fixed_points=[], floquet_multipliers=[], multiplier_errors=[],
                      multiplier_error=math.nan, metrics=_nan_metrics(), steps=[],
                      last_iterate=_named(walker, last),
                      message=f"no periodic orbit of period <= {max_period} found from this "
                              f"guess ({'; '.join(search.tried)})", **common)


def _periodic(walker: Walker, orbit: Orbit, outcome: GaitOutcome, message: str,
              common: dict) -> GaitResult:
    strides = walker.walk(orbit.z, orbit.period, details=True)
    points = [_named(walker, orbit.z)] + [_named(walker, s.z_next) for s in strides[:-1]
                                          if s.z_next is not None]
    fl = orbit.floquet
    return GaitResult(status=GaitStatus.PERIODIC, outcome=outcome, period_steps=orbit.period,
                      stable=fl.stable, stability_certain=fl.certain, fixed_point=points[0],
                      fixed_points=points,
                      floquet_multipliers=[complex(m) for m in fl.multipliers],
                      multiplier_errors=fl.errors.tolist(), multiplier_error=fl.error,
                      metrics=gait_metrics(strides, walker.weight),
                      steps=[_step_record(walker, s) for s in strides], last_iterate=None,
                      message=message, **common)


def gait_start(walker: Walker, parameter: str, start: float, guess: np.ndarray | None = None,
               **options: Any) -> tuple[np.ndarray, int]:
    """The fixed point and period of the walker's gait at ``parameter`` = ``start`` (the start
    of a continuation): the period-1 orbit Newton reaches from a given ``guess`` (stable or not:
    an unstable orbit, Garcia's short-period gait say, is followed as given), else the orbit
    :func:`analyze_gait` reports there; a ModelError saying what the search found when there is
    no orbit."""
    w = walker.with_parameters(**{parameter: start})
    if guess is not None:
        fp = find_fixed_point(w, guess, tol=float(w.gait_tolerance))
        if fp.converged:
            return fp.z, 1
    g = analyze_gait(w, guess, **options)
    if g.status != GaitStatus.PERIODIC:
        raise ModelError(f"{walker.name}: no gait at the start of the range ({parameter} = "
                         f"{start:g}): {g.message}; start the range where the walker has a gait "
                         "(e.g. at the file's value) or give a guess")
    return np.array([g.fixed_point[k] for k in w.section], dtype=float), g.period_steps


#: strides per simulation of :func:`walk`: a longer walk runs in blocks of this many strides,
#: each from the section state the last one ended in, so that its memory stays bounded
WALK_BLOCK = 20


@dataclass
class WalkResult(JSONResult):
    """n steps walked: per-step records, and the energy ledger over the whole walk.

    stopped : ``"time_limit"`` when the walk stopped at its deadline with fewer steps than
    asked (and did not fall), else ``""``."""

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
    stopped: str = ""


def walk(walker: Walker, z0: np.ndarray | None = None, n_steps: int = 20, *,
         deadline: float = math.inf) -> WalkResult:
    """Walk ``n_steps`` from ``z0`` (default: the initial guess) and report the energy ledger:
    its residual r = H − H(0) + E_diss − E_in, its largest |r| (J) and that relative to the
    energy scale (``Trajectory.energy_scale``).

    Up to :data:`WALK_BLOCK` steps are one simulation; a longer walk is simulated in blocks of
    that many strides, each from the section state the last block ended in (the composition of
    the stride map the gait analyses use), so that its memory does not grow with the steps
    (one simulation keeps every integrator step: 0.5 MB per stride for the compliant-leg
    walker). The residual then adds up over the blocks (each block's from its own start, plus
    the ends of the blocks before it), relative to the largest block's energy scale (smaller
    than the whole walk's: the relative residual is not flattered). ``deadline`` (a
    ``time.perf_counter()``): no block starts after it; the result then says so (``stopped``).
    ``n_steps`` is an integer >= 1 and ``deadline`` a number (not NaN, which compares false
    with every time: no limit); else an OptionError (0 or -1 steps returned an empty walk)."""
    n_steps = check_integer("n_steps", n_steps)
    deadline = check_number("deadline", deadline, finite=False)
    z = np.asarray(walker.initial_guess() if z0 is None else z0, dtype=float)
    steps: list[dict] = []
    dissipated = released = offset = scale = max_res = 0.0
    fell, reason, stopped, left = False, "", "", n_steps
    while left > 0:
        if time.perf_counter() > deadline:
            stopped = "time_limit"
            break
        strides = walker.walk(z, min(left, WALK_BLOCK), record=True)
        tick("stride", len(strides))
        traj = strides[-1].info.get("trajectory")
        if traj is not None and len(traj.t):
            r = traj.residual
            max_res = float(np.max([max_res, float(np.max(np.abs(offset + r)))]))  # NaN stays
            offset += float(r[-1])
            scale = max(scale, traj.energy_scale)
        else:
            max_res = math.nan
        steps += [_step_record(walker, s) for s in strides]
        good = [s for s in strides if not s.fell]
        dissipated += sum(s.energy_dissipated for s in good)
        released += sum(s.potential_released for s in good)
        left -= len(good)
        if strides[-1].fell or not good or good[-1].z_next is None:
            fell, reason = True, strides[-1].reason
            break
        z = good[-1].z_next
    rel = max_res / scale if scale > 0 else math.nan
    return WalkResult(walker.name, n_steps - left, fell, reason, steps, float(dissipated),
                      float(released), max_res, rel, dict(walker.parameters), stopped)

"""Continuation of periodic gaits: branches of fixed points of the stride map S^k(z; μ) in a
run-time parameter μ, their stability, and their bifurcations (what AUTO or MatCont do for
maps, on a walker's Poincaré section).

* Pseudo-arclength continuation: a converged point x = (z, μ) and the branch's unit tangent t
  (the null vector of [∂S^k/∂z − I, ∂S^k/∂μ]); predictor x + Δs t, corrector Newton on
  S^k(z; μ) − z = 0 with tᵀ(x − x_pred) = 0 (the last point's Jacobian, with Broyden's
  updates and a halving line search), converged when the residual is below the tolerance and the Newton step below 100
  times it (a residual alone accepts the creeping iterates of a nearly neutral map).
  Coordinates are scaled for the arclength: z_j by |z_j| at the start (at least a tenth of the
  median |z_j| and 1e-3), μ by the length of the range. Step-size control: Δs grows by 1.5 after an easy correction (≤ 4
  iterations), shrinks after a hard one (> 7), after a large change of the multipliers (0.15)
  or of the tangent (25°), and halves after a failure (Newton diverging or stalling, the walker
  falling), down to ``ds_min``. Unstable branches are followed like stable ones; a branch ends
  at the end of the range (landed on exactly: where the predictor or, near a fold, the
  corrected point would leave the range), when it turns back out of the range, at
  ``max_points``, or where it cannot be followed.
* Test functions on the multipliers λ_i of the period-k map: ∏(1 + λ_i) (a flip, period
  doubling: a real multiplier through −1), ∏(λ_i − 1) (a real multiplier through +1: a fold,
  where the tangent's μ component changes sign too, or else a branch point),
  ∏_{i<j}(λ_i λ_j − 1) (a Neimark–Sacker point: a complex pair through the unit circle; a real
  pair with λ_i λ_j = 1, a neutral saddle, is not reported). A sign change between two points
  is located by Brent's method on the arclength between them (each evaluation a corrected
  point and its Jacobian) to ``locate_tol`` in the scaled arclength (1e-10: below 1e-10 of the
  range in μ), and its Jacobian recomputed with the full finite-difference ladder (when
  ``locate_tol`` < 1e-6; a coarse location, enough to switch branches, skips it); each
  bifurcation reports the error of its parameter implied by its critical multiplier's error
  bound and distance from ±1 (over the multiplier's rate of change).
* Branch switching at a flip: the period-2k orbit bifurcates from the flip point along the
  eigenvector v of λ = −1 (a pitchfork of S^2k); it is found on the hyperplane vᵀ(z − z_flip) = a
  (a small amplitude, halved until the point found is a true period-2k orbit) and continued from
  there, away from the flip; and so on, ``doublings`` times (period 1 → 2 → 4: a cascade).
  A period-doubled branch ends where its orbit's two halves meet again, or swap between two
  points (a step through the parent): it has rejoined its parent branch, at the parent's flip
  nearest to its last point (a closed bubble between two flips). An orbit found at a flip that lies on a branch followed already (up to a cyclic
  shift of its points: on that branch's polyline, closed by the flip where it rejoined, and
  confirmed by a corrector run from there) is that branch: the flip "joins" it, and the
  branch is neither followed nor listed again.

:func:`continue_gait` is the Python API (``walker continue`` is its command);
:class:`ParameterPath` is the line in parameter space that μ moves along: one parameter, or a
homotopy from the walker's values to others (what ``walker gait`` uses to reach a gait from the
model file's nominal one). The Jacobian comes from :func:`~.monodromy.stride_jacobian`
(``jacobian="variational"``, exact, by default; ``"fd"``, finite differences, as a
cross-check).
"""
from __future__ import annotations

import difflib
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path

import numpy as np

from porthamiltonian.errors import ModelError, ParameterValueError

from ..core.protocol import Stride, StrideStatus, Walker
from .monodromy import (
    JACOBIAN_METHODS,
    Multipliers,
    StrideJacobian,
    multipliers,
    stride_jacobian,
)
from .poincare import WalkerFell, find_fixed_point
from .results import JSONResult, to_jsonable, view

__all__ = ["Bifurcation", "Branch", "BranchPoint", "ContinuationResult", "ParameterPath",
           "check_parameter", "continue_gait", "parse_range"]


# --- the parameter ---------------------------------------------------------------------------------
def check_parameter(walker: Walker, name: str) -> None:
    """Raise a :class:`~porthamiltonian.errors.ModelError` unless ``name`` is a parameter the
    stride map can be continued in: a parameter of the walker, bound at run time, continuous
    (not a whole number such as a count of spokes), and not a mode of the hybrid description
    (set by its rules) — named, with what to do."""
    if name in walker.mode_names:
        raise ModelError(f"{walker.name}: {name!r} is a mode of the walker's hybrid description "
                         "(its rules set it during a walk), not a parameter to continue in")
    if name not in walker.parameters:
        close = difflib.get_close_matches(name, list(walker.parameters), n=1, cutoff=0.6)
        hint = f" (did you mean {close[0]}?)" if close else ""
        raise ModelError(f"{walker.name}: no parameter {name!r} to continue in{hint}; its "
                         f"parameters: {', '.join(walker.parameters)}")
    spec = walker.specs.get(name)
    if spec is not None and spec.integer:
        raise ModelError(f"{walker.name}: parameter {name!r} is structural (a whole number: it "
                         "changes the walker's make-up, not a value bound at run time); "
                         "continuation needs a continuous parameter")
    if name not in walker.run_time_parameters:
        raise ModelError(f"{walker.name}: parameter {name!r} is structural (not bound at run "
                         "time: the compiled model does not take it); continuation needs a "
                         "run-time parameter")


def parse_range(text: str) -> tuple[str, float, float]:
    """``"slope=0.002:0.02"`` -> ("slope", 0.002, 0.02) (the ``--param`` option)."""
    name, sep, rng = text.partition("=")
    lo, sep2, hi = rng.partition(":")
    if not sep or not sep2 or not name.strip():
        raise ModelError(f"--param takes NAME=START:STOP (e.g. slope=0.002:0.02), got {text!r}")
    try:
        start, stop = float(lo), float(hi)
    except ValueError:
        raise ModelError(f"--param {name.strip()}: {rng!r} is not START:STOP with two "
                         "numbers") from None
    if not (math.isfinite(start) and math.isfinite(stop)) or start == stop:
        raise ModelError(f"--param {name.strip()}: the range {rng!r} must be two different "
                         "finite numbers")
    return name.strip(), start, stop


@dataclass(frozen=True)
class ParameterPath:
    """The parameters along the continuation parameter μ: one parameter (μ is its value), or a
    homotopy (μ from 0 to 1 moves every named parameter from ``a`` to ``b``: geometrically,
    a (b/a)^μ, where both ends are positive — a stiffness, a mass —, else linearly).

    label : the name plotted and reported ("slope", or "homotopy"). unit : μ's unit.
    start, stop : μ's range. names, a, b : the parameters moved (a homotopy's ends).
    """

    label: str
    unit: str
    start: float
    stop: float
    names: tuple[str, ...]
    a: tuple[float, ...] = ()
    b: tuple[float, ...] = ()

    @classmethod
    def single(cls, walker: Walker, name: str, start: float, stop: float) -> ParameterPath:
        """μ = the value of parameter ``name``, from ``start`` to ``stop`` (checked:
        :func:`check_parameter`, and both ends in the parameter's range)."""
        check_parameter(walker, name)
        for value in (start, stop):
            walker.with_parameters(**{name: value})          # out of range raises, naming it
        spec = walker.specs.get(name)
        return cls(name, spec.unit if spec is not None else "", float(start), float(stop),
                   (name,))

    @classmethod
    def homotopy(cls, walker: Walker, frm: Mapping[str, float],
                 to: Mapping[str, float]) -> ParameterPath:
        """μ from 0 (parameters ``frm``) to 1 (parameters ``to``), each changed parameter moving
        linearly."""
        names = tuple(k for k in to if frm[k] != to[k])
        for k in names:
            check_parameter(walker, k)
        return cls("homotopy", "1", 0.0, 1.0, names, tuple(float(frm[k]) for k in names),
                   tuple(float(to[k]) for k in names))

    def values(self, mu: float) -> dict[str, float]:
        """The parameter values at μ."""
        if not self.a:
            return {self.names[0]: float(mu)}
        if mu == 1.0:
            return dict(zip(self.names, self.b))
        return {k: a * (b / a) ** mu if a > 0 and b > 0 else a + mu * (b - a)
                for k, a, b in zip(self.names, self.a, self.b)}


# --- results -----------------------------------------------------------------------------------------
@dataclass
class BranchPoint(Multipliers):
    """A point of a branch: μ, the parameter values, the period-k orbit's section states (model
    coordinates; ``orbit[0]`` is the fixed point continued), the Floquet multipliers of S^k
    (largest modulus first) and their error bounds, stability, and per step of the orbit its
    duration (s) and length (m)."""

    mu: float
    values: dict
    orbit: list[np.ndarray]
    multipliers: np.ndarray
    errors: np.ndarray
    durations: list[float]
    lengths: list[float]
    tangent_mu: float

    @property
    def z(self) -> np.ndarray:
        return self.orbit[0]

    def to_dict(self, walker: Walker) -> dict:
        named = [walker.section_state(z) for z in self.orbit]
        T, L = sum(self.durations), sum(self.lengths)
        return to_jsonable({
            "mu": self.mu, "parameters": self.values, "period_steps": len(self.orbit),
            "fixed_point": named[0], "orbit": named,
            "floquet_multipliers": [complex(m) for m in self.multipliers],
            "multiplier_errors": self.errors.tolist(), "max_multiplier": self.max_modulus,
            "stable": self.stable, "step_periods": self.durations, "step_lengths": self.lengths,
            "speed": L / T if T > 0 else None})


@dataclass
class Bifurcation:
    """A located bifurcation: ``kind`` "flip", "fold", "branch_point" or "neimark_sacker";
    on branch ``branch`` (of period ``period``) at μ = ``mu`` (± ``mu_error``, from the critical
    multiplier's error), the fixed point there, the critical multiplier, and ``child``: the
    index of the period-doubled branch switched onto (flips); ``joins`` when that branch had
    been followed already (from another flip: the two flips are the ends of one branch, e.g. a
    closed period-2 bubble) and was not followed again."""

    kind: str
    branch: int
    period: int
    mu: float
    mu_error: float
    values: dict
    point: BranchPoint
    multiplier: complex
    child: int | None = None
    joins: bool = False

    def to_dict(self, walker: Walker) -> dict:
        return to_jsonable({"kind": self.kind, "branch": self.branch, "period_steps": self.period,
                            "mu": self.mu, "mu_error": self.mu_error, "parameters": self.values,
                            "multiplier": complex(self.multiplier),
                            "fixed_point": walker.section_state(self.point.z),
                            "floquet_multipliers": [complex(m) for m in self.point.multipliers],
                            "child_branch": self.child, "joins_known_branch": self.joins})


@dataclass
class Branch:
    """A followed branch of period-``period`` orbits: its points in order, where it came from
    (``origin``: "start" or "flip of branch i at μ = …"; ``parent``: that branch i) and why it
    ended (``end``; ``rejoined``: the parent's flip where the branch ended on the parent again)."""

    period: int
    points: list[BranchPoint] = field(default_factory=list)
    origin: str = "start"
    end: str = ""
    parent: int | None = None
    rejoined: Bifurcation | None = None


@dataclass
class ContinuationResult(JSONResult):
    """Result of :func:`continue_gait`: the branches, the bifurcations (in the order found), the
    parameter path, and the time it took."""

    model: str
    path: ParameterPath
    branches: list[Branch]
    bifurcations: list[Bifurcation]
    section: list[str]
    jacobian: str
    seconds: float
    walker: Walker = field(repr=False)
    #: why the continuation stopped before following everything ("" when it did not): its
    #: time limit
    stopped: str = ""

    @property
    def message(self) -> str:
        kinds = ", ".join(f"{b.kind} at {self.path.label} = {b.mu:.10g} (period {b.period})"
                          for b in self.bifurcations) or "none"
        return (f"{len(self.branches)} branch(es), {sum(len(b.points) for b in self.branches)} "
                f"points; bifurcations: {kinds}" + (f"; {self.stopped}" if self.stopped else ""))

    def table(self) -> list[dict]:
        """One row per point: branch, period, μ, the fixed point by name, max |λ|, stability."""
        rows = []
        for i, br in enumerate(self.branches):
            for p in br.points:
                rows.append({"branch": i, "period_steps": br.period, self.path.label: p.mu,
                             **{k: float(v) for k, v in zip(self.walker.section, p.z)},
                             "max_multiplier": p.max_modulus, "stable": p.stable,
                             "step_period": float(np.mean(p.durations))})
        return rows

    def to_dict(self) -> dict:
        w = self.walker
        return to_jsonable({
            "model": self.model, "parameter": self.path.label, "unit": self.path.unit,
            "range": [self.path.start, self.path.stop],
            "path": {"names": self.path.names, "from": self.path.a, "to": self.path.b},
            "section": self.section, "jacobian": self.jacobian,
            "branches": [{"period_steps": b.period, "origin": b.origin, "end": b.end,
                          "points": [p.to_dict(w) for p in b.points]} for b in self.branches],
            "bifurcations": [b.to_dict(w) for b in self.bifurcations],
            "seconds": self.seconds, "stopped": self.stopped, "message": self.message})

    def figure(self, path: str | Path) -> bytes:
        """The bifurcation diagram as a PNG at ``path`` (the report's view,
        :func:`walker_library.report.figures.fig_bifurcation`)."""
        return view(self, "figure")(self, Path(path))


# --- the map in scaled coordinates -------------------------------------------------------------------
class _Map:
    """S^k(z; μ) − z in scaled coordinates x = (z / s, (μ − start) / (stop − start))."""

    def __init__(self, walker: Walker, path: ParameterPath, period: int, scale: np.ndarray,
                 method: str):
        self.base, self.path, self.k, self.s, self.method = walker, path, period, scale, method
        self.width = path.stop - path.start
        self._w: tuple[float, Walker] | None = None
        self.strides = 0

    def mu(self, x: np.ndarray) -> float:
        return self.path.start + float(x[-1]) * self.width

    def x(self, z: np.ndarray, mu: float) -> np.ndarray:
        return np.append(np.asarray(z) / self.s, (mu - self.path.start) / self.width)

    def walker(self, mu: float) -> Walker:
        """The walker at μ (ParameterValueError outside the parameter's range)."""
        if self._w is None or self._w[0] != mu:
            self._w = (mu, self.base.with_parameters(**self.path.values(mu)))
        return self._w[1]

    def walk(self, x: np.ndarray) -> tuple[np.ndarray, list[Stride]]:
        """(scaled residual, strides); WalkerFell if a stride falls."""
        z = x[:-1] * self.s
        strides = self.walker(self.mu(x)).walk(z, self.k)
        self.strides += len(strides)
        if len(strides) < self.k or strides[-1].fell:
            raise WalkerFell(z, strides[-1])
        return (strides[-1].z_next - z) / self.s, strides

    def jacobian(self, x: np.ndarray,
                 near: StrideJacobian | None) -> tuple[np.ndarray, StrideJacobian]:
        """The scaled [∂S/∂z − I, ∂S/∂μ] (n × (n+1)) and the stride Jacobian at x (``near``: the
        stride Jacobian of a nearby point, whose steps and error are taken: one central
        difference per coordinate; None: the full finite-difference ladder)."""
        mu, z = self.mu(x), x[:-1] * self.s
        w = self.walker(mu)
        sj = stride_jacobian(w, z, period=self.k, method=self.method,
                             steps=None if near is None else near.steps,
                             error=None if near is None else near.error)
        self.strides += sj.strides
        h = 1e-4 * abs(self.width)
        ends = []
        for m in (mu + h, mu - h):
            try:
                w = self.walker(m)
            except ParameterValueError:         # the parameter's range ends here: one-sided
                m, w = mu, self.walker(mu)
            strides = w.walk(z, self.k)
            self.strides += len(strides)
            z_next = strides[-1].z_next if len(strides) == self.k else None
            if z_next is None or strides[-1].fell:
                raise WalkerFell(z, strides[-1])
            ends.append((m, z_next))
        (m1, s1), (m2, s2) = ends
        self._w = None
        dS = (s1 - s2) / (m1 - m2) * self.width
        n = len(z)
        A = np.empty((n, n + 1))
        A[:, :n] = (sj.matrix - np.eye(n)) * self.s[None, :] / self.s[:, None]
        A[:, n] = dS / self.s
        return A, sj


def _change(a: np.ndarray, b: np.ndarray) -> float:
    """The largest change between two sets of multipliers, paired (Hungarian method), relative
    to max(1, |λ|)."""
    if not len(a):
        return 0.0
    cost = np.abs(a[:, None] - b[None, :]) / np.maximum(1.0, np.abs(a))[:, None]
    from scipy.optimize import linear_sum_assignment  # here: scipy.optimize takes ~0.2 s

    rows, cols = linear_sum_assignment(cost)
    return float(np.max(cost[rows, cols]))


def _tangent(A: np.ndarray, previous: np.ndarray | None) -> np.ndarray:
    t = np.linalg.svd(A)[2][-1]
    if previous is not None and float(t @ previous) < 0:
        t = -t
    return t


@dataclass
class _State:
    """A converged point with what the next step needs."""

    x: np.ndarray
    t: np.ndarray
    A: np.ndarray
    sj: StrideJacobian
    point: BranchPoint
    tests: dict


def _tests(lam: np.ndarray, t_mu: float) -> dict:
    n = len(lam)
    pairs = [lam[i] * lam[j] - 1.0 for i in range(n) for j in range(i + 1, n)]
    return {"flip": float(np.real(np.prod(1.0 + lam))),
            "plus_one": float(np.real(np.prod(lam - 1.0))),
            "neimark_sacker": float(np.real(np.prod(pairs))) if pairs else 1.0,
            "t_mu": float(t_mu)}


class _Continuer:
    """Follows branches (see the module docstring); one per :func:`continue_gait` call."""

    def __init__(self, walker: Walker, path: ParameterPath, *, method: str, ds: float,
                 ds_min: float, ds_max: float, max_points: int, tol: float, locate_tol: float,
                 doublings: int, max_branches: int, locate: bool,
                 log: Callable[[str], None] | None, deadline: float = math.inf,
                 time_limit: float | None = None):
        self.walker, self.path, self.method = walker, path, method
        self.ds0, self.ds_min, self.ds_max = ds, ds_min, ds_max
        self.max_points, self.tol, self.locate_tol = max_points, tol, locate_tol
        self.doublings, self.max_branches, self.locate = doublings, max_branches, locate
        self.log = log or (lambda msg: None)
        self.deadline, self.time_limit = deadline, time_limit
        self.stopped = ""
        self.refresh = 10          # the full finite-difference ladder every 10 points
        self.branches: list[Branch] = []
        self.bifurcations: list[Bifurcation] = []
        self.maps: list[_Map] = []

    # -- points ------------------------------------------------------------------------------------
    def _state(self, m: _Map, x: np.ndarray, strides: list[Stride], t_prev: np.ndarray | None,
               near: StrideJacobian | None) -> _State:
        A, sj = m.jacobian(x, near)
        t = _tangent(A, t_prev)
        lam, err = multipliers(sj)
        z = x[:-1] * m.s
        mu = m.mu(x)
        orbit = [z] + [s.z_next for s in strides[:-1]]
        point = BranchPoint(mu, m.path.values(mu), orbit, lam, err,
                            [float(s.duration) for s in strides],
                            [float(s.step_length) for s in strides], float(t[-1]))
        return _State(x, t, A, sj, point, _tests(lam, t[-1]))

    def _refine(self, m: _Map, st: _State) -> _State:
        """``st`` with its Jacobian from the full finite-difference ladder (fresh steps and
        error estimates)."""
        A, sj = m.jacobian(st.x, None)
        lam, err = multipliers(sj)
        st.A, st.sj = A, sj
        st.point.multipliers, st.point.errors = lam, err
        return st

    def _correct(self, m: _Map, xp: np.ndarray, row: np.ndarray, A: np.ndarray,
                 target: float = 0.0,
                 max_iter: int = 10) -> tuple[np.ndarray, list[Stride], int] | None:
        """Newton on [F(x); row·x − target] from xp with the Jacobian A of a nearby point,
        improved by Broyden's rank-one updates after each iteration (a finite-difference
        Jacobian is good to its error estimate only; the updates make the convergence
        superlinear again), each step halved up to three times until it lowers the residual (a
        line search: the stride map has kinks where a walk's sequence of events changes):
        (x, strides, iterations), or None when it stalls (the residual not halved in three
        iterations), falls or leaves the parameter's range."""
        B = np.vstack([A, row])
        x = xp.copy()
        history: list[float] = []
        try:
            F, strides = m.walk(x)
        except (WalkerFell, ParameterValueError):
            return None
        G = np.append(F, float(row @ x - target))
        for it in range(max_iter):
            try:
                dx = np.linalg.solve(B, G)
            except np.linalg.LinAlgError:
                return None
            r = float(np.max(np.abs(F * m.s)))
            # converged: a small residual and a small Newton step (both in the section's units)
            # — a residual alone would accept the creeping iterate of a nearly neutral map
            if r < self.tol and abs(G[-1]) < 1e-12 and \
                    float(np.max(np.abs(dx[:-1] * m.s))) < 100 * self.tol:
                return x, strides, it
            if len(history) >= 3 and r > 0.5 * history[-3] and r > 1e3 * self.tol:
                return None
            history.append(r)
            step = 1.0
            for _ in range(4):
                x_new = x - step * dx
                try:
                    F_new, strides_new = m.walk(x_new)
                except (WalkerFell, ParameterValueError):
                    step /= 2
                    continue
                if float(np.max(np.abs(F_new * m.s))) < max(r, self.tol):
                    break
                step /= 2
            else:
                return None
            G_new = np.append(F_new, float(row @ x_new - target))
            ds_ = x_new - x                     # Broyden's update of the F rows
            B[:-1] += np.outer((G_new - G)[:-1] - B[:-1] @ ds_, ds_) / float(ds_ @ ds_)
            x, F, G, strides = x_new, F_new, G_new, strides_new
        return None

    # -- a branch ----------------------------------------------------------------------------------
    def follow(self, m: _Map, first: _State, branch: Branch, index: int) -> None:
        """Continue ``branch`` from ``first``: the first step along the tangent ``first.t``, the
        next along the secant through the last two points (smooth, where a tangent from a
        finite-difference Jacobian carries its noise; the tangent's μ component still tells a
        fold)."""
        cur, ds = first, self.ds0
        direction = first.t
        branch.points.append(first.point)
        fails = 0
        # a period-doubled branch ends where its orbit's two halves meet again (it rejoins the
        # parent branch at another flip: a closed bubble, which would otherwise be gone round
        # until max_points)
        half = branch.period // 2 if branch.origin.startswith("flip") else 0
        gap0 = _half_gap(first.point, half, m.s) if half else 0.0
        peak = gap0
        while True:
            if len(branch.points) >= self.max_points:
                branch.end = f"{self.max_points} points (max_points)"
                return
            if self._out_of_time(cur.point.mu):
                branch.end = self.stopped
                return
            xp = cur.x + ds * direction
            landing = next((b for b in (0.0, 1.0)
                            if (xp[-1] - b) * (cur.x[-1] - b) < 0 or xp[-1] == b), None)
            if landing is not None and abs(direction[-1]) > 1e-12:
                res = self._land(m, cur, direction, landing)
            else:
                landing = None
                res = self._correct(m, xp, direction, cur.A, float(direction @ xp))
                if res is not None and not 0.0 <= res[0][-1] <= 1.0:
                    # the corrector left the range (near a fold, where the tangent is nearly
                    # normal to μ): land on the end crossed, from the chord to the point found
                    landing = 0.0 if res[0][-1] < 0.0 else 1.0
                    res = self._land(m, cur, res[0] - cur.x, landing)
            if res is None:
                ds /= 2
                fails += 1
                if ds < self.ds_min:
                    branch.end = (f"could not be followed beyond {self.path.label} = "
                                  f"{cur.point.mu:.10g} (steps down to {self.ds_min:g} failed: "
                                  "Newton diverged or the walker fell)")
                    return
                continue
            x_new, strides, iterations = res
            try:
                new = self._state(m, x_new, strides, cur.t,
                                  None if len(branch.points) % self.refresh == 0 else cur.sj)
            except (WalkerFell, ParameterValueError):
                ds /= 2
                if ds < self.ds_min:
                    branch.end = f"a Jacobian fell near {self.path.label} = {cur.point.mu:.10g}"
                    return
                continue
            if half and float(_halves(new.point, half, m.s) @ _halves(cur.point, half, m.s)) < 0:
                # the step went through the parent branch (the halves swapped: the same orbits,
                # each shifted by half its period, lie beyond)
                self._end_rejoined(m, branch, index, cur.point, "the next step went through "
                                   "it: the orbit's halves swapped")
                return
            if self.locate:
                self._detect(m, cur, new, branch, index)
            branch.points.append(new.point)
            self.log(f"  branch {index} (period {branch.period}): {self.path.label} = "
                     f"{new.point.mu:.8g}, max |λ| = {new.point.max_modulus:.6f}"
                     f"{'' if new.point.stable else ' (unstable)'}")
            if landing is not None:
                branch.end = f"reached {self.path.label} = {new.point.mu:.10g} (end of the range)"
                return
            if half:
                gap = _half_gap(new.point, half, m.s)
                peak = max(peak, gap)
                if peak > 2.0 * gap0 and gap < 0.5 * gap0:
                    self._end_rejoined(m, branch, index, new.point, "its halves meet")
                    return
            # step size: the corrector's effort, the change of the multipliers and of direction
            secant = (new.x - cur.x) / np.linalg.norm(new.x - cur.x)
            change = _change(cur.point.multipliers, new.point.multipliers)
            turn = float(secant @ direction)
            factor = 1.5 if iterations <= 4 and fails == 0 else 1.0 if iterations <= 7 else 0.7
            if change > 0.15 or turn < 0.9:
                factor = 0.5
            ds = min(self.ds_max, max(self.ds_min, ds * factor))
            fails = 0
            direction = secant
            cur = new

    def _land(self, m: _Map, cur: _State, d: np.ndarray,
              bound: float) -> tuple[np.ndarray, list[Stride], int] | None:
        """The corrected point at the end ``bound`` of the range (scaled μ: 0 or 1), from where
        the line cur.x + τ d crosses it (:meth:`_correct`'s result)."""
        e = np.zeros(len(cur.x))
        e[-1] = 1.0
        return self._correct(m, cur.x + (bound - cur.x[-1]) / d[-1] * d, e, cur.A, bound)

    def _end_rejoined(self, m: _Map, branch: Branch, index: int, last: BranchPoint,
                      why: str) -> None:
        """End the period-doubled branch ``index`` where it has rejoined its parent: at the
        parent's located flip nearest (scaled section state and μ) to its ``last`` point, other
        than the flip it was born at (:attr:`Branch.rejoined`)."""
        flips = [b for b in self.bifurcations if b.kind == "flip" and b.branch == branch.parent
                 and b.child != index]
        x = m.x(last.z, last.mu)
        branch.rejoined = min(flips, default=None,
                              key=lambda b: float(np.linalg.norm(m.x(b.point.z, b.mu) - x)))
        at = ("" if branch.rejoined is None else
              f" at its flip at {self.path.label} = {branch.rejoined.mu:.10g}")
        branch.end = (f"rejoined the period-{branch.period // 2} branch {branch.parent}{at} "
                      f"({why}; last point at {self.path.label} = {last.mu:.10g})")

    def _known(self, m: _Map, st: _State) -> int | None:
        """The index of an already-followed branch of period ``m.k`` through the orbit of
        ``st`` (up to a cyclic shift of its points), or None.

        The branch's polyline (its points, closed by the flip where it rejoined its parent, a
        period-k orbit gone round twice) is searched for the segment nearest to the scaled
        (orbit[s], μ) of each shift s; within a quarter of that segment's length (the chord
        of a curved branch strays from it by less), a corrector run from the nearest point of
        the segment onto the hyperplane through the orbit, normal to the segment, must land on
        the orbit itself (to 1e-6 of each coordinate's scale): a point on the known branch."""
        p = st.point
        for i, br in enumerate(self.branches):
            if br.period != m.k or not br.points:
                continue
            ends = [(q.z, q.mu) for q in br.points]
            if br.rejoined is not None:
                ends.append((br.rejoined.point.z, br.rejoined.mu))
            V = np.array([m.x(z, mu) for z, mu in ends])
            for s in range(m.k):
                xs = m.x(p.orbit[s], p.mu)
                best = None
                for a, b in pairwise(V):
                    d = b - a
                    length = float(np.linalg.norm(d))
                    if length == 0.0:
                        continue
                    near = a + min(1.0, max(0.0, float((xs - a) @ d) / length**2)) * d
                    dist = float(np.linalg.norm(xs - near))
                    if dist <= 0.25 * length and (best is None or dist < best[0]):
                        best = (dist, near, d / length)
                if best is None:
                    continue
                _, near, row = best
                try:
                    A, _ = m.jacobian(near, st.sj)
                except (WalkerFell, ParameterValueError):
                    continue
                res = self._correct(m, near, row, A, float(row @ xs), max_iter=30)
                if res is not None and float(np.max(np.abs(res[0] - xs))) < 1e-6:
                    return i
        return None

    # -- bifurcations --------------------------------------------------------------------------------
    def _detect(self, m: _Map, a: _State, b: _State, branch: Branch, index: int) -> None:
        for kind in ("flip", "plus_one", "neimark_sacker"):
            # a sign change; a test exactly 0 at a point (a point on the bifurcation) counts
            # between it and the point before
            if a.tests[kind] * b.tests[kind] > 0 or a.tests[kind] == 0.0:
                continue
            hit = self._locate(m, a, b, kind)
            if hit is None:
                continue
            state, mu_err = hit
            lam = state.point.multipliers
            if kind == "flip":
                crit = min((c for c in lam if abs(c.imag) < 1e-9 * max(1, abs(c))),
                           key=lambda c: abs(c + 1), default=lam[np.argmin(np.abs(lam + 1))])
                name = "flip"
            elif kind == "plus_one":
                crit = lam[np.argmin(np.abs(lam - 1))]
                name = "fold" if a.tests["t_mu"] * b.tests["t_mu"] < 0 else "branch_point"
            else:
                cplx = [c for c in lam if abs(c.imag) > 1e-6]
                if not cplx:
                    continue          # a neutral saddle (λ_i λ_j = 1 for a real pair)
                crit = min(cplx, key=lambda c: abs(abs(c) - 1))
                if abs(abs(crit) - 1) > 1e-3:
                    continue
                name = "neimark_sacker"
            bif = Bifurcation(name, index, branch.period, state.point.mu, mu_err,
                              state.point.values, state.point, complex(crit))
            self.bifurcations.append(bif)
            self.log(f"  {name} on branch {index} at {self.path.label} = {bif.mu:.12g} "
                     f"(± {mu_err:.1g}), multiplier {complex(crit):.6f}")
            if (name == "flip" and self.doublings > 0 and
                    branch.period < 2 ** self.doublings * self.branches[0].period and
                    len(self.branches) < self.max_branches):
                self._pending.append((bif, state, m))

    def _locate(self, m: _Map, a: _State, b: _State, kind: str) -> tuple[_State, float] | None:
        """The sign change of test ``kind`` between a and b, located on the arclength from a
        (corrected points on hyperplanes normal to a's tangent). (state, μ error) or None."""
        d_total = float(a.t @ (b.x - a.x))
        cache: dict[float, _State] = {0.0: a, d_total: b}

        def state(s: float) -> _State:
            if s not in cache:
                xp = a.x + s * a.t
                res = self._correct(m, xp, a.t, a.A, float(a.t @ xp), max_iter=30)
                if res is None:
                    raise WalkerFell(xp[:-1] * m.s, Stride(StrideStatus.FELL, None, 0.0, reason="locate"))
                cache[s] = self._state(m, res[0], res[1], a.t, a.sj)
            return cache[s]

        from scipy.optimize import brentq

        try:
            s = brentq(lambda s: state(s).tests[kind], 0.0, d_total, xtol=self.locate_tol,
                       rtol=4 * np.finfo(float).eps, maxiter=100)
            st = state(s)
            if self.locate_tol < 1e-6:       # a precise location: the full ladder there
                st = self._refine(m, st)
        except (WalkerFell, ParameterValueError, ValueError, RuntimeError):
            return None
        # the parameter's error: the critical multiplier's error over its rate of change
        target = {"flip": -1.0, "plus_one": 1.0}.get(kind)

        def crit(p: BranchPoint) -> tuple[float, float]:
            lam = p.multipliers
            if target is None:
                i = int(np.argmin(np.abs(np.abs(lam) - 1)))
                return float(abs(lam[i])), float(p.errors[i])
            i = int(np.argmin(np.abs(lam - target)))
            return float(lam[i].real), float(p.errors[i])

        (ca, _), (cb, _) = crit(a.point), crit(b.point)
        c, err = crit(st.point)
        rate = abs(cb - ca) / max(abs(b.point.mu - a.point.mu), 1e-300)
        # the bound of the critical multiplier, and how far the refined one is from its target
        miss = abs(c - (1.0 if target is None else target))
        mu_err = (err + miss) / rate if rate > 0 else math.inf
        return st, mu_err

    # -- period doubling ---------------------------------------------------------------------------
    def switch(self, bif: Bifurcation, at: _State, m: _Map) -> None:
        """Onto the period-2k branch born at the flip ``bif`` (module docstring)."""
        lam, X = np.linalg.eig(at.sj.matrix)
        i = int(np.argmin(np.abs(lam + 1)))
        v = np.real(X[:, i]) / m.s
        v /= np.linalg.norm(v)
        m2 = _Map(m.base, m.path, 2 * m.k, m.s, m.method)
        row = np.append(v, 0.0)
        amp = 0.02
        index = len(self.branches)
        branch = Branch(2 * m.k, origin=f"flip of branch {bif.branch} at {self.path.label} = "
                                        f"{bif.mu:.10g}", parent=bif.branch)
        for _ in range(8):
            xp = at.x + amp * row
            try:
                A, _ = m2.jacobian(xp, at.sj)
            except (WalkerFell, ParameterValueError):
                amp /= 2
                continue
            res = self._correct(m2, xp, row, A, float(row @ xp), max_iter=30)
            if res is not None:
                x1, strides, _ = res
                z1 = x1[:-1] * m.s
                gap = float(np.max(np.abs(strides[m.k - 1].z_next - z1) / m.s))
                if gap > 1e-3 * amp:       # a true period-2k orbit, not the period-k one
                    try:
                        first = self._state(m2, x1, strides, None, at.sj)
                    except (WalkerFell, ParameterValueError):
                        amp /= 2
                        continue
                    known = self._known(m2, first)
                    if known is not None:       # e.g. the other end of a closed bubble
                        bif.child, bif.joins = known, True
                        self.log(f"  the period-{2 * m.k} orbit at the flip at "
                                 f"{self.path.label} = {bif.mu:.10g} is on branch {known} "
                                 "(followed already): joins it")
                        return
                    if float(first.t @ (x1 - at.x)) < 0:
                        first.t = -first.t
                    first.point.tangent_mu = float(first.t[-1])
                    bif.child = index
                    self.branches.append(branch)
                    self.log(f"branch {index}: period {2 * m.k} from the flip at "
                             f"{self.path.label} = {bif.mu:.10g}")
                    self.follow(m2, first, branch, index)
                    return
            amp /= 2
        branch.end = "no period-doubled orbit found near the flip"
        bif.child = None
        self.log(f"  no period-{2 * m.k} orbit found near the flip at {bif.mu:.10g}")

    def run(self, z0: np.ndarray, period: int) -> None:
        # a coordinate's scale: its size at the start, but not below a tenth of the median
        # size (a small coordinate's changes would otherwise rule the arclength)
        scale = np.maximum(np.abs(z0), max(1e-3, 0.1 * float(np.median(np.abs(z0)))))
        m = _Map(self.walker, self.path, period, scale, self.method)
        x0 = m.x(z0, self.path.start)
        _, strides = m.walk(x0)
        st = self._state(m, x0, strides, None, None)
        direction = np.zeros(len(x0))
        direction[-1] = 1.0
        if float(st.t @ direction) < 0:
            st.t = -st.t
        self.branches.append(Branch(period))
        self._pending: list[tuple[Bifurcation, _State, _Map]] = []
        self.follow(m, st, self.branches[0], 0)
        while self._pending and not self.stopped:
            bif, state, mm = self._pending.pop(0)
            self.switch(bif, state, mm)

    def _out_of_time(self, mu: float) -> bool:
        """True (and :attr:`stopped` set, once) when the time limit has passed."""
        if not self.stopped and time.perf_counter() > self.deadline:
            self.stopped = (f"stopped at the time limit ({self.time_limit:.3g} s) at "
                            f"{self.path.label} = {mu:.10g}; a larger time limit follows it "
                            "further")
            self.log(f"  {self.stopped}")
        return bool(self.stopped)


def _halves(point: BranchPoint, half: int, scale: np.ndarray) -> np.ndarray:
    """The difference of the two halves of a period-2k orbit (scaled section coordinates)."""
    return (point.orbit[half] - point.orbit[0]) / scale


def _half_gap(point: BranchPoint, half: int, scale: np.ndarray) -> float:
    """How far apart the two halves of a period-2k orbit are (scaled section coordinates)."""
    return float(np.max(np.abs(_halves(point, half, scale))))


def continue_gait(walker: Walker, parameter: str | ParameterPath, start: float | None = None,
                  stop: float | None = None, *, guess: np.ndarray | None = None, period: int = 1,
                  jacobian: str = "variational", ds: float = 0.05, ds_min: float = 1e-6,
                  ds_max: float = 0.3, max_points: int = 400, tol: float | None = None,
                  locate: bool = True, locate_tol: float = 1e-10, doublings: int = 2,
                  max_branches: int = 8, log: Callable[[str], None] | None = None,
                  time_limit: float | None = None) -> ContinuationResult:
    """Continue the walker's gait in ``parameter`` from ``start`` to ``stop`` (module docstring).

    parameter : a parameter's name (then ``start``, ``stop`` its range, in its unit) or a
        :class:`ParameterPath`. guess : a section state (model coordinates) near a fixed point
        of S^period at the start (refined by Newton; default: the walker's own guess);
        :func:`~.gait.gait_start` finds one by the full gait search. jacobian : "variational" or "fd"
        (:func:`~.monodromy.stride_jacobian`). ds, ds_min, ds_max : arclength steps in scaled
        units (the range of μ is 1). tol : Newton tolerance (default: the walker's
        ``gait_tolerance``). locate : detect and locate bifurcations (to ``locate_tol`` of
        arclength). doublings : period doublings to follow (2: period 1 → 2 → 4).
        time_limit : seconds after which no new point is started (None: no limit); the result
        then says where it stopped (``stopped``, and each branch's ``end``). log : progress
        lines (one per point, bifurcation, branch).

    Bad input — an unknown, structural or mode parameter, a range out of the parameter's range,
    an unknown Jacobian method — raises :class:`~porthamiltonian.errors.ModelError` before any
    stride is taken; no fixed point at the start of the range raises one too, with Newton's
    verdict.
    """
    t0 = time.perf_counter()
    if time_limit is not None and not (math.isfinite(time_limit) and time_limit > 0):
        raise ModelError(f"time_limit must be a number of seconds > 0, got {time_limit!r}")
    if jacobian not in JACOBIAN_METHODS:
        raise ModelError(f"jacobian must be one of {', '.join(JACOBIAN_METHODS)}, got "
                         f"{jacobian!r}")
    if isinstance(parameter, ParameterPath):
        path = parameter
    else:
        if start is None or stop is None:
            raise ModelError(f"continue_gait({parameter!r}): give start and stop")
        path = ParameterPath.single(walker, parameter, start, stop)
    tol = float(walker.gait_tolerance) if tol is None else float(tol)
    w0 = walker.with_parameters(**path.values(path.start))
    fp = find_fixed_point(w0, guess, period=period, tol=tol)
    if not fp.converged:
        at = ", ".join(f"{k} = {v:g}" for k, v in path.values(path.start).items())
        raise ModelError(f"{walker.name}: no period-{period} gait at the start of the range "
                         f"({at}) from {'the guess' if guess is not None else 'its own guess'} "
                         f"(Newton: {fp.message}); start the range where the walker has a gait, "
                         "or give its fixed point as the guess (walker gait --json finds one)")
    z0 = fp.z
    c = _Continuer(walker, path, method=jacobian, ds=ds, ds_min=ds_min, ds_max=ds_max,
                   max_points=max_points, tol=tol, locate_tol=locate_tol, doublings=doublings,
                   max_branches=max_branches, locate=locate, log=log, time_limit=time_limit,
                   deadline=math.inf if time_limit is None else t0 + time_limit)
    c.run(z0, period)
    return ContinuationResult(walker.name, path, c.branches, c.bifurcations, list(walker.section),
                              jacobian, time.perf_counter() - t0, walker, c.stopped)

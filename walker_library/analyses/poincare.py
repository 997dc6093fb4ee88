"""Stride map on the Poincaré section just after heel strike; fixed points, period detection
(Garcia et al. 1998; the thesis's §2.5-2.6). Generic over :class:`~.protocol.Walker`.

* :func:`stride_map` — S^k(z): k steps from section coordinates z (model's own, or the thesis's
  with ``coordinates="thesis"``); ``None`` when the walker falls.
* :func:`jacobian` — the Jacobian of S^k by finite differences of one fixed step (absolute, in
  the section coordinates' units; the thesis used 0.001, App. C), central or forward: what
  Newton's method uses. The Floquet multipliers use :mod:`.monodromy` (the step chosen per
  coordinate, with error bounds).
* :func:`find_fixed_point` — Newton on S^k(z) − z with the exact Jacobian (the strides'
  sensitivities, Broyden-updated between them) or a forward-difference one, and step halving,
  from a rough guess; returns the last iterate when it does not converge.
* :func:`detect_period` — iterate the map and find the smallest period k ≤ max_period.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from porthamiltonian.batch.progress import tick
from porthamiltonian.errors import ModelError, OptionError

from ..core.protocol import Stride, Walker

__all__ = [
    "NEWTON_JACOBIANS",
    "FixedPointResult",
    "IterationResult",
    "PeriodResult",
    "WalkerFell",
    "advance",
    "detect_period",
    "find_fixed_point",
    "iterate",
    "jacobian",
    "stride_map",
]


class WalkerFell(RuntimeError):
    """Raised inside the analyses when a stride needed for a derivative falls."""

    def __init__(self, z: np.ndarray, stride: Stride) -> None:
        super().__init__(f"the walker fell ({stride.reason}) from section state {np.asarray(z).tolist()}")
        self.z, self.stride = z, stride


def _walk(walker: Walker, z: np.ndarray, n_steps: int) -> list[Stride]:
    """``walker.walk``, counting the strides as progress (``porthamiltonian.batch.progress``)."""
    strides = walker.walk(z, n_steps)
    tick("stride", len(strides))
    return strides


def _to_model(walker: Walker, z: np.ndarray, coordinates: str) -> np.ndarray:
    z = np.asarray(z, dtype=float)
    if coordinates == "model":
        return z
    if coordinates == "thesis":
        return np.asarray(walker.from_thesis(z), dtype=float)
    raise OptionError(f"coordinates must be 'model' or 'thesis', got {coordinates!r}")


def _from_model(walker: Walker, z: np.ndarray, coordinates: str) -> np.ndarray:
    return np.asarray(z if coordinates == "model" else walker.to_thesis(z), dtype=float)


def stride_map(walker: Walker, z: np.ndarray, period: int = 1,
               coordinates: str = "model") -> np.ndarray | None:
    """S^period(z) on the section (``coordinates``: "model" or "thesis"); None if the walker falls."""
    strides = _walk(walker, _to_model(walker, z, coordinates), period)
    z_next = strides[-1].z_next if len(strides) == period else None
    if z_next is None or strides[-1].fell:
        return None
    return _from_model(walker, z_next, coordinates)


def advance(walker: Walker, z: np.ndarray, period: int) -> np.ndarray:
    """S^period(z) in model coordinates; raises :class:`WalkerFell` when the walker falls."""
    strides = _walk(walker, z, period)
    z_next = strides[-1].z_next if len(strides) == period else None
    if z_next is None or strides[-1].fell:
        raise WalkerFell(z, strides[-1])
    return z_next


@dataclass
class IterationResult:
    """Iterates z_0 … z_n of the stride map; ``fell_at_step`` is the 1-based index of the step
    during which the walker fell (None if it did not)."""

    states: list[np.ndarray]
    strides: list[Stride]
    fell_at_step: int | None = None
    fall_reason: str = ""


def iterate(walker: Walker, z0: np.ndarray, n_steps: int, chunk: int = 50) -> IterationResult:
    """Walk ``n_steps`` steps from ``z0`` (in chunks of one simulation each)."""
    states = [np.asarray(z0, dtype=float)]
    strides: list[Stride] = []
    while len(strides) < n_steps:
        batch = _walk(walker, states[-1], min(chunk, n_steps - len(strides)))
        for s in batch:
            strides.append(s)
            if s.fell or s.z_next is None:
                return IterationResult(states, strides, len(strides), s.reason)
            states.append(s.z_next)
    return IterationResult(states, strides)


def jacobian(walker: Walker, z: np.ndarray, *, period: int = 1, step: float = 1e-3,
             scheme: str = "central", coordinates: str = "model",
             base: np.ndarray | None = None) -> np.ndarray:
    """Finite-difference Jacobian of S^period at z (raises :class:`WalkerFell` when a perturbed
    stride falls). ``step`` is absolute, in the units of the chosen section coordinates."""
    z = np.asarray(z, dtype=float)
    n = len(z)

    def S(w: np.ndarray) -> np.ndarray:
        return _from_model(walker, advance(walker, _to_model(walker, w, coordinates), period), coordinates)

    J = np.empty((n, n))
    if scheme == "forward":
        f0 = S(z) if base is None else np.asarray(base, dtype=float)
        for j in range(n):
            e = np.zeros(n)
            e[j] = step
            J[:, j] = (S(z + e) - f0) / step
    elif scheme == "central":
        for j in range(n):
            e = np.zeros(n)
            e[j] = step
            J[:, j] = (S(z + e) - S(z - e)) / (2 * step)
    else:
        raise OptionError(f"scheme must be 'central' or 'forward', got {scheme!r}")
    return J


@dataclass
class FixedPointResult:
    """Result of :func:`find_fixed_point`.

    converged : |S^k(z) − z|_∞ < tol. z : the fixed point, or the last iterate when not converged.
    residual : |S^k(z) − z|_∞ at z. fell : the walker fell from the last iterate (no residual).
    history : (iterate, residual) of each Newton step.
    """

    converged: bool
    z: np.ndarray
    residual: float
    iterations: int
    period: int
    message: str = ""
    fell: bool = False
    history: list[tuple[list[float], float]] = field(default_factory=list)


#: the Newton matrices of :func:`find_fixed_point`
NEWTON_JACOBIANS = ("auto", "variational", "fd")

#: the tolerances of the Newton matrix's run, relative to the walker's (its Jacobian then errs
#: by ~1e-7 to 1e-5 relative on the compass and compliant walkers, at a third of the cost)
_LOOSE = 10.0

#: Newton gives up when the residual has not halved in this many iterations
_STALL = 5

#: a Newton step that leaves more than this fraction of the residual gets a fresh exact Jacobian
#: (Broyden's updates only where Newton converges fast: far from the fixed point they would lead
#: it elsewhere than the exact matrix, to another fixed point at times)
_SLOW = 0.1


def _exact_jacobian(walker: Walker, z: np.ndarray, period: int,
                    deadline: float) -> tuple[np.ndarray | None, bool]:
    """(∂S^period/∂z at z, stopped) from one run of the strides with their sensitivities
    (``walker.stride_sensitivity``): the matrix None when that run falls, passes ``deadline``
    (then ``stopped``) or the model's runs cannot carry sensitivities
    (:class:`~porthamiltonian.errors.ModelError`)."""
    try:
        run = walker.stride_sensitivity(z, period, factor=_LOOSE, deadline=deadline)
    except ModelError:
        return None, False
    if not run.stopped:
        tick("stride", period)
    return (None if run.fell else run.jacobian), run.stopped


def find_fixed_point(walker: Walker, guess: np.ndarray | None = None, *, period: int = 1, tol: float = 1e-10,
                     max_iter: int = 30, fd_step: float = 1e-6,
                     jacobian: str = "auto", deadline: float = math.inf) -> FixedPointResult:
    """Newton's method on S^period(z) − z from ``guess`` (default: the walker's initial guess),
    with step halving when a step does not reduce the residual or makes the walker fall; it
    stops when the residual |S^period(z) − z|_∞ (absolute, section units) is below ``tol``, when
    no step reduces it, or when it has not halved in five iterations. The residual is always
    the walker's own stride map (:meth:`~.protocol.Walker.walk`).

    jacobian : the Newton matrix ∂S/∂z. "variational": exact, from one run of the strides with
        their sensitivities (:meth:`~.protocol.Walker.stride_sensitivity`: the variational
        equation, a saltation matrix at every event, the lift and the projection of the
        section), then updated by Broyden's rank-one rule from the strides Newton takes
        anyway; recomputed exactly when a step was halved or left more than a tenth of the
        residual. The run with sensitivities is made at ten times the walker's tolerances (the
        matrix only steers Newton: the fixed point is that of the walker's own strides).
        "fd": forward differences of absolute step ``fd_step`` (section units) at every
        iteration (one stride per section coordinate). "auto" (the default): "variational",
        falling back to "fd" where the run with sensitivities cannot be made (a model whose
        runs cannot carry them, e.g. with discrete-time blocks) or falls when the plain stride
        does not.

    deadline : a ``time.perf_counter()`` after which no new iteration starts and the run of
        an exact Newton matrix under way stops: the result is then the iterate reached, not
        converged, its message "stopped at the time limit" (the strides of an iteration under
        way end first)."""
    if jacobian not in NEWTON_JACOBIANS:
        raise OptionError(f"jacobian must be one of {', '.join(NEWTON_JACOBIANS)}, got {jacobian!r}")
    z = np.asarray(walker.initial_guess() if guess is None else guess, dtype=float)
    n = len(z)
    history: list[tuple[list[float], float]] = []
    try:
        Sz = advance(walker, z, period)
    except WalkerFell as err:
        return FixedPointResult(False, z, math.inf, 0, period, f"the walker falls from the initial "
                                f"guess ({err.stride.reason})", fell=True, history=history)
    F = Sz - z
    res = float(np.max(np.abs(F)))
    history.append((z.tolist(), res))
    exact = jacobian != "fd"
    J: np.ndarray | None = None     # the Newton matrix's ∂S/∂z, None: to be computed at z
    J_used: np.ndarray | None = None  # the matrix of the last Newton step
    for it in range(1, max_iter + 1):
        if res < tol:
            creep = _creeping(J_used, F, z, tol)
            if creep is not None:
                return FixedPointResult(False, z, res, it - 1, period, creep, history=history)
            return FixedPointResult(True, z, res, it - 1, period, "converged", history=history)
        if time.perf_counter() > deadline:
            return FixedPointResult(False, z, res, it - 1, period, "stopped at the time limit",
                                    history=history)
        fresh = J is None
        if J is None and exact:
            J, stopped = _exact_jacobian(walker, z, period, deadline)
            if stopped:
                return FixedPointResult(False, z, res, it - 1, period,
                                        "stopped at the time limit", history=history)
            if J is None and jacobian == "variational":
                return FixedPointResult(False, z, res, it, period, "the run with sensitivities "
                                        f"fell or cannot be made at Newton iteration {it}",
                                        history=history)
            exact = J is not None       # "auto": finite differences from here on
        if J is None:
            try:
                J = _forward(walker, z, period, fd_step, Sz)
            except WalkerFell as err:
                return FixedPointResult(False, z, res, it, period, f"a perturbed stride fell "
                                        f"({err.stride.reason}) at Newton iteration {it}",
                                        history=history)
        J_used = J
        try:
            dz = -np.linalg.solve(J - np.eye(n), F)
        except np.linalg.LinAlgError:
            return FixedPointResult(False, z, res, it, period, "singular Newton matrix (a "
                                    "multiplier equals 1)", history=history)
        lam, accepted = 1.0, False
        for _ in range(12):
            trial = z + lam * dz
            try:
                S_trial = advance(walker, trial, period)
            except WalkerFell:
                lam /= 2
                continue
            F_trial = S_trial - trial
            r_trial = float(np.max(np.abs(F_trial)))
            if r_trial < res or r_trial < tol:
                accepted = True
                break
            lam /= 2
        if accepted and exact:
            s = trial - z       # Broyden: the secant of this step, S(trial) − S(z) = J s
            ss = float(s @ s)
            J = None if lam < 1.0 or r_trial > _SLOW * res or ss == 0.0 else \
                J + np.outer(S_trial - Sz - J @ s, s) / ss
        elif accepted or not fresh:
            J = None            # fd: anew at every iterate; an updated matrix: anew here
        if accepted:
            z, Sz, F, res = trial, S_trial, F_trial, r_trial
        history.append((z.tolist(), res))
        if it >= _STALL and res > 0.5 * history[-1 - _STALL][1] and res >= tol:
            return FixedPointResult(False, z, res, it, period, f"stalled (the residual did not "
                                    f"halve in {_STALL} iterations)", history=history)
        if not accepted and fresh:
            return FixedPointResult(res < tol, z, res, it, period,
                                    "converged" if res < tol else
                                    "no Newton step reduced the residual", history=history)
    return FixedPointResult(res < tol, z, res, max_iter, period,
                            "converged" if res < tol else f"not converged in {max_iter} iterations",
                            history=history)


def _creeping(J: np.ndarray | None, F: np.ndarray, z: np.ndarray, tol: float) -> str | None:
    """Why z, whose residual F is below ``tol``, is no isolated fixed point, or None when it is.

    The residual test alone is absolute: near a family of fixed points (a passive walker on
    level ground creeping toward standing still, where a multiplier tends to 1), every stride
    changes a small state by less than ``tol`` while Newton's iterates keep shrinking it by a
    fixed fraction. There the next Newton correction −(J − I)⁻¹F is large: a fixed point is
    accepted only when that correction is at most max(1e3·tol, 1e-6)·max(1, |z_i|) in each
    coordinate (an isolated fixed point has |correction| ≈ |F|/|1 − λ|, far below it unless a
    multiplier is within about 1e-3 of 1). ``J`` is the matrix of the last Newton step (None:
    no step was taken, nothing to judge)."""
    if J is None:
        return None
    try:
        dz = np.linalg.solve(J - np.eye(len(z)), F)
    except np.linalg.LinAlgError:
        return "singular Newton matrix at the converged point (a multiplier equals 1)"
    bound = max(1e3 * tol, 1e-6) * np.maximum(1.0, np.abs(z))
    if np.all(np.abs(dz) <= bound):
        return None
    return (f"no isolated fixed point: the residual is below {tol:g}, but Newton's next "
            f"correction is {float(np.max(np.abs(dz))):.3g} (a multiplier near 1: the iterates "
            f"creep toward a family of fixed points, e.g. standing still)")


def _forward(walker: Walker, z: np.ndarray, period: int, step: float, Sz: np.ndarray) -> np.ndarray:
    """The forward-difference ∂S^period/∂z at z (absolute ``step``; ``Sz`` = S^period(z))."""
    return jacobian(walker, z, period=period, step=step, scheme="forward", base=Sz)


@dataclass
class PeriodResult:
    """Result of :func:`detect_period`: ``period`` (0 when none ≤ max_period was found), the
    iterates, and the step at which the walker fell (None if it did not)."""

    period: int
    iteration: IterationResult
    distance: float

    @property
    def fell_at_step(self) -> int | None:
        return self.iteration.fell_at_step


def detect_period(walker: Walker, z0: np.ndarray, *, max_period: int = 8, n_steps: int = 200,
                  tol: float = 1e-7, chunk: int = 25) -> PeriodResult:
    """Iterate the stride map from ``z0`` (at most ``n_steps`` steps, checked every ``chunk``
    steps) and return the smallest period k ≤ ``max_period`` with |z_N − z_{N−k}|_∞ <
    tol (1 + |z_N|_∞) over the last ``max_period`` iterates."""
    states = [np.asarray(z0, dtype=float)]
    strides: list[Stride] = []
    best = math.inf
    while len(strides) < n_steps:
        part = iterate(walker, states[-1], min(chunk, n_steps - len(strides)))
        strides += part.strides
        states += part.states[1:]
        if part.fell_at_step is not None:
            it = IterationResult(states, strides, len(strides), part.fall_reason)
            return PeriodResult(0, it, math.nan)
        Z = np.array(states)
        scale = 1.0 + float(np.max(np.abs(Z[-1])))
        for k in range(1, max_period + 1):
            if len(Z) < 2 * k + 1:
                break
            recent = Z[-(max_period + k):]
            d = float(np.max(np.abs(recent[k:] - recent[:-k])))
            best = min(best, d / scale)
            if d < tol * scale:
                return PeriodResult(k, IterationResult(states, strides), d)
    return PeriodResult(0, IterationResult(states, strides), best)

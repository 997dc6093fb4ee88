"""The stride map's Jacobian on the Poincaré section (the monodromy matrix projected on the
section) and the Floquet multipliers, each with an error estimate.

One interface, :func:`stride_jacobian`, with a ``method``:

* ``"variational"`` (the default) — the exact Jacobian: the variational equations integrated
  with the stride by the compiled Rosenbrock loop, a saltation matrix at every event (contacts
  switching, impacts, relabelling), the projection on the section at the heel strike
  (:mod:`.variational`, on :mod:`porthamiltonian.simulation.saltation`). Its error is that of the
  integration: it is estimated elementwise as |J(rtol) − J(10 rtol)|, the same Jacobian from a
  second run at ten times the tolerances (an over-estimate by about the ratio of the two runs'
  errors), plus the bound of what the difference Jacobians of the lift, the impact maps and the
  projection bring in (:mod:`.variational`, ~1e-11 relative). The walker provides ``stride_sensitivity(z, period, factor=1)``
  (:class:`~.core.HybridWalker` does); :func:`stride_jacobian` raises a clear error for a walker
  without it. The two runs are independent: the second runs in a thread of its own meanwhile
  (the compiled loops release the GIL, so on two free cores the pair takes the time of the
  longer run, not of both; the numbers are those of the two runs made one after the other).
* ``"fd"`` — central finite differences (the cross-check), the step chosen per section
  coordinate automatically. For coordinate j the differences are taken on a ladder of steps
  h = h0_j 4⁻ᵐ (m = 0, 1, …; h0_j = ``first_step`` × max(|z_j|, 1e-3), ``first_step`` = 1e-3 by
  default), each pair of neighbouring rungs is Richardson-extrapolated (O(h⁴)), and the rung whose
  extrapolation agrees best with the previous one is kept; that disagreement is the column's
  error estimate. Too large a step leaves the region where the stride map is smooth (a
  compliant walker's trailing foot lifts off, or is pushed deep into the ground), too small a
  step drowns in the integrator's error: the ladder finds the window between them, where a
  fixed step cannot (on compass_walker a step of 1e-4 rad errs by 10 % on the leg-angle columns,
  one of 1e-6 rad by 1e-5). The user's step only sets where the ladder starts, so the result —
  and the stability verdict — does not depend on it. On the compliant walkers it costs 15–20
  times the exact method and is 100–1000 times less accurate.

:func:`floquet` turns a Jacobian into Floquet multipliers (largest modulus first) with a
first-order error bound per multiplier, |δλ_i| ≤ |y_i|ᵀ E |x_i| / |y_iᴴ x_i| (x_i, y_i its right
and left eigenvectors, E the Jacobian's elementwise error estimate), so that a stability verdict
comes with whether the error allows it (:attr:`FloquetResult.certain`).
"""
from __future__ import annotations

import math
import os
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np

from porthamiltonian.errors import ModelError

from ..core.protocol import Stride, StrideStatus, Walker
from .poincare import WalkerFell, advance

__all__ = ["JACOBIAN_METHODS", "FloquetResult", "Multipliers", "StrideJacobian", "eigen_errors",
           "floquet", "multipliers", "spectral_radius", "stride_jacobian"]

#: the ways of computing the stride map's Jacobian
JACOBIAN_METHODS = ("fd", "variational")

#: the ladder of finite-difference steps: ratio between rungs, rungs at most
_RATIO = 4.0
_MAX_RUNGS = 9


@dataclass
class StrideJacobian:
    """The Jacobian of S^period at z, in the model's section coordinates.

    matrix : dS^k/dz. error : elementwise error estimate (same shape). steps : the finite
    difference step kept per coordinate (NaN for "variational"). method : "fd" or
    "variational". strides : number of strides simulated to compute it. coarse, bound
    ("variational"): the same Jacobian at ten times the tolerances, and the elementwise bound of
    the difference Jacobians' share of the error (:func:`multipliers`).
    """

    matrix: np.ndarray
    error: np.ndarray
    steps: np.ndarray
    method: str
    period: int
    strides: int = 0
    coarse: np.ndarray | None = None
    bound: np.ndarray | None = None


def _scale(z: np.ndarray) -> np.ndarray:
    return np.maximum(np.abs(z), 1e-3)


def _central(walker: Walker, z: np.ndarray, j: int, h: float, period: int) -> np.ndarray:
    e = np.zeros(len(z))
    e[j] = h
    return (advance(walker, z + e, period) - advance(walker, z - e, period)) / (2.0 * h)


def _column(walker: Walker, z: np.ndarray, j: int, h0: float, period: int,
            row_scale: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, int]:
    """(column, its error estimate, step kept, strides) of the ladder for coordinate j."""
    diffs: list[tuple[float, np.ndarray]] = []
    best: tuple[float, np.ndarray, np.ndarray, float] | None = None
    worse, strides, h = 0, 0, h0
    prev_rich = None
    for _ in range(_MAX_RUNGS):
        try:
            d = _central(walker, z, j, h, period)
        except WalkerFell:       # too large a step: go on down the ladder
            strides += 2
            diffs, prev_rich, h = [], None, h / _RATIO
            continue
        strides += 2
        diffs.append((h, d))
        if len(diffs) >= 2:
            rich = (_RATIO**2 * diffs[-1][1] - diffs[-2][1]) / (_RATIO**2 - 1.0)
            if prev_rich is not None:
                err = np.abs(rich - prev_rich)
                size = float(np.max(err / row_scale))
                if best is None or size < best[0]:
                    best, worse = (size, rich, err, h), 0
                else:
                    worse += 1
                    if worse >= 2:   # two rungs worse than the best: the noise has taken over
                        break
            prev_rich = rich
        h /= _RATIO
    if best is None:
        if len(diffs) >= 2:
            rich = (_RATIO**2 * diffs[-1][1] - diffs[-2][1]) / (_RATIO**2 - 1.0)
            return rich, np.abs(rich - diffs[-1][1]), diffs[-1][0], strides
        if diffs:
            return diffs[-1][1], np.full(len(z), np.inf), diffs[-1][0], strides
        raise WalkerFell(z, walker.walk(z, period)[-1])
    return best[1], best[2], best[3], strides


def _two_rungs(walker: Walker, z: np.ndarray, j: int, h: float,
               period: int) -> tuple[np.ndarray, np.ndarray, float, int]:
    """Column j from the steps h and h/4 only (Richardson), its error |extrapolated − D(h/4)|."""
    d1 = _central(walker, z, j, h, period)
    d2 = _central(walker, z, j, h / _RATIO, period)
    rich = (_RATIO**2 * d2 - d1) / (_RATIO**2 - 1.0)
    return rich, np.abs(rich - d2), h, 4


def _one_rung(walker: Walker, z: np.ndarray, j: int, h: float,
              period: int) -> tuple[np.ndarray, np.ndarray, float, int]:
    """Column j from the step h only (error: unknown here, NaN)."""
    return _central(walker, z, j, h, period), np.full(len(z), np.nan), h, 2


def stride_jacobian(walker: Walker, z: np.ndarray, *, period: int = 1, method: str = "variational",
                    first_step: float | None = None, steps: np.ndarray | None = None,
                    error: np.ndarray | None = None) -> StrideJacobian:
    """The Jacobian of S^period at the section state ``z`` (model coordinates) by ``method``
    (module docstring). ``first_step``: the largest finite-difference step tried, relative to
    max(|z_j|, 1e-3) (default 1e-3); it does not set the step kept. ``steps``: the steps kept at
    a nearby state (a previous :attr:`StrideJacobian.steps`), to skip the ladder: two rungs, h
    and h/4, per coordinate; with ``error`` too (that state's :attr:`StrideJacobian.error`),
    one rung, h, whose error is taken to be that one (what continuation does between its
    points, where the Jacobian changes little); "variational" ignores ``steps`` and ``error``
    (its two runs cost less than one finite-difference rung). Raises
    :class:`~.poincare.WalkerFell` when every step of a coordinate falls, or the stride falls
    (variational)."""
    z = np.asarray(z, dtype=float)
    if method not in JACOBIAN_METHODS:
        raise ModelError(f"jacobian must be one of {', '.join(JACOBIAN_METHODS)}, got {method!r}")
    if method == "variational":
        return _variational(walker, z, period)
    rel = 1e-3 if first_step is None else float(first_step)
    if not (math.isfinite(rel) and rel > 0):
        raise ModelError(f"the finite-difference step must be a number > 0, got {first_step!r}")
    n = len(z)
    scale = _scale(z)
    J, E, total = np.empty((n, n)), np.empty((n, n)), 0
    kept = np.empty(n)
    for j in range(n):
        if steps is not None and math.isfinite(steps[j]):
            rung = _two_rungs if error is None else _one_rung
            J[:, j], E[:, j], kept[j], k = rung(walker, z, j, float(steps[j]), period)
        else:
            J[:, j], E[:, j], kept[j], k = _column(walker, z, j, rel * scale[j], period, scale)
        total += k
    if error is not None:
        E = np.asarray(error, dtype=float).copy()
    return StrideJacobian(J, E, kept, method, period, total)


_A = TypeVar("_A")
_B = TypeVar("_B")


def _concurrently(first: Callable[[], _A], second: Callable[[], _B]) -> tuple[_A, _B]:
    """(first(), second()), ``second`` called in a thread of its own while this one calls
    ``first`` (one after the other where this process may use one processor only); an exception
    of either is raised here (``first``'s when both raise)."""
    usable = (len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
              else os.cpu_count() or 1)
    if usable < 2:
        return first(), second()
    other: list = []

    def run() -> None:
        try:
            other.append((True, second()))
        except BaseException as err:  # noqa: BLE001 - re-raised in the calling thread
            other.append((False, err))

    thread = threading.Thread(target=run, name="stride-sensitivity", daemon=True)
    thread.start()
    try:
        result = first()
    finally:
        thread.join()
    ok, value = other[0]
    if not ok:
        raise value
    return result, value


def _variational(walker: Walker, z: np.ndarray, period: int) -> StrideJacobian:
    """The exact Jacobian and its error estimate (module docstring)."""
    runs = _concurrently(lambda: walker.stride_sensitivity(z, period),
                         lambda: walker.stride_sensitivity(z, period, factor=10.0))
    fell = next((run.fell for run in runs if run.fell), "")
    J, bound, coarse = runs[0].jacobian, runs[0].difference_error, runs[1].jacobian
    if fell or J is None or bound is None or coarse is None:    # a run that fell has no J
        raise WalkerFell(z, Stride(StrideStatus.FELL, None, 0.0, reason=fell))
    E = np.abs(J - coarse) + bound
    return StrideJacobian(J, E, np.full(len(z), np.nan), "variational", period,
                          period * len(runs), coarse, bound)


def eigen_errors(J: np.ndarray, E: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues of J (largest modulus first) and first-order bounds of their errors for an
    elementwise error |δJ| ≤ E: |y|ᵀ E |x| / |yᴴ x| (x, y right and left eigenvectors)."""
    lam, X = np.linalg.eig(J)
    order = sorted(range(len(lam)), key=lambda i: (-abs(lam[i]), -lam[i].imag))
    lam, X = lam[order], X[:, order]
    try:
        Y = np.linalg.inv(X).conj().T          # columns: left eigenvectors, yᴴ x = 1
    except np.linalg.LinAlgError:
        return lam, np.full(len(lam), np.inf)
    err = np.empty(len(lam))
    for i in range(len(lam)):
        x, y = X[:, i], Y[:, i]
        denom = abs(np.vdot(y, x))
        err[i] = float(np.abs(y) @ E @ np.abs(x)) / denom if denom > 0 else np.inf
    return lam, err


def multipliers(sj: StrideJacobian) -> tuple[np.ndarray, np.ndarray]:
    """The eigenvalues of ``sj.matrix`` (largest modulus first) and their error bounds: for an
    exact Jacobian with its second run (``sj.coarse``), |λ_i − λ'_i| (λ'_i the coarse Jacobian's
    eigenvalue nearest λ_i: the change of the multiplier itself when the tolerances grow ten
    times, an over-estimate of its error at the tolerances used) plus the first-order bound of
    ``sj.bound``; else the first-order bound of the elementwise ``sj.error``
    (:func:`eigen_errors`). The elementwise route over-estimates the multipliers' errors of a
    stiff walker 100–1000 times: its Jacobian has large entries in directions the multipliers
    do not feel."""
    if sj.coarse is None or sj.bound is None:
        return eigen_errors(sj.matrix, sj.error)
    lam, err = eigen_errors(sj.matrix, sj.bound)
    other = np.linalg.eigvals(sj.coarse)
    return lam, err + np.array([float(np.min(np.abs(other - x))) for x in lam])


def spectral_radius(multipliers: np.ndarray) -> float:
    """The largest |λ| (0 for none): below 1, the orbit is stable."""
    return float(np.max(np.abs(multipliers))) if len(multipliers) else 0.0


class Multipliers:
    """The stability of an orbit from its Floquet multipliers (a base of the results that hold
    them: :class:`FloquetResult`, a continuation's branch points)."""

    multipliers: np.ndarray

    @property
    def max_modulus(self) -> float:
        """The largest |λ| (:func:`spectral_radius`)."""
        return spectral_radius(self.multipliers)

    @property
    def stable(self) -> bool:
        """All multipliers inside the unit circle."""
        return self.max_modulus < 1.0


@dataclass
class FloquetResult(Multipliers):
    """Floquet multipliers of a period-k orbit (eigenvalues of the stride map's Jacobian,
    largest modulus first), each with an error bound (``errors``), and the Jacobian in both
    section coordinates.

    error : the largest of ``errors``. stable : all multipliers inside the unit circle.
    certain : the errors cannot change that verdict (| max |λ| − 1 | exceeds the error of the
    largest multiplier). steps : the finite-difference step kept per coordinate.
    """

    multipliers: np.ndarray
    errors: np.ndarray
    jacobian: np.ndarray
    jacobian_thesis: np.ndarray
    steps: np.ndarray
    period: int
    method: str = "variational"
    jacobian_error: np.ndarray | None = field(default=None, repr=False)

    @property
    def error(self) -> float:
        return float(np.max(self.errors)) if len(self.errors) else 0.0

    @property
    def certain(self) -> bool:
        if not len(self.multipliers):
            return True
        return abs(self.max_modulus - 1.0) > float(self.errors[0])


def floquet_of(walker: Walker, sj: StrideJacobian) -> FloquetResult:
    """The :class:`FloquetResult` of a computed Jacobian."""
    lam, err = multipliers(sj)
    n = len(sj.matrix)
    T = np.column_stack([walker.to_thesis(np.eye(n)[:, j]) for j in range(n)])
    JT = T @ sj.matrix @ np.linalg.inv(T)
    return FloquetResult(lam, err, sj.matrix, JT, sj.steps, sj.period, sj.method, sj.error)


def floquet(walker: Walker, z: np.ndarray, *, period: int = 1, step: float | None = None,
            jacobian: str = "variational") -> FloquetResult:
    """Floquet multipliers at a fixed point z of S^period with error bounds (module docstring).
    ``jacobian``: "variational" (exact) or "fd"; ``step`` only sets where the finite-difference
    ladder starts (relative to max(|z_j|, 1e-3))."""
    return floquet_of(walker, stride_jacobian(walker, z, period=period, method=jacobian,
                                              first_step=step))

"""Derivatives by central differences, with an error estimate. Numeric, no sympy.

Used where a derivative is needed rarely and no generated one exists: the gradient of an event
guard at the event (:mod:`porthamiltonian.simulation.saltation`), the Jacobian of a reset map such as the
plastic impact (:func:`porthamiltonian.simulation.impact.impact_jacobian`). Each coordinate j is
stepped by ``h_j = step · max(|x_j|, scale_j)`` (default step ε^(1/3) ≈ 6e-6, ε the float64
epsilon: truncation error O(h²) and round-off O(ε/h) balance there, both ~1e-11 of the function's
scale for a smooth function), and the central differences at h and 2h give the estimate:

    D(h) = (f(x + h e_j) − f(x − h e_j)) / 2h,   D(h) − exact ≈ (D(2h) − D(h)) / 3,

to which the round-off bound 2 ε max|f| / h is added. The value returned is D(h). A function that
is not smooth within ±2h of x (a kink of a Piecewise law) shows as a large error estimate.

:func:`directional` gives derivatives along given directions (the tangents of a forward-mode
chain rule whose linear algebra is differentiated exactly, e.g. a reset map's linear solves)
to fourth order: Richardson's extrapolation R(h) = (4 D(h) − D(2h)) / 3 of central differences,
error O(h⁴), estimated from R(2h), the largest relative perturbation of a coordinate 1e-3
(≈ ε^(1/5), where truncation and round-off balance: ~1e-12 of the function's scale).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["CBRT_EPS", "Derivative", "directional", "gradient", "jacobian"]

#: ε^(1/3): the default relative step of the central differences
CBRT_EPS = float(np.finfo(float).eps) ** (1.0 / 3.0)


@dataclass(frozen=True)
class Derivative:
    """A derivative by differences: ``value`` and ``error``, an estimate of |value − exact| per
    entry (same shape: (k, n) for a Jacobian of k values by n coordinates, (n,) for a gradient)."""

    value: np.ndarray
    error: np.ndarray

    @property
    def max_error(self) -> float:
        """The largest entry of :attr:`error`."""
        return float(np.max(self.error)) if self.error.size else 0.0


def jacobian(fun: Callable[[np.ndarray], np.ndarray], x: np.ndarray,
             scale: float | np.ndarray = 1.0, step: float = CBRT_EPS) -> Derivative:
    """∂fun/∂x at ``x`` (fun: n values -> k values) by central differences (module docstring).

    scale : the typical size of each coordinate (a number or one per coordinate, > 0): the step
        of coordinate j is ``step · max(|x_j|, scale_j)``; give the size on which fun varies
        when it is larger than |x_j| (e.g. 1 m for a position near 0).
    """
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    sizes = np.maximum(np.abs(x), np.broadcast_to(np.asarray(scale, dtype=float), (n,)))
    columns, errors = [], []
    for j in range(n):
        h = step * sizes[j]
        values = []
        for k in (1.0, -1.0, 2.0, -2.0):
            xj = x.copy()
            xj[j] += k * h
            values.append(np.atleast_1d(np.asarray(fun(xj), dtype=float)))
        d1 = (values[0] - values[1]) / (2.0 * h)
        d2 = (values[2] - values[3]) / (4.0 * h)
        roundoff = 2.0 * np.finfo(float).eps * np.max(np.abs(values), axis=0) / h
        columns.append(d1)
        errors.append(np.abs(d2 - d1) / 3.0 + roundoff)
    value = np.stack(columns, axis=1) if columns else np.empty((0, 0))
    return Derivative(value, np.stack(errors, axis=1) if errors else np.empty((0, 0)))


def gradient(fun: Callable[[np.ndarray], float], x: np.ndarray,
             scale: float | np.ndarray = 1.0, step: float = CBRT_EPS) -> Derivative:
    """The gradient of the scalar function ``fun`` at ``x`` (see :func:`jacobian`); shape (n,)."""
    d = jacobian(lambda z: np.array([float(fun(z))]), x, scale, step)
    return Derivative(d.value[0], d.error[0])


def directional(fun: Callable[[np.ndarray], np.ndarray], x: np.ndarray, directions: np.ndarray,
                scale: float | np.ndarray = 1.0, step: float = 1e-3) -> Derivative:
    """The derivatives of ``fun`` (n values -> k values) at ``x`` along the columns of
    ``directions`` (n x K): (k, K), fourth order (module docstring). Along column d the step h
    moves no coordinate by more than ``step · max(|x_i|, scale_i)``; a zero column gives 0, and
    so does a column along which fun(x ± h d) equals fun(x) bit for bit (fun does not read
    those coordinates, e.g. a mass matrix along a momentum: two evaluations instead of six)."""
    x = np.asarray(x, dtype=float)
    directions = np.asarray(directions, dtype=float).reshape(len(x), -1)
    sizes = np.maximum(np.abs(x), np.broadcast_to(np.asarray(scale, dtype=float), x.shape))
    columns: list[np.ndarray | None] = []
    errors: list[np.ndarray | None] = []
    base = np.atleast_1d(np.asarray(fun(x), dtype=float))
    k = len(base)
    for d in directions.T:
        moved = d != 0.0
        if not np.any(moved):
            columns.append(None)
            errors.append(None)
            continue
        h = step * float(np.min(sizes[moved] / np.abs(d[moved])))
        values = {s: np.atleast_1d(np.asarray(fun(x + s * h * d), dtype=float))
                  for s in (1.0, -1.0)}
        if np.array_equal(values[1.0], base) and np.array_equal(values[-1.0], base):
            columns.append(None)
            errors.append(None)
            continue
        values.update({s: np.atleast_1d(np.asarray(fun(x + s * h * d), dtype=float))
                       for s in (2.0, -2.0, 4.0, -4.0)})
        central = [(values[s] - values[-s]) / (2.0 * s * h) for s in (1.0, 2.0, 4.0)]
        fine, coarse = (4.0 * central[0] - central[1]) / 3.0, (4.0 * central[1] - central[2]) / 3.0
        roundoff = 2.0 * np.finfo(float).eps * np.max(np.abs(list(values.values())), axis=0) / h
        columns.append(fine)
        errors.append(np.abs(coarse - fine) / 15.0 + roundoff)
    value = np.zeros((k, len(columns)))
    error = np.zeros((k, len(columns)))
    for j, (c, e) in enumerate(zip(columns, errors)):
        if c is not None:
            value[:, j], error[:, j] = c, e
    return Derivative(value, error)

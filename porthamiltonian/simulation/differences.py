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
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["CBRT_EPS", "Derivative", "gradient", "jacobian"]

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

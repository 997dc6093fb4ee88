"""Dense output of the compiled loops: a segment's steps joined by quintic Hermite interpolation.

The compiled methods (Rodas5P, Rodas4, QBDF) return the state at the end of every accepted step.
``simulate(..., dense_output=True)`` with one of them makes each segment's interpolant from those
points alone, after the run: on every step [t_k, t_k+1] the polynomial of degree 5 that takes the
values y, the rates f = ẏ and their derivatives ÿ = df/dt = J f + ∂f/∂t of the model at both
ends: its coefficients in closed form, evaluated by Horner's rule on the step that holds each
time (``scipy.interpolate.PPoly`` computes the same, but importing scipy.interpolate takes
0.3 s, more than most runs; ``BPoly.from_derivatives`` makes the same polynomials in a Python
loop over the steps: 25 ms for 555 steps, where the whole interpolant takes 0.25 ms on the C
back end). ∂f/∂t is a central difference of f (relative step ε^(1/3)) where the right-hand
side reads time (a non-autonomous model, or inputs with a slope); else 0. The states are those
of the run (the model's and the ledger's E_diss, E_in).

Its error on a step of length h is O(h^6) and uses the model's own exact derivatives, so that
the interpolation adds little to the steps' own error: on the mass–spring–damper against its
closed form, at rtol 1e-3 to 1e-9, the interpolant's largest error over the run is 1.0 to 2.3
times that of the stored points themselves (tests/validation/test_dense_output.py), where a
cubic Hermite (values and rates only) on Rodas5P's long steps was 37 to 13 000 times worse. The
interpolant is C² across the steps (values, rates and their derivatives meet at each stored
point), not across events: each segment between two events has its own.

Cost: one right-hand side and one Jacobian per stored point (plus two right-hand sides for
∂f/∂t), after the run, in one call per segment on the C back end
(:func:`porthamiltonian.backends.at_points`); nothing when dense output is not asked for.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..backends import at_points

if TYPE_CHECKING:
    from .compiled import CompiledModel

#: ε^(1/3): the relative step of the central difference of ∂f/∂t
_CBRT_EPS = float(np.finfo(float).eps) ** (1.0 / 3.0)

__all__ = ["StepInterpolant", "step_interpolant"]


class StepInterpolant:
    """y(t) on [t_0, t_last] of one segment (shape (n + 2,) for a number t, (n + 2, len(t)) for
    an array): the quintic Hermite pieces of :func:`step_interpolant` (``coefficients``: 6 x
    steps x n, highest power first, in s = t − t_k), or the one state of a segment of a single
    point. A time between two steps' pieces is evaluated on the later one (the pieces meet
    there); a time outside [t_0, t_last] on the nearest end's piece (extrapolated)."""

    def __init__(self, t: np.ndarray, coefficients: np.ndarray | None, y0: np.ndarray) -> None:
        self.t_min, self.t_max = float(t[0]), float(t[-1])
        self._t, self._y0 = t, y0
        # steps x 6 x n: a step's coefficients side by side (gathered per time at once)
        self._c = None if coefficients is None else np.ascontiguousarray(
            coefficients.transpose(1, 0, 2))

    def __call__(self, t: float | np.ndarray) -> np.ndarray:
        if self._c is None:
            return (self._y0.copy() if np.ndim(t) == 0
                    else np.repeat(self._y0[:, None], np.size(t), axis=1))
        s = np.asarray(t, dtype=float)
        flat = np.atleast_1d(s)
        k = np.clip(np.searchsorted(self._t, flat, side="right") - 1, 0, len(self._c) - 1)
        ds = (flat - self._t[k])[:, None]
        c = self._c[k]                                           # (len(t), 6, n)
        values = c[:, 0]
        for power in range(1, 6):
            values = values * ds + c[:, power]
        return np.asarray(values[0] if s.ndim == 0 else values.T)


def step_interpolant(model: CompiledModel, t: np.ndarray, y: np.ndarray, p: np.ndarray,
                     time_dependent: bool) -> StepInterpolant:
    """The dense output of one segment of a compiled run (module docstring): ``t`` its stored
    times (increasing; a repeated time keeps its last state), ``y`` the states there ((n + 2) x
    len(t)), ``p`` the parameter vector the segment ran with, ``time_dependent``: the
    right-hand side reads t (∂f/∂t by differences)."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    # strictly increasing times: of equal ones (a terminal event at a step's start) the last
    keep = np.append(np.diff(t) > 0.0, True)
    t, y = t[keep], y[:, keep]
    if len(t) < 2:
        return StepInterpolant(t, None, y[:, 0].copy())
    rhs, jac = model.functions.rhs, model.functions.jac
    rows = np.ascontiguousarray(y.T)
    pn = model.native_params(p)
    f = at_points(rhs, t, rows, pn)                               # (points, n)
    rate = np.einsum("kij,kj->ki", at_points(jac, t, rows, pn), f)
    if time_dependent:
        d = _CBRT_EPS * np.maximum(1.0, np.abs(t))
        ahead, behind = at_points(rhs, t + d, rows, pn), at_points(rhs, t - d, rows, pn)
        rate += (ahead - behind) / (2.0 * d[:, None])
    return StepInterpolant(t, _quintic(t, y, f.T, rate.T), y[:, 0].copy())


def _quintic(t: np.ndarray, y: np.ndarray, f: np.ndarray, rate: np.ndarray) -> np.ndarray:
    """The coefficients (6 x steps x n, highest power first, in s = t − t_k) of the quintic on
    each step that takes y, f and ``rate`` (ÿ) at both ends: a0 = y0, a1 = f0, a2 = ÿ0 / 2, and
    with D = y1 − (a0 + a1 h + a2 h²), D′ = f1 − (a1 + 2 a2 h), D″ = ÿ1 − 2 a2:
    a3 = (20 D − 8 D′ h + D″ h²) / (2 h³), a4 = (−30 D + 14 D′ h − 2 D″ h²) / (2 h⁴),
    a5 = (12 D − 6 D′ h + D″ h²) / (2 h⁵)."""
    h = np.diff(t)
    a0, a1, a2 = y[:, :-1], f[:, :-1], 0.5 * rate[:, :-1]
    d0 = y[:, 1:] - (a0 + h * (a1 + h * a2))
    d1 = (f[:, 1:] - (a1 + 2.0 * a2 * h)) * h
    d2 = (rate[:, 1:] - 2.0 * a2) * h * h
    a3 = (20.0 * d0 - 8.0 * d1 + d2) / (2.0 * h**3)
    a4 = (-30.0 * d0 + 14.0 * d1 - 2.0 * d2) / (2.0 * h**4)
    a5 = (12.0 * d0 - 6.0 * d1 + d2) / (2.0 * h**5)
    return np.stack([a5, a4, a3, a2, a1, a0]).transpose(0, 2, 1)

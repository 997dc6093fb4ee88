"""Exact gradients of a gait by the walker's parameters.

At a period-k gait, z* = S^k(z*, p) on the Poincaré section. The strides of one period, each a
run with parameter sensitivities (:func:`~walker_library.core.gradients.stride_gradient`), give
A = ∂S^k/∂z and B = ∂S^k/∂p (chained: z_{j+1} = S(z_j, p), A_{j+1} = J_j A_j, B_{j+1} = J_j B_j +
P_j), and by the implicit function theorem

    dz*/dp = (I − A)⁻¹ B.

Every quantity Q(z, p) of a period (its duration, length, the energy booked as dissipated)
comes with its row (∂Q/∂z, ∂Q/∂p) from the same runs, so that dQ*/dp = Q_z dz*/dp + Q_p exactly.
The gait's quantities (the keys of ``walker gait --json``): ``step_period`` = T/k,
``step_length`` = L/k, ``speed`` = L/T, ``energy_dissipated_per_step`` = E/k,
``cost_of_transport`` = E/(W L) with W the weight (its derivative by central differences of the
model's mass expression and g).

``max_multiplier_modulus``: ρ = |λ| of the largest eigenvalue λ of A (the Floquet multiplier).
Its derivative along the gait branch, dλ/dp = wᴴ (dA/dp) v / (wᴴ v) (v, w its right and left
eigenvectors), needs the total derivative dA/dp = ∂A/∂z dz*/dp + ∂A/∂p, a second derivative.
Scheme: central differences of the *exact* A (the stride Jacobian from the variational
equations, :func:`~walker_library.core.variational.stride_sensitivity`) along the branch's
tangent, at (z* ± s h dz*/dp_j, p ± s h e_j) for s = 1, 2, Richardson-extrapolated,

    D = (4 D(h) − D(2h)) / 3,    D(h) = (A(+h) − A(−h)) / 2h,

h = ``MULTIPLIER_STEP`` · max(|p_j|, 1e-3). The error of D is O(h⁴) (truncation) plus the
integration error of A amplified by 3/2h; the bound reported, |dρ(D(h)) − dρ(D(2h))|, exceeds
both (the truncation of D(h) alone is 3/4 of the difference of the two, and the integration
error enters the difference with about the same weight as D): measured against differences of
multipliers of fixed points found to 1e-12 it holds (tests/walkers/test_gait_gradients.py). It
costs 4 stride-Jacobian runs per parameter; ``multiplier=False`` skips it.

ρ is not differentiable where two multipliers of the largest modulus meet (a real pair turning
complex: there |λ| of each has a square-root branch point) — often where ρ is least (Burke,
Lewis & Overton 2001: optimal spectral radii sit at multiple eigenvalues). The same D_j give the
smooth description that an epigraph formulation needs (:mod:`.optimize`), in
:attr:`GaitGradient.spectrum`: the *cluster* of the largest modulus (a complex pair, a real pair,
or a lone real multiplier), by the sum s and product P of its multipliers, which are smooth
through the collision — with the real Schur form A = Z T Zᵀ ordered so that the cluster comes
first (T₁₁, X = Z[:, :2]) and Yᵀ = [I, R] Zᵀ its left invariant subspace (T₁₁R − RT₂₂ = T₁₂,
YᵀX = I), the cluster's eigenvalues move to first order as those of T₁₁ + Yᵀ D_j X, so
ds/dp_j = tr(Yᵀ D_j X) and dP/dp_j = tr(adj(T₁₁) Yᵀ D_j X) (a lone real λ: s = 2λ, P = λ²) —
and the largest modulus r outside the cluster with its eigenvalue-perturbation derivative.
Both multipliers of the cluster lie in the disc |λ| ≤ t exactly when (Jury's conditions for
λ² − sλ + P scaled by t) t² − P ≥ 0 and t² + P ∓ s t ≥ 0; with r ≤ t that is ρ ≤ t.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, cast

import numpy as np
from numpy.typing import ArrayLike

from porthamiltonian.simulation.differences import gradient

from ..core.gradients import StrideGradient, check_names, stride_gradient
from ..core.protocol import Walker
from .gait import GAIT_QUANTITIES
from .results import JSONResult

if TYPE_CHECKING:
    from ..core.walker import HybridWalker

__all__ = ["GAIT_QUANTITIES", "MULTIPLIER_STEP", "GaitGradient", "gait_gradient",
           "solve_gait"]

#: the relative step h of the multiplier's derivative (module docstring)
MULTIPLIER_STEP = 1e-3


@dataclass
class GaitGradient(JSONResult):
    """A gait's quantities and their exact derivatives (module docstring). SI units.

    model, names (the parameters), period (steps), fixed_point (z*, model section
    coordinates), residual (|S^k(z*) − z*|_∞ at the runs' tolerance), values (each quantity),
    gradients ({quantity: {parameter: d quantity / d parameter}}), errors (the same layout:
    the multiplier's bound, 0 elsewhere — the exact derivatives' errors are the integration's,
    of order rtol relative), fixed_point_gradient ({coordinate: {parameter: dz*/dp}}),
    multipliers (eigenvalues of ∂S^k/∂z, largest modulus first), jacobian (∂S^k/∂z), runs (the
    stride runs made), fell (why a stride fell, when one did: then no gradients).
    """

    model: str
    names: list[str]
    period: int
    fixed_point: list[float]
    residual: float
    values: dict = field(default_factory=dict)
    gradients: dict = field(default_factory=dict)
    errors: dict = field(default_factory=dict)
    fixed_point_gradient: dict = field(default_factory=dict)
    multipliers: list[complex] = field(default_factory=list)
    jacobian: list[list[float]] = field(default_factory=list)
    runs: int = 0
    fell: str = ""
    #: the smooth description of ρ (module docstring; with ``multiplier``): {"cluster_sum",
    #: "cluster_product", "rest_modulus": value, "gradients": {name: {parameter: d/dp}},
    #: "errors": the same layout, "size": 1 or 2}
    spectrum: dict = field(default_factory=dict)

    def array(self, quantity: str) -> np.ndarray:
        """The gradient of ``quantity`` as an array in the order of :attr:`names`."""
        return np.array([self.gradients[quantity][n] for n in self.names])


@dataclass(frozen=True)
class _Period:
    """One period's chained values and their rows by (z₀, p) (k + q columns)."""

    z_end: np.ndarray
    dz: np.ndarray
    totals: dict[str, float]
    rows: dict[str, np.ndarray]
    runs: int
    fell: str = ""


def _chain(walker: HybridWalker, z: np.ndarray, names: Sequence[str], period: int,
           factor: float = 1.0) -> _Period:
    """The strides of one period from z with their derivatives chained (module docstring)."""
    k, q = len(z), len(names)
    dz = np.hstack([np.eye(k), np.zeros((k, q))])      # ∂z_j/∂(z₀, p)
    lift = np.vstack([dz, np.hstack([np.zeros((q, k)), np.eye(q)])])
    totals = {"duration": 0.0, "step_length": 0.0, "energy_dissipated": 0.0,
              "energy_supplied": 0.0}
    rows = {key: np.zeros(k + q) for key in totals}
    for j in range(period):
        g: StrideGradient = stride_gradient(walker, z, names, factor=factor)
        if g.fell:
            return _Period(z, dz, totals, rows, j + 1, g.fell)
        for key in totals:
            totals[key] += getattr(g, key)
            rows[key] = rows[key] + getattr(g, f"d_{key}") @ lift
        dz = cast(np.ndarray, g.dz) @ lift          # (a stride that did not fall has them)
        lift = np.vstack([dz, lift[k:]])
        z = cast(np.ndarray, g.z_next)
    return _Period(z, dz, totals, rows, period)


def solve_gait(walker: HybridWalker, z: ArrayLike, names: Sequence[str], period: int = 1, *,
               tol: float | None = None, max_iter: int = 12) -> tuple[np.ndarray, _Period, int]:
    """Newton on S^k(z) − z with the exact Jacobian (each iteration one run per stride, which
    also gives the derivatives by ``names``): (z*, the period's values and rows at z*, runs).
    ``tol``: 1e-3 of the walker's gait tolerance by default (at least 1e-12; the gradients'
    accuracy follows the fixed point's), a stall below the gait tolerance accepted. When a
    stride falls or Newton fails, the last period is returned with ``fell`` set (its reason,
    or "no convergence")."""
    tol = max(1e-3 * walker.gait_tolerance, 1e-12) if tol is None else tol
    z = np.asarray(z, dtype=float)
    k = len(z)
    runs = 0
    best = None
    for _ in range(max_iter):
        per = _chain(walker, z, names, period)
        runs += per.runs
        if per.fell:
            return z, per, runs
        F = per.z_end - z
        res = float(np.max(np.abs(F)))
        if res < tol:
            return z, per, runs
        if best is not None and res > 0.5 * best:
            if res < max(tol, walker.gait_tolerance):
                return z, per, runs
            break
        best = res
        try:
            step = np.linalg.solve(per.dz[:, :k] - np.eye(k), F)
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(step)):
            break
        z = z - step
    return z, _Period(z, per.dz, per.totals, per.rows, per.runs, "no convergence"), runs


def _weight(walker: Walker, names: Sequence[str]) -> tuple[float, np.ndarray]:
    """The weight W (N) and dW/dp by central differences (the mass expression and g)."""
    values = np.array([walker.parameters[n] for n in names])

    def weight(v: np.ndarray) -> float:
        return walker.with_parameters(**dict(zip(names, v.tolist()))).weight

    return walker.weight, gradient(weight, values, 1.0).value


def gait_gradient(walker: HybridWalker, z: ArrayLike, names: Sequence[str], period: int = 1, *,
                  multiplier: bool = True, solve: bool = True) -> GaitGradient:
    """The gradients of the gait through (or, with ``solve``, Newton-refined from) the section
    state ``z`` of period ``period`` by the parameters ``names`` (module docstring)."""
    names = list(check_names(walker, names))
    z = np.asarray(z, dtype=float)
    k, q = len(z), len(names)
    if solve:
        z, per, runs = solve_gait(walker, z, names, period)
    else:
        per = _chain(walker, z, names, period)
        runs = per.runs
    out = GaitGradient(walker.name, names, int(period), z.tolist(), math.nan, runs=runs)
    if per.fell:
        out.fell = per.fell
        return out
    out.residual = float(np.max(np.abs(per.z_end - z)))
    A, B = per.dz[:, :k], per.dz[:, k:]
    dzdp = np.linalg.solve(np.eye(k) - A, B)

    def total(key: str) -> tuple[float, np.ndarray]:
        row = per.rows[key]
        return per.totals[key], row[:k] @ dzdp + row[k:]

    T, dT = total("duration")
    L, dL = total("step_length")
    E, dE = total("energy_dissipated")
    W, dW = _weight(walker, names)
    values = {"step_period": T / period, "speed": L / T, "step_length": L / period,
              "energy_dissipated_per_step": E / period, "cost_of_transport": E / (W * L)}
    grads = {"step_period": dT / period, "speed": dL / T - L * dT / T ** 2,
             "step_length": dL / period, "energy_dissipated_per_step": dE / period,
             "cost_of_transport": dE / (W * L) - E * (dW * L + W * dL) / (W * L) ** 2}
    errors = {key: np.zeros(q) for key in grads}
    lam, V = np.linalg.eig(A)
    order = sorted(range(k), key=lambda i: (-abs(lam[i]), -lam[i].imag))
    lam, V = lam[order], V[:, order]
    values["max_multiplier_modulus"] = float(abs(lam[0]))
    if multiplier:
        rates, extra = _jacobian_rates(walker, z, period, names, dzdp)
        out.runs += extra
        d, e = _multiplier_gradient(rates, lam[0], V)
        grads["max_multiplier_modulus"], errors["max_multiplier_modulus"] = d, e
        out.spectrum = _spectrum(A, lam, V, rates, names)
    coords = list(walker.section)
    out.values = {key: float(v) for key, v in values.items()}
    out.gradients = {key: dict(zip(names, map(float, g))) for key, g in grads.items()}
    out.errors = {key: dict(zip(names, map(float, g))) for key, g in errors.items()}
    out.fixed_point_gradient = {c: dict(zip(names, map(float, dzdp[i])))
                                for i, c in enumerate(coords)}
    out.multipliers = [complex(v) for v in lam]
    out.jacobian = A.tolist()
    return out


def _jacobian_rates(walker: HybridWalker, z: np.ndarray, period: int, names: Sequence[str],
                    dzdp: np.ndarray) -> tuple[list[tuple[np.ndarray, np.ndarray] | None], int]:
    """dA/dp_j along the branch by central differences at h and 2h (module docstring): per
    parameter (D(h), D(2h)), None when a shifted stride fell; and the runs made."""
    out: list[tuple[np.ndarray, np.ndarray] | None] = []
    runs = 0
    for j, name in enumerate(names):
        p = walker.parameters[name]
        h = MULTIPLIER_STEP * max(abs(p), 1e-3)
        jac: dict[int, np.ndarray] = {}
        for s in (-2, -1, 1, 2):
            shifted = walker.with_parameters(**{name: p + s * h})
            sj = shifted.stride_sensitivity(z + s * h * dzdp[:, j], period)
            runs += period
            if sj.fell or sj.jacobian is None:          # (None exactly when it fell)
                out.append(None)
                break
            jac[s] = sj.jacobian
        else:
            out.append(((jac[1] - jac[-1]) / (2 * h), (jac[2] - jac[-2]) / (4 * h)))
    return out, runs


def _extrapolated(rates: list[tuple[np.ndarray, np.ndarray] | None],
                  rate: Callable[[np.ndarray], float]) -> tuple[np.ndarray, np.ndarray]:
    """A scalar's derivative by each parameter from its rate ``rate(dA)`` at D(h) and D(2h):
    (4 r(h) − r(2h)) / 3 and the bound |r(h) − r(2h)| (NaN and inf where a stride fell)."""
    out, err = np.full(len(rates), math.nan), np.full(len(rates), math.inf)
    for j, pair in enumerate(rates):
        if pair is not None:
            r1, r2 = rate(pair[0]), rate(pair[1])
            out[j], err[j] = (4 * r1 - r2) / 3, abs(r1 - r2)
    return out, err


def _modulus_rate(lam: complex, v: np.ndarray, w: np.ndarray) -> Callable[[np.ndarray], float]:
    """d|λ| = Re(λ̄ dλ)/|λ| with dλ = wᴴ dA v / (wᴴ v) (a simple eigenvalue)."""
    scale = complex(np.vdot(w, v))

    def rate(D: np.ndarray) -> float:
        dlam = complex(np.vdot(w, D @ v)) / scale
        return float((np.conj(lam) * dlam).real / abs(lam))

    return rate


def _multiplier_gradient(rates: list[tuple[np.ndarray, np.ndarray] | None], lam: complex,
                         V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(dρ/dp, its error bound) by the module docstring's scheme."""
    try:
        w = np.linalg.inv(V).conj().T[:, 0]         # the left eigenvector, wᴴ v = 1
    except np.linalg.LinAlgError:
        return np.full(len(rates), math.nan), np.full(len(rates), math.inf)
    return _extrapolated(rates, _modulus_rate(lam, V[:, 0], w))


def _spectrum(A: np.ndarray, lam: np.ndarray, V: np.ndarray,
              rates: list[tuple[np.ndarray, np.ndarray] | None],
              names: Sequence[str]) -> dict:
    """The cluster's sum and product and the rest's largest modulus, with their derivatives
    (module docstring); ``lam``, V: A's eigenvalues, largest modulus first, and eigenvectors."""
    import scipy.linalg as sl

    k = len(lam)
    complex_top = abs(lam[0].imag) > 1e-12 * abs(lam[0])
    size = 2 if k > 1 and (complex_top or abs(lam[1].imag) <= 1e-12 * abs(lam[1])) else 1
    values: dict[str, float] = {}
    grads: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    if size == 2:
        cut = 0.5 * (abs(lam[1]) + abs(lam[2])) if k > 2 else 0.0
        T, Z, sdim = sl.schur(A, output="real",
                              sort=lambda re, im: math.hypot(re, im) > cut)
        if sdim != 2:                       # the cluster cannot be split off: a lone top
            size = 1
    if size == 2:
        T11, X = T[:2, :2], Z[:, :2]
        R = sl.solve_sylvester(T11, -T[2:, 2:], T[:2, 2:]) if k > 2 else np.zeros((2, 0))
        Yt = np.hstack([np.eye(2), R]) @ Z.T
        adj = np.array([[T11[1, 1], -T11[0, 1]], [-T11[1, 0], T11[0, 0]]])
        values["cluster_sum"] = float(np.trace(T11))
        values["cluster_product"] = float(np.linalg.det(T11))
        grads["cluster_sum"] = _extrapolated(rates, lambda D: float(np.trace(Yt @ D @ X)))
        grads["cluster_product"] = _extrapolated(
            rates, lambda D: float(np.trace(adj @ (Yt @ D @ X))))
    else:
        W = np.linalg.inv(V).conj().T
        top = float(lam[0].real)

        def real_rate(D: np.ndarray) -> float:
            return float((np.vdot(W[:, 0], D @ V[:, 0]) / np.vdot(W[:, 0], V[:, 0])).real)

        values["cluster_sum"], values["cluster_product"] = 2 * top, top ** 2
        grads["cluster_sum"] = _extrapolated(rates, lambda D: 2 * real_rate(D))
        grads["cluster_product"] = _extrapolated(rates, lambda D: 2 * top * real_rate(D))
    if k > size:
        i = size
        W = np.linalg.inv(V).conj().T
        values["rest_modulus"] = float(abs(lam[i]))
        grads["rest_modulus"] = _extrapolated(rates, _modulus_rate(lam[i], V[:, i], W[:, i]))
    else:
        values["rest_modulus"] = 0.0
        grads["rest_modulus"] = (np.zeros(len(names)), np.zeros(len(names)))
    return {**values, "size": size,
            "gradients": {key: dict(zip(names, map(float, g[0]))) for key, g in grads.items()},
            "errors": {key: dict(zip(names, map(float, g[1]))) for key, g in grads.items()}}

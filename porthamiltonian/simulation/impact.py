"""Rigid plastic impact: the generic impact map of a multibody. Numeric, no sympy.

A plastic (no-slip, no-bounce) impact imposes, instantaneously, the velocity constraints
G(q) v⁺ = 0 (e.g. the new stance foot stops), with the configuration q unchanged. Impulse–momentum
with the constraint impulse Λ (one entry per constrained velocity, N s) gives

    M(q) (v⁺ − v⁻) = Gᵀ Λ,    G v⁺ = 0
    ⇒ Λ = −(G M⁻¹ Gᵀ)⁻¹ G v⁻,   v⁺ = v⁻ − M⁻¹ Gᵀ (G M⁻¹ Gᵀ)⁻¹ G v⁻,   p⁺ = M v⁺,

and the kinetic energy lost ΔT = T⁻ − T⁺ = ½ (v⁻ − v⁺)ᵀ M (v⁻ − v⁺) ≥ 0 (Kelvin's theorem: the
plastic impact removes exactly the kinetic energy of the velocity jump). Nothing is inverted:
the map is evaluated with linear solves. Two forms:

* ``"kkt"`` (default): the saddle-point system [[M, Gᵀ], [G, 0]] [v⁺; −Λ] = [M v⁻; 0], the same
  map without M⁻¹, symmetrically scaled by D = diag(M)^-½. Exact to round-off for Garcia's mass
  ratio of 1e-9 (checked against 50-digit arithmetic), and valid for a singular M (a coordinate
  with neither mass nor inertia, e.g. the spokes of a rimless wheel whose mass sits at the hub)
  as long as M is positive definite on the null space of G;
* ``"schur"``: the formula above with Cholesky solves of the scaled M and one step of iterative
  refinement (G M⁻¹ Gᵀ has a condition number ~ M/m for light feet).

:func:`model_impact` applies the map to a state of a compiled multibody model, reading the named
matrices ``<name>.M`` and ``<name>.J.<point>`` (see :mod:`porthamiltonian.mechanics.multibody`);
:func:`impact_jacobian` gives its Jacobian ∂x⁺/∂x⁻ (for the saltation matrix of a run with
sensitivities): the momentum columns exactly — for a fixed configuration the map is linear in
the momenta, p⁺ = M Π M⁻¹ p⁻ (Π the projection above), so its columns are the map of unit
momenta — and the configuration columns (through M(q) and G(q)) by central differences with an
error estimate (:mod:`porthamiltonian.simulation.differences`).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ModelError, StateError
from .differences import Derivative, jacobian

if TYPE_CHECKING:
    from .compiled import CompiledModel

__all__ = ["ImpactResult", "ModelImpact", "impact_jacobian", "model_impact", "plastic_impact"]


@dataclass(frozen=True)
class ImpactResult:
    """Result of :func:`plastic_impact` (SI units of the model's coordinates).

    v_plus, p_plus : generalized velocities and momenta just after the impact.
    impulse : constraint impulse Λ (N s for a point constraint), p⁺ − p⁻ = Gᵀ Λ.
    T_minus, T_plus : kinetic energy before and after (J); energy_lost = T_minus − T_plus ≥ 0.
    constraint_velocity : G v⁺ (zero up to round-off).
    """

    v_plus: np.ndarray
    p_plus: np.ndarray
    impulse: np.ndarray
    T_minus: float
    T_plus: float
    energy_lost: float
    constraint_velocity: np.ndarray


def plastic_impact(M: np.ndarray, G: np.ndarray, v_minus: np.ndarray,
                   method: str = "kkt") -> ImpactResult:
    """Plastic impact map v⁻ -> v⁺ for mass matrix ``M`` (n x n) and constraint Jacobian ``G``
    (k x n, the velocities G v that must vanish after the impact). See the module docstring.

    ``method``: ``"kkt"`` (default) solves the symmetrically scaled saddle-point system; it is
    exact to round-off even for mass ratios of 1e-9 and for a singular M. ``"schur"`` evaluates
    v⁻ − M⁻¹Gᵀ(G M⁻¹ Gᵀ)⁻¹ G v⁻ with Cholesky solves plus one step of iterative refinement (for
    light feet G M⁻¹ Gᵀ has a condition number ~ M/m: without the refinement, G v⁺ ≈ 1e-8 was
    measured at m/M = 1e-9); it needs M positive definite.
    """
    M = np.atleast_2d(np.asarray(M, dtype=float))
    G = np.atleast_2d(np.asarray(G, dtype=float))
    v = np.asarray(v_minus, dtype=float).reshape(-1)
    n, k = len(v), G.shape[0]
    if M.shape != (n, n) or G.shape[1] != n:
        raise ModelError(f"plastic_impact: M must be {n}x{n} and G k x {n}, got {M.shape} and {G.shape}")
    if method not in ("kkt", "schur"):
        raise ModelError(f"plastic_impact: method must be 'kkt' or 'schur', got {method!r}")
    if not (np.all(np.isfinite(M)) and np.all(np.isfinite(G)) and np.all(np.isfinite(v))):
        raise StateError("plastic_impact: non-finite mass matrix, Jacobian or velocity")
    M = 0.5 * (M + M.T)
    diag = np.diag(M).copy()
    scale = np.where(diag > 0, 1.0 / np.sqrt(np.where(diag > 0, diag, 1.0)), 1.0)
    Ms = M * scale[:, None] * scale[None, :]          # D M D, D = diag(M)^-1/2
    Gs = G * scale[None, :]
    w = v / scale                                     # v = D w
    if method == "kkt":
        K = np.block([[Ms, Gs.T], [Gs, np.zeros((k, k))]])
        try:
            sol = np.linalg.solve(K, np.concatenate([Ms @ w, np.zeros(k)]))
        except np.linalg.LinAlgError:
            raise StateError("plastic_impact: the constrained impact problem is singular (the mass "
                             "matrix is not positive definite on the constraint's null space, or "
                             "the constraints are dependent)") from None
        w_plus, lam = sol[:n], -sol[n:]
    else:
        import scipy.linalg as sl  # here: importing scipy.linalg takes ~0.3 s

        try:
            cho = sl.cho_factor(Ms, lower=True, check_finite=False)
        except np.linalg.LinAlgError:
            raise StateError("plastic_impact: method 'schur' needs a positive definite mass "
                             "matrix; use method 'kkt'") from None
        X = sl.cho_solve(cho, Gs.T, check_finite=False)      # M⁻¹ Gᵀ (scaled)
        S = Gs @ X                                           # G M⁻¹ Gᵀ
        lam = -np.linalg.solve(S, Gs @ w)
        w_plus = w + X @ lam
        correction = np.linalg.solve(S, Gs @ w_plus)         # one refinement step
        lam, w_plus = lam - correction, w_plus - X @ correction
    v_plus = w_plus * scale
    p_plus = M @ v_plus
    T_minus = 0.5 * float(v @ M @ v)
    T_plus = 0.5 * float(v_plus @ M @ v_plus)
    dv = v - v_plus
    lost = 0.5 * float(dv @ M @ dv)          # = T⁻ − T⁺ when G v⁺ = 0; never negative
    return ImpactResult(v_plus, p_plus, lam, T_minus, T_plus, lost, G @ v_plus)


@dataclass(frozen=True)
class ModelImpact:
    """Result of :func:`model_impact`: the impact and the model state just after it."""

    x_plus: np.ndarray
    v_minus: np.ndarray
    impact: ImpactResult


def model_impact(model: CompiledModel, x: np.ndarray, p: np.ndarray, constraints: Sequence[str],
                 mass_matrix: str = "walker.M", t: float = 0.0, method: str = "kkt",
                 v_minus: np.ndarray | None = None) -> ModelImpact:
    """Plastic impact of a compiled multibody ``model`` at state ``x`` with parameters ``p``.

    ``constraints`` names the point Jacobians whose velocities vanish after the impact (e.g.
    ``["walker.J.foot2"]``; several are stacked). ``mass_matrix`` names the mass matrix; its
    multibody's momentum states ``<name>.p.*`` (in coordinate order) are replaced by p⁺ = M v⁺.
    The velocities before the impact are solved from the momenta, M v⁻ = p⁻, unless given as
    ``v_minus`` (needed when M is singular, e.g. a coordinate without mass or inertia).
    """
    if not constraints:
        raise ModelError("model_impact needs at least one constraint Jacobian name")
    prefix = mass_matrix.rsplit(".M", 1)[0]
    if not mass_matrix.endswith(".M"):
        raise ModelError(f"model_impact: {mass_matrix!r} is not a mass matrix name '<multibody>.M'")
    p_states = [i for i, s in enumerate(model.state_names) if s.startswith(prefix + ".p.")]
    x = np.asarray(x, dtype=float)
    M = model.matrix(mass_matrix, t, x, p)
    if len(p_states) != M.shape[0]:
        raise ModelError(f"model_impact: {len(p_states)} momentum states '{prefix}.p.*' for a "
                         f"{M.shape[0]}x{M.shape[0]} mass matrix")
    G = np.vstack([model.matrix(name, t, x, p) for name in constraints])
    if v_minus is None:
        try:
            v_minus = np.linalg.solve(M, x[p_states])
        except np.linalg.LinAlgError:
            raise StateError(f"model_impact: mass matrix {mass_matrix} is singular at this state; "
                             "pass the velocities as v_minus") from None
    v_minus = np.asarray(v_minus, dtype=float)
    result = plastic_impact(M, G, v_minus, method)
    x_plus = x.copy()
    x_plus[p_states] = result.p_plus
    return ModelImpact(x_plus, v_minus, result)


def impact_jacobian(model: CompiledModel, x: np.ndarray, p: np.ndarray, constraints: Sequence[str],
                    mass_matrix: str = "walker.M", t: float = 0.0,
                    method: str = "kkt") -> Derivative:
    """∂x⁺/∂x⁻ (n x n) of :func:`model_impact` at state ``x`` (same arguments; the velocities
    are solved from the momenta, so M must be regular), with an estimate of its error per entry.

    The configuration is unchanged (identity rows), states outside the multibody too; the
    momentum rows: exact in the momentum columns (the map of unit momenta, linear for a fixed
    configuration), by central differences in the configuration columns (each coordinate stepped
    by ε^(1/3) max(|q_j|, 1), the error estimated from the steps h and 2h; ~1e-10 of the momenta
    for a smooth M(q), G(q))."""
    x = np.asarray(x, dtype=float)
    prefix = mass_matrix.rsplit(".M", 1)[0]
    names = model.state_names
    q_states = [i for i, s in enumerate(names) if s.startswith(prefix + ".q.")]
    p_states = [i for i, s in enumerate(names) if s.startswith(prefix + ".p.")]
    n = len(x)
    value, error = np.eye(n), np.zeros((n, n))
    base = x.copy()
    for j in p_states:                          # the map of the unit momentum of state j
        base[p_states] = 0.0
        base[j] = 1.0
        value[p_states, j] = model_impact(model, base, p, constraints, mass_matrix, t,
                                          method).x_plus[p_states]
    error[np.ix_(p_states, p_states)] = 16 * np.finfo(float).eps * np.max(
        np.abs(value[np.ix_(p_states, p_states)]))

    def momenta(q: np.ndarray) -> np.ndarray:
        xq = x.copy()
        xq[q_states] = q
        return model_impact(model, xq, p, constraints, mass_matrix, t, method).x_plus[p_states]

    d = jacobian(momenta, x[q_states], 1.0)
    value[np.ix_(p_states, q_states)] = d.value
    error[np.ix_(p_states, q_states)] = d.error
    return Derivative(value, error)

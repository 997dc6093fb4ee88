"""The equations of a multibody with closed loops and constraints (:mod:`.closure`'s rows).

With the tree's coordinates q, momenta p, velocities v (M(q) v = p), the constraint rows
G(q) v = 0 (m rows; the holonomic ones also φ(q) = 0) and their switches s_i ∈ {0, 1} (a row is
active when s_i = 1), the constrained port-Hamiltonian system is

    q̇ = K(q) v,   ṗ = f(q, p, e) + Gᵀ S λ,   0 = S G v   (S = diag(s)),

f the tree's own momentum rates (the velocity terms, gravity, the ports' efforts e) and λ the
multipliers: the constraint forces and torques, which do no work (λᵀ S G v = 0), so H's ledger
needs no new term. λ comes from the index-reduced equations — the velocity constraint
differentiated once, d(Gv)/dt = G a + Ġ v = 0 with the accelerations a = v̇ = M⁻¹(ṗ − Ṁ v) —
as the saddle-point system, solved numerically in the generated code (never inverted
symbolically):

    [ M    GᵀS ] [ a ]   [ f − Ṁ v            ]
    [ S G  1−S ] [ ν ] = [ −S (Ġ v + γ G v)   ],   λ = −ν.

Ṁ v and Ġ v are the velocity products: the time derivatives of M and G along q̇ = K(q) v,
times v. Ṁ v comes from one recursive pass over the tree (Newton–Euler's velocity-product
forces, :meth:`.tree.Tree.velocity_products`: O(N) code, where differentiating M's N² entries
grew the code of a long chain by about as much again as the tree's own); Ġ v, a few rows per
constraint, by forward-mode differentiation of G's entries
(:class:`porthamiltonian.modeling.differentiation.Rates`, through the tree's intermediates). An
inactive row reads ν_i = 0 and drops out, so the matrix stays regular when a walker's rule
switches a constraint off.

Drift. An integrator keeps G v = 0 and φ = 0 only to its tolerance, and the errors add up over a
long run. The manifold {φ = 0, G v = 0} is made attracting, with the flow on it unchanged
(the stabilized index reduction of Ascher, Chin, Petzold & Reich, *Mech. Struct. Mach.* 23 (1995)
135–158: ẋ = f̃(x) − γ F(x) h(x) with h = (φ, G v) and F the pseudo-inverse in the mass metric):

* velocities: the term −γ S G v above gives ṗ an extra −γ Gᵀ (G M⁻¹ Gᵀ)⁻¹ G v, the
  M-orthogonal projection of the momenta onto G v = 0 at rate γ; its power
  −γ (Gv)ᵀ (G M⁻¹ Gᵀ)⁻¹ (Gv) is never positive: it removes only the kinetic energy of the
  velocity error (the energy-consistent correction);
* positions: q̇ = K(q) (v + γ Δv) with Δv the M-smallest correction of the holonomic residual,
  [M GᵀS; SG 1−S] [Δv; μ] = [0; −S φ] (zero for the velocity-level rows) — the Gauss–Newton step
  of the mass-metric projection onto φ = 0, taken at rate γ.

γ (``constraint_gain``, 1/s) sets how fast an error decays; both terms vanish on the manifold,
so the solution there is the constrained motion whatever γ is. The error an integration step
leaves decays as e^{−γ t}: |φ| and |G v| settle near (error per unit time) / γ. The
linearization of a constrained model has the eigenvalue −γ once per row (and once more per
holonomic row) beside the constrained motion's own.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import sympy as sp

from ..errors import ModelError
from ..modeling.component import Builder, PHCut
from ..modeling.differentiation import Rates
from .closure import Row


def _saddle(M: sp.Matrix, G: sp.Matrix, active: Sequence) -> sp.Matrix:
    """[[M, GᵀS], [SG, 1 − S]] with the rows' switches S = diag(active)."""
    n, m = M.shape[0], G.shape[0]
    A = sp.zeros(n + m, n + m)
    A[:n, :n] = M
    for i in range(m):
        for k in range(n):
            if G[i, k] != 0:
                A[k, n + i] = A[n + i, k] = active[i] * G[i, k]
        A[n + i, n + i] = 1 - active[i]
    return A


def constrain(b: Builder, rows: Sequence[Row], q: Sequence, v: Sequence, M: sp.Matrix,
              products: Callable[[], Sequence], Q: list, rates: list,
              kinematics: Callable[[Sequence], list], gain: Any,
              where: str) -> tuple[list, list]:
    """The constrained coordinate rates and momentum rates (see the module docstring) of a
    multibody with coordinates ``q``, velocities ``v``, mass matrix ``M``, momentum rates ``Q``
    (with the ports' loads) and coordinate rates ``rates``; ``products()`` forms the velocity
    products Ṁ v (:meth:`.tree.Tree.velocity_products`; not needed by the port-Hamiltonian
    form's cut build) and ``kinematics(w)`` is K(q) w. Declares
    the blocks, the outputs ``reaction.<constraint>.<row>`` (the multipliers: N, N m),
    ``phi.<constraint>.<row>`` (the holonomic residuals), ``active.<constraint>`` and the
    matrices ``G`` (all rows), ``G.<constraint>`` (for impacts) and ``S`` (the rows' switches,
    m x 1: read by the rank check before anything solves with the rows). ``where`` names the
    multibody in errors."""
    n, m = len(v), len(rows)
    G = _matrix(rows, n, where)
    active = [r.active for r in rows]
    A = _saddle(M, G, active)
    holonomic = any(r.holonomic for r in rows)
    if b.ph is not None:
        return _cut_build(b, b.ph, rows, G, Q, rates, kinematics, gain, holonomic)
    if holonomic and gain != 0:
        phi = [0] * n + [-s * r.phi if r.holonomic else 0 for s, r in zip(active, rows)]
        dv = b.implicit("correction", A, sp.Matrix(phi))[:n]
        rates = [a + c for a, c in zip(rates, kinematics([gain * d for d in dv]))]
    Gdot_v, Gv = _velocity_terms(b, G, q, v, kinematics)
    Mv = products()
    f = [b.intermediate(f"mb.f{k}", Q[k]) for k in range(n)]
    rhs = [f[k] - Mv[k] for k in range(n)]
    rhs += [-s * (gd + gain * gv) for s, gd, gv in zip(active, Gdot_v, Gv)]
    nu = b.implicit("acc", A, sp.Matrix(rhs))[n:]
    lam = [-x for x in nu]
    Q = [f[k] + sp.Add(*[G[i, k] * active[i] * lam[i] for i in range(m) if G[i, k] != 0])
         for k in range(n)]
    _declare(b, rows, G, lam, Gv)
    return rates, Q


def constrain_kernel(b: Builder, rows: Sequence[Row], q: Sequence, v: Sequence,
                     Q: list, rates: list, kinematics: Callable[[Sequence], list], gain: Any,
                     where: str, solve: Callable[[list, int, list], list]
                     ) -> tuple[list, list]:
    """:func:`constrain` for a tree evaluated by the kernel (:mod:`.kernel`): the same equations,
    the saddle-point systems solved at run time by the kernel's ``mb_constrained`` entry
    (``solve(inputs, m, pattern)``, :meth:`.kernel_tables.KernelTree.constrained`) on the kernel's
    factorisation of M — Y = M⁻¹ (SG)ᵀ, a₀ = M⁻¹ (f − Ṁ v), the m x m Schur complement
    SG Y − (1 − S), ν = (SG Y − (1 − S))⁻¹ (SG a₀ − r), and the position correction from the same
    complement — with its Jacobian by implicit differentiation inside the kernel. Only the rows'
    φ, G and Ġ v are written out (from the tree's positions); the kernel's inputs are
    (q, v, f, SG (G's structural nonzeros, row by row: ``pattern``), 1 − S,
    r = −S (Ġ v + γ G v), S φ), its outputs (ṗ = f + Gᵀ S λ, λ, Δv)."""
    n, m = len(v), len(rows)
    G = _matrix(rows, n, where)
    active = [r.active for r in rows]
    Gdot_v, Gv = _velocity_terms(b, G, q, v, kinematics)
    correct = gain != 0 and any(r.holonomic for r in rows)

    def named(name: str, expr: Any) -> Any:
        return b.intermediate(f"mb.{name}", expr)

    f = [named(f"f{k}", Q[k]) for k in range(n)]
    pattern = [(i, k) for i in range(m) for k in range(n) if G[i, k] != 0]
    SG = [named(f"SG.{i}.{k}", active[i] * G[i, k]) for i, k in pattern]
    free = [named(f"free{i}", 1 - s) for i, s in enumerate(active)]
    r = [named(f"bias{i}", -s * (gd + gain * gv)) for i, (s, gd, gv)
         in enumerate(zip(active, Gdot_v, Gv))]
    h = [named(f"residual{i}", s * row.phi) if correct and row.holonomic else sp.S.Zero
         for i, (s, row) in enumerate(zip(active, rows))]
    out = solve([*q, *v, *f, *SG, *free, *r, *h], m, pattern)
    lam, dv = out[n:n + m], out[n + m:]
    if correct:
        rates = [a + c for a, c in zip(rates, kinematics([gain * d for d in dv]))]
    _declare(b, rows, G, lam, Gv)
    return rates, list(out[:n])


def _matrix(rows: Sequence[Row], n: int, where: str) -> sp.Matrix:
    """G (m x n) of the rows; more rows than velocities is refused."""
    m = len(rows)
    if m > n:
        raise ModelError(f"{where}: {m} constraint rows ({_listing(rows)}) on {n} velocities: "
                         "more constraints than degrees of freedom, at least "
                         f"{m - n} of them redundant or inconsistent; remove some")
    return sp.Matrix(m, n, lambda i, k: rows[i].G[k])


def _velocity_terms(b: Builder, G: sp.Matrix, q: Sequence, v: Sequence,
                    kinematics: Callable[[Sequence], list]) -> tuple[list, list]:
    """(Ġ v, G v): Ġ by forward-mode differentiation of G's entries along q̇ = K(q) v."""
    m, n = G.shape
    direction = dict(zip(q, kinematics(v)))
    rate = Rates(direction, b.built.intermediates, b.intermediate,
                 lambda w: str(w)[len(b.name) + 1:])
    Gdot_v = [sp.Add(*[rate(G[i, k]) * v[k] for k in range(n) if G[i, k] != 0])
              for i in range(m)]
    Gv = [sp.Add(*[G[i, k] * v[k] for k in range(n) if G[i, k] != 0]) for i in range(m)]
    return Gdot_v, Gv


def _cut_build(b: Builder, cut: PHCut, rows: Sequence[Row], G: sp.Matrix, Q: list, rates: list,
               kinematics: Callable[[Sequence], list], gain: Any,
               holonomic: bool) -> tuple[list, list]:
    """The port-Hamiltonian form's cut build: the multipliers are imposed efforts (sources)
    whose conjugate flows are the constraint velocities S G η_p (zero on the manifold, so they
    supply no power); the position correction γ K Δv is an imposed coordinate rate whose
    conjugate is Kᵀ η_q."""
    n, m = len(Q), len(rows)
    eta = [cut.eta(s) for s in _states(b, "p.")]
    eta_q = [cut.eta(s) for s in _states(b, "q.")]
    Q = list(Q)
    lam = []
    for i, row in enumerate(rows):
        value = -sp.Symbol(f"{b.name}.acc{n + i}", real=True)
        conjugate = sp.Add(*[row.active * G[i, k] * eta[k] for k in range(n) if G[i, k] != 0])
        u = b.source(value, conjugate, f"reaction.{row.constraint}.{row.label}")
        lam.append(u)
        for k in range(n):
            if G[i, k] != 0:
                Q[k] = Q[k] + row.active * G[i, k] * u
    if holonomic and gain != 0:
        columns = [kinematics([1 if j == k else 0 for j in range(n)]) for k in range(n)]
        shift = []
        for k in range(n):
            value = gain * sp.Symbol(f"{b.name}.correction{k}", real=True)
            conjugate = sp.Add(*[c * e for c, e in zip(columns[k], eta_q) if c != 0])
            shift.append(b.source(value, conjugate, f"correction.{k}"))
        rates = [a + c for a, c in zip(rates, kinematics(shift))]
    _declare(b, rows, G, lam, [0] * m)
    return rates, Q


def _states(b: Builder, prefix: str) -> list[sp.Symbol]:
    return [s.symbol for s in b.built.states if str(s.symbol).startswith(f"{b.name}.{prefix}")]


def _declare(b: Builder, rows: Sequence[Row], G: sp.Matrix, lam: Sequence, Gv: Sequence) -> None:
    """The outputs and matrices of the rows (see :func:`constrain`)."""
    seen: dict[str, list[int]] = {}
    for i, row in enumerate(rows):
        seen.setdefault(row.constraint, []).append(i)
        b.output(f"reaction.{row.constraint}.{row.label}", lam[i])
        b.output(f"velocity.{row.constraint}.{row.label}", Gv[i])
        if row.holonomic:
            b.output(f"phi.{row.constraint}.{row.label}", row.phi)
    for name, indices in seen.items():
        b.output(f"active.{name}", rows[indices[0]].active, "1")
        b.matrix(f"G.{name}", G.extract(indices, list(range(G.shape[1]))))
    b.matrix("G", G)
    b.matrix("S", sp.Matrix([row.active for row in rows]))


def _listing(rows: Sequence[Row]) -> str:
    names: dict[str, int] = {}
    for r in rows:
        names[r.constraint] = names.get(r.constraint, 0) + 1
    return ", ".join(f"{k}: {c}" for k, c in names.items())


__all__ = ["constrain", "constrain_kernel"]

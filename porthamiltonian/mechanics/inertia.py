"""Which rotational inertias a rigid body can have, checked on numbers and on the values that
parameters take at run time.

A body's inertia about its centre of mass is I = tr(Σ) 1 − Σ, with Σ = ∫ r rᵀ dm the second
moment of its mass distribution, which is symmetric positive semi-definite. So I is *physically
consistent* exactly when Σ = ½ tr(I) 1 − I is positive semi-definite: in principal moments, the
triangle inequality I₁ + I₂ ≥ I₃ (each way round), which implies I ⪰ 0. A thin rod (one moment
0, the other two equal) and a point mass (I = 0) pass; a negative moment, an indefinite matrix,
or moments like [1, 1, 3] (no mass distribution has them) do not. A body that rotates freely
(a :class:`~porthamiltonian.mechanics.free_body.FreeBody`) needs I positive definite as well (its
twist is solved from 𝕀 T = P). In a planar multibody (the x-z plane) only I_yy enters the
equations; it must be ≥ 0.

:func:`numeric_problem` checks a matrix of numbers; :func:`require_consistent` declares the same
rule as constraints on the entries' expressions (:meth:`~porthamiltonian.modeling.component.
Builder.require`), checked whenever parameter values are bound, the component and the body named.
"""
from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import Any

import numpy as np
import sympy as sp

from ..errors import ModelError

__all__ = ["numeric_problem", "require_consistent"]

#: relative slack of the inequalities (a plate's I_zz = I_xx + I_yy computed in floats)
_SLACK = 1e-12
_AXES = ("xx", "yy", "zz")


def numeric_problem(inertia: np.ndarray, *, definite: bool = False, planar: bool = False) -> str | None:
    """What is wrong with the 3x3 inertia of numbers ``inertia`` (module docstring), or None.
    ``definite``: also positive definite (a free body); ``planar``: only I_yy ≥ 0 counts."""
    if not np.all(np.isfinite(inertia)):
        return f"inertia must be finite numbers, got {inertia.tolist()}"
    if not np.allclose(inertia, inertia.T, rtol=1e-12, atol=0.0):
        return f"inertia must be symmetric, got {inertia.tolist()}"
    if planar:
        return None if inertia[1, 1] >= 0 else (
            f"inertia I_yy (about the plane's normal) must be >= 0, got {inertia[1, 1]:g}")
    eig = np.linalg.eigvalsh(inertia)
    scale = float(np.sum(np.abs(eig)))
    shown = np.round(eig, 12).tolist()
    if definite and not eig.min() > 0:
        return (f"rotational inertia must be symmetric positive definite, got eigenvalues "
                f"{shown}")
    if eig.max() > eig.sum() / 2 + _SLACK * scale:
        return (f"rotational inertia must be physically consistent (symmetric positive "
                f"semi-definite, its principal moments obeying the triangle inequality I1 + I2 >= "
                f"I3: no mass distribution has moments like [1, 1, 3]), got eigenvalues {shown}")
    return None


def require_consistent(b: Any, rows: Sequence[Sequence[sp.Expr]], what: str, *,
                       definite: bool = False, planar: bool = False) -> None:
    """Declare on the builder ``b`` the constraints that make the inertia ``rows`` (3x3
    expressions) physically consistent, for ``what`` (``"body 'leg' inertia"``): the triangle
    inequalities of the principal moments (for a diagonal inertia; else the principal minors of
    Σ = ½ tr(I) 1 − I), with ``definite`` the moments (leading minors) > 0, with ``planar``
    I_yy ≥ 0 only. Entries that differ across the diagonal raise a ModelError now."""
    I_c = sp.Matrix(rows)
    for i, j in ((0, 1), (0, 2), (1, 2)):
        if sp.simplify(I_c[i, j] - I_c[j, i]) != 0:
            raise ModelError(f"{what} must be symmetric: I_{_AXES[i][0]}{_AXES[j][0]} = "
                             f"{I_c[i, j]} but I_{_AXES[j][0]}{_AXES[i][0]} = {I_c[j, i]}")
    if planar:
        b.require(I_c[1, 1], ">=", f"{what} I_yy")
        return
    diagonal = all(I_c[i, j] == 0 for i in range(3) for j in range(3) if i != j)
    if diagonal:
        moments = [I_c[k, k] for k in range(3)]
        for k in range(3):
            i, j = (m for m in range(3) if m != k)
            b.require(moments[i] + moments[j], ">=", f"{what} I_{_AXES[i]} + I_{_AXES[j]} "
                      "(triangle inequality)", moments[k] * (1 - _SLACK), f"I_{_AXES[k]}")
        if definite:
            for k in range(3):
                b.require(moments[k], ">", f"{what} I_{_AXES[k]}")
        return
    sigma = I_c.trace() / 2 * sp.eye(3) - I_c
    for size in (1, 2, 3):
        for idx in itertools.combinations(range(3), size):
            minor = sp.expand(sigma.extract(list(idx), list(idx)).det())
            b.require(minor, ">=", f"{what}: principal minor {''.join(map(str, idx))} of "
                      "tr(I)/2 - I (triangle inequality of the principal moments)",
                      -_SLACK * I_c.trace() ** size, "0")
    if definite:
        for size in (1, 2, 3):
            b.require(sp.expand(I_c[:size, :size].det()), ">",
                      f"{what}: leading minor {size} (positive definite)")

"""The Poisson structure of a multibody in the coordinates (q, p) it compiles to.

With H(q, p) = ½ pᵀ M(q)⁻¹ p + V(q) and v = ∂H/∂p = M⁻¹ p, a multibody's state equations are

    q̇ = K(q) v,    ṗ = −K(q)ᵀ ∂H/∂q + J_pp(p) v + Q_ports,

K the kinematic map of the coordinates (the identity for revolute, prismatic, translational and
universal joints, whose coordinates are canonical; q̇ = ½ q ⊗ (0, ω) and ṙ = R v for a quaternion
joint's quasi-velocities) and J_pp the gyroscopic (Lie–Poisson) block: zero for canonical
coordinates, [L]× for the angular momentum L of a spherical joint from the world (L̇ = L × ω + …),
and ad_Tᵀ P = (L × ω + p × v, p × ω) for a free joint from the world. So J = [[0, K], [−Kᵀ,
J_pp]] is skew by construction; the compiled equations (the recursive ∂T/∂q|_v − ∂V/∂q of
:mod:`.tree`) must equal it applied to the exact ∇H, which the port-Hamiltonian form's checks
verify numerically (porthamiltonian/compiler/phform.py).

Only quaternion joints from the world are derived (their J_pp is the joint's own Lie–Poisson
block); deeper ones raise. The quaternion's stabilising term (along q, zero on |q| = 1) is not
part of the structure: the form holds on the physical configurations |q| = 1.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import sympy as sp

from ..errors import ModelError
from ..modeling.differentiation import derivative
from .joints import Joint
from .kinematics import cross


def poisson_rates(specs: Sequence[Joint], joints: Mapping[str, Any], rates: Sequence,
                  q: Sequence, p: Sequence, eta_q: Sequence, eta_p: Sequence,
                  where: str) -> list:
    """ṗ without the ports' loads in the port-Hamiltonian form's cut build: −K(q)ᵀ η_q +
    J_pp(p) η_p, with ``rates`` = K(q) η_p (the coordinate rates of the velocities η_p, without
    the quaternion's stabilising term) and η_q, η_p the symbols of ∂H/∂q, ∂H/∂p."""
    out = []
    for k in range(len(p)):
        out.append(-sp.Add(*[derivative(rate, eta_p[k]) * eta for rate, eta in zip(rates, eta_q)]))
    start = 0
    for spec in specs:
        index = list(range(start, start + len(spec.velocities)))
        start += len(spec.velocities)
        if spec.type not in ("spherical", "free"):
            continue
        if joints[spec.name].get("parent") != "world":
            raise ModelError(f"{where}: the port-Hamiltonian form of a quaternion joint below the "
                             f"root ({spec.name!r}) is not derived; only spherical and free "
                             "joints from the world are")
        L, w = [p[i] for i in index[:3]], [eta_p[i] for i in index[:3]]
        gyro = cross(L, w)                                   # L × ω
        if spec.type == "free":
            lin, v = [p[i] for i in index[3:]], [eta_p[i] for i in index[3:]]
            gyro = [a + c for a, c in zip(gyro, cross(lin, v))] + cross(lin, w)   # + p × v; p × ω
        for i, term in zip(index, gyro):
            out[i] = out[i] + term
    return out


__all__ = ["poisson_rates"]

"""The compliant-leg walker's standing check: the static compression of a stance leg's spring.

A compliant-leg walker (models/compliant_leg_walker.toml, a spring of stiffness K on a prismatic
joint along each leg) standing on one leg carries the weight above the stance spring — the hip,
both legs and the swing foot, (M + 2 m_leg + m_foot) g cos γ — so that leg is shorter than l by
(load − preload)/K; the hanging foot stretches its spring by (m_foot g + preload)/K (the thesis's
rest length: relaxed at l, preload 0). :func:`stand` simulates that standing.
"""
from __future__ import annotations

import math

from porthamiltonian import Trajectory

from ..core.walker import HybridWalker

__all__ = ["load_above_spring", "stand", "static_compression"]


def load_above_spring(walker: HybridWalker) -> float:
    """Static load on a stance leg's spring in single support, legs normal to the surface:
    (M + 2 m_leg + m_foot) g cos γ (N)."""
    P = walker.parameters
    return (P["M"] + 2 * P["m_leg"] + P["m_foot"]) * P["g"] * math.cos(P["slope"])


def static_compression(walker: HybridWalker, stiffness: str = "K_leg") -> float:
    """Static shortening of the stance leg, (load − preload)/K (m, > 0: shorter than l);
    ``stiffness``: the parameter of the stance spring's stiffness (``K1`` for the
    variable-stiffness walker)."""
    P = walker.parameters
    return (load_above_spring(walker) - P["preload"]) / P[stiffness]


def stand(walker: HybridWalker, t_end: float = 3.0) -> Trajectory:
    """The walker on leg 1 on a level surface (slope 0), both legs along the surface normal (an
    equilibrium by symmetry), foot 1's contact on, foot 2 hanging (contact off), released from
    the springs' rest lengths with foot 1 touching the surface, simulated for ``t_end`` s (the
    stance spring's oscillation, ζ = α, has settled by 3 s). At the end ``walker.q.ankle1`` ≈
    −(M + 2 m_leg + m_foot) g / K + preload/K and ``walker.q.ankle2`` ≈ (m_foot g + preload)/K."""
    P = walker.parameters
    c = walker.model
    x0 = {"walker.q.hip_joint.x": 0.0, "walker.q.hip_joint.z": P["l"] + P["R"] - 1e-9}
    for k in (1, 2):
        x0.update({f"walker.q.leg{k}": 0.0, f"walker.q.ankle{k}": 0.0, f"spring{k}.q": 0.0})
    params = {**{k: v for k, v in P.items() if k in c.param_names},
              "slope": 0.0, "c1": 1.0, "c2": 0.0, "ground1": 0.0, "ground2": 0.0}
    o = walker.options
    return c.simulate(t_end, x0=x0, params=params, method=o.method, rtol=o.rtol, atol=o.atol,
                      max_step=o.max_step)

"""Where a walker's energy goes: the energy dissipated in each step, by element.

:func:`dissipation_breakdown` splits the ledger's dissipation over a step between the friction
elements (the power into each ``SCVSFriction``: e·f ≥ 0), the dampers of the spring–dampers
(D ż² of each ``SpringDamper`` / ``VariableSpringDamper``: the legs', a hip's, an ankle's) and
the contacts (the rest: Hunt–Crossley or Kelvin–Voigt damping, and the spring energy a clipped
contact releases). The thesis's "energy dissipated due to the impact" is what the ground takes,
contact + friction (M. Jafarian 2010, MSc report 022CE2010, University of Twente, §3.1: ≈ 10×
smaller with compliant legs than with rigid ones).
"""
from __future__ import annotations

import numpy as np

from ..core.walker import HybridWalker

__all__ = ["dissipation_breakdown"]

_FRICTION = ("SCVSFriction", "SCVSFriction3D")
_DAMPERS = ("SpringDamper", "VariableSpringDamper")


def dissipation_breakdown(walker: HybridWalker, z: np.ndarray, n_steps: int = 1) -> list[dict]:
    """Energy dissipated in each step from section state ``z``, by element (J).

    Walks ``n_steps`` (one simulation, ``record=True``) and integrates each element's dissipated
    power over each step with the trapezoidal rule on the integrator's steps. Per step:
    ``total`` (the ledger's E_diss increment), ``contact``, ``friction``, ``dampers``,
    ``ground`` = contact + friction, and ``quadrature_error`` = ∫P_diss (trapezoid) − total, the
    error of the split. Steps that fell are left out."""
    strides = walker.walk(np.asarray(z, dtype=float), n_steps, record=True)
    traj = strides[-1].info["trajectory"]
    t, Y = traj.t, traj.outputs
    col = {name: i for i, name in enumerate(walker.model.output_names)}
    friction = np.zeros(len(t))
    damper = np.zeros(len(t))
    for name, comp in walker.spec.model.components():
        kind = getattr(comp, "kind", "")
        if kind in _FRICTION:
            dim = sum(1 for n in col if n.startswith(f"{name}.p.e"))   # 2, 3 (planar screw), 6
            friction += sum(Y[:, col[f"{name}.p.e{i}"]] * Y[:, col[f"{name}.p.f{i}"]]
                            for i in range(dim))
        elif kind in _DAMPERS:
            damper += Y[:, col[f"{name}.D"]] * Y[:, col[f"{name}.p.f"]] ** 2
    total = traj.power[:, 1]
    contact = total - friction - damper
    e_diss = traj.E_diss
    out, i0 = [], 0
    for s in strides:
        if s.fell:
            break
        i1 = int(np.nonzero(t == s.info["t_end"])[0][-1])
        sl = slice(i0, i1 + 1)

        def integral(power: np.ndarray, sl: slice = sl) -> float:
            """∫ power dt over the step (trapezoid on the stored points)."""
            return float(np.trapezoid(power[sl], t[sl]))

        row = {"total": float(e_diss[i1] - e_diss[i0]), "contact": integral(contact),
               "friction": integral(friction), "dampers": integral(damper)}
        row["ground"] = row["contact"] + row["friction"]
        row["quadrature_error"] = integral(total) - row["total"]
        out.append(row)
        i0 = i1
    return out

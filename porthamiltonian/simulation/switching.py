"""Constraints switched by events: the mode changes of a constrained multibody. Numeric, no sympy.

A loop or constraint of a multibody (:mod:`porthamiltonian.mechanics.closure`) is switched by its
``active`` expression, typically a mode parameter (``active = "knee_locked"``). Two event
actions (:class:`~porthamiltonian.simulation.simulate.Reset` makers for ``simulate(...,
actions={event: action})``):

* :func:`engage` — a knee that locks, a foot that is pinned: the plastic impact onto the
  constraint, then the constraint active. The impact is the generic plastic impact map
  (:func:`~porthamiltonian.simulation.impact.plastic_impact`) with the stacked Jacobian of the
  constraint's rows ``<mb>.G.<constraint>`` and of every row already active (the other loops stay
  closed through the impact): the configuration is unchanged, the momenta jump to M v⁺ with
  v⁺ the M-orthogonal projection of v⁻ onto G v = 0, and the kinetic energy of the velocity jump,
  ½ (v⁻ − v⁺)ᵀ M (v⁻ − v⁺) ≥ 0, is booked as dissipated. The switch parameter is set to 1.
* :func:`release` — the constraint lets go (a knee unlocks, a foot lifts): the switch parameter
  set to 0, the state unchanged (no impulse: the velocities already satisfy the remaining
  rows).
"""
from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ModelError
from .assembly import ConstraintRows, constraint_rows
from .impact import ImpactResult, plastic_impact
from .simulate import Reset

if TYPE_CHECKING:
    from .compiled import CompiledModel

__all__ = ["engage", "impact_onto", "release"]


def _rows(model: CompiledModel, multibody: str, constraint: str) -> ConstraintRows:
    for rows in constraint_rows(model):
        if rows.name == multibody:
            if not any(c == constraint for c, _ in rows.rows):
                known = sorted({c for c, _ in rows.rows})
                raise ModelError(f"model {model.name!r}, multibody {multibody!r}: no loop or "
                                 f"constraint {constraint!r} ({', '.join(known)})")
            return rows
    raise ModelError(f"model {model.name!r}: {multibody!r} is not a multibody with loops or "
                     f"constraints ({', '.join(r.name for r in constraint_rows(model)) or 'none'})")


def _parameter(model: CompiledModel, name: str) -> None:
    if name not in model.param_names:
        raise ModelError(f"model {model.name!r}: {name!r} is not a parameter (the constraint's "
                         "switch must be a parameter its 'active' expression reads)")


def impact_onto(model: CompiledModel, multibody: str, constraint: str
                ) -> Callable[[float, np.ndarray, np.ndarray], tuple[np.ndarray, ImpactResult]]:
    """The plastic impact onto ``constraint`` of ``multibody`` as a map (t, x, p) -> (state
    just after, :class:`~porthamiltonian.simulation.impact.ImpactResult`): the rows of the
    constraint and every row already active at ``p`` (see the module docstring); the
    configuration is unchanged, the multibody's momenta jump."""
    rows = _rows(model, multibody, constraint)
    own = [i for i, (c, _) in enumerate(rows.rows) if c == constraint]
    pidx = list(rows.p)

    def onto(t: float, x: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, ImpactResult]:
        y = model.outputs(t, x, p)
        on = sorted({i for i, k in enumerate(rows.active) if y[k] > 0.5} | set(own))
        G = model.matrix(f"{multibody}.G", t, x, p)[on]
        M = model.matrix(f"{multibody}.M", t, x, p)
        result = plastic_impact(M, G, np.linalg.solve(M, x[pidx]))
        x_plus = np.array(x, dtype=float)
        x_plus[pidx] = result.p_plus
        return x_plus, result

    return onto


def engage(model: CompiledModel, multibody: str, constraint: str,
           switch: str) -> Callable[[float, np.ndarray, np.ndarray], Reset]:
    """The action that impacts plastically onto ``constraint`` of ``multibody`` and sets the
    parameter ``switch`` to 1 (see the module docstring)."""
    onto = impact_onto(model, multibody, constraint)
    _parameter(model, switch)

    def action(t: float, x: np.ndarray, p: np.ndarray) -> Reset:
        return Reset(x=onto(t, x, p)[0], params={switch: 1.0}, energy="dissipated")

    return action


def release(model: CompiledModel, multibody: str, constraint: str,
            switch: str) -> Callable[[float, np.ndarray, np.ndarray], Reset]:
    """The action that sets the parameter ``switch`` to 0: ``constraint`` lets go."""
    _rows(model, multibody, constraint)
    _parameter(model, switch)

    def action(t: float, x: np.ndarray, p: np.ndarray) -> Reset:
        return Reset(params={switch: 0.0})

    return action

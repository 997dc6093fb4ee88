"""Consistent states of a constrained multibody: assembly, velocity projection, rank check.

A multibody with loops or constraints (:mod:`porthamiltonian.mechanics.closure`) publishes its
constraint Jacobian ``<mb>.G`` (rows over its velocities), the holonomic residuals
``<mb>.phi.<constraint>.<row>``, the rows' switches ``<mb>.S`` and its mass matrix
``<mb>.M``. From those, numerically (no sympy):

* :func:`consistent` — the state nearest to a given one on the constraint manifold, in the mass
  metric: positions by Gauss–Newton, Δv = argmin ½ Δvᵀ M Δv subject to φ + G_h Δv = 0 (and
  G_nh Δv = 0), i.e. [M Gᵀ; G 0] [Δv; μ] = [0; −φ], q ← q ⊕ K(q) Δv, until |φ| is at round-off;
  then velocities by the M-orthogonal projection v ← v − M⁻¹Gᵀ(G M⁻¹ Gᵀ)⁻¹ G v (p = M v), the
  plastic impact onto the constraints, which removes only the kinetic energy of the velocity
  error (Kelvin). A state already consistent is returned unchanged; one off the manifold is
  assembled, with a :class:`AssemblyWarning` quoting the residual and the correction when the
  residual exceeds 1e-6 of the model's scale (below that it is the drift a run leaves, e.g. a
  run continued from where another one ended: projected silently); one that
  cannot be assembled (no convergence: the constraints are inconsistent there) raises
  :class:`~porthamiltonian.errors.StateError` with the residual.
* the rank check: G's active rows must be independent where the run starts; dependent rows
  (redundant constraints, or a configuration where the mechanism locks) raise
  :class:`~porthamiltonian.errors.ModelError` naming the constraints and rows involved and the
  rank found.

``K(q) Δv`` is the identity for revolute, prismatic, translational and universal coordinates; a
spherical or free joint's quaternion is turned by the rotation vector Δω (child axes) and a free
joint's position moved by R Δv_lin.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ModelError, StateError

if TYPE_CHECKING:
    from .compiled import CompiledModel

__all__ = ["AssemblyWarning", "ConstraintRows", "check_rank", "consistent", "constraint_rows"]

#: Newton iterations at most; the residual tolerance relative to the length scale of the model
_ITERATIONS = 50
_TOLERANCE = 1e-12
#: residuals below this (relative, as _TOLERANCE) are the drift an integration leaves (a run
#: continued from the state another run ended with): projected without a warning
_SILENT = 1e-6


class AssemblyWarning(UserWarning):
    """An initial state off its constraints was moved onto them (the message quotes how far)."""


@dataclass(frozen=True)
class ConstraintRows:
    """The constraint rows of one multibody ``name`` of a compiled model: ``rows`` (constraint,
    row) in the order of G's rows; ``phi`` the output index of each row's residual (-1 for a
    velocity-level row); ``active`` the output index of each row's switch; the state indices of
    the coordinates ``q`` and momenta ``p``, and ``steps``: for each velocity, how its coordinate
    moves (("same", i) a coordinate of its own; ("rotation", quaternion indices, component) or
    ("shift", position indices, quaternion indices, component) for a quaternion joint)."""

    name: str
    rows: tuple[tuple[str, str], ...]
    phi: tuple[int, ...]
    active: tuple[int, ...]
    q: tuple[int, ...]
    p: tuple[int, ...]
    steps: tuple[tuple[Any, ...], ...]


def constraint_rows(model: CompiledModel) -> list[ConstraintRows]:
    """The constrained multibodies of ``model`` (empty for a model without constraints)."""
    out = []
    for matrix in model.matrix_names:
        if not matrix.endswith(".G") or f"{matrix[:-2]}.M" not in model.matrix_names:
            continue
        name = matrix[:-2]
        prefix = f"{name}.reaction."
        rows = [(c, r) for c, _, r in (o[len(prefix):].partition(".") for o in model.output_names
                                         if o.startswith(prefix))]
        index = model._output_index
        phi = tuple(index.get(f"{name}.phi.{c}.{r}", -1) for c, r in rows)
        active = tuple(index[f"{name}.active.{c}"] for c, _ in rows)
        q = [i for i, s in enumerate(model.state_names) if s.startswith(f"{name}.q.")]
        p = [i for i, s in enumerate(model.state_names) if s.startswith(f"{name}.p.")]
        out.append(ConstraintRows(name, tuple(rows), phi, active, tuple(q), tuple(p),
                                  _steps(model, name, q, p)))
    return out


def _steps(model: CompiledModel, name: str, q: list[int], p: list[int]
           ) -> tuple[tuple[Any, ...], ...]:
    coords = {model.state_names[i][len(name) + 3:]: i for i in q}
    steps: list[tuple[Any, ...]] = []
    for i in p:
        label = model.state_names[i][len(name) + 3:]
        if label in coords:
            steps.append(("same", coords[label]))
            continue
        joint, _, component = label.rpartition(".")
        quaternion = tuple(coords[f"{joint}.{c}"] for c in ("qw", "qx", "qy", "qz"))
        if component.startswith("w"):
            steps.append(("rotation", quaternion, "xyz".index(component[1])))
        else:
            position = tuple(coords[f"{joint}.{c}"] for c in "xyz")
            steps.append(("shift", position, quaternion, "xyz".index(component[1])))
    return tuple(steps)


def _rotation(qn: np.ndarray) -> np.ndarray:
    w, x, y, z = qn / np.linalg.norm(qn)
    return np.array([[w*w + x*x - y*y - z*z, 2*(x*y - w*z), 2*(x*z + w*y)],
                     [2*(x*y + w*z), w*w - x*x + y*y - z*z, 2*(y*z - w*x)],
                     [2*(x*z - w*y), 2*(y*z + w*x), w*w - x*x - y*y + z*z]])


def _moved(x: np.ndarray, rows: ConstraintRows, dv: np.ndarray) -> np.ndarray:
    """x with the coordinates moved by the velocities ``dv`` (K(q) Δv, see the module
    docstring)."""
    out = x.copy()
    turns: dict[tuple[int, ...], np.ndarray] = {}
    shifts: dict[tuple[int, ...], tuple[tuple[int, ...], np.ndarray]] = {}
    for step, d in zip(rows.steps, dv):
        if step[0] == "same":
            out[step[1]] += d
        elif step[0] == "rotation":
            turns.setdefault(step[1], np.zeros(3))[step[2]] += d
        else:
            shifts.setdefault(step[1], (step[2], np.zeros(3)))[1][step[3]] += d
    for position, (quaternion, lin) in shifts.items():
        out[list(position)] += _rotation(x[list(quaternion)]) @ lin
    for quaternion, omega in turns.items():
        angle = np.linalg.norm(omega)
        axis = omega / angle if angle > 0 else omega
        turn = np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])
        w, v = x[list(quaternion)][0], x[list(quaternion)][1:]
        a, b = turn[0], turn[1:]
        out[list(quaternion)] = np.concatenate([[w * a - v @ b], w * b + a * v + np.cross(v, b)])
    return out


def _system(model: CompiledModel, rows: ConstraintRows, t: float, x: np.ndarray,
            p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(M, G of the active rows, their residuals (0 for velocity-level rows), the active row
    indices) at a point. The active rows (the switches ``<mb>.S``) are checked for rank first
    (:func:`check_rank`), before the outputs solve the constrained equations with them (a
    singular saddle-point matrix: dependent rows)."""
    on = np.flatnonzero(model.matrix(f"{rows.name}.S", t, x, p)[:, 0] > 0.5)
    G = model.matrix(f"{rows.name}.G", t, x, p)[on]
    check_rank(model, rows, G, on)
    y = model.outputs(t, x, p)
    M = model.matrix(f"{rows.name}.M", t, x, p)
    phi = np.array([y[rows.phi[i]] if rows.phi[i] >= 0 else 0.0 for i in on])
    return M, G, phi, on


def _saddle(M: np.ndarray, G: np.ndarray, top: np.ndarray, bottom: np.ndarray) -> np.ndarray:
    n, m = M.shape[0], G.shape[0]
    K = np.block([[M, G.T], [G, np.zeros((m, m))]])
    return np.linalg.solve(K, np.concatenate([top, bottom]))[:n]


def _scale(model: CompiledModel, rows: ConstraintRows, x: np.ndarray) -> float:
    return max(1.0, float(np.max(np.abs(x[list(rows.q)]))) if rows.q else 1.0)


def check_rank(model: CompiledModel, rows: ConstraintRows, G: np.ndarray, on: np.ndarray) -> None:
    """ModelError when the active rows ``G`` are dependent (see the module docstring)."""
    if not len(on):
        return
    sv = np.linalg.svd(G, compute_uv=False)
    tol = max(G.shape) * np.finfo(float).eps * 1e3 * max(sv[0], 1.0)
    rank = int(np.sum(sv > tol))
    if rank == len(on):
        return
    _, _, Vt = np.linalg.svd(G.T)                       # left null space of G: rows of Vt
    null = Vt[rank:]
    involved = [i for i in range(len(on)) if np.max(np.abs(null[:, i])) > 1e-8]
    names = [f"{rows.rows[on[i]][0]}.{rows.rows[on[i]][1]}" for i in involved]
    constraints = sorted({rows.rows[on[i]][0] for i in involved})
    raise ModelError(f"model {model.name!r}, multibody {rows.name!r}: the {len(on)} active "
                     f"constraint rows have rank {rank} here: redundant or locked constraints "
                     f"among {', '.join(constraints)} (dependent rows {', '.join(names)}). Remove "
                     "the redundant rows (e.g. a planar loop declared with 3D joints, or a loop "
                     "closed twice) or start from a configuration where the mechanism can move")


def consistent(model: CompiledModel, x: np.ndarray, p: np.ndarray, t: float = 0.0,
               warn: bool = True) -> np.ndarray:
    """The model state ``x`` (model states only) moved onto its constraints (see the module
    docstring), with the rank of the active rows checked; ``x`` itself when the model has no
    constraints."""
    x = np.array(x, dtype=float)
    for rows in constraint_rows(model):
        x = _assemble(model, rows, x, p, t, warn)
    return x


def _assemble(model: CompiledModel, rows: ConstraintRows, x: np.ndarray, p: np.ndarray,
              t: float, warn: bool) -> np.ndarray:
    scale = _scale(model, rows, x)
    M, G, phi, on = _system(model, rows, t, x, p)
    first = float(np.max(np.abs(phi))) if phi.size else 0.0
    residual, moved = first, 0.0
    start = x.copy()
    for _ in range(_ITERATIONS):
        if residual <= _TOLERANCE * scale:
            break
        dv = _saddle(M, G, np.zeros(M.shape[0]), -phi)
        x = _moved(x, rows, dv)
        M, G, phi, on = _system(model, rows, t, x, p)
        last, residual = residual, float(np.max(np.abs(phi)))
        if not np.isfinite(residual) or residual > 10 * last:
            break
    if residual > _TOLERANCE * scale * 10:
        bad = ", ".join(f"{rows.rows[on[i]][0]}.{rows.rows[on[i]][1]} = {phi[i]:.3g}"
                        for i in np.argsort(-np.abs(phi))[:4])
        raise StateError(f"model {model.name!r}, multibody {rows.name!r}: the initial "
                         f"configuration cannot be assembled onto its constraints (residual "
                         f"{residual:.3g} after {_ITERATIONS} Newton steps in the mass metric; "
                         f"largest: {bad}): the constraints are inconsistent there; give "
                         "initial coordinates nearer a closed configuration")
    moved = float(np.max(np.abs(x[list(rows.q)] - start[list(rows.q)]))) if rows.q else 0.0
    pidx = list(rows.p)
    v = np.linalg.solve(M, x[pidx])
    error = float(np.max(np.abs(G @ v))) if len(on) else 0.0
    speed = max(float(np.max(np.abs(v))), 1.0) if v.size else 1.0
    if error > _TOLERANCE * speed * 10:
        v_new = _saddle(M, G, M @ v, np.zeros(len(on)))
        x[pidx] = M @ v_new
    else:
        error = 0.0
    if warn and (first > _SILENT * scale or error > _SILENT * speed):
        warnings.warn(
            f"model {model.name!r}, multibody {rows.name!r}: the initial state is off its "
            f"constraints (position residual {first:.3g}, constraint velocity {error:.3g}); "
            f"assembled by a Newton projection in the mass metric (coordinates moved by up to "
            f"{moved:.3g}, velocities projected onto G v = 0)", AssemblyWarning, stacklevel=3)
    return x

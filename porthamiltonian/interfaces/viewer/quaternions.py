"""Unit quaternions for the viewer: arrays of shape (..., 4), scalar first (w, x, y, z).

Hamilton convention, the one of :class:`~porthamiltonian.mechanics.free_body.FreeBody`: the
quaternion ``q`` of a body's orientation rotates body-frame coordinates into world coordinates,
``x_W = p + R(q) x_B``, and ``q1 ⊗ q2`` is the rotation ``R(q1) R(q2)``.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["AXES", "about_axis", "from_matrix", "multiply", "normalise", "rotate", "to_matrix"]

#: world unit vectors (downhill x, lateral, up) for each ``up`` axis of a scene (right-handed)
AXES = {"z": (np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0])),
        "y": (np.array([1.0, 0, 0]), np.array([0, 0, -1.0]), np.array([0, 1.0, 0]))}


def normalise(q: np.ndarray) -> np.ndarray:
    """``q / |q|`` (any shape (..., 4))."""
    q = np.asarray(q, dtype=float)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def about_axis(axis: ArrayLike, angle: ArrayLike) -> np.ndarray:
    """The rotation by ``angle`` (rad, right hand; scalar or array) about the unit ``axis``."""
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    half = 0.5 * np.asarray(angle, dtype=float)[..., None]
    return np.concatenate([np.cos(half), np.sin(half) * axis], axis=-1)


def multiply(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """The Hamilton product ``q1 ⊗ q2`` (broadcasting)."""
    w1, x1, y1, z1 = np.moveaxis(np.asarray(q1, dtype=float), -1, 0)
    w2, x2, y2, z2 = np.moveaxis(np.asarray(q2, dtype=float), -1, 0)
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=-1)


def to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices R(q), shape (..., 3, 3), of unit quaternions."""
    w, x, y, z = np.moveaxis(np.asarray(q, dtype=float), -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=-2)


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R(q) v`` (broadcasting: q (..., 4), v (..., 3))."""
    return np.einsum("...ij,...j->...i", to_matrix(q), np.asarray(v, dtype=float))


def from_matrix(R: np.ndarray) -> np.ndarray:
    """The unit quaternion (w ≥ 0) of a rotation matrix (one 3×3 matrix), by the largest of the
    four squared components (Shepperd's method: accurate for every rotation)."""
    R = np.asarray(R, dtype=float)
    t = np.trace(R)
    cand = np.array([1 + t, 1 + 2 * R[0, 0] - t, 1 + 2 * R[1, 1] - t, 1 + 2 * R[2, 2] - t])
    k = int(np.argmax(cand))
    s = 2.0 * np.sqrt(cand[k])               # 4 |q_k|
    if k == 0:
        q = [s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif k == 1:
        q = [(R[2, 1] - R[1, 2]) / s, s / 4, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif k == 2:
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, s / 4, (R[1, 2] + R[2, 1]) / s]
    else:
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, s / 4]
    out = np.array(q)
    return out if out[0] >= 0 else -out

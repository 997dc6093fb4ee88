"""Frames at evenly spaced times from the stored points of a run with events.

A trajectory stores an event as two points at the same time: the state just before it and the
state after its reset. :func:`resample` interpolates inside the continuous pieces only (never
across a reset) and takes the point after the reset at the event's own time;
:func:`resample_quaternions` does the same for orientations (normalised linear interpolation
along the shorter arc, which is the exact rotation's path to second order in the step).
"""
from __future__ import annotations

import numpy as np

__all__ = ["frame_times", "resample", "resample_quaternions"]


def frame_times(t: np.ndarray, rate: float, max_frames: int) -> np.ndarray:
    """Evenly spaced times over ``t[0] .. t[-1]`` at ``rate`` frames per unit of time, at most
    ``max_frames`` (and at least 2)."""
    t0, t1 = float(t[0]), float(t[-1])
    n = int(min(max_frames, max(2, round((t1 - t0) * rate) + 1)))
    return np.linspace(t0, t1, n)


def _bracket(t: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    i = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(t) - 1)
    j = np.minimum(i + 1, len(t) - 1)
    span = t[j] - t[i]
    w = np.where(span > 0, (times - t[i]) / np.where(span > 0, span, 1.0), 0.0)
    return i, j, w


def resample(t: np.ndarray, values: np.ndarray, times: np.ndarray) -> np.ndarray:
    """``values`` (N, ...) over the points ``t`` (N,), linearly interpolated at ``times``
    (module docstring: never across an event)."""
    values = np.asarray(values, dtype=float)
    i, j, w = _bracket(np.asarray(t, dtype=float), np.asarray(times, dtype=float))
    w = w.reshape((-1,) + (1,) * (values.ndim - 1))
    return values[i] * (1 - w) + values[j] * w


def resample_quaternions(t: np.ndarray, q: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Unit quaternions (N, 4) over ``t`` at ``times``: normalised linear interpolation between
    neighbouring points, the second one's sign chosen for the shorter arc (q and −q are the same
    rotation)."""
    q = np.asarray(q, dtype=float)
    i, j, w = _bracket(np.asarray(t, dtype=float), np.asarray(times, dtype=float))
    a, b = q[i], q[j]
    b = np.where((np.sum(a * b, axis=1) < 0)[:, None], -b, b)
    out = a * (1 - w)[:, None] + b * w[:, None]
    return out / np.linalg.norm(out, axis=1, keepdims=True)

"""The walker in three dimensions: the :class:`~porthamiltonian.viewer.Scene` of a recorded walk,
for the report's interactive 3D view and its still image.

* A 3D walker (its multibody is not planar and outputs its bodies' poses,
  ``<multibody>.<body>.pose.x|y|z|qw|qx|qy|qz``, :mod:`porthamiltonian.viewer.from_trajectory`):
  the bodies at their poses, each drawn as capsules from its origin to its points, and each
  foot of radius R > 0 (:func:`~.labels.foot_radius`) as an arc of that radius in the body's
  x–z plane about the foot's point (a toroidal foot; a point foot is a small ball).
* A planar walker (:func:`planar_scene`): its stick figure (:mod:`.animation`) set upright in 3D
  — the hip a ball, each leg a capsule from the hip towards its foot, the foot an arc (or a
  ball); a leg whose length changes (a compliant leg) telescopes: an upper tube from the hip,
  a lower rod from the foot. The two legs of a biped are drawn 0.1 leg lengths apart sideways
  so that neither hides the other (the model's legs share one plane).

Both turn the model's slope frame into the level world (x horizontal, z up), with the slope
at its angle γ as the ground, and mark the start of every recorded step as a stride.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Protocol

import numpy as np

from porthamiltonian.interfaces.viewer import (
    Arrow,
    Body,
    Capsule,
    Ground,
    Scene,
    Sphere,
    TorusArc,
    pose_sources,
    scene_from_trajectory,
)
from porthamiltonian.interfaces.viewer.from_trajectory import body_points
from porthamiltonian.interfaces.viewer.quaternions import about_axis

from ..analyses.series import GaitSeries
from .animation import ARC_HALF_ANGLE, LEG_COLOURS, arrow_scale
from .animation import Scene as Scene2D
from .labels import Described, foot_radius, is_nondimensional

__all__ = ["Drawn", "is_3d", "planar_scene", "walker_scene"]

#: sideways offset of each leg of a planar biped in the 3D view (leg lengths)
LEG_SPREAD = 0.05


class Drawn(Described, Protocol):
    """What the 3D view reads of a walker besides its file (:class:`~.labels.Described`): its
    name, its parameter values (SI) and its leg length (m, the scale of the feet's markers)."""

    @property
    def name(self) -> str:
        """The model name (the scene's title)."""

    @property
    def parameters(self) -> Mapping[str, float]:
        """Parameter values by name (SI)."""

    @property
    def leg_length(self) -> float:
        """The leg length (m)."""


def _units(walker: Described, step_period: float) -> dict[str, Any]:
    """The scene's units and time scale (real seconds per unit: one step per second for a
    nondimensional model, as the 2D player does)."""
    if is_nondimensional(walker):
        scale = 1.0 / step_period if math.isfinite(step_period) and step_period > 0 else 1.0
        return {"time_unit": "nondimensional time", "time_scale": scale,
                "length_unit": "nondim."}
    return {"time_unit": "s", "time_scale": 1.0, "length_unit": "m"}


def _planar(walker: Described) -> bool:
    try:
        comp = walker.spec.model.freeze().components[walker.multibody]
    except (AttributeError, KeyError):
        return True
    return comp.value("plane") == "xz"


def is_3d(walker: Described, series: GaitSeries) -> bool:
    """Whether ``walker`` is a 3D walker whose recorded walk gives its bodies' poses."""
    traj = series.strides[-1].info.get("trajectory") if series.strides else None
    if traj is None or _planar(walker):
        return False
    names = [*traj.model.state_names, *traj.model.output_names]
    return any(b.startswith(f"{walker.multibody}.") for b in pose_sources(names))


def _stride_starts(series: GaitSeries) -> list[float]:
    ends = series.step_times
    return [float(series.t[0]), *(float(series.t[0] + e) for e in ends[:-1])]


def walker_scene(walker: Drawn, series: GaitSeries, sc2d: Scene2D, *,
                 step_period: float = math.nan) -> Scene:
    """The 3D scene of a recorded walk (module docstring): from the bodies' poses for a 3D
    walker, else from the stick figure ``sc2d`` of the same walk."""
    if not is_3d(walker, series):
        return planar_scene(walker, sc2d, step_period=step_period)
    traj = series.strides[-1].info["trajectory"]
    model = walker.spec.model
    mb = walker.multibody
    bodies = [b for b in pose_sources([*traj.model.state_names, *traj.model.output_names])
              if b.startswith(f"{mb}.")]
    values = {**{k: float(v.value) for k, v in model.parameters.items()}, **walker.parameters}
    leg = float(walker.leg_length)
    extra: dict[str, list] = {}
    points = {b: body_points(traj, model, b) for b in bodies}
    for foot in walker.spec.feet:
        owner, _, name = foot.point.rpartition(".")
        for b in bodies:
            if owner != mb or name not in points[b]:
                continue
            p = points[b][name]
            R = foot_radius(walker, foot, values)
            tint = LEG_COLOURS[len(extra) % len(LEG_COLOURS)]
            mid = p / np.linalg.norm(p) if np.linalg.norm(p) > 1e-9 * leg else (0.0, 0.0, -1.0)
            extra.setdefault(b, []).append(
                TorusArc(tuple(p), (0.0, 1.0, 0.0), tuple(mid), R, 0.1 * R, 2 * ARC_HALF_ANGLE,
                         colour=tint) if R > 0 else Sphere(tuple(p), 0.025 * leg, colour=tint))
    slope = float(walker.parameters.get("slope", 0.0))
    return scene_from_trajectory(
        traj, model=model, bodies=bodies, extra_shapes=extra, ground=Ground(slope=slope),
        strides=_stride_starts(series), slope_frame=slope, title=walker.name,
        **_units(walker, step_period))


def _leg_quaternions(d: np.ndarray) -> np.ndarray:
    """Rotations about y taking the body's −z axis along the unit directions ``d`` (F, 2: x, z)."""
    return about_axis([0.0, 1.0, 0.0], np.arctan2(-d[:, 0], -d[:, 1]))


def planar_scene(walker: Drawn, sc: Scene2D, *, step_period: float = math.nan) -> Scene:
    """The stick figure ``sc`` of a planar walker as a 3D scene (module docstring)."""
    F, K = sc.feet.shape[:2]
    L = sc.leg_length
    r = 0.02 * L

    def lift(xz: np.ndarray, y: float | np.ndarray = 0.0) -> np.ndarray:
        return np.stack([xz[..., 0], np.broadcast_to(y, xz[..., 0].shape), xz[..., 1]], axis=-1)

    spread = [(j - (K - 1) / 2) * 2 * LEG_SPREAD * L for j in range(K)] if K == 2 else [0.0] * K
    bodies = [Body("hip", [Sphere((0, 0, 0), 3 * r, colour="#333333")], lift(sc.hip),
                   np.tile([1.0, 0, 0, 0], (F, 1)))]
    rows = np.arange(F)
    for j in range(K):
        k = np.argmax(sc.colour == j, axis=1)             # the foot that is leg j at each frame
        foot = sc.feet[rows, k]
        d = foot - sc.hip
        length = np.hypot(d[:, 0], d[:, 1])
        d = d / np.where(length > 0, length, 1.0)[:, None]
        q = _leg_quaternions(d)
        tint = LEG_COLOURS[j % len(LEG_COLOURS)]
        shortest = float(length.min())
        telescopes = float(length.max() - shortest) > 1e-3 * L
        upper = 0.6 * shortest if telescopes else shortest
        bodies.append(Body(f"leg {j + 1}", [Capsule((0, 0, 0), (0, 0, -upper), r, colour=tint)],
                           lift(sc.hip, spread[j]), q))
        R = float(sc.radius[k[0]])
        sole = (TorusArc((0, 0, 0), (0, 1, 0), (0, 0, -1), R, 0.8 * r, 2 * ARC_HALF_ANGLE,
                         colour=tint) if R > 0 else Sphere((0, 0, 0), 1.4 * r, colour=tint))
        shapes = [sole] + ([Capsule((0, 0, 0), (0, 0, 0.6 * shortest), 0.6 * r, colour=tint)]
                           if telescopes else [])
        bodies.append(Body(f"foot {j + 1}", shapes, lift(foot, spread[j]), q))
    arrows = []
    if sc.force is not None:
        for k in range(K):
            y = np.array(spread)[sc.colour[:, k]]
            arrows.append(Arrow(f"contact force {k + 1}", lift(sc.contact[:, k], y),
                                lift(sc.force[:, k]), arrow_scale(sc)))
    change = np.flatnonzero(np.diff(sc.step) != 0) + 1
    strides = [float(sc.t[0]), *(float(sc.t[i]) for i in change)]
    return Scene(sc.t, bodies, ground=Ground(slope=sc.slope), arrows=arrows, strides=strides,
                 title=walker.name, **_units(walker, step_period))

"""Scenes from simulations: the bodies' poses read by name from a trajectory.

Where the poses come from (:func:`pose_sources`), per body, its name in the scene in brackets:

* a :class:`~porthamiltonian.mechanics.multibody.Multibody` ``mb`` whose body ``B`` outputs
  its pose [``mb.B``] — seven outputs:
  ``mb.B.pose.x``, ``mb.B.pose.y``, ``mb.B.pose.z``: the origin of B's frame in world
  coordinates (m); ``mb.B.pose.qw``, ``mb.B.pose.qx``, ``mb.B.pose.qy``, ``mb.B.pose.qz``: the
  unit quaternion of B's orientation, Hamilton convention, scalar first, rotating B's
  coordinates into world coordinates (``x_W = p + R(q) x_B``);
* a :class:`~porthamiltonian.mechanics.free_body.FreeBody` ``b`` [``b``]: its states
  ``b.r.x|y|z`` and ``b.q.w|x|y|z`` (the same meaning; the quaternion is normalised here, as the
  component's own R(q) is).

Shapes, unless given per body (``shapes=``):

* a Multibody body (when ``model`` is given): a ball at its origin and a capsule from there to
  each of its named points and to each joint that carries a child body (:func:`body_points`:
  body-fixed coordinates from the points' outputs ``mb.<point>.x|y|z``, the children's poses
  and the body's pose at the first point);
* a FreeBody: the box of the same mass and principal moments of inertia about its centre of
  mass (edges ``a_i = sqrt(6 (I_j + I_k − I_i) / m)``, along the principal axes, at least 5 % of
  the longest), from its spatial-inertia matrix ``b.inertia`` at the first point;
* otherwise a ball at the body's origin.

Radii are fractions of the scene's characteristic size (the extent of the body origins and
points at the first frame). Frames are taken at ``rate`` per unit of time (at most
``max_frames``), interpolated inside the run's continuous pieces (:mod:`.sampling`).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ...errors import SceneError
from .quaternions import AXES, about_axis, from_matrix, multiply, normalise, rotate, to_matrix
from .sampling import frame_times, resample, resample_quaternions
from .scene import Arrow, Body, Ground, Scene
from .shapes import Box, Capsule, Shape, Sphere

__all__ = ["PALETTE", "body_points", "pose_names", "pose_sources", "scene_from_trajectory"]

#: body colours, in turn (the matplotlib default cycle)
PALETTE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
           "#7f7f7f", "#bcbd22", "#17becf")
_POSE = ("x", "y", "z", "qw", "qx", "qy", "qz")


def pose_names(body: str, kind: str = "multibody") -> tuple[str, ...]:
    """The seven names (x, y, z, qw, qx, qy, qz) a body's pose is read from: ``kind``
    ``"multibody"`` (outputs ``<body>.pose.*``) or ``"free"`` (FreeBody states)."""
    if kind == "free":
        return tuple(f"{body}.{n}" for n in ("r.x", "r.y", "r.z", "q.w", "q.x", "q.y", "q.z"))
    return tuple(f"{body}.pose.{n}" for n in _POSE)


def pose_sources(names: Sequence[str]) -> dict[str, tuple[str, ...]]:
    """Body name -> the seven names of its pose, for every body whose pose is among ``names``
    (a trajectory's states and outputs; module docstring), in the order found."""
    have = set(names)
    found: dict[str, tuple[str, ...]] = {}
    for name in names:
        for suffix, kind in ((".pose.qw", "multibody"), (".q.w", "free")):
            if name.endswith(suffix):
                body = name[: -len(suffix)]
                wanted = pose_names(body, kind)
                if body and body not in found and all(n in have for n in wanted):
                    found[body] = wanted
    return found


def _names(traj: Any) -> list[str]:
    return [*traj.model.state_names, *traj.model.output_names]


def _first_point(traj: Any) -> tuple[float, np.ndarray, np.ndarray]:
    """(t, x, p) at the trajectory's first point."""
    seg = traj.segments[0]
    return float(seg.t[0]), np.asarray(seg.y[:, 0], dtype=float), np.asarray(seg.p, dtype=float)


def body_points(traj: Any, model: Any, body: str) -> dict[str, np.ndarray]:
    """Body-fixed coordinates (m) of the named points of Multibody body ``body`` (``mb.B``) and
    of the joints that carry its child bodies (named by the joint), from their world positions
    (the outputs ``mb.<point>.x|y|z``, the children's poses) and the body's pose at the first
    point of ``traj``; {} when ``model`` does not say (module docstring)."""
    if model is None or "." not in body:
        return {}
    mb, _, name = body.rpartition(".")
    comp = model.freeze().components.get(mb)
    if comp is None or getattr(comp, "kind", "") != "Multibody":
        return {}
    bodies, joints = comp.value("bodies"), comp.value("joints")
    if name not in bodies:
        return {}
    names = set(_names(traj))
    pose = np.array([float(traj[n][0]) for n in pose_names(body)])
    R0 = to_matrix(normalise(pose[3:]))
    world: dict[str, np.ndarray] = {}
    for point in bodies[name].get("points") or {}:
        axes = [f"{mb}.{point}.{a}" for a in "xyz"]
        if any(n in names for n in axes):
            world[point] = np.array([float(traj[n][0]) if n in names else 0.0 for n in axes])
    for joint, spec in joints.items():
        child = pose_names(f"{mb}.{spec.get('child')}")
        if spec.get("parent") == name and all(n in names for n in child):
            world[joint] = np.array([float(traj[n][0]) for n in child[:3]])
    return {k: R0.T @ (w - pose[:3]) for k, w in world.items()}


def _inertia_box(traj: Any, body: str, colour: str) -> Shape | None:
    """The box of FreeBody ``body``'s mass and central principal moments, or None."""
    if f"{body}.inertia" not in traj.model.matrix_names:
        return None
    t0, x0, p0 = _first_point(traj)
    M = np.asarray(traj.model.matrix(f"{body}.inertia", t0, x0, p0), dtype=float)
    m = M[3, 3]
    if not m > 0:
        return None
    ct = M[0:3, 3:6] / m                                 # hat(c)
    c = np.array([ct[2, 1], ct[0, 2], ct[1, 0]])
    I_c = M[0:3, 0:3] - m * ct @ ct.T
    moments, axes = np.linalg.eigh(0.5 * (I_c + I_c.T))
    if np.linalg.det(axes) < 0:
        axes[:, 2] *= -1
    total = moments.sum()
    edges = np.sqrt(np.maximum(6.0 * (total - 2 * moments) / m, 0.0))
    edges = np.maximum(edges, 0.05 * edges.max()) if edges.max() > 0 else np.ones(3)
    return Box(tuple(c), tuple(edges), tuple(from_matrix(axes)), colour=colour)


def scene_from_trajectory(traj: Any, *, model: Any = None, bodies: Sequence[str] | None = None,
                          shapes: Mapping[str, Sequence[Shape]] | None = None,
                          extra_shapes: Mapping[str, Sequence[Shape]] | None = None,
                          ground: Ground | None = None, arrows: Sequence[Arrow] = (),
                          strides: Sequence[float] = (), slope_frame: float | None = None,
                          rate: float = 30.0, max_frames: int = 900, up: str = "z",
                          title: str = "", time_unit: str = "s", time_scale: float = 1.0,
                          length_unit: str = "m", link_radius: float = 0.02) -> Scene:
    """The :class:`Scene` of a simulation (module docstring: the names read, the default shapes).

    traj : a :class:`~porthamiltonian.simulation.trajectory.Trajectory`. model : the
        :class:`~porthamiltonian.modeling.model.Model` it was compiled from (for the bodies' points;
        optional). bodies : the bodies to draw (default: every body with a pose).
    shapes : body name -> its shapes (body frame), replacing the default ones.
    extra_shapes : body name -> shapes drawn besides the (default or given) ones.
    ground, strides (times of the run), up, title, time_unit, time_scale, length_unit : as in
        :class:`Scene`.
    arrows : :class:`Arrow` s whose origin and vector are given at the trajectory's points
        (N, 3), in the model's frame; they are resampled (and rotated) with the bodies.
    slope_frame : γ when the model's frame is a slope frame (x down a slope of angle γ, z along
        its normal, as the walker models have): the scene is turned into the level world frame
        (x horizontal, up vertical), where a ``Ground(slope=γ)`` is the model's plane z = 0.
    link_radius : capsule radius of the default shapes, a fraction of the size.
    """
    sources = pose_sources(_names(traj))
    if not sources:
        raise SceneError(
            f"model {traj.model.name!r} gives no body poses: a Multibody body B is drawn from "
            "its outputs <multibody>.B.pose.x|y|z|qw|qx|qy|qz, a FreeBody from its states "
            "r.x|y|z and q.w|x|y|z")
    chosen = list(sources) if bodies is None else list(bodies)
    unknown = [b for b in chosen if b not in sources]
    if unknown:
        raise SceneError(f"no pose for body {', '.join(map(repr, unknown))}; bodies with "
                         f"poses: {', '.join(sources)}")
    shapes, more = dict(shapes or {}), dict(extra_shapes or {})
    stray = (set(shapes) | set(more)) - set(chosen)
    if stray:
        raise SceneError(f"shapes given for {', '.join(sorted(stray))}, which are not drawn; "
                         f"bodies: {', '.join(chosen)}")
    t = np.asarray(traj.t, dtype=float)
    times = frame_times(t, rate, max_frames)
    turn = (np.array([1.0, 0, 0, 0]) if slope_frame is None
            else about_axis(AXES[up][1], float(slope_frame)))
    raw = {b: np.stack([np.asarray(traj[n], dtype=float) for n in sources[b]], axis=1)
           for b in chosen}
    points = {b: list(body_points(traj, model, b).values()) for b in chosen}
    cloud = [raw[b][0, :3] for b in chosen]
    for b in chosen:
        if points[b]:
            cloud += list(raw[b][0, :3] + rotate(normalise(raw[b][0, 3:]), np.array(points[b])))
    corners = np.array(cloud)
    size = float(np.linalg.norm(corners.max(axis=0) - corners.min(axis=0))) or 1.0
    out = []
    for k, b in enumerate(chosen):
        tint = PALETTE[k % len(PALETTE)]
        if b in shapes:
            drawn = list(shapes[b])
        elif points[b]:
            r = link_radius * size
            drawn = [Sphere((0, 0, 0), 1.6 * r, colour=tint)] + [
                Capsule((0, 0, 0), tuple(p), r, colour=tint) for p in points[b]
                if np.linalg.norm(p) > 1e-9 * size]
        else:
            box = _inertia_box(traj, b, tint)
            drawn = [box] if box is not None else [Sphere((0, 0, 0), 2 * link_radius * size,
                                                          colour=tint)]
        drawn += list(more.get(b, ()))
        position = rotate(turn, resample(t, raw[b][:, :3], times))
        q = resample_quaternions(t, normalise(raw[b][:, 3:]), times)
        out.append(Body(b, drawn, position, multiply(turn, q)))
    moved = [Arrow(a.name, rotate(turn, resample(t, a.origin, times)),
                   rotate(turn, resample(t, a.vector, times)), a.scale, a.colour, a.unit)
             for a in arrows]
    inside = [float(s) for s in strides if times[0] - 1e-12 <= s <= times[-1] + 1e-12]
    return Scene(times, out, ground=ground, arrows=moved, strides=inside, up=up, title=title,
                 time_unit=time_unit, time_scale=time_scale, length_unit=length_unit)

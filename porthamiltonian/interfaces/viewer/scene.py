"""A scene: rigid bodies drawn with shapes, their poses over time, the ground, force arrows and
stride boundaries — the neutral description the viewer draws, which any model can produce.

Frames, units and conventions
-----------------------------
* The world frame is right-handed; ``up`` is its vertical axis, ``"z"`` (default) or ``"y"``.
  The ground descends along the world's x axis (downhill); the third axis is lateral.
* Lengths are in the scene's ``length_unit`` (m by default), times in its ``time_unit`` (s).
* A body's pose at frame k: the position ``position[k]`` of its frame's origin in world
  coordinates and the unit quaternion ``orientation[k]`` = (w, x, y, z), Hamilton convention,
  that rotates body-frame coordinates into world coordinates (``x_W = p + R(q) x_B``; the
  convention of :class:`~porthamiltonian.mechanics.free_body.FreeBody`). Shapes are given in the
  body frame (:mod:`.shapes`).
* Frames are the times ``t`` (F,), nondecreasing; the viewer shows them in order and at their
  times (real time at speed 1 when ``time_scale`` is 1: real seconds per unit of ``t``).
* ``strides``: times at which strides (steps, cycles) begin, for stepping through them.

:class:`Ground`: a plane through the origin at slope γ (descending along x), optionally dropping
by ``step_height`` along its normal beyond ``step_at`` (measured along the slope).
:class:`Arrow`: a vector drawn at a point over time (a contact force), ``scale`` lengths per unit.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import SceneError
from .quaternions import AXES, rotate
from .shapes import Shape, colour, positive

__all__ = ["Arrow", "Body", "Ground", "Scene"]

#: largest deviation of a pose quaternion's norm from 1 that is accepted (then normalised)
QUATERNION_TOLERANCE = 1e-3


def _series(value: Any, shape: tuple[int, int], where: str) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise SceneError(f"{where}: expected an array of numbers of shape {shape}") from None
    if a.shape != shape:
        raise SceneError(f"{where}: expected shape {shape} (frames × components), got {a.shape}")
    bad = np.argwhere(~np.isfinite(a))
    if len(bad):
        raise SceneError(f"{where}: frame {int(bad[0][0])} is not finite")
    return a


def _text(value: Any, where: str, limit: int = 200) -> str:
    if not isinstance(value, str) or len(value) > limit:
        raise SceneError(f"{where}: expected a text of at most {limit} characters")
    return value


@dataclass
class Body:
    """A rigid body: its ``shapes`` (body frame) and its pose at every frame — ``position``
    (F, 3) of its origin in the world and ``orientation`` (F, 4), unit quaternions (w, x, y, z)
    from body to world (module docstring)."""

    name: str
    shapes: Sequence[Shape]
    position: np.ndarray
    orientation: np.ndarray


@dataclass(frozen=True)
class Ground:
    """The ground plane through the world origin, descending along x at ``slope`` γ (rad; 0:
    level); beyond ``step_at`` (along the slope, from the origin) it lies ``step_height`` lower
    (along its normal). ``colour``: #rrggbb."""

    slope: float = 0.0
    step_at: float | None = None
    step_height: float = 0.0
    colour: str = "#d5d9df"

    def __post_init__(self) -> None:
        if not (isinstance(self.slope, (int, float)) and abs(self.slope) < math.pi / 2):
            raise SceneError(f"ground slope: expected an angle in (−π/2, π/2) rad, got "
                             f"{self.slope!r}"[:200])
        for name in ("step_at", "step_height"):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise SceneError(f"ground {name}: expected a finite number, got {v!r}"[:200])
        object.__setattr__(self, "colour", colour(self.colour, "ground colour"))

    def frame(self, up: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World unit vectors (downhill, lateral, normal) of the slope."""
        ex, ey, ez = AXES[up]
        c, s = math.cos(self.slope), math.sin(self.slope)
        return c * ex - s * ez, ey, s * ex + c * ez

    def quads(self, up: str, u: tuple[float, float], w: tuple[float, float]) -> list[np.ndarray]:
        """The surface as world quadrilaterals (4, 3) over slope coordinates ``u`` (downhill)
        and ``w`` (lateral) ranges: one plane, or the upper plane, the riser and the lower
        plane of a step."""
        d, lat, n = self.frame(up)

        def at(uu: float, ww: float, h: float) -> np.ndarray:
            return uu * d + ww * lat + h * n

        def quad(u0: float, u1: float, h: float) -> np.ndarray:
            return np.array([at(u0, w[0], h), at(u1, w[0], h), at(u1, w[1], h), at(u0, w[1], h)])

        s = self.step_at
        if s is None or not self.step_height or not u[0] < s < u[1]:
            h = -self.step_height if s is not None and s <= u[0] else 0.0
            return [quad(u[0], u[1], h)]
        drop = -self.step_height
        riser = np.array([at(s, w[0], 0), at(s, w[1], 0), at(s, w[1], drop), at(s, w[0], drop)])
        return [quad(u[0], s, 0.0), riser, quad(s, u[1], drop)]

    def to_dict(self) -> dict[str, Any]:
        """The ground as the page's JSON data (slope in rad, step position and height in m)."""
        return {"slope": self.slope, "stepAt": self.step_at, "stepHeight": self.step_height,
                "colour": self.colour}


@dataclass
class Arrow:
    """A vector drawn over time: from ``origin`` (F, 3), world, along ``vector`` (F, 3) in its
    own ``unit`` (N for a force), ``scale`` lengths per unit (m/N). Hidden where it would be
    shorter than 1 % of the scene's size."""

    name: str
    origin: np.ndarray
    vector: np.ndarray
    scale: float
    colour: str = "#d62728"
    unit: str = "N"


@dataclass
class Scene:
    """Bodies, ground, arrows and strides over the frame times ``t`` (module docstring).

    Checked when made (a :class:`~porthamiltonian.errors.SceneError` names the body and frame):
    shapes of the arrays, finite values, times in order, pose quaternions of norm 1 within
    :data:`QUATERNION_TOLERANCE` (then normalised), distinct body names, strides inside the run.
    """

    t: np.ndarray
    bodies: list[Body]
    ground: Ground | None = None
    arrows: list[Arrow] = field(default_factory=list)
    strides: Sequence[float] | np.ndarray = ()
    up: str = "z"
    title: str = ""
    time_unit: str = "s"
    length_unit: str = "m"
    time_scale: float = 1.0

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float)
        if t.ndim != 1 or len(t) < 1 or not np.all(np.isfinite(t)):
            raise SceneError("scene times t: expected a non-empty list of finite numbers")
        if np.any(np.diff(t) < 0):
            k = int(np.argmax(np.diff(t) < 0))
            raise SceneError(f"scene times t: must not decrease (frame {k + 1}: {t[k + 1]:g} "
                             f"after {t[k]:g})")
        self.t = t
        F = len(t)
        if self.up not in AXES:
            raise SceneError(f"scene up axis: 'z' or 'y', got {self.up!r}"[:200])
        self.title = _text(self.title, "scene title")
        self.time_unit = _text(self.time_unit, "scene time unit", 40)
        self.length_unit = _text(self.length_unit, "scene length unit", 40)
        self.time_scale = positive(self.time_scale, "scene time_scale")
        seen: set[str] = set()
        for body in self.bodies:
            name = _text(body.name, "body name")
            if name in seen:
                raise SceneError(f"body {name!r}: two bodies have this name")
            seen.add(name)
            for s in body.shapes:
                if not isinstance(s, Shape):
                    raise SceneError(f"body {name!r}: shapes must be Sphere, Capsule, Cylinder, "
                                     f"Box or TorusArc, got {type(s).__name__}")
            body.shapes = tuple(body.shapes)
            body.position = _series(body.position, (F, 3), f"body {name!r} position")
            q = _series(body.orientation, (F, 4), f"body {name!r} orientation")
            norm = np.linalg.norm(q, axis=1)
            bad = np.flatnonzero(np.abs(norm - 1) > QUATERNION_TOLERANCE)
            if len(bad):
                k = int(bad[0])
                raise SceneError(
                    f"body {name!r} orientation at t = {t[k]:g} (frame {k}): a unit quaternion "
                    f"(w, x, y, z) is expected, its norm is {norm[k]:.6g}")
            body.orientation = q / norm[:, None]
        for arrow in self.arrows:
            where = f"arrow {_text(arrow.name, 'arrow name')!r}"
            arrow.origin = _series(arrow.origin, (F, 3), f"{where} origin")
            arrow.vector = _series(arrow.vector, (F, 3), f"{where} vector")
            arrow.scale = positive(arrow.scale, f"{where} scale")
            arrow.colour = colour(arrow.colour, f"{where} colour")
            arrow.unit = _text(arrow.unit, f"{where} unit", 40)
        strides = np.asarray(self.strides, dtype=float).ravel()
        if (not np.all(np.isfinite(strides)) or np.any(np.diff(strides) < 0)
                or np.any(strides < t[0] - 1e-12) or np.any(strides > t[-1] + 1e-12)):
            raise SceneError(f"scene strides: expected increasing times within the run "
                             f"[{t[0]:g}, {t[-1]:g}]")
        self.strides = strides

    # --- geometry ---------------------------------------------------------------------------------
    def shape_points(self) -> np.ndarray:
        """World points (F, k, 3) bounding every body's shapes at every frame."""
        parts = []
        for body in self.bodies:
            if not body.shapes:
                parts.append(body.position[:, None, :])
                continue
            local = np.concatenate([s.extent() for s in body.shapes])
            parts.append(body.position[:, None, :]
                         + rotate(body.orientation[:, None, :], local[None, :, :]))
        if not parts:
            return np.zeros((len(self.t), 1, 3))
        return np.concatenate(parts, axis=1)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The world bounding box (lower, upper corners) of the bodies over the whole run."""
        pts = self.shape_points().reshape(-1, 3)
        return pts.min(axis=0), pts.max(axis=0)

    def size(self) -> float:
        """The scene's characteristic size: the largest diagonal of the bodies' bounding box at
        one frame (> 0; 1 for an empty scene)."""
        pts = self.shape_points()
        d = float(np.max(np.linalg.norm(pts.max(axis=1) - pts.min(axis=1), axis=1)))
        return d if d > 0 else 1.0

    def ground_region(self, lo: np.ndarray, hi: np.ndarray,
                      margin: float) -> tuple[tuple[float, float], tuple[float, float]]:
        """Slope-coordinate ranges (downhill u, lateral w) of the ground under the box
        ``lo``–``hi``, widened by ``margin``."""
        if self.ground is None:
            raise SceneError("the scene has no ground: give it one to ask for its region")
        d, lat, _ = self.ground.frame(self.up)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])
        return ((float((corners @ d).min() - margin), float((corners @ d).max() + margin)),
                (float((corners @ lat).min() - margin), float((corners @ lat).max() + margin)))

    def stride_of(self, time: float) -> int:
        """0-based index of the stride in progress at ``time`` (−1 before the first)."""
        return int(np.searchsorted(self.strides, time, side="right")) - 1

    # --- output -----------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The scene as the page's JSON data: times, strides, units, the bodies (shapes, poses
        flattened frame by frame: x y z w qx qy qz), the ground as world polygons and its grid,
        the arrows, the view's bounds and size. Positions are rounded to 1e-5 of the size."""
        size = self.size()
        decimals = max(0, 5 - math.floor(math.log10(size)))
        lo, hi = self.bounds()
        r = lambda a, d=decimals: np.round(np.asarray(a, dtype=float), d).ravel().tolist()
        data: dict[str, Any] = {
            "version": 1, "title": self.title, "up": self.up, "t": r(self.t, 6),
            "strides": r(self.strides, 6), "timeUnit": self.time_unit,
            "lengthUnit": self.length_unit, "timeScale": self.time_scale, "size": size,
            "bounds": [r(lo), r(hi)],
            "bodies": [{"name": b.name, "shapes": [s.to_dict() for s in b.shapes],
                        "pose": np.concatenate([np.round(b.position, decimals),
                                                np.round(b.orientation, 6)], axis=1)
                        .ravel().tolist()}
                       for b in self.bodies],
            "arrows": [{"name": a.name, "colour": a.colour, "scale": a.scale, "unit": a.unit,
                        "origin": r(a.origin), "vector": r(a.vector * a.scale)}
                       for a in self.arrows]}
        if self.ground is not None:
            data["ground"] = self._ground_data(lo, hi, size, decimals)
        return data

    def _ground_data(self, lo: np.ndarray, hi: np.ndarray, size: float,
                     decimals: int) -> dict[str, Any]:
        """The ground under the whole run: its polygons and grid lines (world points)."""
        if self.ground is None:
            raise SceneError("the scene has no ground to draw")
        d, lat, n = self.ground.frame(self.up)
        u, w = self.ground_region(lo, hi, 0.6 * size)
        spacing = 10.0 ** math.floor(math.log10(size / 2))
        if size / spacing > 10:
            spacing *= 5 if size / spacing > 25 else 2
        step = self.ground.step_at
        grid = []
        for k in range(math.ceil(u[0] / spacing), math.floor(u[1] / spacing) + 1):
            uu = k * spacing
            h = -self.ground.step_height if step is not None and uu >= step else 0.0
            grid.append([uu * d + w[0] * lat + h * n, uu * d + w[1] * lat + h * n])
        for k in range(math.ceil(w[0] / spacing), math.floor(w[1] / spacing) + 1):
            ww = k * spacing
            if step is not None and u[0] < step < u[1]:
                grid.append([u[0] * d + ww * lat, step * d + ww * lat])
                grid.append([step * d + ww * lat - self.ground.step_height * n,
                             u[1] * d + ww * lat - self.ground.step_height * n])
            else:
                h = -self.ground.step_height if step is not None and step <= u[0] else 0.0
                grid.append([u[0] * d + ww * lat + h * n, u[1] * d + ww * lat + h * n])
        r = lambda a: np.round(np.asarray(a, dtype=float), decimals).ravel().tolist()
        return {**self.ground.to_dict(), "quads": [r(q) for q in self.ground.quads(self.up, u, w)],
                "grid": r(grid), "spacing": spacing, "normal": n.tolist()}

    def to_html(self, path: str | Path, *, title: str | None = None, caption: str = "",
                still: bool = True) -> Path:
        """Write a self-contained page (three.js inline: it works offline) with the interactive
        view; ``still``: the PNG of :meth:`to_png` inside it, shown where WebGL is missing."""
        from .page import write_page
        return write_page(self, Path(path), title=title, caption=caption, still=still)

    def to_png(self, path: str | Path, *, times: Sequence[float] | None = None,
               elevation: float = 18.0, azimuth: float = -70.0, dpi: int = 110) -> Path:
        """Write a still image (matplotlib 3D): the bodies at ``times`` (default: the start of
        each stride, at most five, and the last frame; earlier ones faded), the paths of their
        origins and the ground; view angles in degrees (azimuth about the up axis from downhill)."""
        from .still import write_png
        return write_png(self, Path(path), times=times, elevation=elevation, azimuth=azimuth,
                         dpi=dpi)

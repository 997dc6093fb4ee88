"""The shapes a body of a scene is drawn with, in the body's own frame (lengths in the scene's
length unit, m by default).

* :class:`Sphere` — ``center``, ``radius``;
* :class:`Capsule` — a cylinder with round ends between the body-fixed points ``a`` and ``b``,
  ``radius`` (a leg, a link);
* :class:`Cylinder` — flat ends between ``a`` and ``b``, ``radius``;
* :class:`Box` — ``center``, edge lengths ``size`` along the box's axes, which are the body's
  axes rotated by the unit quaternion ``rotation`` (w, x, y, z);
* :class:`TorusArc` — an arc foot or a wheel: the tube of radius ``tube`` around a circular arc of
  radius ``radius`` about ``center`` in the plane normal to ``axis``, spanning ``angle`` (rad,
  up to a full ring, 2π) centred on the direction ``mid`` (from the centre; its component along
  ``axis`` is dropped).

Every shape has a ``colour`` (``#rrggbb``). :meth:`Shape.surfaces` gives the shape as grids of
body-frame points (for the matplotlib still image and the bounds); the page draws the same
shapes with three.js meshes from :meth:`Shape.to_dict`.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar

import numpy as np

from ...errors import SceneError
from .quaternions import about_axis, normalise, rotate

__all__ = ["SHAPES", "Box", "Capsule", "Cylinder", "Shape", "Sphere", "TorusArc", "shape_from_dict"]

_COLOUR = re.compile(r"#[0-9a-fA-F]{6}")
Grid = tuple[np.ndarray, np.ndarray, np.ndarray]


def vector3(value: Any, where: str) -> tuple[float, float, float]:
    """Three finite numbers, or a :class:`SceneError` naming ``where``."""
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise SceneError(f"{where}: expected three numbers, got {value!r}"[:300]) from None
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise SceneError(f"{where}: expected three finite numbers, got {value!r}"[:300])
    return (float(v[0]), float(v[1]), float(v[2]))


def positive(value: Any, where: str, upper: float = math.inf) -> float:
    """A finite number in (0, upper], or a :class:`SceneError` naming ``where``."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SceneError(f"{where}: expected a positive number, got {value!r}"[:300]) from None
    if not (math.isfinite(v) and 0 < v <= upper):
        bound = "" if upper == math.inf else f" and at most {upper:g}"
        raise SceneError(f"{where}: must be positive{bound}, got {value!r}"[:300])
    return v


def colour(value: Any, where: str) -> str:
    """A colour ``#rrggbb`` (lower case), or a :class:`SceneError`."""
    if not (isinstance(value, str) and _COLOUR.fullmatch(value)):
        raise SceneError(f"{where}: a colour is written #rrggbb, got {value!r}"[:300])
    return value.lower()


def _basis(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing the unit vector ``d`` to an orthonormal basis."""
    other = np.array([1.0, 0, 0]) if abs(d[0]) < 0.9 else np.array([0, 1.0, 0])
    e = np.cross(d, other)
    e /= np.linalg.norm(e)
    return e, np.cross(d, e)


def _sphere_grid(center: np.ndarray, radius: float, n: int) -> Grid:
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 2 * n + 1), np.linspace(0, np.pi, n + 1))
    return (center[0] + radius * np.cos(u) * np.sin(v), center[1] + radius * np.sin(u) * np.sin(v),
            center[2] + radius * np.cos(v))


def _tube_grid(a: np.ndarray, b: np.ndarray, radius: float, n: int) -> Grid:
    d = b - a
    length = float(np.linalg.norm(d))
    d = d / length if length > 0 else np.array([0, 0, 1.0])
    e, f = _basis(d)
    u, s = np.meshgrid(np.linspace(0, 2 * np.pi, 2 * n + 1), np.array([0.0, length]))
    pts = (a[:, None, None] + d[:, None, None] * s
           + radius * (np.cos(u) * e[:, None, None] + np.sin(u) * f[:, None, None]))
    return pts[0], pts[1], pts[2]


@dataclass(frozen=True)
class Shape:
    """Base class of the shapes (module docstring); ``colour`` is ``#rrggbb``."""

    kind: ClassVar[str] = ""
    colour: str = field(default="#4c72b0", kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "colour", colour(self.colour, f"{self.kind} colour"))

    def surfaces(self, n: int = 12) -> list[Grid]:
        """The shape as grids (X, Y, Z) of body-frame points, ``n`` segments per half turn."""
        raise NotImplementedError

    def extent(self) -> np.ndarray:
        """Body-frame points (k, 3) of the shape's surface whose bounding box is the shape's,
        up to the sampling of curved surfaces (within 4 % of the size)."""
        return np.concatenate([np.stack([g.ravel() for g in grid], axis=1)
                               for grid in self.surfaces(6)])

    def to_dict(self) -> dict[str, Any]:
        """The shape as JSON-able data: ``kind``, its fields, ``colour``."""
        out: dict[str, Any] = {"kind": self.kind}
        for f in fields(self):
            value = getattr(self, f.name)
            out[f.name] = list(value) if isinstance(value, tuple) else value
        return out


@dataclass(frozen=True)
class Sphere(Shape):
    """A ball of ``radius`` about the body-fixed point ``center``."""

    kind: ClassVar[str] = "sphere"
    center: tuple[float, float, float]
    radius: float

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "center", vector3(self.center, "sphere center"))
        object.__setattr__(self, "radius", positive(self.radius, "sphere radius"))

    def surfaces(self, n: int = 12) -> list[Grid]:
        return [_sphere_grid(np.array(self.center), self.radius, n)]


@dataclass(frozen=True)
class Capsule(Shape):
    """A cylinder of ``radius`` with hemispherical ends, from point ``a`` to point ``b``."""

    kind: ClassVar[str] = "capsule"
    a: tuple[float, float, float]
    b: tuple[float, float, float]
    radius: float

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "a", vector3(self.a, f"{self.kind} end a"))
        object.__setattr__(self, "b", vector3(self.b, f"{self.kind} end b"))
        object.__setattr__(self, "radius", positive(self.radius, f"{self.kind} radius"))

    def surfaces(self, n: int = 12) -> list[Grid]:
        a, b = np.array(self.a), np.array(self.b)
        return [_tube_grid(a, b, self.radius, n), _sphere_grid(a, self.radius, n // 2 + 1),
                _sphere_grid(b, self.radius, n // 2 + 1)]


@dataclass(frozen=True)
class Cylinder(Capsule):
    """A cylinder of ``radius`` with flat ends, from point ``a`` to point ``b``."""

    kind: ClassVar[str] = "cylinder"

    def surfaces(self, n: int = 12) -> list[Grid]:
        a, b = np.array(self.a), np.array(self.b)
        tube = _tube_grid(a, b, self.radius, n)
        caps: list[Grid] = []
        for row, end in ((0, a), (1, b)):          # a disc: the end's centre and its ring
            x, y, z = (np.stack([np.full_like(g[row], end[i]), g[row]])
                       for i, g in enumerate(tube))
            caps.append((x, y, z))
        return [tube, *caps]


@dataclass(frozen=True)
class Box(Shape):
    """A box of edge lengths ``size`` about ``center``, its axes the body's rotated by
    ``rotation`` (a unit quaternion w, x, y, z)."""

    kind: ClassVar[str] = "box"
    center: tuple[float, float, float]
    size: tuple[float, float, float]
    rotation: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "center", vector3(self.center, "box center"))
        object.__setattr__(self, "size", tuple(positive(s, "box size")
                                               for s in vector3(self.size, "box size")))
        q = np.asarray(self.rotation, dtype=float)
        if q.shape != (4,) or not np.all(np.isfinite(q)) or abs(np.linalg.norm(q) - 1) > 1e-6:
            raise SceneError(f"box rotation: expected a unit quaternion (w, x, y, z), got "
                             f"{self.rotation!r}"[:300])
        object.__setattr__(self, "rotation", tuple(float(x) for x in normalise(q)))

    def surfaces(self, n: int = 12) -> list[Grid]:
        half = np.array(self.size) / 2
        grids = []
        for axis in range(3):
            others = [k for k in range(3) if k != axis]
            s, u = np.meshgrid([-1.0, 1.0], [-1.0, 1.0])
            for sign in (-1.0, 1.0):
                local = np.zeros((2, 2, 3))
                local[..., axis] = sign
                local[..., others[0]], local[..., others[1]] = s, u
                pts = np.array(self.center) + rotate(np.array(self.rotation), local * half)
                grids.append((pts[..., 0], pts[..., 1], pts[..., 2]))
        return grids


@dataclass(frozen=True)
class TorusArc(Shape):
    """A tube of radius ``tube`` around an arc of ``radius`` about ``center`` in the plane normal
    to ``axis``, spanning ``angle`` (rad, at most 2π) centred on the direction ``mid``."""

    kind: ClassVar[str] = "torus"
    center: tuple[float, float, float]
    axis: tuple[float, float, float]
    mid: tuple[float, float, float]
    radius: float
    tube: float
    angle: float = 2 * math.pi

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "center", vector3(self.center, "torus center"))
        axis = np.array(vector3(self.axis, "torus axis"))
        mid = np.array(vector3(self.mid, "torus mid"))
        if not np.linalg.norm(axis) > 0:
            raise SceneError("torus axis: must not be zero")
        axis /= np.linalg.norm(axis)
        mid = mid - axis * (mid @ axis)
        if not np.linalg.norm(mid) > 1e-9:
            raise SceneError("torus mid: must not be parallel to the axis (it points to the "
                             "arc's middle, in the arc's plane)")
        mid /= np.linalg.norm(mid)
        object.__setattr__(self, "axis", tuple(float(x) for x in axis))
        object.__setattr__(self, "mid", tuple(float(x) for x in mid))
        object.__setattr__(self, "radius", positive(self.radius, "torus radius"))
        object.__setattr__(self, "tube", positive(self.tube, "torus tube"))
        object.__setattr__(self, "angle", positive(self.angle, "torus angle", 2 * math.pi))

    def surfaces(self, n: int = 12) -> list[Grid]:
        axis, mid = np.array(self.axis), np.array(self.mid)
        start = rotate(about_axis(axis, -self.angle / 2), mid)
        side = np.cross(axis, start)
        m = 2 * max(1, math.ceil(n * self.angle / (2 * math.pi)))     # even: the middle too
        u, v = np.meshgrid(np.linspace(0, self.angle, m + 1),
                           np.linspace(0, 2 * np.pi, 4 * math.ceil(n / 2) + 1))
        ring = self.radius + self.tube * np.cos(v)
        pts = (np.array(self.center)[:, None, None]
               + ring * (np.cos(u) * start[:, None, None] + np.sin(u) * side[:, None, None])
               + self.tube * np.sin(v) * axis[:, None, None])
        return [(pts[0], pts[1], pts[2])]


#: the shape classes by ``kind``
SHAPES: dict[str, type[Shape]] = {c.kind: c for c in (Sphere, Capsule, Cylinder, Box, TorusArc)}


def shape_from_dict(data: Any, where: str = "shape") -> Shape:
    """A shape from :meth:`Shape.to_dict`'s data (e.g. read from a JSON file: checked, never
    trusted)."""
    if not isinstance(data, dict) or data.get("kind") not in SHAPES:
        raise SceneError(f"{where}: expected a table with kind = one of {', '.join(SHAPES)}")
    cls = SHAPES[data["kind"]]
    known = {f.name for f in fields(cls)}
    extra = set(data) - known - {"kind"}
    if extra:
        raise SceneError(f"{where}: unknown field(s) {', '.join(sorted(map(str, extra)))[:200]} "
                         f"of a {cls.kind}; fields: {', '.join(sorted(known))}")
    try:
        return cls(**{k: v for k, v in data.items() if k != "kind"})
    except TypeError as err:
        raise SceneError(f"{where}: {err}") from None

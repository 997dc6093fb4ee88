"""Python-side descriptions of rigid bodies and joints for :class:`~.multibody.Multibody`.

They are thin, validated records that turn into the plain tables a model file uses (``to_dict``),
so a mechanism reads the same in Python and in TOML::

    Multibody(bodies={"leg": RigidBody(mass="m_leg", com=[0, 0, "-l/2"], inertia=[0, "I", 0],
                                       points={"foot": [0, 0, "-l"]})},
              joints={"hip": Revolute(parent="world", child="leg", axis="y")})

Values are numbers or expressions in the model's parameters (SI units: kg, m, kg m², rad).
"""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

from ..errors import ModelError
from ..modeling.expressions import check_name

Value = float | str


@dataclass(frozen=True)
class RigidBody:
    """A rigid body: ``mass`` (kg, > 0), centre of mass ``com`` (m, body frame), rotational
    ``inertia`` about the centre of mass (kg m²: 0 for a point mass, three principal moments, or
    a symmetric positive definite 3x3 matrix), named ``points`` (m, body frame; each a force port),
    named ``frames`` (origins in the body frame, axes parallel to it; each a wrench/twist port)
    and named ``world_frames`` (origins in the body frame, axes parallel to the world's; each a
    wrench/twist port in world coordinates, the port of a 3D contact)."""

    mass: Value
    com: list[Value] = field(default_factory=lambda: [0, 0, 0])
    inertia: Any = 0
    points: dict[str, list[Value]] = field(default_factory=dict)
    frames: dict[str, list[Value]] = field(default_factory=dict)
    world_frames: dict[str, list[Value]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if isinstance(self.mass, (int, float)) and not self.mass > 0:
            raise ModelError(f"RigidBody: mass must be positive, got {self.mass}")

    def to_dict(self) -> dict[str, Any]:
        """The body as a Multibody's table (what a model file holds)."""
        out: dict[str, Any] = {"mass": self.mass, "com": list(self.com), "inertia": self.inertia}
        if self.points:
            out["points"] = {k: list(v) for k, v in self.points.items()}
        if self.frames:
            out["frames"] = {k: list(v) for k, v in self.frames.items()}
        if self.world_frames:
            out["world_frames"] = {k: list(v) for k, v in self.world_frames.items()}
        return out


@dataclass(frozen=True)
class _Joint:
    parent: str
    child: str
    origin: list[Value] = field(default_factory=lambda: [0, 0, 0])

    kind = ""

    def to_dict(self) -> dict[str, Any]:
        """The joint as a Multibody's table (what a model file holds)."""
        out = {"type": self.kind, "parent": self.parent, "child": self.child,
               "origin": list(self.origin)}
        for name in ("axis", "axes", "q0", "v0"):
            if hasattr(self, name) and getattr(self, name) is not None:
                value = getattr(self, name)
                out[name] = list(value) if isinstance(value, tuple) else value
        return out


@dataclass(frozen=True)
class _OneAxis(_Joint):
    """A joint of one coordinate q about or along ``axis``, starting at q0 with rate v0."""

    axis: Any = "x"
    q0: Any = 0
    v0: Any = 0


@dataclass(frozen=True)
class Revolute(_OneAxis):
    """Rotation by q (rad) about ``axis`` ('x', 'y', 'z' or a 3-vector, parent frame)."""

    axis: Any = "y"
    kind = "revolute"


@dataclass(frozen=True)
class Prismatic(_OneAxis):
    """Translation by q (m) along ``axis``."""

    kind = "prismatic"


@dataclass(frozen=True)
class Translational(_Joint):
    """Translations along several world-aligned ``axes`` (e.g. ("x", "z")), one coordinate each."""

    axes: tuple[str, ...] = ("x", "z")
    q0: Any = 0
    v0: Any = 0
    kind = "translational"


@dataclass(frozen=True)
class Universal(_Joint):
    """Rotations by q1 about ``axes[0]`` (parent frame) then by q2 about ``axes[1]`` (the frame
    turned by the first): a Cardan joint."""

    axes: tuple = ("x", "y")
    q0: Any = 0
    v0: Any = 0
    kind = "universal"


@dataclass(frozen=True)
class Spherical(_Joint):
    """Any rotation about ``origin``: a unit quaternion ``q0`` = [w, x, y, z] (default identity)
    and the relative angular velocity ``v0`` = [wx, wy, wz] in the child's axes (rad/s)."""

    q0: Any = None
    v0: Any = None
    kind = "spherical"


@dataclass(frozen=True)
class Free(_Joint):
    """Six degrees of freedom (a floating base when the parent is "world"): ``q0`` = [x, y, z, w,
    qx, qy, qz] (position of the child origin in the parent's axes, m, and a unit quaternion;
    default at the origin, identity) and the relative twist ``v0`` = [wx, wy, wz, vx, vy, vz] in
    the child's axes (rad/s, m/s)."""

    q0: Any = None
    v0: Any = None
    kind = "free"


@dataclass(frozen=True)
class Weld(_Joint):
    """A fixed joint: the child is rigidly attached at ``origin``."""

    kind = "weld"


def as_tables(bodies: dict[str, Any], joints: dict[str, Any]) -> tuple[dict, dict]:
    """Bodies and joints as plain tables (accepting records or tables). Body, joint, point and
    frame names must be names (:func:`~porthamiltonian.modeling.expressions.check_name`): they name states,
    ports and outputs."""
    if not isinstance(bodies, dict) or not isinstance(joints, dict):
        return bodies, joints              # Multibody's checks say what is wrong
    bodies = {k: v.to_dict() if isinstance(v, RigidBody) else v for k, v in bodies.items()}
    joints = {k: v.to_dict() if isinstance(v, _Joint) else v for k, v in joints.items()}
    for name, body in bodies.items():
        check_name(name, "Multibody body name")
        for key in ("points", "frames", "world_frames"):
            table = body.get(key) if isinstance(body, dict) else None
            for point in table if isinstance(table, dict) else ():
                check_name(point, f"Multibody body {name!r} {key[:-1].replace('_', ' ')} name")
    for name in joints:
        check_name(name, "Multibody joint name")
    return bodies, joints


def expression_fields(bodies: Any, joints: Any, gravity: Any) -> Iterator[tuple[tuple, Any, str]]:
    """Every expression of a Multibody's tables as ``(key path, value, what)``: the path within
    the component's table (for the line of a model file), ``what`` as the compiler names the field
    in messages (``"body 'b' mass"``). Tables of the wrong shape are skipped (Multibody's checks
    report them)."""
    def leaves(path: tuple[Any, ...], value: Any, what: str
               ) -> Iterator[tuple[tuple[Any, ...], Any, str]]:
        if isinstance(value, list):
            for i, item in enumerate(value):
                yield from leaves((*path, i), item, what)
        else:
            yield path, value, what

    for name, body in (bodies.items() if isinstance(bodies, dict) else ()):
        if not isinstance(body, dict):
            continue
        for key in ("mass", "com", "inertia"):
            if key in body:
                yield from leaves(("bodies", name, key), body[key], f"body {name!r} {key}")
        for key in ("points", "frames", "world_frames"):
            table = body.get(key)
            for point, pos in (table.items() if isinstance(table, dict) else ()):
                what = f"point {point!r}" if key == "points" else f"frame {point!r}"
                yield from leaves(("bodies", name, key, point), pos, what)
    for name, joint in (joints.items() if isinstance(joints, dict) else ()):
        for key in ("origin", "q0", "v0"):
            if isinstance(joint, dict) and key in joint:
                yield from leaves(("joints", name, key), joint[key], f"joint {name!r} {key}")
    if gravity is not None:
        yield from leaves(("gravity",), gravity, "gravity")

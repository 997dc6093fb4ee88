"""Symbolic kinematics that keeps expressions local (compact) for tree-structured mechanisms.

Composing poses as 4x4 matrices multiplies out cos/sin of every joint angle: a chain of N links
gives entries with ~2^N terms and mass-matrix entries that need trigonometric simplification. Here

* a :class:`Rotation` stays in axis-angle form while it is composed with rotations about the same
  axis (a planar chain gives R(q1 + q2 + q3), not a product of three matrices);
* a :class:`Vector` is a sum of rotated constant vectors Σ R_t c_t, so that rotations combine
  before they are multiplied out, and a dot product u·w = Σ c_tᵀ (R_t⁻¹ R_s) c_s is formed with
  relative rotations (cos(q2 + q3) rather than cos(q1+q2)cos(q1+q2+q3) + sin(...)sin(...)).

General 3D chains fall back to matrix products where axes differ; results are exact either way.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import sympy as sp

from ..expressions import as_expr
from .screw import exp_so3


@dataclass(frozen=True)
class Rotation:
    """A rotation: axis-angle (``axis`` a unit 3-tuple, ``angle`` rad) or a general matrix."""

    axis: tuple | None
    angle: Any
    general: sp.ImmutableMatrix | None = None

    @staticmethod
    def about(axis: tuple, angle: Any) -> Rotation:
        """The rotation by ``angle`` (rad) about the unit ``axis``."""
        return Rotation(tuple(axis), as_expr(angle))

    @staticmethod
    def identity() -> Rotation:
        """No rotation."""
        return Rotation(None, sp.Integer(0))

    @property
    def is_identity(self) -> bool:
        """True for no rotation (no axis, or a zero angle, and no general matrix)."""
        return self.general is None and (self.axis is None or self.angle == 0)

    @property
    def matrix(self) -> sp.Matrix:
        """The 3x3 rotation matrix."""
        if self.general is not None:
            return sp.Matrix(self.general)
        if self.is_identity:
            return sp.eye(3)
        return sp.Matrix(_axis_angle_matrix(self.axis, self.angle))

    def __matmul__(self, other: Rotation) -> Rotation:
        if self.is_identity:
            return other
        if other.is_identity:
            return self
        if self.general is None and other.general is None and self.axis == other.axis:
            return Rotation.about(self.axis, self.angle + other.angle)
        return Rotation(None, None, sp.ImmutableMatrix(self.matrix * other.matrix))

    def inverse(self) -> Rotation:
        """The inverse rotation (the negative angle, or the transpose)."""
        if self.is_identity:
            return self
        if self.general is None:
            return Rotation.about(self.axis, -self.angle)
        return Rotation(None, None, sp.ImmutableMatrix(self.general.T))

    def key(self) -> tuple:
        """A hashable key: equal keys, equal rotations (merges the terms of a Vector)."""
        if self.is_identity:
            return ("I",)
        return ("aa", self.axis, self.angle) if self.general is None else ("M", self.general)


@functools.lru_cache(maxsize=65536)
def _axis_angle_matrix(axis: tuple, angle: sp.Expr) -> sp.ImmutableMatrix:
    """Rotation matrix of (axis, angle), cached: the same relative rotations recur many times."""
    c, s = sp.cos(angle), sp.sin(angle)
    if axis == (0, 1, 0):
        return sp.ImmutableMatrix([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    if axis == (1, 0, 0):
        return sp.ImmutableMatrix([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == (0, 0, 1):
        return sp.ImmutableMatrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    return sp.ImmutableMatrix(exp_so3(sp.Matrix(axis), angle))


@dataclass(frozen=True)
class Vector:
    """A 3-vector Σ R_t c_t (world or frame coordinates), terms with equal rotations merged."""

    terms: tuple[tuple[Rotation, sp.ImmutableMatrix], ...]

    @staticmethod
    def of(c: Any, R: Rotation | None = None) -> Vector:
        """The vector ``R c`` (``c`` three components; R default: none)."""
        return Vector(((R or Rotation.identity(), sp.ImmutableMatrix(sp.Matrix(c))),))._merged()

    @staticmethod
    def zero() -> Vector:
        """The zero vector."""
        return Vector(())

    def _merged(self) -> Vector:
        groups: dict[tuple, list] = {}
        for R, c in self.terms:
            entry = groups.setdefault(R.key(), [R, sp.zeros(3, 1)])
            entry[1] = entry[1] + sp.Matrix(c)
        terms = tuple((R, sp.ImmutableMatrix(c.applyfunc(sp.expand))) for R, c in groups.values()
                      if any(sp.expand(x) != 0 for x in c))
        return Vector(terms)

    def __add__(self, other: Vector) -> Vector:
        return Vector(self.terms + other.terms)._merged()

    def __neg__(self) -> Vector:
        return Vector(tuple((R, -c) for R, c in self.terms))

    def __sub__(self, other: Vector) -> Vector:
        return self + (-other)

    def scaled(self, s: Any) -> Vector:
        """The vector times the scalar ``s``."""
        return Vector(tuple((R, c * s) for R, c in self.terms))._merged()

    def rotated(self, R: Rotation) -> Vector:
        """R applied to the vector."""
        return Vector(tuple((R @ Rt, c) for Rt, c in self.terms))._merged()

    def cross(self, other: Vector) -> Vector:
        """self × other, each term pair formed in the frame of the second term (R_a a × R_b b =
        R_b ((R_b⁻¹ R_a a) × b): a joint axis then stays constant in the link frames)."""
        out = []
        for Ra, a in self.terms:
            for Rb, b in other.terms:
                rel = (Rb.inverse() @ Ra).matrix * sp.Matrix(a)
                out.append((Rb, sp.ImmutableMatrix(rel.cross(sp.Matrix(b)))))
        return Vector(tuple(out))._merged()

    def dot(self, other: Vector) -> sp.Expr:
        """self · other, formed term by term with relative rotations."""
        total = sp.Integer(0)
        for Ra, a in self.terms:
            for Rb, b in other.terms:
                total += (sp.Matrix(a).T * (Ra.inverse() @ Rb).matrix * sp.Matrix(b))[0, 0]
        return sp.expand(total)

    def in_frame(self, R: Rotation) -> Vector:
        """Coordinates in a frame whose axes are R (i.e. Rᵀ applied)."""
        return self.rotated(R.inverse())

    def matrix(self) -> sp.Matrix:
        """The vector as one 3x1 matrix (its terms rotated and summed)."""
        out = sp.zeros(3, 1)
        for R, c in self.terms:
            out += R.matrix * sp.Matrix(c)
        return out


@dataclass(frozen=True)
class Frame:
    """A pose: origin ``p`` and axes ``R``, both relative to the world frame."""

    R: Rotation
    p: Vector

    @staticmethod
    def world() -> Frame:
        """The world frame."""
        return Frame(Rotation.identity(), Vector.zero())

    def compose(self, R: Rotation | None = None, shift: Any = None) -> Frame:
        """The frame moved by ``shift`` (in this frame's axes) then rotated by ``R``."""
        p = self.p if shift is None else self.p + Vector.of(shift).rotated(self.R)
        return Frame(self.R if R is None else self.R @ R, p)

    def point(self, c: Any) -> Vector:
        """A point given in this frame's coordinates, as a world vector."""
        return self.p + Vector.of(c).rotated(self.R)

"""Small symbolic building blocks of the recursive multibody (:mod:`.multibody`).

Vectors are lists of three sympy expressions; zeros stay exact zeros, so a planar mechanism
keeps only its planar components. A :class:`Rotation` is kept in the cheapest exact form:

* the identity;
* axis-angle, ``R = c 1 + s ã + (1 − c) a aᵀ`` with ``c = cos θ``, ``s = sin θ`` as named
  intermediates: rotations about one axis compose by adding angles (a planar chain gives
  cos(θ_{k−1} + q_k), never products of cosines);
* a 3x3 matrix whose entries are named intermediates (rotations about different axes).

Every quantity that is used more than once is given to a ``make(name, expr)`` callback, which
returns a symbol standing for it (a compiler intermediate) or ``expr`` itself; so expressions stay
O(1) in size whatever the depth of the tree, and the compiler differentiates through them by the
chain rule.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import sympy as sp

Vec = list
Make = Callable[[str, Any], Any]
ZERO3 = (sp.Integer(0),) * 3


def written_out(name: str, expr: Any) -> Any:
    """A ``make`` that keeps every quantity as an expression (for values needed without
    intermediates, e.g. initial states)."""
    return expr


def _nonzero(x: Any) -> bool:
    return x != 0


def add(*vectors: Sequence) -> Vec:
    """Componentwise sum of 3-vectors."""
    return [sp.Add(*[v[i] for v in vectors if _nonzero(v[i])]) for i in range(3)]


def sub(a: Sequence, b: Sequence) -> Vec:
    """Componentwise difference a − b of 3-vectors."""
    return add(a, scale(-1, b))


def scale(s: Any, a: Sequence) -> Vec:
    """The 3-vector ``a`` times the scalar ``s`` (exact zeros kept)."""
    return [s * x if _nonzero(x) else sp.S.Zero for x in a]


def _products(pairs: Iterable[tuple[Any, Any]]) -> Any:
    return sp.Add(*[x * y for x, y in pairs if _nonzero(x) and _nonzero(y)])


def dot(a: Sequence, b: Sequence) -> Any:
    """The dot product of two 3-vectors (terms with an exact zero left out)."""
    return _products(zip(a, b))


def cross(a: Sequence, b: Sequence) -> Vec:
    """The cross product a × b of two 3-vectors (terms with an exact zero left out)."""
    return [_products(((a[1], b[2]), (-a[2], b[1]))), _products(((a[2], b[0]), (-a[0], b[2]))),
            _products(((a[0], b[1]), (-a[1], b[0])))]


def named(make: Make, name: str, vector: Sequence, labels: str = "xyz") -> Vec:
    """``make`` applied to each component (names ``name.x``, ``name.y``, ``name.z``)."""
    return [make(f"{name}.{labels[i]}", vector[i]) for i in range(len(vector))]


def _axis_angle_rows(axis: tuple, c: Any, s: Any) -> tuple:
    """Rows of c 1 + s ã + (1 − c) a aᵀ (exact zeros and ones for a coordinate axis)."""
    if axis in ((1, 0, 0), (0, 1, 0), (0, 0, 1)):
        k = axis.index(1)
        i, j = (k + 1) % 3, (k + 2) % 3
        rows = [[sp.S.Zero] * 3 for _ in range(3)]
        rows[k][k] = sp.S.One
        rows[i][i] = rows[j][j] = c
        rows[i][j], rows[j][i] = -s, s
        return tuple(tuple(r) for r in rows)
    a = axis
    skew = ((0, -a[2], a[1]), (a[2], 0, -a[0]), (-a[1], a[0], 0))
    return tuple(tuple(sp.Add(c if i == j else 0, s * skew[i][j], (1 - c) * a[i] * a[j])
                       for j in range(3)) for i in range(3))


@dataclass(frozen=True)
class Rotation:
    """A rotation matrix in one of three exact forms (see the module docstring).

    ``axis`` (unit 3-tuple) and ``angle`` for the axis-angle form (``rows`` then holds its
    matrix in terms of the cosine and sine intermediates); ``rows`` (3x3) alone for the matrix
    form; neither for the identity.
    """

    axis: tuple | None = None
    angle: Any = None
    rows: tuple | None = None

    def apply(self, v: Sequence) -> Vec:
        """R v."""
        if self.rows is None:
            return list(v)
        return [dot(row, v) for row in self.rows]

    def apply_T(self, v: Sequence) -> Vec:
        """Rᵀ v."""
        if self.rows is None:
            return list(v)
        return [dot([row[i] for row in self.rows], v) for i in range(3)]

    def congruence(self, J: Sequence[Sequence]) -> list[list]:
        """R J Rᵀ of a symmetric 3x3 ``J`` (rows)."""
        if self.rows is None:
            return [list(r) for r in J]
        RJ = [[dot(self.rows[i], [J[k][j] for k in range(3)]) for j in range(3)] for i in range(3)]
        return [[dot(RJ[i], self.rows[j]) if j >= i else None for j in range(3)] for i in range(3)]

    def then(self, step: Rotation, make: Make, name: str) -> Rotation:
        """This rotation followed by ``step`` (in the rotated frame): R · R_step, with angles
        added when both turn about the same axis (intermediates ``name.th``, ``name.c``,
        ``name.s``), else as a matrix (``name.R<i><j>``)."""
        if self.rows is None:
            return step
        if step.rows is None:
            return self
        if self.axis is not None and self.axis == step.axis:
            angle = make(f"{name}.th", self.angle + step.angle)
            return Rotation(step.axis, angle, _axis_angle_rows(
                step.axis, make(f"{name}.c", sp.cos(angle)), make(f"{name}.s", sp.sin(angle))))
        rows = tuple(tuple(make(f"{name}.R{i}{j}", dot(self.rows[i], [r[j] for r in step.rows]))
                           for j in range(3)) for i in range(3))
        return Rotation(rows=rows)

    @staticmethod
    def turn(axis: Sequence, q: Any, make: Make, name: str) -> Rotation:
        """Rot(axis, q) about a unit ``axis``, with cos q and sin q as ``name.c``, ``name.s``."""
        axis = tuple(axis)
        return Rotation(axis, q, _axis_angle_rows(axis, make(f"{name}.c", sp.cos(q)),
                                                  make(f"{name}.s", sp.sin(q))))

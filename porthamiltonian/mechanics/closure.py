"""Closed kinematic loops and constraints of a multibody: their tables and their rows φ(q), G(q).

A :class:`~.multibody.Multibody` is a tree; a mechanism with loops is that tree plus constraints
on it. Each constraint contributes *rows*: a velocity-level row g(q)·v = 0 (G's row, over the
multibody's velocities v) and, for a holonomic row, its position-level residual φ(q) = 0 with
φ̇ = g·v exactly (G = ∂φ/∂q K(q), K the coordinates' kinematic map). The equations they enter
are in :mod:`.constrained`. Two tables declare them:

``loops`` — loop-closing joints, any joint type of the tree but free (a free joint constrains
nothing): ``{type, parent, child, origin, child_origin, axis | axes, active}``. The joint sits at
``origin`` in the parent's frame and at ``child_origin`` in the child's frame (m); at zero joint
motion the two frames are parallel (as for a tree joint). ``parent``/``child`` are bodies or
"world". Its rows are the components of the relative motion the joint forbids:

============== ==================================================================================
type           rows (λ: the constraint force / torque on the child, world axes)
============== ==================================================================================
spherical      x, y, z: the two joint points coincide, φ = x_C − x_P
revolute       x, y, z and w1, w2: the axes stay aligned, φ_i = (R_P (b_i × a))·(R_C a)
universal      x, y, z and w: the pins a1 (parent) and a2 (child) stay perpendicular,
               φ = (R_P a1)·(R_C a2)
prismatic      d1, d2: φ_i = (R_P b_i)·(x_C − x_P), b_i ⊥ axis; wx, wy, wz: no relative rotation,
               φ_x = (R_P e_z)·(R_C e_y) and cyclic
translational  the directions ⊥ the axes, and wx, wy, wz
weld           x, y, z and wx, wy, wz
============== ==================================================================================

(b1, b2, a) is a right-handed orthonormal frame of the axis a. A rotation row's torque acts about
the row's direction (R_C a × R_P(b_i × a) for a revolute row, b_i at alignment).

``constraints`` — constraints between body points, frames, joints and the ground:

* ``point``: ``{point, to | position, axes}``: the named point stays on another point (``to``)
  or at a world position (``position``, default the origin), along the world ``axes`` given
  (default all): a pin, a slot along a world line. λ: the force on the point's body (N).
* ``lock``: ``{joint, value}``: a revolute, prismatic, translational or universal joint's
  coordinates are held at ``value`` (default 0): a locked knee. λ: the generalized force.
* ``rolling``: ``{body, center, axis, radius, height}``: a disc of ``radius`` (a wheel, knife
  edge) with centre ``center`` and axle ``axis`` in the body's frame rolls without slipping on the
  ground z = ``height`` (world z up). The contact point is P = C + r d, d = the unit vector of the
  wheel plane pointing most downward, d ∝ −e_z + (e_z·a) a; rows: z (holonomic, the contact:
  φ = C_z − r √(1 − a_z²) − height) and x, y (no slip: the wheel's material velocity at P is zero;
  velocity level only, nonholonomic). λ: the contact force on the wheel at P (N).
* ``sphere``: ``{body, center, radius, height}``: a ball rolling without slipping on the ground:
  P = C − r e_z, the same rows.

Every constraint takes ``active``, an expression in parameters, 1 (the default) or 0: a mode
parameter a walker's rules switch (a knee that locks, a foot pinned in stance). Rows whose φ and
G are zero by structure (a planar mechanism's out-of-plane rows, whose axes are exact) are
dropped; the numeric rank of the rest is checked when a run starts
(:mod:`porthamiltonian.simulation.assembly`).
"""
from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import sympy as sp

from ..errors import ModelError, UnknownComponentError, ValidationError
from .joints import AXES, TYPES, axis
from .kinematics import ZERO3, Rotation, add, cross, dot, named, scale, sub

#: loop-closing joint types (a free joint would constrain nothing)
LOOP_TYPES = tuple(t for t in TYPES if t != "free")
#: constraint types and the fields each takes
CONSTRAINT_FIELDS = {
    "point": ("point", "to", "position", "axes"),
    "lock": ("joint", "value"),
    "rolling": ("body", "center", "axis", "radius", "height"),
    "sphere": ("body", "center", "radius", "height"),
}
_LOOP_FIELDS = ("type", "parent", "child", "origin", "child_origin", "axis", "axes", "active")
_LOCKABLE = ("revolute", "prismatic", "translational", "universal")


@dataclass(frozen=True)
class Row:
    """One constraint row: ``constraint`` (its name), ``label`` (the row within it: "x", "w1",
    …), ``phi`` (the holonomic residual φ(q), or None for a velocity-level row), ``G`` (its row
    of G over the multibody's velocities: φ̇ = G·v), ``active`` (1 or 0, an expression in
    parameters)."""

    constraint: str
    label: str
    phi: Any
    G: tuple
    active: Any

    @property
    def holonomic(self) -> bool:
        """Whether the row has a position-level residual."""
        return self.phi is not None


def _vector(value: Any, where: str, path: tuple) -> list:
    if value is None:
        return [0, 0, 0]
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ModelError(f"{where}: expected three components [x, y, z], got {value!r}", path=path)
    return list(value)


def validate(loops: Any, constraints: Any, bodies: Mapping, joints: Mapping,
             points: Mapping[str, str]) -> None:
    """Check the ``loops`` and ``constraints`` tables against the tree (``points``: point name ->
    its body). Every problem is found before any is raised, each a typed error naming its entry
    and field (its key path): one problem is raised as itself, several as a ValidationError
    listing them (:attr:`~porthamiltonian.errors.ModelError.problems`)."""
    found: list[ModelError] = []
    taken = set(joints) | set(points)
    for key, table in (("loops", loops), ("constraints", constraints)):
        if table is None:
            continue
        if not isinstance(table, Mapping):
            found.append(ModelError(f"Multibody {key} must be a table name -> {{type, ...}}",
                                    path=(key,)))
            continue
        for name, entry in table.items():
            where = f"Multibody {key[:-1]} {name!r}"
            if not isinstance(entry, Mapping):
                found.append(ModelError(f"{where}: expected a table {{type, ...}}",
                                        path=(key, name)))
                continue
            if name in taken:
                found.append(ModelError(f"{where}: the name is already used by a joint, point "
                                        "or another loop or constraint", path=(key, name)))
            taken.add(name)
            checks = (_loop_checks(name, entry, bodies, where) if key == "loops" else
                      _constraint_checks(name, entry, bodies, joints, points, where))
            for check in checks:
                try:
                    check()
                except ModelError as err:
                    found.append(err)
    if len(found) == 1:
        raise found[0]
    if found:
        raise ValidationError(f"Multibody loops and constraints: {len(found)} problems:\n"
                              + "\n".join(f"  {err}" for err in found), problems=found)


def _body(value: Any, bodies: Mapping, where: str, path: tuple, world: bool = True) -> None:
    if value == "world" and world:
        return
    if value not in bodies:
        raise UnknownComponentError(f"{where}: {path[-1]} {value!r} is not a body ("
                                    f"{', '.join(bodies)}{', world' if world else ''})", path=path)


def _known_fields(entry: Mapping, allowed: Sequence[str], where: str, hint: str,
                  path: tuple) -> Callable[[], None]:
    """The check that ``entry`` has no field outside ``allowed`` (its error: ``where``, the
    unknown fields, then ``hint``)."""
    def check() -> None:
        extra = set(entry) - set(allowed)
        if extra:
            raise ModelError(f"{where}: unknown field(s) {', '.join(sorted(extra))}; {hint}",
                             path=(*path, min(extra)))
    return check


def _loop_checks(name: str, entry: Mapping, bodies: Mapping,
                 where: str) -> list[Callable[[], None]]:
    """The independent checks of one loop entry (each raises its problem; see
    :func:`validate`)."""
    path = ("loops", name)
    kind = entry.get("type")

    fields = _known_fields(entry, _LOOP_FIELDS, where, f"fields: {', '.join(_LOOP_FIELDS)}", path)

    def type_() -> None:
        if kind not in LOOP_TYPES:
            raise ModelError(f"{where}: type must be one of {', '.join(LOOP_TYPES)}, got "
                             f"{kind!r}", path=(*path, "type"))

    def sides() -> None:
        if entry.get("parent") == entry.get("child"):
            raise ModelError(f"{where}: parent and child are the same body",
                             path=(*path, "child"))

    def axes() -> None:
        if kind in ("revolute", "prismatic"):
            axis(entry.get("axis"), where, (*path, "axis"))
        if kind in ("universal", "translational"):
            given = entry.get("axes")
            count = 2 if kind == "universal" else None
            if not isinstance(given, list) or not given or (count and len(given) != count) or \
                    len(given) > 3:
                raise ModelError(f"{where}: a {kind} loop needs axes, e.g. "
                                 f"{['x', 'y'] if count else ['x', 'z']}", path=(*path, "axes"))
            vectors = [axis(a, where, (*path, "axes", i)) for i, a in enumerate(given)]
            if kind == "universal" and abs(float(sum(x * y for x, y in zip(*vectors)))) > 1e-12:
                raise ModelError(f"{where}: the pins of a universal loop (axes[0] in the parent, "
                                 "axes[1] in the child) must be perpendicular at zero joint "
                                 "motion", path=(*path, "axes"))

    def body(side: str) -> Callable[[], None]:
        return lambda: _body(entry.get(side), bodies, where, (*path, side))

    def vector(field: str) -> Callable[[], None]:
        def check() -> None:
            _vector(entry.get(field), f"{where} {field}", (*path, field))
        return check

    return [fields, type_, body("parent"), body("child"), sides, vector("origin"),
            vector("child_origin"), axes]


def _constraint_checks(name: str, entry: Mapping, bodies: Mapping, joints: Mapping,
                       points: Mapping[str, str], where: str) -> list[Callable[[], None]]:
    """The checks of one constraint entry (see :func:`validate`): its type and fields, then
    (for a known type) its values."""
    path = ("constraints", name)
    kind = entry.get("type")
    if kind not in CONSTRAINT_FIELDS:
        def type_() -> None:
            raise ModelError(f"{where}: type must be one of {', '.join(CONSTRAINT_FIELDS)}, "
                             f"got {kind!r}", path=(*path, "type"))
        return [type_]
    allowed = ("type", "active", *CONSTRAINT_FIELDS[kind])

    fields = _known_fields(entry, allowed, where,
                           f"a {kind} constraint takes {', '.join(allowed)}", path)

    def values() -> None:
        _constraint_values(kind, entry, bodies, joints, points, where, path)

    return [fields, values]


def _constraint_values(kind: str, entry: Mapping, bodies: Mapping, joints: Mapping,
                       points: Mapping[str, str], where: str, path: tuple) -> None:
    """The values of a constraint entry of a known ``kind`` (its first problem raised)."""
    if kind == "point":
        for field in ("point", "to"):
            value = entry.get(field)
            if (field == "point" or value is not None) and value not in points:
                raise UnknownComponentError(f"{where}: {field} {value!r} is not a point of the "
                                            f"multibody ({', '.join(points) or 'none'})",
                                            path=(*path, field))
        if "to" in entry and "position" in entry:
            raise ModelError(f"{where}: give 'to' (a point) or 'position' (world), not both",
                             path=(*path, "position"))
        _vector(entry.get("position"), f"{where} position", (*path, "position"))
        axes = entry.get("axes", ["x", "y", "z"])
        if not isinstance(axes, list) or not axes or any(a not in AXES for a in axes) or \
                len(set(axes)) != len(axes):
            raise ModelError(f"{where}: axes must be a list of distinct world axes 'x', 'y', "
                             f"'z', got {axes!r}", path=(*path, "axes"))
    elif kind == "lock":
        joint = entry.get("joint")
        if joint not in joints:
            raise UnknownComponentError(f"{where}: joint {joint!r} is not a joint of the "
                                        f"multibody ({', '.join(joints)})", path=(*path, "joint"))
        if joints[joint].get("type") not in _LOCKABLE:
            raise ModelError(f"{where}: only {', '.join(_LOCKABLE)} joints can be locked, "
                             f"{joint!r} is {joints[joint].get('type')}", path=(*path, "joint"))
    else:
        _body(entry.get("body"), bodies, where, (*path, "body"), world=False)
        _vector(entry.get("center"), f"{where} center", (*path, "center"))
        if "radius" not in entry:
            raise ModelError(f"{where}: a {kind} constraint needs a radius (m)", path=path)
        if kind == "rolling":
            axis(entry.get("axis"), where, (*path, "axis"))


def expression_fields(loops: Any, constraints: Any) -> Iterator[tuple[tuple, Any, str]]:
    """Every expression of the two tables as ``(key path, value, what)`` (see
    :func:`.bodies.expression_fields`)."""
    for key, fields in (("loops", ("origin", "child_origin", "active")),
                        ("constraints", ("position", "value", "center", "radius", "height",
                                         "active"))):
        table = loops if key == "loops" else constraints
        for name, entry in (table.items() if isinstance(table, Mapping) else ()):
            for field in fields:
                value = entry.get(field) if isinstance(entry, Mapping) else None
                if value is None:
                    continue
                items = list(enumerate(value)) if isinstance(value, list) else [(None, value)]
                for i, item in items:
                    path = (key, name, field) if i is None else (key, name, field, i)
                    yield path, item, f"{key[:-1]} {name!r} {field}"


def _frame(a: tuple) -> tuple[tuple, tuple]:
    """Two unit vectors b1, b2 with (b1, b2, a) right-handed orthonormal (exact for a
    coordinate axis)."""
    smallest = min(range(3), key=lambda i: (abs(float(a[i])), i))
    b1 = _normalized(cross(a, _unit(smallest)))
    return b1, tuple(cross(a, b1))


def _normalized(v: Sequence) -> tuple:
    norm = sp.sqrt(dot(v, v))
    return tuple(x / norm for x in v)


class Closures:
    """Builds the rows of a multibody's loops and constraints (see the module docstring) from
    its tree after :meth:`.tree.Tree.world`: ``placement`` (body -> (link or None, offset)),
    ``make`` the multibody's intermediate maker, ``parse(value, what)`` its expression parser,
    ``velocity_index`` (joint -> its velocity indices), ``coordinate`` (joint -> its coordinate
    symbols), ``points`` (point -> (body, local position as given))."""

    def __init__(self, tree: Any, placement: Mapping, make: Callable[[str, Any], Any],
                 parse: Callable[[Any, str], Any], velocity_index: Mapping[str, list[int]],
                 coordinate: Mapping[str, list], points: Mapping[str, tuple[str, list]]):
        self.tree = tree
        self.placement = placement
        self.make = make
        self.parse = parse
        self.n = tree.n
        self.velocity_index = velocity_index
        self.coordinate = coordinate
        self.points = points

    # --- geometry -----------------------------------------------------------------------------
    def _site(self, body: str, local: Sequence, name: str) -> tuple[Any, list, Rotation]:
        """(link or None, world position, world rotation) of a point fixed to ``body`` (or the
        world) at ``local`` (body frame)."""
        if body == "world":
            return None, list(local), Rotation()
        link, offset = self.placement[body]
        x = add(offset, local)
        if link is None:
            return None, x, Rotation()
        return link, named(self.make, name, self.tree.point(link, x)), self.tree.pos[link].world_R

    def _row(self, sites: Sequence[tuple[Any, list, int]], torque: Sequence, force: Sequence,
             name: str) -> tuple:
        """G's row of a unit wrench (world torque, force) acting on each ``(link, x, sign)``:
        Σ sign · (the generalized forces of the wrench at x on the link), as intermediates."""
        row = [sp.S.Zero] * self.n
        for link, x, sign in sites:
            if link is None:
                continue
            for k, value in self.tree.load(link, x, torque, force):
                row[k] = row[k] + sign * value
        return tuple(self.make(f"{name}.{k}", e) if e != 0 else sp.S.Zero
                     for k, e in enumerate(row))

    def _vector(self, value: Any, what: str) -> list:
        return [self.parse(v, what) for v in _vector(value, what, ())]

    # --- rows ---------------------------------------------------------------------------------
    def rows(self, loops: Mapping | None, constraints: Mapping | None) -> list[Row]:
        """Every row of the two tables, in their order, structurally zero rows left out."""
        out: list[Row] = []
        for name, entry in (loops or {}).items():
            active = self.parse(entry.get("active", 1), f"loop {name!r} active")
            out += [Row(name, label, phi, g, active) for label, phi, g in self._loop(name, entry)]
        makers = {"point": self._point, "lock": self._lock, "rolling": self._rolling,
                  "sphere": self._rolling}
        for name, entry in (constraints or {}).items():
            active = self.parse(entry.get("active", 1), f"constraint {name!r} active")
            out += [Row(name, label, phi, g, active)
                    for label, phi, g in makers[entry["type"]](name, entry)]
        return [r for r in out if any(e != 0 for e in r.G) or (r.phi is not None and r.phi != 0)]

    def _loop(self, name: str, entry: Mapping) -> Iterator[tuple[str, Any, tuple]]:
        kind = entry["type"]
        base = f"loop.{name}"
        parent, child = entry["parent"], entry["child"]
        link_p, x_p, R_p = self._site(parent, self._vector(entry.get("origin"), f"loop {name!r} "
                                                            "origin"), f"{base}.xp")
        link_c, x_c, R_c = self._site(child, self._vector(entry.get("child_origin"),
                                                          f"loop {name!r} child_origin"),
                                      f"{base}.xc")
        r = sub(x_c, x_p)
        points = [(link_c, x_c, 1), (link_p, x_p, -1)]
        if kind in ("prismatic", "translational"):
            given = [entry["axis"]] if kind == "prismatic" else entry["axes"]
            axes = [axis(a, f"loop {name!r}") for a in given]
            for i, d in enumerate(_complement(axes)):
                dw = named(self.make, f"{base}.d{i + 1}", R_p.apply(d))
                phi = self.make(f"{base}.phi.d{i + 1}", dot(dw, r))
                # φ̇ = d·(v_C − v_P) + (ω_P × d)·r: the force d on the two points, the torque
                # d × r on the parent
                g = self._row(points, ZERO3, dw, f"{base}.G.d{i + 1}")
                turn = self._row([(link_p, x_p, 1)], cross(dw, r), ZERO3, f"{base}.G.d{i + 1}r")
                yield f"d{i + 1}", phi, tuple(
                    self.make(f"{base}.G.d{i + 1}s.{k}", a + c) if a != 0 and c != 0 else a + c
                    for k, (a, c) in enumerate(zip(g, turn)))
        else:
            for i, label in enumerate("xyz"):
                e = [sp.S.One if j == i else sp.S.Zero for j in range(3)]
                yield label, r[i], self._row(points, ZERO3, e, f"{base}.G.{label}")
        turns = [(link_c, x_c, 1), (link_p, x_p, -1)]
        if kind in ("weld", "prismatic", "translational"):
            for i, label in enumerate(("wx", "wy", "wz")):
                j, k = (i + 1) % 3, (i + 2) % 3
                ej, ek = _unit(j), _unit(k)
                a_c, b_p = R_c.apply(ej), R_p.apply(ek)
                yield (label, *self._rot(base, label, a_c, b_p, turns))
        elif kind == "revolute":
            a = axis(entry["axis"], f"loop {name!r}")
            for i, b in enumerate(_frame(a)):
                yield (f"w{i + 1}", *self._rot(base, f"w{i + 1}", R_c.apply(a),
                                               R_p.apply(cross(b, a)), turns))
        elif kind == "universal":
            a1, a2 = (axis(x, f"loop {name!r}") for x in entry["axes"])
            yield ("w", *self._rot(base, "w", R_c.apply(a2), R_p.apply(a1), turns))

    def _rot(self, base: str, label: str, a_c: list, b_p: list, turns: list) -> tuple:
        """(φ, G row) of the rotation row φ = b_p · a_c (world vectors fixed in the parent and
        the child): φ̇ = (ω_C − ω_P)·(a_c × b_p)."""
        a_c = named(self.make, f"{base}.{label}.c", a_c)
        b_p = named(self.make, f"{base}.{label}.p", b_p)
        u = named(self.make, f"{base}.{label}.u", cross(a_c, b_p))
        phi = self.make(f"{base}.phi.{label}", dot(b_p, a_c))
        return phi, self._row(turns, u, ZERO3, f"{base}.G.{label}")

    def _point(self, name: str, entry: Mapping) -> Iterator[tuple[str, Any, tuple]]:
        base = f"con.{name}"
        body, local = self.points[entry["point"]]
        link_a, x_a, _ = self._site(body, self._vector(local, f"point {entry['point']!r}"),
                                    f"{base}.xa")
        if entry.get("to") is not None:
            other, where = self.points[entry["to"]]
            link_b, x_b, _ = self._site(other, self._vector(where, f"point {entry['to']!r}"),
                                        f"{base}.xb")
        else:
            link_b, x_b = None, self._vector(entry.get("position"), f"constraint {name!r} "
                                             "position")
        for label in entry.get("axes", ["x", "y", "z"]):
            i = "xyz".index(label)
            e = _unit(i)
            yield label, x_a[i] - x_b[i], self._row([(link_a, x_a, 1), (link_b, x_b, -1)],
                                                     ZERO3, e, f"{base}.G.{label}")

    def _lock(self, name: str, entry: Mapping) -> Iterator[tuple[str, Any, tuple]]:
        coords = self.coordinate[entry["joint"]]
        value = entry.get("value", 0)
        values = value if isinstance(value, list) else [value] * len(coords)
        if len(values) != len(coords):
            raise ModelError(f"Multibody constraint {name!r}: value needs {len(coords)} "
                             f"entries, got {value!r}", path=("constraints", name, "value"))
        for j, (k, q, v) in enumerate(zip(self.velocity_index[entry["joint"]], coords, values)):
            row = tuple(sp.S.One if i == k else sp.S.Zero for i in range(self.n))
            label = "q" if len(coords) == 1 else f"q{j + 1}"
            yield label, q - self.parse(v, f"constraint {name!r} value"), row

    def _rolling(self, name: str, entry: Mapping) -> Iterator[tuple[str, Any, tuple]]:
        base = f"con.{name}"
        link, c, R = self._site(entry["body"], self._vector(entry.get("center"), f"constraint "
                                                            f"{name!r} center"), f"{base}.c")
        radius = self.parse(entry["radius"], f"constraint {name!r} radius")
        height = self.parse(entry.get("height", 0), f"constraint {name!r} height")
        if entry["type"] == "sphere":
            d, depth = [sp.S.Zero, sp.S.Zero, sp.S.NegativeOne], radius
        else:
            a = named(self.make, f"{base}.a", R.apply(axis(entry["axis"], f"constraint "
                                                           f"{name!r}")))
            s = self.make(f"{base}.s", sp.sqrt(1 - a[2] ** 2))      # |e_z × a|
            d = named(self.make, f"{base}.d", [a[0] * a[2] / s, a[1] * a[2] / s, -s])
            depth = radius * s
        arm = scale(radius, d)                                     # P − C
        for i, label in enumerate("xyz"):
            e = _unit(i)
            g = self._row([(link, c, 1)], cross(arm, e), e, f"{base}.G.{label}")
            yield label, (c[2] - depth - height if label == "z" else None), g


def _unit(i: int) -> list:
    return [sp.S.One if j == i else sp.S.Zero for j in range(3)]


def _complement(axes: list[tuple]) -> list[tuple]:
    """Unit directions completing ``axes`` (unit, independent) to an orthonormal set."""
    if len(axes) == 1:
        return list(_frame(axes[0]))
    if len(axes) == 2:
        return [_normalized(cross(axes[0], axes[1]))]
    return []


__all__ = ["CONSTRAINT_FIELDS", "LOOP_TYPES", "Closures", "Row", "expression_fields", "validate"]

"""The joint types of a :class:`~.multibody.Multibody`: their coordinates, velocities and links.

Each joint moves its child body's frame relative to the parent body's frame, the joint sitting at
``origin`` (parent frame) and the child frame's origin on the joint. Per type:

============== ============================ ============================= ===================
type           coordinates (``q.J…``)       velocities / momenta          port (effort/flow)
============== ============================ ============================= ===================
revolute       angle about ``axis`` (rad)   its rate                      rotation, 1
prismatic      shift along ``axis`` (m)     its rate                      translation, 1
translational  one shift per ``axes`` entry their rates                   translation, n
universal      two angles: about ``axes[0]``  their rates                 rotation, 2
               then about ``axes[1]`` (in the
               frame turned by the first)
spherical      unit quaternion (w, x, y, z) angular velocity relative     rotation, 3
               ``J.qw … J.qz``              to the parent, child axes
                                            ``J.wx, J.wy, J.wz``
free           position of the child origin relative twist (ω, v), child  screw, 6
               (parent axes) ``J.x, J.y,    axes ``J.wx … J.vz``
               J.z`` and quaternion
               ``J.qw … J.qz``
weld           none                         none                          none
============== ============================ ============================= ===================

Coordinates of translational and universal joints are named by their axes (``J.x``, ``J.z``) when
the axes are given as "x", "y", "z", else ``J.a1``, ``J.a2``. The momenta are named as the
velocities (``p.J.wx``). A quaternion joint's rotation is that of q/|q| (so drift of |q| changes
nothing physical); its rate carries a term along q that pulls |q| back to 1 (see
:func:`~.tree.quaternion_rate`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from ..errors import ModelError
from ..modeling.ports import DOMAINS

AXES = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}
TYPES = ("revolute", "prismatic", "translational", "universal", "spherical", "free", "weld")
_QUATERNION = ("qw", "qx", "qy", "qz")
_TWIST = ("wx", "wy", "wz", "vx", "vy", "vz")


def axis(value: Any, where: str, path: tuple = ()) -> tuple:
    """A unit axis from "x", "y", "z" or three numbers (``path``: the key path of errors)."""
    if isinstance(value, str) and value in AXES:
        return AXES[value]
    try:
        vec = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: axis must be 'x', 'y', 'z' or three numbers, got {value!r}",
                         path=path) from None
    if vec.shape != (3,) or not np.linalg.norm(vec) > 0:
        raise ModelError(f"{where}: axis must be a non-zero 3-vector, got {value!r}", path=path)
    vec = vec / np.linalg.norm(vec)
    return tuple(sp.nsimplify(v) if float(v).is_integer() else float(v) for v in vec)


@dataclass(frozen=True)
class Joint:
    """A joint's structure: ``velocities`` and ``coordinates`` (labels, e.g. "hip.x"), the
    elementary ``links`` it adds ((kind, axis, label): see :class:`~.tree.Link`), the
    ``domain`` of its port, and the default initial values."""

    name: str
    type: str
    velocities: tuple[str, ...]
    coordinates: tuple[str, ...]
    links: tuple[tuple[str, tuple | None, str], ...]
    domain: str | None
    q0: tuple
    v0: tuple


def joint(name: str, table: dict) -> Joint:
    """The structure of joint ``name`` from its table (type and axis/axes checked)."""
    where = f"Multibody joint {name!r}"
    jtype = table.get("type")
    if jtype not in TYPES:
        raise ModelError(f"{where}: type must be one of {', '.join(TYPES)}, got {jtype!r}",
                         path=("joints", name, "type"))
    if jtype in ("revolute", "prismatic"):
        kind = "rotation" if jtype == "revolute" else "translation"
        a = axis(table.get("axis"), where, ("joints", name, "axis"))
        return Joint(name, jtype, (name,), (name,), ((kind, a, name),),
                     "rotation" if jtype == "revolute" else "translation", (0,), (0,))
    if jtype in ("translational", "universal"):
        axes = table.get("axes")
        count = 2 if jtype == "universal" else None
        if not isinstance(axes, list) or not axes or (count and len(axes) != count):
            example = "['x', 'y']" if count else "['x', 'z']"
            raise ModelError(f"{where}: a {jtype} joint needs axes, e.g. {example}",
                             path=("joints", name, "axes") if "axes" in table else ("joints", name))
        if jtype == "translational" and any(ax not in AXES for ax in axes):
            raise ModelError(f"{where}: translational axes are 'x', 'y' or 'z', got {axes!r}",
                             path=("joints", name, "axes"))
        vectors = [axis(ax, where, ("joints", name, "axes", i)) for i, ax in enumerate(axes)]
        named = all(isinstance(ax, str) for ax in axes)
        labels = tuple(f"{name}.{ax}" if named else f"{name}.a{i + 1}" for i, ax in enumerate(axes))
        for i in range(len(vectors)):
            for j in range(i):
                if abs(float(np.dot(vectors[i], vectors[j]))) > 1 - 1e-12:
                    raise ModelError(f"{where}: coordinates {labels[j]!r} and {labels[i]!r} move "
                                     f"along parallel axes ({axes!r}): the mass matrix would be "
                                     "singular; give different axes",
                                     path=("joints", name, "axes"))
        kind = "rotation" if jtype == "universal" else "translation"
        return Joint(name, jtype, labels, labels,
                     tuple((kind, a, label) for a, label in zip(vectors, labels)),
                     "rotation" if jtype == "universal" else "translation",
                     (0,) * len(axes), (0,) * len(axes))
    if jtype == "spherical":
        return Joint(name, jtype, tuple(f"{name}.{c}" for c in _TWIST[:3]),
                     tuple(f"{name}.{c}" for c in _QUATERNION), (("spherical", None, name),),
                     "rotation", (1, 0, 0, 0), (0, 0, 0))
    if jtype == "free":
        return Joint(name, jtype, tuple(f"{name}.{c}" for c in _TWIST),
                     tuple(f"{name}.{c}" for c in ("x", "y", "z", *_QUATERNION)),
                     (("free", None, name),), "screw", (0, 0, 0, 1, 0, 0, 0), (0,) * 6)
    return Joint(name, jtype, (), (), (), None, (), ())


def quaternion_slice(spec: Joint) -> slice | None:
    """Where the quaternion sits among the joint's coordinates (None: no quaternion)."""
    if spec.type == "spherical":
        return slice(0, 4)
    if spec.type == "free":
        return slice(3, 7)
    return None


def units(spec: Joint) -> tuple[list[str], list[str]]:
    """The SI units of the joint's coordinates (rad, m, or 1 for a quaternion's entries) and of
    its momenta (N*m*s for a rotation rate, N*s for a linear rate)."""
    rotation, translation = DOMAINS["rotation"], DOMAINS["translation"]
    if spec.type in ("spherical", "free"):
        shift = [translation.displacement_unit] * 3 if spec.type == "free" else []
        linear = [translation.momentum_unit] * 3 if spec.type == "free" else []
        return [*shift, *["1"] * 4], [rotation.momentum_unit] * 3 + linear
    domain = DOMAINS[spec.domain] if spec.domain else rotation
    return ([domain.displacement_unit] * len(spec.coordinates),
            [domain.momentum_unit] * len(spec.velocities))

"""JSON values of sweeps: cases, fixed arguments and results as plain JSON.

:func:`to_jsonable` turns results (dataclasses, numpy arrays and scalars, complex numbers) into
JSON values — complex numbers become ``{"re": ..., "im": ...}``, non-finite floats ``null``.
:func:`plain_value` is the strict version for what identifies a sweep (cases and fixed
arguments): it refuses non-finite numbers and objects instead of converting them.
:func:`canonical` is the canonical JSON text (sorted keys, no spaces) that identities hash.
"""
from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .errors import SweepError

__all__ = ["canonical", "plain_value", "to_jsonable"]


def to_jsonable(obj: Any) -> Any:
    """``obj`` as JSON values: dataclasses (through their ``to_dict`` when they have one) and
    mappings as objects, sequences and arrays as lists, numpy scalars as numbers, complex numbers
    as ``{"re", "im"}``, NaN and ±inf as None; anything else as its ``str``."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        if hasattr(obj, "to_dict"):
            return to_jsonable(obj.to_dict())
        return {f.name: to_jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [to_jsonable(v) for v in obj.tolist()]
    if isinstance(obj, (complex, np.complexfloating)):
        return {"re": to_jsonable(float(obj.real)), "im": to_jsonable(float(obj.imag))}
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        value = float(obj)
        return value if math.isfinite(value) else None
    if obj is None or isinstance(obj, str):
        return obj
    return str(obj)


def plain_value(value: Any, where: str) -> Any:
    """``value`` as a JSON value of a case or a fixed argument (numpy scalars and arrays become
    Python numbers and lists); :class:`SweepError` naming ``where`` for a non-finite number or a
    value JSON cannot hold."""
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        value = value.tolist()
    if isinstance(value, bool) or value is None or isinstance(value, (str, int)):
        return value
    if isinstance(value, float):
        if not math.isfinite(value):
            raise SweepError(f"{where}: value {value!r} is not finite")
        return value
    if isinstance(value, (list, tuple)):
        return [plain_value(v, where) for v in value]
    if isinstance(value, Mapping) and all(isinstance(k, str) for k in value):
        return {k: plain_value(v, where) for k, v in value.items()}
    raise SweepError(f"{where}: value {value!r} of type {type(value).__name__} is not a number, "
                     "string, bool, list or dict (sweep values are stored as JSON)")


def canonical(obj: Any) -> str:
    """Canonical JSON text of ``obj``: sorted keys, no spaces, NaN refused."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)

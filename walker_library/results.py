"""JSON serialization of the analysis results (SI units, named fields).

:func:`to_jsonable` turns dataclasses, numpy arrays and scalars into plain JSON values: complex
numbers become ``{"re": ..., "im": ...}``, non-finite floats become ``null``.
"""
from __future__ import annotations

import dataclasses
import json
import math
from typing import Any

import numpy as np

__all__ = ["JSONResult", "to_jsonable", "to_json"]


def to_jsonable(obj: Any) -> Any:
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


def to_json(obj: Any, indent: int | None = 1) -> str:
    return json.dumps(to_jsonable(obj), indent=indent, allow_nan=False)


class JSONResult:
    """Mixin of the analyses' result dataclasses: ``to_dict()`` (every field, JSON-able) and
    ``to_json()``. A result with a custom layout overrides ``to_dict``."""

    def to_dict(self) -> dict:
        return to_jsonable(self.__dict__)

    def to_json(self, indent: int | None = 1) -> str:
        return to_json(self.to_dict(), indent)

"""JSON serialization of the analysis results (SI units, named fields).

:func:`to_jsonable` turns dataclasses, numpy arrays and scalars into plain JSON values: complex
numbers become ``{"re": ..., "im": ...}``, non-finite floats become ``null``.
"""
from __future__ import annotations

import json
from typing import Any

from porthamiltonian.batch.values import to_jsonable

__all__ = ["JSONResult", "to_json", "to_jsonable"]


def to_json(obj: Any, indent: int | None = 1) -> str:
    """``obj`` (see :func:`to_jsonable`) as JSON text."""
    return json.dumps(to_jsonable(obj), indent=indent, allow_nan=False)


class JSONResult:
    """Mixin of the analyses' result dataclasses: ``to_dict()`` (every field, JSON-able) and
    ``to_json()``. A result with a custom layout overrides ``to_dict``."""

    def to_dict(self) -> dict:
        """Every field, JSON-ready."""
        return to_jsonable(self.__dict__)

    def to_json(self, indent: int | None = 1) -> str:
        """:meth:`to_dict` as JSON text."""
        return to_json(self.to_dict(), indent)

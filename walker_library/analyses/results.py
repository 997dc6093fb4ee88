"""The analysis results as JSON (SI units, named fields), and their views for notebooks.

:func:`to_jsonable` turns dataclasses, numpy arrays and scalars into plain JSON values: complex
numbers become ``{"re": ..., "im": ...}``, non-finite floats become ``null``.

A result shows itself in a notebook (``GaitResult._repr_html_``, ``GaitResult.plot()``,
``ContinuationResult.figure(path)``) through views that the report stage draws: the report
registers them here (:func:`register_view`, when :mod:`walker_library.report.display` is
imported, which the package does), and a result looks them up by its class and the view's name
(:func:`view`). So the analyses never import the report, and a result knows nothing of HTML or
matplotlib.
"""
from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from porthamiltonian.batch.values import to_jsonable

__all__ = ["JSONResult", "register_view", "to_json", "to_jsonable", "view"]

#: the registered views: (result class, view name) -> the function that draws it
_VIEWS: dict[tuple[type, str], Callable[..., Any]] = {}


def register_view(kind: type, name: str, function: Callable[..., Any]) -> None:
    """Register ``function`` as the view ``name`` (``"html"``, ``"plot"``, ``"figure"``) of the
    results of class ``kind``; it is called with the result and the view's arguments."""
    _VIEWS[(kind, name)] = function


def view(result: Any, name: str) -> Callable[..., Any]:
    """The view ``name`` registered for ``result``'s class (or a base class of it)."""
    for kind in type(result).__mro__:
        if (kind, name) in _VIEWS:
            return _VIEWS[(kind, name)]
    raise LookupError(f"no {name!r} view of a {type(result).__name__} is registered (import "
                      "walker_library, whose report stage registers the views)")


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

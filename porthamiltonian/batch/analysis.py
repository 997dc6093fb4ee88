"""A named case function for the command lines' ``sweep`` commands.

An :class:`Analysis` bundles a case function (given as a callable or lazily as
``"module:function"``, imported when used), an optional ``prepare`` run once in the main process
before any case, the statuses that are not failures, and the result columns worth printing.
``prepare(cases, **fixed)`` validates the cases (raising a
:class:`~porthamiltonian.errors.ModelError` that names the bad case), warms this process's caches
(forked workers inherit them) and may return the sweep's *shared* arguments — values derived
from ``fixed`` that every case needs, computed once (e.g. a gait that a basin's points all start
from).
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["Analysis"]


@dataclass(frozen=True)
class Analysis:
    """A case function for ``sweep --analysis NAME`` (see the module docstring)."""

    name: str
    function: str | Callable
    doc: str
    prepare: str | Callable | None = None
    ok_statuses: tuple[str, ...] = ("ok",)
    columns: tuple[str, ...] = ()

    @classmethod
    def adhoc(cls, ref: str) -> Analysis:
        """The analysis of a user's own ``"module:function"`` case function."""
        return cls(ref, ref, f"case function {ref}")

    def resolve(self) -> Callable:
        """The case function (imported now if given by name)."""
        from .runner import resolve_function  # the sweep runner: only when a sweep runs

        return resolve_function(self.function)

    def run_prepare(self, cases: list[dict], fixed: Mapping[str, Any]) -> dict[str, Any]:
        """Run ``prepare`` (if any); the shared arguments it returns ({} for none)."""
        if self.prepare is None:
            return {}
        from .runner import resolve_function

        return dict(resolve_function(self.prepare)(cases, **fixed) or {})

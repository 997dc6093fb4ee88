"""The problems of a walker table, collected and raised as one error naming the file and lines.

:class:`Problems` collects every problem the readers (:mod:`.reading`) and the plan
(:mod:`.plan`) find, each with the line of its key in the file when the TOML text is known, and
raises them as one :class:`~porthamiltonian.errors.ModelFileError`; :func:`suggestion` is the
"did you mean" hint for a misspelt name.
"""
from __future__ import annotations

import difflib
from collections.abc import Iterable

from porthamiltonian.errors import ModelFileError
from porthamiltonian.interfaces.io import locate

__all__ = ["Problems", "suggestion"]


class Problems:
    """Collects the problems of a ``[walker]`` table; raises them as one ModelFileError."""

    def __init__(self, source: str, text: str):
        self.source, self.text = source, text
        self.items: list[tuple[int | None, str]] = []

    def add(self, message: str, *path: str | int, table: str = "walker") -> None:
        """Record a problem about the key at ``path`` of ``[table]`` (its line when known)."""
        line = locate(self.text, table, *path) if self.text else None
        self.items.append((line, message))

    def raise_if_any(self) -> None:
        """Raise the problems recorded so far as one ModelFileError (none: return)."""
        if not self.items:
            return
        if len(self.items) == 1:
            line, msg = self.items[0]
            raise ModelFileError(f"{self.source}{f', line {line}' if line else ''}: {msg}")
        lines = "\n".join(f"  {f'line {line}: ' if line else ''}{msg}" for line, msg in self.items)
        raise ModelFileError(f"{self.source}: {len(self.items)} problems in its [walker] table "
                             f"(see docs/walkers.md):\n{lines}")


def suggestion(name: str, known: Iterable[str]) -> str:
    """The hint ' (did you mean ...?)' for a misspelt name, or an empty string."""
    close = difflib.get_close_matches(str(name), [str(k) for k in known], n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""

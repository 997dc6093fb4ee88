"""Public names of a package imported on first use (PEP 562 module ``__getattr__``/``__dir__``),
so that importing the package does not import every module behind its names."""
from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any


def lazy_names(package: str, names: Mapping[str, str], *,
               first: str | None = None) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``(__getattr__, __dir__)`` pair of the package ``package``: ``names`` maps each public
    name to the submodule (relative to the package) that defines it; on its first use that
    submodule is imported (after the submodule ``first``, when given) and the value kept in the
    package's namespace. An unknown name raises AttributeError."""

    def __getattr__(name: str) -> Any:
        if name not in names:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        if first is not None:
            importlib.import_module(f".{first}", package)
        value = getattr(importlib.import_module(f".{names[name]}", package), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted({*vars(sys.modules[package]), *names})

    return __getattr__, __dir__

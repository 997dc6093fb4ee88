"""On-disk cache of compiled models, keyed by a hash of the model description.

The key hashes the model's canonical description (components with their arguments, bonds,
parameters, events, outputs), the sources of the package modules that determine the generated code
(the component classes' modules and what they import, the compiler, the back ends, the integration
loops), the versions of sympy and of the code generator: editing the command line, the analyses or
a docstring of an unrelated module keeps every cached model. An entry is two files: ``<key>.json`` (state/parameter/output layout,
equations for display) and ``<key>.py`` (the generated code body); the back-end modules
``<key>_<backend>.py`` are derived from the body. Writes are atomic (write, then rename), so
concurrent sweep workers can share one cache.

Location: ``$PORTHAMILTONIAN_CACHE`` or ``~/.cache/porthamiltonian``.
"""
from __future__ import annotations

import functools
import hashlib
import inspect
import json
import os
import re
import tempfile
from pathlib import Path
from typing import Any

import sympy

from ..model import Model
from .codegen import CODEGEN_VERSION


def cache_dir() -> Path:
    path = Path(os.environ.get("PORTHAMILTONIAN_CACHE", Path.home() / ".cache" / "porthamiltonian"))
    path.mkdir(parents=True, exist_ok=True)
    return path


def model_key(model: Model) -> str:
    """A hash of everything that determines the generated code: the model's canonical
    description, the source of every package module the model's component classes depend on
    (their modules and, transitively, the package modules those import), the compiler and
    back-end sources, and the versions of sympy and of the code generator."""
    from ..io import model_to_dict  # io imports the compiler's users; import late

    description = model_to_dict(model)
    modules = {type(c).__module__ for c in _all_components(model)}
    blob = json.dumps({"model": description, "classes": _sources_hash(frozenset(modules)),
                       "sympy": sympy.__version__, "codegen": CODEGEN_VERSION},
                      sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:32]


_PACKAGE = Path(__file__).resolve().parent.parent
#: package modules that shape the generated code whatever the model holds
_CORE = ("compiler", "backends", "integrators", "component", "ports", "expressions", "model",
         "elements")
_IMPORT = re.compile(r"^\s*from\s+(\.+)([\w.]*)\s+import\s+([\w, ()]+)", re.MULTILINE)


@functools.cache
def _sources_hash(modules: frozenset[str]) -> str:
    """sha256 over the sources of ``modules`` (dotted names; those outside the package by name
    and, where found, source), the core modules, and every package module they import."""
    files: set[Path] = set()
    outside: list[str] = []
    todo = [_PACKAGE / name for name in _CORE]
    for module in modules:
        if module.split(".")[0] == _PACKAGE.name:
            todo.append(_PACKAGE.joinpath(*module.split(".")[1:]))
        else:
            outside.append(_outside_source(module))
    while todo:
        base = todo.pop()
        candidates = sorted(base.rglob("*.py")) if base.is_dir() else [base.with_suffix(".py")]
        for path in candidates:
            if path in files or not path.is_file():
                continue
            files.add(path)
            for dots, name, names in _IMPORT.findall(path.read_text()):
                root = path.parent
                for _ in range(len(dots) - 1):
                    root = root.parent
                target = root.joinpath(*name.split(".")) if name else root
                todo.append(target)
                if target.is_dir():  # ``from . import cache``: the named submodules
                    todo += [target / n.strip() for n in names.strip("()").split(",") if n.strip()]
    digest = hashlib.sha256()
    for path in sorted(files):
        digest.update(str(path.relative_to(_PACKAGE)).encode() + b"\0" + path.read_bytes())
    for text in sorted(outside):
        digest.update(text.encode())
    return digest.hexdigest()


def _outside_source(module: str) -> str:
    """Source text of a component module defined outside the package (e.g. a user's own
    component), or its name when the source is not available."""
    import sys

    try:
        return inspect.getsource(sys.modules[module])
    except (KeyError, OSError, TypeError):
        return module


def _all_components(model: Model):
    for _, comp in model.components():
        if isinstance(comp, Model):
            yield from _all_components(comp)
        else:
            yield comp


def write_atomic(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    with os.fdopen(fd, "w") as fh:
        fh.write(text)
    os.replace(tmp, path)


def read(key: str) -> tuple[dict[str, Any], str] | None:
    base = cache_dir() / key
    try:
        meta = json.loads(base.with_suffix(".json").read_text())
        body = base.with_suffix(".py").read_text()
    except (OSError, ValueError):
        return None
    return meta, body


def write(key: str, meta: dict[str, Any], body: str) -> None:
    base = cache_dir() / key
    write_atomic(base.with_suffix(".py"), body)
    write_atomic(base.with_suffix(".json"), json.dumps(meta, indent=1))


def backend_module(key: str, backend: str, text: str) -> Path:
    """Path of the back-end module for ``key``, written if missing or different."""
    path = cache_dir() / f"m{key}_{backend}.py"
    if not path.exists() or path.read_text() != text:
        write_atomic(path, text)
    return path

"""On-disk cache of compiled models, keyed by a hash of the model description.

The key hashes the model's canonical description (components with their arguments, bonds,
parameters, events, outputs), the source of every component class used, the versions of sympy and
of the code generator. An entry is two files: ``<key>.json`` (state/parameter/output layout,
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
    """A hash of everything that determines the generated code."""
    from ..io import model_to_dict  # io imports the compiler's users; import late

    description = model_to_dict(model)
    classes = {type(c) for c in _all_components(model)}
    sources = sorted(_class_source(cls) for cls in classes)
    blob = json.dumps({"model": description, "classes": sources, "sympy": sympy.__version__,
                       "codegen": CODEGEN_VERSION, "compiler": _compiler_hash()},
                      sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:32]


@functools.lru_cache(maxsize=None)
def _class_source(cls: type) -> str:
    """Source of the module defining a component class (the class and the helpers it calls)."""
    try:
        return inspect.getsource(inspect.getmodule(cls))
    except (OSError, TypeError):
        try:
            return inspect.getsource(cls)
        except (OSError, TypeError):
            return f"{cls.__module__}.{cls.__qualname__}"


def _compiler_hash() -> str:
    """Hash of the package's own source (compiler, components, mechanics, integration loop), so
    that a changed library never reuses stale generated code."""
    global _COMPILER_HASH
    if _COMPILER_HASH is None:
        root = Path(__file__).resolve().parent.parent
        files = sorted(root.rglob("*.py"))
        _COMPILER_HASH = hashlib.sha256(b"".join(f.read_bytes() for f in files)).hexdigest()
    return _COMPILER_HASH


_COMPILER_HASH: str | None = None


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

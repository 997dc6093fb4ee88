"""Snapshots: plain data kept in the compiled-model cache so that a second run starts at once.

Reading a file into something runnable (a walker file into a walker: the model read, its
expressions parsed with sympy, the model's graph built with networkx, the plan checked, the model
compiled) costs far more than running it for a moment. A reader that has done that work keeps
what it needs to start again as a *snapshot*: a JSON document (never a pickle) in an entry of the
compiled-model cache (:mod:`.cache`), so the next run with the same file reads one small verified
file, reopens the compiled model (:func:`porthamiltonian.compiler.reopen`) and needs neither sympy
nor networkx.

Key
---
sha256 of: the ``kind`` of snapshot and the ``identity`` the reader gives (the file's text, the
path it was read from, the options that shaped the result), the package version, a digest of the
source of the package and of the reader's packages (so that an edited module, in a checkout
whose version did not change, never meets a snapshot of the old code), the C compiler's identity
and the back ends ``"auto"`` tries (``$PORTHAMILTONIAN_BACKEND``).

Trust
-----
The snapshot is a cache file like every other: written atomically with its sha256 in the entry's
manifest, read only from a private folder, verified before it is used (a damaged or edited file
gives one :class:`~.cache.CacheWarning`, is removed, and the reader does the work again and
stores a new one). Its content is data: a reader rebuilds its records from it with its own
checks (:func:`recall` returns it only when it is a JSON object of this format, kind and key);
nothing in it is imported, unpickled or evaluated.
"""
from __future__ import annotations

import functools
import hashlib
import json
import os
import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar, cast

from .. import backends
from ..backends import native
from ..version import __version__
from . import cache

__all__ = ["FORMAT", "deferred", "package_made", "recall", "remember", "snapshot_key"]

#: the snapshot document's format (a reader of another format's document ignores it)
FORMAT = 1
#: the snapshot's file in its cache entry
_FILE = "snapshot.json"


@functools.cache
def _sources(packages: tuple[str, ...]) -> str:
    """sha256 over the Python sources (and C templates) of the imported ``packages``."""
    digest = hashlib.sha256()
    for name in packages:
        module = sys.modules.get(name)
        root = Path(module.__file__).parent if module is not None and module.__file__ else None
        if root is None:
            digest.update(f"{name}: not imported\0".encode())
            continue
        found = []                       # (one walk of the tree, its byte-code folders skipped)
        for folder, subfolders, files in os.walk(root):
            subfolders[:] = [d for d in subfolders if d != "__pycache__"]
            found += [Path(folder, f) for f in files if f.endswith((".py", ".c"))]
        for path in sorted(found):
            digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def snapshot_key(kind: str, identity: Mapping[str, Any], packages: Sequence[str] = (),
                 backend: str = "auto") -> str:
    """The cache key of the snapshot of ``kind`` for ``identity`` (JSON-able; module docstring),
    made by code of the packages ``packages`` (besides this one) for the back end ``backend``."""
    content = {"kind": kind, "identity": identity, "version": __version__,
               "sources": _sources(("porthamiltonian", *packages)),
               "compiler": native.compiler_identity(),
               "backends": list(backends.candidates(backend))}
    blob = json.dumps(content, sort_keys=True, allow_nan=False)
    return "s" + hashlib.sha256(blob.encode()).hexdigest()[:31]


def remember(key: str, kind: str, data: Mapping[str, Any]) -> None:
    """Keep ``data`` (a JSON-able mapping: numbers, text, lists, tables) as the snapshot ``key``
    (:func:`snapshot_key`) of ``kind``."""
    document = {"format": FORMAT, "kind": kind, "key": key, "data": data}
    cache.store(key, _FILE, json.dumps(document, separators=(",", ":")))  # order kept


def recall(key: str, kind: str) -> dict[str, Any] | None:
    """The data of snapshot ``key`` of ``kind`` when it is in the cache, intact (its sha256 in
    the manifest) and of this format; else None (a damaged file is reported once, removed, and
    the caller does the work again)."""
    raw = cache.load_verified(key, _FILE)
    if raw is None:
        return None
    try:
        document = json.loads(raw)
    except (ValueError, UnicodeDecodeError):
        return None
    if (not isinstance(document, dict) or document.get("format") != FORMAT
            or document.get("kind") != kind or document.get("key") != key
            or not isinstance(document.get("data"), dict)):
        return None
    data: dict[str, Any] = document["data"]
    return data


def package_made(components: Iterable[object]) -> bool:
    """Whether the ``components`` (a description's) are all of this package's classes: only
    then may a snapshot stand for them (a class defined elsewhere, a user's, could change
    without the package's sources, and so the key, changing)."""
    return all(type(c).__module__.split(".")[0] == "porthamiltonian" for c in components)


class _Deferred:
    """Stands for an object of a file's full read that a restored snapshot does without: an
    attribute is looked up on ``load()``'s result (read once, on first use); the attributes in
    ``known`` are answered without it."""

    __slots__ = ("_known", "_load")

    def __init__(self, load: Callable[[], Any], **known: Any):
        self._load = load
        self._known = known

    def __getattr__(self, name: str) -> Any:
        if name in self._known:
            return self._known[name]
        return getattr(self._load(), name)

    def __repr__(self) -> str:
        return f"<{self._known.get('name', 'part')} of the file, read when first used>"


_T = TypeVar("_T")


def deferred(load: Callable[[], _T], **known: Any) -> _T:
    """A stand-in for ``load()``'s result, typed as that result: the attributes ``known`` (e.g.
    a model's ``name``) are answered at once, any other is read of ``load()``'s result, called
    once, on first use (``load`` should cache its result: the full read of the file the snapshot
    was keyed by)."""
    return cast(_T, _Deferred(load, **known))

"""A model file's warm start (``porthamiltonian simulate``, the model sweeps): what a run needs,
kept as a snapshot and restored without sympy or networkx.

Reading a model file builds its model (the components' laws with sympy, the bond graph with
networkx) and compiles it: about a second before a run that may take milliseconds. A run needs
the compiled model, the file's ``[simulation]`` settings and the model's name, all plain data or
in the compiled-model cache already. :func:`keep` stores them after a full read as a snapshot
(:mod:`porthamiltonian.compiler.snapshots`: JSON, verified by its sha256, keyed by the file's
text and path, the back end asked for, the package's version and sources and the C compiler);
:func:`restore` gives them back and reopens the compiled model
(:func:`porthamiltonian.compiler.reopen`). The model itself is then a stand-in that answers its
name at once and reads the file in full (the text the snapshot was keyed by) on first use of
anything else, e.g. the 3D view's bodies.

A snapshot is kept only when the settings are plain data (a JSON round trip gives them back
unchanged), the model's components are all the package's and the back end is the one asked for
(not a fallback); one that does not fit is ignored: the file is read in full and a new snapshot
stored.
"""
from __future__ import annotations

import functools
import json
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from ..backends import candidates
from ..compiler import (
    compiled_record,
    deferred,
    package_made,
    recall,
    remember,
    reopen,
    snapshot_key,
)
from ..errors import ModelError

if TYPE_CHECKING:
    from ..modeling.model import Model
    from ..simulation.compiled import CompiledModel

__all__ = ["KIND", "keep", "restore"]

#: the snapshot's kind (:func:`porthamiltonian.compiler.snapshot_key`)
KIND = "simulation"


def _key(source: str, text: str, backend: str | None) -> str:
    """The snapshot's key (None and "auto" ask for the same back end)."""
    return snapshot_key(KIND, {"source": source, "text": text, "backend": backend or "auto"})


def keep(model: Model, compiled: CompiledModel, settings: Mapping[str, Any], source: str,
         text: str, backend: str | None) -> None:
    """Store the snapshot of the model file ``text`` (read from ``source``, compiled with the
    back end ``backend`` asked for, None: "auto"): its ``model``'s name, the ``compiled``
    model's record and the completed ``settings``, when they can be restored as they are
    (module docstring)."""
    try:
        if compiled.backend != candidates(backend or "auto")[0]:
            return
    except ModelError:
        return
    if not package_made(model.freeze().components.values()):
        return
    try:
        plain = json.loads(json.dumps(dict(settings), allow_nan=False)) == dict(settings)
    except (TypeError, ValueError):
        plain = False
    if plain:
        remember(_key(source, text, backend), KIND,
                 {"name": model.name, "settings": dict(settings),
                  "model": compiled_record(compiled)})


def restore(source: str, text: str, backend: str | None,
            read: Callable[[], Model]) -> tuple[Model, CompiledModel, dict[str, Any]] | None:
    """(the model, the compiled model, the settings) of the model file ``text`` (read from
    ``source``; back end ``backend`` asked for, None: "auto") from its snapshot, or None when
    there is none that fits (then the file is read in full). ``read()`` reads the file's
    model in full: called when the model is first used beyond its name, or to compile it
    again if the compiled model needs it. Imports neither sympy nor networkx."""
    try:
        data = recall(_key(source, text, backend), KIND)
    except ModelError:
        return None
    if data is None:
        return None
    name, settings, record = data.get("name"), data.get("settings"), data.get("model")
    if not (isinstance(name, str) and isinstance(settings, dict) and isinstance(record, dict)):
        return None
    full = functools.cache(read)
    compiled = reopen(record, lambda: full().freeze())
    if compiled is None:
        return None
    return deferred(full, name=name), compiled, settings

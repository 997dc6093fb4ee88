"""numba's on-disk cache of a generated module's compiled functions, verified like every other
file of a compiled-model cache entry (:mod:`.cache`).

``numba.njit(cache=True)`` keeps each function's machine code in the module's ``__pycache__``:
an index (``<function>-<line>.py<ver>.nbi``) and one data file per signature (``.nbc``), both
*pickles*, unpickled by numba at the function's first call. numba checks only that the index
names the module's size and time stamp, so a damaged file fails every later run (an
UnpicklingError) and a planted one would run code. Here each dispatcher of the module gets a
:class:`numba.core.caching.FunctionCache` whose files are

* read whole, then checked against the sha256 recorded in the entry's manifest, and only then
  unpickled (a file that is not recorded, or does not match, is removed with one warning and
  the function compiled again);
* written under the entry's lock and recorded in the manifest in the same step
  (:func:`.cache.record_written`), so that concurrent processes (a sweep's workers) see each
  file with its record;
* looked up, and on a miss compiled and written, under the entry's compile lock
  (:func:`.cache.compiling`), so that concurrent processes compile a function once.

When the module is loaded, every file of its ``__pycache__`` is checked so (:func:`.cache.
pycache_usable`); a ``__pycache__`` that is not the user's private folder
(:func:`.cache.private_problem`) is removed, or when it cannot be, caching is off for the
module.

The integration loops, compiled once for all models (:mod:`porthamiltonian.backends.
numba_loops`), are a module of their own in an entry of their own, keyed by its text
(:func:`loop_module`), and their compiled code is kept and verified the same way.
"""
from __future__ import annotations

import hashlib
import io
import pickle
import types
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..backends import module, numba_loops
from . import cache

__all__ = ["loop_module", "verified_caches"]


def loop_module(use_cache: bool = True) -> types.ModuleType:
    """The numba back end's loop module (:func:`~porthamiltonian.backends.numba_loops.
    loops_text`), imported once per process from the cache entry keyed by a hash of its text,
    its dispatchers given verified caches (:func:`verified_caches`); with ``use_cache`` False,
    built in the private temporary folder."""
    if use_cache not in _LOOP_MODULES:
        text = numba_loops.loops_text()
        key = hashlib.sha256(("numba loops\0" + text).encode()).hexdigest()[:32]
        path = cache.backend_module(key, "numba", text, use_cache)
        _LOOP_MODULES[use_cache] = module.import_module(path, text, verified_caches(path.parent))
    return _LOOP_MODULES[use_cache]


#: this process's loop modules, by use_cache
_LOOP_MODULES: dict[bool, types.ModuleType] = {}


def verified_caches(entry: Path) -> Callable[[Any], None]:
    """A function that gives a numba dispatcher of a module in the cache entry ``entry`` a
    verified cache (module docstring); for :func:`porthamiltonian.backends.module.load`."""
    from numba.core.caching import FunctionCache, IndexDataCacheFile

    class VerifiedIndex(IndexDataCacheFile):
        """numba's index and data files, verified against the entry's manifest."""

        def _load_index(self) -> dict[Any, Any]:
            data = cache.read_recorded(entry, Path(self._index_path))
            if data is None:
                return {}
            stream = io.BytesIO(data)
            if pickle.load(stream) != self._version:
                return {}
            stamp, overloads = pickle.loads(stream.read())
            return overloads if stamp == self._source_stamp else {}

        def _load_data(self, name: str) -> Any:
            data = cache.read_recorded(entry, Path(self._data_path(name)))
            if data is None:
                raise OSError(f"{name}: not in the cache")      # numba's miss: compile again
            return pickle.loads(data)

        def save(self, key: Any, data: Any) -> None:
            with cache.record_written(entry, self._written):
                super().save(key, data)

        def _written(self) -> list[Path]:
            folder = Path(self._cache_path)
            stem = Path(self._index_name).stem
            return [Path(self._index_path)] + sorted(folder.glob(f"{stem}.*.nbc"))

    class VerifiedCache(FunctionCache):
        """FunctionCache over :class:`VerifiedIndex`."""

        def __init__(self, py_func: Any):
            super().__init__(py_func)
            old = self._cache_file
            self._cache_file = VerifiedIndex(old._cache_path, self._impl.filename_base,
                                             old._source_stamp)

    usable = cache.pycache_usable(entry)      # once per module: every file checked

    def attach(dispatcher: Any) -> None:
        verified = VerifiedCache(dispatcher.py_func)
        if not usable or Path(verified.cache_path).parent.resolve() != entry.resolve():
            dispatcher._cache.disable()          # not private, or outside the entry: no cache
            return
        dispatcher._cache = verified
        dispatcher.compile = _locked(dispatcher.compile, entry)
    return attach


def _locked(compile_function: Callable[[Any], Any], entry: Path) -> Callable[[Any], Any]:
    """A dispatcher's ``compile`` (load from the cache, or compile and save) run under the entry's
    compile lock (:func:`.cache.compiling`): a concurrent process that needs the same function
    (a sweep's or a test run's other worker) waits, then loads it from the cache instead of
    compiling it a second time. numba's own lock is taken first, as its compile does, so that
    threads of one process cannot hold the two in opposite orders."""
    from numba.core.compiler_lock import global_compiler_lock

    def compile_locked(sig: Any) -> Any:
        with global_compiler_lock, cache.compiling(entry):
            return compile_function(sig)
    return compile_locked

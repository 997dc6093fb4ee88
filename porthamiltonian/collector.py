"""Python's cyclic garbage collector paused around the work that builds a model.

Reading a model file the first time (importing sympy), the symbolic stage and the code generator
allocate hundreds of thousands of objects that live on (modules, sympy's caches) or die young
without forming reference cycles (expression trees, strings): reference counting frees those,
and the collector's passes over the growing heap find next to nothing. They cost about a tenth
of a cold build's Python time (on compass_walker ≈ 0.1–0.2 s of CPU over the file's reading and
the build; benchmarks/RESULTS.md). Objects in cycles made meanwhile are collected by the first
pass after the work.
"""
from __future__ import annotations

import contextlib
import gc
from collections.abc import Iterator


@contextlib.contextmanager
def paused() -> Iterator[None]:
    """The collector off while the block (or the decorated function) runs, then on again if it
    was on before; nested uses leave it to the outermost. Process-wide: other threads' objects
    are not collected meanwhile either (a build takes seconds, not hours)."""
    if not gc.isenabled():
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        gc.enable()

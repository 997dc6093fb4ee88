"""Shared helpers of the reliability tests (issue 10: model files are data, the cache is trusted
only when intact, every bad input gets a clear answer; issue 21: no bad input costs a user their
memory, their time, their page or their numbers).

``within(cpu, wall)`` bounds a block (issue 21): it fails when the block has not answered after
``wall`` seconds of wall-clock time (SIGALRM: a hang, a read that blocks) or used more than
``cpu`` seconds of processor time, its own and its children's (work; processor time, unlike the
wall clock, does not grow when other programs share the machine). ``capped(argv, memory)`` runs
a Python command line in a subprocess whose address space is capped (``resource.setrlimit``), for
the inputs whose cost is memory.

``REFUSAL_CPU``, ``HANG_WALL``, ``MODELS_DIR`` and ``capped`` live in bounds.py (tests import
them from there).

``audit`` records, through a Python audit hook (PEP 578), every event that would mean that data
ran as code or touched the system while a block runs: ``exec``/``compile`` of code, a process
started (``os.system``, ``subprocess.Popen``, ``os.posix_spawn``, ``os.fork``, ``os.exec*``), a
shared library loaded, a file opened for writing.
"""
from __future__ import annotations

import contextlib
import os
import resource
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import ClassVar

import pytest
from bounds import HANG_WALL, MODELS_DIR, REFUSAL_CPU, forget_generated

_FORBIDDEN = {"exec", "compile", "os.system", "subprocess.Popen", "os.posix_spawn", "os.spawn",
              "os.exec", "os.fork", "os.forkpty", "pty.spawn", "ctypes.dlopen", "os.startfile"}
_WRITE_FLAGS = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_APPEND | os.O_TRUNC


class _Recorder:
    active = False
    events: ClassVar[list] = []


def _hook(event: str, args: tuple) -> None:
    if not _Recorder.active:
        return
    if event in _FORBIDDEN:
        _Recorder.events.append((event, repr(args)[:200]))
    elif event == "open":
        path, mode, flags = (list(args) + [None, None])[:3]
        writes = (isinstance(mode, str) and any(c in mode for c in "wax+")) or (
            isinstance(flags, int) and flags & _WRITE_FLAGS)
        if writes:
            _Recorder.events.append(("open for writing", str(path)))


sys.addaudithook(_hook)


@contextlib.contextmanager
def _audit() -> Iterator[list]:
    _Recorder.events = []
    _Recorder.active = True
    try:
        yield _Recorder.events
    finally:
        _Recorder.active = False


@pytest.fixture
def audit():
    """``with audit() as events: ...`` then ``assert not events``."""
    return _audit


@pytest.fixture
def fresh(tmp_path, monkeypatch):
    """A fresh cache folder, nothing of it imported yet, and a process that has not seen the C
    back end fail (test files that need more define their own)."""
    from porthamiltonian import compiler
    from porthamiltonian.compiler import cache

    folder = tmp_path / "cache"
    monkeypatch.setenv("PORTHAMILTONIAN_CACHE", str(folder))
    monkeypatch.setattr(cache, "_refused", set())
    monkeypatch.setattr(compiler, "_C_FAILED", [])
    forget_generated()
    yield folder
    forget_generated()


@pytest.fixture
def forgotten():
    """``forgotten()``: :func:`forget_generated`, for a test."""
    return forget_generated


@pytest.fixture
def fresh_with_loops(fresh, seed_loops):
    """The test module's own ``fresh`` cache folder, holding the session's integration loops'
    object (tests/conftest.py, ``seed_loops``): for the tests of a model's entry or library on
    C, not for those of the loops' object, of compiler identities or of ``use_cache=False``."""
    seed_loops()
    return fresh


@pytest.fixture(scope="session")
def built_elsewhere(tmp_path_factory, seed_loops):
    """``built_elsewhere(model, backend, ph=False)``: ``models/<model>.toml`` compiled (with its
    port-Hamiltonian form when ``ph``) by a fresh process, so that this one has mapped none of
    its libraries, in a cache folder of its own seeded with the session's loops' object; the
    key and the folder of the entry, which a test copies (manifest and all) into its own cache
    to damage it. Once per (model, back end, ph) for the session."""
    built: dict[tuple[str, str, bool], tuple[str, Path]] = {}

    def get(model: str, backend: str, ph: bool = False) -> tuple[str, Path]:
        if (model, backend, ph) not in built:
            folder = tmp_path_factory.mktemp(f"built_{model}_{backend}") / "cache"
            with pytest.MonkeyPatch.context() as mp:
                mp.setenv("PORTHAMILTONIAN_CACHE", str(folder))
                seed_loops()
                build = subprocess.run(
                    [sys.executable, "-c", ("from porthamiltonian import compile_model, io; "
                                            f"print(compile_model(io.load({model!r}), "
                                            f"backend={backend!r}, ph={ph!r}).key)")],
                    capture_output=True, text=True, check=True, env=dict(os.environ))
            key = build.stdout.strip()
            built[model, backend, ph] = key, folder / key
        return built[model, backend, ph]

    return get


@pytest.fixture(scope="session")
def model_text():
    """``model_text(name)``: the text of ``models/<name>.toml``."""
    return lambda name: (MODELS_DIR / f"{name}.toml").read_text()


def _cpu() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


@contextlib.contextmanager
def _within(cpu: float = REFUSAL_CPU, wall: float = HANG_WALL) -> Iterator[None]:
    def hung(signum, frame):
        raise AssertionError(f"no answer within {wall:g} s (wall clock): the input hangs")

    previous = signal.signal(signal.SIGALRM, hung)
    signal.setitimer(signal.ITIMER_REAL, wall)
    start, t0 = _cpu(), time.monotonic()
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    used = _cpu() - start
    assert used <= cpu, (f"the answer took {used:.1f} s of processor time (bound {cpu:g} s; "
                         f"{time.monotonic() - t0:.1f} s of wall-clock time)")


@pytest.fixture
def within():
    """``with within(cpu=5, wall=120): ...`` (module docstring)."""
    return _within

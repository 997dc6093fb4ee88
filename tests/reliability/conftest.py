"""Shared helpers of the reliability tests (issue 10: model files are data, the cache is trusted
only when intact, every bad input gets a clear answer).

``audit`` records, through a Python audit hook (PEP 578), every event that would mean that data
ran as code or touched the system while a block runs: ``exec``/``compile`` of code, a process
started (``os.system``, ``subprocess.Popen``, ``os.posix_spawn``, ``os.fork``, ``os.exec*``), a
shared library loaded, a file opened for writing.
"""
from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import ClassVar

import pytest

from porthamiltonian import io

MODELS_DIR = Path(io.__file__).resolve().parents[2] / "models"

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


@pytest.fixture(scope="session")
def model_text():
    """``model_text(name)``: the text of ``models/<name>.toml``."""
    return lambda name: (MODELS_DIR / f"{name}.toml").read_text()

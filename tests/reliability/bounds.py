"""Bounds and paths the reliability tests import by name (a module of its own: two conftest.py
files share one module name, so a test must not import from one).

``capped(argv, memory)`` runs a Python command line in a subprocess whose address space is
capped (``resource.setrlimit``), for the inputs whose cost is memory; :data:`REFUSAL_CPU` and
:data:`HANG_WALL` bound a refusal (issue 21; conftest.py's ``within``). ``forget_generated``
and ``copy_entry`` serve the tests of the compiled-model cache."""
from __future__ import annotations

import os
import resource
import shutil
import subprocess
import sys
from pathlib import Path

from porthamiltonian import io

MODELS_DIR = Path(io.__file__).resolve().parents[2] / "models"

#: the bound of a refusal (issue 21): processor seconds, and a wall-clock guard against hangs
REFUSAL_CPU, HANG_WALL = 5.0, 120.0


def capped(argv: list[str], memory: int, *, timeout: float = HANG_WALL,
           env: dict | None = None, cwd: str | None = None) -> subprocess.CompletedProcess:
    """Run ``python argv...`` in a subprocess whose address space is capped at ``memory`` bytes
    (RLIMIT_AS, inherited by what it starts), with this process's import path."""
    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (memory, memory))

    environment = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path), **(env or {}))
    return subprocess.run([sys.executable, *argv], capture_output=True, text=True,
                          timeout=timeout, preexec_fn=limit, env=environment, cwd=cwd,
                          check=False)


def forget_generated() -> None:
    """Drop the generated models' modules this process imported (a fresh cache's are new)."""
    for name in [n for n in sys.modules if n.startswith("_porthamiltonian_generated_")]:
        del sys.modules[name]


def copy_entry(entry: Path, folder: Path) -> Path:
    """A copy of the cache entry ``entry`` (its files, time stamps and manifest) in the cache
    folder ``folder`` (made private, 0700, as a compile makes it, if missing); its path."""
    folder.mkdir(mode=0o700, exist_ok=True)
    shutil.copytree(entry, folder / entry.name)
    return folder / entry.name

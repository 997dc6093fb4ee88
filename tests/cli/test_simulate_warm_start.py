"""A model file simulated before starts from its snapshot (porthamiltonian/interfaces/warm.py):

* ``porthamiltonian simulate`` run again in a new process imports neither sympy nor networkx
  (nor matplotlib), and prints the first run's result, character for character (every number
  bit for bit: JSON floats are printed with their shortest round-trip form);
* the restored model answers its name from the snapshot and reads the file in full when used
  beyond it (the same description as the full read);
* a snapshot edited in the cache is refused (one CacheWarning), the file is read in full, and
  the snapshot stored again as it was.
"""
from __future__ import annotations

import contextlib
import json
import os
import subprocess
import sys
import warnings
from io import StringIO
from pathlib import Path

import pytest

from porthamiltonian.compiler.cache import CacheWarning, configured_dir
from porthamiltonian.interfaces import io, warm
from porthamiltonian.interfaces.cli import main
from porthamiltonian.interfaces.sweeps import SimulationModel

ROOT = Path(__file__).resolve().parents[2]
#: a model with events (the ball's bounces) and a [simulation] table
NAME = "bouncing_ball"
HEAVY = ("sympy", "networkx", "matplotlib")
#: the command
ARGV = ["simulate", NAME, "--json"]
#: run the command in a new interpreter; print its exit status, output and the heavy modules
_CODE = (
    "import contextlib, io, json, sys\n"
    "from porthamiltonian.interfaces.cli import main\n"
    "out = io.StringIO()\n"
    "with contextlib.redirect_stdout(out):\n"
    f"    status = main({ARGV!r})\n"
    f"print(json.dumps({{'status': status, 'out': out.getvalue(),\n"
    f"                  'heavy': [m for m in {HEAVY!r} if m in sys.modules]}}))\n")


def _run() -> dict:
    """The command in a new interpreter (this checkout, this test's cache)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *sys.path[1:]])}
    out = subprocess.run([sys.executable, "-c", _CODE], capture_output=True, text=True, env=env,
                         cwd=ROOT, timeout=600, check=False)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def _snapshot_path() -> Path:
    path = io.model_path(NAME)
    text = io.read_text(path, limit=io.MAX_FILE_SIZE, label=str(path), kind="model file",
                        language="TOML")
    return configured_dir() / warm._key(str(path), text, None) / "snapshot.json"


@pytest.fixture(scope="module")
def cold(tmp_path_factory: pytest.TempPathFactory, seed_loops):
    """The command run once, in this process (its entry point, ``main``: the new process is
    the second run's), in a fresh cache of this module's own (a full read, which leaves the
    snapshot), holding the session's integration loops' object (tests/conftest.py: not
    compiled again); its exit status and output."""
    mp = pytest.MonkeyPatch()
    mp.setenv("PORTHAMILTONIAN_CACHE", str(tmp_path_factory.mktemp("simulate_warm_cache")))
    seed_loops()
    out = StringIO()
    with contextlib.redirect_stdout(out):
        status = main(ARGV)
    yield {"status": status, "out": out.getvalue()}
    mp.undo()


def test_a_warm_simulate_imports_neither_sympy_nor_networkx(cold):
    assert cold["status"] == 0 and _snapshot_path().is_file()
    assert json.loads(cold["out"])["model"] == NAME
    again = _run()
    assert again["heavy"] == []
    assert again["status"] == 0
    assert again["out"] == cold["out"]                 # the same numbers, bit for bit


def test_the_restored_model_is_the_files(cold):
    restored = SimulationModel.load(NAME)
    assert type(restored.model).__name__ == "_Deferred"
    full = SimulationModel.from_file(io.read(NAME))
    assert restored.model.name == full.model.name == NAME
    assert restored.settings == full.settings
    assert restored.compiled.key == full.compiled.key
    assert restored.model.freeze().canonical() == full.model.freeze().canonical()  # read now


def test_a_tampered_snapshot_is_refused_and_rebuilt(cold):
    path = _snapshot_path()
    original = path.read_bytes()
    document = json.loads(original)
    document["data"]["settings"]["rtol"] = 0.5                # an edited setting
    path.write_text(json.dumps(document))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        again = SimulationModel.load(NAME)
    messages = [str(w.message) for w in caught if issubclass(w.category, CacheWarning)]
    assert len(messages) == 1 and "snapshot.json" in messages[0]
    assert type(again.model).__name__ != "_Deferred"            # read in full
    assert again.settings["rtol"] != 0.5
    assert path.read_bytes() == original                        # stored again, as it was
    assert type(SimulationModel.load(NAME).model).__name__ == "_Deferred"

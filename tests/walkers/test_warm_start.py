"""A walker loaded before starts from its snapshot (walker_library/core/warm.py):

* a second load in a new process imports neither sympy nor networkx (nor matplotlib), and its
  stride is the first load's, bit for bit; importing the packages and the ``walker`` command
  loads none of them either; a warm ``walker gait`` loads only the modules it runs (not scipy,
  the sweep runner, the progress bar, the other commands' machinery) and prints the gait of a
  full load;
* the restored walker is the file's: the same table, plan records and parameters, and its
  model (read when first used) is the file's model;
* a snapshot edited in the cache is refused (one CacheWarning naming it), the walker is loaded
  in full (with the file's values, not the edited ones) and a new snapshot is stored.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from porthamiltonian.compiler.cache import CacheWarning, configured_dir
from walker_library.core import warm
from walker_library.core.files import _file_text, load_walker

ROOT = Path(__file__).resolve().parents[2]
#: a rigid walker: its impact also reopens the floating multibody (python back end)
NAME = "compass_gait"
HEAVY = ("sympy", "networkx", "matplotlib")


def _run(code: str) -> dict:
    """Run ``code`` in a new interpreter (this checkout, this test's cache); its last line of
    output as JSON."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *sys.path[1:]])}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         cwd=ROOT, timeout=600, check=False)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def own_cache(tmp_path_factory: pytest.TempPathFactory, seed_loops):
    """A cache folder of this module's own (the snapshots it checks are the ones it makes, not
    whatever the session's earlier tests left in the shared cache), holding the session's
    integration loops' object (tests/conftest.py: not compiled again)."""
    mp = pytest.MonkeyPatch()
    mp.setenv("PORTHAMILTONIAN_CACHE", str(tmp_path_factory.mktemp("warm_start_cache")))
    seed_loops()
    yield
    mp.undo()


@pytest.fixture(scope="module")
def cold(own_cache):
    """The walker loaded once, in full (a fresh cache), and its stride from the initial guess;
    the next load is warm."""
    walker = load_walker(NAME)
    return walker, walker.stride(walker.initial_guess())


def _snapshot_path() -> Path:
    source, text = _file_text(NAME)
    return configured_dir() / warm._key(source, text, None) / "snapshot.json"


def test_a_warm_load_imports_neither_sympy_nor_networkx(cold):
    _, stride = cold
    assert _snapshot_path().is_file()
    found = _run(
        "import json, sys\n"
        "from walker_library.core.files import load_walker\n"
        f"w = load_walker({NAME!r})\n"
        "s = w.stride(w.initial_guess())\n"
        f"print(json.dumps({{'heavy': [m for m in {HEAVY!r} if m in sys.modules],\n"
        "                    'z': s.z_next.tolist(), 'time': s.duration,\n"
        "                    'deferred': type(w.spec.model).__name__}))\n")
    assert found["heavy"] == []
    assert found["deferred"] == "_Deferred"                     # it came from the snapshot
    assert found["z"] == stride.z_next.tolist()                 # bit for bit
    assert found["time"] == stride.duration


def test_the_packages_and_the_walker_command_import_no_symbolic_library():
    found = _run("import json, sys\nimport porthamiltonian, walker_library, walker_library.cli\n"
                 f"print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))\n")
    assert found == []


#: what a warm ``walker gait`` of a walker on the compiled loops never loads: besides the symbolic
#: and plotting libraries, scipy and pandas, the progress bar (no terminal), the sweep runner and
#: its process pools, the TOML parser (the snapshot is keyed by the file's text, which is not
#: parsed), and the machinery of the commands it does not run (the code generator, FMU export,
#: fitting, linearization, the model sweeps, the optimizer, continuation, gradients, step-down
#: and basins, the report)
NOT_ON_THE_WARM_PATH = (*HEAVY, "scipy", "pandas", "tqdm", "multiprocessing", "concurrent.futures",
                        "tomllib", "porthamiltonian.compiler.codegen", "porthamiltonian.fmu",
                        "porthamiltonian.batch.runner", "porthamiltonian.interfaces.fitting",
                        "porthamiltonian.interfaces.linearization",
                        "porthamiltonian.interfaces.sweeps", "porthamiltonian.simulation.fitting",
                        "porthamiltonian.simulation.linearize", "walker_library.analyses.optimize",
                        "walker_library.analyses.continuation", "walker_library.analyses.gradients",
                        "walker_library.analyses.robustness", "walker_library.report")


def test_a_warm_walker_gait_loads_only_what_it_runs():
    """``walker gait compass_walker --json`` after a first load (the session's cache holds the
    model and the snapshot): none of the modules above, and the gait of the walker loaded in
    full in this process, character for character."""
    from walker_library.analyses.gait import analyze_gait

    walker = load_walker("compass_walker")
    expected = analyze_gait(walker).to_json()
    # numba itself imports scipy, and concurrent.futures when it compiles or loads a function:
    # on that back end those two are numba's, not ours
    own = ("scipy", "concurrent.futures") if walker.backend == "numba" else ()
    forbidden = [name for name in NOT_ON_THE_WARM_PATH if name not in own]
    found = _run(
        "import contextlib, io, json, sys\n"
        "from walker_library.cli import main\n"
        "out = io.StringIO()\n"
        "with contextlib.redirect_stdout(out):\n"
        "    status = main(['gait', 'compass_walker', '--json'])\n"
        "print(json.dumps({'status': status, 'out': out.getvalue(), 'modules': sorted(sys.modules)}))\n")
    assert found["status"] == 0
    assert found["out"].strip() == expected
    loaded = [m for m in found["modules"]
              if any(m == name or m.startswith(f"{name}.") for name in forbidden)]
    assert loaded == []


def test_a_warm_walker_gait_in_text_reads_no_model_file(capsys):
    """``walker gait compass_walker`` printed as text (units and labels of every coordinate,
    which name the multibody's joint types) after a first load: neither sympy nor networkx nor
    matplotlib (the joint types come with the snapshot, the file is not read in full), and the
    text of this process's run, character for character."""
    from walker_library.cli import main

    load_walker("compass_walker")
    assert main(["gait", "compass_walker"]) == 0
    expected = capsys.readouterr().out
    found = _run(
        "import contextlib, io, json, sys\n"
        "from walker_library.cli import main\n"
        "out = io.StringIO()\n"
        "with contextlib.redirect_stdout(out):\n"
        "    status = main(['gait', 'compass_walker'])\n"
        f"print(json.dumps({{'status': status, 'out': out.getvalue(),\n"
        f"                  'heavy': [m for m in {HEAVY!r} if m in sys.modules]}}))\n")
    assert (found["status"], found["heavy"]) == (0, [])
    assert found["out"] == expected and " rad/s" in expected


def test_the_restored_walker_is_the_files(cold):
    walker, _ = cold
    restored = load_walker(NAME)
    assert type(restored.spec.model).__name__ == "_Deferred"
    assert restored.spec == walker.spec                          # the table as read
    for name in warm._PLAN_FIELDS:
        assert getattr(restored.plan, name) == getattr(walker.plan, name), name
    assert [m.text for m in restored.plan.bodies.masses] == \
        [m.text for m in walker.plan.bodies.masses]
    assert dict(restored.parameters) == dict(walker.parameters)
    np.testing.assert_array_equal(restored.run.p, walker.run.p)
    assert restored.model.key == walker.model.key
    # the parts read when first used: the file's model and description
    assert restored.spec.model.freeze().canonical() == walker.spec.model.freeze().canonical()
    assert restored.plan.description.canonical() == walker.plan.description.canonical()
    assert restored.name == walker.name == NAME


def test_a_tampered_snapshot_is_refused_and_rebuilt(cold):
    walker, _ = cold
    path = _snapshot_path()
    original = path.read_bytes()
    document = json.loads(original)
    slope = document["data"]["plan"]["parameters"]["@m"]["slope"]["f"]
    slope["value"] = 0.5                                     # an edited default
    path.write_text(json.dumps(document))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        again = load_walker(NAME)
    messages = [str(w.message) for w in caught if issubclass(w.category, CacheWarning)]
    assert len(messages) == 1 and "snapshot.json" in messages[0]
    assert "does not match its recorded sha256" in messages[0]
    assert type(again.spec.model).__name__ != "_Deferred"      # loaded in full
    assert again.parameters["slope"] == walker.parameters["slope"] != 0.5
    assert path.read_bytes() == original                         # stored again, as it was
    restored = load_walker(NAME)                                 # and used again
    assert type(restored.spec.model).__name__ == "_Deferred"
    assert restored.parameters["slope"] == walker.parameters["slope"]


def test_a_snapshot_of_another_form_is_ignored(cold):
    """A document that is intact but not what this version writes (an unknown record class)
    is not used: the walker is loaded in full."""
    from porthamiltonian.compiler import recall, remember

    source, text = _file_text(NAME)
    key = warm._key(source, text, None)
    data = recall(key, warm.KIND)
    assert data is not None
    data["plan"]["section"]["@"] = "Popen"
    remember(key, warm.KIND, data)
    assert warm.restore(source, text, None) is None
    assert type(load_walker(NAME).spec.model).__name__ != "_Deferred"
    assert warm.restore(source, text, None) is not None          # a new snapshot was stored

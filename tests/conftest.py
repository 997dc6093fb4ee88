"""Shared fixtures of the porthamiltonian test suite.

* Every test runs with ``PORTHAMILTONIAN_CACHE`` pointing at a session-scoped temporary folder,
  set before anything is compiled, so the suite never reads or writes ``~/.cache`` (subprocesses
  started by the tests inherit it), and with ``PORTHAMILTONIAN_QUIET`` set: no build lines on
  stderr, whose appearance would depend on the order of the tests (tests of the lines unset it),
  and with ``PORTHAMILTONIAN_CC_JOBS=1``: a build runs one C compiler (the workers keep the cores
  busy, where a second compiler for a long body only costs CPU; tests/unit/test_model_units.py
  sets 2 to check the two-unit build).
* ``PORTHAMILTONIAN_BACKEND`` (``c``, ``numba``, ``python``), when set by the caller, is what
  back end ``"auto"`` means (porthamiltonian.backends): ``.ci/run`` runs the walker tests once
  more with ``PORTHAMILTONIAN_BACKEND=numba`` so that the numba fallback stays tested.
* ``--numba-pass`` (that run of ``.ci/run``) selects the walker tests and the tests marked
  ``numba_loop``: the checks of the numba back end's own compiled loops (each costs a JIT of a
  model's loops, ~15 s of CPU). Without it, those are deselected: the README's test command
  checks the same loops as Python source and as C, and ``.ci/run`` checks them on numba.
  Likewise the walker tests marked ``study`` (a reproduction study's pinned numbers, e.g.
  ``walker reproduce compliance_3d --quick``, ~10 s of CPU): run by that pass only (on numba;
  the studies' code paths are checked piecewise in the README's command). And the walker tests
  marked ``breadth``: the same check repeated on a variant whose code path the README's command
  already checks on a sibling (a parameter or mass variant's Floquet multipliers, the next flip
  of a cascade): run by that pass only.
* Under pytest-xdist (the README's ``-n auto``) each test file stays on one worker (the files
  sharing a costly session fixture on the same one) and the workers share one compiled-model
  cache (see the hooks below).
* ``compile_named(name)`` compiles a model of ``models/`` with the fast-to-build ``python`` back
  end (memoized for the session), for tests where the back end does not matter.
* The garbage collector: the objects alive after collection are frozen (never scanned again)
  and the young generation is collected every 10000 allocations instead of 700 (sympy and the
  compiled models make many objects): 5-13 % less CPU on the sympy- and walker-heavy files
  (A/B, interleaved, load 1-2), no check changed.
* Python bytecode: the session writes it beside the sources (``__pycache__``, ignored by git),
  as an installed package has it, even when ``PYTHONDONTWRITEBYTECODE`` is set (it is unset
  for the session and the processes it starts): the workers and the hundred or so interpreters
  the tests start would otherwise each compile the package's sources anew (the README's command
  with it set: 13 s more CPU, two interleaved pairs of the whole suite).
* ``energy_check`` is the session's one ``porthamiltonian --backend c check-energy`` over every
  shipped model (a fresh interpreter): the command-line test and the per-model energy tests read
  its report instead of simulating every model again, and the tests comparing every model's
  python and C functions wait for it and read the compiled models from the shared cache. (On the
  C back end: the same generated program as the python back end's, which test_backends checks
  function by function; the simulations cost a third of the python back end's CPU.)
"""
from __future__ import annotations

import gc
import os
import re
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field

import pytest


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--numba-pass", action="store_true",
                     help="run the walker tests and the numba_loop tests only (.ci/run, with "
                          "PORTHAMILTONIAN_BACKEND=numba)")


def pytest_configure(config: pytest.Config) -> None:
    # bytecode for the package (module docstring): before pytest-xdist starts the workers, which
    # inherit this environment, as do the interpreters the tests start
    if os.environ.pop("PYTHONDONTWRITEBYTECODE", None) is not None:
        sys.dont_write_bytecode = False
    config.addinivalue_line("markers", "numba_loop: checks numba's compiled loops (run by "
                                       "--numba-pass, deselected otherwise)")
    config.addinivalue_line("markers", "study: a walker reproduction study with pinned numbers "
                                       "(run by --numba-pass, deselected otherwise)")
    config.addinivalue_line("markers", "breadth: a walker check repeated on a variant whose code "
                                       "path a sibling test checks (run by --numba-pass, "
                                       "deselected otherwise)")


def pytest_collection_finish(session: pytest.Session) -> None:
    """Freeze what collection left alive and collect the young generation less often (module
    docstring)."""
    gc.collect()
    gc.freeze()
    gc.set_threshold(10000, 20, 20)


@pytest.hookimpl(tryfirst=True)     # before pytest-xdist's, which reads the groups
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """``--numba-pass`` or not (module docstring); under pytest-xdist (``-n auto --dist
    loadgroup``, the README's command), keep each test file on one worker (its module fixtures
    run once), every test that reads the session's ``check-energy`` run on the same worker
    (that run is made once), and the files that use the sweeps' ``gait_reference`` (the
    serial walker sweep, ~5 s of CPU for its chaotic slope) together on one worker."""
    numba_pass = config.getoption("--numba-pass")
    keep, drop = [], []
    for item in items:
        walker = item.nodeid.startswith("tests/walkers/")
        marked = item.get_closest_marker("numba_loop") is not None
        study = walker and any(item.get_closest_marker(m) is not None
                               for m in ("study", "breadth"))
        selected = (walker or marked) if numba_pass else not (marked or study)
        (keep if selected else drop).append(item)
    if drop:
        config.hook.pytest_deselected(items=drop)
        items[:] = keep
    if not config.pluginmanager.hasplugin("xdist"):
        return
    shared = {item.nodeid.split("::", 1)[0] for item in items
              if "gait_reference" in getattr(item, "fixturenames", ())}
    for item in items:
        path = item.nodeid.split("::", 1)[0]
        group = ("energy_check" if "energy_check" in getattr(item, "fixturenames", ())
                 else "gait_reference" if path in shared else path)
        item.add_marker(pytest.mark.xdist_group(group))


@pytest.fixture(scope="session", autouse=True)
def isolated_cache(tmp_path_factory: pytest.TempPathFactory):
    """Point the compiled-model cache at a fresh session folder (never ~/.cache); under
    pytest-xdist the workers share one folder (the cache is safe for concurrent writers), so a
    model compiled by one worker is read by the other."""
    if os.environ.get("PYTEST_XDIST_WORKER"):
        path = tmp_path_factory.getbasetemp().parent / "porthamiltonian_cache"
        path.mkdir(mode=0o700, exist_ok=True)
    else:
        path = tmp_path_factory.mktemp("porthamiltonian_cache")
    mp = pytest.MonkeyPatch()
    mp.setenv("PORTHAMILTONIAN_CACHE", str(path))
    mp.setenv("PORTHAMILTONIAN_QUIET", "1")
    # one C compiler per build: the workers keep the cores busy (a second one only costs CPU)
    mp.setenv("PORTHAMILTONIAN_CC_JOBS", "1")
    yield path
    mp.undo()


@pytest.fixture(scope="session")
def seed_loops(isolated_cache) -> Callable[[], None]:
    """``seed_loops()`` stores the C back end's integration loops' object in the cache folder
    that ``PORTHAMILTONIAN_CACHE`` names now (a test's fresh folder), for a test that needs an
    empty cache for the model entries it examines but not for the loops (one object for every
    model, compiled once per compiler: otherwise every fresh folder compiles it again, ~0.6 s
    of CPU). The object is the session cache's (compiled there once, for the session's
    compiler), read through the cache's verified path (its sha256 against the session entry's
    manifest) and stored with its hash in the fresh folder's entry (``cache.store``), as a
    build would have stored it. A test that sets another compiler (``CC``) still compiles its
    own: the object's key holds the compiler's identity. Not for the tests of the loops' object
    itself, of compiler identities and flags, or of ``use_cache=False``."""
    from pathlib import Path

    from porthamiltonian import compiler
    from porthamiltonian.backends import native
    from porthamiltonian.compiler import cache

    key, name = native.object_key(native.loop_source()), compiler._loop_name()
    with pytest.MonkeyPatch.context() as mp:        # (first asked for when a test's is set)
        mp.setenv("PORTHAMILTONIAN_CACHE", str(isolated_cache))
        compiler._loop_object(True, {}, None, Path("loops.c"))
        data = cache.load_verified(key, name)
    assert data is not None, f"the session cache lost the loops' object {key}/{name}"

    def seed() -> None:
        cache.store(key, name, data)

    return seed


@pytest.fixture(scope="session")
def compile_named(isolated_cache) -> Callable:
    """``compile_named(name)`` -> CompiledModel of ``models/<name>.toml`` (python back end)."""
    from porthamiltonian import compile_model, io

    compiled: dict[str, object] = {}

    def _compile(name: str):
        if name not in compiled:
            compiled[name] = compile_model(io.load(name), backend="python")
        return compiled[name]

    return _compile


@pytest.fixture
def without_views(monkeypatch) -> None:
    """No notebook view of the walker results registered (walker_library.analyses.results), as
    in a fresh ``walker`` process, which never imports walker_library.report.display: a command
    that draws through a view (``ContinuationResult.figure``) fails here as it does there."""
    from walker_library.analyses import results
    monkeypatch.setattr(results, "_VIEWS", {})


@pytest.fixture(scope="session")
def model_settings() -> Callable:
    """``model_settings(name)`` -> the model file's [simulation] table with the CLI defaults."""
    from porthamiltonian import io

    def _settings(name: str) -> dict:
        sim = {"method": "Radau", "rtol": 1e-9, "atol": 1e-12, "energy_tolerance": 1e-6}
        sim.update(io.read(name).simulation)
        return sim

    return _settings



@pytest.fixture(scope="session")
def model_run(compile_named, model_settings) -> Callable:
    """``model_run(name)`` -> (CompiledModel, Trajectory) simulated with the model file's own
    [simulation] settings (t_end, method, rtol, atol, max_step, inputs), memoized for the
    session; with dense output unless the method is a compiled loop (Rodas5P, Rodas4, QBDF)."""
    from porthamiltonian.integrators import COMPILED_METHODS

    runs: dict[str, tuple] = {}

    def _run(name: str):
        if name not in runs:
            sim = model_settings(name)
            model = compile_named(name)
            options = {k: sim[k] for k in ("method", "rtol", "atol", "max_step") if k in sim}
            if model.input_names:
                options["inputs"] = sim.get("inputs")
            dense = sim.get("method") not in COMPILED_METHODS     # a compiled loop keeps none
            runs[name] = (model, model.simulate(float(sim["t_end"]), dense_output=dense,
                                                **options))
        return runs[name]

    return _run


#: a line of ``check-energy``'s report (porthamiltonian.interfaces.cli.cmd_check_energy)
_CHECK_LINE = re.compile(r"(?P<ok>ok  |FAIL) (?P<name>[\w.-]+): status (?P<status>\w+), max "
                         r"\|residual\| / energy scale = (?P<rel>\S+) \(tolerance (?P<tol>\S+)\)")


@dataclass
class EnergyCheck:
    """The session's ``check-energy`` run, started at once and collected on first use."""

    proc: subprocess.Popen
    _done: subprocess.CompletedProcess | None = field(default=None, init=False)

    @property
    def run(self) -> subprocess.CompletedProcess:
        """The finished run (stdout, stderr, returncode)."""
        if self._done is None:
            out, err = self.proc.communicate(timeout=900)
            self._done = subprocess.CompletedProcess(self.proc.args, self.proc.returncode, out,
                                                     err)
        return self._done

    def line(self, name: str) -> dict:
        """Model ``name``'s report: ok (bool), status, rel (the residual over the energy scale,
        as printed: 3 digits) and tol (its energy_tolerance); AssertionError when absent."""
        for match in _CHECK_LINE.finditer(self.run.stdout):
            if match["name"] == name:
                return {"ok": match["ok"] == "ok  ", "status": match["status"],
                        "rel": float(match["rel"]), "tol": float(match["tol"]),
                        "text": match.group(0)}
        raise AssertionError(f"check-energy printed no line for {name}:\n{self.run.stdout}"
                             f"{self.run.stderr}")


@pytest.fixture(scope="session")
def energy_check(isolated_cache) -> EnergyCheck:
    """``porthamiltonian --backend c check-energy`` over every shipped model, in a fresh
    interpreter (the session's cache), each with its file's [simulation] settings."""
    started = EnergyCheck(subprocess.Popen(
        [sys.executable, "-m", "porthamiltonian", "--backend", "c", "check-energy"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True))
    yield started
    if started.proc.poll() is None:
        started.proc.kill()
        started.proc.communicate()

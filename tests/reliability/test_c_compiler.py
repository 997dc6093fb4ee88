"""The C back end when its compiler fails or is missing, and its library in the cache (issue 11;
porthamiltonian/backends/native.py, porthamiltonian/compiler/__init__.py).

* a failing compiler (``CC=false``, a ``CC`` that does not exist): with ``backend="c"`` a
  CompilerError showing the command and the path of a file holding the compiler's output;
  under ``"auto"`` one BackendWarning (one line) and the next back end;
* no compiler at all: a CompilerError saying what to install;
* a cached library needs no compiler, is verified by its sha256 before it is loaded (a damaged
  one is never loaded: it is rebuilt), and ``use_cache=False`` writes nothing to the cache;
* the build line: one line on stderr per build, none when everything is cached;
* the integration loops' object: one for every model (their sizes read at run time), compiled
  once per compiler, in the background from ``compiler.prepare`` on; a compile started for
  another compiler is never used.
"""
from __future__ import annotations

import importlib.util
import json
import os
import re
import time
import warnings

import numpy as np
import pytest
from bounds import copy_entry

import porthamiltonian as ph
from porthamiltonian import compile_model, compiler, io
from porthamiltonian.backends import BackendWarning, native
from porthamiltonian.compiler import cache
from porthamiltonian.compiler.cache import CacheWarning
from porthamiltonian.errors import CompilerError


def _model(k: float = 4.0) -> ph.Model:
    """A small model; ``k`` changes its cache key (a model no other test has built)."""
    m = ph.Model("osc")
    m.parameter("k", k, "N/m")
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0, p0=0.5))
    m.add("spring", ph.C(stiffness="k"))
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    return m


@pytest.fixture
def fresh(tmp_path, monkeypatch):
    """A fresh cache folder, and a process that has not seen the C back end fail."""
    folder = tmp_path / "cache"
    monkeypatch.setenv("PORTHAMILTONIAN_CACHE", str(folder))
    monkeypatch.setattr(cache, "_refused", set())
    monkeypatch.setattr(compiler, "_C_FAILED", [])
    monkeypatch.setattr(compiler, "_LOOPS", {})
    return folder


def test_failing_compiler_shows_the_command_and_its_output_file(fresh, monkeypatch):
    monkeypatch.setenv("CC", "false")
    with pytest.raises(CompilerError) as info:
        compile_model(_model(4.1), backend="c")
    message = str(info.value)
    match = re.search(r"its output is in (\S+)\.", message)
    assert match and "false -O1" in message and "exit status 1" in message, message
    log = match.group(1)
    assert log.startswith(str(fresh)) and log.endswith("_c.log")
    with open(log) as fh:
        text = fh.read()
    assert text.startswith("command: false -O1") and "exit status 1" in text


def test_failing_compiler_without_the_cache_keeps_its_log_elsewhere(fresh, monkeypatch, tmp_path):
    """use_cache=False writes nothing to the cache, not even the log (a kept temporary file)."""
    monkeypatch.setenv("CC", "false")
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    monkeypatch.setattr("tempfile.tempdir", None)
    with pytest.raises(CompilerError, match=r"its output is in .*porthamiltonian-m.*\.log") as info:
        compile_model(_model(4.2), backend="c", use_cache=False)
    assert not fresh.exists() or not any(fresh.iterdir())
    log = re.search(r"its output is in (\S+)\.", str(info.value)).group(1)
    with open(log) as fh:
        assert log.startswith(str(tmp_path)) and fh.read().startswith("command: false")


def test_compiler_that_cannot_start(fresh, monkeypatch):
    monkeypatch.setenv("CC", "/nonexistent/cc --flag")
    with pytest.raises(CompilerError, match=r"could not be started.*/nonexistent/cc --flag -O1"):
        compile_model(_model(4.3), backend="c")


def test_auto_falls_back_with_one_warning(fresh, monkeypatch):
    """Under "auto" a failing compiler costs one one-line warning per process, naming the log,
    and the next back end is used; the C back end is not tried again in this process."""
    monkeypatch.setenv("CC", "false")
    monkeypatch.delenv("PORTHAMILTONIAN_BACKEND", raising=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        first = compile_model(_model(4.4), backend="auto")
        second = compile_model(_model(4.5), backend="auto")
    backend_warnings = [str(w.message) for w in caught if issubclass(w.category, BackendWarning)]
    assert len(backend_warnings) == 1, backend_warnings
    message = backend_warnings[0]
    assert "\n" not in message and "false -O1" in message and "_c.log" in message
    expected = "numba" if importlib.util.find_spec("numba") else "python"
    assert message.endswith(f"using the {expected} back end instead")
    assert first.backend == second.backend == expected
    x = first.augment(first.initial_state())
    assert first.functions.rhs(0.0, x, first.native_params(first.param_defaults))[1] == 0.5


def test_cli_prints_the_fallback_as_one_warning_line(fresh, monkeypatch, capsys):
    from porthamiltonian.interfaces import cli

    monkeypatch.setenv("CC", "false")
    assert cli.main(["show", "mass_spring_damper", "--code"]) == 0
    out, err = capsys.readouterr()
    err = err.splitlines()
    assert len(err) == 1, err
    assert err[0].startswith("warning: C back end not used: the C compiler failed"), err
    assert "def integrate_rodas5p(" in out


def test_no_compiler_at_all(fresh, monkeypatch, tmp_path):
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))          # no cc, gcc, clang
    find_spec = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "ziglang" else find_spec(name, *a))
    assert native.compiler() is None
    with pytest.raises(CompilerError, match=r"no C compiler found.*porthamiltonian\[c\]"):
        compile_model(_model(4.6), backend="c")


def test_zig_is_the_last_resort(monkeypatch, tmp_path):
    """With no $CC and no cc/gcc/clang on PATH, the ziglang package's compiler is used when
    installed (pip install 'porthamiltonian[c]')."""
    import sys

    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))
    find_spec = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: object() if name == "ziglang" else find_spec(name, *a))
    assert native.compiler() == [sys.executable, "-m", "ziglang", "cc"]


@pytest.mark.usefixtures("fresh_with_loops")
def test_cached_library_needs_no_compiler(fresh, monkeypatch):
    """A model built earlier runs from its cached library when the C compiler named now fails:
    the build of what that compiler would need is tried, fails, and one BackendWarning says the
    earlier library (self-checked) is used."""
    model = _model(4.7)
    first = compile_model(model, backend="c")
    monkeypatch.setenv("CC", "false")
    with pytest.warns(BackendWarning, match="built earlier by another compiler") as caught:
        again = compile_model(model, backend="c")
    assert len([w for w in caught if issubclass(w.category, BackendWarning)]) == 1
    assert again.backend == "c"
    np.testing.assert_array_equal(first.simulate(1.0).y, again.simulate(1.0).y)


@pytest.mark.usefixtures("fresh_with_loops")
@pytest.mark.parametrize("damage", ["garbage", "truncated"])
def test_damaged_library_is_never_loaded_and_is_rebuilt(fresh, built_elsewhere, damage,
                                                        recwarn):
    """A library whose bytes differ from the manifest's sha256 is reported (one CacheWarning
    naming it), removed and rebuilt before anything is loaded: damaged bytes that were loaded
    would fail (garbage is no shared library). The library is built by another process, so
    that this one has never mapped it (its entry, manifest and all, copied into this test's
    cache)."""
    key, built = built_elsewhere("mass_spring_damper", "c")
    lib = copy_entry(built, fresh) / native.library_name(key)
    data = lib.read_bytes()
    lib.write_bytes(b"not a shared library" if damage == "garbage" else data[: len(data) // 2])
    compiled = compile_model(io.load("mass_spring_damper"), backend="c")
    assert compiled.key == key and compiled.simulate(1.0).status == "finished"
    warned = [str(w.message) for w in recwarn if issubclass(w.category, CacheWarning)]
    assert len(warned) == 1 and str(lib) in warned[0], warned
    files = json.loads((lib.parent / "manifest.json").read_text())["files"]
    assert cache._sha256(lib.read_bytes()) == files[lib.name]


def test_the_build_line_counts_the_symbolic_work_of_an_earlier_layout(fresh, monkeypatch, capfd):
    """A walker asks for its model's layout (the symbolic stage), then compiles the model with
    its outputs, reusing that stage: the build line's symbolic time counts the layout's part
    (here a solve made to last 0.3 s), once: a second build of the model (another output, a
    build of its own) reuses the solve again and does not count it twice."""
    from porthamiltonian.compiler import structure

    monkeypatch.delenv("PORTHAMILTONIAN_QUIET", raising=False)
    solve = structure.solve

    def slow(system):
        time.sleep(0.3)
        return solve(system)
    monkeypatch.setattr(structure, "solve", slow)
    model = _model(5.3)
    compiler.layout(model, use_cache=False)
    model.output("x2", "2 * spring.q")
    compile_model(model, backend="python")
    model.output("x3", "3 * spring.q")
    compile_model(model, backend="python")
    lines = capfd.readouterr().err.splitlines()
    seconds = [float(re.match(r"building osc: symbolic (\d+\.\d) s", line).group(1))
               for line in lines]
    assert len(seconds) == 2 and seconds[0] >= 0.3 and seconds[1] < 0.3, lines


def test_use_cache_false_writes_nothing(fresh):
    compiled = compile_model(_model(5.0), backend="c", use_cache=False)
    assert compiled.backend == "c" and compiled.simulate(1.0).status == "finished"
    assert not fresh.exists() or not any(fresh.iterdir())


@pytest.mark.usefixtures("fresh_with_loops")
def test_one_build_line_then_silence(fresh, monkeypatch, capfd):
    """``building NAME: symbolic .. s, code .. s, C .. s, N kB`` once; nothing when cached (the
    python back end after the C one: the Python body printed, ``code .. s``); the model's name
    as printable text; nothing at all with $PORTHAMILTONIAN_QUIET."""
    monkeypatch.delenv("PORTHAMILTONIAN_QUIET", raising=False)
    model = _model(5.1)
    model.name = "osc\x1b[2J"
    compile_model(model, backend="c")
    err = capfd.readouterr().err.splitlines()
    assert len(err) == 1, err
    assert re.fullmatch(r"building osc\\x1b\[2J: symbolic \d+\.\d s, code \d+\.\d s, C \d+\.\d s, "
                        r"\d+ kB", err[0]), err
    compile_model(model, backend="c")
    assert capfd.readouterr().err == ""
    # a C build prints no Python body: the python back end's first build prints it (one line)
    compile_model(model, backend="python")
    err = capfd.readouterr().err.splitlines()
    assert len(err) == 1, err
    assert re.fullmatch(r"building osc\\x1b\[2J: code \d+\.\d s, \d+ kB", err[0]), err
    compile_model(model, backend="python")   # the code is cached: nothing to do
    assert capfd.readouterr().err == ""
    monkeypatch.setenv("PORTHAMILTONIAN_QUIET", "1")
    compile_model(_model(5.2), backend="c")
    assert capfd.readouterr().err == ""


def test_backend_variable_chooses_what_auto_means(fresh, monkeypatch):
    monkeypatch.setenv("PORTHAMILTONIAN_BACKEND", "python")
    assert compile_model(_model(5.3)).backend == "python"
    monkeypatch.setenv("PORTHAMILTONIAN_BACKEND", "fortran")
    with pytest.raises(ph.errors.ModelError, match=r"PORTHAMILTONIAN_BACKEND.*'fortran'"):
        compile_model(_model(5.3))


def _chain(n: int) -> ph.Model:
    """``n`` masses on springs in a row: a model of 2 n states (a size other than osc's)."""
    m = ph.Model(f"chain{n}")
    for i in range(n):
        m.add(f"j{i}", ph.OneJunction())
        m.add(f"mass{i}", ph.I(inertance=1.0 + i, p0=0.1 * (i + 1)))
        m.add(f"spring{i}", ph.C(stiffness=2.0 + i))
        m.connect(f"j{i}", f"mass{i}.p")
        m.connect(f"j{i}", f"spring{i}.p")
    return m


def _loop_objects(folder) -> list:
    return sorted(folder.glob("*/loops_*.o"))


def test_one_loops_object_serves_models_of_every_size(fresh, capfd):
    """prepare() starts the loops' object compiling; the first build on C waits for it and
    caches it; a model of another size links the same object (no compile of its own), and its
    functions are right (the loops read the model's sizes at run time)."""
    compiler.prepare("c")
    assert list(compiler._LOOPS) == [os.getpid()]
    small = compile_model(_model(6.1), backend="c")
    assert compiler._LOOPS == {} and len(_loop_objects(fresh)) == 1
    big = compile_model(_chain(3), backend="c")
    assert len(_loop_objects(fresh)) == 1
    compiler.prepare("c")                       # cached: nothing started
    assert compiler._LOOPS == {}
    for model, n in ((small, 2), (big, 6)):
        assert model.n_states == n
        traj = model.simulate(2.0, method="Rodas5P", rtol=1e-10, atol=1e-12)
        reference = model.simulate(2.0, method="Radau", rtol=1e-10, atol=1e-12)
        assert traj.status == "finished" and traj.y.shape[0] == n + 2      # (the ledger)
        assert traj.y[:, -1] == pytest.approx(reference.y[:, -1], rel=1e-6, abs=1e-8)
    capfd.readouterr()


def test_loops_started_for_another_compiler_are_not_used(fresh, monkeypatch):
    """A loops' compile that prepare() started before CC changed is stopped, not linked: the
    object is built by the compiler of the build (here one that fails)."""
    compiler.prepare("c")
    assert compiler._LOOPS
    monkeypatch.setenv("CC", "false")
    with pytest.raises(CompilerError, match="false -O1"):
        compile_model(_model(6.2), backend="c")
    assert compiler._LOOPS == {} and _loop_objects(fresh) == []

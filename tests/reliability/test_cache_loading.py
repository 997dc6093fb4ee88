"""Everything the compiled-model cache loads is verified, from folders only the user can write,
and a C library is that of this compiler and this model (issue 21; porthamiltonian/compiler/
cache.py, compiler/numba_cache.py, backends/native.py).

Before: a damaged numba cache file (``__pycache__/*.nbi``) failed every later run with an
UnpicklingError reported as a bug (the manifest's hashes did not cover what numba loads); the
rule that nothing is loaded from a folder others can write held for the cache root only (a
planted module in a world-writable entry, its manifest rewritten to match, was run); the C
library's cache name ignored the compiler, so a garbage library from a broken ``CC`` was cached
and broke later runs until removed by hand, and a ``-ffast-math`` library was reused after ``CC``
changed.

Each case damages or plants something, compiles again (the generated modules dropped from
``sys.modules``) and checks the warning, that nothing planted ran, and the numbers.
"""
from __future__ import annotations

import builtins
import json
import os
import pickle
import stat
import subprocess
import sys
import time
import warnings

import numpy as np
import pytest
from bounds import copy_entry, forget_generated

import porthamiltonian as ph
from porthamiltonian import compile_model, compiler, io
from porthamiltonian.backends import BackendWarning, native
from porthamiltonian.compiler import cache
from porthamiltonian.compiler.cache import CacheWarning
from porthamiltonian.errors import CompilerError

MODEL = "mass_spring_damper"


# ``fresh``: tests/reliability/conftest.py


def _compile(backend: str, model=None):
    forget_generated()
    return compile_model(model or io.load(MODEL), backend=backend)


def _warned(record, category=CacheWarning) -> list[str]:
    return [str(w.message) for w in record if issubclass(w.category, category)]


def _manifest(entry) -> dict:
    return json.loads((entry / "manifest.json").read_text())["files"]


class _Opens:
    """A pickle that opens (creates) a file when it is unpickled: a planted payload."""

    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        return builtins.open, (self.path, "w")


def _rhs(compiled) -> np.ndarray:
    x = compiled.augment(compiled.initial_state())
    return compiled.functions.rhs(0.0, x, compiled.native_params(compiled.param_defaults))


# --- numba's files ----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def numba_built(tmp_path_factory):
    """(entry, rhs at the initial state) after numba compiled and cached rhs, in a cache folder
    of the module's own, once: every file numba wrote is recorded in the manifest, and intact."""
    folder = tmp_path_factory.mktemp("numba_built") / "cache"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("PORTHAMILTONIAN_CACHE", str(folder))
        compiled = _compile("numba")
        expected = _rhs(compiled)
    forget_generated()
    entry = folder / compiled.key
    files = _manifest(entry)
    cached = sorted(p.name for p in (entry / "__pycache__").iterdir())
    assert any(n.endswith(".nbi") for n in cached) and any(n.endswith(".nbc") for n in cached)
    for name in cached:                       # every file numba wrote is recorded, and intact
        data = (entry / "__pycache__" / name).read_bytes()
        assert files[f"__pycache__/{name}"] == cache._sha256(data), name
    return entry, expected


@pytest.fixture
def numba_entry(fresh, numba_built):
    """(entry, rhs at the initial state): :func:`numba_built`'s entry copied (its numba files,
    their time stamps and the manifest with it) into this test's fresh cache, for the test to
    damage."""
    built, expected = numba_built
    return copy_entry(built, fresh), expected


@pytest.mark.parametrize("damage", ["garbage", "truncated", "empty"])
def test_a_damaged_numba_index_is_rebuilt_not_unpickled(numba_entry, damage, recwarn):
    entry, expected = numba_entry
    index = next((entry / "__pycache__").glob("*.rhs-*.nbi"))
    data = index.read_bytes()
    index.write_bytes({"garbage": b"not a pickle", "truncated": data[: len(data) // 2],
                       "empty": b""}[damage])
    np.testing.assert_array_equal(_rhs(_compile("numba")), expected)
    warned = _warned(recwarn)
    assert len(warned) == 1 and str(index) in warned[0] and "does not match" in warned[0]
    assert _manifest(entry)[f"__pycache__/{index.name}"] == cache._sha256(index.read_bytes())


@pytest.mark.parametrize("planted", ["index", "data"])
def test_a_planted_numba_pickle_is_never_unpickled(numba_entry, planted, tmp_path, recwarn):
    """A pickle that would create a file, as a cache file numba would read: an unrecorded index
    beside the others, or the data file of rhs (its record then no longer matches)."""
    entry, expected = numba_entry
    marker = tmp_path / "PWNED"
    payload = pickle.dumps(_Opens(marker))
    if planted == "index":
        target = entry / "__pycache__" / "planted-1.py311.nbi"
        import numba

        target.write_bytes(pickle.dumps(numba.__version__) + payload)
    else:
        target = next((entry / "__pycache__").glob("*.rhs-*.1.nbc"))
        target.write_bytes(payload)
    np.testing.assert_array_equal(_rhs(_compile("numba")), expected)
    assert not marker.exists()
    warned = _warned(recwarn)
    assert len(warned) == 1 and str(target) in warned[0], warned


def test_a_pycache_others_can_write_is_removed(numba_entry, recwarn):
    entry, expected = numba_entry
    os.chmod(entry / "__pycache__", 0o777)
    np.testing.assert_array_equal(_rhs(_compile("numba")), expected)
    warned = _warned(recwarn)
    assert len(warned) == 1 and "__pycache__: it is writable by other users" in warned[0]
    assert stat.S_IMODE(os.stat(entry / "__pycache__").st_mode) & 0o022 == 0


# --- the entry's folder ---------------------------------------------------------------------------------
@pytest.mark.parametrize("mode", [0o777, 0o775, 0o757])
def test_an_entry_others_can_write_is_never_loaded(fresh, mode, tmp_path, recwarn):
    """A planted module whose manifest was rewritten to match (what someone who can write the
    entry can do): the entry's permissions refuse it, the module never runs."""
    compiled = _compile("python")
    expected = _rhs(compiled)
    entry = fresh / compiled.key
    marker = tmp_path / "PWNED"
    module = entry / f"m{compiled.key}_python.py"
    evil = f"open({str(marker)!r}, 'w').close()\n" + module.read_text()
    module.write_text(evil)
    files = _manifest(entry)
    files[module.name] = cache._sha256(evil.encode())
    (entry / "manifest.json").write_text(json.dumps({"key": compiled.key, "files": files}))
    os.chmod(entry, mode)
    np.testing.assert_array_equal(_rhs(_compile("python")), expected)
    assert not marker.exists()
    warned = _warned(recwarn)
    assert len(warned) == 1 and str(entry) in warned[0] and "writable by other users" in warned[0]
    assert stat.S_IMODE(os.stat(entry).st_mode) == 0o700     # rebuilt, private


def test_no_bytecode_is_written_or_read_for_generated_modules(fresh):
    compiled = _compile("python")
    assert not (fresh / compiled.key / "__pycache__").exists()


# --- the C compiler ------------------------------------------------------------------------------------
def _script(tmp_path, name: str, body: str) -> str:
    """A fake compiler: a shell script that handles ``-o FILE`` with ``body`` ($out)."""
    path = tmp_path / name
    path.write_text("#!/bin/sh\nout=\nwhile [ $# -gt 0 ]; do if [ \"$1\" = -o ]; then shift; "
                    f"out=$1; fi; shift; done\n{body}\n")
    path.chmod(0o755)
    return str(path)


def _model(k: float) -> ph.Model:
    m = ph.Model("osc")
    m.parameter("k", k, "N/m")
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0, p0=0.5))
    m.add("spring", ph.C(stiffness="k"))
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    return m


def _libraries(entry) -> list[str]:
    return sorted(n for n in os.listdir(entry) if n.endswith((".so", ".dll")))


def test_a_new_compiler_or_new_flags_build_their_own_library(fresh, monkeypatch):
    cc = native.compiler()
    first = compile_model(_model(6.1), backend="c")
    entry = fresh / first.key
    assert len(_libraries(entry)) == 1
    monkeypatch.setenv("CC", " ".join([*cc, "-DPH_OTHER_FLAGS=1"]))
    again = compile_model(_model(6.1), backend="c")
    assert len(_libraries(entry)) == 2                       # its own, beside the first
    np.testing.assert_array_equal(first.simulate(1.0).y, again.simulate(1.0).y)
    assert native.library_name(first.key) in _libraries(entry)


@pytest.mark.parametrize("flags", ["-ffast-math", "-ffinite-math-only",
                                   "-fassociative-math -fno-signed-zeros -fno-trapping-math"])
def test_a_library_that_breaks_ieee_arithmetic_is_refused(fresh, monkeypatch, flags):
    """-ffast-math and friends: the self-check fails, nothing is cached, and the process keeps
    its subnormal numbers (loading a -ffast-math library turns them off: restored)."""
    monkeypatch.setenv("CC", " ".join([*native.compiler(), flags]))
    with pytest.raises(CompilerError) as info:
        compile_model(_model(6.2), backend="c")
    message = str(info.value)
    assert "fails its self-check" in message and "break IEEE arithmetic" in message, message
    assert sys.float_info.min / 2 > 0.0
    key = cache.model_key(_model(6.2))
    assert _libraries(fresh / key) == []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fallback = compile_model(_model(6.2), backend="auto")
    assert fallback.backend in ("numba", "python")
    assert any("break IEEE arithmetic" in m for m in _warned(caught, BackendWarning))


@pytest.mark.usefixtures("fresh_with_loops")
@pytest.mark.parametrize("body, words", [
    ('echo garbage > "$out"', "not a loadable shared library"),
    ('cp /bin/sh "$out"', "not a loadable shared library"),
    (': > "$out"', "not a loadable shared library"),
])
def test_a_broken_compiler_leaves_nothing_to_remove_by_hand(fresh, monkeypatch, tmp_path, body,
                                                            words):
    monkeypatch.setenv("CC", _script(tmp_path, "cc.sh", body))
    with pytest.raises(CompilerError) as info:
        compile_model(_model(6.3), backend="c")
    assert words in str(info.value) and "Set CC to a working C compiler" in str(info.value)
    key = cache.model_key(_model(6.3))
    assert _libraries(fresh / key) == []
    monkeypatch.delenv("CC")
    monkeypatch.setattr(compiler, "_C_FAILED", [])
    assert compile_model(_model(6.3), backend="c").simulate(1.0).success   # no hand work


_OSC = ("import warnings, porthamiltonian as ph\n"
        "warnings.simplefilter('always')\n"
        "m = ph.Model('osc'); m.parameter('k', {k}, 'N/m'); m.add('j', ph.OneJunction())\n"
        "m.add('mass', ph.I(inertance=1.0, p0=0.5)); m.add('spring', ph.C(stiffness='k'))\n"
        "m.connect('j', 'mass.p'); m.connect('j', 'spring.p')\n"
        "print(ph.compile_model(m, backend='c').simulate(1.0).x_final.tolist())\n")


@pytest.mark.usefixtures("fresh_with_loops")
def test_the_library_of_another_model_is_refused_and_rebuilt(fresh):
    """Another model's library in this model's place (its hash recorded, as a mix-up of files
    would have it): its ph_model_key says so; it is removed and this model's is built. In a
    fresh process, which has not loaded either library."""
    import subprocess

    one, two = compile_model(_model(6.4), backend="c"), compile_model(_model(6.5), backend="c")
    theirs = (fresh / two.key / native.library_name(two.key)).read_bytes()
    cache.store(one.key, native.library_name(one.key), theirs)    # recorded: hashes match
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.run([sys.executable, "-c", _OSC.format(k=6.4)], capture_output=True,
                          text=True, env=env, timeout=300, check=True)
    assert "the library is that of another model" in proc.stderr, proc.stderr
    assert json.loads(proc.stdout) == one.simulate(1.0).x_final.tolist()
    mine = (fresh / one.key / native.library_name(one.key)).read_bytes()
    assert mine != theirs and cache._sha256(mine) == _manifest(fresh / one.key)[
        native.library_name(one.key)]


# --- two processes, one build ------------------------------------------------------------------------
#: a second process: it reads the model and its key, says so, then compiles it (python back end)
_SECOND = """
from porthamiltonian import compile_model, io
from porthamiltonian.compiler import cache
model = io.load("mass_spring_damper")
cache.model_key(model)
print("ready", flush=True)
compiled = compile_model(model, backend="python")
print(compiled.key, repr(float(compiled.simulate(1.0)["H"][-1])))
"""


def test_a_second_process_waits_for_the_build_and_reads_the_entry(fresh, monkeypatch):
    """While this process holds the model's build lock (as during its build), another process
    compiling the same model waits for it, then reads the entry this one made: it prints no
    'building' line of its own (without the lock it would miss the cache and build too) and
    gets the same model (key; H after 1 s equal to round-off, 1e-12 relative)."""
    monkeypatch.delenv("PORTHAMILTONIAN_QUIET", raising=False)
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")])}
    model = io.load(MODEL)
    key = cache.model_key(model)
    with cache.building(key):
        second = subprocess.Popen([sys.executable, "-c", _SECOND], env=env,
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        assert second.stdout is not None and second.stdout.readline() == "ready\n"
        time.sleep(0.5)                       # the second process is at its look-up: a miss
        assert not (fresh / key).exists()
        ours = _compile("python", model)
    out, err = second.communicate(timeout=120)
    assert second.returncode == 0, err
    assert "building" not in err, err
    their_key, their_h = out.split()
    assert their_key == ours.key == key
    assert float(their_h) == pytest.approx(float(ours.simulate(1.0)["H"][-1]), rel=1e-12)


#: a second process: compiles the model on C (its loops' object is not in the cache yet)
_SECOND_C = _SECOND.replace('backend="python"', 'backend="c"')


def test_the_loops_object_is_compiled_by_one_process(fresh, monkeypatch):
    """The integration loops' object (one for every model) is stored under its own build lock:
    while this process holds it, another process that compiles a model on C waits at its loops
    and stores nothing (without the lock it would compile and store its own within this wait);
    once this process has stored the object and let go, the other links with it (the file is
    not written again: same inode and time) and simulates as a C model should (H after 1 s as
    this process's python build, 1e-12 relative)."""
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")])}
    key = native.object_key(native.loop_source())
    name = f"loops_{sys.platform}.o"
    with cache.building(key):
        second = subprocess.Popen([sys.executable, "-c", _SECOND_C], env=env,
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        assert second.stdout is not None and second.stdout.readline() == "ready\n"
        time.sleep(3.0)                      # its model built, its loops compiled: it waits
        assert cache.verified_path(key, name) is None
        _compile("c", io.load("pendulum"))   # (another model: its own model lock)
        stored = cache.verified_path(key, name)
        assert stored is not None
        before = stored.stat()
    out, err = second.communicate(timeout=120)
    assert second.returncode == 0, err
    after = stored.stat()
    assert (after.st_ino, after.st_mtime_ns) == (before.st_ino, before.st_mtime_ns)
    their_key, their_h = out.split()
    ours = _compile("python")
    assert their_key == ours.key
    assert float(their_h) == pytest.approx(float(ours.simulate(1.0)["H"][-1]), rel=1e-12)

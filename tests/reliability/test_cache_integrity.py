"""The compiled-model cache is trusted only when intact (issue 10, item 3;
porthamiltonian/compiler/cache.py).

Each case starts from a fresh cache holding an untampered compile of
models/mass_spring_damper.toml (python back end; compiled once for the module, its entry copied
with its manifest into each case's cache), damages or plants something, compiles again (the generated modules dropped from sys.modules, so that they
are imported from disk again) and checks: exactly one CacheWarning naming the damaged file or
the untrusted folder, the entry rebuilt intact (or the folder left alone), no planted code run,
and a simulation bit-identical to the untampered one.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import stat

import numpy as np
import pytest
from bounds import copy_entry, forget_generated

from porthamiltonian import compile_model, io
from porthamiltonian.compiler import cache
from porthamiltonian.compiler.cache import CacheWarning

MODEL = "mass_spring_damper"


@pytest.fixture
def fresh(tmp_path, monkeypatch):
    """A fresh cache folder (tmp/cache) for this test, nothing of it imported yet."""
    folder = tmp_path / "cache"
    monkeypatch.setenv("PORTHAMILTONIAN_CACHE", str(folder))
    monkeypatch.setattr(cache, "_refused", set())
    forget_generated()
    yield folder
    forget_generated()


def _run(compiled):
    traj = compiled.simulate(5.0, params={"c": 0.7}, method="Radau", rtol=1e-8, atol=1e-10)
    return traj.t, traj.y


def _compile():
    forget_generated()
    return compile_model(io.load(MODEL), backend="python")


def _same(a, b) -> None:
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])


def _cache_warnings(record) -> list[str]:
    return [str(w.message) for w in record if issubclass(w.category, CacheWarning)]


def _intact(entry) -> None:
    files = json.loads((entry / "manifest.json").read_text())["files"]
    assert {"meta.json", "body.py"} <= set(files)
    for name, digest in files.items():
        assert cache._sha256((entry / name).read_bytes()) == digest, name


@pytest.fixture(scope="module")
def untampered(tmp_path_factory):
    """(entry folder, simulation, key) of an untampered compile into a fresh cache folder of
    the module's own, once: the entry intact, the folder made private (0700)."""
    folder = tmp_path_factory.mktemp("untampered") / "cache"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("PORTHAMILTONIAN_CACHE", str(folder))
        compiled = _compile()
        simulation = _run(compiled)
    forget_generated()
    entry = folder / compiled.key
    _intact(entry)
    assert stat.S_IMODE(os.stat(folder).st_mode) == 0o700
    return entry, simulation, compiled.key


@pytest.fixture
def reference(fresh, untampered):
    """(entry folder, simulation, key): the untampered entry copied (manifest and all) into
    this test's fresh cache folder (private, as a compile makes it), and its simulation."""
    built, simulation, key = untampered
    return copy_entry(built, fresh), simulation, key


def _truncate(path):
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def _empty(path):
    path.write_bytes(b"")


def _change_coefficient(path):
    text = path.read_text()
    new, n = re.subn(r"\bp\[(\d+)\]", lambda m: f"p[{(int(m.group(1)) + 1) % 5}]", text, count=1)
    assert n == 1
    path.write_text(new)


def _reorder_states(path):
    meta = json.loads(path.read_text())
    meta["state_names"] = meta["state_names"][::-1]
    path.write_text(json.dumps(meta, indent=1))


@pytest.mark.parametrize("damage", [_truncate, _empty, _change_coefficient])
@pytest.mark.parametrize("name", ["body.py", "module"])
def test_damaged_code_is_detected_and_rebuilt(reference, damage, name, recwarn):
    entry, expected, key = reference
    path = entry / ("body.py" if name == "body.py" else f"m{key}_python.py")
    damage(path)
    _same(_run(_compile()), expected)
    warned = _cache_warnings(recwarn)
    assert len(warned) == 1 and str(path) in warned[0], warned
    _intact(entry)


@pytest.mark.parametrize("damage", [_truncate, _empty, _reorder_states])
def test_damaged_layout_is_detected_and_rebuilt(reference, damage, recwarn):
    entry, expected, _ = reference
    damage(entry / "meta.json")
    compiled = _compile()
    _same(_run(compiled), expected)
    assert compiled.state_names == ["mass.p", "spring.q"]
    warned = _cache_warnings(recwarn)
    assert len(warned) == 1 and str(entry / "meta.json") in warned[0], warned
    _intact(entry)


@pytest.mark.parametrize("damage", [_truncate, _empty, os.unlink])
def test_damaged_manifest_is_detected_and_rebuilt(reference, damage, recwarn):
    entry, expected, _ = reference
    damage(entry / "manifest.json")
    _same(_run(_compile()), expected)
    warned = _cache_warnings(recwarn)
    assert len(warned) == 1 and str(entry / "manifest.json") in warned[0], warned
    _intact(entry)


@pytest.mark.usefixtures("fresh_with_loops")
@pytest.mark.parametrize("damage", [None, _change_coefficient, os.unlink, "planted"])
def test_python_body_added_to_a_c_entry_is_verified(reference, damage, recwarn):
    """A C build stores no Python body; the python back end's first build of that entry prints
    it and records it (body.py), after which it is verified like every file: edited or missing,
    one warning and the entry rebuilt; a body.py left in the entry without a record is never
    read (the body is printed again and recorded). The simulation is the same each time."""
    entry, expected, key = reference
    shutil.rmtree(entry)                            # the python back end's entry, made again
    c_build = compile_model(io.load(MODEL), backend="c")
    assert c_build.key == key and not (entry / "body.py").exists()
    assert "body.py" not in json.loads((entry / "manifest.json").read_text())["files"]
    if damage == "planted":
        (entry / "body.py").write_text("raise SystemExit('planted body read')\n")
    _same(_run(_compile()), expected)               # the body printed now, and recorded
    _intact(entry)
    if damage in (None, "planted"):
        assert _cache_warnings(recwarn) == []
        return
    damage(entry / "body.py")
    _same(_run(_compile()), expected)
    warned = _cache_warnings(recwarn)
    assert len(warned) == 1 and str(entry / "body.py") in warned[0], warned
    _intact(entry)


def _plant(entry, key, marker) -> None:
    """A module that would create ``marker`` when imported, as every file of the entry."""
    evil = f"open({str(marker)!r}, 'w').close()\n"
    (entry / f"m{key}_python.py").write_text(evil + (entry / f"m{key}_python.py").read_text())
    (entry / "planted.py").write_text(evil)


def test_planted_file_in_a_world_writable_cache_is_never_read(reference, tmp_path, recwarn):
    entry, expected, key = reference
    marker = tmp_path / "PWNED"
    _plant(entry, key, marker)
    folder = entry.parent
    os.chmod(folder, 0o777)
    before = sorted(p.name for p in folder.iterdir())
    _same(_run(_compile()), expected)
    assert not marker.exists()
    warned = _cache_warnings(recwarn)
    assert len(warned) == 1 and str(folder) in warned[0] and "writable by other users" in warned[0]
    assert "chmod 700" in warned[0]
    assert sorted(p.name for p in folder.iterdir()) == before      # nothing written there either
    _same(_run(_compile()), expected)                               # warned once per process
    assert len(_cache_warnings(recwarn)) == 1


def test_planted_module_in_a_private_cache_is_detected(reference, tmp_path, recwarn):
    entry, expected, key = reference
    marker = tmp_path / "PWNED"
    _plant(entry, key, marker)
    _same(_run(_compile()), expected)
    assert not marker.exists()
    warned = _cache_warnings(recwarn)
    assert len(warned) == 1 and f"m{key}_python.py" in warned[0]


def test_cache_of_another_user_is_refused(reference, monkeypatch, recwarn):
    entry, expected, _ = reference
    owner = os.stat(entry.parent).st_uid
    monkeypatch.setattr(os, "getuid", lambda: owner + 1)
    _same(_run(_compile()), expected)
    warned = _cache_warnings(recwarn)
    assert len(warned) == 1 and "belongs to another user" in warned[0]


def test_cache_under_a_folder_others_can_write_is_refused(tmp_path, monkeypatch, recwarn):
    shared = tmp_path / "shared"
    shared.mkdir()
    os.chmod(shared, 0o777)                                        # not sticky, unlike /tmp
    monkeypatch.setenv("PORTHAMILTONIAN_CACHE", str(shared / "cache"))
    monkeypatch.setattr(cache, "_refused", set())
    compiled = _compile()
    _run(compiled)
    warned = _cache_warnings(recwarn)
    assert len(warned) == 1 and str(shared) in warned[0] and "writable by other users" in warned[0]
    assert not any((shared / "cache").iterdir())


def test_read_only_cache_builds_elsewhere_with_a_warning(reference, monkeypatch, recwarn):
    entry, expected, _ = reference
    folder = entry.parent
    real_access = os.access
    monkeypatch.setattr(os, "access", lambda p, mode, **kw: False if str(p) == str(folder)
                        else real_access(p, mode, **kw))
    _same(_run(_compile()), expected)
    warned = _cache_warnings(recwarn)
    assert len(warned) == 1 and "not writable" in warned[0]


def test_use_cache_false_writes_nothing(fresh):
    forget_generated()
    compiled = compile_model(io.load(MODEL), backend="python", use_cache=False)
    _run(compiled)
    assert not fresh.exists()
    private = cache.private_dir()
    assert stat.S_IMODE(os.stat(private).st_mode) == 0o700


def test_store_and_load_verified_for_a_native_back_end(fresh, recwarn):
    """The API a native back end uses for its binaries: stored, verified, damage detected."""
    key = "0" * 32
    path = cache.store(key, "model.so", b"\x7fELF binary")
    assert path == fresh / key / "model.so"
    assert cache.load_verified(key, "model.so") == b"\x7fELF binary"
    assert cache.verified_path(key, "model.so") == path
    path.write_bytes(b"\x7fELF other")
    assert cache.load_verified(key, "model.so") is None
    warned = _cache_warnings(recwarn)
    assert len(warned) == 1 and str(path) in warned[0]
    assert not path.exists()
    assert cache.load_verified(key, "absent.so") is None
    with pytest.raises(ValueError):
        cache.store(key, "../escape.so", b"")

"""Add-ons of a model's cache entry: the port-Hamiltonian form's functions and the declared
outputs' Jacobian ``out_jac``, each generated and compiled alone beside the model's library
(porthamiltonian/compiler/__init__.py, ``_with_addon``; porthamiltonian/compiler/cache.py).

* after a plain build, ``compile_model(model, ph=True)`` (and ``ph_matrices`` on the plain
  model) compiles one translation unit, the add-on's: the model's library is not built again
  (its file untouched); the add-on's functions are the text a build of the whole program with
  them printed (the pH functions come from the same generator, in a unit of their own), and
  the form reproduces the right-hand side as in tests/validation/test_ph_form.py;
* every file of the add-on is verified by its sha256 before it is used: a damaged one (its
  record, its bodies, its C library, its module) gives one CacheWarning naming it and is
  rebuilt, never loaded;
* ``out_jac`` is not part of a model's build: its first linearization compiles it alone;
* a compiled model with the form reopens from the cache (``compiler.reopen``) with it, in a
  process that imports no sympy; without the add-on in the cache it does not reopen.
"""
from __future__ import annotations

import dataclasses
import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest
from bounds import copy_entry

from porthamiltonian import compile_model, compiler, io
from porthamiltonian.backends import native
from porthamiltonian.compiler import cache, codegen, phform, printers, symbolic
from porthamiltonian.compiler.cache import CacheWarning

MODEL = "mass_spring_damper"
#: the add-on's functions
PH_FUNCTIONS = ("ph_M0", "ph_grad", "ph_values")


@pytest.fixture
def unit_starts(monkeypatch):
    """``unit_starts()``: from then on, the C units handed to the compiler (their texts), in
    the list it returns."""
    def start() -> list[str]:
        started: list[str] = []
        start_object = native.start_object

        def counted(text: str, name: str) -> native.Pending:
            started.append(text)
            return start_object(text, name)
        monkeypatch.setattr(native, "start_object", counted)
        return started
    return start


def _files(entry) -> dict[str, str]:
    return json.loads((entry / "manifest.json").read_text())["files"]


def _form_numbers(compiled) -> np.ndarray:
    """J, R and ∇H of the form at a state near the initial one, and the form's check of the
    right-hand side there (<= 1e-10 relative, as tests/validation/test_ph_form.py)."""
    x = compiled.initial_state() + 0.01 * np.arange(1, compiled.n_states + 1)
    form = compiled.ph_matrices(x)
    assert form.check()["rhs"] < 1e-10
    return np.concatenate([form.J.ravel(), form.R.ravel(), form.gradient.ravel()])


def _functions(c_body: str) -> dict[str, str]:
    """The C functions of a generated body (each with its wrapper), by name."""
    end = c_body.index(native.FUNCTIONS_END)
    parts = re.split(r"^/\* ph: function (\w+) \*/$", c_body[:end], flags=re.MULTILINE)
    return dict(zip(parts[1::2], parts[2::2]))


def test_ph_after_a_plain_build_compiles_only_the_addon(fresh_with_loops, unit_starts):
    """The plain C build, then ``ph=True``: one unit compiled (the add-on's, which defines the
    three pH functions and none of the model's own), the model's library file the same (inode,
    time, bytes); the add-on's functions are, to the character, those of the whole program
    printed with them (as a ph=True build printed them before the add-on), so the numbers are
    those of that build; ``ph_matrices`` on the plain model gives the same numbers (0 ulp)."""
    model = io.load(MODEL)
    plain = compile_model(model, backend="c")
    entry = fresh_with_loops / plain.key
    library = entry / native.library_name(plain.key)
    before = library.stat()
    started = unit_starts()
    with_form = compile_model(model, backend="c", ph=True)
    assert with_form.key == plain.key and set(PH_FUNCTIONS) <= set(with_form.functions.extra)
    assert len(started) == 1, [text[:200] for text in started]
    assert set(_functions(started[0])) == set(PH_FUNCTIONS)
    after = library.stat()
    assert (after.st_ino, after.st_mtime_ns, after.st_size) == (
        before.st_ino, before.st_mtime_ns, before.st_size)
    assert cache._sha256(library.read_bytes()) == _files(entry)[library.name]
    # the add-on's code is the one-program build's, function by function
    sym = symbolic(model)
    prog = codegen.program(sym)
    whole = dataclasses.replace(prog, functions=(
        *prog.functions, *phform.ph_functions(sym, sym.ph_form())))
    addon = _functions((entry / "addon-ph.c").read_text())
    one_program = _functions(printers.c_source(whole))
    assert {name: addon[name] for name in PH_FUNCTIONS} == {
        name: one_program[name] for name in PH_FUNCTIONS}
    # asked for by the plain model itself: the add-on from the cache, nothing compiled
    started.clear()
    np.testing.assert_array_equal(_form_numbers(plain), _form_numbers(with_form))
    assert started == []
    assert plain.meta.ph is None and with_form.meta.ph == with_form.ph_layout is not None


def test_a_python_build_with_its_form_after_a_c_build_derives_the_model_once(
        fresh_with_loops, forgotten, intact_numbers, monkeypatch):
    """A C build stores no Python body; the python back end's build with the form (``ph=True``)
    from that entry made the symbolic model twice, for the body and again for the add-on: once
    now, and the form's numbers are those of a build without the cache (0 ulp)."""
    model = io.load(MODEL)
    compile_model(model, backend="c")
    forgotten()
    made: list[str] = []
    symbolic_model = compiler._symbolic_model

    def counted(description, claim):
        made.append(description.name)
        return symbolic_model(description, claim)
    monkeypatch.setattr(compiler, "_symbolic_model", counted)
    compiled = compile_model(model, backend="python", ph=True)
    assert made == [MODEL]
    np.testing.assert_array_equal(_form_numbers(compiled), intact_numbers("python"))


@pytest.fixture(scope="module")
def intact_numbers():
    """``intact_numbers(backend)``: :func:`_form_numbers` of the model with its form compiled
    without the cache (``use_cache=False``, nothing of an earlier build reused), once per back
    end for the module (the caller has forgotten the generated modules it imported): what a
    build from a damaged cache must give."""
    numbers: dict[str, np.ndarray] = {}

    def get(backend: str) -> np.ndarray:
        if backend not in numbers:
            numbers[backend] = _form_numbers(
                compile_model(io.load(MODEL), backend=backend, ph=True, use_cache=False))
        return numbers[backend]
    return get


# every file once; the two kinds of damage (the same path: a sha256 that does not match) on the
# library both, on the others alternately
@pytest.mark.parametrize(("backend", "name", "damage"), [
    ("c", "library", "garbage"), ("c", "library", "truncated"), ("c", "addon-ph.c", "truncated"),
    ("c", "addon-ph.json", "garbage"), ("python", "module", "truncated"),
    ("python", "addon-ph.py", "garbage")])
def test_a_damaged_addon_file_is_never_loaded_and_is_rebuilt(fresh_with_loops, forgotten,
                                                             built_elsewhere, intact_numbers,
                                                             backend, name, damage, recwarn):
    """Each file of the add-on, damaged after a build in another process (its entry, manifest
    and all, copied into this test's cache): one CacheWarning naming it, the file made again
    (its bytes matching the manifest), and the form's numbers those of an intact build (0 ulp);
    the model's own library or module is not touched."""
    key, built = built_elsewhere(MODEL, backend, ph=True)
    entry = copy_entry(built, fresh_with_loops)
    files = {"library": native.library_name(f"{key}_ph"), "module": f"m{key}_ph_python.py"}
    path = entry / files.get(name, name)
    own = entry / (native.library_name(key) if backend == "c" else f"m{key}_python.py")
    own_before = own.read_bytes()
    data = path.read_bytes()
    path.write_bytes(b"not what was stored" if damage == "garbage" else data[: len(data) // 2])
    compiled = compile_model(io.load(MODEL), backend=backend, ph=True)
    warned = [str(w.message) for w in recwarn if issubclass(w.category, CacheWarning)]
    assert len(warned) == 1 and str(path) in warned[0], warned
    assert path.read_bytes() == data and cache._sha256(data) == _files(entry)[path.name]
    assert own.read_bytes() == own_before
    forgotten()
    np.testing.assert_array_equal(_form_numbers(compiled), intact_numbers(backend))


#: a fresh process reopens a compiled model with its form from its record, and says whether
#: it imported sympy
_REOPEN = """
import json, sys
from porthamiltonian.compiler import reopen
compiled = reopen(json.loads(sys.argv[1]), lambda: None)
x = [0.1, 0.2]
p = compiled.native_params(compiled.param_defaults)
print(json.dumps({"sympy": "sympy" in sys.modules,
                  "M0": compiled.functions.extra["ph_M0"](0.0, compiled.augment(x), p).tolist(),
                  "ph": compiled.ph_layout is not None}))
"""


def test_a_model_with_its_form_reopens_without_sympy(fresh_with_loops):
    """``compiled_record`` of a model compiled with ``ph=True``: ``reopen`` in a fresh process
    gives it with the form's functions (M₀ the same, 0 ulp) and imports no sympy; with the
    add-on's record gone from the cache it does not reopen (the caller compiles)."""
    compiled = compile_model(io.load(MODEL), backend="c", ph=True)
    record = compiler.compiled_record(compiled)
    assert record["ph"] is True
    run = subprocess.run([sys.executable, "-c", _REOPEN, json.dumps(record)],
                         capture_output=True, text=True, check=True, env=dict(os.environ))
    out = json.loads(run.stdout)
    expected = compiled.functions.extra["ph_M0"](
        0.0, compiled.augment([0.1, 0.2]), compiled.native_params(compiled.param_defaults))
    assert out["ph"] and not out["sympy"]
    np.testing.assert_array_equal(np.array(out["M0"]), expected)
    cache.discard(compiled.key, "addon-ph.json")
    assert compiler.reopen(record, lambda: io.load(MODEL).freeze()) is None


def test_a_first_linearization_compiles_only_the_output_jacobian(fresh_with_loops, unit_starts):
    """``out_jac`` (∂y/∂[x, u] of the declared outputs) is the add-on a first linearization
    builds: cart_pole's C build, with a nonlinear output of a state and the input besides its
    own (x, θ), has none; its first ``linearize`` compiles one unit, which defines out_jac
    alone (the model's library untouched); a second linearization and a model compiled again
    read it from the cache (nothing compiled). C and D: the rows of x and θ exactly [I 0] and
    0; the nonlinear row equal to its closed form to 1e-15 (relative)."""
    model = io.load("cart_pole")
    model.output("tip", "cart_pole.q.slider + 0.5*sin(cart_pole.q.pivot) + 0.1*F**2")
    plain = compile_model(model, backend="c")
    assert "out_jac" not in plain.functions.extra and "out_jac" not in plain.meta.shapes
    library = fresh_with_loops / plain.key / native.library_name(plain.key)
    before = library.stat()
    started = unit_starts()
    x, u = np.array([0.3, -0.4, 0.2, 0.1]), 0.7
    lin = plain.linearize(x=x, u=[u])
    assert len(started) == 1 and set(_functions(started[0])) == {"out_jac"}
    after = library.stat()
    assert (after.st_ino, after.st_mtime_ns) == (before.st_ino, before.st_mtime_ns)
    assert lin.outputs == ("x", "theta", "tip")
    np.testing.assert_array_equal(lin.C[:2], np.hstack([np.eye(2), np.zeros((2, 2))]))
    np.testing.assert_array_equal(lin.D[:2], np.zeros((2, 1)))
    closed = np.array([1.0, 0.5 * np.cos(x[1]), 0.0, 0.0, 0.2 * u])
    row = np.append(lin.C[2], lin.D[2])
    assert np.max(np.abs(row - closed)) <= 1e-15 * np.max(np.abs(closed)), row
    again = compile_model(model, backend="c").linearize(x=x, u=[u])
    np.testing.assert_array_equal(plain.linearize(x=x, u=[u]).C, lin.C)
    np.testing.assert_array_equal(again.C, lin.C)
    assert len(started) == 1

"""The C back end compiles a long model body as two translation units at once when a core is
free (porthamiltonian.backends.native.model_units, split_units): every generated function in exactly one of them
with its wrapper, the two about the same size, the model's other definitions once; a library
linked from them computes what the one-unit library computes, bit for bit, with and without a
generated ``jac_p`` (the stub must then not be added beside it)."""
from __future__ import annotations

import re

import numpy as np
import pytest

from porthamiltonian import compile_model, io
from porthamiltonian.backends import native
from porthamiltonian.compiler import symbolic
from porthamiltonian.compiler.codegen import program
from porthamiltonian.compiler.printers import c_source

_DEFINED = re.compile(r"^(?:static |PH_HIDDEN |PH_EXPORT )?(?:void|int|const char \*) ?(\w+)\(",
                      re.MULTILINE)


def _body(name: str, jac_p: list[str] | None = None) -> str:
    return c_source(program(symbolic(io.load(name)), jac_p=jac_p))


def _external(unit: str) -> list[str]:
    """The names a unit defines with external linkage (not static)."""
    return [m.group(1) for m in _DEFINED.finditer(unit) if not m.group(0).startswith("static")]


@pytest.mark.parametrize("jac_p", [None, ["slope"]], ids=["plain", "jac_p"])
def test_a_long_body_is_two_balanced_units_defining_everything_once(jac_p):
    body = _body("compass_walker", jac_p)
    assert len(body) > native.SPLIT_SIZE
    units = native.model_units(body, key="k1")
    assert len(units) == 2
    functions = re.findall(r"^/\* ph: function (\w+) \*/$", body, re.MULTILINE)
    placed = [re.findall(r"^/\* ph: function (\w+) \*/$", u, re.MULTILINE) for u in units]
    assert sorted(placed[0] + placed[1]) == sorted(functions)
    for names, unit in zip(placed, units):     # each function's wrapper beside it
        assert all(f"PH_EXPORT void ph_{n}(" in unit for n in names)
    def parts(text: str) -> list[str]:
        return re.split(r"(?=^/\* ph: function )", text, flags=re.MULTILINE)[1:]
    sizes = [sum(len(part) for part in parts(u)) for u in units]
    largest = max(len(part) for part in parts(body))
    assert abs(sizes[0] - sizes[1]) <= largest
    external = _external(units[0]) + _external(units[1])
    assert len(external) == len(set(external))                 # linked together: once each
    assert {"ph_layout", "ph_selftest", "ph_model_key"} <= set(_external(units[0]))
    assert external.count("jac_p") == 1      # generated (in either unit) or the stub (the first)


def test_a_short_body_or_a_busy_machine_is_one_unit():
    body = _body("mass_spring_damper")
    assert len(body) <= native.SPLIT_SIZE
    assert native.model_units(body, key="k2") == [native.model_unit(body, key="k2")]
    body = _body("compass_walker")
    assert native.model_units(body, key="k2", split=False) == [native.model_unit(body, key="k2")]


def test_two_units_when_asked_or_when_a_core_is_free(monkeypatch):
    """$PORTHAMILTONIAN_CC_JOBS decides (the test suite sets 1: its workers keep the cores
    busy); without it (or with a value that is not a number), a free core: the 1-minute load
    below the core count less one half."""
    monkeypatch.setattr("os.cpu_count", lambda: 2)
    monkeypatch.setattr("os.getloadavg", lambda: (1.2, 0.0, 0.0))
    for value, split in (("1", False), ("2", True), (" 4 ", True)):
        monkeypatch.setenv("PORTHAMILTONIAN_CC_JOBS", value)
        assert native.split_units() is split
    for value in ("", "two", "-1"):
        monkeypatch.setenv("PORTHAMILTONIAN_CC_JOBS", value)
        assert native.split_units()                  # load 1.2 < 1.5: a core is free
    monkeypatch.setattr("os.getloadavg", lambda: (1.6, 0.0, 0.0))  # (two busy workers, say)
    assert not native.split_units()


@pytest.mark.parametrize("jac_p", [[], ["slope"]], ids=["plain", "jac_p"])
def test_the_two_unit_library_computes_what_one_unit_computes(jac_p, monkeypatch, tmp_path,
                                                             seed_loops):
    """compass_walker built on C twice, in two fresh caches (each holding the session's loops'
    object, which both libraries link: the model's units are what differs): as two units
    ($PORTHAMILTONIAN_CC_JOBS=2), then as one (1): every generated function (rhs, jac, energy, outputs,
    guards, jac_p) equal bit for bit at 5 points."""
    monkeypatch.setenv("PORTHAMILTONIAN_CACHE", str(tmp_path / "two"))
    seed_loops()
    monkeypatch.setenv("PORTHAMILTONIAN_CC_JOBS", "2")
    units = []
    start = native.start_object
    monkeypatch.setattr(native, "start_object", lambda text, name: units.append(name)
                        or start(text, name))
    two = compile_model(io.load("compass_walker"), backend="c", jac_p=jac_p)
    assert len([u for u in units if u.startswith("m")]) == 2
    monkeypatch.setenv("PORTHAMILTONIAN_CC_JOBS", "1")
    monkeypatch.setenv("PORTHAMILTONIAN_CACHE", str(tmp_path / "one"))
    seed_loops()
    one = compile_model(io.load("compass_walker"), backend="c", jac_p=jac_p)
    rng = np.random.default_rng(5)
    x0 = one.augment(one.initial_state())
    p = one.native_params(np.asarray(one.param_defaults, dtype=float))

    def calls(model):
        f = model.functions
        return {"rhs": f.rhs, "jac": f.jac, "energy": f.energy, "outputs": f.outputs,
                "guards": f.guards, **f.extra}
    assert calls(one).keys() == calls(two).keys() and ("jac_p" in calls(one)) == bool(jac_p)
    for _ in range(5):
        x = x0 + 0.05 * rng.standard_normal(x0.size)
        for name, f in calls(one).items():
            assert np.array_equal(f(0.0, x, p), calls(two)[name](0.0, x, p)), name

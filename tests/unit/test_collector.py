"""The cyclic garbage collector is paused while a model is read and built (porthamiltonian.collector),
and only then."""
from __future__ import annotations

import gc

import pytest

from porthamiltonian import collector, compiler, io


@pytest.fixture
def collector_on():
    was = gc.isenabled()
    gc.enable()
    yield
    if not was:
        gc.disable()


def test_paused_restores_the_collector_also_after_an_error(collector_on):
    with collector.paused():
        assert not gc.isenabled()
        with collector.paused():        # nested: the outer one turns it on again
            assert not gc.isenabled()
        assert not gc.isenabled()
    assert gc.isenabled()
    with pytest.raises(ZeroDivisionError), collector.paused():
        _ = 1 / 0
    assert gc.isenabled()


def test_paused_leaves_a_collector_that_was_off_off(collector_on):
    gc.disable()
    with collector.paused():
        assert not gc.isenabled()
    assert not gc.isenabled()


def test_the_collector_is_off_while_a_model_is_read_and_built(collector_on, tmp_path,
                                                             monkeypatch):
    """Reading a model file (its components, expressions) and the build's symbolic stage and
    code generation run with the collector off; it is on again afterwards."""
    from porthamiltonian.interfaces import io as io_module

    monkeypatch.setenv("PORTHAMILTONIAN_CACHE", str(tmp_path))     # a build, not a cache hit
    seen: dict[str, bool] = {}

    def recording(name, function):
        def wrapper(*args, **kwargs):
            seen[name] = gc.isenabled()
            return function(*args, **kwargs)
        return wrapper

    monkeypatch.setattr(io_module, "file_from_dict",
                        recording("read", io_module.file_from_dict))
    monkeypatch.setattr(compiler, "_symbolic_model",
                        recording("symbolic", compiler._symbolic_model))
    monkeypatch.setattr(compiler, "_program", recording("code", compiler._program))
    compiled = compiler.compile_model(io.load("pendulum"), backend="python")
    assert compiled.n_states == 2
    assert seen == {"read": False, "symbolic": False, "code": False}
    assert gc.isenabled()

"""The numba back end's integration loops, compiled once for all models
(porthamiltonian/backends/numba_loops.py; .ci/run's numba pass runs these: ``numba_loop``).

* Two models run one compiled loop (the same dispatcher with one signature: the model's
  functions are first-class function arguments), each agreeing with the same loop run as plain
  Python on the python back end.
* Arguments of other types than the loop's (a read-only state, integer scalars, a list, float
  event directions, a strided vector) are converted: the same result, no second compile.
* The loops' compiled code is kept in their own cache entry, every file of it recorded in the
  entry's manifest with its sha256 (read back only after that check: compiler/numba_cache.py).
* The loop calls a model's functions through numba's own calling convention: an exception
  raised in one (a division by zero) reaches the caller; with a valid parameter the same hand-
  written model integrates x'' = -x/p to cos(1) (its closed form).
"""
from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np
import pytest

from porthamiltonian import compile_model, io

pytestmark = pytest.mark.numba_loop

MODELS = ("pendulum", "bouncing_ball")     # different sizes; one with events
SETTINGS = {"method": "Rodas5P", "rtol": 1e-8, "atol": 1e-11}


@pytest.fixture(scope="module")
def runs() -> dict:
    """name -> (numba model, its run, the python back end's run) over 1 s."""
    out = {}
    for name in MODELS:
        nb = compile_model(io.load(name), backend="numba")
        py = compile_model(io.load(name), backend="python")
        out[name] = (nb, nb.simulate(1.0, **SETTINGS), py.simulate(1.0, **SETTINGS))
    return out


def test_models_share_one_compiled_loop(runs):
    loops = [nb.functions.loops["Rodas5P"] for nb, _, _ in runs.values()]
    assert loops[0].entry is loops[1].entry
    assert loops[0].fn[0] is not loops[1].fn[0]
    assert len(loops[0].entry.signatures) == 1
    for nb, numba_run, python_run in runs.values():
        assert numba_run.status == python_run.status
        assert abs(len(numba_run.t) - len(python_run.t)) <= 2
        scale = np.max(np.abs(python_run.x_final))
        np.testing.assert_allclose(numba_run.x_final, python_run.x_final, rtol=1e-7,
                                   atol=1e-9 * scale)


def _arguments(model) -> tuple:
    p = np.asarray(model.native_params(model.param_defaults))
    y0 = model.augment(model.initial_state())
    n = len(y0)
    return (0.0, y0, 1.0, p, 1e-8, np.full(n, 1e-11), 0.0, 1e300, np.zeros(0, dtype=np.int64),
            np.zeros(0, dtype=bool), -1, 0.0, model.n_states, 1e12, 10**6, 4096, 0.0)


def test_other_argument_types_are_converted(runs):
    model = runs["pendulum"][0]
    loop = model.functions.loops["Rodas5P"]
    args = _arguments(model)
    reference = loop(*args)
    frozen = args[1].copy()
    frozen.flags.writeable = False
    strided = np.repeat(args[5], 2)[::2]
    odd = (0, frozen, 1, list(args[3]), args[4], strided, 0, args[7], np.zeros(0), [], -1, 0,
           model.n_states, args[13], args[14], 4096, 0)
    out = loop(*odd)
    assert out[0] == reference[0] == 0 and out[1] == reference[1]
    assert np.array_equal(out[2], reference[2])
    assert len(loop.entry.signatures) == 1


def _oscillator():
    """x'' = -x / p[0] as (rhs, jac, guards, jac_p), written by hand with numba."""
    from numba import njit

    @njit
    def rhs(t, x, p):
        out = np.empty(2)
        out[0] = x[1]
        out[1] = -x[0] / p[0]
        return out

    @njit
    def jac(t, x, p):
        out = np.zeros((2, 2))
        out[0, 1] = 1.0
        out[1, 0] = -1.0 / p[0]
        return out

    @njit
    def guards(t, x, p):
        return np.empty(0)

    @njit
    def jac_p(t, x, p):
        return np.zeros((2, 0))

    return rhs, jac, guards, jac_p


def test_a_model_function_raising_reaches_the_caller():
    from porthamiltonian.backends.numba_loops import BoundLoop
    from porthamiltonian.compiler.numba_cache import loop_module

    entry = loop_module().integrate_rodas5p
    loop = BoundLoop(entry, _oscillator(), variational=False)
    args = [0.0, np.array([1.0, 0.0]), 1.0, np.array([1.0]), 1e-10, np.full(2, 1e-13), 0.0,
            1e300, np.zeros(0, dtype=np.int64), np.zeros(0, dtype=bool), -1, 0.0, 2, 1e12,
            10**6, 4096, 0.0]
    out = loop(*args)
    assert out[0] == 0 and abs(out[2][0] - math.cos(1.0)) < 1e-8
    args[3] = np.array([0.0])
    with pytest.raises(ZeroDivisionError):
        loop(*args)
    assert len(entry.signatures) == 1


def test_the_loops_compiled_code_is_recorded(runs):
    from porthamiltonian.compiler.numba_cache import loop_module

    entry = Path(loop_module().__file__).parent
    files = json.loads((entry / "manifest.json").read_text())["files"]
    written = sorted((entry / "__pycache__").iterdir())
    assert any(p.name.endswith(".nbi") for p in written)
    assert any(p.name.endswith(".nbc") for p in written)
    for path in written:
        assert files[f"__pycache__/{path.name}"] == hashlib.sha256(path.read_bytes()).hexdigest()

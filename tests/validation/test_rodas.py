"""The compiled Rosenbrock loops (porthamiltonian/integrators/: Rodas4 and Rodas5P, one template
in Python and in C) against closed forms and against scipy's Radau: order of convergence,
events, stiffness, time-dependent models, back ends.

References: Hairer & Wanner, *Solving Ordinary Differential Equations II* (2nd ed., 1996), §IV.7
(Rodas: order 4, embedded order 3, L-stable); G. Steinebach, BIT Numer. Math. 63, 27 (2023)
(Rodas5P: order 5, embedded order 4); the closed forms are those of test_textbook.py.
"""
from __future__ import annotations

import itertools
import math
import sys
from pathlib import Path

import numpy as np
import pytest

import porthamiltonian as ph
from porthamiltonian import compile_model, io

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "unit"))
from test_events import ball_model, bounce_action, bounce_times

METHODS = ("Rodas4", "Rodas5P")
#: the numba loops run in .ci/run's numba pass (tests/conftest.py: ``numba_loop``)
NUMBA = pytest.param("numba", marks=pytest.mark.numba_loop)


def _msd_exact(t: float) -> float:
    """Free response of models/mass_spring_damper.toml (m = 1, k = 4, c = 0.4, x0 = 0.1)."""
    wn, z = 2.0, 0.1
    wd = wn * math.sqrt(1 - z * z)
    return 0.1 * math.exp(-z * wn * t) * (math.cos(wd * t) + z * wn / wd * math.sin(wd * t))


@pytest.fixture(scope="module")
def msd():
    """mass_spring_damper on the C back end (its loops are numba's, statement for statement:
    test_python_numba_and_c_loops_agree; numba's compilation of a model's loops costs ~15 s of
    CPU, the C library is shared with test_sensitivity)."""
    return compile_model(io.load("mass_spring_damper"), backend="c")


@pytest.mark.parametrize("method, q", [("Rodas4", 4), ("Rodas5P", 5)])
def test_error_falls_with_tolerance_and_steps_grow_as_root_of_order(msd, method, q):
    """A method whose error estimate is of order q - 1 with tolerance-proportional control:
    100x smaller rtol gives ~100x smaller error and 100^(1/q) more steps (Rodas4: ≈ 3.2x, we
    accept 2.5-4x; Rodas5P: ≈ 2.5x, we accept 2-3.2x)."""
    errors, steps = [], []
    for rtol in (1e-6, 1e-8, 1e-10):
        traj = msd.simulate(20.0, method=method, rtol=rtol, atol=rtol * 1e-2)
        errors.append(abs(traj.x_final[msd.state_index("spring.q")] - _msd_exact(20.0)))
        steps.append(len(traj.t))
    assert errors[0] < 1e-6 * 0.1 * 10 and errors[2] < 1e-10 * 0.1 * 10
    for a, b in itertools.pairwise(errors):
        assert 20 < a / b < 500
    expected = 100 ** (1 / q)
    for a, b in itertools.pairwise(steps):
        assert 0.8 * expected < b / a < 1.27 * expected


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("backend", ["python", NUMBA, "c"])
def test_bounce_times_match_closed_form(backend, method):
    """Bounces of a ball with restitution 0.8 (closed form in test_events.py) to 1e-9, with the
    ledger closed across the resets; the whole flight between two bounces may fit in a few steps,
    so this also checks that interior guard samples catch the crossing (on each method's dense
    output)."""
    ball = compile_model(ball_model(ground_event=True), backend=backend)
    traj = ball.simulate(2.5, method=method, actions={"ground": bounce_action(ball)},
                         rtol=1e-10, atol=1e-12)
    times = np.array([t for t, _ in traj.events])
    assert len(times) == 4
    np.testing.assert_allclose(times, bounce_times(4), atol=1e-9)
    assert traj.relative_residual < 1e-9


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("other", ["c", NUMBA])
def test_python_numba_and_c_loops_agree(method, other):
    """The same loop as plain Python, as numba machine code and as C: the same steps up to the
    last bits of pow() in the step-size rule and of the generated arithmetic, so the results
    agree to the tolerance (rtol 1e-8)."""
    model = io.load("dc_motor")
    runs = [compile_model(model, backend=b).simulate(0.2, method=method, rtol=1e-8, atol=1e-11)
            for b in ("python", other)]
    for run in runs[1:]:
        assert abs(len(run.t) - len(runs[0].t)) <= 2
        np.testing.assert_allclose(run.x_final, runs[0].x_final, rtol=1e-7)


def _fixed_step(model, method: str, t_end: float, h: float) -> np.ndarray:
    """The compiled loop of ``method`` with constant steps h (a tolerance no step can miss)."""
    p = model.param_defaults
    y0 = model.augment(model.initial_state(p))
    n = len(y0)
    out = model.functions.loops[method](
        0.0, y0, t_end, p, 0.5, np.full(n, 1e10), h, h, np.zeros(0, dtype=np.int64),
        np.zeros(0, dtype=bool), -1, 0.0, model.n_states, 1e12, 10**6, 10**5,
        0.0 if model.autonomous else 1e-7)
    assert out[0] == 0 and abs(out[8] - round(t_end / h)) <= 1   # (+1: a last sliver)
    return out[2][:model.n_states]


@pytest.mark.parametrize("name, method, order, h", [
    ("double_pendulum", "Rodas5P", 5, 0.02), ("pendulum", "Rodas4", 4, 0.02),
    ("modulated_spring", "Rodas4", 4, 0.02), ("modulated_spring", "Rodas5P", 5, 0.01)])
def test_order_of_convergence_with_constant_steps(c_run, name, method, order, h):
    """Halving a constant step divides the error at t = 1 by 2^order (Rodas4: 4, Rodas5P: 5;
    modulated_spring is time-dependent: ∂f/∂t by a difference), measured against Radau at rtol
    1e-13: the observed order over h -> h/2 -> h/4 (in the asymptotic range, above the error
    floor of the ∂f/∂t difference) is within 0.35 of it. This checks the coefficients of
    tableaus.py as the loops use them (C back end; the Radau reference is the session's one run
    per model, validation/conftest.py)."""
    model = compile_model(io.load(name), backend="c")
    ref = c_run(name, 1.0, "Radau", 1e-13, 1e-14).x_final
    errors = [np.max(np.abs(_fixed_step(model, method, 1.0, step) - ref))
              for step in (h, h / 2, h / 4)]
    for a, b in itertools.pairwise(errors):
        assert abs(math.log2(a / b) - order) < 0.35, errors


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", ["dc_motor", "modulated_spring", "double_pendulum", "free_rigid_body"])
def test_agrees_with_radau(c_run, name, method):
    """Stiff (dc_motor: time constants 0.5 ms and ~40 ms), time-dependent (modulated_spring:
    ∂f/∂t by a difference), implicit blocks (double pendulum, free body): each compiled method
    and Radau at rtol 1e-10 agree to 1e-6 relative to the state scale, and both ledgers close.
    (Radau's run is the session's one per model, shared with test_qbdf: validation/conftest.py.)"""
    model = compile_model(io.load(name), backend="c")
    t_end = min(3.0, float(io.read(name).simulation["t_end"]))
    a = model.simulate(t_end, method=method, rtol=1e-10, atol=1e-12)
    b = c_run(name, t_end, "Radau", 1e-10, 1e-12)
    assert a.status == b.status == "finished"
    scale = max(1.0, float(np.max(np.abs(b.x))))
    assert np.max(np.abs(a.x_final - b.x_final)) < 1e-6 * scale
    assert a.relative_residual < 1e-7


@pytest.mark.parametrize("backend", [NUMBA, "c"])
def test_divergence_is_a_status(backend):
    m = ph.Model("unstable")
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0, p0=1.0))
    m.add("spring", ph.C(stiffness=-100.0))
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    traj = compile_model(m, backend=backend).simulate(100.0, method="Rodas4", divergence_bound=1e6)
    assert traj.status == "diverged" and "1e+06" in traj.message
    assert 0.0 < traj.t_final < 2.0


@pytest.mark.parametrize("method", METHODS)
def test_compiled_methods_refuse_python_events(msd, method):
    apex = ph.Event("apex", lambda t, x, p: x[1])
    with pytest.raises(ph.errors.ModelError, match=f"{method}.*Python events"):
        msd.simulate(1.0, method=method, events=[apex])


def test_a_tableau_beyond_the_loops_stage_buffers_is_refused():
    """The C loops keep a stage's coefficients in a buffer of PH_MAX_STAGES (16): a tableau
    of 17 stages (zeros, well formed otherwise) is refused when checked, naming the limit."""
    from dataclasses import replace

    from porthamiltonian.errors import OptionError
    from porthamiltonian.integrators.tableaus import MAX_STAGES, TABLEAUS

    s = MAX_STAGES + 1
    square = tuple(tuple(0.0 for _ in range(s)) for _ in range(s))
    base = TABLEAUS["Rodas5P"]
    wide = replace(base, a=square, c=square, nodes=(0.0,) * s, d=(base.gamma,) + (0.0,) * (s - 1),
                   dense=tuple(tuple(0.0 for _ in range(s)) for _ in base.dense))
    with pytest.raises(OptionError, match="17 stages, more than the loops' 16"):
        wide.check()
    base.check()
    assert max(t.stages for t in TABLEAUS.values()) <= MAX_STAGES
    source = (Path(ph.__file__).parent / "integrators" / "rosenbrock_loop.c").read_text()
    assert f"#define PH_MAX_STAGES {MAX_STAGES} " in source

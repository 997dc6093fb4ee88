"""The back ends against each other: the C back end (generated C99 + the C integration loop),
numba and the python reference evaluate the same program (porthamiltonian.compiler.codegen).

* every shipped model: python and C agree on rhs, jac, energy, outputs, guards, the named
  matrices and the initial state to 1e-12 relative to each function's largest entry, at random
  states and parameters (numba on a cheap set: its compilation is slow);
* the printers give Heaviside, sign, min/max, Piecewise, abs and powers the same meaning on
  edge values (±0, ±inf, NaN);
* (the energy ledger closes on the C back end for every shipped model with its file's settings:
  test_textbook's per-model test, from the session's ``check-energy`` run, tests/conftest.py);
* the same gait: a rigid walker (scipy DOP853 on C or on python functions) to 1e-9 (fixed
  point) and 1e-7 (multipliers).
"""
from __future__ import annotations

import math
import re

import numpy as np
import pytest

import porthamiltonian as ph
from porthamiltonian import compile_model, io

MODELS = io.available_models()


def _random_point(model, rng):
    """(t, x, p): the initial state plus noise, parameters within 10 % of their defaults."""
    p = model.param_defaults * (1 + 0.1 * rng.uniform(-1, 1, len(model.param_defaults)))
    x = np.concatenate([model.initial_state(model.param_defaults), [0.0, 0.0]])
    x = x + 0.1 * rng.standard_normal(len(x))
    return float(rng.uniform(0, 1)), x, p


def _all_functions(model, t, x, p) -> dict[str, np.ndarray]:
    f, pn = model.functions, model.native_params(p)
    out = {name: np.asarray(getattr(f, name)(t, x, pn), dtype=float)
           for name in ("rhs", "jac", "energy", "outputs", "guards")}
    out["initial"] = np.asarray(f.initial(pn), dtype=float)
    for k, fn in enumerate(f.matrices):
        out[f"matrix_{k}"] = np.asarray(fn(t, x, pn), dtype=float)
    return out


def _agree(a: dict, b: dict, what: str) -> None:
    for name, ra in a.items():
        rb = b[name]
        assert rb.shape == ra.shape, (what, name)
        scale = max(float(np.max(np.abs(ra))), 1e-300)
        assert np.max(np.abs(ra - rb)) <= 1e-12 * scale, (what, name, np.max(np.abs(ra - rb)))


@pytest.mark.parametrize("name", MODELS)
def test_python_and_c_agree_on_every_shipped_model(name, compile_named, energy_check):
    """Every function of every shipped model at 3 random points: C equals the python reference
    to 1e-12 of the function's largest entry (measured: ≤ 7e-16). (The session's check-energy
    run has built every model for both back ends into the shared cache: waited for, not built
    twice.)"""
    _ = energy_check.run
    py = compile_named(name)
    c = compile_model(io.load(name), backend="c")
    assert c.backend == "c" and c.key == py.key
    rng = np.random.default_rng(sum(map(ord, name)))
    for _ in range(3):
        t, x, p = _random_point(py, rng)
        _agree(_all_functions(py, t, x, p), _all_functions(c, t, x, p), name)


@pytest.mark.parametrize("name", ["compass_walker", "whipple_bicycle", "bouncing_ball"])
def test_a_batch_call_is_the_calls_point_by_point(name, compile_named, energy_check):
    """The C back end's ``fn.many`` (one call for many points: a trajectory's outputs and
    energy, a dense output's rates) gives each point's result bit for bit; and
    ``backends.at_points`` on the python back end (a call per point) the same to 1e-12. A
    batch of states of the wrong width is refused, naming the shapes."""
    _ = energy_check.run
    c = compile_model(io.load(name), backend="c")
    rng = np.random.default_rng(sum(map(ord, name)) + 1)
    points = [_random_point(c, rng) for _ in range(5)]
    ts = np.array([t for t, _, _ in points])
    xs = np.array([x for _, x, _ in points])
    pn = c.native_params(points[0][2])
    py = compile_named(name)
    for fname in ("rhs", "jac", "energy", "outputs", "guards"):
        fn = getattr(c.functions, fname)
        single = np.array([fn(t, x, pn) for t, x in zip(ts, xs)])
        assert np.array_equal(fn.many(ts, xs, pn), single), fname
        assert np.array_equal(ph.backends.at_points(fn, ts, xs, pn), single), fname
        reference = ph.backends.at_points(getattr(py.functions, fname), ts, xs,
                                          py.native_params(points[0][2]))
        _agree({fname: single}, {fname: reference}, name)
    with pytest.raises(ph.errors.OptionError, match=r"rhs.many: 5 times .*\(5, 3\)"):
        c.functions.rhs.many(ts, xs[:, :3], pn)


@pytest.mark.numba_loop
@pytest.mark.parametrize("name", ["double_pendulum", "free_rigid_body", "bouncing_ball"])
def test_numba_agrees_with_python_and_c(name, compile_named):
    """numba (compiled at the first call: a cheap set of models, implicit blocks included; in
    .ci/run's numba pass)."""
    py = compile_named(name)
    nb = compile_model(io.load(name), backend="numba")
    rng = np.random.default_rng(7)
    t, x, p = _random_point(py, rng)
    _agree(_all_functions(py, t, x, p), _all_functions(nb, t, x, p), name)


def _edge_model() -> ph.Model:
    m = ph.Model("edges")
    m.parameter("k", 2.0, "N/m")
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0))
    m.add("spring", ph.C(stiffness="k"))
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    q = "spring.q"
    outputs = {"heaviside": f"Heaviside({q})", "sign": f"sign({q})",
               "min": f"min({q}, k - 2, 1)", "max": f"max(0.5, {q})", "abs": f"abs({q})",
               "piecewise": f"Piecewise((1, {q} > 0), (2, {q} < -1), (3, True))",
               "where": f"where({q} >= 0.5, {q}**3, -{q}**2)", "inverse": f"1/({q}**2 + 1)",
               "root": f"sqrt(abs({q}))"}
    for name, expr in outputs.items():
        m.output(name, expr)
    return m


def test_printers_give_the_same_meaning_on_edge_values():
    """Heaviside (1/2 at 0), sign (0 at ±0, ±1 by the sign bit), min/max (Python's left fold,
    NaN included), Piecewise, where, abs, powers: C and python give the same bits (NaN
    positions equal) at q in {±2, ±1, ±0.5, ±0, ±inf, NaN}."""
    model = _edge_model()
    py = compile_model(model, backend="python")
    c = compile_model(model, backend="c")
    assert py.output_names == c.output_names
    qs = [-2.0, -1.0, -0.5, -0.0, 0.0, 0.5, 1.0, 2.0, math.inf, -math.inf, math.nan]
    iq = py.state_index("spring.q")
    for q in qs:
        x = np.zeros(py.n_states + 2)
        x[iq] = q
        a = np.asarray(py.functions.outputs(0.0, x, py.native_params(py.param_defaults)))
        b = c.functions.outputs(0.0, x, c.native_params(c.param_defaults))
        mine = [py.output_index(n) for n in ("heaviside", "sign", "min", "max", "abs",
                                             "piecewise", "where", "inverse", "root")]
        np.testing.assert_array_equal(a[mine], b[mine], err_msg=f"q = {q}")
    x = np.zeros(py.n_states + 2)
    assert py.functions.outputs(0.0, x, py.native_params(py.param_defaults))[
        py.output_index("heaviside")] == 0.5


def test_generated_functions_list_their_layout_and_hostile_names_stay_in_comments():
    """The generated code lists the order of the state and parameter entries by name (once, in
    its header) and names each output in a comment where it is stored; a model name that would
    end a C comment or a Python docstring stays inside it (the code compiles, imports and
    runs)."""
    m = _edge_model()
    m.name = 'x*/ int evil; /* """ ??/'
    c = compile_model(m, backend="c")
    py = compile_model(m, backend="python")
    assert c.simulate(0.1).status == py.simulate(0.1).status == "finished"
    for source in (c.source, py.source):
        assert "[1] spring.q" in source and "[0] k" in source
    out = c.output_index("heaviside")
    assert re.search(rf"^    out\[{out}\] = .*  # heaviside$", py.source, re.MULTILINE)
    assert re.search(rf"^    out\[{out}\] = .*; /\* heaviside \*/$", c.source, re.MULTILINE)
    assert "x* / int evil; / * " in c.source and "int evil;" not in c.source.replace(
        "x* / int evil;", "")
    for name in ("rhs", "jac", "energy", "outputs", "guards", "initial"):
        # rhs, jac, guards: hidden externals, called by the integration loops' own object
        linkage = "PH_HIDDEN" if name in ("rhs", "jac", "guards") else "static"
        assert f"{linkage} void {name}(" in c.source and f"\ndef {name}(" in py.source


def test_same_rigid_walker_gait_on_python_and_c():
    """The rimless wheel (its file: scipy DOP853 at rtol 1e-12) on python and on C functions:
    the fixed point to 1e-9, the Floquet multipliers to 1e-7."""
    from walker_library import analyze_gait, load_walker

    gaits = [analyze_gait(load_walker("rimless_wheel", backend=b)) for b in ("python", "c")]
    assert gaits[1].status == gaits[0].status == "periodic"
    for k, v in gaits[0].fixed_point.items():
        assert abs(gaits[1].fixed_point[k] - v) < 1e-9, k
    a, b = (np.array(sorted(g.floquet_multipliers, key=lambda c: (-abs(c), -c.imag)))
            for g in gaits)
    assert np.max(np.abs(a - b)) < 1e-7

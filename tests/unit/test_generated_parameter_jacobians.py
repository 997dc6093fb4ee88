"""The generated ∂g/∂[x, p] of the event guards (``guard_jac``) and ∂y/∂[x, p] of the named
outputs (``outputs_jac``), which a model compiled with ``jac_p`` has beside ∂ẋ/∂p: against
central differences of the model's own ``guards`` and ``outputs`` (a second derivation: the
generated code's chain rule against the evaluated functions), on the compass gait (C back end)
and the compliant compass walker (python back end), at a state off the initial one so that
every coordinate matters. Tolerance: 1e-7 · max(1, |entry|) — the differences' own error
(:mod:`porthamiltonian.simulation.differences`, h ≈ 6e-6 relative) is ~1e-10 here."""
from __future__ import annotations

import numpy as np
import pytest

from porthamiltonian import compile_model, io
from porthamiltonian.simulation.differences import jacobian

CASES = {"compass_gait": ("c", ["slope", "m_H", "a"]),
         "compass_walker": ("python", ["slope", "K", "l"])}


@pytest.fixture(scope="module", params=sorted(CASES))
def case(request):
    backend, names = CASES[request.param]
    model = compile_model(io.load(request.param), backend=backend, jac_p=names)
    rng = np.random.default_rng(3)
    x = model.initial_state() * (1.0 + 0.1 * rng.standard_normal(model.n_states))
    x += 0.01 * rng.standard_normal(model.n_states)
    return model, names, 0.3, x, model.param_defaults.copy()


def _by_differences(fun, model, names, t, x, p):
    """∂fun/∂[x, p_names] (fun(t, x, p): values) by central differences."""
    n, index = model.n_states, [model.param_names.index(name) for name in names]

    def at(z):
        q = p.copy()
        q[index] = z[n:]
        return fun(t, z[:n], q)

    return jacobian(at, np.concatenate([x, p[index]]), 1.0).value


@pytest.mark.parametrize("function, evaluated", [("guard_jac", "guards"),
                                                 ("outputs_jac", "outputs")])
def test_generated_jacobian_against_differences(case, function, evaluated):
    model, names, t, x, p = case
    n = model.n_states
    fun = model.functions.extra[function]
    exact = np.asarray(fun(t, model.augment(x), model.native_params(p)), dtype=float)
    values = getattr(model, evaluated)
    reference = _by_differences(values, model, names, t, x, p)
    assert exact.shape == (len(values(t, x, p)), n + len(names))
    assert np.any(exact[:, n:] != 0.0)                # the parameters do enter
    np.testing.assert_allclose(exact, reference, rtol=1e-7,
                               atol=1e-7 * max(1.0, float(np.max(np.abs(reference)))))

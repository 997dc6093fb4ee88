"""Exact derivatives of strides and gaits by the walker's parameters
(walker_library/core/gradients.py, walker_library/analyses/gradients.py), against independent
references:

* one stride (compass_gait: rigid, plastic impact; compass_walker: compliant contacts switched
  by events): ∂z'/∂p, ∂T/∂p, ∂L/∂p, ∂E_diss/∂p against Richardson-extrapolated central
  differences of strides (the events' timing moves with p);
* the simplest walker's gait (Garcia, Chatterjee, Ruina & Coleman 1998, J. Biomech. Eng. 120:
  281): its small-slope asymptotics θ* ∝ γ^(1/3) and a constant step period give
  d ln θ*/d ln γ → 1/3 and d ln v/d ln γ → 1/3 with corrections O(γ^(2/3)); dz*/dγ, d(speed)/dγ
  and the largest multiplier's derivative against differences of fixed points found to 1e-12;
* energy balance: a passive walker's cost of transport is sin γ at any periodic gait (the
  energy dissipated per step is the work of gravity W L sin γ), so dCoT/dγ = cos γ exactly.
"""
from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest
from test_variational_stride import COMPASS_FIXED_POINT

from porthamiltonian.backends import BACKEND_VARIABLE
from walker_library.analyses.gradients import GAIT_QUANTITIES, gait_gradient
from walker_library.analyses.monodromy import stride_jacobian
from walker_library.analyses.poincare import find_fixed_point
from walker_library.cli import main as walker_main
from walker_library.core.files import load_walker
from walker_library.core.gradients import stride_gradient


def _richardson(f, p0: float, h: float) -> np.ndarray:
    """(4 D(h) − D(2h))/3 of central differences D of ``f`` at ``p0`` (error O(h⁴))."""
    def central(step):
        return (f(p0 + step) - f(p0 - step)) / (2 * step)
    return (4 * central(h) - central(2 * h)) / 3


# (walker, {parameter: tolerance relative to the column's largest entry}, relative step, rtol of
# the differenced strides); measured: compass_gait 2e-10 to 4e-10; compass_walker 5e-8 (slope),
# 1.5e-7 (l), 1.1e-5 (K: the contact stiffness moves the stride little, and its column's
# integration error at the file's rtol 1e-9 is that large relative to it)
STRIDE_CASES = [
    ("compass_gait", {"slope": 1e-8, "m_H": 1e-8, "a": 1e-8}, 1e-4, None),
    ("compass_walker", {"slope": 1e-6, "l": 1e-6, "K": 3e-5}, 2e-5, 1e-12),
]


@pytest.mark.parametrize("name, tolerances, step, rtol", STRIDE_CASES,
                         ids=[c[0] for c in STRIDE_CASES])
def test_stride_gradient_against_extrapolated_differences(name, tolerances, step, rtol):
    """One stride from the gait's section state: the exact columns (z', duration, step length,
    energy dissipated by each parameter) against Richardson-extrapolated central differences of
    strides (relative step ``step``; the compliant walker's at rtol 1e-12). The walkers' back
    end is "auto": C here, numba in the CI's numba pass (``PORTHAMILTONIAN_BACKEND=numba``,
    asserted), whose loops then integrate the parameter columns (compass_gait measured there:
    the same tolerances pass)."""
    walker = load_walker(name)
    forced = os.environ.get(BACKEND_VARIABLE)
    assert forced not in ("c", "numba") or walker.model.backend == forced
    z = (np.array(COMPASS_FIXED_POINT) if name == "compass_walker"
         else find_fixed_point(walker, walker.initial_guess(), tol=1e-12).z)
    names = list(tolerances)
    g = stride_gradient(walker, z, names)
    assert not g.fell and g.names == tuple(names)
    k = len(z)
    tight = walker if rtol is None else walker.with_options(rtol=rtol, atol=rtol * 1e-2)

    def values(w) -> np.ndarray:
        s = w.stride(z)
        return np.concatenate([s.z_next, [s.duration, s.step_length, s.energy_dissipated]])

    for j, p in enumerate(names):
        p0 = walker.parameters[p]
        ref = _richardson(lambda v, p=p: values(tight.with_parameters(**{p: v})), p0,
                          step * abs(p0))
        exact = np.concatenate([g.dz[:, k + j], [g.d_duration[k + j], g.d_step_length[k + j],
                                                 g.d_energy_dissipated[k + j]]])
        assert np.max(np.abs(exact - ref)) < tolerances[p] * np.max(np.abs(ref)), p


SLOPES = (0.009, 0.002)


@pytest.fixture(scope="module")
def simplest():
    """The simplest walker and its gait's gradients by the slope at γ = 0.009 and 0.002 (the
    fixed points found to 1e-12 first; the second from the first scaled by the asymptotics:
    θ, θ̇ ∝ γ^(1/3), φ̇ ∝ γ)."""
    walker = load_walker("simplest_walker")
    z = find_fixed_point(walker, walker.initial_guess(), tol=1e-12).z
    out = {}
    for gamma in SLOPES:
        w = walker.with_parameters(slope=gamma)
        r = gamma / SLOPES[0]
        zg = find_fixed_point(w, z * np.array([r ** (1 / 3)] * 2 + [r]), tol=1e-12)
        assert zg.converged
        out[gamma] = (w, gait_gradient(w, zg.z, ["slope"]))
    return out


def test_simplest_walker_small_slope_asymptotics(simplest):
    """d ln θ*/d ln γ and d ln v/d ln γ from the exact derivatives approach 1/3, their deviation
    falling as γ^(2/3), the next term of the series (ratio (0.009/0.002)^(2/3) = 2.73 within
    5 %; measured: deviations −5.4e-3, −2.0e-3 for θ*; −0.022, −0.0081 for v; ratios 2.7)."""
    dev_theta, dev_speed = [], []
    for gamma in SLOPES:
        g = simplest[gamma][1]
        assert not g.fell and g.residual < 1e-11
        coordinate = next(iter(g.fixed_point_gradient))      # θ (the stance angle)
        theta, d_theta = g.fixed_point[0], g.fixed_point_gradient[coordinate]["slope"]
        dev_theta.append(gamma * d_theta / theta - 1 / 3)
        dev_speed.append(gamma * g.gradients["speed"]["slope"] / g.values["speed"] - 1 / 3)
    ratio = (SLOPES[0] / SLOPES[1]) ** (2 / 3)
    for dev in (dev_theta, dev_speed):
        assert abs(dev[1]) < abs(dev[0]) < 0.03
        assert dev[0] / dev[1] == pytest.approx(ratio, rel=0.05)


def test_simplest_walker_against_differences_of_fixed_points(simplest):
    """At γ = 0.009: dz*/dγ, d(speed)/dγ and d(step period)/dγ against Richardson-extrapolated
    central differences of fixed points found to 1e-12 (step 1e-3 γ) to 1e-7 relative
    (measured 2e-10 to 1.2e-9), and the largest multiplier's derivative within its reported
    error bound plus the differences' own error (1e-5 relative; measured: off by 1.7e-6, the
    bound 2.3e-5)."""
    gamma = SLOPES[0]
    w, g = simplest[gamma]
    z0 = np.array(g.fixed_point)

    def at(v: float) -> np.ndarray:
        wv = w.with_parameters(slope=v)
        fp = find_fixed_point(wv, z0, tol=1e-12)
        assert fp.converged
        s = wv.stride(fp.z)
        rho = max(abs(np.linalg.eigvals(stride_jacobian(wv, fp.z).matrix)))
        return np.concatenate([fp.z, [s.step_length / s.duration, s.duration, rho]])

    ref = _richardson(at, gamma, 1e-3 * gamma)
    exact = np.array([*(d["slope"] for d in g.fixed_point_gradient.values()),
                      g.gradients["speed"]["slope"], g.gradients["step_period"]["slope"]])
    np.testing.assert_allclose(exact, ref[:-1], rtol=1e-7)
    bound = g.errors["max_multiplier_modulus"]["slope"]
    d_rho = g.gradients["max_multiplier_modulus"]["slope"]
    assert abs(d_rho - ref[-1]) <= bound + 1e-5 * abs(ref[-1])


def test_cost_of_transport_is_the_slope_sine(simplest):
    """Energy balance at a periodic gait of a passive walker: CoT = sin γ to 1e-9 and its exact
    derivative cos γ to 1e-8 (measured 3e-12 and 1.3e-10 at γ = 0.009); the energy per step
    E = W L sin γ (measured 3e-10 relative)."""
    for gamma in SLOPES:
        w, g = simplest[gamma]
        assert g.values["cost_of_transport"] == pytest.approx(math.sin(gamma), abs=1e-9)
        assert g.gradients["cost_of_transport"]["slope"] == pytest.approx(math.cos(gamma),
                                                                          abs=1e-8)
        E, L = g.values["energy_dissipated_per_step"], g.values["step_length"]
        assert E == pytest.approx(w.weight * L * math.sin(gamma), rel=1e-8)


def test_gait_gradient_cli(capsys):
    """``walker gait simplest_walker --gradient slope --json``: the gradients of every gait
    quantity by name, equal to the API's; an unknown or mode parameter is ``error: ...`` with
    status 2."""
    assert walker_main(["gait", "simplest_walker", "--gradient", "slope", "--json",
                        "--quiet"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["gradients"]) == set(GAIT_QUANTITIES)
    assert set(out["gradients"]["speed"]) == {"slope"}
    assert set(out["gradient_errors"]) == set(GAIT_QUANTITIES)
    assert math.isfinite(out["gradients"]["max_multiplier_modulus"]["slope"])
    for bad in ("nope", "stance_x"):
        assert walker_main(["gait", "simplest_walker", "--gradient", bad, "--quiet"]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error:") and bad in err and "Traceback" not in err


@pytest.mark.parametrize("seed", range(4))
def test_spectrum_cluster_derivatives(seed):
    """The smooth description of ρ (gradients._spectrum) on A(p) = A₀ + p D: the cluster's sum
    and product and the rest's largest modulus and their derivatives against central
    differences (step 1e-6) of the eigenvalues of A₀ ± εD, to 1e-8 (measured ≤ 4e-10),
    random A₀ of sizes 2 to 4; and at a defective double eigenvalue (a Jordan block, where the
    eigenvectors do not exist and |λ| has a branch point) the sum and product are still
    differentiated to 1e-8."""
    from walker_library.analyses.gradients import _spectrum

    def ordered(A):
        lam, V = np.linalg.eig(A)
        o = sorted(range(len(lam)), key=lambda i: (-abs(lam[i]), -lam[i].imag))
        return lam[o], V[:, o]

    rng = np.random.default_rng(seed)
    k = 2 + seed
    A = rng.normal(size=(k, k)) * 0.3
    if seed == 3:
        A = np.array([[0.3, 1.0, 0.1, 0.0], [0.0, 0.3, 0.2, 0.1], [0, 0, 0.05, 0.0],
                      [0, 0, 0.1, -0.02]])
        k = 4
    D = rng.normal(size=(k, k))
    lam, V = ordered(A)
    sp = _spectrum(A, lam, V, [(D, D)], ["p"])
    n = sp["size"]
    eps = 1e-6
    (lp, _), (lm, _) = ordered(A + eps * D), ordered(A - eps * D)
    pair = (lambda l: (l[0] + l[1], l[0] * l[1])) if n == 2 else (lambda l: (2 * l[0], l[0] ** 2))
    assert sp["cluster_sum"] == pytest.approx(pair(lam)[0].real, abs=1e-12)
    assert sp["cluster_product"] == pytest.approx(pair(lam)[1].real, abs=1e-12)
    for key, i in (("cluster_sum", 0), ("cluster_product", 1)):
        fd = (pair(lp)[i] - pair(lm)[i]).real / (2 * eps)
        assert sp["gradients"][key]["p"] == pytest.approx(fd, abs=1e-8)
    if k > n and seed < 3:
        fd = (abs(lp[n]) - abs(lm[n])) / (2 * eps)
        assert sp["gradients"]["rest_modulus"]["p"] == pytest.approx(fd, abs=1e-8)

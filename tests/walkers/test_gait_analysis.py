"""The gait analysis tools on bad input and their machine-readable results.

* a walker that falls gives a result with the step at which it fell (never an exception);
* where only unstable orbits exist the result says so, with them: the simplest walker at
  γ = 0.0186 lies in its chaotic range (Garcia et al. 1998, J. Biomech. Eng. 120:281, §4 and
  Fig. 5: period doublings from γ ≈ 0.015, chaos up to γ ≈ 0.019);
* no orbit from a guess, and no fall, is "no_fixed_point" with the last iterate;
* parameters out of range, or unknown, raise a ParameterValueError naming the parameter;
* the stride map and the Floquet multipliers in the thesis's coordinates (θ̇, φ, φ̇) agree with
  the model's own (similarity-invariant multipliers).
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from porthamiltonian.errors import ParameterValueError
from walker_library import (
    analyze_gait,
    compass_gait,
    find_fixed_point,
    floquet,
    rimless_wheel,
    simplest_walker,
    stride_map,
)
from walker_library.analyses.poincare import jacobian


@pytest.fixture(scope="module")
def simplest():
    return simplest_walker()


def test_walker_on_level_ground_falls_and_reports_the_step(simplest):
    """γ = 0 from Garcia's rough guess, without the continuation from the file's gait: the
    walker loses energy at each heel strike and falls (the hip drops below half the leg length)
    during step 2; the result says so, with the steps taken and the last section state; no gait
    fields are invented (null), the metrics included."""
    r = analyze_gait(simplest.with_parameters(slope=0.0), continuation=False)
    assert r.status == "fell" and r.outcome == "fell"
    assert r.fell_at_step == 2 and r.fall_reason == "fall"
    assert r.period_steps == 0 and r.floquet_multipliers == [] and r.orbits == []
    assert set(r.fixed_point) >= {"theta", "theta_dot", "phi", "phi_dot"}
    assert all(v is None for v in r.fixed_point.values())
    assert r.last_iterate["theta"] > 0
    d = json.loads(r.to_json())
    assert d["status"] == "fell" and d["fell_at_step"] == 2
    assert d["steps"][-1]["status"] == "fell"
    assert d["step_period"] is None and d["speed"] is None


def test_only_unstable_orbits_are_reported_as_such(simplest):
    """γ = 0.0186 (chaotic range), started on the attractor (a state reached by continuing the
    period-2/4 gaits from γ = 0.0155), without the continuation from the file's gait: Newton
    finds the unstable period-1 orbit, 200 iterated steps repeat with no period ≤ 8 and do not
    fall. Outcome "unstable_orbits_only" (status "periodic", stable false): the orbit with its
    period and multipliers at the top level and in ``orbits``, and the top-level step period is
    that orbit's (one stride from its fixed point), not the last iterate's."""
    w = simplest.with_parameters(slope=0.0186)
    guess = w.from_thesis([-0.24837989, 2 * 0.25775171, -0.03227829])
    r = analyze_gait(w, guess, continuation=False)
    assert r.status == "periodic" and r.outcome == "unstable_orbits_only", r.message
    assert r.stable is False and r.stability_certain and r.period_steps == 1
    assert r.fell_at_step is None and r.newton["converged"]
    assert len(r.orbits) == 1 and r.orbits[0]["period_steps"] == 1
    assert r.orbits[0]["max_multiplier"] == pytest.approx(max(abs(m) for m in
                                                              r.floquet_multipliers))
    assert max(abs(m) for m in r.floquet_multipliers) > 1
    assert r.unstable_fixed_point is not None
    z = np.array([r.fixed_point[k] for k in w.section])
    assert r.metrics.step_period == pytest.approx(w.stride(z).duration, rel=1e-12)
    assert "only unstable orbits" in r.message
    d = json.loads(r.to_json())
    assert d["status"] == "periodic" and d["stable"] is False
    assert d["orbits"][0]["floquet_multipliers"][0].keys() == {"re", "im"}


def test_no_periodic_orbit_from_a_guess_reports_the_last_iterate(simplest):
    """The same chaotic state with Newton cut to one iteration: no orbit is found, the walker
    does not fall over 200 steps: "no_fixed_point" with the last iterate by name."""
    w = simplest.with_parameters(slope=0.0186)
    guess = w.from_thesis([-0.24837989, 2 * 0.25775171, -0.03227829])
    r = analyze_gait(w, guess, continuation=False, max_iter=1)
    assert r.status == "no_fixed_point" and r.outcome == "no_periodic_orbit", r.message
    assert r.period_steps == 0 and r.fell_at_step is None and r.orbits == []
    assert r.last_iterate is not None and 0.2 < r.last_iterate["theta"] < 0.3


def test_newton_from_a_hopeless_guess_returns_its_last_iterate(simplest):
    """A guess from which the walker falls at once: Newton reports non-convergence, the guess as
    its last iterate and fell = True, without raising."""
    fp = find_fixed_point(simplest, simplest.from_thesis([-0.05, 1.0, 0.0]))
    assert not fp.converged and fp.fell
    np.testing.assert_array_equal(fp.z, simplest.from_thesis([-0.05, 1.0, 0.0]))
    assert "falls" in fp.message


@pytest.mark.parametrize("builder,values,name", [
    (simplest_walker, {"slope": 2.0}, "slope"),
    (simplest_walker, {"beta": 0.0}, "beta"),
    (simplest_walker, {"l": -1.0}, "l"),
    (compass_gait, {"m_H": -10.0}, "m_H"),
    (compass_gait, {"slope": math.nan}, "slope"),
    (rimless_wheel, {"n_spokes": 2.0}, "n_spokes"),
    (rimless_wheel, {"n_spokes": 7.5}, "n_spokes"),
])
def test_parameters_out_of_range_raise(builder, values, name):
    """Out-of-range or non-finite parameters raise ParameterValueError naming the parameter and
    its range, at build time and through with_parameters."""
    with pytest.raises(ParameterValueError, match=name):
        builder(**values)
    with pytest.raises(ParameterValueError, match=name):
        builder().with_parameters(**values)


def test_unknown_parameter_raises(simplest):
    with pytest.raises(ParameterValueError, match="unknown parameter.*gamma"):
        simplest.with_parameters(gamma=0.01)
    with pytest.raises(ParameterValueError, match="stance_x"):       # mode parameters are internal
        simplest.with_parameters(stance_x=1.0)


def test_thesis_coordinates_give_the_same_map_and_multipliers(simplest):
    """S in the thesis's section coordinates (θ̇, φ, φ̇) is the model's S conjugated by the linear
    change of coordinates: the images agree to 1e-12; the eigenvalues of central-difference
    Jacobians (h = 1e-5 in either coordinates, so different perturbations) to 2e-5 (their O(h²)
    truncation), and of the transformed Richardson Jacobian to 1e-9."""
    fp = find_fixed_point(simplest)
    z = fp.z + np.array([1e-3, -2e-3, 1e-3])
    w = simplest.to_thesis(z)
    np.testing.assert_allclose(stride_map(simplest, w, coordinates="thesis"),
                               simplest.to_thesis(stride_map(simplest, z)), atol=1e-12)
    J_model = jacobian(simplest, fp.z, step=1e-5)
    J_thesis = jacobian(simplest, simplest.to_thesis(fp.z), step=1e-5, coordinates="thesis")
    ev = lambda J: np.sort_complex(np.linalg.eigvals(J))
    np.testing.assert_allclose(ev(J_model), ev(J_thesis), atol=2e-5)
    fl = floquet(simplest, fp.z)
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(fl.jacobian_thesis)),
                               np.sort_complex(fl.multipliers), atol=1e-9)


def test_gait_result_json_has_the_named_si_fields(simplest):
    """The JSON of a gait result: status, period_steps (int), fixed_point by name with theta,
    theta_dot, phi, phi_dot, floquet_multipliers as {re, im}, the metrics as numbers, and no NaN
    (non-finite values are null)."""
    r = analyze_gait(rimless_wheel())
    text = r.to_json()
    d = json.loads(text)
    assert "NaN" not in text
    assert d["status"] == "periodic" and isinstance(d["period_steps"], int)
    assert all(set(m) == {"re", "im"} for m in d["floquet_multipliers"])
    for key in ("step_period", "step_length", "speed", "energy_dissipated_per_step",
                "cost_of_transport", "max_theta"):
        assert isinstance(d[key], float), key
    assert d["max_phi"] is None                                       # a wheel has no φ
    assert d["fixed_point"]["walker.v.stance"] > 0

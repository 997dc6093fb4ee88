"""The compliant-contact walker tends to the rigid-impact walker as the contact stiffens.

Same mechanism on both sides (thesis masses: hip 3 kg, legs 0.01 kg at mid-leg, feet 0.1 kg at
the leg ends, l = 0.7 m, γ = 0.009): ``compass_walker`` with point feet (R = 1 µm) and a
Hunt–Crossley contact of stiffness K and damping λ = 31.6 s/m · K (a plastic impact at every K),
against ``rigid_compass_walker`` (plastic impact map, the same point feet). Measured errors of the
compliant fixed point against the rigid one (θ at heel strike, energy dissipated per step, step
length; the step period converges more slowly, by the contact's settling time):

    K (N/m)   |Δθ| (rad)   ΔE/E      ΔL/L      ΔT/T
    1e5       1.7e-3       1.4e-2    1.4e-2    3.2e-3
    1e6       6.3e-4       2.6e-3    2.6e-3    3.3e-3
    1e7       2.4e-4       1.2e-3    1.2e-3    2.5e-3
    1e8       7.5e-6       4.4e-5    4.5e-5    1.2e-3   (not run here: 10 s)

The rigid limit also happens to match the thesis's Table 2.3 closely (0.267 m/s, 0.077 J per step
against 0.274 m/s, 0.08 J): the arc feet (R = 5 cm) of the nominal walker add ≈ 14 % of speed.
"""
from __future__ import annotations

import numpy as np
import pytest

from walker_library import analyze_gait, compass_walker
from walker_library.analyses.poincare import find_fixed_point
from walker_library.core.files import rigid_compass_walker


@pytest.fixture(scope="module")
def rigid():
    w = rigid_compass_walker()
    g = analyze_gait(w)
    assert g.status == "periodic" and g.stable
    return g


@pytest.fixture(scope="module")
def compliant_series(rigid):
    base = compass_walker()
    out = {}
    for K in (1e5, 1e6, 1e7):
        w = base.with_parameters(R=1e-6, K=K, lam=31.6 * K, s_fric=5000.0,
                                 theta0=rigid.fixed_point["theta"], theta_dot0=-0.80, phi_dot0=0.0)
        fp = find_fixed_point(w, w.initial_guess(), tol=1e-8)
        assert fp.converged, fp.message
        s = w.walk(fp.z, 1)[0]
        out[K] = {"theta": w.section_state(fp.z)["theta"], "E": s.energy_dissipated,
                  "L": s.step_length, "T": s.duration}
    return out


def test_rigid_compass_walker_gait(rigid):
    m = rigid.metrics
    assert m.energy_dissipated_per_step == pytest.approx(m.potential_released_per_step, rel=1e-9)
    assert m.cost_of_transport == pytest.approx(np.sin(0.009), rel=1e-8)
    assert m.speed == pytest.approx(0.274, rel=0.05)          # thesis Table 2.3 (arc feet)


def test_compliant_contact_converges_to_the_rigid_impact(rigid, compliant_series):
    ref = {"theta": rigid.fixed_point["theta"], "E": rigid.metrics.energy_dissipated_per_step,
           "L": rigid.metrics.step_length, "T": rigid.metrics.step_period}
    err = {K: {k: abs(v[k] - ref[k]) / (1.0 if k == "theta" else ref[k]) for k in v}
           for K, v in compliant_series.items()}
    for k in ("theta", "E", "L"):                     # monotone convergence as K grows
        assert err[1e5][k] > err[1e6][k] > err[1e7][k], (k, err)
    assert err[1e7]["theta"] < 5e-4
    assert err[1e7]["E"] < 2.5e-3 and err[1e7]["L"] < 2.5e-3
    assert all(e["T"] < 4e-3 for e in err.values())

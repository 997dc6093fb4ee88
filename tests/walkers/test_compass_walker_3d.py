"""The 3D compass walker (models/compass_walker_3d.toml): the thesis's nominal walker with a pelvis
of width w, spherical feet, the 3D Hunt–Crossley contact and vector SCVS friction.

With w = 0 and a sagittal start the lateral coordinates stay 0 and the gait is compass_walker's
(an independent model file: planar multibody, planar contact and friction). The lateral
multipliers of that gait: one unstable (measured −32.79, the sideways fall: Kuo 1999, IJRR 18,
"Stabilization of lateral motion in passive dynamic walking": the straight-legged 3D walker is
laterally unstable without control; we agree), one ≈ −1.0026 (the heading: yaw is neutral up to
the slope's gravity component, and the section's mirror relabelling flips its sign every step).
"""
from __future__ import annotations

import numpy as np
import pytest

from walker_library import load_walker, walk
from walker_library.poincare import find_fixed_point, floquet

TIGHT = {"rtol": 1e-12, "atol": 1e-13, "gait_tolerance": 1e-11}
LATERAL = ["walker.q.pelvis.x", "walker.q.pelvis.z", "walker.v.pelvis.x", "walker.v.pelvis.z",
           "walker.v.hip_joint.y"]


@pytest.fixture(scope="module")
def pair(isolated_cache):
    planar = load_walker("compass_walker").with_options(**TIGHT)
    spatial = load_walker("compass_walker_3d", {"w": 0.0}).with_options(**TIGHT)
    fp2 = find_fixed_point(planar, tol=1e-11)
    return planar, spatial, fp2


def test_sections_share_the_planar_coordinates(pair):
    planar, spatial, _ = pair
    assert list(spatial.section) == list(planar.section) + LATERAL


def test_sagittal_gait_equals_compass_walker(pair):
    """From compass_walker's fixed point (lateral coordinates 0) Newton converges in ≤ 8
    iterations (measured 2) to the same fixed point (measured 1.1e-11 at rtol 1e-12; asserted
    1e-8), with the lateral coordinates exactly 0. The Jacobian of the stride map is block
    diagonal (sagittal/lateral, exactly 0 off the blocks by symmetry); its sagittal block equals
    compass_walker's to 1e-6 (measured 1.8e-7) and so do the multipliers to 1e-5 (measured
    3.5e-6; their own finite-difference error estimate is 4e-4, equal in both)."""
    planar, spatial, fp2 = pair
    assert fp2.converged
    fp3 = find_fixed_point(spatial, np.concatenate([fp2.z, np.zeros(5)]), tol=1e-11)
    assert fp3.converged and fp3.iterations <= 8
    assert np.max(np.abs(fp3.z[:6] - fp2.z)) < 1e-8
    assert np.all(fp3.z[6:] == 0.0)
    f2 = floquet(planar, fp2.z, period=1, step=1e-4)
    f3 = floquet(spatial, fp3.z, period=1, step=1e-4)
    J = f3.jacobian
    assert np.all(J[6:, :6] == 0.0) and np.all(J[:6, 6:] == 0.0)
    assert np.max(np.abs(J[:6, :6] - f2.jacobian)) < 1e-6
    sagittal = np.sort_complex(np.linalg.eigvals(J[:6, :6]))
    assert np.max(np.abs(sagittal - np.sort_complex(f2.multipliers))) < 1e-5
    lateral = sorted(np.linalg.eigvals(J[6:, 6:]), key=abs, reverse=True)
    assert lateral[0].real == pytest.approx(-32.794, rel=1e-3) and abs(lateral[0].imag) < 1e-9
    assert lateral[1].real == pytest.approx(-1.0026, abs=1e-3)
    assert all(abs(m) < 0.05 for m in lateral[2:])


def test_ledger_closes_over_20_steps_and_a_sideways_push_falls(pair):
    """At the file's own tolerances: 20 steps from the fixed point, ledger residual < 1e-7 J (the
    energy in play per step is 0.09 J), dissipated = potential released; a lateral push
    (roll rate 0.05 rad/s) grows by the unstable lateral multiplier into a sideways fall: a
    stride with status "fell", not an exception."""
    _, _, fp2 = pair
    spatial = load_walker("compass_walker_3d", {"w": 0.0})
    fp = find_fixed_point(spatial, np.concatenate([fp2.z, np.zeros(5)]))
    res = walk(spatial, fp.z, 20)
    assert res.steps_taken == 20 and not res.fell
    assert res.max_energy_residual < 1e-7
    assert res.energy_dissipated == pytest.approx(res.potential_released, rel=1e-4)
    pushed = fp.z.copy()
    pushed[spatial.section.index("walker.v.pelvis.x")] = 0.05
    strides = spatial.walk(pushed, 10)
    assert strides[-1].fell and strides[-1].reason == "fall" and len(strides) <= 6

"""The compliant-leg walker in 3D (models/compliant_leg_walker_3d.toml): compass_walker_3d with each
foot on a prismatic joint along its leg and compliant_leg_walker's spring–damper (K_leg = 6000
N/m, α = 0.15).

With w = 0 and a sagittal start its gait is compliant_leg_walker_sole_friction's (an independent
file: planar multibody, planar contact and friction at the sole point, as this file's), and it is laterally unstable as the rigid-leg 3D walker
is (Kuo 1999, IJRR 18, "Stabilization of lateral motion in passive dynamic walking": the
straight-legged 3D passive walker is laterally unstable without control); compliance in the legs
does not change that (sideways-fall multiplier −36.92 against −33.39 with rigid legs). The
`compliance_3d` study (walker_library.report.studies) asks the thesis's Figs. 3.3–3.6 question in 3D;
its reduced grid is checked here, the full study is `walker reproduce compliance_3d`
(REPRODUCTION.md).

Floquet multipliers are exact (:func:`~walker_library.analyses.monodromy.floquet`'s default). The pins
changed when the legs got compliant_leg_walker's rod inertia I_leg = m_leg l²/12 (they were point
masses) and the multipliers became exact (they were central differences at a fixed step of 1e-4):
the sideways-fall multiplier from −36.311 to −36.923 — all of it the inertia: with I_leg = 0 the
exact Jacobian gives −36.3111, the old value.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from walker_library import load_walker, walk
from walker_library.analyses.monodromy import floquet
from walker_library.analyses.poincare import find_fixed_point
from walker_library.report.studies import run_studies

LATERAL = ["walker.q.pelvis.x", "walker.q.pelvis.z", "walker.v.pelvis.x", "walker.v.pelvis.z",
           "walker.v.hip_joint.y"]


@pytest.fixture(scope="module")
def pair(isolated_cache):
    planar = load_walker("compliant_leg_walker_sole_friction")
    spatial = load_walker("compliant_leg_walker_3d")
    # Newton to 1e-9, the stride maps' integration noise at the files' rtol 1e-9 (the two files'
    # maps differ by 1.9e-9 at fp2): at 1e-10 the forward-difference Newton creeps on C and
    # stalls on numba (the planar one at 1.27e-10 on numba after the legs became rods)
    fp2 = find_fixed_point(planar, tol=1e-9)
    assert fp2.converged
    fp3 = find_fixed_point(spatial, np.concatenate([fp2.z, np.zeros(5)]), tol=1e-9)
    return planar, spatial, fp2, fp3


def test_sagittal_gait_equals_compliant_leg_walker(pair):
    """Same section coordinates plus the lateral ones; from the 2D fixed point Newton converges in
    ≤ 8 iterations to the same fixed point, to 1e-8, lateral coordinates exactly 0 (Newton
    tolerance 1e-9 at the files' rtol 1e-9: the 2D fixed point already satisfies the 3D stride
    map to 1.9e-9, the two models' integration error; at a tolerance of 1e-10 Newton took 7
    iterations on C and did not converge on numba). Exact Jacobians: the 3D one is block diagonal (exactly 0 off the blocks,
    by symmetry: measured exactly 0.0), its sagittal block is the 2D walker's to 1e-5 of its
    largest entry (measured 1.1e-3 on entries up to 433: 2.5e-6 — the stiff legs' directions) and
    all ten sagittal multipliers are the 2D walker's to 1e-6 (measured 4.3e-8; with central
    differences at a fixed step the four largest agreed to 6e-5 only, asserted 2e-4). Lateral
    multipliers pinned to 1e-4 (error bound 2.5e-6) and 1e-5: −36.92335, −0.997447, −0.006002, 0,
    0 (−36.311 before the legs' inertia; −33.386 with rigid legs): stiff-legged or compliant,
    the 3D passive walker falls sideways."""
    planar, spatial, fp2, fp3 = pair
    assert list(spatial.section) == list(planar.section) + LATERAL
    assert fp3.converged and fp3.iterations <= 8
    assert np.max(np.abs(fp3.z[:10] - fp2.z)) < 1e-8
    assert np.all(fp3.z[10:] == 0.0)
    f3 = floquet(spatial, fp3.z, period=1)
    f2 = floquet(planar, fp2.z, period=1)
    assert f2.method == f3.method == "variational"
    J = f3.jacobian
    assert np.all(J[10:, :10] == 0.0) and np.all(J[:10, 10:] == 0.0)
    assert np.max(np.abs(J[:10, :10] - f2.jacobian)) < 1e-5 * np.max(np.abs(f2.jacobian))
    sagittal = sorted(np.linalg.eigvals(J[:10, :10]), key=lambda m: (-abs(m), m.imag))
    expected = sorted(f2.multipliers, key=lambda m: (-abs(m), m.imag))
    assert np.max(np.abs(np.array(sagittal) - np.array(expected))) < 1e-6
    lateral = np.array(sorted(np.linalg.eigvals(J[10:, 10:]), key=abs, reverse=True))
    assert np.all(np.abs(lateral.imag) < 1e-9)
    assert lateral[0].real == pytest.approx(-36.92335, abs=1e-4)
    assert lateral[1:].real == pytest.approx([-0.997447, -0.006002, 0.0, 0.0], abs=1e-5)
    assert f3.errors[0] < 1e-4 and f3.certain and not f3.stable


def test_ledger_closes_over_20_steps_and_a_roll_push_falls(pair):
    """20 steps from the fixed point at the file's tolerances: ledger residual < 1e-7 J (measured
    2.7e-10; 1.98 J dissipated), dissipated = potential released (1e-6 relative: a periodic
    gait; measured 3e-8). A roll-rate push of 0.05 rad/s falls sideways within 6 steps (measured
    4): a stride with status "fell", not an exception."""
    _, spatial, _, fp3 = pair
    res = walk(spatial, fp3.z, 20)
    assert res.steps_taken == 20 and not res.fell
    assert res.max_energy_residual < 1e-7
    assert res.energy_dissipated == pytest.approx(res.potential_released, rel=1e-6)
    pushed = fp3.z.copy()
    pushed[spatial.section.index("walker.v.pelvis.x")] = 0.05
    strides = spatial.walk(pushed, 10)
    assert strides[-1].fell and strides[-1].reason == "fall" and len(strides) <= 6


@pytest.mark.study      # run by .ci/run's numba pass (tests/conftest.py), not by the README's
def test_compliance_3d_study_reduced_grid(pair, tmp_path):
    """`walker reproduce compliance_3d --quick` (K_leg = 6000 N/m and the rigid legs; bisection to
    0.5 mm and 1e-3, pushes survived over 2 steps). At w = 0 a step-down keeps the motion
    sagittal, so the largest step-downs are the 2D walkers' (REPRODUCTION.md: 1.1 mm compliant,
    2.5 mm rigid, on a 0.1 mm grid, point-mass legs): asserted to the bisection's 0.5 mm. Pinned
    (regression, to the bisection's resolution; exact multipliers to 1e-4): compliant 0.94 mm,
    0.430 rad/s roll rate, 3.9 mm/s lateral hip velocity, |λ| 36.923; rigid 2.5 mm, 0.124 rad/s,
    4.9 mm/s, |λ| 33.386. Both laterally unstable. Before the legs' rod inertia (and with
    multipliers by central differences at a fixed step): roll rate 0.444 and 0.126 rad/s, |λ|
    36.311 and 32.794; the step-downs and hip-velocity pushes did not change."""
    summary = run_studies(["compliance_3d"], tmp_path, quick=True, serial=True,
                          progress="none", log=lambda msg: None)["compliance_3d"]
    (row,) = summary["table"]
    rigid = summary["rigid"]
    assert row["status"] == "ok" and rigid["status"] == "ok"
    assert row["max_multiplier"] == pytest.approx(36.92335, abs=1e-4)
    assert rigid["max_multiplier"] == pytest.approx(33.38619, abs=1e-4)
    assert abs(row["max_step_down"] - 1.1e-3) <= 5e-4
    assert abs(rigid["max_step_down"] - 2.5e-3) <= 5e-4
    assert row["max_step_down"] == pytest.approx(0.9375e-3, abs=1e-9)
    assert row["max_roll_rate_push"] == pytest.approx(0.4297, abs=1e-3)
    assert row["max_hip_vy_push"] == pytest.approx(0.0039, abs=1e-3)
    assert rigid["max_roll_rate_push"] == pytest.approx(0.1240, abs=1e-3)
    assert rigid["max_hip_vy_push"] == pytest.approx(0.0049, abs=1e-3)
    saved = json.loads((tmp_path / "compliance_3d" / "summary.json").read_text())
    assert saved["rows"][2]["ours"] is True
    assert (tmp_path / "compliance_3d" / "fig_3d_robustness_over_K.png").stat().st_size > 1000

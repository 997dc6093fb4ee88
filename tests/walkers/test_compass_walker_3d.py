"""The 3D compass walker (models/compass_walker_3d.toml): the thesis's nominal walker with a pelvis
of width w, spherical feet, the 3D Hunt–Crossley contact and vector SCVS friction.

With w = 0 and a sagittal start the lateral coordinates stay 0 and the gait is compass_walker's
(an independent model file: planar multibody, planar contact and friction). The lateral
multipliers of that gait: one unstable (measured −32.79, the sideways fall: Kuo 1999, IJRR 18,
"Stabilization of lateral motion in passive dynamic walking": the straight-legged 3D walker is
laterally unstable without control; we agree), one ≈ −1.0026 (the heading: yaw is neutral up to
the slope's gravity component, and the section's mirror relabelling flips its sign every step).

With w > 0 the gait, continued in w from w = 0 (0.01, 0.02 m), leaves the sagittal plane: the
fixed point yaws (0.035 rad at w = 0.01) and sways (lateral hip velocity 0.038 m/s), the Jacobian
couples the blocks, and the walker stays laterally unstable (the sideways-fall multiplier −32.5,
−31.6): Kuo's result holds at every width tried. The heading multiplier moves inside the unit
circle (−0.997, −0.980). `walker gait` reports the unstable orbit with its multipliers, and the
walker's own motion from it — or from a roll push — falls sideways as a result.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from walker_library import load_walker, walk
from walker_library.cli import main
from walker_library.monodromy import floquet
from walker_library.poincare import find_fixed_point

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


# measured at the file's tolerances (rtol 1e-9), multipliers by central differences at 1e-4:
# (w, yaw*, hip_vy*, sideways-fall multiplier, heading multiplier, the sagittal complex pair)
CONTINUED = [(0.01, 0.034933, 0.038059, -32.5025, -0.99716, complex(-0.09431, 0.26433)),
             (0.02, 0.069543, 0.075699, -31.6382, -0.98048, complex(-0.09817, 0.27058))]


@pytest.fixture(scope="module")
def continued(pair):
    """The gait continued in w from w = 0 (the 2D fixed point as the first guess): {w: (walker,
    fixed point, Floquet result)}."""
    _, _, fp2 = pair
    base, z, out = load_walker("compass_walker_3d"), np.concatenate([fp2.z, np.zeros(5)]), {}
    for w, *_ in CONTINUED:
        walker = base.with_parameters(w=w)
        fp = find_fixed_point(walker, z, tol=1e-10)
        assert fp.converged and fp.iterations <= 8
        z = fp.z
        out[w] = (walker, z, floquet(walker, z, period=1, step=1e-4))
    return out


@pytest.mark.parametrize("case", CONTINUED, ids=lambda c: f"w={c[0]}")
def test_wide_pelvis_gait_is_laterally_unstable(continued, case):
    """w > 0: the fixed point leaves the sagittal plane (yaw and lateral hip velocity pinned to
    1e-5; both grow linearly in w, checked to 1 %), the blocks couple, and the multipliers
    (pinned: the unstable one to 1e-3 relative, the others to 1e-3) are, by their eigenvectors'
    share in the lateral coordinates: one unstable lateral (the sideways fall, > 0.95 lateral: Kuo
    1999 — the straight-legged 3D passive walker is laterally unstable without control; we
    agree), the heading (lateral, |λ| just below 1), the sagittal complex pair as compass_walker's
    (−0.0933 ± 0.2627i at w = 0), and every other one inside the unit circle."""
    w, yaw, hip_vy, fall, heading, pair_ = case
    walker, z, fl = continued[w]
    named = dict(zip(walker.section, z))
    assert named["walker.q.pelvis.z"] == pytest.approx(yaw, abs=1e-5)
    assert named["walker.v.hip_joint.y"] == pytest.approx(hip_vy, abs=1e-5)
    assert yaw / w == pytest.approx(CONTINUED[0][1] / CONTINUED[0][0], rel=1e-2)
    assert np.max(np.abs(fl.jacobian[6:, :6])) > 1.0     # coupled (exactly 0 at w = 0)
    values, vectors = np.linalg.eig(fl.jacobian)
    order = np.argsort(-np.abs(values))
    values, vectors = values[order], vectors[:, order]
    lateral_share = np.linalg.norm(vectors[6:], axis=0) / np.linalg.norm(vectors, axis=0)
    assert values[0].real == pytest.approx(fall, rel=1e-3) and abs(values[0].imag) < 1e-9
    assert lateral_share[0] > 0.95
    assert values[1].real == pytest.approx(heading, abs=1e-3) and lateral_share[1] > 0.9
    assert abs(values[1]) < 1.0
    assert abs(values[2] - pair_) < 1e-3 or abs(values[2] - pair_.conjugate()) < 1e-3
    assert lateral_share[2] < 0.1
    assert np.all(np.abs(values[1:]) < 1.0)


def test_gait_json_reports_the_unstable_orbit_and_a_roll_push_falls(continued, capsys):
    """`walker gait compass_walker_3d --set w=0.01 --json`: the walker's own motion from the guess
    falls sideways (status "fell"), and the JSON says why — Newton's unstable period-1 fixed point
    with its multipliers (the largest −32.50, as above) — instead of claiming no gait. From that
    fixed point a roll-rate push of ±0.01 rad/s falls within 4 steps (unpushed, the round-off
    grows by 32× a step and falls after 7); every fall is a stride with status "fell"."""
    assert main(["gait", "compass_walker_3d", "--set", "w=0.01", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["status"] == "fell" and d["stable"] is None
    assert "unstable period-1 fixed point" in d["message"]
    mults = [complex(m["re"], m["im"]) for m in d["unstable_fixed_point"]["floquet_multipliers"]]
    assert max(mults, key=abs).real == pytest.approx(CONTINUED[0][3], rel=1e-3)
    assert d["unstable_fixed_point"]["fixed_point"]["yaw"] == pytest.approx(CONTINUED[0][1],
                                                                           abs=1e-5)
    walker, z, _ = continued[0.01]
    alone = walker.walk(z, 12)
    assert alone[-1].fell and len(alone) >= 6
    for push in (0.01, -0.01):
        pushed = z.copy()
        pushed[walker.section.index("walker.v.pelvis.x")] += push
        strides = walker.walk(pushed, 12)
        assert strides[-1].fell and strides[-1].reason == "fall" and len(strides) <= 5
        assert all(s.status == "step" for s in strides[:-1])

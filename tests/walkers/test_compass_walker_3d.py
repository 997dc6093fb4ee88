"""The 3D compass walker (models/compass_walker_3d.toml): the thesis's nominal walker with a pelvis
of width w, spherical feet, the 3D Hunt–Crossley contact and vector SCVS friction.

With w = 0 and a sagittal start the lateral coordinates stay 0 and the gait is
compass_walker_sole_friction's (an independent model file: planar multibody, planar contact and
friction at the sole point; both with the legs' rod inertia I_leg = m_leg l²/12): the 3D file
keeps the friction at the sole point, compass_walker moved it to the rolling contact's material
point. The lateral multipliers of that gait: one unstable (measured
−33.386, the sideways fall: Kuo 1999, IJRR 18, "Stabilization of lateral motion in passive
dynamic walking": the straight-legged 3D walker is laterally unstable without control; we agree),
one ≈ −1.0026 (the heading: yaw is neutral up to the slope's gravity component, and the section's
mirror relabelling flips its sign every step).

With w > 0 the gait, continued in w from w = 0 (0.01, 0.02 m), leaves the sagittal plane: the
fixed point yaws (0.0351 rad at w = 0.01) and sways (lateral hip velocity 0.0382 m/s), the
Jacobian couples the blocks, and the walker stays laterally unstable (the sideways-fall multiplier
−33.09, −32.21): Kuo's result holds at every width tried. The heading multiplier moves inside the
unit circle (−0.9967, −0.9786). `walker gait` reports the unstable orbit with its multipliers
(outcome "unstable_orbits_only"), and the walker's own motion from it — or from a roll push —
falls sideways as a result.

Floquet multipliers here are exact (:func:`~walker_library.analyses.monodromy.floquet`'s default: the
variational equations with saltation matrices). The pins changed when the legs got their rod
inertia (they were point masses) and the multipliers became exact (they were central differences
at a fixed step of 1e-4): the sideways-fall multiplier at w = 0 from −32.794 to −33.386 — all of it
the inertia: with I_leg = 0 the exact Jacobian gives −32.7941, the old value.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from walker_library import load_walker, walk
from walker_library.analyses.monodromy import floquet
from walker_library.analyses.poincare import find_fixed_point
from walker_library.cli import main

TIGHT = {"rtol": 1e-12, "atol": 1e-13, "gait_tolerance": 1e-11}
LATERAL = ["walker.q.pelvis.x", "walker.q.pelvis.z", "walker.v.pelvis.x", "walker.v.pelvis.z",
           "walker.v.hip_joint.y"]


@pytest.fixture(scope="module")
def pair(isolated_cache):
    planar = load_walker("compass_walker_sole_friction").with_options(**TIGHT)
    spatial = load_walker("compass_walker_3d", {"w": 0.0}).with_options(**TIGHT)
    fp2 = find_fixed_point(planar, tol=1e-11)
    return planar, spatial, fp2


def test_sections_share_the_planar_coordinates(pair):
    planar, spatial, _ = pair
    assert list(spatial.section) == list(planar.section) + LATERAL


def test_sagittal_gait_equals_compass_walker(pair):
    """From compass_walker_sole_friction's fixed point (lateral coordinates 0) Newton converges in ≤ 8
    iterations to the same fixed point (asserted 1e-8; measured: 0 iterations, the 2D fixed point
    is within the Newton tolerance 1e-11 of the 3D stride map's at rtol 1e-12), with the lateral
    coordinates exactly 0. Exact Jacobians of the stride maps: the 3D one is block diagonal
    (sagittal/lateral), exactly 0 off the blocks (measured exactly 0.0 on the C and numba back
    ends: by the mirror symmetry, no lateral state or variation is ever nonzero in the sagittal
    columns' runs, nor a sagittal one in the lateral rows); its sagittal block equals
    compass_walker_sole_friction's to 1e-6 (measured 1.5e-8 C, 7.1e-8 numba, on entries up to 94) and so do the
    multipliers (the issue's 1e-6; measured 4.4e-10 C, 7.0e-10 numba — with step-1e-4 finite
    differences they were asserted to 1e-5 only, measured 3.5e-6). Lateral multipliers (pinned to
    1e-5, their error bounds are 1e-8; measured −33.386187, −1.0025858, −0.0110616, −0.0016387, 0;
    the C and numba back ends agree to 2.4e-10): were −32.794 and −1.0026 before the legs' rod
    inertia (with finite differences; the exact Jacobian at I_leg = 0 gives −32.7941, −1.00260).
    The sagittal complex pair: −0.11159 ± 0.23910i (−0.0933 ± 0.2627i with point-mass legs)."""
    planar, spatial, fp2 = pair
    assert fp2.converged
    fp3 = find_fixed_point(spatial, np.concatenate([fp2.z, np.zeros(5)]), tol=1e-11)
    assert fp3.converged and fp3.iterations <= 8
    assert np.max(np.abs(fp3.z[:6] - fp2.z)) < 1e-8
    assert np.all(fp3.z[6:] == 0.0)
    f2 = floquet(planar, fp2.z, period=1)
    f3 = floquet(spatial, fp3.z, period=1)
    assert f2.method == f3.method == "variational"
    J = f3.jacobian
    assert np.all(J[6:, :6] == 0.0) and np.all(J[:6, 6:] == 0.0)
    assert np.max(np.abs(J[:6, :6] - f2.jacobian)) < 1e-6
    sagittal = np.sort_complex(np.linalg.eigvals(J[:6, :6]))
    assert np.max(np.abs(sagittal - np.sort_complex(f2.multipliers))) < 1e-6
    pair_ = max(f2.multipliers, key=lambda m: m.imag)
    assert abs(pair_ - complex(-0.111585, 0.239100)) < 1e-5
    lateral = np.array(sorted(np.linalg.eigvals(J[6:, 6:]), key=abs, reverse=True))
    assert np.all(np.abs(lateral.imag) < 1e-9)
    assert lateral.real == pytest.approx([-33.386187, -1.0025858, -0.0110616, -0.0016387, 0.0],
                                         abs=1e-5)
    assert f3.errors[0] < 1e-5 and f3.certain and not f3.stable


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


# measured at the file's tolerances (rtol 1e-9), exact multipliers (error bounds ≤ 4e-7):
# (w, yaw*, hip_vy*, sideways-fall multiplier, heading multiplier, the sagittal complex pair).
# Before the legs' rod inertia, with central differences at a fixed step of 1e-4, they were
# w = 0.01: 0.034933, 0.038059, −32.5025, −0.99716, −0.09431 + 0.26433i;
# w = 0.02: 0.069543, 0.075699, −31.6382, −0.98048, −0.09817 + 0.27058i.
CONTINUED = [(0.01, 0.0351098, 0.0382028, -33.08820, -0.996695, complex(-0.112964, 0.241072)),
             (0.02, 0.0698947, 0.0759835, -32.20517, -0.978605, complex(-0.117442, 0.246718))]


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
        out[w] = (walker, z, floquet(walker, z, period=1))
    return out


@pytest.mark.parametrize("case", CONTINUED, ids=lambda c: f"w={c[0]}")
def test_wide_pelvis_gait_is_laterally_unstable(continued, case):
    """w > 0: the fixed point leaves the sagittal plane (yaw and lateral hip velocity pinned to
    1e-6; both grow linearly in w, checked to 1 %), the blocks couple, and the exact multipliers
    (pinned to 1e-4 the unstable one, 1e-5 the others; their error bounds are ≤ 4e-7) are, by
    their eigenvectors' share in the lateral coordinates: one unstable lateral (the sideways fall,
    > 0.95 lateral, measured 0.991 and 0.965: Kuo 1999 — the straight-legged 3D passive walker is
    laterally unstable without control; we agree), the heading (lateral, > 0.9, measured 0.983
    and 0.933; |λ| just below 1), the sagittal complex pair as compass_walker_sole_friction's (−0.1116 ±
    0.2391i at w = 0; < 0.1 lateral, measured 0.014 and 0.029), and every other one inside the
    unit circle."""
    w, yaw, hip_vy, fall, heading, pair_ = case
    walker, z, fl = continued[w]
    named = dict(zip(walker.section, z))
    assert named["walker.q.pelvis.z"] == pytest.approx(yaw, abs=1e-6)
    assert named["walker.v.hip_joint.y"] == pytest.approx(hip_vy, abs=1e-6)
    assert yaw / w == pytest.approx(CONTINUED[0][1] / CONTINUED[0][0], rel=1e-2)
    assert np.max(np.abs(fl.jacobian[6:, :6])) > 1.0     # coupled (exactly 0 at w = 0)
    values, vectors = np.linalg.eig(fl.jacobian)
    order = np.argsort(-np.abs(values))
    values, vectors = values[order], vectors[:, order]
    lateral_share = np.linalg.norm(vectors[6:], axis=0) / np.linalg.norm(vectors, axis=0)
    assert values[0].real == pytest.approx(fall, abs=1e-4) and abs(values[0].imag) < 1e-9
    assert lateral_share[0] > 0.95
    assert values[1].real == pytest.approx(heading, abs=1e-5) and lateral_share[1] > 0.9
    assert abs(values[1]) < 1.0
    assert abs(values[2] - pair_) < 1e-5 or abs(values[2] - pair_.conjugate()) < 1e-5
    assert lateral_share[2] < 0.1
    assert np.all(np.abs(values[1:]) < 1.0)


def test_gait_json_reports_the_unstable_orbit_and_a_roll_push_falls(continued, capsys):
    """`walker gait compass_walker_3d --set w=0.01 --json`: the search finds one periodic orbit,
    Newton's period-1 fixed point from the guess, and it is unstable (the largest multiplier
    −33.088, as above, with an error bound < 1e-6: the verdict is certain); no stable one (the
    walker's own motion from the guess falls sideways during step 2). The JSON says so — outcome
    "unstable_orbits_only", status "periodic" with stable false, the orbit in `orbits` and at the
    top level (its fixed point, multipliers and metrics), the fall from the guess in
    `fell_at_step` — instead of claiming no gait (before the gait search's outcomes, the status
    was "fell" with the orbit under `unstable_fixed_point` only). From that fixed point a
    roll-rate push of ±0.01 rad/s falls within 5 strides (measured 4 and 5, the falling stride
    included; unpushed, the round-off grows by 33× a step and falls in stride 8); every fall is a
    stride with status "fell"."""
    assert main(["gait", "compass_walker_3d", "--set", "w=0.01", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["outcome"] == "unstable_orbits_only"
    assert d["status"] == "periodic" and d["stable"] is False and d["stability_certain"] is True
    assert "only unstable orbits" in d["message"]
    (orbit,) = d["orbits"]
    assert orbit["period_steps"] == d["period_steps"] == 1 and orbit["stable"] is False
    assert orbit["found_by"] == "Newton from the guess"
    assert orbit["max_multiplier"] == pytest.approx(-CONTINUED[0][3], abs=1e-4)
    for mults in (orbit["floquet_multipliers"], d["floquet_multipliers"],
                  d["unstable_fixed_point"]["floquet_multipliers"]):
        top = max((complex(m["re"], m["im"]) for m in mults), key=abs)
        assert top.real == pytest.approx(CONTINUED[0][3], abs=1e-4) and abs(top.imag) < 1e-9
    assert d["multiplier_error"] < 1e-6
    for fp in (orbit["fixed_point"], d["fixed_point"]):
        assert fp["yaw"] == pytest.approx(CONTINUED[0][1], abs=1e-6)
        assert fp["hip_vy"] == pytest.approx(CONTINUED[0][2], abs=1e-6)
    assert d["step_period"] > 0 and d["speed"] > 0          # the orbit's metrics, not null
    assert d["fell_at_step"] == 2 and d["fall_reason"] == "fall"
    walker, z, _ = continued[0.01]
    alone = walker.walk(z, 12)
    assert alone[-1].fell and len(alone) >= 6
    for push in (0.01, -0.01):
        pushed = z.copy()
        pushed[walker.section.index("walker.v.pelvis.x")] += push
        strides = walker.walk(pushed, 12)
        assert strides[-1].fell and strides[-1].reason == "fall" and len(strides) <= 5
        assert all(s.status == "step" for s in strides[:-1])

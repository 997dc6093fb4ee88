"""The thesis's nominal walker (models/compass_walker.toml; M. Jafarian 2010, "Variable stiffness
for robust and energy efficient 2D bipedal locomotion", MSc report 022CE2010, University of
Twente, ch. 2): rigid legs, rolling arc feet, Hunt–Crossley contact + SCVS friction at the
rolling contact point, the scuffing rule, γ = 0.009.

Thesis numbers (Table 2.3, §3.1): speed 0.274 m/s, energy dissipated per step 0.08 J. Measured
here (λ = 3.16e7 N·s/m² from calibrate_damping; legs as rods, I_leg = m_leg l²/12): speed
0.304 m/s, 0.0876 J per step, step period 1.013 s, step length 0.308 m, Floquet multipliers
|λ| ≤ 0.27. They are compared with the thesis
loosely (within 15 %); the energy balance (dissipated = potential released, cost of transport =
sin γ) is checked tightly, and the gait itself is pinned (regression) at tolerances derived from
the integration tolerances (see test_regression_pins).

The model compiles once (numba ≈ 30 s, cached on disk); each stride then takes ≈ 0.1 s.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from walker_library import analyze_gait, compass_walker, walk
from walker_library.analyses.calibration import calibrate_damping
from walker_library.analyses.robustness import (
    basin,
    basin_state,
    basin_walker,
    fixed_points,
    recovers,
)


@pytest.fixture(scope="module")
def walker():
    return compass_walker()


@pytest.fixture(scope="module")
def gait(walker):
    return analyze_gait(walker)


def test_stable_period_one_gait_at_nominal_slope(walker, gait):
    assert gait.status == "periodic" and gait.period_steps == 1 and gait.stable
    mults = np.abs(np.array(gait.floquet_multipliers))
    # the dominant pair's error bound (the small ones form a nearly defective cluster whose
    # first-order bounds are large, ≈ 0.07, and irrelevant to the verdict)
    assert mults.max() < 0.5 and gait.multiplier_errors[0] < 1e-2 and gait.stability_certain
    fp = gait.fixed_point
    # heel strike: the new foot in front (θ > 0), walking downhill (θ̇ < 0), φ ≈ 2θ (the stance
    # foot penetrates a little, so φ − 2θ is small but not 0)
    assert fp["theta"] > 0.15 and fp["theta_dot"] < 0
    assert fp["phi"] == pytest.approx(2 * fp["theta"], abs=2e-3)
    m = gait.metrics
    # thesis: 0.274 m/s and 0.08 J per step (Table 2.3): loosely
    assert m.speed == pytest.approx(0.274, rel=0.15)
    assert m.energy_dissipated_per_step == pytest.approx(0.08, rel=0.15)
    # energy balance of a periodic gait: dissipated = potential released; CoT = sin γ
    assert m.energy_dissipated_per_step == pytest.approx(m.potential_released_per_step, rel=1e-5)
    assert m.cost_of_transport == pytest.approx(math.sin(walker.parameters["slope"]), rel=1e-4)
    assert m.step_length == pytest.approx(m.speed * m.step_period, rel=1e-12)


def test_energy_residual_over_20_steps(walker, gait):
    z = np.array([gait.fixed_point[k] for k in walker.section])
    res = walk(walker, z, 20)
    assert res.steps_taken == 20 and not res.fell
    assert res.max_energy_residual < 1e-7                 # J, over the whole run
    assert res.energy_dissipated == pytest.approx(res.potential_released, rel=1e-4)
    for s in res.steps:                                  # every step repeats the gait
        assert s["state_after"]["theta"] == pytest.approx(gait.fixed_point["theta"], abs=1e-6)


def test_step_down_of_1_mm_is_survived_and_5_cm_falls(walker, gait):
    """walk(..., ground_drop=h) (the thesis's step-down, §2.6): the surface ahead of the stance foot drops by
    h before the first heel strike. From the fixed point, h = 1 mm: 20 steps, back on the fixed
    point (measured 8e-8; asserted 1e-5), the ledger closed across the surface switches
    (measured 5e-8 J; asserted 1e-7 J), and the potential released is the weight times the
    descent, Σ step lengths · sin γ + h cos γ (the end state is the start state moved; measured
    to 1e-7 J, asserted 1e-5 J). h = 5 cm: a fall, as a Stride with status "fell"."""
    z = np.array([gait.fixed_point[k] for k in walker.section])
    h = 0.001
    strides = walker.walk(z, 20, ground_drop=h, record=True)
    assert len(strides) == 20 and not any(s.fell for s in strides)
    assert np.max(np.abs(strides[-1].z_next - z)) < 1e-5
    traj = strides[-1].info["trajectory"]
    assert np.max(np.abs(traj.residual)) < 1e-7
    assert max(abs(s.energy_residual) for s in strides) < 1e-7
    g1, g2 = (walker.model.param_names.index(f"ground{k}") for k in (1, 2))
    assert traj.segments[-1].p[g1] == -h and traj.segments[-1].p[g2] == -h
    # back on the gait h lower: the potential released is the weight times the descent
    released = sum(s.potential_released for s in strides)
    gamma = walker.parameters["slope"]
    descent = sum(s.step_length for s in strides) * math.sin(gamma) + h * math.cos(gamma)
    assert released == pytest.approx(walker.weight * descent, abs=1e-5)
    fell = walker.walk(z, 5, ground_drop=0.05)
    assert fell[-1].status == "fell" and fell[-1].reason == "fall" and len(fell) <= 3


def test_scuffing_rule_ignores_the_mid_stance_pass(walker, gait):
    """The swing foot passes through the surface near mid-stance (straight legs): its touchdown
    guard fires there but the contact does not start (the foot is not in front); the step ends at
    the later touchdown in front of the stance foot."""
    z = np.array([gait.fixed_point[k] for k in walker.section])
    s = walker.stride(z, record=True)
    traj = s.info["trajectory"]
    swing = "touchdown2"                                  # leg 1 leads at the start of a walk
    times = [t for t, name in traj.events if name == swing]
    assert len(times) >= 2 and times[0] < 0.8 * s.duration and times[-1] == pytest.approx(s.duration)
    mid = [seg for seg in traj.segments if seg.t[0] < times[0] < seg.t[-1] or seg.t[0] == times[0]]
    c2 = walker.model.param_names.index("c2")
    assert all(seg.p[c2] == 0.0 for seg in mid)


def test_basin_walks_with_qbdf_and_keeps_every_status(walker, gait):
    """The basin walks this stiff walker's points with QBDF (basin_walker's "auto"), not its own
    Rodas5P. A 5 × 5 grid of the study's span (θ/0.4 ± 0.025, θ̇/0.8 ± 0.1) at γ = 0.009: the
    statuses and step counts are those of Rodas5P (measured on the whole grid; the 50 × 50 grid
    at γ = 0.007 keeps all 2500: benchmarks/RESULTS.md); two neighbours across the boundary are
    walked again with Rodas5P here, and the converged end states agree to 1e-6 (QBDF's error
    over the walk, a hundredth of the basin's tolerance)."""
    r = basin(walker, gait, n=5, span=(0.025, 0.1))
    assert r.method == "QBDF" and walker.options.method == "Rodas5P"
    C, F = "converged", "fell"
    assert r.outcome == [[F, F, C, C, F], [F, F, C, F, F], [F, C, C, F, F], [C, C, F, F, F],
                         [C, C, F, F, F]]
    assert r.steps == [[1, 1, 9, 6, 2], [1, 3, 8, 4, 1], [1, 11, 8, 2, 1], [11, 10, 3, 1, 1],
                       [10, 9, 1, 1, 1]]
    fps = fixed_points(walker, gait)
    for j in (2, 3):
        z0 = basin_state(walker, fps[0], r.theta[1], r.theta_dot[j])
        own = recovers(walker, z0, fps, n_steps=r.n_steps, tol=r.tol)
        qbdf = recovers(basin_walker(walker), z0, fps, n_steps=r.n_steps, tol=r.tol)
        assert (own.status, own.steps) == (qbdf.status, qbdf.steps) == (r.outcome[1][j],
                                                                          r.steps[1][j])
        if own.survived:
            assert abs(own.distance - qbdf.distance) < 1e-6


def test_falls_are_results(walker):
    """A walker started far too slowly falls back: a result with the step, not an exception."""
    z = walker.initial_guess().copy()
    z[2:] *= 0.3
    strides = walker.walk(z, 3)
    assert strides[-1].fell and strides[-1].reason in ("fall", "time_limit")


def test_damping_calibration_the_thesis_way(walker):
    """Energy dissipated per impact vs λ rises to a plateau; the smallest λ at the maximum (within
    0.1 %) is the walker's default."""
    cal = calibrate_damping(walker, lams=np.logspace(6, 9, 7))
    d = np.array(cal.dissipated)
    assert d[0] < 0.5 * cal.max_dissipated               # 1e6: bouncy, little dissipation
    assert cal.calibrated_lam == pytest.approx(walker.parameters["lam"], rel=0.01)
    assert 0.05 < cal.max_dissipated < 0.12


#: the gait at the defaults, measured (C + Rodas5P at rtol 1e-9, atol 1e-11; Newton to 1e-8).
#: The friction at the rolling contact point since issue 14; with the friction at the sole point
#: (compass_walker_sole_friction, the pins before) they were 1.0132068997 s, 0.3075614420 m,
#: 0.3035524551 m/s, 0.0874366281 J, −0.1115854267 + 0.2391000346i (test_sole_friction_variant
#: below keeps them); with point-mass legs as well 1.0076010079 s, 0.3072938955 m, 0.3049757723
#: m/s, 0.0873605681 J, −0.0930544675 + 0.2620491072i (compass_walker_point_legs).
PINS = {"step_period": 1.0128548571, "step_length": 0.3080182966, "speed": 0.3041090186,
        "energy_dissipated_per_step": 0.0875665077}
SOLE_PINS = {"step_period": 1.0132068997, "step_length": 0.3075614420, "speed": 0.3035524551,
             "energy_dissipated_per_step": 0.0874366281}
#: the dominant multiplier, exact (variational equations; the sole point's −0.1115854267 +
#: 0.2391000346i; until the exact Jacobian, −0.1116409256 + 0.2387423315i from finite differences)
PIN_MULTIPLIER = complex(-0.1064134582, 0.2440763673)
SOLE_MULTIPLIER = complex(-0.1115854267, 0.2391000346)


def test_regression_pins(gait):
    """The gait's own numbers, pinned. Tolerances from the integration tolerances: the fixed
    point is converged to 1e-8 and each stride integrated at rtol 1e-8, so the step period, step
    length, speed and energy per step carry errors of order 1e-8 (relative); a different back
    end or a change of step sequence moves them by as much: asserted to 1e-6 (relative). The
    multipliers are exact (the variational equations at rtol 1e-9): 3e-8 from those at rtol
    1e-11, their error bound ≈ 1.2e-7: asserted to 1e-6; the third is 5.1e-4, the other three
    below 1e-8 in modulus."""
    m = gait.metrics
    for key, value in PINS.items():
        assert getattr(m, key) == pytest.approx(value, rel=1e-6), key
    mults = sorted(gait.floquet_multipliers, key=lambda c: (-abs(c), -c.imag))
    assert abs(mults[0] - PIN_MULTIPLIER) < 1e-6
    assert abs(mults[1] - PIN_MULTIPLIER.conjugate()) < 1e-6
    assert gait.multiplier_errors[0] < 1e-6
    assert abs(mults[2] - 5.143658e-4) < 1e-6
    assert all(abs(c) < 1e-6 for c in mults[3:])


def test_sole_friction_variant_keeps_the_old_gait():
    """compass_walker_sole_friction (the friction at the sole point, R beyond the foot centre
    along the leg: compass_walker before its arc foot became a rolling contact) walks the gait
    pinned before, to the same tolerances: the rolling contact is the whole difference."""
    from walker_library import load_walker
    gait = analyze_gait(load_walker("compass_walker_sole_friction"))
    assert gait.status == "periodic" and gait.period_steps == 1 and gait.stable
    for key, value in SOLE_PINS.items():
        assert getattr(gait.metrics, key) == pytest.approx(value, rel=1e-6), key
    assert abs(max(gait.floquet_multipliers, key=lambda c: (abs(c), c.imag)) - SOLE_MULTIPLIER) \
        < 1e-6
    assert abs(gait.metrics.speed - PINS["speed"]) > 5e-4        # the two walkers differ


#: the gait of strides integrated at rtol 1e-11 (the file's Rodas5P, atol 1e-13; Newton to 1e-11;
#: Floquet multipliers exact, from the variational equations), measured on the C back end. Legs
#: with a rod's inertia, the friction at the rolling contact point (at the sole point, the pins
#: before: −0.206593040026, 0.206392004125, 0.606538920573, −0.118663812337, 0.824951668227,
#: 0.827335229012; multipliers −0.1115854267 ± 0.2391000346i, 0.0005198352; compass_walker_
#: sole_friction gives them to 1e-12); the last three multipliers are below 1e-11
TIGHT_FIXED_POINT = [-0.206804111206, 0.206603239163, 0.607219067185, -0.118749925976,
                     0.824827471111, 0.827100015272]
TIGHT_MULTIPLIERS = [complex(-0.1064134323, 0.2440764027), complex(-0.1064134323, -0.2440764027),
                     complex(0.0005143661, 0.0), 0j, 0j, 0j]


def test_same_gait_on_every_back_end(walker):
    """The back end in use ("auto": C; .ci/run runs this file once more with
    PORTHAMILTONIAN_BACKEND=numba) gives the gait pinned from the C back end: the fixed point
    to 1e-9 (measured C vs numba: 4e-12) and the exact multipliers to 1e-6 (their error bound
    at rtol 1e-11: ≤ 3e-7)."""
    from walker_library import find_fixed_point
    from walker_library.analyses.monodromy import floquet

    tight = walker.with_options(rtol=1e-11, atol=1e-13)
    fp = find_fixed_point(tight, np.array(TIGHT_FIXED_POINT), tol=1e-11)
    assert fp.converged
    assert np.max(np.abs(fp.z - TIGHT_FIXED_POINT)) < 1e-9
    mults = sorted(floquet(tight, fp.z).multipliers, key=lambda c: (-abs(c), -c.imag))
    assert np.max(np.abs(np.array(mults) - TIGHT_MULTIPLIERS)) < 1e-6


#: modules a walk on a cached model does not need (importing them took ~0.5 s of a cold start)
_NOT_FOR_A_WALK = ("scipy.linalg", "scipy.optimize", "scipy.integrate", "scipy.sparse")


def test_a_walk_from_the_cache_does_not_import_scipy(walker):
    """A fresh process that loads the walker from the cache (filled by the fixture) and walks a
    stride imports none of scipy's linear algebra, optimisation or integration (they are
    imported where an analysis uses them: impacts, stride extremes, multiplier matching, the
    scipy methods)."""
    import json
    import subprocess
    import sys

    script = ("import json, sys\n"
              "from walker_library import load_walker\n"
              "w = load_walker('compass_walker')\n"
              "s = w.stride(w.initial_guess())\n"
              f"print(json.dumps([s.status, [m for m in {_NOT_FOR_A_WALK!r} if m in sys.modules]]))")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         check=True, timeout=300)
    status, imported = json.loads(out.stdout.strip().splitlines()[-1])
    assert "building" not in out.stderr      # the fixture's build was reused
    assert status == "step"
    # numba imports scipy.linalg itself (numba/np/linalg.py: ensure_blas, at its numpy support's
    # import) when the walker runs on it (.ci/run's second pass)
    allowed = {"scipy.linalg"} if walker.backend == "numba" else set()
    assert set(imported) - allowed == set()


def test_the_gaits_stride_is_cut_from_newtons_last_walk(walker, gait, monkeypatch):
    """The same walk asked again with ``details`` (the gait's metrics stride at the fixed point,
    after Newton's last residual there), or plainly after a ``record`` walk, is cut from the
    last walk's trajectory (a ``record`` walk itself is always integrated): no second
    integration, and the strides of a walker that integrates it afresh, bit for bit; the
    stride's max |θ| and max |φ| (all stored points at once) are the largest of
    ``walker.angles`` over the stored points."""
    from walker_library.core.walker import HybridWalker

    z = np.array([gait.fixed_point[k] for k in walker.section])
    runs = []
    simulate = walker.model.simulate
    monkeypatch.setattr(walker.model, "simulate", lambda *a, **k: runs.append(1) or simulate(*a, **k))
    w = HybridWalker(walker.plan, walker.compiled, walker.run)
    plain = w.walk(z, 1)[0]
    cut = w.walk(z, 1, details=True)[0]
    assert len(runs) == 1
    fresh = HybridWalker(walker.plan, walker.compiled, walker.run).walk(z, 1, details=True,
                                                                         record=True)[0]
    assert len(runs) == 2
    assert np.array_equal(cut.z_next, plain.z_next) and np.array_equal(cut.z_next, fresh.z_next)
    assert (cut.max_theta, cut.max_phi) == (fresh.max_theta, fresh.max_phi)
    assert (cut.duration, cut.energy_dissipated) == (fresh.duration, fresh.energy_dissipated)
    X = fresh.info["trajectory"].y[:walker.model.n_states]
    angles = [w.angles(X[:, i]) for i in range(X.shape[1])]
    assert cut.max_theta == max(abs(a["theta"]) for a in angles)
    assert cut.max_phi == max(abs(a["phi"]) for a in angles)
    w.walk(z + 1e-6, 1)                      # another walk: integrated
    assert len(runs) == 3
    w.walk(z + 1e-6, 1)                      # the same walk again: cut
    assert len(runs) == 3
    again = w.walk(z + 1e-6, 1, reuse=False)  # integrated, on request: the same stride
    assert len(runs) == 4
    assert np.array_equal(again[0].z_next, w.walk(z + 1e-6, 1)[0].z_next)
    assert len(runs) == 4                    # (and a plain walk after it: cut from it)
    w.run = w.with_parameters(slope=0.01).run  # other run values: integrated again
    w.walk(z + 1e-6, 1)
    assert len(runs) == 5
    recorded = w.walk(z, 2, record=True)     # a record walk (no dense output with Rodas5P)
    assert len(runs) == 6
    again = w.walk(z, 2)                     # then plainly, as gait.walk's callers do: cut
    assert len(runs) == 6
    assert [s.z_next.tobytes() for s in again] == [s.z_next.tobytes() for s in recorded]
    assert "trajectory" in recorded[-1].info and "trajectory" not in again[-1].info
    w.walk(z, 2, record=True)                # a record walk is always integrated (timed)
    assert len(runs) == 7


def test_floquet_runs_its_two_jacobians_side_by_side_with_the_same_numbers(walker, gait):
    """The Floquet multipliers' two runs (the walker's tolerances and ten times them) run in two
    threads; the result is that of the two runs made one after the other, and an error in the
    second thread's run is raised in the caller's."""
    from walker_library.analyses.monodromy import StrideJacobian, floquet, multipliers
    from walker_library.core.walker import HybridWalker

    z = np.array([gait.fixed_point[k] for k in walker.section])
    fine, coarse = walker.stride_sensitivity(z), walker.stride_sensitivity(z, factor=10.0)
    lam, err = multipliers(StrideJacobian(fine.jacobian, np.abs(fine.jacobian - coarse.jacobian)
                                          + fine.difference_error, np.full(len(z), np.nan),
                                          "variational", 1, 2, coarse.jacobian,
                                          fine.difference_error))
    fl = floquet(walker, z)
    assert np.array_equal(fl.multipliers, lam) and np.array_equal(fl.errors, err)

    class Broken(HybridWalker):
        def stride_sensitivity(self, z, period=1, *, factor=1.0, deadline=math.inf):
            if factor != 1.0:
                raise ValueError("the coarse run broke")
            return super().stride_sensitivity(z, period, factor=factor, deadline=deadline)

    with pytest.raises(ValueError, match="coarse run broke"):
        floquet(Broken(walker.plan, walker.compiled, walker.run), z)

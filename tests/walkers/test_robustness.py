"""Robustness analyses (walker_library.analyses.robustness): the step-down test, the basin of attraction
and the Gait Sensitivity Norm, on the rigid-impact walkers (fast; the compliant-contact walkers
use the same code through the Walker protocol).

Independent checks: the drop itself (the new stance foot lands h lower, the ledger stays closed),
the step-down scan against explicit re-walks, and the GSN's direct finite-difference impulse
response against the linearized stride map x_{k+1} = A x_k + B h_k, T_k = C x_k + D h_k built
from separately computed derivatives (Hobbelen & Wisse 2007, eq. for the H2 norm)."""
from __future__ import annotations

import dataclasses
import functools
import json
import math
import operator

import numpy as np
import pytest

from porthamiltonian.errors import ParameterValueError
from walker_library import analyze_gait, compass_gait, simplest_walker
from walker_library.analyses.poincare import jacobian
from walker_library.analyses.robustness import (
    basin,
    basin_walker,
    gait_sensitivity_norm,
    recovers,
    step_down,
)
from walker_library.cli import main


@pytest.fixture(scope="module")
def simplest():
    w = simplest_walker()
    return w, analyze_gait(w)


def _z(walker, gait):
    return np.array([gait.fixed_point[k] for k in walker.section])


def test_ground_drop_lowers_the_new_stance_foot_once_and_keeps_the_ledger(simplest):
    w, g = simplest
    h = 1e-3
    strides = w.walk(_z(w, g), 4, ground_drop=h, record=True)
    assert [s.status for s in strides] == ["step"] * 4
    traj = strides[-1].info["trajectory"]
    iz = w.model.param_names.index("stance_z")
    heights = sorted({float(seg.p[iz]) for seg in traj.segments})
    # after the first heel strike every stance foot stands on the lowered surface: the stance
    # foot's height is -h (to the heel-strike guard's 1e-12 m hysteresis)
    assert heights[0] == pytest.approx(-h, abs=1e-11) and heights[-1] == 0.0
    assert all(abs(v + h) < 1e-11 for v in heights[:-1])
    assert np.max(np.abs(traj.residual)) < 1e-10
    with pytest.raises(Exception, match="ground_drop"):
        w.walk(_z(w, g), 1, ground_drop=-1e-3)


def test_step_down_does_not_depend_on_the_grid(simplest):
    """The scan in metres over a window of at least twice the first failure, then every boundary
    of the survived set bisected to 0.01 mm: on 0.2 mm and 0.3 mm grids the same answer to the
    bisection's tolerance — contiguous up to 1.555 mm, then a survived island 2.062–2.288 mm
    (measured; the thesis's "chaotic" robustness), so max_step_down 2.288 mm, not contiguous.
    (A 0.5 mm grid misses the 0.23 mm wide island: an island narrower than the grid can be
    missed.) Two heights re-walked independently of the scan."""
    w, g = simplest
    a = step_down(w, g, resolution=2e-4)
    b = step_down(w, g, resolution=3e-4)
    for r in (a, b):
        assert r.status == "ok" and r.n_steps >= 20 and r.boundary_tol == 1e-5
        assert r.window >= 2 * r.first_failure
        grid = [c["h"] for c in r.cases if c["kind"] == "grid"]
        assert grid == pytest.approx([r.resolution * k for k in range(1, len(grid) + 1)],
                                     abs=1e-15)
        assert not r.contiguous and len(r.survived_intervals) == 2
        assert r.max_step_down == r.survived_intervals[-1][1]
        assert r.contiguous_limit == r.survived_intervals[0][1]
        assert r.max_step_down == max(c["h"] for c in r.cases if c["survived"])
    for (lo_a, hi_a), (lo_b, hi_b) in zip(a.survived_intervals, b.survived_intervals):
        assert abs(lo_a - lo_b) < 2e-5 and abs(hi_a - hi_b) < 2e-5
    assert a.contiguous_limit == pytest.approx(1.555e-3, abs=2e-5)
    assert a.survived_intervals[1] == pytest.approx([2.062e-3, 2.288e-3], abs=2e-5)
    fps = np.array([_z(w, g)])
    assert recovers(w, _z(w, g), fps, n_steps=40, tol=1e-6, ground_drop=1.5e-3).survived
    assert recovers(w, _z(w, g), fps, n_steps=40, tol=1e-6, ground_drop=1.8e-3).status == "fell"
    # an explicit list of heights is evaluated as given (boundary_tol=0: no bisection)
    r2 = step_down(w, g, heights=[2.2e-3, 1e-3, 1.8e-3], boundary_tol=0)
    assert [c["status"] for c in r2.cases] == ["converged", "fell", "converged"]
    assert r2.max_step_down == 2.2e-3 and r2.contiguous is False and r2.holes == [1.8e-3]
    assert r2.contiguous_limit == 1e-3
    r3 = step_down(w, g, heights=[1e-3, 1.8e-3], boundary_tol=0)
    assert r3.max_step_down == 1e-3 and r3.contiguous is True


def test_a_recovery_ends_at_the_first_step_within_tol(simplest):
    """The walk's ``until`` ends it after the first step whose section state satisfies it, on
    the same strides as the full walk; ``recovers`` stops there and counts the steps to it, also
    across chunks. On this spiral (complex multipliers) the distance is not monotone: step 13 is
    within 1e-5 of the fixed point (6.0e-6, measured), step 14 outside (6.2e-5), step 20 within
    again."""
    w, g = simplest
    z_star = _z(w, g)
    z0 = z_star + np.array([0.0, 0.01, 0.0])
    full = w.walk(z0, 24)
    d = [float(np.max(np.abs(s.z_next - z_star))) for s in full]
    tol = 1e-5
    k = next(i for i, x in enumerate(d, 1) if x <= tol)
    assert k == 13 and d[13] > tol and d[19] <= tol
    early = w.walk(z0, 24, until=lambda z: float(np.max(np.abs(z - z_star))) <= tol)
    assert [s.status for s in early] == ["step"] * k
    for a, b in zip(early, full):
        assert np.array_equal(a.z_next, b.z_next) and a.duration == b.duration
    fps = np.array([z_star])
    for n_steps in (20, 5):
        r = recovers(w, z0, fps, n_steps=n_steps, tol=tol)
        assert r.status == "converged" and r.steps == k
        # a new chunk restarts the integration from the section state: equal to its tolerance
        assert r.distance == pytest.approx(d[k - 1], abs=1e-9)


def test_step_down_without_a_gait_is_a_result():
    # from this guess the walker falls (the continuation from the file's gait, not asked for
    # here, would find the shallow slope's gait)
    w = simplest_walker(slope=0.0001, theta0=0.05)
    r = step_down(w, analyze_gait(w, continuation=False))
    assert r.status == "no_gait" and r.max_step_down is None and r.contiguous is False
    assert "no periodic gait" in r.message
    json.loads(r.to_json())


def test_gsn_matches_the_linearized_stride_map(simplest):
    """After the drop step the trailing foot stands h higher than the new stance foot (off the
    two-feet-on-the-ground section), so the linear model starts from the section state after the
    second step, both feet on the lowered surface: g_k = C A^(k-2) dz_2 for k >= 2 (A from the
    Floquet Jacobian, C = dT/dz by separate central differences)."""
    w, g = simplest
    res = gait_sensitivity_norm(w, g, h=1e-6, n_steps=60)
    assert res.status == "ok" and res.error < 1e-3 * res.gsn
    z = _z(w, g)
    h = 1e-6
    A = jacobian(w, z, step=1e-6)
    dz2 = (w.walk(z, 2, ground_drop=h)[1].z_next - z) / h
    C = np.empty(len(z))
    for j in range(len(z)):
        e = np.zeros(len(z))
        e[j] = 1e-6
        C[j] = (w.stride(z + e).duration - w.stride(z - e).duration) / 2e-6
    g_lin, x = [], dz2.copy()
    for _ in range(58):
        g_lin.append(float(C @ x))
        x = A @ x
    direct = np.array(res.response["step_period"][2:])
    assert np.linalg.norm(g_lin) == pytest.approx(np.linalg.norm(direct), rel=2e-3)
    assert direct[:5] == pytest.approx(g_lin[:5], rel=1e-2, abs=1e-2)


def test_basin_of_the_compass_gait():
    w = compass_gait()
    g = analyze_gait(w)
    r = basin(w, g, n=5, span=0.1)
    assert r.status == "ok" and len(r.outcome) == 5 and all(len(row) == 5 for row in r.outcome)
    assert r.outcome[2][2] == "converged"                  # the fixed point itself
    assert r.theta[2] == pytest.approx(g.fixed_point["theta"], abs=1e-12)
    assert r.theta[4] - r.theta[0] == pytest.approx(2 * 0.1 * 0.4, rel=1e-12)   # scaled by 0.4
    assert r.theta_dot[4] - r.theta_dot[0] == pytest.approx(2 * 0.1 * 0.8, rel=1e-12)
    assert 0 < r.fraction < 1 and set(functools.reduce(operator.iadd, r.outcome, [])) <= {"converged", "fell", "wandered"}
    assert 0 < r.radius <= 0.1 * math.sqrt(2)
    assert r.method == "QBDF"             # "auto": QBDF for a walker on a compiled method
    json.loads(r.to_json())


def test_the_basin_method_rule(simplest):
    """basin_walker: "auto" keeps a walker whose own method is not a compiled stiff one (scipy's
    DOP853 here) and gives one whose method is Rodas5P (the file's) QBDF at the same
    tolerances; a name is taken as given, None keeps the walker's own, an unknown name is
    refused."""
    stiff, _ = simplest
    assert stiff.options.method == "Rodas5P"
    w = stiff.with_options(method="DOP853")
    assert basin_walker(w) is w and basin_walker(w, None) is w
    auto = basin_walker(stiff)
    assert auto.options == dataclasses.replace(stiff.options, method="QBDF")
    assert basin_walker(stiff, None) is stiff
    assert basin_walker(w, "Rodas4").options.method == "Rodas4"
    with pytest.raises(ParameterValueError, match="unknown integration method 'Euler'"):
        basin_walker(w, "Euler")


def test_cli_step_down_json(capsys):
    assert main(["step-down", "simplest_walker", "--resolution", "5e-4", "--quiet", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert isinstance(d["max_step_down"], float) and isinstance(d["contiguous"], bool)
    assert d["max_step_down"] == max(c["h"] for c in d["cases"] if c["survived"])
    assert d["max_step_down"] >= 1.5e-3 and d["resolution"] == 5e-4

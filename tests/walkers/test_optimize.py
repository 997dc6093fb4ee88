"""Design by optimization (walker_library/analyses/optimize.py, ``walker optimize``): the most
efficient simplest-walker gait whose largest Floquet multiplier is at most 0.6.

A passive walker's cost of transport is sin γ (tests/walkers/test_gait_gradients.py), so the
problem's answer is the smallest slope with ρ(γ) ≤ 0.6: on the branch where ρ falls with γ,
the constraint is active at the optimum. Checked: the first-order (KKT) conditions at the
optimizer's tolerance, a grid around the optimum (every neighbour either violates the constraint
or costs more), and the record file (a second run reads every evaluation back).
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from porthamiltonian.errors import OptionError
from walker_library.analyses.monodromy import stride_jacobian
from walker_library.analyses.optimize import optimize_gait
from walker_library.analyses.poincare import find_fixed_point
from walker_library.cli import main as walker_main
from walker_library.core.files import load_walker

ARGS = ["optimize", "simplest_walker", "--vary", "slope", "--objective", "cost_of_transport",
        "--constraint", "max_multiplier_modulus<=0.6", "--bounds", "slope=0.001:0.012",
        "--step-down", "none", "--json", "--quiet"]


@pytest.fixture(scope="module")
def optimum(tmp_path_factory):
    """The record file of one optimization run."""
    record = tmp_path_factory.mktemp("optimize") / "record.jsonl"
    assert walker_main([*ARGS, "--record", str(record)]) == 0
    return record


def _run(capsys, record) -> dict:
    assert walker_main([*ARGS, "--record", str(record)]) == 0
    return json.loads(capsys.readouterr().out)


def test_first_order_conditions_and_the_grid(optimum, capsys):
    """SLSQP converges in ≤ 12 gait evaluations (measured 6; 9 before the impact's forward
    derivative) to γ* ≈ 0.00766 with the constraint active (ρ = 0.6 to 1e-6), its multiplier
    positive and the gradient of the Lagrangian zero to 1e-6 (scaled units); the grid
    γ*(1 ± 2e-3): below, ρ > 0.6 (ρ from the exact stride Jacobian at a fixed point found to
    1e-12, independent of the optimizer's gradients); above, the cost of transport is larger."""
    capsys.readouterr()
    res = _run(capsys, optimum)        # again: every evaluation read back from the record
    assert res["success"] and res["evaluations"] <= 12
    assert res["reused"] == res["evaluations"]          # all read back: nothing simulated
    assert res["values"]["max_multiplier_modulus"] == pytest.approx(0.6, abs=1e-6)
    kkt = res["kkt"]
    assert kkt["active"] == ["max_multiplier_modulus <= 0.6"]
    assert kkt["multipliers"]["max_multiplier_modulus <= 0.6"] > 0
    assert kkt["gradient_of_lagrangian"] < 1e-6 * max(1.0, kkt["gradient"])
    gamma = res["optimum"]["slope"]
    assert res["values"]["cost_of_transport"] == pytest.approx(math.sin(gamma), abs=1e-9)
    walker = load_walker("simplest_walker")
    z = find_fixed_point(walker, walker.initial_guess(), tol=1e-12).z
    for factor in (1 - 2e-3, 1 + 2e-3):
        w = walker.with_parameters(slope=gamma * factor)
        fp = find_fixed_point(w, z, tol=1e-12)
        rho = max(abs(np.linalg.eigvals(stride_jacobian(w, fp.z).matrix)))
        if factor < 1:
            assert rho > 0.6 + 1e-5
        else:
            assert rho < 0.6 and math.sin(gamma * factor) > res["values"]["cost_of_transport"]


@pytest.mark.parametrize("change, message", [
    (("--constraint", "speed<0.3"), "expected QUANTITY<=NUMBER"),
    (("--bounds", "slope=0.01"), "NAME=LOW:HIGH"),
    (("--bounds", "M=1:2"), "not varied"),
    (("--vary", "stance_x"), "cannot differentiate"),
    (("--max-evaluations", "0"), "at least 1"),
    (("--bounds", "slope=0.02:0.03"), "outside the bounds"),
])
def test_bad_options_are_errors(change, message, capsys):
    """Every bad option is ``error: ...`` and status 2 before any gait evaluation."""
    args = ["optimize", "simplest_walker", "--vary", "slope", "--objective",
            "cost_of_transport", "--quiet", *change]
    assert walker_main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("error:") and message in err and "Traceback" not in err


def test_a_record_of_another_problem_is_refused(optimum, capsys):
    """The record names its problem: a run of another problem on it is an error, status 2."""
    args = [a.replace("0.6", "0.5") for a in ARGS]
    assert walker_main([*args, "--record", str(optimum)]) == 2
    assert "another problem" in capsys.readouterr().err


def test_least_multiplier_by_the_epigraph_lands_on_the_collision():
    """min ρ over the slope of the simplest walker (0.008 ≤ γ ≤ 0.0145): the complex pair of
    multipliers shrinks as γ grows until it meets on the real axis (γ ≈ 0.0138), after which one
    real multiplier runs to −1 (period doubling at 0.0186), so the least ρ sits at the
    collision, where ρ(γ) has a kink (slope −∞ on the right). SLSQP on ρ itself zigzags across
    it (40 evaluations, measured); the epigraph formulation (Jury's conditions on the cluster's
    sum and product) converges in ≤ 8 gait evaluations (measured 5) with two of them active,
    their multipliers positive and ∇L = 0 to 1e-8; at the optimum the two multipliers are real
    and equal to 1e-3 (their separation grows like the square root of the distance to the
    collision); a grid γ*(1 ± 2e-3) with ρ from the exact stride Jacobian at fixed points found
    to 1e-12 (independent of the optimizer's gradients) is higher on both sides."""

    walker = load_walker("simplest_walker")
    res = optimize_gait(walker, ["slope"], "max_multiplier_modulus",
                        bounds={"slope": (0.008, 0.0145)}, step_down="none")
    assert res.formulation == "epigraph" and res.success and res.evaluations <= 8
    kkt = res.kkt
    assert sorted(kkt["active"]) == ["t^2 + P + s t >= 0", "t^2 - P >= 0"]
    assert min(kkt["multipliers"].values()) > 0
    assert kkt["gradient_of_lagrangian"] < 1e-8
    lam = res.multipliers
    rho = res.values["max_multiplier_modulus"]
    assert abs(lam[0].imag) == abs(lam[1].imag) == 0.0 and abs(lam[0] - lam[1]) < 1e-3
    gamma = res.optimum["slope"]
    z = find_fixed_point(walker, walker.initial_guess(), tol=1e-12).z
    for factor in (1 - 2e-3, 1 + 2e-3):
        w = walker.with_parameters(slope=gamma * factor)
        fp = find_fixed_point(w, z, tol=1e-12)
        assert max(abs(np.linalg.eigvals(stride_jacobian(w, fp.z).matrix))) > rho + 1e-4


def test_an_iteration_limit_beyond_scipy_is_refused_before_the_work(capsys):
    """``walker optimize --max-evaluations 10**40`` ran the first gait, then failed inside
    scipy's slsqp (a SystemError: status 3, "this is a bug"); it is refused first now, and
    optimize_gait checks its count and tolerance (2.5 and NaN went to scipy)."""
    assert walker_main(["optimize", "compass_walker", "--vary", "slope", "--objective", "speed",
                        "--step-down", "none", "--quiet", "--max-evaluations", str(10**40)]) == 2
    err = capsys.readouterr().err
    assert err == ("error: max_evaluations must be at most 2147483647 (scipy's iteration "
                   f"counter), got {10**40}\n"), err
    walker = load_walker("compass_walker")
    for options, words in (({"max_evaluations": 2.5}, "max_evaluations must be an integer"),
                           ({"tol": math.nan}, "tol must be finite and > 0, got nan")):
        with pytest.raises(OptionError, match=words):
            optimize_gait(walker, ["slope"], "speed", step_down="none", **options)

"""The hint that an explicit method's steps were held by its stability bound
(porthamiltonian/simulation/stiffness.py).

Independent references: the extent of the stability domains along the negative real axis,
about 3.3 for Dormand–Prince 5(4) (scipy's RK45) and about 6 for DOP853 (E. Hairer, G. Wanner,
Solving Ordinary Differential Equations II, §IV.2); and the mass–spring–damper's eigenvalues in
closed form: with m = 1 kg, k = 4 N/m, c = 1e4 N·s/m, λ = (−c ± √(c² − 4 k m)) / 2m, the fast
one −c/m + O(k/c) = −1e4 1/s, the slow one −k/c = −4e-4 1/s (stiffness ratio 2.5e7).
"""
from __future__ import annotations

import re
import warnings

import pytest

from porthamiltonian import compile_model, io
from porthamiltonian.simulation.stiffness import BOUNDS, StiffnessWarning

#: h·ρ(J) as the warning prints it
_REACHED = re.compile(r"h·ρ\(J\) reached (\S+) at t = ")


@pytest.fixture(scope="module")
def msd():
    return compile_model(io.load("mass_spring_damper"), backend="c")


def _run(model, **options):
    """The run and the StiffnessWarnings it gave."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = model.simulate(**options)
    return run, [w for w in caught if issubclass(w.category, StiffnessWarning)]


@pytest.mark.parametrize("method", ["RK45", "DOP853"])
def test_a_stiff_run_of_an_explicit_method_says_so(msd, method):
    """c = 1e4 N·s/m: ρ(J) = 1e4 1/s. The controller holds h ρ at the method's bound (measured
    3.6–3.7 for RK45, 6.4 for DOP853: 1.0–1.25 of it), so the run takes ≈ t_end ρ / bound steps
    (RK45: 2 s × 1e4 / 3.3 ≈ 6060; measured 6056), one warning says so, and the run is as
    without the watch (finished, its ledger closed)."""
    run, caught = _run(msd, t_end=2.0, method=method, params={"c": 1e4}, rtol=1e-8, atol=1e-10)
    assert run.status == "finished"
    assert len(caught) == 1
    text = str(caught[0].message)
    assert method in text and "'auto'" in text and "'Rodas5P'" in text, text
    reached = float(_REACHED.search(text)[1])
    assert 1.0 <= reached / BOUNDS[method] <= 1.25, text
    steps = len(run.t) - 1
    assert steps == pytest.approx(2.0 * 1e4 / BOUNDS[method], rel=0.15)
    r = run["H"] - run["H"][0] + run["E_diss"] - run["E_in"]
    assert abs(r).max() < 1e-8 * run["H"][0]


@pytest.mark.parametrize("method", ["RK45", "DOP853"])
def test_a_long_run_of_a_non_stiff_model_at_a_loose_tolerance_says_nothing(method):
    """The pendulum over 3000 s at rtol 1e-3 (measured 8878 steps of RK45, 4418 of DOP853; h ρ
    at most 0.33 of RK45's bound and 0.44 of DOP853's, below 0.75 of it): no warning."""
    model = compile_model(io.load("pendulum"), backend="c")
    run, caught = _run(model, t_end=3000.0, method=method, rtol=1e-3, atol=1e-5)
    assert run.status == "finished" and len(run.t) > 4000
    assert caught == []


def test_a_stiff_method_is_not_watched(msd):
    """Radau on the stiff mass–spring–damper: its steps are not held by stability, no warning."""
    run, caught = _run(msd, t_end=2.0, method="Radau", params={"c": 1e4})
    assert run.status == "finished" and len(run.t) < 200
    assert caught == []


def test_the_command_line_prints_the_hint_as_a_warning_and_exits_0(capsys):
    from porthamiltonian.interfaces.cli import main
    with warnings.catch_warnings():
        warnings.simplefilter("always")         # not once per process: this test's own line
        status = main(["simulate", "mass_spring_damper", "--method", "RK45", "--set", "c=1e4",
                       "--t-end", "2"])
    assert status == 0
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if "stability" in ln]
    assert len(lines) == 1 and lines[0].startswith("warning: model 'mass_spring_damper': RK45"), err

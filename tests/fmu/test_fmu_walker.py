"""A walker as an FMU (walker_library.core.fmu): compass_walker's mode machine runs as C rules
inside the FMU, and FMPy's co-simulation of it walks the strides the walker library walks."""
from __future__ import annotations

import fmpy  # the test extra installs it
import numpy as np
import pytest
from fmpy.validation import validate_fmu

from porthamiltonian.errors import ExportError
from walker_library.cli import main
from walker_library.core.files import load_walker
from walker_library.core.fmu import export_walker_fmu, walker_program

VERSIONS = (2, 3)


@pytest.fixture(scope="module")
def walker(isolated_cache):
    return load_walker("compass_walker", backend="c")


@pytest.fixture(scope="module")
def walker_fmus(walker, tmp_path_factory):
    folder = tmp_path_factory.mktemp("walker_fmus")
    return {fmi: export_walker_fmu(walker, folder / f"compass_walker_{fmi}.fmu", fmi=fmi,
                                   kind="both", steps=5) for fmi in VERSIONS}


@pytest.mark.parametrize("fmi", VERSIONS)
def test_fmpy_validation_reports_no_problem(walker_fmus, fmi):
    assert validate_fmu(str(walker_fmus[fmi])) == []


@pytest.mark.parametrize("fmi", VERSIONS)
def test_co_simulation_walks_the_same_strides(walker, walker_fmus, fmi):
    """Five heel-strike times of FMPy's co-simulation (walker.heel_strike.time at the
    communication points, every 0.01 s) vs walker.walk(guess, 5): measured equal (the FMU's
    Rodas5P takes the walk's steps: its steps do not depend on the communication points);
    required 1e-8 s. The ledger stays closed over the 15 s run."""
    strides = walker.walk(walker.initial_guess(), 5)
    assert [s.status for s in strides] == ["step"] * 5
    expected = np.cumsum([s.duration for s in strides])
    result = fmpy.simulate_fmu(str(walker_fmus[fmi]), fmi_type="CoSimulation",
                               output_interval=0.01,
                               output=["walker.heel_strike.count", "walker.heel_strike.time",
                                       "ledger.residual", "lead"])
    assert result["time"][-1] == pytest.approx(15.0)         # steps x max_step_time
    times = np.array(sorted(set(result["walker.heel_strike.time"]) - {0.0}))
    assert len(times) >= 5 and result["walker.heel_strike.count"][-1] == len(times)
    assert np.max(np.abs(times[:5] - expected)) < 1e-8
    assert set(result["lead"]) == {1.0, 2.0}                 # the legs take turns
    assert abs(result["ledger.residual"][-1]) < 1e-7


def test_the_mode_machine_becomes_rules(walker):
    program = walker_program(walker)
    assert len(program.rules) == len(walker.machine.transitions)
    heel = [r for r in program.rules if r.counter == "walker.heel_strike"]
    assert [r.name for r in heel] == ["touchdown1#3", "touchdown2#7"]
    assert [r.name for r in program.rules if r.stop] == ["fall#10"]
    names = walker.model.param_names
    assert {names[i] for i in program.modes} == {"c1", "c2", "ground1", "ground2", "lead"}


def test_a_rigid_walker_is_refused_with_the_reason(tmp_path, capsys):
    rigid = load_walker("simplest_walker", backend="python")
    with pytest.raises(ExportError, match="rigid impact.*computed in Python.*cannot run inside"):
        export_walker_fmu(rigid, tmp_path / "w.fmu")
    assert main(["export-fmu", "simplest_walker", "--out", str(tmp_path / "w.fmu")]) == 2
    assert "error: walker 'simplest_walker' cannot be exported" in capsys.readouterr().err


@pytest.mark.parametrize("steps", ["0", str(10**400)])
def test_a_stop_time_beyond_float64_is_refused(steps, tmp_path, capsys):
    """``walker export-fmu --steps 10**400``: the stop time steps × max_step_time raised
    OverflowError (status 3, "this is a bug"); the steps are checked against the largest count
    whose stop time is a float64 (3 s per step: 5.99e307), before any work."""
    out = tmp_path / "w.fmu"
    assert main(["export-fmu", "compass_walker", "--out", str(out), "--steps", steps]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: steps must be a whole number from 1 to 5.99e+307 (the time, "
                          "steps × max_step_time = 3 s, a float64), got "), err
    assert "Traceback" not in err and not out.exists()

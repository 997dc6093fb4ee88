"""The command line, run as a user would: ``python -m porthamiltonian ...`` in a subprocess.

The python back end is chosen (``--backend python``) to keep the runs short; the cache folder is
the session's temporary one (inherited PORTHAMILTONIAN_CACHE, see tests/conftest.py).
"""
from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from porthamiltonian import io
from porthamiltonian.interfaces.cli import main

MSD_TEXT = (Path(io.__file__).resolve().parents[2] / "models" / "mass_spring_damper.toml").read_text()


def _command(*args: str) -> list[str]:
    return [sys.executable, "-m", "porthamiltonian", "--backend", "python", *args]


class ConcurrentRuns:
    """Start several command-line runs at once (each is mostly interpreter start-up) and collect
    them on demand as CompletedProcess objects."""

    def __init__(self, commands: dict[str, list[str]]):
        self._procs = {key: subprocess.Popen(_command(*args), stdout=subprocess.PIPE,
                                             stderr=subprocess.PIPE, text=True)
                       for key, args in commands.items()}
        self._done: dict[str, subprocess.CompletedProcess] = {}

    def __getitem__(self, key: str) -> subprocess.CompletedProcess:
        if key not in self._done:
            proc = self._procs[key]
            out, err = proc.communicate(timeout=300)
            self._done[key] = subprocess.CompletedProcess(proc.args, proc.returncode, out, err)
        return self._done[key]

    def close(self) -> None:
        for proc in self._procs.values():
            if proc.poll() is None:
                proc.kill()
                proc.communicate()


@pytest.fixture(scope="module")
def runs(tmp_path_factory, energy_check):
    """Every command-line run of this module, started concurrently (with the session's
    ``check-energy`` over every shipped model, tests/conftest.py)."""
    tmp = tmp_path_factory.mktemp("cli")
    impossible = tmp / "impossible_msd.toml"
    text = MSD_TEXT.replace('name = "mass_spring_damper"', 'name = "impossible_msd"')
    text = text.replace("energy_tolerance = 1e-6", "energy_tolerance = 1e-30")
    assert "energy_tolerance = 1e-30" in text
    impossible.write_text(text)
    csv_path = tmp / "msd.csv"
    commands = {
        "json": ["simulate", "mass_spring_damper", "--t-end", "1", "--json", "--csv", str(csv_path)],
        "set": ["simulate", "mass_spring_damper", "--t-end", "1", "--json", "--set", "k=9",
                "--set", "c=0.6"],
        "show": ["show", "dc_motor"],
        "impossible": ["check-energy", str(impossible)],
        "unknown_model": ["simulate", "no_such_model", "--t-end", "1"],
    }
    started = ConcurrentRuns(commands)
    started.csv_path = csv_path
    yield started
    started.close()


def msd_free_response(t: float, m=1.0, k=4.0, c=0.4, x0=0.1) -> tuple[float, float]:
    """Underdamped free response x(t) and momentum m x'(t) of m x'' + c x' + k x = 0, x(0) = x0,
    x'(0) = 0 (Ogata, Modern Control Engineering, §5-3)."""
    wn, zeta = math.sqrt(k / m), c / (2 * math.sqrt(k * m))
    wd = wn * math.sqrt(1 - zeta**2)
    decay = math.exp(-zeta * wn * t)
    x = x0 * decay * (math.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * math.sin(wd * t))
    v = -x0 * wn / math.sqrt(1 - zeta**2) * decay * math.sin(wd * t)
    return x, m * v


@pytest.fixture(scope="module")
def msd_json(runs):
    run = runs["json"]
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout)


def test_simulate_json_final_state_by_name(msd_json):
    assert msd_json["model"] == "mass_spring_damper"
    assert msd_json["status"] == "finished"
    assert msd_json["t_end"] == 1.0
    state = msd_json["final_state"]
    assert set(state) == {"mass.p", "spring.q"}
    x, p = msd_free_response(1.0)
    assert state["spring.q"] == pytest.approx(x, abs=1e-7)
    assert state["mass.p"] == pytest.approx(p, abs=1e-7)


def test_simulate_json_energy_ledger(msd_json):
    energy = msd_json["energy"]
    for key in ("H0", "HT", "dissipated", "supplied", "residual"):
        assert key in energy
    assert energy["H0"] == pytest.approx(0.5 * 4.0 * 0.1**2, rel=1e-12)
    x, p = msd_free_response(1.0)
    assert energy["HT"] == pytest.approx(0.5 * 4.0 * x**2 + p**2 / 2, rel=1e-6)
    assert energy["supplied"] == 0.0
    assert energy["dissipated"] > 0
    assert abs(energy["H0"] - energy["HT"] - energy["dissipated"]) < 1e-12
    assert abs(energy["residual"]) < 1e-12


def test_set_changes_the_result(runs, msd_json):
    run = runs["set"]
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    x, _p = msd_free_response(1.0, k=9.0, c=0.6)
    assert out["final_state"]["spring.q"] == pytest.approx(x, abs=1e-7)
    assert out["final_state"]["spring.q"] != pytest.approx(msd_json["final_state"]["spring.q"],
                                                           abs=1e-3)
    assert out["energy"]["H0"] == pytest.approx(0.5 * 9.0 * 0.1**2, rel=1e-12)


def test_csv_header_names_states(runs):
    """``--csv FILE`` (given together with --json) writes t, the states by name and the ledger."""
    path = runs.csv_path
    run = runs["json"]
    assert run.returncode == 0, run.stderr
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    header = rows[0]
    assert header[0] == "t"
    assert {"mass.p", "spring.q", "H", "E_diss", "E_in", "residual"} <= set(header)
    data = [list(map(float, r)) for r in rows[1:]]
    assert data[0][0] == 0.0 and data[-1][0] == 1.0
    iq = header.index("spring.q")
    assert data[0][iq] == 0.1
    assert data[-1][iq] == pytest.approx(msd_free_response(1.0)[0], abs=1e-7)


def test_show_prints_states_and_equations(runs):
    run = runs["show"]
    assert run.returncode == 0, run.stderr
    out = run.stdout
    assert "states:" in out
    assert "winding_inductance.p" in out and "rotor.p" in out
    assert "d(rotor.p)/dt" in out and "d(winding_inductance.p)/dt" in out
    assert "k_m" in out and "motor.p2 -> shaft" in out
    assert "P_in" in out and "P_diss" in out


@pytest.mark.parametrize("backend, marks", [
    ("c", ["PH_HIDDEN void rhs(double t, const double *x, const double *p, double *out)",
           " *   [1] spring.q", "PH_EXPORT int ph_integrate_rodas5p("]),
    ("python", ['"""Generated by porthamiltonian', "def rhs(t, x, p):", "\n  [1] spring.q\n",
                "def integrate_rodas4("])])
def test_show_code_prints_the_generated_source(backend, marks, capsys):
    """``show MODEL --code --backend B``: the source the back end compiles (the Python module's
    docstring first), the state order by name in its header, the integration loops included."""
    assert main(["show", "mass_spring_damper", "--code", "--backend", backend]) == 0
    out = capsys.readouterr().out
    for mark in marks:
        assert mark in out, mark


def test_check_energy_passes_on_shipped_models(energy_check):
    run = energy_check.run
    assert run.returncode == 0, run.stdout + run.stderr
    for name in io.available_models():
        assert f"ok   {name}" in run.stdout


def test_check_energy_fails_naming_the_model_with_impossible_tolerance(runs):
    """A copy of mass_spring_damper asking for energy_tolerance = 1e-30 (below round-off)."""
    run = runs["impossible"]
    assert run.returncode == 1, run.stdout + run.stderr
    assert "FAIL" in run.stdout and "impossible_msd" in run.stdout
    assert "energy check failed for" in run.stdout


def test_unknown_model_exits_2_with_message(runs):
    run = runs["unknown_model"]
    assert run.returncode == 2
    assert "no_such_model" in run.stderr and "mass_spring_damper" in run.stderr
    assert "Traceback" not in run.stderr


def test_the_console_scripts_freeze_what_is_alive_before_the_exit(monkeypatch, capsys):
    """``porthamiltonian`` and ``walker`` (the console scripts, ``python -m``) return main's exit
    status with the objects still alive frozen for the collector, which the interpreter's exit
    then does not traverse."""
    import gc

    from porthamiltonian.interfaces import cli
    from walker_library import cli as walker_cli

    for script, argv in ((cli.command, ["porthamiltonian", "simulate", "no_such_model"]),
                         (walker_cli.command, ["walker", "gait", "no_such_walker"])):
        monkeypatch.setattr(sys, "argv", argv)
        alive = [[]]
        alive[0].append(alive)                  # a cycle: only the collector frees it
        before = gc.get_freeze_count()
        assert script() == 2
        assert gc.get_freeze_count() > before
        assert "error: " in capsys.readouterr().err


def test_simulate_method_replaces_the_files(capsys):
    """`simulate --method Rodas5P` on the Kelvin-Voigt ball (its file names Radau) is the
    Python API's Rodas5P run at the file's tolerances, number for number; an unknown method is
    refused by the argument parser (exit status 2)."""
    from porthamiltonian import compile_model

    status = main(["--backend", "c", "simulate", "bouncing_ball_kelvin_voigt", "--method",
                   "Rodas5P", "--json"])
    out = json.loads(capsys.readouterr().out)
    ball = compile_model(io.load("bouncing_ball_kelvin_voigt"), backend="c")
    ref = ball.simulate(1.5, method="Rodas5P", rtol=1e-9, atol=1e-12)
    assert status == 0 and out["nfev"] == ref.nfev
    assert list(out["final_state"].values()) == ref.x_final.tolist()
    with pytest.raises(SystemExit) as info:
        main(["simulate", "bouncing_ball_kelvin_voigt", "--method", "rodas"])
    assert info.value.code == 2 and "invalid choice: 'rodas'" in capsys.readouterr().err


def test_the_files_initial_state_is_the_runs(tmp_path, capsys):
    """``[simulation] initial`` starts ``simulate`` (and check-energy, sweep, view, export-fmu)
    from those state values (it was read, checked for its type and then ignored: the run
    started from the components' initial values)."""
    path = tmp_path / "msd.toml"
    path.write_text(MSD_TEXT.replace("atol = 1e-12", 'atol = 1e-12\ninitial = { "spring.q" = 0.5 }'))
    assert main(["--backend", "python", "simulate", str(path), "--t-end", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["energy"]["H0"] == pytest.approx(0.5 * 4.0 * 0.5**2, rel=1e-12)   # k q^2 / 2


def test_names_the_model_lacks_in_the_simulation_table_exit_2_with_their_lines(tmp_path, capsys):
    """A state of ``[simulation] initial`` or an input of ``inputs`` that the model does not have
    is refused before any run, every one with its line (both used to be ignored silently)."""
    initial, inputs = 'initial = { "spring.x" = 0.5 }', "inputs = { u = 1.0 }"
    text = MSD_TEXT.replace("atol = 1e-12", f"atol = 1e-12\n{initial}\n{inputs}")
    path = tmp_path / "msd.toml"
    path.write_text(text)
    lines = text.splitlines()
    for command in (["simulate", str(path), "--t-end", "1"],
                    ["export-fmu", str(path), "--out", str(tmp_path / "msd.fmu")]):
        assert main(["--backend", "python", *command]) == 2
        assert capsys.readouterr().err.splitlines() == [
            f"error: {path}: 2 problems:",
            (f"  line {lines.index(initial) + 1}: [simulation] initial: model "
             "'mass_spring_damper' has no state 'spring.x'; its states: mass.p, spring.q"),
            (f"  line {lines.index(inputs) + 1}: [simulation] inputs: model "
             "'mass_spring_damper' has no input 'u'; its inputs: none")]
    assert not (tmp_path / "msd.fmu").exists()


def _strict_json(text: str) -> dict:
    """``text`` parsed as JSON proper: NaN and Infinity (Python's extensions) refused."""
    def refuse(constant: str) -> None:
        raise AssertionError(f"{constant} in the JSON output")
    return json.loads(text, parse_constant=refuse)


def test_json_of_a_run_that_overflowed_is_json(capsys):
    """`simulate --json` and `linearize --json` printed NaN and Infinity (not JSON: strict
    parsers refuse the document) when a run or a point overflowed (x0 = 1e308: an infinite
    energy; k = 1e300: |dx/dt| beyond the float range); they print null there, as the walker
    commands and `fit --json` do."""
    from porthamiltonian.interfaces import cli

    assert main(["--backend", "python", "simulate", "mass_spring_damper", "--set", "x0=1e308",
                 "--t-end", "1", "--json"]) == 1
    out, err = capsys.readouterr()
    assert "warning" not in err, err          # numpy's about inf - inf in the residual
    energy = _strict_json(out)["energy"]
    assert energy["H0"] is None and energy["relative_residual"] is None
    assert cli.main(["--backend", "python", "linearize", "mass_spring_damper", "--set",
                     "k=1e300", "--json"]) == 0
    output, err = capsys.readouterr()
    out = _strict_json(output)
    assert out["eigenvalues"][1] == [pytest.approx(-0.2), pytest.approx(1e150)]
    # |dx/dt| = k x0 = 1e299: numpy's norm squared it to inf, with an overflow warning
    assert out["xdot_norm"] == pytest.approx(1e299, rel=1e-12) and "warning" not in err, err


# The remaining bad-input checks call the entry point in-process (``main`` returns the exit status
# that ``python -m porthamiltonian.interfaces.cli`` exits with), saving an interpreter start-up each.
def test_set_without_equals_exits_2_with_message(capsys):
    status = main(["--backend", "python", "simulate", "mass_spring_damper", "--t-end", "1",
                   "--set", "k"])
    err = capsys.readouterr().err
    assert status == 2
    assert "NAME=VALUE" in err and "'k'" in err


def test_set_unknown_parameter_exits_2_naming_it(capsys):
    status = main(["--backend", "python", "simulate", "mass_spring_damper", "--t-end", "1",
                   "--set", "kk=3"])
    err = capsys.readouterr().err
    assert status == 2
    assert "'kk'" in err and "mass_spring_damper" in err


def test_set_non_numeric_value_exits_2_naming_it(capsys):
    status = main(["--backend", "python", "simulate", "mass_spring_damper", "--t-end", "1",
                   "--set", "k=stiff"])
    err = capsys.readouterr().err
    assert status == 2
    assert "'stiff'" in err and "k" in err


def test_plain_text_summary(capsys):
    status = main(["--backend", "python", "simulate", "rlc_circuit", "--t-end", "0.05"])
    out = capsys.readouterr().out
    assert status == 0
    assert "rlc_circuit: finished" in out
    assert "capacitor.q" in out and "inductor.p" in out and "residual" in out
    units = {ln.split()[0]: ln.split()[-1] for ln in out.splitlines() if ln.startswith("  ")}
    assert units["capacitor.q"] == "A*s" and units["inductor.p"] == "V*s"   # charge, flux linkage

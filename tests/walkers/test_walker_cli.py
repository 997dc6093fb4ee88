"""The ``walker`` command and the walker model files (models/simplest_walker.toml, ...; a model plus
its ``[walker]`` table, docs/walkers.md).

The fields checked are those the walker JSON promises (docs/walkers.md): status, period_steps,
fixed_point (with theta, theta_dot, phi, phi_dot for legged walkers), floquet_multipliers as {re, im}, step_period, step_length, speed,
energy_dissipated_per_step, max_theta, max_phi. Values are checked in test_rigid_walkers.py.
"""
from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from porthamiltonian import io
from porthamiltonian.errors import ModelFileError
from walker_library import analyze_gait, available_walkers, load_walker
from walker_library.cli import main

MODELS = Path(io.__file__).resolve().parents[2] / "models"
WALKERS = ["simplest_walker", "compass_gait", "rimless_wheel"]
LEGGED = {"simplest_walker", "compass_gait"}


def _check_gait_json(name: str, d: dict) -> None:
    assert d["status"] in ("periodic", "fell", "no_fixed_point")
    assert isinstance(d["period_steps"], int)
    assert isinstance(d["fixed_point"], dict)
    if name in LEGGED:
        assert {"theta", "theta_dot", "phi", "phi_dot"} <= set(d["fixed_point"])
        assert "max_theta" in d and "max_phi" in d
    assert all(isinstance(m, dict) and set(m) == {"re", "im"} for m in d["floquet_multipliers"])
    for key in ("step_period", "step_length", "speed", "energy_dissipated_per_step"):
        assert isinstance(d[key], (int, float)), key


@pytest.mark.parametrize("name", WALKERS)
def test_walker_gait_json_fields(name, capsys):
    """``walker gait MODEL --json`` prints one JSON document with the named fields; the shipped
    models all walk periodically (status "periodic", period 1, stable)."""
    assert main(["gait", name, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    _check_gait_json(name, d)
    assert d["status"] == "periodic" and d["period_steps"] == 1 and d["stable"]


def test_walker_gait_set_changes_parameters(capsys):
    """--set slope=... is applied (the compass gait at 2°: a shorter step than at 3°)."""
    assert main(["gait", "compass_gait", "--set", "slope=0.0349066", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["parameters"]["slope"] == pytest.approx(0.0349066)
    assert d["status"] == "periodic" and d["fixed_point"]["theta"] < 0.271


@pytest.mark.parametrize("args,message", [
    (["gait", "simplest_walker", "--set", "slope=2"], "slope"),
    (["gait", "simplest_walker", "--set", "wobble=1"], "wobble"),
    (["gait", "simplest_walker", "--set", "slope"], "NAME=VALUE"),
    (["gait", "no_such_walker"], "no_such_walker"),
    (["gait", "pendulum"], "not a walker file"),
])
def test_walker_bad_input_exits_2_with_a_message(args, message, capsys):
    assert main(args) == 2
    assert message in capsys.readouterr().err


def test_walker_gait_text_output_and_fall(capsys):
    """Human-readable output; a walker that falls is a result (exit 0), with the step."""
    assert main(["gait", "simplest_walker", "--set", "slope=0"]) == 0
    out = capsys.readouterr().out
    assert "fell" in out and "step 2" in out


def test_walker_walk_reports_the_ledger(capsys):
    assert main(["walk", "rimless_wheel", "--steps", "5", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["steps_taken"] == 5 and not d["fell"]
    assert d["relative_energy_residual"] < 1e-10


def test_console_script_runs():
    """The installed ``walker`` script (pyproject [project.scripts]) answers like ``main``."""
    exe = shutil.which("walker")
    assert exe, "the `walker` script is installed by the README's install command (pip install -e .)"
    proc = subprocess.run([exe, "gait", "rimless_wheel", "--json"], capture_output=True, text=True,
                          timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr
    _check_gait_json("rimless_wheel", json.loads(proc.stdout))


# --- model files -------------------------------------------------------------------------------
def test_shipped_walker_files_are_found_and_export_round_trips(tmp_path, capsys):
    """models/ holds the walker files; ``walker export`` writes a walker's file (with --set
    values) that loads back to the same description and model, with the new values."""
    assert set(WALKERS) <= set(available_walkers())
    for name in WALKERS:
        out = tmp_path / f"{name}.toml"
        assert main(["export", name, str(out), "--set", "slope=0.05"]) == 0
        again, original = load_walker(out), load_walker(name)
        assert again.spec == original.spec
        assert io.model_to_dict(again.spec.model)["components"] == \
            io.model_to_dict(original.spec.model)["components"]
        assert again.parameters == {**original.parameters, "slope": 0.05}


@pytest.mark.parametrize("name", WALKERS)
def test_walker_files_load_as_walkers_and_as_porthamiltonian_models(name):
    """A walker file is both: load_walker builds the walker from it; porthamiltonian.interfaces.io loads the
    model (the same components, and the [walker] table kept for saving back)."""
    walker = load_walker(name)
    record = io.read(name)
    assert (io.model_to_dict(record.model)["components"]
            == io.model_to_dict(walker.spec.model)["components"])
    assert walker.name == name and "walker" in record.sections


def test_walker_file_parameters_overrides_and_edited_components(tmp_path):
    """Parameter values in the file are used; overrides win; an edited component is the walker
    (the compass gait with its hip mass doubled walks another gait: Goswami's gait depends on the
    mass ratio m_H / m)."""
    text = (MODELS / "simplest_walker.toml").read_text()
    path = tmp_path / "steeper.toml"
    path.write_text(text.replace("slope = { value = 0.009,", "slope = { value = 0.012,", 1))
    assert load_walker(path).parameters["slope"] == pytest.approx(0.012)
    assert load_walker(path, {"slope": 0.01}).parameters["slope"] == pytest.approx(0.01)
    original = (MODELS / "compass_gait.toml").read_text()
    edited = tmp_path / "heavy_hip.toml"
    heavier = original.replace('mass = "m_H"', 'mass = "2*m_H"', 1)
    edited.write_text(heavier)
    with pytest.raises(ModelFileError, match=r"\[walker\] mass gives 20 kg .* weigh 30 kg"):
        load_walker(edited)                # the walker's weight must follow the bodies'
    edited.write_text(heavier.replace('mass = "m_H + 2*m"', 'mass = "2*m_H + 2*m"', 1))
    a, b = analyze_gait(load_walker("compass_gait")), analyze_gait(load_walker(edited))
    assert a.status == b.status == "periodic"
    assert abs(a.fixed_point["theta"] - b.fixed_point["theta"]) > 1e-3

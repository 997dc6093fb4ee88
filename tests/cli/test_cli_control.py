"""``porthamiltonian linearize`` and ``porthamiltonian show --ph`` as a user runs them (through
``main``, python back end)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from porthamiltonian import io
from porthamiltonian.errors import ModelFileError
from porthamiltonian.interfaces.cli import main


def _run(capsys, *args: str) -> tuple[int, str, str]:
    status = main(["--backend", "python", *args])
    out = capsys.readouterr()
    return status, out.out, out.err


def test_linearize_json_at_the_files_operating_point(capsys):
    """cart_pole's [linearize] table (trim from θ = 0): JSON with A, B, C, D (nested lists),
    states, inputs, outputs (names) and eigenvalues ([re, im]: a pair ±λ and two zeros); |ẋ|
    there 0."""
    status, out, _ = _run(capsys, "linearize", "cart_pole", "--json")
    assert status == 0
    data = json.loads(out)
    for key in ("A", "B", "C", "D", "states", "inputs", "outputs", "eigenvalues"):
        assert key in data
    assert data["inputs"] == ["F"] and data["outputs"] == ["x", "theta"]
    assert np.array(data["A"]).shape == (4, 4) and np.array(data["B"]).shape == (4, 1)
    assert np.array(data["C"]).shape == (2, 4) and np.array(data["D"]).shape == (2, 1)
    re = sorted(v[0] for v in data["eigenvalues"])
    assert re[0] < 0 < re[-1] and re[0] == pytest.approx(-re[-1])
    assert data["trim"]["trim"] is True and data["xdot_norm"] < 1e-12


def test_linearize_at_a_given_point_and_parameters(capsys):
    """--at and --set: the pendulum at θ = π (trimmed), l = 2: A = [[0, 1/(m l²)], [m g l, 0]]."""
    status, out, _ = _run(capsys, "linearize", "pendulum", "--at", "pendulum.q.pivot=3.1",
                          "--trim", "--set", "l=2", "--json")
    assert status == 0
    data = json.loads(out)
    np.testing.assert_allclose(data["A"], [[0, 0.25], [9.81 * 2, 0]], atol=1e-10)
    assert data["x"]["pendulum.q.pivot"] == pytest.approx(np.pi, abs=1e-12)


def test_linearize_text_and_errors(capsys):
    status, out, _ = _run(capsys, "linearize", "mass_spring_damper")
    assert status == 0 and "A =" in out and "eigenvalues of A" in out
    status, _, err = _run(capsys, "linearize", "pendulum", "--at", "arm.q=1")
    assert status == 2 and "not a state or an input" in err and "pendulum.q.pivot" in err
    status, _, err = _run(capsys, "linearize", "pendulum", "--at", "pendulum.q.pivot")
    assert status == 2 and "--at takes NAME=VALUE" in err


def test_show_ph_prints_the_structure(capsys):
    """The DC motor: the gyrator's coupling appears in J, the resistances in R, the voltage
    source as a port."""
    status, out, _ = _run(capsys, "show", "dc_motor", "--ph")
    assert status == 0
    assert out.startswith("port-Hamiltonian form of model 'dc_motor'")
    assert "J:" in out and "R:" in out and "port " in out


def test_model_file_inputs_and_linearize_round_trip():
    """[inputs] (with a binding) and [linearize] survive dumps/reads."""
    record = io.read("cart_pole")
    model = record.model
    model.input("G", "N", "a second force", bind="2*t")
    text = io.dumps(io.ModelFile(model, linearize=record.linearize,
                                 simulation=record.simulation))
    again = io.reads(text)
    assert again.model.inputs["F"].unit == "N" and again.model.inputs["G"].bind == "2*t"
    assert again.linearize == record.linearize


def test_model_file_input_errors_name_the_line():
    text = io.model_path("cart_pole").read_text().replace(
        'F = { unit = "N", doc = "horizontal force on the cart" }',
        'F = { unit = "N", dock = "typo" }')
    with pytest.raises(ModelFileError, match=r"line \d+: input 'F': unknown key 'dock'"):
        io.reads(text)

"""Model files (models/*.toml): loading by name and path, lossless round trips, and malformed files
raising ModelFileError that names the file and the offending component or line."""
from __future__ import annotations

from pathlib import Path

import pytest

from porthamiltonian import compile_model, io, symbolic
from porthamiltonian.errors import ModelFileError

MODELS_DIR = Path(io.__file__).resolve().parents[2] / "models"
MSD_TEXT = (MODELS_DIR / "mass_spring_damper.toml").read_text()


def _line_of(text: str, needle: str) -> int:
    return next(i for i, line in enumerate(text.splitlines(), 1) if needle in line)


@pytest.mark.parametrize("name", io.available_models())
def test_model_file_round_trips_text_and_equations(name):
    """dumps(load(name)) loaded again dumps to the same text and compiles to the same state
    equations, Hamiltonian, dissipated and supplied power."""
    original = io.read(name)
    text = io.dumps(original)
    again = io.reads(text, source=f"{name} (dumped)")
    assert io.dumps(again) == text
    a, b = symbolic(original.model), symbolic(again.model)
    assert a.state_names == b.state_names
    assert a.param_names == b.param_names and a.param_defaults == b.param_defaults
    assert a.equations == b.equations
    assert a.hamiltonian == b.hamiltonian and a.p_diss == b.p_diss and a.p_in == b.p_in
    assert again.simulation == original.simulation


def test_save_then_load_from_path(tmp_path):
    model = io.load("dc_motor")
    path = tmp_path / "motor_copy.toml"
    io.save(model, path)
    loaded = io.load(path)
    assert io.dumps(loaded) == io.dumps(model)
    assert symbolic(loaded).equations == symbolic(model).equations


def test_load_by_name_and_by_path_agree():
    by_name = io.load("rlc_circuit")
    by_path = io.load(MODELS_DIR / "rlc_circuit.toml")
    by_str_path = io.load(str(MODELS_DIR / "rlc_circuit.toml"))
    assert io.dumps(by_name) == io.dumps(by_path) == io.dumps(by_str_path)
    assert by_name.name == "rlc_circuit"


def test_models_folder_from_environment(tmp_path, monkeypatch):
    """$PORTHAMILTONIAN_MODELS is searched before the shipped models/ folder."""
    (tmp_path / "my_oscillator.toml").write_text(
        MSD_TEXT.replace('name = "mass_spring_damper"', 'name = "my_oscillator"'))
    monkeypatch.setenv("PORTHAMILTONIAN_MODELS", str(tmp_path))
    assert "my_oscillator" in io.available_models()
    assert io.load("my_oscillator").name == "my_oscillator"
    assert "mass_spring_damper" in io.available_models()


def test_unknown_model_name_lists_available_models():
    with pytest.raises(ModelFileError) as info:
        io.load("no_such_model")
    msg = str(info.value)
    assert "'no_such_model'" in msg and "mass_spring_damper" in msg


def test_missing_model_path():
    with pytest.raises(ModelFileError, match="does_not_exist.toml"):
        io.load("/tmp/does_not_exist.toml")


def test_shipped_models_compile_with_expected_states(compile_named):
    expected = {
        "mass_spring_damper": {"mass.p", "spring.q"},
        "rlc_circuit": {"inductor.p", "capacitor.q"},
        "dc_motor": {"winding_inductance.p", "rotor.p"},
        "lc_oscillator": {"inductor.p", "capacitor.q"},
        "modulated_spring": {"mass.p", "spring.q"},
    }
    for name, states in expected.items():
        assert set(compile_named(name).state_names) == states


# --- malformed files --------------------------------------------------------------------------
def _write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def test_toml_syntax_error_names_file_and_line(tmp_path):
    text = MSD_TEXT.replace("[components.damper]", "[components.damper")
    path = _write(tmp_path, "syntax", text)
    with pytest.raises(ModelFileError) as info:
        io.load(path)
    msg = str(info.value)
    assert str(path) in msg
    assert f"line {_line_of(text, '[components.damper')}" in msg


def test_unknown_component_type_names_file_component_and_line(tmp_path):
    text = MSD_TEXT.replace('type = "R"', 'type = "Damper"')
    path = _write(tmp_path, "unknown_type", text)
    with pytest.raises(ModelFileError) as info:
        io.load(path)
    msg = str(info.value)
    assert str(path) in msg and "'damper'" in msg and "'Damper'" in msg
    n = _line_of(text, 'type = "Damper"')
    assert f"line {n}" in msg


def test_unknown_parameter_in_expression_names_file_and_component(tmp_path):
    """A misspelt parameter (``cc`` for ``c``) in a component's law is a file error naming the
    file, the component and the name: at load time, or at the latest when the model compiles."""
    text = MSD_TEXT.replace('resistance = "c"', 'resistance = "cc"')
    path = _write(tmp_path, "unknown_param", text)
    with pytest.raises(ModelFileError) as info:
        compile_model(io.load(path), backend="python")
    msg = str(info.value)
    assert str(path) in msg and "'damper'" in msg and "cc" in msg


def test_bad_bond_syntax_names_file_bond_and_line(tmp_path):
    text = MSD_TEXT.replace('"j -> damper.p"', '"j.p => damper.p"')
    path = _write(tmp_path, "bad_bond", text)
    with pytest.raises(ModelFileError) as info:
        io.load(path)
    msg = str(info.value)
    assert str(path) in msg and "j.p => damper.p" in msg
    assert f"line {_line_of(text, '=>')}" in msg


def test_bond_to_unknown_port_names_file_component_and_port(tmp_path):
    text = MSD_TEXT.replace('"j -> damper.p"', '"j -> damper.q"')
    path = _write(tmp_path, "unknown_port", text)
    with pytest.raises(ModelFileError) as info:
        io.load(path)
    msg = str(info.value)
    assert str(path) in msg and "'damper'" in msg and "'q'" in msg
    assert f"line {_line_of(text, 'damper.q')}" in msg


def test_unknown_section_names_file(tmp_path):
    path = _write(tmp_path, "unknown_section", MSD_TEXT + "\n[solver]\nmethod = 'Radau'\n")
    with pytest.raises(ModelFileError, match="solver") as info:
        io.load(path)
    assert str(path) in str(info.value)


def test_bad_simulation_key_names_file(tmp_path):
    path = _write(tmp_path, "bad_sim", MSD_TEXT.replace("t_end = 20.0", "tend = 20.0"))
    with pytest.raises(ModelFileError, match=r"\[simulation\]") as info:
        io.load(path)
    assert str(path) in str(info.value)


def test_loads_names_its_source():
    with pytest.raises(ModelFileError, match="<my text>"):
        io.loads("[model\n", source="<my text>")

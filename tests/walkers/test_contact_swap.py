"""Swapping a walker's contact law by editing its model file (docs/walkers.md, docs/model-files.md):
the two feet's contact lines of models/compass_walker.toml (HuntCrossley3D in the x-z plane, the
rolling arc feet) become Kelvin–Voigt contacts (KelvinVoigt3D, linear damping B_contact = 1e3
N·s/m, calibrated the thesis's way: walker_library.analyses.calibration), and one parameter line declares
B_contact.

Measured (γ = 0.009, B = 1e3 N·s/m; legs as rods, the rolling contact): the walker walks from
the Hunt–Crossley walker's initial guess, and analyze_gait finds a stable period-1 gait (Newton
from the guess does not converge; iterating the stride map does): step period 1.0125 s, step
length 0.3076 m, speed 0.3038 m/s, 0.0874 J per step (= the potential released), Floquet
multipliers −0.102 ± 0.244i (|λ| = 0.264) and four below 3e-3 — within 1 % of the Hunt–Crossley
walker's gait. (Point-mass legs and the sole-point friction gave 1.007 s, 0.307 m, 0.305 m/s,
0.0872 J, −0.089 ± 0.262i.)

The Kelvin–Voigt model compiles once (numba ≈ 30 s, cached on disk); the module fixture builds it
once.
"""
from __future__ import annotations

import difflib
import math
from pathlib import Path

import numpy as np
import pytest

from porthamiltonian import io
from porthamiltonian.errors import ModelFileError
from walker_library import analyze_gait, load_walker, save_walker

ORIGINAL = Path(io.__file__).resolve().parents[2] / "models" / "compass_walker.toml"
B_CONTACT = 1.0e3


def kelvin_voigt(text: str) -> str:
    """The file with both feet's Hunt–Crossley lines made Kelvin–Voigt and B_contact declared."""
    for k in (1, 2):
        geometry = f'plane = "xz", x = "walker.c{k}.x", z = "walker.c{k}.z", radius = "R", '
        text = text.replace(
            f'floor{k} = {{ type = "HuntCrossley3D", {geometry}stiffness = "K", damping = "lam", '
            'exponent = 1,',
            f'floor{k} = {{ type = "KelvinVoigt3D", {geometry}stiffness = "K", '
            'damping = "B_contact",', 1)
    line = 'lam = { value = 3.16e7'
    i = text.index(line)
    return (text[:i] + f'B_contact = {{ value = {B_CONTACT}, unit = "N*s/m", doc = "Kelvin-Voigt '
            'contact damping (calibrated the thesis\'s way)" }\n' + text[i:])


def _changed(a: str, b: str) -> list[str]:
    return [ln for ln in difflib.unified_diff(a.splitlines(), b.splitlines(), lineterm="", n=0)
            if ln[:1] in "+-" and not ln.startswith(("+++", "---"))]


@pytest.fixture(scope="module")
def swapped(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("swap") / "compass_walker_kelvin_voigt.toml"
    path.write_text(kelvin_voigt(ORIGINAL.read_text()))
    return path


@pytest.fixture(scope="module")
def walker(swapped):
    return load_walker(swapped)


@pytest.fixture(scope="module")
def gait(walker):
    return analyze_gait(walker)


def test_the_swap_is_three_lines(swapped):
    """Two contact lines changed and one parameter line added; nothing else."""
    changed = _changed(ORIGINAL.read_text(), swapped.read_text())
    assert len([ln for ln in changed if ln.startswith("-")]) == 2
    assert len([ln for ln in changed if ln.startswith("+")]) == 3
    assert all("floor" in ln for ln in changed if ln.startswith("-"))


def test_both_feet_get_kelvin_voigt_contacts(walker):
    model = walker.spec.model
    for k in (1, 2):
        floor = model.component(f"floor{k}")
        assert floor.kind == "KelvinVoigt3D"
        assert floor.args["damping"] == "B_contact" and floor.args["stiffness"] == "K"
        assert model.component(f"fric{k}").kind == "SCVSFriction3D"
    assert [f.contact for f in walker.spec.feet] == ["floor1", "floor2"]
    assert walker.parameters["B_contact"] == B_CONTACT
    assert walker.parameters["lam"] == 3.16e7 and walker.parameters["slope"] == 0.009


def test_walks_five_steps_with_a_closed_ledger(walker):
    steps = walker.walk(walker.initial_guess(), 5)
    assert [s.status for s in steps] == ["step"] * 5
    assert abs(sum(s.energy_residual for s in steps)) < 1e-6          # J, the whole run
    assert max(abs(s.energy_residual) for s in steps) < 1e-6
    assert all(0.29 < s.step_length < 0.32 for s in steps)


def test_stable_period_one_gait(walker, gait):
    assert gait.status == "periodic" and gait.period_steps == 1 and gait.stable
    assert np.abs(np.array(gait.floquet_multipliers)).max() < 0.5
    m = gait.metrics
    assert m.step_period == pytest.approx(1.0125, rel=0.02)
    assert m.step_length == pytest.approx(0.3076, rel=0.02)
    assert m.energy_dissipated_per_step == pytest.approx(m.potential_released_per_step, rel=1e-5)
    assert m.cost_of_transport == pytest.approx(math.sin(walker.parameters["slope"]), rel=1e-4)
    z = np.array([gait.fixed_point[k] for k in walker.section])
    steps = walker.walk(z, 5)
    assert [s.status for s in steps] == ["step"] * 5
    assert abs(sum(s.energy_residual for s in steps)) < 1e-6
    assert np.abs(steps[-1].z_next - z).max() < 1e-5


def test_save_and_reload_keep_the_swap(walker, tmp_path):
    again = load_walker(save_walker(walker, tmp_path / "kv.toml"))
    assert again.spec == walker.spec
    assert io.model_to_dict(again.spec.model)["components"] == \
        io.model_to_dict(walker.spec.model)["components"]
    assert again.parameters == walker.parameters


def test_a_misspelt_contact_law_names_the_file_and_line(tmp_path):
    bad = tmp_path / "hertz.toml"
    text = ORIGINAL.read_text().replace('floor1 = { type = "HuntCrossley3D"',
                                        'floor1 = { type = "HuntCrosley3D"', 1)
    bad.write_text(text)
    line = next(i for i, ln in enumerate(text.splitlines(), 1) if "HuntCrosley" in ln)
    with pytest.raises(ModelFileError) as err:
        load_walker(bad)
    msg = str(err.value)
    assert msg.startswith(f"{bad}, line {line}:") and "'HuntCrossley3D'" in msg

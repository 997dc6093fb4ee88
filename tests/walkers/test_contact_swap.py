"""Swapping a walker's contact law by one line of its model file (docs/model-files.md, "Swapping
a contact law"): ``contact = "KelvinVoigt"`` under ``[model.walker]`` of models/compass_walker.toml
makes both feet's contacts Kelvin–Voigt (linear damping B_contact = 1e3 N·s/m, calibrated the
thesis's way: walker_library.compliant.contact_specs).

Measured (γ = 0.009, B = 1e3 N·s/m): the walker walks from the Hunt–Crossley walker's initial
guess, and analyze_gait finds a stable period-1 gait (Newton from the guess does not converge;
iterating the stride map does): step period 1.007 s, step length 0.307 m, speed 0.305 m/s,
0.0872 J per step (= the potential released), Floquet multipliers −0.089 ± 0.262i (|λ| = 0.276)
and four below 3e-3 — within 1 % of the Hunt–Crossley walker's gait.

The Kelvin–Voigt model compiles with numba once (≈ 30 s, cached on disk); the module fixture
builds it once.
"""
from __future__ import annotations

import difflib
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from porthamiltonian import io
from porthamiltonian.errors import ModelFileError, ParameterValueError
from walker_library import analyze_gait, load_walker
from walker_library.compliant import B_CONTACT, CONTACT_KINDS
from walker_library.walkers import export_model_file

ORIGINAL = Path(io.__file__).resolve().parent.parent / "models" / "compass_walker.toml"
SWAP = 'contact = "KelvinVoigt"'


def _with_line(text: str, line: str, after: str = 'builder = "compass_walker"') -> str:
    lines = text.splitlines(keepends=True)
    i = lines.index(after + "\n")
    return "".join(lines[:i + 1] + [line + "\n"] + lines[i + 1:])


def _changed(a: str, b: str) -> list[str]:
    return [ln for ln in difflib.unified_diff(a.splitlines(), b.splitlines(), lineterm="", n=0)
            if ln[:1] in "+-" and not ln.startswith(("+++", "---"))]


@pytest.fixture(scope="module")
def swapped(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("swap") / "compass_walker_kelvin_voigt.toml"
    path.write_text(_with_line(ORIGINAL.read_text(), SWAP))
    return path


@pytest.fixture(scope="module")
def walker(swapped):
    return load_walker(swapped, backend=None)         # numba, the builder's default


@pytest.fixture(scope="module")
def gait(walker):
    return analyze_gait(walker)


def test_the_swap_is_one_added_line(swapped):
    assert _changed(ORIGINAL.read_text(), swapped.read_text()) == ["+" + SWAP]
    assert tomllib.loads(swapped.read_text())["model"]["walker"] == {
        "builder": "compass_walker", "contact": "KelvinVoigt"}


def test_both_feet_get_kelvin_voigt_contacts(walker):
    assert walker.contact == "KelvinVoigt"
    assert walker.builder_options == {"contact": "KelvinVoigt"}
    for k in (1, 2):
        floor = walker.swing_model.component(f"floor{k}")
        assert floor.kind == "KelvinVoigt"
        assert floor.args["damping"] == "B_contact" and floor.args["stiffness"] == "K"
        assert walker.swing_model.component(f"fric{k}").kind == "SCVSFriction"
    # the file's parameters are kept (lam stays, unused); B_contact takes its calibrated default
    assert walker.parameters["B_contact"] == B_CONTACT == 1e3
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
    assert m.step_period == pytest.approx(1.007, rel=0.02)
    assert m.step_length == pytest.approx(0.307, rel=0.02)
    assert m.energy_dissipated_per_step == pytest.approx(m.potential_released_per_step, rel=1e-5)
    assert m.cost_of_transport == pytest.approx(math.sin(walker.parameters["slope"]), rel=1e-4)
    z = np.array([gait.fixed_point[k] for k in walker.section])
    steps = walker.walk(z, 5)
    assert [s.status for s in steps] == ["step"] * 5
    assert abs(sum(s.energy_residual for s in steps)) < 1e-6
    assert np.abs(steps[-1].z_next - z).max() < 1e-5


def test_export_writes_the_option_and_reloads(walker, tmp_path):
    out = export_model_file(walker, tmp_path / "kv.toml")
    data = tomllib.loads(out.read_text())
    assert data["model"]["walker"] == {"builder": "compass_walker", "contact": "KelvinVoigt"}
    assert data["components"]["floor1"]["type"] == "KelvinVoigt"
    assert data["parameters"]["B_contact"]["value"] == B_CONTACT
    again = load_walker(out, backend=None)                 # components check: same as builder's
    assert again.contact == "KelvinVoigt" and again.parameters == walker.parameters


def test_a_changed_mechanism_is_still_refused(swapped, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(swapped.read_text().replace('stiffness = "K"', 'stiffness = "2*K"', 1))
    with pytest.raises(ModelFileError, match="differ from what the builder 'compass_walker' "
                                             "generates with contact = 'KelvinVoigt'"):
        load_walker(bad, backend=None)


def test_unknown_option_names_file_option_and_allowed(tmp_path):
    bad = tmp_path / "typo.toml"
    bad.write_text(_with_line(ORIGINAL.read_text(), 'contacts = "KelvinVoigt"'))
    with pytest.raises(ModelFileError) as err:
        load_walker(bad, backend=None)
    msg = str(err.value)
    assert str(bad) in msg and "'contacts'" in msg and "contact (default 'HuntCrossley')" in msg


def test_rigid_walker_has_no_options(tmp_path):
    src = ORIGINAL.parent / "simplest_walker.toml"
    bad = tmp_path / "simplest.toml"
    bad.write_text(_with_line(src.read_text(), SWAP, after='builder = "simplest_walker"'))
    with pytest.raises(ModelFileError, match="its options: none"):
        load_walker(bad)


def test_unknown_contact_kind_lists_the_kinds(tmp_path):
    bad = tmp_path / "hertz.toml"
    bad.write_text(_with_line(ORIGINAL.read_text(), 'contact = "Hertz"'))
    with pytest.raises(ParameterValueError) as err:
        load_walker(bad, backend=None)
    msg = str(err.value)
    assert str(bad) in msg and "'Hertz'" in msg
    assert all(kind in msg for kind in CONTACT_KINDS)

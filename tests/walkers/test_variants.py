"""The thesis's recommendations (M. Jafarian 2010, MSc report 022CE2010, University of Twente,
§4.2) as walkers that are only files (docs/walkers.md):

* models/hip_and_leg_spring_walker.toml — the compliant-leg walker plus a torsional
  spring–damper between the legs (four lines more than compliant_leg_walker.toml);
* the foot radius R of the arc-foot walkers, a parameter (here compass_walker with R = 0.1 m);
* models/ankle_stiffness_walker.toml — feet on revolute ankles held by torsional springs;
* models/smooth_stiffness_walker.toml — the leg stiffness a smooth function of the leg angle.

For each: the gait search ends in a gait or a fall (results, not exceptions) — here a stable
period-1 gait for each — and the energy ledger closes over 10 steps walked from it (|H − H(0) +
E_diss − E_in| < 1e-7 J, the level of compass_walker's own check), with the energy dissipated
equal to the potential released plus the energy supplied by a modulated stiffness (relative
1e-5). Each walker compiles once (numba ≈ 30–90 s, cached for the session).
"""
from __future__ import annotations

import difflib
from pathlib import Path

import numpy as np
import pytest

from porthamiltonian import io
from walker_library import analyze_gait, load_walker, walk

MODELS = Path(io.__file__).resolve().parents[2] / "models"

VARIANTS = {
    "hip spring": ("hip_and_leg_spring_walker", {}),
    "foot radius": ("compass_walker", {"R": 0.1}),
    "ankle stiffness": ("ankle_stiffness_walker", {}),
    "smooth stiffness schedule": ("smooth_stiffness_walker", {}),
}


@pytest.fixture(scope="module", params=list(VARIANTS))
def variant(request):
    name, values = VARIANTS[request.param]
    w = load_walker(name, values)
    return request.param, w, analyze_gait(w)


def test_gait_and_ten_steps_with_a_closed_ledger(variant):
    label, w, gait = variant
    assert gait.status in ("periodic", "fell"), gait.message
    assert gait.status == "periodic" and gait.stable, (label, gait.message)
    z = np.array([gait.fixed_point[k] for k in w.section])
    result = walk(w, z, 10)
    assert result.steps_taken == 10 and not result.fell, label
    assert result.max_energy_residual < 1e-7, label
    strides = w.walk(z, 10)
    supplied = sum(s.info["energy_supplied"] for s in strides)
    assert result.energy_dissipated == pytest.approx(result.potential_released + supplied,
                                                     rel=1e-5), label
    assert np.max(np.abs(strides[-1].z_next - z)) < 1e-5, label


def test_the_hip_spring_is_four_lines_of_the_compliant_leg_walkers_file():
    """Besides the header comments and the description: the bonds of the hip junction, the hip
    stiffness, the junction and the spring (docs/walkers.md, the worked example)."""
    a = (MODELS / "compliant_leg_walker.toml").read_text().splitlines()
    b = (MODELS / "hip_and_leg_spring_walker.toml").read_text().splitlines()
    changed = [ln for ln in difflib.unified_diff(a, b, lineterm="", n=0)
               if ln[:1] in "+-" and not ln.startswith(("+++", "---", "+#", "-#"))
               and "description = " not in ln]
    assert changed == [
        '+    "walker.leg1 -> hip", "hip -> walker.leg2", "hip -> hip_spring.p",',
        ('+K_hip = { value = 0.1, unit = "N*m/rad", doc = "hip spring stiffness (torque per rad '
         'of phi; its damper: 0.05 s times it)" }'),
        '+hip = { type = "0" }',
        ('+hip_spring = { type = "SpringDamper", domain = "rotation", length = "walker.q.leg1 - '
         'walker.q.leg2", stiffness = "K_hip", damping = "0.05*K_hip" }'),
    ]


def test_the_hip_spring_changes_the_gait_and_vanishes_at_zero_stiffness():
    """Adding the spring is honoured: its gait is not the compliant-leg walker's; with K_hip = 0
    the model is the compliant-leg walker (one stride from the same state: the same next state to
    the integration tolerance)."""
    hip = load_walker("hip_and_leg_spring_walker")
    legs = load_walker("compliant_leg_walker")
    z = legs.initial_guess()
    a, b, c = legs.stride(z), hip.stride(z), hip.with_parameters(K_hip=0.0).stride(z)
    assert np.max(np.abs(a.z_next - b.z_next)) > 1e-3
    assert np.max(np.abs(a.z_next - c.z_next)) < 1e-6


def test_the_smooth_schedule_books_its_modulation_as_supplied_energy():
    """K changes with the leg angle while the stance spring is compressed: the ledger books
    ½ K̇ z² (the compiler's modulation power) as supplied energy, continuously (no jump)."""
    w = load_walker("smooth_stiffness_walker")
    s = w.stride(w.initial_guess(), record=True)
    traj = s.info["trajectory"]
    assert abs(s.info["energy_supplied"]) > 1e-4
    assert all(j == 0.0 for _, _, j in traj.jumps)
    K = traj["spring1.K"]
    P = w.parameters
    assert np.allclose(K, P["K_leg"] * (1 + P["kappa"] * np.tanh(traj["walker.q.leg1"]
                                                                 / P["angle_scale"])), rtol=1e-12)

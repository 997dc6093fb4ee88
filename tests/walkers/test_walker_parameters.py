"""One parameter system for a walker file (issue 21): the ``[walker.ranges]`` of a walker's
parameters agree with its components' constraints, ``[walker] mass`` is the bodies' total mass,
and a leg said to be a uniform rod stays one when its length changes.

Each bad file is a shipped file with one line changed, so the error must name that line."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from porthamiltonian import io
from porthamiltonian.errors import ModelFileError, ParameterValueError
from walker_library import compass_gait, load_walker

MODELS = Path(io.__file__).resolve().parents[2] / "models"


def _edited(tmp_path: Path, name: str, old: str, new: str) -> tuple[Path, int]:
    """The shipped file ``name`` with ``old`` replaced by ``new`` (once), and that line."""
    text = (MODELS / f"{name}.toml").read_text()
    assert text.count(old) == 1, old
    path = tmp_path / f"{name}_edited.toml"
    path.write_text(text.replace(old, new))
    line = next(i for i, ln in enumerate(path.read_text().splitlines(), 1) if new in ln)
    return path, line


@pytest.mark.parametrize("rng,admits,write", [
    ('"[0, inf)"', "m_leg = 0", "(0, inf)"),
    ('"(-1, inf)"', "m_leg < 0", "(0, inf)"),
    ('"[-1, 2]"', "m_leg < 0", "(0, 2]"),
])
def test_a_range_that_admits_what_a_body_refuses_is_a_file_error(tmp_path, rng, admits, write):
    """The walker table allowed m_leg = 0 where the legs' bodies refuse a mass <= 0: two
    validators with different rules. Now the range is checked against the constraints when the
    file is read (nothing compiled), naming the line, the body and the range to write."""
    path, line = _edited(tmp_path, "rigid_compass_walker", 'm_leg = "(0, inf)"',
                         f"m_leg = {rng}")
    with pytest.raises(ModelFileError) as err:
        load_walker(path)
    msg = str(err.value)
    assert f"line {line}:" in msg and f"admits {admits}" in msg
    assert "component 'walker' body 'stance_leg' mass must be > 0" in msg
    assert "component 'walker' body 'swing_leg' mass must be > 0" in msg
    assert msg.count("range of 'm_leg'") == 1           # one problem, naming both bodies
    assert f"write '{write}'" in msg


def test_a_parameter_without_a_range_takes_its_components_bounds():
    """hip_and_leg_spring_walker gives K_hip no range: the hip spring's constraint (stiffness
    >= 0) is its range, and a value outside it is refused by the walker's own check, naming the
    constraint, before any parameter vector is built."""
    walker = load_walker("hip_and_leg_spring_walker")
    spec = walker.specs["K_hip"]
    assert (spec.low, spec.low_inclusive, spec.high) == (0.0, True, math.inf)
    with pytest.raises(ParameterValueError) as err:
        walker.with_parameters(K_hip=-1.0)
    msg = str(err.value)
    assert "K_hip" in msg and "[0, inf)" in msg
    assert "component 'hip_spring' argument 'stiffness' must be >= 0" in msg
    assert walker.with_parameters(K_hip=0.0).parameters["K_hip"] == 0.0


@pytest.mark.parametrize("mass,value", [('"m_H + m"', 15.0), ('"m_H + 2*m + 1"', 21.0),
                                        ('"2*m_H"', 20.0 + 0.0)])
def test_walker_mass_must_be_the_bodies_total(tmp_path, mass, value):
    """compass_gait's bodies weigh m_H + 2 m = 20 kg. A [walker] mass that is not their total
    (15 kg gave a cost of transport sin(3°)·20/15 instead of sin 3°) is refused, naming the
    line and both masses; one equal at the defaults but not as an expression (2 m_H) is refused
    as soon as a parameter set tells them apart."""
    path, line = _edited(tmp_path, "compass_gait", 'mass = "m_H + 2*m"', f"mass = {mass}")
    if value == 20.0:
        walker = load_walker(path)                     # 2 m_H = 20 kg at the defaults
        with pytest.raises(ModelFileError) as err:
            walker.with_parameters(m=4.0)
        value = 20.0
        total = 18.0
    else:
        with pytest.raises(ModelFileError) as err:
            load_walker(path)
        total = 20.0
    msg = str(err.value)
    assert msg.startswith(f"{path}, line {line}:")
    assert f"gives {value:.10g} kg" in msg and f"weigh {total:.10g} kg" in msg


def test_the_cost_of_transport_of_the_shipped_compass_gait_is_sin_slope():
    """With the mass checked, the energy balance of a periodic gait gives the cost of transport
    sin γ exactly (the energy dissipated per step is the potential released, m g d sin γ;
    Goswami et al.'s γ = 3°): 0.0523, not 0.0654."""
    from walker_library import analyze_gait
    gait = analyze_gait(compass_gait())
    assert gait.status == "periodic"
    assert gait.metrics.cost_of_transport == pytest.approx(math.sin(math.radians(3.0)), rel=1e-6)


def test_uniform_rod_legs_follow_the_leg_length():
    """The rod files' legs are m_leg l²/12 in the model itself (no I_leg number): the
    multibody's leg inertia at l = 0.65 is m_leg 0.65²/12, read from the compiled mass matrix
    of rigid_compass_walker (pinned at the stance foot, legs straight down: M[hip, hip] is the
    swing leg's inertia about the hip, m_leg (l/2)² + m_leg l²/12 + m_foot l²)."""
    import numpy as np
    for length in (0.7, 0.65):
        walker = load_walker("rigid_compass_walker", {"l": length})
        P = walker.parameters
        x = np.zeros(walker.model.n_states)
        M = walker.model.matrix("walker.M", 0.0, x, walker.run.p)
        names = [s for s in walker.model.state_names if s.startswith("walker.q.")]
        k = names.index("walker.q.hip")
        rod = P["m_leg"] * length**2 / 12
        expected = P["m_leg"] * (length / 2) ** 2 + rod + P["m_foot"] * length**2
        assert M[k, k] == pytest.approx(expected, rel=1e-12)

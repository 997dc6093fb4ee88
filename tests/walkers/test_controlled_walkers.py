"""Closed loops on walkers, against theory.

* Controlled symmetry (M. W. Spong, "Passivity based control of the compass gait biped", IFAC
  1999; M. W. Spong and F. Bullo, "Controlled symmetries and passive walking", IEEE TAC
  50(7):1025–1031, 2005): the compass gait on the ground of slope γ′ with the ankle and hip torques
  of models/controlled_symmetry_walker.toml has, in coordinates relative to the ground, the
  dynamics of the passive compass gait on slope γ (the torques replace the gravity of γ′ by that
  of γ; the mass matrix and the impact map do not depend on the ground's tilt). So its fixed point
  and Floquet multipliers are those of models/compass_gait.toml at γ, and the actuators supply per
  step the potential energy the passive walker releases per step, m g d sin γ (their work is
  −Δ(V_γ − V_γ′) over a step, and V_γ′ repeats). Both walkers' coordinates are measured from
  their ground's normal, so the rotation between the frames is the identity on them.
* The actuated variable-stiffness leg (models/actuated_stiffness_walker.toml): the thesis's
  stiffness rule followed by a servo through a stiffness actuator; on the periodic gait the
  energy the actuators supply per step closes the ledger with the dissipation and the potential
  energy released (H repeats), and the gait stays that of the instantaneous rule
  (variable_stiffness_walker, REPRODUCTION.md Table 3.1: 0.3365 m/s).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from walker_library import analyze_gait, compass_gait, load_walker


@pytest.fixture(scope="module")
def passive():
    walker = compass_gait()
    return walker, analyze_gait(walker)


def _section(result, walker) -> np.ndarray:
    return np.array([result.fixed_point[k] for k in walker.section])


@pytest.mark.parametrize("ground", [0.0, 0.02])
def test_controlled_symmetry_reproduces_the_passive_gait(passive, ground):
    """On level ground (γ′ = 0) and on γ′ = 0.02 rad, emulating compass_gait's γ = 3°: the fixed
    point equals the passive walker's to 1e-8 (measured 4.1e-13 and 2.5e-13), the Floquet
    multipliers to 1e-8 (measured 3.0e-10 and 2.8e-10; their error bounds 2.5e-9), and the two
    actuators' work per step, plus on γ′ the potential energy the walker itself releases there,
    equals the potential energy the passive walker releases per step to 1e-8 relative (measured
    5.4e-11 and 5.0e-11), with the ledger closed (relative residual < 1e-10)."""
    pw, pr = passive
    walker = load_walker("controlled_symmetry_walker", {"slope": ground})
    result = analyze_gait(walker)
    assert result.status == "periodic" and result.period_steps == 1
    np.testing.assert_allclose(_section(result, walker), _section(pr, pw), rtol=0, atol=1e-8)
    np.testing.assert_allclose(np.sort_complex(np.asarray(result.floquet_multipliers, dtype=complex)),
                               np.sort_complex(np.asarray(pr.floquet_multipliers, dtype=complex)),
                               atol=1e-8)
    strides = walker.walk(_section(result, walker), 4, record=True)
    traj = strides[-1].info["trajectory"]
    ledger = traj.ledger()
    work = sum(ledger["actuators"].values()) / 4
    released = pr.metrics.potential_released_per_step
    assert released == pytest.approx(pw.total_mass * pw.parameters["g"] * pr.metrics.step_length
                                     * math.sin(pw.parameters["slope"]), rel=1e-8)
    level_released = (walker.total_mass * walker.parameters["g"] * result.metrics.step_length
                      * math.sin(ground))
    assert work + level_released == pytest.approx(released, rel=1e-8)
    assert ledger["relative_residual"] < 1e-10


def test_actuated_stiffness_leg_books_its_energy():
    """The actuated variable-stiffness walker walks a stable period-1 gait at the speed of the
    instantaneous rule (0.3365 m/s, ±5e-4); its stiffness actuators' work per step equals the
    dissipated energy minus the potential energy released per step (the ledger on the periodic
    gait, H repeating) to 1e-5 relative (measured 1.4e-6: 3e-8 J of H ≈ 22 J, the gait's
    periodicity at the file's gait tolerance 1e-6 on a section holding K ≈ 8000 N/m), and is
    positive: stiffening the loaded leg costs energy (REPRODUCTION.md, Table 3.1: 0.0201 J per step for 6000 -> 8000 N/m)."""
    walker = load_walker("actuated_stiffness_walker")
    result = analyze_gait(walker)
    assert result.status == "periodic" and result.period_steps == 1 and result.stable
    assert result.metrics.speed == pytest.approx(0.3365, abs=5e-4)
    strides = walker.walk(_section(result, walker), 2, record=True)
    ledger = strides[-1].info["trajectory"].ledger()
    work = sum(ledger["actuators"].values()) / 2
    m = result.metrics
    assert work == pytest.approx(m.energy_dissipated_per_step - m.potential_released_per_step,
                                 rel=1e-5)
    assert work == pytest.approx(ledger["supplied"] / 2, rel=1e-12)
    assert 0.015 < work < 0.025

"""An honest energy check (issue 10, item 5): the residual's scale (Trajectory.energy_scale) cannot
be inflated by a constant offset of H.

The pendulum of models/pendulum.toml with its pivot at height h (the joint's origin [0, 0, h]):
its motion does not depend on h, its potential energy m g (h − l cos θ) does, by a constant. The
old scale, max |H|, grew with h, so at h = 1e6 m every run passed; now ``porthamiltonian
check-energy`` fails the raised pendulum exactly when it fails the one at h = 0, over a range of
integration tolerances that makes some runs fail and some pass.
"""
from __future__ import annotations

import numpy as np
import pytest

from porthamiltonian import compile_model, io
from porthamiltonian.interfaces import cli

RTOLS = (1e-3, 1e-4, 1e-6, 1e-9)
TOLERANCE = 1e-6


def pendulum_file(model_text, tmp_path, height: float, rtol: float):
    text = model_text("pendulum")
    text = text.replace('theta0 = { value = 0.5,', f'h = {height!r}\ntheta0 = {{ value = 0.5,')
    text = text.replace('parent = "world"', 'parent = "world"\norigin = [0, 0, "h"]')
    text = text.replace('method = "DOP853"', 'method = "RK45"')
    text = text.replace("rtol = 1e-10", f"rtol = {rtol!r}")
    text = text.replace("energy_tolerance = 1e-8", f"energy_tolerance = {TOLERANCE!r}")
    path = tmp_path / f"pendulum_{height:g}_{rtol:g}.toml"
    path.write_text(text)
    return path


def verdict(path, capsys) -> tuple[bool, str]:
    status = cli.main(["--backend", "python", "check-energy", str(path)])
    out = capsys.readouterr().out
    assert status in (0, 1), out
    return status == 0, out


@pytest.mark.parametrize("rtol", RTOLS)
def test_raised_pivot_fails_exactly_when_the_low_one_fails(model_text, tmp_path, capsys, rtol):
    low, high = (pendulum_file(model_text, tmp_path, h, rtol) for h in (0.0, 1e6))
    ok_low, out_low = verdict(low, capsys)
    ok_high, out_high = verdict(high, capsys)
    assert ok_low == ok_high, (out_low, out_high)


def test_the_tolerances_reach_both_verdicts_and_the_old_scale_would_pass(model_text, tmp_path):
    """The range of tolerances above makes the check both fail and pass (so the test above can
    fail); at h = 1e6 m the old scale (max |H| ≈ m g h) passes the run that fails."""
    verdicts, old = [], []
    for rtol in (RTOLS[0], RTOLS[-1]):
        record = io.read(pendulum_file(model_text, tmp_path, 1e6, rtol))
        sim = record.simulation
        traj = compile_model(record.model, backend="python").simulate(
            sim["t_end"], method=sim["method"], rtol=sim["rtol"], atol=sim["atol"])
        verdicts.append(traj.relative_residual <= TOLERANCE)
        old.append(np.max(np.abs(traj.residual)) / np.max(np.abs(traj.H)) <= TOLERANCE)
        # the scale: kinetic energy (size) plus potential energy (range), ~ twice the swing energy
        swing = 9.81 * 1.0 * (1 - np.cos(0.5))
        assert traj.energy_scale == pytest.approx(2 * swing, rel=0.05)
    assert verdicts == [False, True]
    assert old == [True, True]

"""Long walks stay bounded (docs/walkers.md, "Walking" and "A stride's cost is bounded").

* a walk longer than ``WALK_BLOCK`` steps runs in blocks of that many strides, each from the
  section state the last one ended in: its steps are those of one simulation of the whole walk
  (to the integrator's tolerance), and its ledger residual is the blocks' residuals added up
  (recomputed here from the blocks' own trajectories);
* a stride beyond ``max_steps_per_stride`` integrator steps ends the walk as a fall whose reason
  names the limit (a result, not hours of work and gigabytes);
* ``walker walk --time-limit`` stops between blocks and reports the steps walked;
* a recorded walk (the report's figures and animation: one simulation) is bounded;
* a count, period or deadline that is not one is a typed error, and a state no stride starts
  from is a fall of the variational stride too.
"""
from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from porthamiltonian import io
from porthamiltonian.errors import OptionError
from walker_library import load_walker, read_walker, walk
from walker_library.analyses.gait import WALK_BLOCK
from walker_library.analyses.series import MAX_SERIES_STEPS, walk_series
from walker_library.cli import main
from walker_library.core.gradients import stride_gradient

MODELS = Path(io.__file__).resolve().parents[2] / "models"


def test_a_walk_in_blocks_is_the_walk_in_one_simulation_and_adds_up_its_ledger():
    walker = load_walker("compass_gait")
    z = walker.initial_guess()
    n = 2 * WALK_BLOCK + 5
    blocked = walk(walker, z, n)
    assert blocked.steps_taken == n and len(blocked.steps) == n and not blocked.fell
    assert blocked.stopped == ""
    whole = walker.walk(z, n)              # one simulation of all n strides
    assert len(whole) == n and not whole[-1].fell
    for got, ref in zip(blocked.steps, whole):
        assert got["duration"] == pytest.approx(ref.duration, rel=1e-7)
        assert got["step_length"] == pytest.approx(ref.step_length, rel=1e-7)
        assert got["energy_dissipated"] == pytest.approx(ref.energy_dissipated, rel=1e-6)
    assert blocked.energy_dissipated == pytest.approx(sum(s.energy_dissipated for s in whole),
                                                      rel=1e-8)
    # the ledger: each block's residual from its own start, plus the ends of the blocks before
    offset, worst, scale, start = 0.0, 0.0, 0.0, z
    for size in (WALK_BLOCK, WALK_BLOCK, 5):
        strides = walker.walk(start, size, record=True)
        traj = strides[-1].info["trajectory"]
        worst = max(worst, float(np.max(np.abs(offset + traj.residual))))
        offset += float(traj.residual[-1])
        scale = max(scale, traj.energy_scale)
        start = strides[-1].z_next
    assert blocked.max_energy_residual == worst
    assert blocked.relative_energy_residual == worst / scale
    assert 0.0 < blocked.relative_energy_residual < 1e-8


def test_a_stride_beyond_its_step_budget_is_a_fall_naming_the_limit(tmp_path, capsys):
    """A walker file's budget is read (``[walker] integration``); with 50 steps per stride (the
    shipped compass gait's own model, ``with_options``: nothing compiled again) the walk, the
    stride with its sensitivities and the stride gradient fall, naming the limit."""
    text = (MODELS / "compass_gait.toml").read_text()
    old = "max_step_time = "
    assert text.count(old) == 1
    tight = tmp_path / "tight_compass_gait.toml"
    tight.write_text(text.replace(old, "max_steps_per_stride = 50, " + old))
    spec, _ = read_walker(tight)
    assert spec.integration.max_steps_per_stride == 50
    shipped = load_walker("compass_gait")
    walker = shipped.with_options(max_steps_per_stride=50)
    result = walk(walker, None, 3)         # a run of 3 strides: 50 steps for each stride
    assert result.fell and result.steps_taken == 0
    assert result.fall_reason.startswith(
        "failed: more than 50 steps in one stride (max_steps_per_stride; t = "), result.fall_reason
    # the runs with sensitivities keep the budget too: the stride falls, naming it
    sens = walker.stride_sensitivity(walker.initial_guess())
    assert sens.jacobian is None and "more than 50 steps" in sens.fell, sens.fell
    grad = stride_gradient(walker, walker.initial_guess(), ["slope", "m_H", "a"])
    assert grad.z_next is None and "more than 50 steps" in grad.fell, grad.fell
    # the command line: the fall's line has no step length or energy (it printed "nan")
    assert main(["walk", str(tight), "--steps", "3"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == f"tight_compass_gait: 0 steps, fell ({result.fall_reason})"
    assert out[1].startswith("  step   1: fell  T = ") and out[1].endswith(" s"), out[1]
    assert "nan" not in "\n".join(out)
    # the shipped file's budget (100 000 per stride) is far from this walker's ~250 steps
    assert walk(shipped, None, 3).steps_taken == 3


def test_the_budget_holds_for_each_stride_of_a_walk_not_for_the_run(monkeypatch):
    """A walk's run may take n × budget steps, but no stride more than its own budget: the
    compass gait's first three strides from its guess, their integrator steps read from the
    loops' reports at the heel strikes (236, 243, 238 when written); with a budget of the first
    stride's steps the second stride, a few steps longer, falls naming the budget, and the
    first is kept (the run stopped there and made again up to the second stride's budget)."""
    walker = load_walker("compass_gait")
    z = walker.initial_guess()
    reports: list[tuple[float, int]] = []
    simulate = walker.model.simulate

    def recorded(*args, **options):
        watch = options.get("progress")

        def report(t, steps):
            reports.append((t, steps))
            if watch is not None:
                watch(t, steps)
        return simulate(*args, **{**options, "progress": report})

    monkeypatch.setattr(walker.model, "simulate", recorded)
    strides = walker.walk(z, 3, reuse=False)
    monkeypatch.undo()
    at = dict(reports)
    ends = [at[s.info["t_end"]] for s in strides]
    steps = np.diff([0, *ends]).tolist()
    assert steps[1] > steps[0], steps            # the second stride is the longer one
    result = walk(walker.with_options(max_steps_per_stride=steps[0]), z, 3)
    assert result.steps_taken == 1 and result.fell, result.fall_reason
    assert result.fall_reason.startswith(f"failed: more than {steps[0]} steps in one stride")
    assert result.steps[0]["duration"] == pytest.approx(strides[0].duration, rel=1e-12)
    assert walk(walker.with_options(max_steps_per_stride=max(steps)), z, 3).steps_taken == 3


def test_walker_walk_time_limit_reports_the_steps_walked(capsys):
    warm = load_walker("rimless_wheel")    # built and run once (numba: compiled), as the limit
    warm.stride(warm.initial_guess())      # counts from the command's start
    assert main(["walk", "rimless_wheel", "--steps", "1000000", "--time-limit", "0.5",
                 "--json", "--quiet"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["stopped"] == "time_limit" and not d["fell"]
    assert 0 < d["steps_taken"] < 1000000 and d["steps_taken"] % WALK_BLOCK == 0
    assert len(d["steps"]) == d["steps_taken"]
    assert d["relative_energy_residual"] < 1e-8
    assert main(["walk", "rimless_wheel", "--steps", "1000000", "--time-limit", "0.2"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith("rimless_wheel: ") and first.endswith(
        "steps, stopped at the time limit (0.2 s; --time-limit)"), first


def test_a_recorded_walk_is_bounded_and_says_what_walks_further():
    """walk_series (the report's figures and animation) keeps every integrator step of one
    simulation: at most MAX_SERIES_STEPS steps, a typed error beyond that naming `walker walk`."""
    walker = load_walker("rimless_wheel")
    with pytest.raises(OptionError, match=r"n_steps must be a whole number from 1 to 100, got "
                                          r"101: .*`walker walk MODEL --steps N`"):
        walk_series(walker, walker.initial_guess(), MAX_SERIES_STEPS + 1)
    assert len(walk_series(walker, walker.initial_guess(), 2).strides) == 2


#: HybridWalker.walk's count: its run's time, n × max_step_time (compass_gait: 5 s), a float64
_RUN = ("n_steps must be a whole number from 1 to 3.6e+307 (the time, n_steps × max_step_time = "
        "5 s, a float64), ")


@pytest.mark.parametrize("call, words", [
    (lambda w, z: walk(w, z, 0), "n_steps must be an integer >= 1, got 0"),
    (lambda w, z: walk(w, z, 2.5), "n_steps must be an integer >= 1, got 2.5"),
    (lambda w, z: walk(w, z, float("nan")), "n_steps must be an integer >= 1, got nan"),
    (lambda w, z: walk(w, z, 3, deadline=float("nan")),
     "deadline must be a number, not NaN, got nan"),
    (lambda w, z: w.walk(z, 0), _RUN + "got 0"),
    (lambda w, z: w.walk(z, 2.5), _RUN + "got 2.5"),
    (lambda w, z: w.walk(z, 10**400), _RUN + f"got {10**400}"),
    (lambda w, z: w.stride_sensitivity(z, 0), "period must be an integer >= 1, got 0"),
    (lambda w, z: w.stride_sensitivity(z, 1, deadline=float("nan")),
     "deadline must be a number, not NaN, got nan"),
], ids=["walk 0", "walk 2.5", "walk nan", "walk deadline nan", "HybridWalker.walk 0",
        "HybridWalker.walk 2.5", "HybridWalker.walk 10**400", "stride_sensitivity period 0",
        "stride_sensitivity deadline nan"])
def test_a_bad_count_or_deadline_is_a_typed_error(call, words):
    """walk(w, z, 0) and walk(w, z, -1) returned an empty walk, 2.5 walked 2 steps, a NaN
    deadline was no limit; HybridWalker.walk(z, 0) blamed t_end, (z, 2.5) max_events, and
    (z, 10**400) raised OverflowError (`walker report --steps 10**400`: status 3);
    stride_sensitivity(z, 0) returned the identity as the Jacobian of no stride. Each is an
    OptionError naming the argument now."""
    walker = load_walker("compass_gait")
    with pytest.raises(OptionError) as info:
        call(walker, walker.initial_guess())
    assert str(info.value) == words


@pytest.mark.parametrize("z", [[1e308] * 6, [float("nan")] * 6, [0.1]],
                         ids=["beyond float64", "nan", "too short"])
def test_a_state_no_stride_starts_from_falls_in_the_variational_stride_too(z):
    """stride_sensitivity from a section state beyond float64 (or NaN) raised "sensitivity
    directions must be finite", after numpy's "invalid value" warnings of the lift's
    differences; one of the wrong length raised. ``stride`` calls such a state a fall
    (invalid_state); stride_sensitivity now does too, quietly (warnings are errors here)."""
    walker = load_walker("compass_walker")
    z = np.array(z)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        stride = walker.stride(z)
        sens = walker.stride_sensitivity(z)
    assert stride.fell and stride.reason.startswith("invalid_state")
    assert sens.jacobian is None and sens.fell == stride.reason


def test_a_walk_stopped_before_its_first_block_says_it_has_no_ledger(capsys):
    """``walker walk --time-limit`` passed before the first block printed "max |energy
    residual| = 0.000e+00 J (relative nan)" for a ledger of nothing; it says so now."""
    assert main(["walk", "rimless_wheel", "--steps", "100", "--time-limit", "1e-9",
                 "--quiet"]) == 0
    out = capsys.readouterr().out
    first = "rimless_wheel: 0 steps, stopped at the time limit (1e-09 s; --time-limit)"
    assert out.splitlines() == [first, "  no stride was integrated: no energy ledger"]

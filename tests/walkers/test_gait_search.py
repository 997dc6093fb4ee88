"""``walker gait`` finds gaits without luck: the given guess first, then the model file's nominal
gait continued to the requested parameters; a full-state guess from a previous result or by
name; hostile guess files refused with a message.

Reference: Garcia et al. (1998), J. Biomech. Eng. 120:281 — the simplest walker's long-period
gait is stable up to its period doubling at γ ≈ 0.0151 (ours: 0.01508843815,
test_continuation.py), so at γ = 0.015 a stable period-1 gait exists (|λ| = 0.98046, measured
by continuation from γ = 0.009), though the default guess falls there.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from walker_library import analyze_gait, simplest_walker
from walker_library.analyses.gait import section_guess
from walker_library.cli import main


@pytest.fixture(scope="module")
def nominal_json(tmp_path_factory):
    path = tmp_path_factory.mktemp("guess") / "gait.json"
    w = simplest_walker()
    path.write_text(analyze_gait(w).to_json())
    return path


def test_gait_at_slope_0_015_found_by_continuation_from_the_nominal_gait(capsys):
    """`walker gait simplest_walker --set slope=0.015`: from the default guess Newton finds only
    the unstable short-period orbit (|λ| ≈ 4.8) and the walker falls; the continuation of the
    file's gait (γ = 0.009) to γ = 0.015 reaches the stable gait, |λ| = 0.980464. Both orbits are
    listed; the top level is the stable one."""
    assert main(["gait", "simplest_walker", "--set", "slope=0.015", "--json", "--quiet"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["status"] == "periodic" and d["outcome"] == "stable_gait" and d["stable"]
    assert d["period_steps"] == 1 and d["stability_certain"]
    mults = [abs(complex(m["re"], m["im"])) for m in d["floquet_multipliers"]]
    assert max(mults) == pytest.approx(0.980464, abs=1e-5)
    assert "continuation from the nominal gait (slope 0.009 -> 0.015)" in d["message"]
    periods = sorted((o["period_steps"], o["stable"]) for o in d["orbits"])
    assert periods == [(1, False), (1, True)]
    unstable = next(o for o in d["orbits"] if not o["stable"])
    assert unstable["max_multiplier"] == pytest.approx(4.797, abs=1e-2)   # the short-period gait
    assert d["fell_at_step"] is not None            # the default guess's own walk falls


def test_a_previous_result_is_a_guess(nominal_json, capsys):
    """--guess FILE starts Newton on the previous fixed point: converged at once (0 Newton
    iterations), the same gait to 1e-12; --set of one section coordinate (the thesis's θ̇)
    changes that value of the guess only."""
    assert main(["gait", "simplest_walker", "--guess", str(nominal_json), "--json",
                 "--quiet"]) == 0
    d = json.loads(capsys.readouterr().out)
    prev = json.loads(nominal_json.read_text())
    assert d["newton"]["iterations"] == 0 and d["outcome"] == "stable_gait"
    for k in ("theta", "theta_dot", "phi_dot"):
        assert d["fixed_point"][k] == pytest.approx(prev["fixed_point"][k], abs=1e-12)
    w = simplest_walker()
    z = section_guess(w, prev, {"theta_dot": -0.25})
    named = w.section_state(z)
    assert named["theta_dot"] == pytest.approx(-0.25, abs=1e-15)
    assert named["theta"] == pytest.approx(prev["fixed_point"]["theta"], abs=1e-15)
    z2 = section_guess(w, None, {"walker.q.stance": -0.21})
    np.testing.assert_allclose(z2, [-0.21, *w.initial_guess()[1:]], atol=0)


@pytest.mark.parametrize("content,message", [
    ("not json", "not a JSON document"),
    ("[1, 2]", "expected a JSON object"),
    ('{"fixed_point": {"theta": 0.2}}', "no value for walker.q.stance"),
    ('{"fixed_point": {"walker.q.stance": "x", "walker.v.stance": 0.2, "walker.v.hip": 0}}',
     "must be a finite number"),
    ('{"fixed_point": {"walker.q.stance": 1e999, "walker.v.stance": 0.2, "walker.v.hip": 0}}',
     "must be a finite number"),
    # an integer beyond the float range (OverflowError) and a deep nesting (RecursionError)
    # were reported as bugs (status 3)
    ('{"fixed_point": {"walker.q.stance": 1' + "0" * 400 + ', "walker.v.stance": 0.2, '
     '"walker.v.hip": 0}}', "guess: walker.q.stance must be a finite number, got 1" + "0" * 400),
    ("[" * 100_000 + "]" * 100_000, "arrays or objects are nested too deeply for a gait result"),
])
def test_bad_guess_files_are_refused(tmp_path, capsys, content, message):
    path = tmp_path / "bad.json"
    path.write_text(content)
    assert main(["gait", "simplest_walker", "--guess", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and len(err.splitlines()) == 1
    assert message in err and "Traceback" not in err


@pytest.mark.parametrize("args,message", [
    (["--set", "wobble=1"], "neither a parameter nor a section coordinate"),
    (["--set", "phi=0.4", "--set", "walker.v.hip=0"], "not both"),
    (["--guess", "/nonexistent/gait.json"], "/nonexistent/gait.json does not exist"),
])
def test_bad_guess_options_are_refused(capsys, args, message):
    assert main(["gait", "simplest_walker", *args]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err

"""``porthamiltonian fit MODEL DATA.csv --param ...``: the data file read as hostile input, the
fit's text and JSON results, errors as ``error: ...`` with status 2."""
from __future__ import annotations

import json

import numpy as np
import pytest

from porthamiltonian import compile_model, io
from porthamiltonian.interfaces.cli import main


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> str:
    """The spring's elongation of mass_spring_damper (k = 4, c = 0.4) at 20 times, 2 mm noise,
    with a comment line and a gap."""
    model = compile_model(io.load("mass_spring_damper"), backend="c")
    t = np.linspace(0.5, 10.0, 20)
    q = model.simulate(10.0, t_eval=t, rtol=1e-10, atol=1e-12, method="Rodas5P")["spring.q"]
    q = q + 2e-3 * np.random.default_rng(1).standard_normal(t.size)
    rows = [f"{a:.9g},{'' if i == 5 else f'{b:.9g}'}" for i, (a, b) in enumerate(zip(t, q))]
    path = tmp_path_factory.mktemp("fit") / "msd.csv"
    path.write_text("# elongation (m)\nt,spring.q\n" + "\n".join(rows) + "\n")
    return str(path)


def test_fit_json(data, capsys):
    """From k = 3: the estimates' 95 % intervals contain the truth (seeded noise), 19 samples
    (one gap), the JSON names every field."""
    assert main(["fit", "mass_spring_damper", data, "--param", "k,c", "--set", "k=3",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["converged"] and out["identifiable"] and out["n_data"] == 19
    for name, truth in (("k", 4.0), ("c", 0.4)):
        low, high = out["intervals"][name]
        assert low < truth < high and high - low < 0.1 * truth
    assert out["initial"]["k"] == 3.0


@pytest.mark.parametrize("text, message", [
    ("t,spring.q\n1,abc\n", "line 2, column 'spring.q'"),
    ("time,nope\n1,2\n", "nope"),
    ("x,spring.q\n1,2\n", "first column must be the time"),
    ("t,spring.q\n1,2,3\n", "line 2: 3 cells for 2 columns"),
    ("t,spring.q\n1,inf\n", "line 2"),
    ("# nothing\n", "no header row"),
])
def test_bad_data_files(text, message, tmp_path, capsys):
    """Each problem of the data file is ``error: FILE line N ...`` and status 2."""
    path = tmp_path / "bad.csv"
    path.write_text(text)
    assert main(["fit", "mass_spring_damper", str(path), "--param", "k"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error:") and message in err and "Traceback" not in err


def test_bad_options(data, capsys):
    """An unknown parameter, malformed bounds, a missing file: ``error: ...``, status 2."""
    for args in (["--param", "nope"], ["--param", "k", "--bounds", "k=1"],
                 ["--param", "k", "--weight", "spring.q=x"]):
        assert main(["fit", "mass_spring_damper", data, *args]) == 2
        assert capsys.readouterr().err.startswith("error:")
    assert main(["fit", "mass_spring_damper", data + ".missing", "--param", "k"]) == 2
    assert capsys.readouterr().err.startswith("error:")


@pytest.mark.parametrize("args, message", [
    (["--bounds", "k=nan:inf"],
     "bounds for 'k' must be (low, high) with low < high (-inf and inf allowed), got (nan, inf)"),
    (["--bounds", "k=5:1"],
     "bounds for 'k' must be (low, high) with low < high (-inf and inf allowed), got (5.0, 1.0)"),
    (["--bounds", "k=4:4"],
     "bounds for 'k' must be (low, high) with low < high (-inf and inf allowed), got (4.0, 4.0)"),
    (["--weight", "spring.x=2", "--weight", "spring.q=1"],
     "weights for 'spring.x', which the data does not hold (its outputs and events: spring.q)"),
])
def test_bounds_that_are_no_interval_and_weights_of_no_data(data, args, message, capsys):
    """A NaN bound reached scipy, whose ValueError was reported as a bug (status 3); reversed
    bounds were "the initial values lie outside the bounds" and equal ones scipy's ValueError;
    a weight of a name the data does not hold (a typo) was ignored, the fit run unweighted.
    Each is now ``error:`` naming the option, status 2."""
    assert main(["fit", "mass_spring_damper", data, "--param", "k", *args]) == 2
    assert capsys.readouterr().err == f"error: {message}\n"


def test_time_limit_and_progress_lines(data, capsys, monkeypatch):
    """``--time-limit`` stops a fit between runs with the best point so far (status 1, not
    converged, status "time_limit" in the JSON); ``--progress-interval`` gives lines on stderr
    (a fit with ``--t-end 1e308`` ran for minutes without a word), ``--quiet`` none."""
    monkeypatch.delenv("PORTHAMILTONIAN_QUIET", raising=False)     # (the tests' default)
    assert main(["fit", "mass_spring_damper", data, "--param", "k,c", "--set", "k=3",
                 "--time-limit", "1e-9", "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "time_limit" and not out["converged"] and out["nfev"] == 1
    assert out["estimates"]["k"] == 3.0
    assert main(["fit", "mass_spring_damper", data, "--param", "k,c", "--set", "k=3",
                 "--progress-interval", "1e-9"]) == 0
    captured = capsys.readouterr()
    assert "converged" in captured.out
    lines = [ln for ln in captured.err.splitlines() if ": fit, " in ln]
    assert lines and lines[0].startswith("mass_spring_damper: fit, 1 runs after "), captured.err
    assert main(["fit", "mass_spring_damper", data, "--param", "k,c", "--set", "k=3",
                 "--progress-interval", "1e-9", "--quiet"]) == 0
    assert ": fit, " not in capsys.readouterr().err
    assert main(["fit", "mass_spring_damper", data, "--param", "k", "--time-limit", "-1"]) == 2
    assert "--time-limit must be a finite number >= 0, got -1" in capsys.readouterr().err


def test_errors_beyond_float64_are_inf_without_warnings(data, capsys):
    """Weights of 1e-308 (absolute): the Jacobian's singular values square to 0, and numpy's
    "divide by zero" and "invalid value" warnings reached the user's screen. The standard
    error is beyond float64 (null in the JSON, ± inf in the text), quietly."""
    args = ["fit", "mass_spring_damper", data, "--param", "k", "--weight", "spring.q=1e-308",
            "--absolute-sigma"]
    assert main([*args, "--json"]) == 0
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    assert out["standard_errors"] == {"k": None} and out["intervals"] == {"k": [None, None]}
    assert out["correlation"] == [[None]]
    assert "warning" not in captured.err, captured.err
    assert main(args) == 0
    captured = capsys.readouterr()
    assert "4 ± inf   95 %: [-inf, inf]" in captured.out and "warning" not in captured.err

"""`walker sweep` in this process (walker_library.cli.main): the printed table, CSV export, exit
statuses and messages for bad input (nothing written), and --backend before or after the
subcommand."""
from __future__ import annotations

import csv

from porthamiltonian.batch import load_results, read_header
from walker_library.cli import main

CHEAP = ["sweep", "unused", "--analysis", "sweep_cases:square_case", "--grid", "x=1,2", "--grid",
         "y=0,1", "--serial", "--progress", "none"]


def test_table_and_csv(tmp_path, capsys):
    out, table_csv = tmp_path / "s.jsonl", tmp_path / "s.csv"
    assert main([*CHEAP, "--out", str(out), "--csv", str(table_csv)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"{out}: 4/4 cases (ok 4); this run 4 case(s) in ")
    assert lines[0].endswith(", 0 already done")
    assert lines[1].split() == ["case_id", "x", "y", "status"]
    assert [ln.split() for ln in lines[2:6]] == [["0", "1", "0", "ok"], ["1", "1", "1", "ok"],
                                                  ["2", "2", "0", "ok"], ["3", "2", "1", "ok"]]
    assert lines[6] == f"wrote {table_csv}"
    with open(table_csv, newline="") as fh:
        got = list(csv.DictReader(fh))
    assert [(r["x"], r["y"], r["square"]) for r in got] == [
        ("1.0", "0.0", "1.0"), ("1.0", "1.0", "1.0"), ("2.0", "0.0", "4.0"), ("2.0", "1.0", "4.0")]
    assert main([*CHEAP, "--out", str(out)]) == 0            # resumed: nothing to run
    assert "this run 0 case(s)" in capsys.readouterr().out


def test_unknown_walker_parameter_fails_before_anything_is_written(tmp_path, capsys):
    out = tmp_path / "s.jsonl"
    code = main(["sweep", "simplest_walker", "--grid", "slope=0.01", "--grid", "stiffness=1,2",
                 "--backend", "python", "--out", str(out), "--serial"])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith('error: case 0 {"slope":0.01,"stiffness":1.0}: unknown parameter(s) '
                          "stiffness of simplest_walker; parameters: slope, M, beta")
    assert not out.exists()


def test_out_of_range_walker_parameter_fails_naming_the_case(tmp_path, capsys):
    out = tmp_path / "s.jsonl"
    code = main(["sweep", "simplest_walker", "--grid", "slope=0.01,2", "--backend", "python",
                 "--out", str(out), "--serial"])
    assert code == 2
    err = capsys.readouterr().err
    assert 'case 1 {"slope":2.0}' in err and "'slope' = 2 is out of range" in err
    assert not out.exists()


def test_gait_search_options_are_checked_before_anything_is_written(tmp_path, capsys):
    """`--option max_period=-1` (or "x", 2.5, or `nan`, which JSON reads as the text 'nan')
    reached the gait search as given: used as such, its error met only when period 1 failed,
    in one case's row. Each is refused before the sweep, naming the option."""
    out = tmp_path / "s.jsonl"
    for option, message in (("max_period=-1", "max_period must be an integer >= 1, got -1"),
                            ("max_period=nan", "max_period must be an integer >= 1, got 'nan'"),
                            ("max_period=2.5", "max_period must be an integer >= 1, got 2.5"),
                            ("n_iterate=0", "n_iterate must be an integer >= 1, got 0"),
                            ("fd_step=-1", "fd_step must be finite and > 0, got -1")):
        assert main(["sweep", "simplest_walker", "--grid", "slope=0.01", "--backend", "python",
                     "--option", option, "--out", str(out), "--serial"]) == 2
        assert capsys.readouterr().err == f"error: {message}\n"
        assert not out.exists()


def test_basin_sweep_options_are_checked_before_anything_is_written(tmp_path, capsys):
    """`--option params=[1]` reached the walker cache (a ValueError: a bug report, status 3);
    n_steps=-1 and tol=nan (the text 'nan') failed each case with a message about something
    else (t_end, a TypeError). Each is refused before the sweep, naming the option."""
    out = tmp_path / "s.jsonl"
    for option, message in (
            ("params=[1]", ("--option params must be a JSON object of parameter values (e.g. "
                            "params='{\"slope\": 0.01}'), got [1]")),
            ("n_steps=-1", "n_steps must be an integer >= 1, got -1"),
            ("tol=nan", "tol must be a number, got str 'nan'")):
        assert main(["sweep", "simplest_walker", "--analysis", "basin", "--grid", "theta=0.2",
                     "--grid", "theta_dot=-0.2", "--backend", "python", "--option", option,
                     "--out", str(out), "--serial"]) == 2
        assert capsys.readouterr().err == f"error: {message}\n"
        assert not out.exists()


def test_bad_input_exit_status_2_with_the_reason(tmp_path, capsys):
    out = tmp_path / "s.jsonl"
    assert main(["sweep", "unused", "--analysis", "limit-cycle", "--grid", "x=1", "--out", str(out)]) == 2
    assert ("unknown analysis 'limit-cycle'; analyses: gait, step-down, basin"
            in capsys.readouterr().err)
    assert main([*CHEAP, "--grid", "z=1:2", "--out", str(out)]) == 2
    assert "a range is start:stop:n" in capsys.readouterr().err
    assert main([*CHEAP, "--option", "delay", "--out", str(out)]) == 2
    assert "--option takes NAME=VALUE" in capsys.readouterr().err
    assert main([*CHEAP[:-3], "--workers", "0", "--out", str(out)]) == 2
    assert "--workers must be at least 1" in capsys.readouterr().err
    assert not out.exists()
    foreign = tmp_path / "notes.txt"
    foreign.write_text("my notes\n")
    assert main([*CHEAP, "--out", str(foreign)]) == 2
    assert f"error: {foreign}: not a sweep results file" in capsys.readouterr().err
    assert foreign.read_text() == "my notes\n"


def test_options_are_fixed_arguments_of_the_identity(tmp_path, capsys):
    out = tmp_path / "s.jsonl"
    assert main([*CHEAP, "--option", "scale=3", "--out", str(out)]) == 0
    assert [r["result"]["square"] for r in load_results(out)] == [3.0, 3.0, 12.0, 12.0]
    capsys.readouterr()
    assert main([*CHEAP, "--option", "scale=2", "--out", str(out)]) == 2
    assert 'fixed arguments {"backend":null,"model":"unused","scale":3} (file) vs' in \
        capsys.readouterr().err


def test_backend_before_or_after_the_subcommand(tmp_path):
    for where, args in (("before", ["--backend", "python", *CHEAP]),
                        ("after", [*CHEAP, "--backend", "python"])):
        out = tmp_path / f"{where}.jsonl"
        assert main([*args, "--out", str(out)]) == 0
        assert read_header(out)["sweep"]["fixed"] == {"backend": "python", "model": "unused"}

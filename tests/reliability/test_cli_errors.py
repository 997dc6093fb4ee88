"""The command line never shows a traceback for a user error (issue 10, item 7): ``error:
<message>`` on stderr and exit status 2; a bug shows its traceback and asks to be reported
(status 3); Ctrl-C exits 130 and a closed pipe 141, both without a traceback
(porthamiltonian.interfaces.cli.run, shared by the ``walker`` command)."""
from __future__ import annotations

import argparse
import os
import subprocess
import sys

import pytest

from porthamiltonian.interfaces import cli
from walker_library import cli as walker_cli

HOSTILE = ('[components.spring]\ntype = "C"\n'
           'stiffness = "__import__(\'os\').system(\'touch PWNED\')"\n')
EMPTY = '[model]\nname = "nothing"\n'


def _file(tmp_path, text, name="model.toml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


USER_ERRORS = [
    (["simulate", "no_such_model"], ["no model called 'no_such_model'"]),
    (["simulate", "{hostile}"], ["cannot parse", "'_'"]),
    (["simulate", "{empty}", "--t-end", "1"], ["no components"]),
    (["simulate", "mass_spring_damper", "--set", "m=-1"], ["'mass'", "'inertance'", "> 0"]),
    (["simulate", "mass_spring_damper", "--set", "m=0"], ["'mass'", "> 0"]),
    (["simulate", "pendulum", "--set", "m=-1"], ["body 'bob' mass", "> 0"]),
    (["simulate", "mass_spring_damper", "--set", "k=nan"], ["'k'", "finite"]),
    (["simulate", "mass_spring_damper", "--set", "k=1e400"], ["'k'", "finite"]),
    (["simulate", "mass_spring_damper", "--set", "nosuch=1"], ["'nosuch'"]),
    (["simulate", "mass_spring_damper", "--set", "k"], ["NAME=VALUE"]),
    (["simulate", "mass_spring_damper", "--set", "k=abc"], ["'abc'", "not a number"]),
    (["simulate", "mass_spring_damper", "--t-end", "nan"], ["t_end"]),
    (["simulate", "mass_spring_damper", "--t-end", "-1"], ["t_end"]),
    (["simulate", "mass_spring_damper", "--t-end", "1", "--csv", "{missing}/out.csv"],
     ["--csv", "out.csv", "the folder", "does not exist"]),      # before the run
    (["simulate", "mass_spring_damper", "--t-end", "1", "--csv", "{folder}"],
     ["--csv", "is a directory, not a file"]),
    (["sweep", "mass_spring_damper", "--grid", "k=1", "--out", "{folder}/s.jsonl", "--csv",
      "{folder}"], ["--csv", "is a directory, not a file"]),
    (["show", "{hostile}"], ["cannot parse"]),
]


@pytest.mark.parametrize("argv, words", USER_ERRORS, ids=[" ".join(a) for a, _ in USER_ERRORS])
def test_user_error_is_one_message_and_status_2(argv, words, tmp_path, capsys, isolated_cache):
    """One message: ``error: ...`` on one line, or, for a file with several problems, its first
    line and one indented line per problem (the hostile file also leaves its spring unconnected:
    both problems are reported)."""
    names = {"hostile": _file(tmp_path, HOSTILE, "hostile.toml"),
             "empty": _file(tmp_path, EMPTY, "empty.toml"), "missing": str(tmp_path / "missing"),
             "folder": str(tmp_path)}
    argv = [a.format(**names) for a in argv]
    status = cli.main(["--backend", "python", *argv])
    err = capsys.readouterr().err
    assert status == 2, err
    assert err.startswith("error: ") and "Traceback" not in err, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 or (lines[0].endswith("problems:")
                               and all(line.startswith("  line ") for line in lines[1:])), err
    for word in words:
        assert word in err, err
    assert not (tmp_path / "PWNED").exists() and not os.path.exists("PWNED")


def test_walker_command_shares_the_runner(capsys):
    status = walker_cli.main(["gait", "no_such_walker"])
    err = capsys.readouterr().err
    assert status == 2 and err.startswith("error: ") and "Traceback" not in err


def _parser(action):
    parser = argparse.ArgumentParser(prog="demo")
    parser.set_defaults(func=lambda args: action())
    return parser


def test_a_bug_shows_the_traceback_and_asks_for_a_report(capsys):
    def broken():
        raise RuntimeError("internal inconsistency")

    assert cli.run(_parser(broken), []) == 3
    err = capsys.readouterr().err
    assert "Traceback" in err and "RuntimeError: internal inconsistency" in err
    assert "bug in porthamiltonian" in err and "report" in err


def test_ctrl_c_exits_130_without_a_traceback(capsys):
    def interrupted():
        raise KeyboardInterrupt

    assert cli.run(_parser(interrupted), []) == 130
    err = capsys.readouterr().err
    assert "Traceback" not in err and "interrupted" in err


def test_usage_error_exits_2(capsys):
    with pytest.raises(SystemExit) as info:
        cli.main(["simulate"])
    assert info.value.code == 2
    assert "Traceback" not in capsys.readouterr().err


def test_closed_pipe_exits_quietly(isolated_cache):
    """``porthamiltonian show MODEL | head -0``: the reader is gone before the first line (closed
    before the child has even imported the package, so the write always fails)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    code = ("import sys; from porthamiltonian.interfaces.cli import main; "
            "sys.exit(main(['show', 'mass_spring_damper']))")
    proc = subprocess.Popen([sys.executable, "-c", code],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141, err
    assert "Traceback" not in err and "Exception ignored" not in err, err

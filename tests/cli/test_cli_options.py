"""The two command lines as argparse users expect them: every option and positional has help
text, ``--backend`` works before and after the subcommand (and takes what
porthamiltonian.backends accepts), a mistyped walker model gets a suggestion among the walker
models only, output lines carry units, and a closed pipe ends a command quietly."""
from __future__ import annotations

import argparse
import subprocess
import sys

import pytest

from porthamiltonian import backends
from porthamiltonian.interfaces.cli import build_parser as ph_parser
from walker_library import available_walkers
from walker_library.cli import build_parser as walker_parser
from walker_library.cli import main as walker_main


def _parsers(parser: argparse.ArgumentParser, name: str):
    yield name, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub, subparser in action.choices.items():
                yield from _parsers(subparser, f"{name} {sub}")


@pytest.mark.parametrize("build", [ph_parser, walker_parser], ids=["porthamiltonian", "walker"])
def test_every_option_positional_and_command_has_help(build):
    missing = []
    for name, parser in _parsers(build(), build.__module__):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                commands = {c.dest for c in action._choices_actions if c.help}
                missing += [f"{name} {c}" for c in action.choices if c not in commands]
            elif not isinstance(action, argparse._HelpAction) and not action.help:
                missing.append(f"{name} {'/'.join(action.option_strings) or action.dest}")
    assert not missing


@pytest.mark.parametrize("build", [ph_parser, walker_parser], ids=["porthamiltonian", "walker"])
def test_backend_before_and_after_the_command(build):
    parser = build()
    default = parser.parse_args(["list"] if build is walker_parser else ["show", "x"]).backend
    assert default == (None if build is walker_parser else "auto")
    command = ["gait", "rimless_wheel"] if build is walker_parser else ["simulate", "msd"]
    for name in ("auto", *backends.BACKENDS):
        assert parser.parse_args(["--backend", name, *command]).backend == name
        assert parser.parse_args([*command, "--backend", name]).backend == name
    assert parser.parse_args(["--backend", "python", *command, "--backend", "auto"]).backend == "auto"
    with pytest.raises(SystemExit):
        parser.parse_args([*command, "--backend", "fortran"])


def test_walker_gait_backend_after_the_model(capsys):
    assert walker_main(["gait", "rimless_wheel", "--backend", "python", "--json"]) == 0
    assert '"status": "periodic"' in capsys.readouterr().out


def test_mistyped_walker_model_gets_a_suggestion_among_walker_models(capsys):
    assert walker_main(["gait", "compas_walker"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: no walker model called 'compas_walker' (did you mean "
                          "compass_walker?); walker models: ")
    listed = err.split("walker models: ", 1)[1].split(";")[0].split(", ")
    assert listed == available_walkers()
    assert "pendulum" not in err and "mass_spring_damper" not in err


def test_mistyped_model_name_gets_a_suggestion(capsys):
    from porthamiltonian.interfaces.cli import main
    assert main(["show", "mass_spring_dumper"]) == 2
    assert "no model called 'mass_spring_dumper' (did you mean 'mass_spring_damper'?)" in \
        capsys.readouterr().err


def test_walk_output_carries_units(capsys):
    assert walker_main(["walk", "rimless_wheel", "--steps", "3"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[1].startswith("  step   1: step  T = ") and " s  length = " in out[1]
    assert out[1].split("length = ")[1].split()[1] == "m" and out[1].endswith(" J")
    assert out[-1].startswith("  dissipated = ") and " J, potential released = " in out[-1]


def test_gait_output_carries_units(capsys):
    assert walker_main(["gait", "rimless_wheel", "--quiet"]) == 0
    lines = {ln.split()[0]: ln.split()[1:] for ln in capsys.readouterr().out.splitlines()
             if ln.startswith("  ")}
    assert lines["step_period"][1] == "s" and lines["speed"][1] == "m/s"
    assert lines["energy_dissipated_per_step"][1] == "J" and lines["theta"][1] == "rad"


def test_a_closed_pipe_ends_the_command_quietly():
    """``walker gait ... --json | head`` : the reader is gone before the document is written."""
    proc = subprocess.Popen([sys.executable, "-m", "walker_library.cli", "gait", "rimless_wheel",
                             "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 141 and err == b""


def test_a_model_build_is_announced_once_and_quiet_silences_it(tmp_path, monkeypatch, capsys):
    """A model not in the cache is built once, and stderr hears about it in one line; the next
    run of the same model (cached) is silent, and so is a build with $PORTHAMILTONIAN_QUIET set
    or inside ``backends.quiet()`` (the commands' --quiet)."""
    from porthamiltonian import backends
    from porthamiltonian.interfaces.cli import main
    monkeypatch.delenv("PORTHAMILTONIAN_QUIET", raising=False)
    monkeypatch.setenv("PORTHAMILTONIAN_CACHE", str(tmp_path / "cache"))
    argv = ["--backend", "python", "simulate", "mass_spring_damper", "--t-end", "0.1"]
    for expected in (True, False):
        assert main(argv) == 0
        assert ("building mass_spring_damper:" in capsys.readouterr().err) is expected
    for folder in ("other", "third"):
        monkeypatch.setenv("PORTHAMILTONIAN_CACHE", str(tmp_path / folder))
        if folder == "other":
            monkeypatch.setenv("PORTHAMILTONIAN_QUIET", "1")
            assert main(argv) == 0
        else:
            monkeypatch.delenv("PORTHAMILTONIAN_QUIET")
            with backends.quiet():
                assert main(argv) == 0
        assert "building" not in capsys.readouterr().err


@pytest.mark.parametrize("build, argv", [
    (ph_parser, ["simulate", "mass_spring_damper", "--csv", ""]),
    (ph_parser, ["sweep", "mass_spring_damper", "--grid", "k=1,2", "--out", "s.jsonl", "--csv",
                 " "]),
    (walker_parser, ["continue", "rimless_wheel", "--param", "slope=0.07:0.08", "--out", ""]),
    (ph_parser, ["view", "pendulum", "--out", ""]),
    (walker_parser, ["reproduce", "kneed_walker", "--quick", "--out", ""]),
    (walker_parser, ["report", "--out", " "]),
    (walker_parser, ["optimize", "rimless_wheel", "--vary", "slope", "--objective", "speed",
                     "--record", ""]),
    (walker_parser, ["gait", "rimless_wheel", "--guess", ""]),
    (walker_parser, ["continue", "rimless_wheel", "--param", "slope=0.07:0.08", "--guess", ""]),
    (walker_parser, ["optimize", "rimless_wheel", "--vary", "slope", "--objective", "speed",
                     "--guess", ""]),
], ids=["simulate --csv", "sweep --csv", "continue --out", "view --out", "reproduce --out",
        "report --out", "optimize --record", "gait --guess", "continue --guess",
        "optimize --guess"])
def test_an_empty_path_is_refused(build, argv, capsys):
    """An optional file given an empty path was taken as not given: the command ran and wrote
    nothing, without a word (``--csv``), or wrote into the current folder (``view --out``,
    ``reproduce --out``, ``report --out``), or searched from the model file's guess
    (``--guess``). argparse refuses it now (status 2), naming the option."""
    with pytest.raises(SystemExit) as info:
        build().parse_args(argv)
    option = argv[-2]
    assert info.value.code == 2
    what = "give the file to read" if option == "--guess" else "give the file or folder to write"
    assert capsys.readouterr().err.splitlines()[-1].endswith(
        f"error: argument {option}: an empty path; {what}")


def test_an_empty_gradient_is_refused(capsys):
    """``walker gait --gradient ""`` was taken as no option given (no gradients, no word); it
    is refused as ``--gradient " "`` was, by the names' check (status 2)."""
    assert walker_main(["gait", "rimless_wheel", "--gradient", ""]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: rimless_wheel: cannot differentiate by (): give distinct "
                          "parameters of the walker"), err

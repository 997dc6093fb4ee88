"""One clear message for each input that got a misleading one, a raw traceback or silence
(issue 21, the "Poor" list): a typed error (status 2 with ``error: ...`` on the command line)
naming what is wrong, within :data:`bounds.REFUSAL_CPU` seconds of processor time.

Before: a flow source on a mass got the dissipator's causality hint; ``--steps 0`` spoke of
t_end; ``compile_model("msd")``, ``connect(1, 2)`` and ``x0={'spring.q': 'abc'}`` raised bare
Python errors; a full disk during a sweep was an OSError reported as a bug (no data was lost);
``walker export`` overwrote any file, through symbolic links too.
"""
from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import replace

import pytest

import porthamiltonian as ph
from porthamiltonian import compile_model, io
from porthamiltonian.errors import (
    ConnectError,
    DerivativeCausalityError,
    ModelError,
    StateError,
)
from porthamiltonian.interfaces import cli
from walker_library import cli as walker_cli
from walker_library.report import writer
from walker_library.report.studies import STUDIES


@pytest.mark.parametrize("source, storage, words", [
    (("Sf", "flow"), ("I", "inertance"), ["source 'src' (Sf) imposes the flow of storage 'st'",
                                          "drive the storage with an effort source"]),
    (("Se", "effort"), ("C", "stiffness"), ["source 'src' (Se) imposes the effort of storage",
                                            "drive the storage with a flow source"]),
])
def test_a_source_on_a_storage_gets_the_causality_message(source, storage, words, within):
    m = ph.Model("driven")
    m.add("src", getattr(ph, source[0])(**{source[1]: 1.0}))
    m.add("st", getattr(ph, storage[0])(**{storage[1]: 2.0}))
    m.connect("src.p", "st.p")
    with within(), pytest.raises(DerivativeCausalityError) as info:
        compile_model(m, backend="python", use_cache=False)
    message = str(info.value)
    for word in words + ["derivative causality"]:
        assert word in message, message
    assert "nonlinear law" not in message


@pytest.mark.parametrize("call, error, words", [
    (lambda: compile_model("msd"), ModelError,
     ["compile_model takes a Model", "compile_model(io.load('msd'))"]),
    (lambda: compile_model(42), ModelError, ["got int 42"]),
    (lambda: ph.Model("m").connect(1, 2), ConnectError, ["tail must be a string", "got int 1"]),
    (lambda: ph.Model("m").connect("a.p", None), ModelError, []),
])
def test_python_api_misuse_is_a_typed_error(call, error, words, within):
    with within(), pytest.raises(error) as info:
        call()
    for word in words:
        assert word in str(info.value), str(info.value)


@pytest.mark.parametrize("x0, words", [
    ({"spring.q": "abc"}, ["initial value of state 'spring.q' must be a number", "str 'abc'"]),
    ({"spring.q": None}, ["must be a number, got NoneType"]),
    ({"spring.q": [1.0]}, ["must be a number, got list"]),
    ({"spring.q": True}, ["must be a number, got bool"]),
    ({"spring.q": float("nan")}, ["initial state is not finite: spring.q = nan"]),
    ({"spring.x": 1.0}, ["no state 'spring.x'"]),
])
def test_a_bad_initial_value_names_the_state(compile_named, x0, words, within):
    model = compile_named("mass_spring_damper")
    with within(), pytest.raises(StateError) as info:
        model.simulate(1.0, x0=x0)
    for word in words:
        assert word in str(info.value), str(info.value)


WALKER_OPTIONS = [
    (["walk", "compass_walker", "--steps", "0"], "--steps must be at least 1, got 0"),
    (["report", "compass_walker", "--steps", "-1"],
     "--steps must be a whole number from 1 to 100, got -1"),
    # a recorded walk of 100 000 steps kept every integrator step: gigabytes (0.5 GB per 60
    # strides of the compass walker), before the figures and the animation
    (["report", "compass_walker", "--steps", "100000"],
     "--steps must be a whole number from 1 to 100, got 100000"),
    (["basin", "simplest_walker", "--n", "1"], "--n must be at least 2, got 1"),
    (["basin", "simplest_walker", "--span", "0"], "--span must be a finite number > 0, got 0"),
    (["step-down", "simplest_walker", "--resolution", "nan"], "--resolution must be a finite"),
    (["step-down", "simplest_walker", "--h-max", "-1"], "--h-max must be a finite number > 0"),
    (["gait", "simplest_walker", "--max-period", "0"], "--max-period must be at least 1"),
    (["gait", "simplest_walker", "--iterate", "0"], "--iterate must be at least 1"),
    (["gait", "simplest_walker", "--fd-step", "inf"], "--fd-step must be a finite number > 0"),
    (["continue", "simplest_walker", "--param", "slope=0.01:0.02", "--doublings", "-1"],
     "--doublings must be at least 0"),
    (["continue", "simplest_walker", "--param", "slope=0.01:0.02", "--max-points", "1"],
     "--max-points must be at least 2"),
    (["sweep", "simplest_walker", "--grid", "slope=0.01", "--out", "x.jsonl", "--workers", "0"],
     "--workers must be at least 1, got 0"),
    (["sweep", "simplest_walker", "--grid", "slope=0.01", "--out", "x.jsonl", "--max-cases",
      "-1"], "--max-cases must be at least 0"),
    (["reproduce", "--workers", "0"], "--workers must be at least 1"),
]


@pytest.mark.parametrize("argv, words", WALKER_OPTIONS, ids=[" ".join(a) for a, _ in WALKER_OPTIONS])
def test_a_bad_option_gets_its_own_message_before_any_work(argv, words, capsys, tmp_path,
                                                          monkeypatch, within):
    """Before: ``--steps 0`` spoke of t_end (after the gait search had run)."""
    monkeypatch.chdir(tmp_path)
    with within():
        status = walker_cli.main(argv)
    err = capsys.readouterr().err
    assert status == 2 and err == f"error: {err[7:]}" and words in err, err
    assert not (tmp_path / "x.jsonl").exists()


@pytest.mark.parametrize("argv, words", [
    (["view", "free_rigid_body", "--rate", "inf"], "--rate must be a finite number > 0, got inf"),
    (["sweep", "mass_spring_damper", "--grid", "k=1", "--out", "x.jsonl",
      "--progress-interval", "-1"], "--progress-interval must be a finite number >= 0"),
])
def test_porthamiltonian_options_too(argv, words, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(argv) == 2
    assert words in capsys.readouterr().err


# --- walker export ---------------------------------------------------------------------------------
@pytest.mark.parametrize("target", ["file", "link to a file", "broken link", "directory"])
def test_export_never_overwrites_without_force(target, tmp_path, capsys, within):
    precious = tmp_path / "precious.txt"
    precious.write_text("keep me")
    path = tmp_path / "out.toml"
    if target == "file":
        path.write_text("mine")
    elif target == "link to a file":
        path.symlink_to(precious)
    elif target == "broken link":
        path.symlink_to(tmp_path / "nowhere")
    else:
        path.mkdir()
    with within():
        status = walker_cli.main(["export", "simplest_walker", str(path)])
    err = capsys.readouterr().err
    assert status == 2, err
    assert ("is a directory" if target == "directory" else "give --force to replace it") in err
    assert precious.read_text() == "keep me"
    if target == "file":
        assert path.read_text() == "mine"


def test_export_with_force_replaces_the_link_not_its_target(tmp_path, capsys):
    precious = tmp_path / "precious.txt"
    precious.write_text("keep me")
    path = tmp_path / "out.toml"
    path.symlink_to(precious)
    assert walker_cli.main(["export", "simplest_walker", str(path), "--force",
                            "--set", "slope=0.01"]) == 0
    assert precious.read_text() == "keep me" and not path.is_symlink()
    assert io.read(path).model.parameters["slope"].value == 0.01
    assert oct(path.stat().st_mode & 0o777) == oct(0o666 & ~_umask())


def test_export_into_a_missing_folder_names_the_folder(tmp_path, capsys):
    """The error named the temporary file the export writes first
    (``.out.toml.dojfnmy6.tmp: No such file or directory``); it names the path and its
    missing folder now, before any work."""
    path = tmp_path / "missing" / "out.toml"
    assert walker_cli.main(["export", "simplest_walker", str(path)]) == 2
    assert capsys.readouterr().err == (f"error: cannot write {path}: the folder {path.parent} "
                                       "does not exist\n")


@pytest.mark.parametrize("command", [
    ["porthamiltonian", "view", "pendulum", "--t-end", "1"],
    ["walker", "continue", "simplest_walker", "--param", "slope=0.009:0.01"],
    ["walker", "report", "simplest_walker", "--no-step-down"],
    ["walker", "reproduce", "kneed_walker", "--quick", "--serial"],
])
@pytest.mark.parametrize("inside", [False, True], ids=["a file", "inside a file"])
def test_an_output_folder_that_cannot_be_made_fails_before_the_work(command, inside, tmp_path,
                                                                     monkeypatch, capsys):
    """`view --out FILE` and `walker continue --out FILE` ran the simulation or the whole
    continuation (up to an hour) and only then failed to make the folder: the work was lost.
    The folder is made first now; a path that is a file fails at once (status 2), saying what
    is in the way (mkdir said "File exists" or "Not a directory")."""
    from porthamiltonian.interfaces.sweeps import SimulationModel

    def no_work(*args, **kwargs):
        raise AssertionError("the work started")

    monkeypatch.setattr(SimulationModel, "simulate", no_work)
    monkeypatch.setattr(walker_cli, "_continuation", no_work)
    monkeypatch.setattr(writer, "analyze_gait", no_work)
    monkeypatch.setitem(STUDIES, "kneed_walker", replace(STUDIES["kneed_walker"], run=no_work))
    taken = tmp_path / "taken"
    taken.write_text("a file")
    out = taken / "sub" if inside else taken
    main = cli.main if command[0] == "porthamiltonian" else walker_cli.main
    assert main([*command[1:], "--out", str(out)]) == 2
    made = out / "kneed_walker" if command[1] == "reproduce" else out
    assert capsys.readouterr().err == (
        f"error: {made} cannot be made: a part of its path is a file, not a folder\n"
        if inside or command[1] == "reproduce" else
        f"error: {taken} exists and is not a folder: give a folder to write into\n")


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


# --- a full disk during a sweep ---------------------------------------------------------------------
#: the environment of a process under a file size limit: no bytecode written (Python would write
#: a .pyc cut at the limit, which breaks every later import of its module, in every process)
def _limited_env(**more: str) -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path), PYTHONDONTWRITEBYTECODE="1",
                **more)


_FULL = """
import resource, signal, sys
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (3000, 3000))   # the header and a few rows fit
from porthamiltonian.interfaces import cli
sys.exit(cli.main(["--backend", "python", "sweep", "mass_spring_damper", "--grid", "k=1:2:12",
                   "--out", sys.argv[1], "--serial", "--t-end", "1"]))
"""


def test_a_full_disk_stops_a_sweep_with_a_message_and_loses_nothing(tmp_path, capsys):
    """The results file cannot grow (RLIMIT_FSIZE: writes fail with EFBIG, as with a full
    disk; a subprocess, whose limit this process does not share): the sweep stops with status
    2 and says the rows are kept; rerun (here, where files can grow), it finishes the cases
    without repeating those done."""
    out = tmp_path / "s.jsonl"
    # the model cached first: only the results file is to grow
    compile_model(io.load("mass_spring_damper"), backend="python")
    proc = subprocess.run([sys.executable, "-c", _FULL, str(out)], capture_output=True,
                          text=True, env=_limited_env(), timeout=300, check=False)
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert "cannot write the results file" in proc.stderr and "is kept" in proc.stderr
    assert "Traceback" not in proc.stderr and "bug" not in proc.stderr
    done = len(out.read_bytes().split(b"\n")) - 2      # the header, a torn last line
    assert done >= 1
    again = cli.main(["--backend", "python", "sweep", "mass_spring_damper", "--grid",
                      "k=1:2:12", "--out", str(out), "--serial", "--t-end", "1", "--json"])
    output = capsys.readouterr()
    assert again == 0, output.err[-2000:]
    import json
    report = json.loads(output.out)["report"]
    assert report["n_done"] == 12 and report["n_previously_done"] == done


@pytest.mark.parametrize("command", [
    ["porthamiltonian", "sweep", "mass_spring_damper", "--grid", "k=1,2", "--serial", "--out"],
    ["walker", "optimize", "simplest_walker", "--vary", "slope", "--objective", "speed",
     "--step-down", "none", "--record"],
])
def test_a_results_file_inside_a_file_names_what_is_in_the_way(command, tmp_path, capsys):
    """``sweep --out FILE/s.jsonl`` and ``optimize --record FILE/x.jsonl`` said "cannot create
    the results file (File exists)": the file in the way is named now (status 2)."""
    taken = tmp_path / "taken"
    taken.write_text("a file")
    main = cli.main if command[0] == "porthamiltonian" else walker_cli.main
    assert main([*command[1:], str(taken / "rows.jsonl")]) == 2
    err = capsys.readouterr().err
    assert err.endswith(f"error: {taken} exists and is not a folder: give a folder to write "
                        "into\n"), err


_NO_ROOM = """
import resource, signal, sys
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (3000, 3000))   # no generated file fits anywhere
from porthamiltonian.interfaces import cli
from walker_library import cli as walker_cli
for backend in ("python", "c"):
    print(cli.main(["--backend", backend, "simulate", "mass_spring_damper", "--t-end", "1"]))
print(walker_cli.main(["gait", "rimless_wheel", "--backend", "c"]))
"""


def test_a_build_with_nowhere_to_write_says_so(tmp_path):
    """A build that can write its generated code nowhere (RLIMIT_FSIZE as with a full disk: the
    cache, then the private temporary folder; a subprocess with an empty cache) ended in "this
    is a bug" and a traceback: it is the machine's problem, exit status 2 with what to do, on
    the python back end (its module) and on C (the compiler's source)."""
    proc = subprocess.run([sys.executable, "-c", _NO_ROOM], capture_output=True, text=True,
                          env=_limited_env(PORTHAMILTONIAN_CACHE=str(tmp_path / "cache")),
                          timeout=300, check=False)
    assert proc.returncode == 0 and proc.stdout.split() == ["2", "2", "2"], proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr and "bug" not in proc.stderr, proc.stderr[-3000:]
    errors = [line for line in proc.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 3, proc.stderr
    assert "cannot write m" in errors[0] and "_python.py of the compiled model" in errors[0]
    for line in errors[1:]:
        assert "cannot write loops.c for the C compiler in " in line, line
    for line in errors:
        assert "(File too large): free space in " in line and "point TMPDIR" in line, line

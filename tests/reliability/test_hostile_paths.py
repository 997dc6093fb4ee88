"""Every path a user names is read by one bounded reader (issue 21; porthamiltonian/userfiles.py):
at most its limit whatever ``st_size`` says, what is not a file refused by type with its own
message, a pipe read within the same bound.

Before: a directory, a loop of links, a device and a FIFO all said "does not exist" (or, for a
bare name, "no model called"), ``simulate <(cat m.toml)`` failed where ``--guess <(...)`` worked,
``--guess /dev/zero`` read forever (the size check trusted st_size, 0 for a device), ``walker
gait`` and ``walker list`` read a 3 GB file whole before the size check, ``sweep --out /dev/zero``
read forever, and a UTF-8 byte-order mark was "Invalid statement".

Each hostile path is given to every reader that takes one (a model file by path, ``simulate``,
``walker gait --guess``, ``sweep --out``); each answers within :data:`bounds.REFUSAL_CPU`
seconds of processor time (and no hang) with exit status 2 or a ModelFileError whose message
says what the path is. The size cases run in subprocesses capped at 1 GB of address space.
"""
from __future__ import annotations

import os
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from bounds import MODELS_DIR, capped

from porthamiltonian import io, userfiles
from porthamiltonian.errors import ModelFileError
from porthamiltonian.interfaces import cli
from walker_library import cli as walker_cli

MSD = (MODELS_DIR / "mass_spring_damper.toml").read_text()
HUGE = 3_000_000_000          # a sparse file: st_size says 3 GB, nothing is on disk


def _make(kind: str, tmp_path: Path) -> tuple[str, str]:
    """(path, the words the refusal must hold) of a hostile path of ``kind``."""
    path = tmp_path / "target.toml"
    if kind == "directory":
        path.mkdir()
        return str(path), "is a directory"
    if kind == "missing":
        return str(path), "does not exist"
    if kind == "link loop":
        a, b = tmp_path / "a.toml", tmp_path / "b.toml"
        a.symlink_to(b)
        b.symlink_to(a)
        return str(a), "points to itself"
    if kind == "dangling link":
        path.symlink_to(tmp_path / "nowhere.toml")
        return str(path), "symbolic link to nothing"
    if kind in ("/dev/zero", "/dev/null", "/dev/urandom"):
        return kind, "is a device, not a file"
    if kind == "fifo with no writer":
        os.mkfifo(path)
        return str(path), "pipe that gave no data"
    if kind == "socket":
        path = tmp_path / "s.toml"
        sock = socket.socket(socket.AF_UNIX)
        sock.bind(str(path))
        _SOCKETS.append(sock)
        return str(path), "is a socket"
    if kind == "3 GB sparse file":
        with open(path, "wb") as fh:
            fh.truncate(HUGE)
        return str(path), f"{HUGE} bytes long"
    if kind == "not UTF-8":
        path.write_bytes(b"[model]\nname = \"\xff\xfe\"\n")
        return str(path), "not a UTF-8 text file"
    raise AssertionError(kind)


_SOCKETS: list[socket.socket] = []


@pytest.fixture(autouse=True)
def _close_sockets():
    yield
    while _SOCKETS:
        _SOCKETS.pop().close()


KINDS = ["directory", "missing", "link loop", "dangling link", "/dev/zero", "/dev/null",
         "/dev/urandom", "fifo with no writer", "socket", "3 GB sparse file", "not UTF-8"]


@pytest.mark.parametrize("kind", KINDS)
def test_model_file_path_is_refused_by_what_it_is(kind, tmp_path, within):
    path, words = _make(kind, tmp_path)
    with within(), pytest.raises(ModelFileError) as info:
        io.load(path)
    assert words in str(info.value) and path in str(info.value), str(info.value)


@pytest.mark.parametrize("kind", KINDS)
def test_simulate_names_what_the_path_is(kind, tmp_path, capsys, within):
    path, words = _make(kind, tmp_path)
    with within():
        status = cli.main(["--backend", "python", "simulate", path, "--t-end", "0.1"])
    err = capsys.readouterr().err
    assert status == 2 and err.startswith("error: ") and words in err, err
    assert "Traceback" not in err and "no model called" not in err


@pytest.mark.parametrize("kind", KINDS)
def test_guess_file_is_read_within_the_bound(kind, tmp_path, capsys, within):
    """``--guess`` is read before the walker is built: a refusal costs no build."""
    path, words = _make(kind, tmp_path)
    with within():
        status = walker_cli.main(["gait", "simplest_walker", "--guess", path])
    err = capsys.readouterr().err
    assert status == 2 and f"--guess {path}" in err and words in err, err


@pytest.mark.parametrize("kind, words", [
    ("directory", "is a directory"), ("/dev/zero", "is a device"), ("/dev/null", "is a device"),
    ("fifo with no writer", "is a pipe, not a file"), ("socket", "is a socket"),
    ("dangling link", "symbolic link to nothing"), ("link loop", "points to itself")])
def test_sweep_results_file_must_be_a_file(kind, words, tmp_path, capsys, within):
    path, _ = _make(kind, tmp_path)
    with within():
        status = cli.main(["--backend", "python", "sweep", "mass_spring_damper", "--grid",
                           "k=1:2:2", "--out", path, "--serial"])
    err = capsys.readouterr().err
    assert status == 2 and words in err, err


def _pipe(data: bytes, repeat: bool = False) -> str:
    """A pipe fed by a thread with ``data`` (forever when ``repeat``); its /dev/fd path."""
    r, w = os.pipe()

    def feed() -> None:
        try:
            while True:
                os.write(w, data)
                if not repeat:
                    break
        except OSError:         # the reader went away
            pass
        finally:
            os.close(w)

    threading.Thread(target=feed, daemon=True).start()
    return f"/dev/fd/{r}"


def test_a_pipe_is_read_like_a_file(tmp_path, within):
    """``simulate <(cat m.toml)``: the pipe's model loads (once, before any build)."""
    with within():
        model = io.load(_pipe(MSD.encode()))
    assert [name for name, _ in model.components()] == ["force", "j", "mass", "spring", "damper"]


def test_a_pipe_that_never_ends_is_read_to_the_bound_only(within, capsys):
    with within():
        status = walker_cli.main(["gait", "simplest_walker", "--guess",
                                  _pipe(b"x" * 65536, repeat=True)])
    err = capsys.readouterr().err
    assert status == 2 and "more than 10000000 bytes" in err, err


def test_process_substitution_works_for_simulate_as_for_guess(isolated_cache):
    """The shell's ``<(...)`` (a /dev/fd/N pipe): simulate reads it, as --guess does."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    model = MODELS_DIR / "mass_spring_damper.toml"
    command = (f'"{sys.executable}" -m porthamiltonian --backend python simulate '
               f'<(cat "{model}") --t-end 1')
    proc = subprocess.run(["bash", "-c", command], capture_output=True, text=True, env=env,
                          timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("mass_spring_damper: finished at t = 1 s")


def test_a_byte_order_mark_is_dropped(tmp_path):
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + MSD.encode())
    assert io.load(path).name == "mass_spring_damper"
    assert io.loads("\ufeff" + MSD).name == "mass_spring_damper"


def test_a_folder_with_a_model_name_does_not_hide_the_model(tmp_path, monkeypatch):
    """``porthamiltonian view pendulum --out pendulum`` leaves a folder called pendulum: the name
    still finds models/pendulum.toml; a folder that is no model's name is named as a folder."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "pendulum").mkdir()
    assert io.model_path("pendulum") == MODELS_DIR / "pendulum.toml"
    (tmp_path / "results").mkdir()
    with pytest.raises(ModelFileError, match="results is a directory, not a model file"):
        io.model_path("results")


def test_the_reader_never_trusts_st_size(tmp_path):
    """A file that grows past the limit after its size was looked at (a log being written, a
    /proc file whose st_size is 0) is still refused: the reader reads one byte past the limit."""
    assert userfiles.read_bytes("/proc/self/status", limit=1 << 20, label="x", kind="y")
    with pytest.raises(ModelFileError, match="more than 10 bytes"):
        userfiles.read_bytes("/proc/self/status", limit=10, label="x", kind="y")


# --- the size cases: memory-capped subprocesses ---------------------------------------------------
GIGABYTE = 1 << 30


def test_a_3_gb_model_file_costs_no_memory(tmp_path):
    """``walker gait`` of a 3 GB file under a 1 GB address-space cap: refused by its size
    (before: read whole, 3 GB, before the size check)."""
    path, _ = _make("3 GB sparse file", tmp_path)
    proc = capped(["-m", "walker_library", "gait", path], GIGABYTE)
    assert proc.returncode == 2, proc.stderr
    assert f"the file is {HUGE} bytes long" in proc.stderr and "MemoryError" not in proc.stderr


def test_walker_list_skips_a_huge_file(tmp_path):
    """``walker list`` with a 3 GB file among the models ($PORTHAMILTONIAN_MODELS), capped at
    1 GB: lists the walkers, reading at most 4 MB of that file."""
    folder = tmp_path / "models"
    folder.mkdir()
    with open(folder / "huge.toml", "wb") as fh:
        fh.truncate(HUGE)
    proc = capped(["-m", "walker_library", "list", "--json"], GIGABYTE,
                  env={"PORTHAMILTONIAN_MODELS": str(folder)})
    assert proc.returncode == 0, proc.stderr
    assert '"compass_walker"' in proc.stdout and "huge" not in proc.stdout


@pytest.mark.parametrize("kind", ["fifo with no writer", "socket"])
def test_a_written_file_replaces_no_pipe_socket_or_device(kind, tmp_path, capsys, within):
    """`export-fmu --out` (both commands) and `walker export --force` write a new file and
    rename it into place: over a pipe, a socket or a device that replaced the node with the file
    (run as root, `--out /dev/null` turned /dev/null into an FMU). Each is refused before any
    work, naming what is there, and the node stays (a pipe and a socket stand in for a device
    here: a regression must not replace this machine's /dev/null)."""
    path, _ = _make(kind, tmp_path)
    words = {"fifo with no writer": "is a pipe, not a file", "socket": "is a socket, not a file"}
    before = os.lstat(path)
    for main, argv in ((cli.main, ["export-fmu", "mass_spring_damper", "--out", path]),
                       (walker_cli.main, ["export-fmu", "compliant_leg_walker", "--out", path]),
                       (walker_cli.main, ["export", "compass_walker", path, "--force"])):
        with within():
            status = main(argv)
        err = capsys.readouterr().err
        assert status == 2 and err.startswith(f"error: {path} {words[kind]}"), err
        assert "give the" in err and "file" in err.split(";")[-1], err
        assert os.lstat(path).st_ino == before.st_ino and os.lstat(path).st_mode == before.st_mode
    assert userfiles.replace_problem(tmp_path / "nothing here") is None
    (tmp_path / "file").write_text("x")
    (tmp_path / "link").symlink_to(tmp_path / "nowhere")
    assert userfiles.replace_problem(tmp_path / "file") is None
    assert userfiles.replace_problem(tmp_path / "link") is None
    assert userfiles.replace_problem("/dev/null") == "is a device, not a file"

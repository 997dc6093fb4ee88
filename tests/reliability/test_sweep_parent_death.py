"""Sweeps survive the death of their parent (porthamiltonian.batch): ``walker sweep`` SIGKILLed
while its process pool is busy leaves no worker behind and no lock held, so the same command
resumes at once and ends with every case exactly once and the numbers of an uninterrupted run.
A results file forked into a child process is not kept locked by the child. A ``--out`` that is
a directory and an ``--option`` the analysis does not take are refused before any case runs."""
from __future__ import annotations

import json
import multiprocessing
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from porthamiltonian.batch import Sweep, SweepFileError, load_results
from porthamiltonian.batch.resultsfile import ResultsFile
from walker_library.analyses.cases import gait_case
from walker_library.cli import main

ROOT = Path(__file__).resolve().parents[2]
# simplest_walker's gait over 40 slopes, C back end: ~0.1 s per case on one core, so the sweep is
# still busy when both workers have written a row (from 0.015 on, the gait search continues
# through the period doublings: 7-70x longer)
N_CASES = 40
SLOPES = f"slope=0.004:0.012:{N_CASES}"
FIXED = {"model": "simplest_walker", "backend": "c"}


def _command(out: Path) -> list[str]:
    return [sys.executable, "-m", "walker_library.cli", "sweep", "simplest_walker", "--grid",
            SLOPES, "--backend", "c", "--workers", "2", "--progress", "none",
            "--out", str(out)]


def _env() -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    return env


def _rows(path: Path) -> int:
    try:
        return max(0, path.read_bytes().count(b"\n") - 1)
    except FileNotFoundError:
        return 0


def _alive(pid: int) -> bool:
    """Whether process ``pid`` runs (an exited one not yet reaped, a zombie, counts as gone
    where /proc tells)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[-1].split()[0] != "Z"
    except OSError:
        return True


def _workers(path: Path) -> set[int]:
    """The pool processes named by the rows written so far (a row's ``worker`` is host:pid)."""
    try:
        lines = path.read_text().split("\n")[1:-1]          # after the header, complete lines
    except FileNotFoundError:
        return set()
    return {int(json.loads(line)["worker"].rsplit(":", 1)[1]) for line in lines}


def _uninterrupted(tmp_path: Path) -> dict[int, tuple]:
    from porthamiltonian.batch import parse_grid
    path = tmp_path / "reference.jsonl"
    Sweep(gait_case, parse_grid([SLOPES]), path, fixed=FIXED).run(serial=True, progress="none")
    return {r["case_id"]: (r["case"], r["status"], r["result"]) for r in load_results(path)}


def test_sigkill_of_the_sweep_then_an_immediate_resume(tmp_path):
    out = tmp_path / "gait.jsonl"
    proc = subprocess.Popen(_command(out), env=_env(), cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    t0 = time.monotonic()
    while len(_workers(out)) < 2:                     # killed once each worker wrote a row
        assert proc.poll() is None, f"the sweep ended early: {proc.communicate()}"
        assert time.monotonic() - t0 < 120, "no rows from both workers in time"
        time.sleep(0.01)
    workers = _workers(out)
    assert len(workers) == 2, workers                 # both pool workers, busy with more cases
    os.kill(proc.pid, signal.SIGKILL)                 # the main process only, no handler runs
    proc.communicate(timeout=30)
    assert proc.returncode == -signal.SIGKILL
    n_before = len(load_results(out))
    assert 2 <= n_before < N_CASES

    # the same command, at once: the lock died with its holder (the workers never held it)
    resumed = subprocess.run(_command(out), env=_env(), cwd=ROOT, capture_output=True,
                             text=True, timeout=300, check=False)
    assert resumed.returncode == 0, resumed.stderr
    assert f"this run {N_CASES - n_before} case(s)" in resumed.stdout
    assert f"{n_before} already done" in resumed.stdout

    # the killed sweep's workers exited with it (parent-death signal)
    t0 = time.monotonic()
    while any(_alive(pid) for pid in workers) and time.monotonic() - t0 < 5:
        time.sleep(0.05)
    assert not any(_alive(pid) for pid in workers)

    rows = load_results(out)
    assert sorted(r["case_id"] for r in rows) == list(range(N_CASES))  # each case exactly once
    assert {r["case_id"]: (r["case"], r["status"], r["result"]) for r in rows} == \
        _uninterrupted(tmp_path)


def _hold(started, seconds: float) -> None:
    started.set()
    time.sleep(seconds)


def test_a_forked_child_does_not_keep_the_results_file_locked(tmp_path):
    """The lock is the sweep process's alone: a child forked while it is held (a pool worker)
    does not keep it after the holder lets go (or dies)."""
    path = tmp_path / "s.jsonl"
    header = b'{"format": "porthamiltonian-sweep", "version": 1, "sweep": {"function": "f", ' \
             b'"fixed": {}, "n_cases": 1, "cases_sha256": ""}}\n'
    held, _ = ResultsFile.open(path, header, lambda scan: None)
    fork = multiprocessing.get_context("fork")
    started = fork.Event()
    child = fork.Process(target=_hold, args=(started, 30.0))
    child.start()
    try:
        assert started.wait(30)                       # the child runs (its at-fork hooks ran)
        with pytest.raises(SweepFileError, match="being written by another running sweep"):
            ResultsFile.open(path, header, lambda scan: None)
        held.close()                                  # as the holder's death would
        again, _ = ResultsFile.open(path, header, lambda scan: None)
        again.close()
        assert child.is_alive()
    finally:
        child.kill()
        child.join()


def test_out_naming_a_directory_is_refused_before_any_case_runs(tmp_path, capsys):
    assert main(["sweep", "simplest_walker", "--grid", "slope=0.009", "--backend", "python",
                 "--serial", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {tmp_path} is a directory; name a results file")
    assert list(tmp_path.iterdir()) == []


def test_unknown_option_is_refused_before_any_case_runs(tmp_path, capsys):
    out = tmp_path / "s.jsonl"
    assert main(["sweep", "simplest_walker", "--grid", "slope=0.009", "--backend", "python",
                 "--serial", "--option", "max_periods=4", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: unknown option 'max_periods' of the case function "
                          "walker_library.analyses.cases:gait_case; it takes: model, backend, "
                          "max_period, fd_step, n_iterate"), err
    assert not out.exists()

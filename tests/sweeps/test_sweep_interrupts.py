"""A sweep interrupted half-way and resumed: `walker sweep` (walker_library.cli.main) in a
subprocess with a process pool, stopped by SIGINT, SIGTERM or SIGKILL after some rows are in its
file, then run again. Checked against an uninterrupted run of the same sweep: every case appears
exactly once, with the same numbers; the rows written before the stop are not recomputed; the
worker processes are gone after a SIGINT/SIGTERM; a torn last line from a hard kill is
truncated with a warning."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import sweep_cases

from porthamiltonian.batch import Sweep, grid, load_results, read_header
from walker_library.cli import main

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
# 16 cases of 0.12 s on 2 workers: ~1 s of work, stopped after 3 or 4 rows
N = 16
CHEAP = ["sweep", "unused", "--analysis", "sweep_cases:square_case", "--grid", f"x=1:{N}:{N}",
         "--grid", "y=0.5", "--option", "delay=0.12", "--workers", "2", "--progress", "text",
         "--progress-interval", "0"]
CHEAP_CASES = grid(x=[float(x) for x in range(1, N + 1)], y=[0.5])
CHEAP_FIXED = {"model": "unused", "backend": None, "delay": 0.12}
# what an uninterrupted run gives (the delay does not change the numbers)
CHEAP_EXPECTED = {i: (case, "ok", sweep_cases.square_case(case)) for i, case in enumerate(CHEAP_CASES)}


def _env() -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(HERE), str(ROOT), env.get("PYTHONPATH", "")])
    return env


def _start(args: list[str], **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "walker_library.cli", *args],
                            env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=ROOT, **kw)


def _rows_written(path: Path) -> int:
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return 0
    return max(0, data.count(b"\n") - 1)


def _wait_for_rows(proc: subprocess.Popen, path: Path, n: int, timeout: float = 60.0) -> None:
    t0 = time.monotonic()
    while _rows_written(path) < n:
        assert proc.poll() is None, f"the sweep ended early: {proc.communicate()}"
        assert time.monotonic() - t0 < timeout, "no rows in time"
        time.sleep(0.01)


def _results(rows: list[dict]) -> dict[int, tuple]:
    return {r["case_id"]: (r["case"], r["status"], r["result"]) for r in rows}


def _resume_in_process(out: Path, function, cases, fixed):
    """Run the sweep again from Python, as the same sweep (same identity and metadata)."""
    meta = read_header(out)["meta"]
    return Sweep(function, cases, out, fixed=fixed, meta=meta).run(workers=2, progress="none")


def _gone(pids: set[int], timeout: float = 5.0) -> bool:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        alive = set()
        for pid in pids:
            try:
                os.kill(pid, 0)
                with open(f"/proc/{pid}/stat") as fh:     # a zombie is gone too
                    if fh.read().split(")")[-1].split()[0] != "Z":
                        alive.add(pid)
            except (ProcessLookupError, FileNotFoundError):
                pass
        if not alive:
            return True
        time.sleep(0.05)
    return False


def _interrupt(out: Path, sig: signal.Signals, after: int) -> bytes:
    """Start the cheap sweep, send ``sig`` once ``after`` rows are in the file; check the exit
    status, the message, the file and that the pool's workers are gone. The file's bytes."""
    proc = _start([*CHEAP, "--out", str(out)])
    _wait_for_rows(proc, out, after)
    proc.send_signal(sig)
    _, stderr = proc.communicate(timeout=30)
    assert proc.returncode == 128 + sig, stderr
    assert f"interrupted: sweep interrupted by {sig.name}" in stderr
    assert "run the same sweep again to resume" in stderr
    data = out.read_bytes()
    assert data.endswith(b"\n")
    partial = load_results(out)
    assert after <= len(partial) < N
    assert _gone({int(r["worker"].rsplit(":", 1)[1]) for r in partial})
    return data


def test_sigint_pool_sweep_resumes_from_the_command_line_to_the_uninterrupted_table(tmp_path,
                                                                                  capsys):
    out = tmp_path / "sweep.jsonl"
    first = _interrupt(out, signal.SIGINT, 4)
    n_partial = len(load_results(out))
    assert main([*CHEAP, "--out", str(out)]) == 0          # the same command, again
    stdout = capsys.readouterr().out
    assert f"{out}: {N}/{N} cases (ok {N}); this run {N - n_partial} case(s)" in stdout
    assert f"{n_partial} already done" in stdout
    assert out.read_bytes().startswith(first)         # appended, nothing rewritten
    rows = load_results(out)
    assert sorted(r["case_id"] for r in rows) == list(range(N))     # each case exactly once
    assert _results(rows) == CHEAP_EXPECTED


def test_sigterm_is_handled_like_sigint(tmp_path):
    out = tmp_path / "sweep.jsonl"
    first = _interrupt(out, signal.SIGTERM, 3)
    n_partial = len(load_results(out))
    report = _resume_in_process(out, sweep_cases.square_case, CHEAP_CASES, CHEAP_FIXED)
    assert (report.n_run, report.n_previously_done) == (N - n_partial, n_partial)
    assert out.read_bytes().startswith(first)
    rows = load_results(out)
    assert sorted(r["case_id"] for r in rows) == list(range(N))
    assert _results(rows) == CHEAP_EXPECTED


def test_hard_killed_sweep_with_a_torn_last_line_resumes(tmp_path):
    """SIGKILL to the whole process group (no handler runs), then a torn row appended as a kill
    during a write leaves it: the next run warns, truncates it and completes the sweep."""
    out = tmp_path / "sweep.jsonl"
    proc = _start([*CHEAP, "--out", str(out)], start_new_session=True)
    _wait_for_rows(proc, out, 3)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.communicate(timeout=30)
    assert proc.returncode == -signal.SIGKILL
    done = load_results(out)
    assert 3 <= len(done) < N
    missing = next(i for i in range(N) if i not in {r["case_id"] for r in done})
    torn = json.dumps({"case_id": missing, "case": CHEAP_CASES[missing], "status": "ok",
                       "result": {"square": 1.0}})[:40]
    with open(out, "ab") as fh:
        fh.write(torn.encode())
    valid = out.read_bytes()[:-40]

    with pytest.warns(UserWarning, match=rf"line {len(done) + 2}: torn last line \(40 bytes, an "
                      "interrupted write\\) removed; that case runs again"):
        report = _resume_in_process(out, sweep_cases.square_case, CHEAP_CASES, CHEAP_FIXED)
    assert report.n_run == N - len(done)
    assert out.read_bytes().startswith(valid)
    rows = load_results(out)
    assert sorted(r["case_id"] for r in rows) == list(range(N))
    assert _results(rows) == CHEAP_EXPECTED


def test_interrupted_simplest_walker_gait_sweep_resumes_to_the_same_numbers(tmp_path, capsys,
                                                                            gait_reference):
    """The real thing: simplest_walker gait over the reference's first 3 slopes (C back end, one
    worker), stopped by SIGINT after the first row, resumed; the table equals an uninterrupted
    in-process run (the reference's fourth slope, chaotic, ~5 s of CPU, is the same machinery's
    case: the reference checks its verdict)."""
    out = tmp_path / "gait.jsonl"
    args = ["sweep", "simplest_walker", "--grid", "slope=0.004:0.014:3", "--out", str(out),
            "--backend", "c", "--workers", "1", "--progress", "none"]
    proc = _start(args)
    _wait_for_rows(proc, out, 1)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=30)
    assert proc.returncode == 130, stderr
    partial = load_results(out)
    assert 1 <= len(partial) < 3

    assert main([*args, "--json"]) == 0                    # the same command, again
    doc = json.loads(capsys.readouterr().out)
    assert doc["report"]["n_run"] == 3 - len(partial) and doc["report"]["complete"]
    assert doc["identity"]["function"] == "walker_library.analyses.cases:gait_case"
    assert doc["identity"]["fixed"] == {"backend": "c", "model": "simplest_walker"}
    rows = load_results(out)
    assert sorted(r["case_id"] for r in rows) == [0, 1, 2]
    reference = gait_reference
    assert _results(rows) == {i: reference[i] for i in range(3)}
    statuses = [reference[i][1] for i in range(4)]
    # γ = 0.019: chaotic, only unstable orbits (status "periodic", not stable)
    assert statuses == ["periodic"] * 4
    assert [reference[i][2]["stable"] for i in range(4)] == [True, True, True, False]
    assert [row["status"] for row in doc["table"]] == statuses[:3]

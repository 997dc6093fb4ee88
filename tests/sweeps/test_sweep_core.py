"""Sweeps in one process: grids and command-line specs, the results file (header, rows, resume
without recomputing), refusal of foreign, mismatched and corrupt files (left byte-identical),
failing cases as rows, a crashing worker, the tidy table and CSV, progress display, and the
walker analyses (porthamiltonian.batch, walker_library.analyses)."""
from __future__ import annotations

import csv
import json
import math
import warnings
from concurrent.futures import Executor, Future
from pathlib import Path

import numpy as np
import pytest
import sweep_cases

from porthamiltonian import batch
from porthamiltonian.batch import (
    Sweep,
    SweepError,
    SweepFileError,
    SweepInterrupted,
    grid,
    load_results,
    parse_axis,
    parse_grid,
    read_header,
    table,
    write_csv,
)
from porthamiltonian.errors import ModelError
from walker_library.analyses import cases as analyses

CASES = grid(x=[1.0, 2.0, 3.0], y=[0.0, 0.5])


def _lines(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


# --- grids -----------------------------------------------------------------------------------
def test_grid_is_the_cartesian_product_with_the_last_axis_fastest():
    cases = grid(a=[1, 2], b=np.array([10.0, 20.0]), c=0.5)
    assert cases == [{"a": 1, "b": 10.0, "c": 0.5}, {"a": 1, "b": 20.0, "c": 0.5},
                     {"a": 2, "b": 10.0, "c": 0.5}, {"a": 2, "b": 20.0, "c": 0.5}]
    assert all(type(c["b"]) is float for c in cases)       # numpy scalars became floats


def test_grid_refuses_empty_axes_and_non_finite_values():
    with pytest.raises(SweepError, match="axis 'a' has no values"):
        grid(a=[])
    with pytest.raises(SweepError, match="not finite"):
        grid(a=[1.0, math.nan])
    with pytest.raises(SweepError, match="not a number, string, bool, list or dict"):
        grid(a=[object()])


def test_parse_axis_ranges_lists_and_single_values():
    assert parse_axis("slope=0.004:0.019:4") == ("slope", [0.004, 0.009, 0.014, 0.019])
    assert parse_axis("K=1e4,2e4, 3e4") == ("K", [1e4, 2e4, 3e4])
    assert parse_axis("lam=0.5") == ("lam", [0.5])
    assert parse_axis("h=-0.01:0:1") == ("h", [-0.01])
    assert parse_grid(["a=1,2", "b=0:1:3"]) == [
        {"a": 1.0, "b": 0.0}, {"a": 1.0, "b": 0.5}, {"a": 1.0, "b": 1.0},
        {"a": 2.0, "b": 0.0}, {"a": 2.0, "b": 0.5}, {"a": 2.0, "b": 1.0}]


@pytest.mark.parametrize("spec, message", [
    ("slope", "write NAME=start:stop:n or NAME=v1,v2"),
    ("1x=3", "write NAME=start:stop:n"),
    ("slope=0:1", "three fields"),
    ("slope=0:1:0", "n = 0 must be at least 1"),
    ("slope=0:1:2.5", "whole number"),
    ("slope=a,b", "'a' is not a number"),
    ("slope=", "no values"),
    ("slope=inf", "not finite"),
])
def test_parse_axis_errors_say_what_to_write(spec, message):
    with pytest.raises(SweepError, match=message) as info:
        parse_axis(spec)
    assert isinstance(info.value, ModelError) and repr(spec) in str(info.value)


def test_parse_grid_refuses_an_axis_given_twice():
    with pytest.raises(SweepError, match="axis 'a' is given twice"):
        parse_grid(["a=1", "a=2"])


# --- the file, resume ---------------------------------------------------------------------------
def test_header_rows_and_identity(tmp_path):
    path = tmp_path / "s.jsonl"
    sweep = Sweep(sweep_cases.square_case, CASES, path, fixed={"scale": 2.0}, meta={"who": "t"})
    report = sweep.run(serial=True, progress="none")
    assert (report.n_cases, report.n_done, report.n_run, report.n_previously_done) == (6, 6, 6, 0)
    assert report.complete and report.status_counts == {"ok": 6} and report.interrupted is None
    header, *rows = _lines(path)
    assert header["format"] == batch.FORMAT and header["version"] == 1
    assert header["sweep"] == {"function": "sweep_cases:square_case", "fixed": {"scale": 2.0},
                               "n_cases": 6, "cases_sha256": batch.cases_sha256(CASES)}
    assert header["meta"] == {"who": "t"} and read_header(path) == header
    assert [r["case_id"] for r in rows] == list(range(6))     # serial: completion = case order
    for row in rows:
        case = CASES[row["case_id"]]
        assert row["case"] == case and row["status"] == "ok"
        assert row["result"] == sweep_cases.square_case(case, scale=2.0)
        assert row["seconds"] >= 0 and row["finished"].endswith("Z") and ":" in row["worker"]
    assert path.read_bytes().endswith(b"\n")


def test_rerun_recomputes_nothing_and_leaves_the_file_byte_identical(tmp_path):
    path = tmp_path / "s.jsonl"
    sweep = Sweep(sweep_cases.counting_case, grid(x=[1, 2, 3, 4]), path)
    sweep_cases.CALLS.clear()
    sweep.run(serial=True, progress="none")
    assert sweep_cases.CALLS == [1, 2, 3, 4]
    before = path.read_bytes()
    report = Sweep(sweep_cases.counting_case, grid(x=[1, 2, 3, 4]), path).run(progress="none")
    assert (report.n_run, report.n_previously_done, report.n_done) == (0, 4, 4)
    assert sweep_cases.CALLS == [1, 2, 3, 4] and path.read_bytes() == before


def test_interrupted_serial_sweep_resumes_with_the_remaining_cases_only(tmp_path):
    """A KeyboardInterrupt inside case x = 3 stops the sweep (SweepInterrupted carries the
    report); the rerun computes exactly the cases not in the file."""
    path = tmp_path / "s.jsonl"
    cases = grid(x=[1, 2, 3, 4, 5])
    sweep_cases.CALLS.clear()
    sweep_cases.INTERRUPT_AT = 3
    try:
        with pytest.raises(SweepInterrupted) as info:
            Sweep(sweep_cases.counting_case, cases, path).run(serial=True, progress="none")
    finally:
        sweep_cases.INTERRUPT_AT = None
    report = info.value.report
    assert isinstance(info.value, KeyboardInterrupt) and info.value.signum == 2
    assert (report.n_done, report.n_run, report.n_lost, report.interrupted) == (2, 2, 3, "SIGINT")
    assert "run the same sweep again to resume" in str(info.value)
    assert [r["case_id"] for r in load_results(path)] == [0, 1]
    report = Sweep(sweep_cases.counting_case, cases, path).run(serial=True, progress="none")
    assert sweep_cases.CALLS == [1, 2, 3, 4, 5]
    assert (report.n_run, report.n_previously_done) == (3, 2)
    assert sorted(r["case_id"] for r in load_results(path)) == [0, 1, 2, 3, 4]


def test_pool_run_resumes_a_partial_file_and_gives_the_serial_table(tmp_path):
    ref = Sweep(sweep_cases.square_case, CASES, tmp_path / "ref.jsonl")
    ref.run(serial=True, progress="none")
    path = tmp_path / "s.jsonl"
    lines = (tmp_path / "ref.jsonl").read_bytes().splitlines(keepends=True)
    path.write_bytes(b"".join(lines[:3]))                # header + cases 0 and 1
    report = Sweep(sweep_cases.square_case, CASES, path).run(workers=2, progress="none")
    assert (report.n_run, report.n_previously_done) == (4, 2)
    assert path.read_bytes().startswith(b"".join(lines[:3]))
    strip = lambda rows: [{k: v for k, v in r.items() if k != "seconds"} for r in rows]
    assert strip(Sweep(sweep_cases.square_case, CASES, path).table()) == strip(ref.table())


def test_an_empty_existing_file_is_started(tmp_path):
    path = tmp_path / "s.jsonl"
    path.touch()
    Sweep(sweep_cases.square_case, CASES[:2], path).run(serial=True, progress="none")
    assert [r["case_id"] for r in load_results(path)] == [0, 1]


# --- refused files ------------------------------------------------------------------------------
def _complete_file(tmp_path: Path, name: str = "s.jsonl") -> Path:
    path = tmp_path / name
    Sweep(sweep_cases.square_case, CASES, path).run(serial=True, progress="none")
    return path


def _refused(path: Path, sweep: Sweep, *needles: str) -> str:
    before = path.read_bytes()
    with pytest.raises(SweepFileError) as info:
        sweep.run(serial=True, progress="none")
    msg = str(info.value)
    assert str(path) in msg, msg
    for needle in needles:
        assert needle in msg, (needle, msg)
    assert path.read_bytes() == before
    return msg


def test_foreign_file_is_refused_and_left_unchanged(tmp_path):
    path = tmp_path / "results.csv"
    path.write_text("slope,speed\n0.009,0.1\n")
    _refused(path, Sweep(sweep_cases.square_case, CASES, path),
             "not a sweep results file", "line 1 is not a JSON header line",
             "write the sweep to another file")
    path.write_text('{"format": "something-else"}\n{"case_id": 0}\n')
    _refused(path, Sweep(sweep_cases.square_case, CASES, path), '"format": "porthamiltonian-sweep"')
    path.write_text('{"format": "walker-sweep", "version": 1}\n')
    _refused(path, Sweep(sweep_cases.square_case, CASES, path), "line 1", "no complete \"sweep\"")
    path.write_text('{"format": "walker-sweep", "version": 99, "sweep": {}}\n')
    _refused(path, Sweep(sweep_cases.square_case, CASES, path), "version 99", "upgrade")


def test_file_of_a_different_sweep_is_refused_naming_the_difference(tmp_path):
    path = _complete_file(tmp_path)
    msg = _refused(path, Sweep(sweep_cases.square_case, CASES[:4], path),
                   "line 1", "different sweep", "case list: 6 cases", "(now)",
                   "write this one to another file")
    assert "4 cases" in msg
    _refused(path, Sweep(sweep_cases.square_case, CASES, path, fixed={"scale": 3.0}),
             'fixed arguments {} (file) vs {"scale":3.0} (now)')
    _refused(path, Sweep(sweep_cases.mixed_case, CASES, path),
             "case function sweep_cases:square_case (file) vs sweep_cases:mixed_case (now)")


def test_corrupt_row_in_the_middle_is_refused_naming_the_line(tmp_path):
    path = _complete_file(tmp_path)
    lines = path.read_bytes().splitlines(keepends=True)
    lines[3] = lines[3][:20] + b"\n"                       # row of line 4 cut short
    path.write_bytes(b"".join(lines))
    _refused(path, Sweep(sweep_cases.square_case, CASES, path),
             "line 4: a corrupt row (not JSON", "delete line 4 to run that case again")
    lines[3] = b"\n"
    path.write_bytes(b"".join(lines))
    _refused(path, Sweep(sweep_cases.square_case, CASES, path), "line 4: an empty line")
    lines[3] = b'{"case_id": 2, "case": {"x": 9.0, "y": 0.0}, "status": "ok", "result": {}}\n'
    path.write_bytes(b"".join(lines))
    _refused(path, Sweep(sweep_cases.square_case, CASES, path),
             "line 4: row of case 2 holds case {\"x\":9.0,\"y\":0.0}", "case 2 is {\"x\":2.0")
    lines[3] = b'{"case_id": 2, "case": {"x": 2.0, "y": 0.0}}\n'
    path.write_bytes(b"".join(lines))
    _refused(path, Sweep(sweep_cases.square_case, CASES, path), "line 4", "missing status, result")
    with pytest.raises(SweepFileError, match="line 4"):
        load_results(path)


def test_torn_last_line_is_truncated_with_a_warning_and_its_case_run_again(tmp_path):
    path = _complete_file(tmp_path)
    full = path.read_bytes()
    lines = full.splitlines(keepends=True)
    path.write_bytes(b"".join(lines[:-1]) + lines[-1][:37])   # the last row torn mid-write
    with pytest.warns(UserWarning, match="line 7: torn last line"):
        assert len(load_results(path)) == 5                    # reading leaves the file alone
    with pytest.warns(UserWarning, match=r"line 7: torn last line \(37 bytes"):
        report = Sweep(sweep_cases.square_case, CASES, path).run(serial=True, progress="none")
    assert report.n_run == 1 and report.n_previously_done == 5
    rows = load_results(path)
    assert sorted(r["case_id"] for r in rows) == list(range(6)) and rows[-1]["case_id"] == 5
    assert path.read_bytes().startswith(b"".join(lines[:-1]))


def test_last_row_without_its_newline_is_kept(tmp_path):
    path = _complete_file(tmp_path)
    path.write_bytes(path.read_bytes()[:-1])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        report = Sweep(sweep_cases.square_case, CASES, path).run(serial=True, progress="none")
    assert report.n_run == 0 and path.read_bytes().endswith(b"}\n")
    assert len(load_results(path)) == 6


def test_a_file_locked_by_a_running_sweep_is_refused(tmp_path):
    import fcntl
    path = _complete_file(tmp_path)
    with open(path, "rb") as other:
        fcntl.flock(other.fileno(), fcntl.LOCK_EX)
        _refused(path, Sweep(sweep_cases.square_case, CASES, path),
                 "is being written by another running sweep")


def test_case_function_must_be_importable_by_workers(tmp_path):
    with pytest.raises(SweepError, match="top-level function of an importable module"):
        Sweep(lambda case: {}, CASES, tmp_path / "s.jsonl")

    def local(case):
        return {}
    with pytest.raises(SweepError, match="lambdas and nested functions"):
        Sweep(local, CASES, tmp_path / "s.jsonl")
    with pytest.raises(SweepError, match="fixed argument .delay.: value <object"):
        Sweep(sweep_cases.square_case, CASES, tmp_path / "s.jsonl", fixed={"delay": object()})


# --- failing cases ------------------------------------------------------------------------------
@pytest.mark.parametrize("serial", [True, False], ids=["serial", "pool"])
def test_failing_cases_are_rows_with_their_status_and_message(tmp_path, serial):
    path = tmp_path / "s.jsonl"
    sweep = Sweep(sweep_cases.mixed_case, grid(x=[-1, 0, 1, 2, 3, 4]), path)
    report = sweep.run(serial=serial, workers=2, progress="none")
    assert report.complete and report.status_counts == {"error": 2, "fell": 1, "ok": 3}
    rows = {r["case_id"]: r for r in load_results(path)}
    assert rows[0]["status"] == "error" and rows[0]["result"] is None
    assert rows[0]["message"] == "ValueError: negative x = -1"
    assert rows[0]["error_type"] == "builtins.ValueError" and "mixed_case" in rows[0]["traceback"]
    assert rows[1]["status"] == "fell" and rows[1]["result"]["message"] == "fell at step 3"
    assert rows[2]["status"] == "ok" and rows[2]["result"] == {"value": 1.0}   # no status: ok
    assert rows[3]["result"] == {"status": "ok", "value": None}                 # NaN -> null
    assert rows[4]["message"] == "TypeError: the case function returned list, expected a dict of results"
    tab = sweep.table()
    assert [r["status"] for r in tab] == ["error", "fell", "ok", "ok", "error", "ok"]
    assert tab[1]["message"] == "fell at step 3" and tab[0]["message"].startswith("ValueError")


def test_a_case_that_kills_its_worker_becomes_an_error_row(tmp_path):
    """The pool breaks; the cases in flight run again one at a time; the one that kills its
    process again is an "error" row, the others are computed."""
    path = tmp_path / "s.jsonl"
    cases = [{"x": 1.0}, {"x": 2.0}, {"x": 3.0, "crash": True}, {"x": 4.0}, {"x": 5.0}]
    report = Sweep(sweep_cases.crash_case, cases, path).run(workers=2, progress="none")
    assert report.complete and report.status_counts == {"ok": 4, "error": 1}
    rows = {r["case_id"]: r for r in load_results(path)}
    assert len(load_results(path)) == 5
    assert rows[2]["status"] == "error" and "worker process died" in rows[2]["message"]
    assert all(rows[i]["result"] == {"status": "ok", "x": cases[i]["x"]} for i in (0, 1, 3, 4))


def test_a_pool_that_dies_between_a_wait_and_the_next_submit_is_replaced(tmp_path, monkeypatch):
    """A worker dies after the runner collected the finished futures and before it submits the
    next case (the pool refuses the submission with BrokenProcessPool; seen under load in
    test_a_case_that_kills_its_worker_becomes_an_error_row): the cases in flight run again,
    every case is computed once, none is lost."""
    import os
    import signal
    import time
    from concurrent.futures import ProcessPoolExecutor

    from porthamiltonian.batch import runner

    killed: list[int] = []

    class DyingPool(ProcessPoolExecutor):
        def submit(self, fn, /, *args, **kwargs):
            if len(killed) == 0 and args[2] == 4:       # case 4: the first after the window
                pid = next(iter(self._processes))
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
                t0 = time.monotonic()
                while not self._broken and time.monotonic() - t0 < 30:
                    time.sleep(0.01)
                assert self._broken
            return super().submit(fn, *args, **kwargs)

    monkeypatch.setattr(runner, "ProcessPoolExecutor", DyingPool)
    path = tmp_path / "s.jsonl"
    cases = [{"x": float(x)} for x in range(1, 7)]
    report = Sweep(sweep_cases.crash_case, cases, path).run(workers=2, progress="none")
    assert len(killed) == 1
    assert report.complete and report.status_counts == {"ok": 6}
    rows = load_results(path)
    assert sorted(r["case_id"] for r in rows) == list(range(6))
    assert all(r["result"] == {"status": "ok", "x": cases[r["case_id"]]["x"]} for r in rows)


# --- tidy table, CSV ------------------------------------------------------------------------------
def test_table_is_in_case_order_with_flat_columns_and_pending_cases(tmp_path):
    path = tmp_path / "s.jsonl"
    sweep = Sweep(sweep_cases.square_case, CASES, path)
    rows = [batch.run_case(sweep_cases.square_case, {}, i, CASES[i]) for i in (4, 1)]
    full = table(rows, CASES, pending=True)
    assert [r["case_id"] for r in full] == list(range(6))
    assert [r["status"] for r in full] == ["pending", "ok", "pending", "pending", "ok", "pending"]
    assert full[1] == {"case_id": 1, "x": 1.0, "y": 0.5, "status": "ok", "square": 1.0,
                       "mix": math.sin(1.0) * math.exp(-0.5), "nested.sum": 1.5,
                       "message": None, "seconds": rows[1]["seconds"]}
    assert [r["case_id"] for r in table(rows)] == [1, 4]
    assert sweep.table(pending=True)[0] == {"case_id": 0, "x": 1.0, "y": 0.0, "status": "pending"}


def test_csv_export(tmp_path):
    path = _complete_file(tmp_path)
    out = Sweep(sweep_cases.square_case, CASES, path).to_csv(tmp_path / "s.csv")
    with open(out, newline="") as fh:
        got = list(csv.reader(fh))
    assert got[0] == ["case_id", "x", "y", "status", "square", "mix", "nested.sum", "message",
                      "seconds"]
    assert len(got) == 7
    assert got[2][:7] == ["1", "1.0", "0.5", "ok", "1.0", repr(math.sin(1.0) * math.exp(-0.5)), "1.5"]
    assert got[2][7] == ""                                  # null message
    write_csv([{"a": True, "b": [1, 2]}, {"c": None}], tmp_path / "t.csv")
    assert (tmp_path / "t.csv").read_text().splitlines() == ["a,b,c", 'true,"[1, 2]",', ",,"]


# --- progress -------------------------------------------------------------------------------------
def test_text_progress_lines_show_cases_failures_and_eta(tmp_path, capsys):
    Sweep(sweep_cases.mixed_case, grid(x=[-1, 0, 4]), tmp_path / "s.jsonl").run(
        serial=True, progress="text", progress_interval=0.0)
    err = capsys.readouterr().err.splitlines()
    assert err[0] == "sweep s.jsonl: 0/3 cases, 0 failed, elapsed 0s, ETA ?"
    assert err[1].startswith("sweep s.jsonl: 1/3 cases, 1 failed (error 1), ")
    assert "cases/min" in err[1] and "ETA" in err[1]
    assert err[-1].startswith("sweep s.jsonl: 3/3 cases, 2 failed (error 1, fell 1), ")
    assert "ETA" not in err[-1]


def test_progress_bar_and_none(tmp_path, capsys):
    Sweep(sweep_cases.square_case, CASES, tmp_path / "a.jsonl").run(serial=True, progress="bar")
    err = capsys.readouterr().err
    assert "6/6" in err and "case" in err and "0 failed" in err
    Sweep(sweep_cases.square_case, CASES, tmp_path / "b.jsonl").run(serial=True, progress="none")
    assert capsys.readouterr().err == ""
    with pytest.raises(SweepError, match="progress must be"):
        Sweep(sweep_cases.square_case, CASES, tmp_path / "c.jsonl").run(serial=True, progress="x")


@pytest.mark.parametrize("serial", [True, False], ids=["serial", "pool"])
def test_progress_counts_the_work_ticks_of_the_cases(tmp_path, capsys, serial):
    """Work ticks of the case functions reach the display, also from pool workers."""
    Sweep(sweep_cases.ticking_case, grid(x=[1, 2, 3, 4]), tmp_path / "s.jsonl").run(
        serial=serial, workers=2, progress="text", progress_interval=0.0)
    last = capsys.readouterr().err.splitlines()[-1]
    assert last.startswith("sweep s.jsonl: 4/4 cases, 0 failed, 10 iterations, "), last


def test_activity_counts_ticks_on_a_terminal_only():
    import io

    from porthamiltonian.batch import activity, tick

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    shown, hidden = Terminal(), io.StringIO()
    for stream in (shown, hidden):
        with activity("gait test", stream=stream) as display:
            for _ in range(3):
                tick("stride")
            display.write("a line")
    assert "gait test, 3 strides [00:00]" in shown.getvalue() and "a line" in shown.getvalue()
    assert hidden.getvalue() == "a line\n"


# --- analyses ---------------------------------------------------------------------------------------
def test_walker_analyses_by_name_and_module_function_names():
    assert analyses.get_analysis("gait").resolve() is analyses.gait_case
    assert analyses.get_analysis("gait").ok_statuses == ("periodic",)
    assert analyses.get_analysis("step-down").resolve() is analyses.step_down_case
    assert analyses.get_analysis("basin").resolve() is analyses.basin_case
    with pytest.raises(SweepError, match="unknown analysis 'orbit'; analyses: gait, step-down, basin"):
        analyses.get_analysis("orbit")
    entry = analyses.get_analysis("sweep_cases:square_case")
    assert entry.resolve() is sweep_cases.square_case and entry.run_prepare([], {}) == {}
    assert analyses.get_analysis("sweep_cases:mixed_case").resolve() is sweep_cases.mixed_case
    with pytest.raises(SweepError, match="cannot import the case function 'no_module:f'"):
        analyses.get_analysis("no_module:f").resolve()


def test_a_basin_sweep_ships_the_gait_found_once_to_its_workers(tmp_path):
    """prepare_basin finds the gait in this process; the pool's workers use that one (a gait
    that says "fell" makes every point "no_gait") and give the rows of cases that find it."""
    import dataclasses
    fixed = {"model": "simplest_walker", "backend": "c", "params": {"slope": 0.009}}
    cases = grid(theta=[0.2], theta_dot=[-0.2, -0.19])
    shared = analyses.prepare_basin(cases, **fixed)
    assert shared["gait"].status == "periodic"
    analyses.walker_cache().clear_gaits()
    sweep = Sweep(analyses.basin_case, cases, tmp_path / "a.jsonl", fixed=fixed, shared=shared)
    sweep.run(workers=2, progress="none")
    own = [analyses.basin_case(case, **fixed) for case in cases]       # each finds the gait
    assert [r["result"] for r in sorted(load_results(sweep.path), key=lambda r: r["case_id"])] == own
    assert [r["status"] for r in own] == ["converged", "fell"]
    fell = {"gait": dataclasses.replace(shared["gait"], status="fell", message="shipped")}
    other = Sweep(analyses.basin_case, cases, tmp_path / "b.jsonl", fixed=fixed, shared=fell)
    other.run(workers=2, progress="none")
    assert [(r["status"], r["message"]) for r in other.table()] == [("no_gait", "shipped")] * 2
    assert other.identity == sweep.identity                         # shared: not the identity


# --- executors that lose or fail cases ---------------------------------------------------------------
class _FlakyExecutor(Executor):
    """Runs cases in this thread; cancels case x == 2 (as a cluster losing it would) and fails
    case x == 3 with an executor-level error (as dask's KilledWorker would)."""

    def submit(self, fn, *args, **kwargs):
        future = Future()
        x = args[3]["x"]
        if x == 2:
            future.cancel()
            future.set_running_or_notify_cancel()
        elif x == 3:
            future.set_exception(RuntimeError("worker lost 3 times"))
        else:
            future.set_result(fn(*args, **kwargs))
        return future


def test_cases_lost_or_failed_by_the_executor(tmp_path):
    path = tmp_path / "s.jsonl"
    cases = grid(x=[1, 2, 3, 4])
    report = Sweep(sweep_cases.counting_case, cases, path).run(_FlakyExecutor(), progress="none")
    assert (report.n_done, report.n_lost, report.complete) == (3, 1, False)
    rows = {r["case_id"]: r for r in load_results(path)}
    assert sorted(rows) == [0, 2, 3]
    assert rows[2]["status"] == "error"
    assert rows[2]["message"] == ("the executor failed to run this case: RuntimeError: worker "
                                  "lost 3 times")
    report = Sweep(sweep_cases.counting_case, cases, path).run(serial=True, progress="none")
    assert (report.n_run, report.n_done, report.complete) == (1, 4, True)

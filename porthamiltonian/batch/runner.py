"""Resumable sweeps: a case function over a list of cases, through any Executor.

A *sweep* is a case function ``fn(case, **fixed, **shared) -> dict`` (a top-level function of an
importable module, so worker processes can import it), a list of cases, a results file
(:mod:`.resultsfile`) and keyword arguments: ``fixed`` (JSON values, part of the sweep's identity)
and ``shared`` (any picklable values derived from ``fixed`` — a gait computed once from the model
and parameters in ``fixed``, say — sent to each worker once and not part of the identity).
:meth:`Sweep.run` runs the cases not yet in the file through an executor — a local
:class:`~concurrent.futures.ProcessPoolExecutor` by default (``os.cpu_count()`` workers), a
``dask.distributed`` client's ``get_executor()``, any other :class:`~concurrent.futures.Executor`,
or in-process (``serial=True``) — and appends one row per finished case, in completion order:

* rerunning the same sweep skips the cases in the file and appends the rest;
* SIGINT or SIGTERM loses at most the cases in flight: pending futures are cancelled, the
  workers of the sweep's own pool are terminated, the file stays valid, and
  :class:`SweepInterrupted` (a ``KeyboardInterrupt``) carries the :class:`SweepReport`;
* SIGKILL of the sweep's process: its own pool's workers exit at once (Linux: a parent-death
  signal; elsewhere a watchdog thread notices within half a second) and the file's lock dies
  with the process, so the same sweep resumes immediately; a torn last line is truncated.
* a file that is a directory, foreign, of a different sweep, corrupt before its last line or
  locked by a running sweep is refused (:class:`~.errors.SweepFileError`) and never written.

A case that fails is a row: its ``status`` is the result's ``"status"`` (``"ok"`` when it has
none), or ``"error"`` when the function raised (``message``, ``error_type``, ``traceback``). A
worker process that dies (a crash in compiled code) breaks a process pool: the cases in flight
then run again one at a time in fresh one-process pools, and one that kills its process again
becomes an ``"error"`` row.
"""
from __future__ import annotations

import datetime as _dt
import importlib
import inspect
import json
import multiprocessing
import os
import pickle
import platform
import signal
import socket
import sys
import threading
import time
import traceback
import warnings
from collections import Counter, deque
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import (
    FIRST_COMPLETED,
    CancelledError,
    Executor,
    Future,
    ProcessPoolExecutor,
    wait,
)
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, Self

from . import progress as _progress
from .errors import SweepError, SweepFileError
from .executors import executor_width
from .grids import cases_sha256, normalize_case
from .resultsfile import FORMAT, VERSION, ResultsFile, Scan, read_file, scan
from .table import table, to_dataframe, write_csv

if TYPE_CHECKING:  # pandas is optional (the frames extra)
    import pandas as pd
from .values import canonical, plain_value, to_jsonable

__all__ = ["Sweep", "SweepInterrupted", "SweepReport", "function_name", "resolve_function",
           "run_case"]


# --- the case function -------------------------------------------------------------------------
def _import(module: str, qualname: str) -> Any:
    """The object ``module:qualname`` (ImportError or AttributeError when there is none)."""
    obj: Any = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    return obj


def function_name(fn: Callable) -> str:
    """``"module:qualname"`` of a top-level function that worker processes can import;
    :class:`SweepError` for lambdas, nested functions and names that do not import back."""
    module, qualname = getattr(fn, "__module__", None), getattr(fn, "__qualname__", None)
    if not module or not qualname or "<" in qualname:
        raise SweepError(
            f"the case function {fn!r} must be a top-level function of an importable module "
            "(worker processes import it by name); lambdas and nested functions cannot be used")
    if module != "__main__":
        try:
            obj = _import(module, qualname)
        except (ImportError, AttributeError):
            raise SweepError(f"the case function {module}:{qualname} cannot be imported by that "
                             "name; define it at the top level of an importable module") from None
        if obj is not fn:
            raise SweepError(f"{module}:{qualname} is not the case function given (it was "
                             "redefined?); define it once at the top level of a module")
    return f"{module}:{qualname}"


def resolve_function(ref: str | Callable) -> Callable:
    """A callable, or the function named ``"module:function"`` (imported now)."""
    if callable(ref):
        return ref
    module, sep, qualname = str(ref).partition(":")
    if not sep or not module or not qualname:
        raise SweepError(f"{ref!r}: a case function is named 'module:function'")
    try:
        obj = _import(module, qualname)
    except (ImportError, AttributeError) as err:
        raise SweepError(f"cannot import the case function {ref!r}: {err}") from None
    if not callable(obj):
        raise SweepError(f"{ref!r} is not a function")
    return obj


def _check_options(fn: Callable, name: str, options: Mapping[str, Any]) -> None:
    """Refuse keyword arguments the case function does not take (and required ones missing),
    before any case runs."""
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):  # pragma: no cover - a builtin: cannot tell
        return
    params = list(sig.parameters.values())
    if any(p.kind is p.VAR_KEYWORD for p in params):
        return
    takes = [p.name for p in params[1:] if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)]
    unknown = [k for k in options if k not in takes]
    if unknown:
        raise SweepError(f"unknown option{'s' if len(unknown) > 1 else ''} "
                         f"{', '.join(repr(k) for k in unknown)} of the case function {name}; "
                         f"it takes: {', '.join(takes) or 'no options'}")
    try:
        sig.bind({}, **options)
    except TypeError as err:
        raise SweepError(f"the case function {name} cannot be called with these options: "
                         f"{err}") from None


def _utc_now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


# --- in the worker -----------------------------------------------------------------------------
class _WorkerState:
    """What the sweep's own pool hands each worker once (its initializer): the shared keyword
    arguments and the tick sink."""

    shared: Mapping[str, Any] = {}
    sink: Any = None


def run_case(function: Callable, fixed: Mapping[str, Any], case_id: int, case: Mapping[str, Any],
             shared: Mapping[str, Any] | None = None) -> dict:
    """Run one case: the row to record (never raises for a failing case). ``shared`` None: the
    worker's shared arguments (set by the pool initializer)."""
    t0 = time.perf_counter()
    row: dict[str, Any] = {"case_id": case_id, "case": dict(case)}
    shared = _WorkerState.shared if shared is None else shared
    try:
        result = function(dict(case), **fixed, **shared)
        if not isinstance(result, Mapping):
            raise TypeError(f"the case function returned {type(result).__name__}, expected a "
                            "dict of results")
        result = to_jsonable(dict(result))
        row["status"] = str(result.get("status", "ok"))
        row["result"] = result
    except Exception as err:  # noqa: BLE001 - a failing case is a row: the sweep goes on
        row["status"] = "error"
        row["result"] = None
        row["message"] = f"{type(err).__name__}: {err}"
        row["error_type"] = f"{type(err).__module__}.{type(err).__qualname__}"
        row["traceback"] = "".join(traceback.format_exception(err)[-12:])[-4000:]
    if _WorkerState.sink is not None:
        _WorkerState.sink.flush()
    row["seconds"] = time.perf_counter() - t0
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return row


def _exit_with_parent(parent_pid: int) -> None:
    """End this worker when the sweep's process dies: a parent-death SIGKILL where the kernel
    offers one (Linux), and a watchdog thread that exits when this process is reparented."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGKILL)           # PR_SET_PDEATHSIG
        except (OSError, AttributeError):  # pragma: no cover - no prctl: the watchdog remains
            pass
    ppid = os.getppid()
    try:
        os.kill(parent_pid, 0)
    except ProcessLookupError:                      # the sweep died while this one started
        os._exit(1)
    except PermissionError:  # pragma: no cover
        pass

    def watch() -> None:
        while True:
            time.sleep(0.5)
            if os.getppid() != ppid:
                os._exit(1)

    threading.Thread(target=watch, name="sweep-parent-watch", daemon=True).start()


def _worker_init(parent_pid: int, tick_writer: Any, shared: Mapping[str, Any]) -> None:
    """Initializer of the sweep's own pool processes. Ctrl-C in a terminal reaches the whole
    process group and only the parent handles it (it terminates the workers); SIGTERM kills."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _exit_with_parent(parent_pid)
    _WorkerState.shared = shared
    _WorkerState.sink = _progress.install_worker_sink(tick_writer)


# --- interrupts ---------------------------------------------------------------------------------
class _Stop(BaseException):
    """Raised in the main thread by the sweep's SIGINT/SIGTERM handler (not an Exception, so a
    case function's ``except Exception`` cannot swallow it)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


class _SignalGuard:
    """SIGINT and SIGTERM handlers for the duration of a run (main thread only). While a row is
    being written (``critical``), a signal is deferred until the write is complete."""

    def __init__(self) -> None:
        self.previous: dict[int, Any] = {}
        self.pending: int | None = None
        self.critical = False

    def _handler(self, signum: int, frame: Any) -> None:
        if self.critical:
            self.pending = signum
        else:
            raise _Stop(signum)

    def __enter__(self) -> Self:
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                try:
                    self.previous[sig] = signal.signal(sig, self._handler)
                except (ValueError, OSError):  # pragma: no cover
                    pass
        return self

    def __exit__(self, *exc: object) -> Literal[False]:
        for sig, handler in self.previous.items():
            signal.signal(sig, handler)
        self.previous.clear()
        return False

    def end_critical(self) -> None:
        self.critical = False
        if self.pending is not None:
            signum, self.pending = self.pending, None
            raise _Stop(signum)


@dataclass
class SweepReport:
    """What a run of a sweep did. ``n_done``: cases in the file at the end (of ``n_cases``);
    ``n_previously_done``: already in the file at the start (skipped); ``n_run``: rows written by
    this run; ``n_lost``: cases not in the file at the end (interrupted, or cancelled by the
    executor: they run next time); ``status_counts``: rows of the whole file by status;
    ``seconds``: wall time of this run (s); ``interrupted``: the signal's name, or None."""

    path: str
    n_cases: int
    n_done: int
    n_previously_done: int
    n_run: int
    n_lost: int
    status_counts: dict[str, int]
    seconds: float
    interrupted: str | None = None

    @property
    def complete(self) -> bool:
        """Every case of the sweep is done."""
        return self.n_done == self.n_cases

    def to_dict(self) -> dict[str, Any]:
        """The report as JSON-ready data."""
        return {**self.__dict__, "complete": self.complete}


class SweepInterrupted(KeyboardInterrupt):
    """A sweep stopped by SIGINT or SIGTERM. ``report``: what was saved; ``signum``: the signal."""

    def __init__(self, report: SweepReport, signum: int):
        name = signal.Signals(signum).name
        super().__init__(f"sweep interrupted by {name}: {report.n_done} of {report.n_cases} "
                         f"cases are in {report.path}; run the same sweep again to resume")
        self.report, self.signum = report, signum


# --- the sweep -----------------------------------------------------------------------------------
def _terminate(pool: Executor) -> None:
    """Stop a process pool now: cancel what is queued, terminate the workers (the cases they are
    running are lost), and wait for its threads."""
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        try:
            process.terminate()
        except Exception:  # noqa: BLE001, S110 - already gone
            pass
    pool.shutdown(wait=True, cancel_futures=True)


class Sweep:
    """A resumable sweep: ``function(case, **fixed, **shared)`` for every case, rows in ``path``.

    Parameters
    ----------
    function : top-level function of an importable module (workers import it by name; a
        :func:`functools.partial` of one is accepted, its keywords joining ``fixed``) returning a
        dict of results; numpy values, complex numbers and NaN are converted by
        :func:`~.values.to_jsonable` (NaN becomes null).
    cases : list of dicts of named values (numbers, strings, bools or lists).
    path : the JSON Lines results file (created if missing; see :mod:`.resultsfile`).
    fixed : keyword arguments of every call (JSON values; the sweep's identity). A name the
        function does not take is refused here.
    shared : keyword arguments of every call that are *derived from* ``fixed`` (not part of the
        identity: they must be determined by it), any picklable values; a process pool receives
        them once per worker, other executors with each case.
    meta : extra header information (not part of the identity; a difference on resume warns).
    ok_statuses : statuses that are not failures, for the progress display.
    """

    def __init__(self, function: Callable, cases: Sequence[Mapping[str, Any]], path: str | Path, *,
                 fixed: Mapping[str, Any] | None = None, shared: Mapping[str, Any] | None = None,
                 meta: Mapping[str, Any] | None = None,
                 ok_statuses: Sequence[str] = ("ok", "periodic")):
        fixed = dict(fixed or {})
        func = function
        if hasattr(func, "func") and hasattr(func, "keywords") and hasattr(func, "args"):
            if func.args:
                raise SweepError("a functools.partial case function may bind keyword arguments "
                                 "only (the case is the first positional argument)")
            fixed = {**func.keywords, **fixed}
            func = func.func
        self.function_name = function_name(func)
        self.function = func
        self.fixed = {name: plain_value(value, f"fixed argument {name!r}")
                      for name, value in fixed.items()}
        self.shared: dict[str, Any] = {}
        self.set_shared(shared)
        self.cases = [normalize_case(c, i) for i, c in enumerate(cases)]
        if not self.cases:
            raise SweepError("the sweep has no cases")
        self.path = Path(path)
        self.meta = to_jsonable(dict(meta or {}))
        self.ok_statuses = tuple(ok_statuses)

    def set_shared(self, shared: Mapping[str, Any] | None) -> None:
        """Replace the shared arguments (e.g. with what an analysis's ``prepare`` computed);
        checked against the case function's signature like ``fixed``."""
        shared = dict(shared or {})
        both = sorted(set(self.fixed) & set(shared))
        if both:
            raise SweepError(f"{', '.join(both)}: given both as fixed and as shared arguments")
        _check_options(self.function, self.function_name, {**self.fixed, **shared})
        self.shared = shared

    @property
    def identity(self) -> dict:
        """The sweep's identity in its results file: function, fixed arguments, case list."""
        return {"function": self.function_name, "fixed": self.fixed,
                "n_cases": len(self.cases), "cases_sha256": cases_sha256(self.cases)}

    def _header_line(self) -> bytes:
        from ..version import __version__ as ph_version
        header = {"format": FORMAT, "version": VERSION, "sweep": self.identity,
                  "created": _utc_now(), "meta": self.meta,
                  "software": {"porthamiltonian": ph_version, "python": platform.python_version(),
                               "host": socket.gethostname()}}
        return (json.dumps(header, allow_nan=False) + "\n").encode()

    # --- the file --------------------------------------------------------------------------------
    def _check_identity(self, header: dict) -> None:
        theirs, mine = header["sweep"], self.identity
        diffs = []
        if theirs.get("function") != mine["function"]:
            diffs.append(f"case function {theirs.get('function')} (file) vs {mine['function']} (now)")
        if theirs.get("fixed") != mine["fixed"]:
            diffs.append(f"fixed arguments {canonical(theirs.get('fixed'))} (file) vs "
                         f"{canonical(mine['fixed'])} (now)")
        if (theirs.get("cases_sha256"), theirs.get("n_cases")) != (mine["cases_sha256"], mine["n_cases"]):
            diffs.append(f"case list: {theirs.get('n_cases')} cases, sha256 "
                         f"{str(theirs.get('cases_sha256'))[:12]}... (file) vs {mine['n_cases']} "
                         f"cases, sha256 {mine['cases_sha256'][:12]}... (now)")
        if diffs:
            raise SweepFileError(
                f"{self.path}, line 1: the file holds a different sweep: {'; '.join(diffs)}. The "
                "file was left unchanged: run the same sweep (same analysis, model, options and "
                "grid) to resume it, or write this one to another file")

    def _check_rows(self, rows: list[tuple[int, dict]]) -> dict[int, dict]:
        done: dict[int, dict] = {}
        for number, row in rows:
            cid = row["case_id"]
            if cid >= len(self.cases) or row["case"] != self.cases[cid]:
                expected = self.cases[cid] if cid < len(self.cases) else "no such case"
                raise SweepFileError(
                    f"{self.path}, line {number}: row of case {cid} holds case "
                    f"{canonical(row['case'])}, but this sweep's case {cid} is "
                    f"{expected if isinstance(expected, str) else canonical(expected)}; the file "
                    "was left unchanged: it was edited, or written by another sweep")
            if cid in done:
                warnings.warn(f"{self.path}, line {number}: case {cid} appears again; the first "
                              "row is kept", stacklevel=4)
                continue
            done[cid] = row
        return done

    def _check_scan(self, found: Scan | None) -> dict[int, dict]:
        """Accept a results file for this sweep (or refuse it); its rows by case id."""
        if found is None:
            return {}
        self._check_identity(found.header)
        done = self._check_rows(found.rows)
        theirs = found.header.get("meta", {})
        if theirs != self.meta:
            keys = sorted(set(theirs) | set(self.meta))
            changed = [k for k in keys if theirs.get(k) != self.meta.get(k)]
            warnings.warn(f"{self.path}: resuming a sweep whose header metadata differ in "
                          f"{', '.join(changed)} (the file's are kept)", stacklevel=5)
        return done

    def rows(self) -> list[dict]:
        """The rows in the file (file order), after checking it belongs to this sweep; [] when
        there is no file yet. Refuses (:class:`SweepFileError`) a directory or a file it could
        not resume, so calling it first checks ``path`` before any work is done."""
        if not os.path.lexists(self.path):
            return []
        found = scan(self.path, read_file(self.path))
        self._check_identity(found.header)
        return list(self._check_rows(found.rows).values())

    def pending(self) -> list[int]:
        """Indices of the cases not in the file yet."""
        done = {row["case_id"] for row in self.rows()}
        return [i for i in range(len(self.cases)) if i not in done]

    def table(self, *, pending: bool = False) -> list[dict]:
        """The tidy table of the file, one flat dict per case in case order (see
        :func:`~.table.table`); ``pending=True`` also lists the cases not run yet."""
        return table(self.rows(), self.cases, pending=pending)

    def to_csv(self, path: str | Path, *, pending: bool = False) -> Path:
        """Write :meth:`table` as CSV (see :func:`~.table.write_csv`)."""
        return write_csv(self.table(pending=pending), path)

    def dataframe(self, *, pending: bool = False) -> pd.DataFrame:
        """:meth:`table` as a pandas DataFrame indexed by case_id (pandas: the ``frames`` extra)."""
        return to_dataframe(self.table(pending=pending))

    # --- running -----------------------------------------------------------------------------------
    def _repr_html_(self) -> str:
        from ..simulation.display import sweep_html
        return sweep_html(self)

    def run(self, executor: Executor | None = None, *, workers: int | None = None,
            serial: bool = False, progress: str | bool | None = "auto",
            progress_interval: float = 10.0, max_in_flight: int | None = None,
            mp_context: Any = None) -> SweepReport:
        """Run the cases that are not in the results file yet; return a :class:`SweepReport`.

        executor : any :class:`concurrent.futures.Executor` (e.g. ``client.get_executor()`` of
            a dask.distributed client); it is not shut down. Default: a process pool of
            ``workers`` processes (default ``os.cpu_count()``), created and shut down here.
        serial : run the cases one after the other in this process (no executor).
        progress : "auto", "bar", "text" or "none" (:class:`~.progress.SweepProgress`).
        max_in_flight : cases submitted ahead (default twice the executor's workers): bounds
            what an interrupt loses and what is queued.
        mp_context : multiprocessing context of the own pool (default: the platform's).

        Raises :class:`SweepInterrupted` on SIGINT/SIGTERM after saving, and
        :class:`~.errors.SweepFileError` for a file it must not write to.
        """
        if workers is not None and workers < 1:
            raise SweepError(f"workers must be at least 1, got {workers}")
        t0 = time.monotonic()
        results, done = ResultsFile.open(self.path, self._header_line(), self._check_scan)
        counts = Counter(row["status"] for row in done.values())
        n_before = len(done)
        todo = [i for i in range(len(self.cases)) if i not in done]
        state = {"run": 0}
        prog = None
        stop: _Stop | None = None
        try:
            if todo:
                if not serial:
                    self._check_picklable()
                prog = _progress.SweepProgress(progress, len(self.cases), counts,
                                               f"sweep {self.path.name}", self.ok_statuses,
                                               progress_interval)
                with _SignalGuard() as guard:
                    def record(row: dict) -> None:
                        row["finished"] = _utc_now()
                        guard.critical = True
                        try:
                            results.append(row)
                            counts[row["status"]] += 1
                            state["run"] += 1
                            prog.update(row["status"])
                        finally:
                            guard.end_critical()

                    try:
                        if serial:
                            with _progress.counting(prog.add_work):
                                for cid in todo:
                                    record(run_case(self.function, self.fixed, cid,
                                                    self.cases[cid], self.shared))
                        else:
                            self._run_parallel(executor, workers, todo, record, prog,
                                               max_in_flight, mp_context)
                    except _Stop as err:
                        stop = err
                    except KeyboardInterrupt:   # not in the main thread: no handler installed
                        stop = _Stop(signal.SIGINT)
        finally:
            results.close()
            if prog is not None:
                prog.close()
        n_done = n_before + state["run"]
        report = SweepReport(str(self.path), len(self.cases), n_done, n_before, state["run"],
                             len(self.cases) - n_done, dict(counts), time.monotonic() - t0,
                             signal.Signals(stop.signum).name if stop else None)
        if stop is not None:
            raise SweepInterrupted(report, stop.signum)
        return report

    def _check_picklable(self) -> None:
        try:
            pickle.dumps((self.function, self.fixed, self.shared))
        except Exception as err:  # noqa: BLE001 - any pickling failure says the same
            raise SweepError(f"the case function {self.function_name} and its arguments must be "
                             f"picklable to reach worker processes: {err}") from None

    def _run_parallel(self, executor: Executor | None, workers: int | None, todo: list[int],
                      record: Callable[..., Any], prog: Any, max_in_flight: int | None,
                      mp_context: Any) -> int:
        """Run ``todo`` through an executor; returns the number of cases lost (not recorded)."""
        owned = executor is None
        context = mp_context or multiprocessing.get_context()
        channel = _progress.TickChannel(context) if owned else None

        def new_pool(n: int) -> ProcessPoolExecutor:
            return ProcessPoolExecutor(max_workers=n, mp_context=context,
                                       initializer=_worker_init,
                                       initargs=(os.getpid(), channel and channel.writer,
                                                 self.shared))

        def submit_case(pool: Executor, cid: int) -> Future[Any]:
            # the own pool's workers hold the shared arguments already
            return pool.submit(run_case, self.function, self.fixed, cid, self.cases[cid],
                               None if owned else self.shared)

        n_workers = min(workers or os.cpu_count() or 1, len(todo))
        active = new_pool(n_workers) if executor is None else executor
        window = max_in_flight or max(2, 2 * executor_width(active))
        queue: deque[int] = deque(todo)
        pending: dict[Future[Any], int] = {}
        lost = 0

        def submit() -> bool:
            """Fill the window; False when the own pool died since the last wait (a worker
            crashed after its case's future was collected): its futures say so at the next
            wait, and the case not submitted stays first in the queue."""
            while queue and len(pending) < window:
                try:
                    future = submit_case(active, queue[0])
                except BrokenProcessPool:
                    if not owned:
                        raise
                    return False
                pending[future] = queue.popleft()
            return True

        try:
            submit()
            while pending or queue:
                finished, _ = wait(list(pending), timeout=0.25, return_when=FIRST_COMPLETED)
                if channel is not None:
                    for what, n in channel.drain().items():
                        prog.add_work(what, n)
                broken: list[int] = []
                for fut in finished:
                    cid = pending.pop(fut)
                    outcome = self._outcome(fut, cid, owned)
                    if outcome == "broken":
                        broken.append(cid)
                    elif outcome == "lost":
                        lost += 1
                    else:
                        record(outcome)
                if broken:
                    # the pool died (a worker crashed): every case in it is suspect; run them
                    # one at a time in a fresh one-process pool, then go on with a new pool
                    suspects = sorted(broken + list(pending.values()))
                    pending.clear()
                    _terminate(active)
                    for cid in suspects:
                        active = new_pool(1)
                        row = self._outcome(submit_case(active, cid), cid, owned, isolated=True)
                        active.shutdown(wait=True)
                        if isinstance(row, dict):
                            record(row)
                        else:
                            lost += 1
                    active = new_pool(n_workers)
                prog.refresh()
                if not submit() and not pending:     # died with nothing in it: a new pool
                    _terminate(active)
                    active = new_pool(n_workers)
                    submit()
            if channel is not None:                 # ticks sent after the last row arrived
                for what, n in channel.drain().items():
                    prog.add_work(what, n)
        except BaseException:
            for fut in pending:
                fut.cancel()
            if owned:
                _terminate(active)
            raise
        finally:
            if owned:
                active.shutdown(wait=True)
            if channel is not None:             # (the own pool's)
                channel.close()
        return lost

    def _outcome(self, fut: Future[Any], cid: int, owned: bool, isolated: bool = False) -> Any:
        """A finished future: its row, "broken" (the process pool died), or "lost"."""
        try:
            return fut.result()
        except CancelledError:
            return "lost"
        except BrokenProcessPool as err:
            if isolated:
                return self._error_row(cid, f"the worker process died while running this case, "
                                            f"twice ({type(err).__name__}: {err})", err)
            if owned:
                return "broken"
            raise SweepError(f"the executor broke ({type(err).__name__}: {err}); the cases done "
                             f"are saved in {self.path}: run the sweep again to resume") from None
        except (KeyboardInterrupt, SystemExit):
            return "lost"
        except Exception as err:  # noqa: BLE001 - the executor failed the case (dask's KilledWorker)
            return self._error_row(cid, f"the executor failed to run this case: "
                                        f"{type(err).__name__}: {err}", err)

    def _error_row(self, cid: int, message: str, err: BaseException) -> dict:
        return {"case_id": cid, "case": self.cases[cid], "status": "error", "result": None,
                "message": message,
                "error_type": f"{type(err).__module__}.{type(err).__qualname__}",
                "seconds": None, "worker": None}


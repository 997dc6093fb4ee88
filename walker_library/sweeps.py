"""Resumable parameter sweeps through any :class:`concurrent.futures.Executor` (DESIGN.md §8).

A *case* is a dict of named values (``{"slope": 0.009, "K": 2e4}``); a *sweep* is a case function
``fn(case, **fixed) -> dict`` (a top-level function of an importable module, so worker processes
can import it), a list of cases, a results file and the fixed keyword arguments ``fixed`` passed
to every call. :class:`Sweep` runs the cases not yet in the file through an executor — a local
:class:`~concurrent.futures.ProcessPoolExecutor` by default (``os.cpu_count()`` workers), or a
``dask.distributed`` client's executor (``client.get_executor()``) on a cluster, or in-process
(``serial=True``) — and appends one row per finished case to the file, in completion order.

Results file (JSON Lines, UTF-8, one JSON object per line)::

    {"format": "walker-sweep", "version": 1,
     "sweep": {"function": "walker_library.sweeps:gait_case",
               "fixed": {"model": "simplest_walker", "backend": "python"},
               "n_cases": 4, "cases_sha256": "..."},
     "created": "2026-...Z", "meta": {...}, "software": {...}}
    {"case_id": 2, "case": {"slope": 0.014}, "status": "periodic", "result": {...},
     "seconds": 0.26, "worker": "host:pid", "finished": "2026-...Z"}
    ...

``"sweep"`` is the sweep's identity: the case function's qualified name, its fixed arguments and
a hash of the case list (canonical JSON: sorted keys, no spaces). ``case_id`` is the index of the
case in the case list. Each row is written with one ``write`` and made durable (flush + fsync)
before the next is handled, so:

* rerunning the same sweep reads the file, skips the cases it holds and appends the rest (nothing
  is recomputed);
* Ctrl-C (SIGINT) or SIGTERM loses at most the cases in flight: pending futures are cancelled,
  the worker processes of the sweep's own pool are terminated, the file stays valid, and
  :class:`SweepInterrupted` (a ``KeyboardInterrupt``) carries the :class:`SweepReport`;
* a hard kill (SIGKILL, power loss) can at worst leave a torn last line (no newline, not JSON):
  the next run warns and truncates it (that case is run again);
* a file whose first line is not a walker-sweep header, that belongs to a different sweep (its
  identity differs), or has a corrupt row before its last line is refused with
  :class:`~porthamiltonian.errors.SweepFileError` (a ``ModelError``) naming the file, the line and
  what to do — such a file is never written to. A file being written by another running sweep
  is refused too (an advisory ``flock`` lock, where the file system supports it).

A case that fails is a row, never a lost sweep: the row's ``status`` is the ``"status"`` of the
function's result when it has one (``"fell"``, ``"no_fixed_point"``...), ``"ok"`` when it has
none, and ``"error"`` when the function raised (``message``: the exception's type and text,
``traceback``: its last frames). A worker process that dies (a crash in compiled code) breaks a
process pool: the cases that were in flight are then run again one at a time in a fresh
one-process pool, and the one that kills it again becomes an ``"error"`` row.

Tidy output: :func:`load_results` (rows in file order), :func:`table` / :meth:`Sweep.table` (one
flat dict per case, in case order: ``case_id``, the case's values, ``status``, the result's
fields — nested dicts flattened as ``a.b`` —, ``message``, ``seconds``) and :func:`write_csv`.

Grids: :func:`grid` (cartesian product, the last axis varying fastest), :func:`parse_axis` and
:func:`parse_grid` for command-line specs ``NAME=start:stop:n`` (n values, both ends included)
and ``NAME=v1,v2,...``.

Analyses for the command line: :data:`ANALYSES`, filled by :func:`register_analysis` with a case
function given as a callable or lazily as ``"module:function"`` (so an analysis may live in a
module that is imported only when it is used). ``"gait"`` is :func:`gait_case`. Walkers are
cached per process by model name and back end (:func:`cached_walker`), so a worker builds and
compiles a walker once and each case only rebinds its parameters.

Command line (``walker sweep``; :func:`add_parser` registers it, :func:`main` runs it alone)::

    walker sweep MODEL --analysis gait --grid slope=0.004:0.014:3 [--grid K=1e4,2e4]
                 --out FILE [--workers N | --serial | --scheduler ADDRESS] [--json] [--csv FILE]

Exit status: 0 when every case is in the file (failed cases included: they are results), 1 when
some cases were lost by the executor (rerun to resume), 2 on bad input or a refused file,
128 + signal number when interrupted (130 for Ctrl-C, 143 for SIGTERM).
"""
from __future__ import annotations

import argparse
import csv
import datetime as _dt
import hashlib
import importlib
import itertools
import json
import math
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
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import (FIRST_COMPLETED, CancelledError, Executor, Future,
                                ProcessPoolExecutor, wait)
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import Any

try:  # advisory locking of the results file (POSIX)
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None

from porthamiltonian.errors import ModelError, ParameterValueError, SweepError, SweepFileError

from .results import to_jsonable

__all__ = [
    "ANALYSES", "FORMAT", "VERSION", "Analysis", "Sweep", "SweepInterrupted", "SweepReport",
    "add_parser", "cached_walker", "cases_sha256", "gait_case", "gait_summary", "get_analysis",
    "grid", "load_results", "main", "parse_axis", "parse_grid", "prepare_walker", "read_header",
    "register_analysis", "table", "warm_walker", "write_csv",
]

FORMAT = "walker-sweep"
VERSION = 1
_ROW_KEYS = ("case_id", "case", "status", "result")


# --------------------------------------------------------------------------------------------
# cases
# --------------------------------------------------------------------------------------------
def _plain_value(value: Any, where: str) -> Any:
    """A JSON value of a case (numpy scalars and arrays become Python numbers and lists)."""
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        value = value.tolist()
    if isinstance(value, bool) or value is None or isinstance(value, (str, int)):
        return value
    if isinstance(value, float):
        if not math.isfinite(value):
            raise SweepError(f"{where}: value {value!r} is not finite")
        return value
    if isinstance(value, (list, tuple)):
        return [_plain_value(v, where) for v in value]
    if isinstance(value, Mapping) and all(isinstance(k, str) for k in value):
        return {k: _plain_value(v, where) for k, v in value.items()}
    raise SweepError(f"{where}: value {value!r} of type {type(value).__name__} is not a number, "
                     "string, bool, list or dict (sweep values are stored as JSON)")


def _normalize_case(case: Any, index: int) -> dict[str, Any]:
    if not isinstance(case, Mapping):
        raise SweepError(f"case {index} is {type(case).__name__} {case!r}; a case is a dict of "
                         "named values, e.g. {'slope': 0.009}")
    out = {}
    for name, value in case.items():
        if not isinstance(name, str) or not name:
            raise SweepError(f"case {index}: names must be non-empty strings, got {name!r}")
        out[name] = _plain_value(value, f"case {index} {name!r}")
    return out


def _canonical(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def cases_sha256(cases: Sequence[Mapping[str, Any]]) -> str:
    """SHA-256 of the canonical JSON of a case list (sorted keys, no spaces): part of a sweep's
    identity, so that a results file is resumed only by the sweep that wrote it."""
    return hashlib.sha256(_canonical([dict(c) for c in cases]).encode()).hexdigest()


def grid(**axes: Any) -> list[dict[str, Any]]:
    """The cartesian product of named axes, as a list of cases.

    Each axis is a list, tuple, range or numpy array of values (a scalar is a one-value axis).
    Order is deterministic: axes in the order given, the last one varying fastest, e.g.
    ``grid(a=[1, 2], b=[10, 20])`` -> ``[{a:1,b:10}, {a:1,b:20}, {a:2,b:10}, {a:2,b:20}]``.
    Numpy scalars become Python numbers (cases are stored as JSON).
    """
    names, values = [], []
    for name, axis in axes.items():
        if isinstance(axis, (str, bytes)) or not isinstance(axis, Iterable):
            axis = [axis]
        axis = [_plain_value(v, f"axis {name!r}") for v in axis]
        if not axis:
            raise SweepError(f"axis {name!r} has no values")
        names.append(name)
        values.append(axis)
    return [dict(zip(names, combo)) for combo in itertools.product(*values)]


def _number(text: str, spec: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise SweepError(f"grid {spec!r}: {text.strip()!r} is not a number") from None
    if not math.isfinite(value):
        raise SweepError(f"grid {spec!r}: {text.strip()!r} is not finite")
    return value


def parse_axis(spec: str) -> tuple[str, list[float]]:
    """Parse a command-line axis: ``NAME=start:stop:n`` (n evenly spaced values, both ends
    included; rounded to 15 significant digits so that 0.004:0.019:4 gives 0.009, not
    0.009000000000000001), ``NAME=v1,v2,...`` or ``NAME=v``."""
    name, sep, rhs = spec.partition("=")
    name = name.strip()
    if not sep or not name.isidentifier():
        raise SweepError(f"grid {spec!r}: write NAME=start:stop:n or NAME=v1,v2,... "
                         "(e.g. slope=0.004:0.014:6 or K=1e4,2e4)")
    if ":" in rhs:
        parts = rhs.split(":")
        if len(parts) != 3:
            raise SweepError(f"grid {spec!r}: a range is start:stop:n (three fields), got {rhs!r}")
        start, stop = _number(parts[0], spec), _number(parts[1], spec)
        try:
            n = int(parts[2])
        except ValueError:
            raise SweepError(f"grid {spec!r}: n = {parts[2].strip()!r} must be a whole number "
                             "of values") from None
        if n < 1:
            raise SweepError(f"grid {spec!r}: n = {n} must be at least 1")
        if n == 1:
            return name, [start]
        step = (stop - start) / (n - 1)
        return name, [float(f"{start + k * step:.15g}") for k in range(n - 1)] + [stop]
    values = [_number(v, spec) for v in rhs.split(",")] if rhs.strip() else []
    if not values:
        raise SweepError(f"grid {spec!r}: no values after '='")
    return name, values


def parse_grid(specs: Sequence[str]) -> list[dict[str, float]]:
    """The cases of command-line axis specs (see :func:`parse_axis`), in :func:`grid` order."""
    axes: dict[str, list[float]] = {}
    for spec in specs:
        name, values = parse_axis(spec)
        if name in axes:
            raise SweepError(f"grid axis {name!r} is given twice; give each axis once")
        axes[name] = values
    return grid(**axes)


# --------------------------------------------------------------------------------------------
# the case function and its identity
# --------------------------------------------------------------------------------------------
def _qualified_name(fn: Callable) -> str:
    module, qualname = getattr(fn, "__module__", None), getattr(fn, "__qualname__", None)
    if not module or not qualname or "<" in qualname:
        raise SweepError(
            f"the case function {fn!r} must be a top-level function of an importable module "
            "(worker processes import it by name); lambdas and nested functions cannot be used")
    if module != "__main__":
        try:
            obj: Any = importlib.import_module(module)
            for part in qualname.split("."):
                obj = getattr(obj, part)
        except (ImportError, AttributeError):
            raise SweepError(f"the case function {module}:{qualname} cannot be imported by that "
                             "name; define it at the top level of an importable module") from None
        if obj is not fn:
            raise SweepError(f"{module}:{qualname} is not the case function given (it was "
                             "redefined?); define it once at the top level of a module")
    return f"{module}:{qualname}"


def _resolve(ref: str | Callable) -> Callable:
    if callable(ref):
        return ref
    module, sep, qualname = str(ref).partition(":")
    if not sep or not module or not qualname:
        raise SweepError(f"{ref!r}: a case function is named 'module:function'")
    try:
        obj: Any = importlib.import_module(module)
        for part in qualname.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as err:
        raise SweepError(f"cannot import the case function {ref!r}: {err}") from None
    if not callable(obj):
        raise SweepError(f"{ref!r} is not a function")
    return obj


def _utc_now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def _run_case(function: Callable, fixed: dict, case_id: int, case: dict) -> dict:
    """Run one case in a worker: the row to record (never raises for a failing case)."""
    t0 = time.perf_counter()
    row: dict[str, Any] = {"case_id": case_id, "case": case}
    try:
        result = function(dict(case), **fixed)
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
    row["seconds"] = time.perf_counter() - t0
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return row


def _worker_init() -> None:
    """Initializer of the sweep's own pool processes: Ctrl-C in a terminal reaches the whole
    process group, and only the parent handles it (it terminates the workers); SIGTERM kills."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


# --------------------------------------------------------------------------------------------
# the results file
# --------------------------------------------------------------------------------------------
def _parse_header(raw: bytes, path: Path) -> dict:
    what = f"{path}: not a walker sweep results file"
    fix = ("it was left unchanged; write the sweep to another file (--out), or delete this one "
           "if it is yours and unwanted")
    try:
        header = json.loads(raw)
    except (UnicodeDecodeError, json.JSONDecodeError):
        raise SweepFileError(f"{what} (line 1 is not a JSON header line); {fix}") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise SweepFileError(f"{what} (line 1 has no \"format\": \"{FORMAT}\"); {fix}")
    version = header.get("version")
    if not isinstance(version, int) or version > VERSION:
        raise SweepFileError(f"{path}, line 1: results file version {version!r} is not supported "
                             f"by this version of walker_library (it reads version <= {VERSION}); "
                             "upgrade walker_library, or write to another file")
    sweep = header.get("sweep")
    if not isinstance(sweep, dict) or not {"function", "fixed", "n_cases", "cases_sha256"} <= set(sweep):
        raise SweepFileError(f"{path}, line 1: the header has no complete \"sweep\" identity "
                             f"(function, fixed, n_cases, cases_sha256); {fix}")
    return header


def _parse_row(raw: bytes) -> dict:
    """A row of the file, or ValueError saying what is wrong with it."""
    try:
        row = json.loads(raw)
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ValueError(f"not JSON ({err})") from None
    if not isinstance(row, dict):
        raise ValueError("not a JSON object")  # noqa: TRY004 - "this row is invalid"
    missing = [k for k in _ROW_KEYS if k not in row]
    if missing:
        raise ValueError(f"missing {', '.join(missing)}")
    if not isinstance(row["case_id"], int) or isinstance(row["case_id"], bool) or row["case_id"] < 0:
        raise ValueError(f"case_id {row['case_id']!r} is not a case index")
    if not isinstance(row["case"], dict) or not isinstance(row["status"], str):
        raise ValueError("case must be an object and status a string")  # noqa: TRY004
    return row


@dataclass
class _Scan:
    header: dict
    rows: list[tuple[int, dict]]     # (line number, row)
    good_end: int                    # byte offset after the last good line (incl. its newline)
    torn: tuple[int, bytes] | None   # (line number, bytes) of a torn last line
    missing_newline: bool            # the last row is complete JSON but lacks its newline


def _scan(path: Path, data: bytes) -> _Scan:
    lines = data.split(b"\n")
    complete, tail = lines[:-1], lines[-1]
    if not complete:
        # one line without a newline: a torn header cannot happen (the header is written to a
        # temporary file and linked into place), so this is some other file
        _parse_header(tail, path)
        raise SweepFileError(f"{path}: line 1 has no newline; the file was left unchanged")
    header = _parse_header(complete[0], path)
    rows: list[tuple[int, dict]] = []
    offset = len(complete[0]) + 1
    for number, raw in enumerate(complete[1:], start=2):
        try:
            rows.append((number, _parse_row(raw)))
        except ValueError as err:
            kind = "an empty line" if not raw.strip() else "a corrupt row"
            raise SweepFileError(
                f"{path}, line {number}: {kind} ({err}) before the end of the file; the file was "
                f"left unchanged. Rows are only ever appended, so this file was edited or damaged: "
                f"delete line {number} to run that case again, or write the sweep to another "
                f"file") from None
        offset += len(raw) + 1
    torn, missing_newline = None, False
    if tail:
        try:
            rows.append((len(complete) + 1, _parse_row(tail)))
            missing_newline = True
            offset += len(tail)
        except ValueError:
            torn = (len(complete) + 1, tail)
    return _Scan(header, rows, offset, torn, missing_newline)


def read_header(path: str | Path) -> dict:
    """The header (first line) of a sweep results file; SweepFileError if it has none."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            first = fh.readline()
    except OSError as err:
        raise SweepFileError(f"{path}: cannot read the sweep results file ({err.strerror})") from None
    return _parse_header(first.rstrip(b"\n"), path)


def load_results(path: str | Path) -> list[dict]:
    """The rows of a sweep results file, in file (completion) order, as dicts with case_id,
    case, status, result, seconds (s, wall time in the worker), worker, finished (UTC) and, for
    an ``"error"`` row, message, error_type and traceback. A torn last line is left out with a
    warning (the file is not modified: the next run of the sweep truncates it)."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as err:
        raise SweepFileError(f"{path}: cannot read the sweep results file ({err.strerror})") from None
    scan = _scan(path, data)
    if scan.torn:
        warnings.warn(f"{path}, line {scan.torn[0]}: torn last line (an interrupted write) "
                      "left out", stacklevel=2)
    return [row for _, row in scan.rows]


class _ResultsFile:
    """The open, locked results file of a running sweep; rows are appended durably."""

    def __init__(self, path: Path, fh):
        self.path, self.fh = path, fh

    def append(self, row: dict) -> None:
        line = (json.dumps(row, allow_nan=False, separators=(", ", ": ")) + "\n").encode()
        self.fh.write(line)
        self.fh.flush()
        os.fsync(self.fh.fileno())

    def close(self) -> None:
        if not self.fh.closed:
            self.fh.close()


def _lock(fh, path: Path) -> None:
    if fcntl is None:  # pragma: no cover
        return
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        fh.close()
        raise SweepFileError(f"{path} is being written by another running sweep (it is locked); "
                             "wait for that one to finish, or write to another file") from None
    except OSError:  # pragma: no cover - a file system without flock: go on unlocked
        pass


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path.parent, os.O_RDONLY)
    except OSError:  # pragma: no cover
        return
    try:
        os.fsync(fd)
    except OSError:  # pragma: no cover
        pass
    finally:
        os.close(fd)


def _create(path: Path, header_line: bytes) -> bool:
    """Create ``path`` holding only the header, atomically (never replacing an existing file).
    False if the file exists already."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    try:
        with open(tmp, "wb") as fh:
            fh.write(header_line)
            fh.flush()
            os.fsync(fh.fileno())
        try:
            os.link(tmp, path)
        except FileExistsError:
            return False
        except OSError:  # pragma: no cover - no hard links here: exclusive create instead
            try:
                with open(path, "xb") as fh:
                    fh.write(header_line)
                    fh.flush()
                    os.fsync(fh.fileno())
            except FileExistsError:
                return False
        _fsync_dir(path)
        return True
    finally:
        try:
            tmp.unlink()
        except OSError:
            pass


# --------------------------------------------------------------------------------------------
# progress
# --------------------------------------------------------------------------------------------
def _duration(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    seconds = round(seconds)
    h, rest = divmod(seconds, 3600)
    m, s = divmod(rest, 60)
    return f"{h}h{m:02d}m{s:02d}s" if h else (f"{m}m{s:02d}s" if m else f"{s}s")


class _Progress:
    """A tqdm bar (cases done, failures, ETA) on a terminal, else a text line every
    ``interval`` seconds and at the end, on ``stream`` (stderr)."""

    def __init__(self, mode: str | bool | None, total: int, initial: Counter, desc: str,
                 ok_statuses: Sequence[str], interval: float, stream=None):
        self.total, self.desc, self.ok = total, desc, set(ok_statuses)
        self.counts = Counter(initial)
        self.initial = sum(initial.values())
        self.stream = stream or sys.stderr
        self.interval = interval
        self.t0 = time.monotonic()
        self.last = self.t0
        self.bar = None
        if mode is True:
            mode = "auto"
        if mode in (None, False, "none"):
            self.mode = "none"
            return
        if mode not in ("auto", "bar", "text"):
            raise SweepError(f"progress must be 'auto', 'bar', 'text' or 'none', got {mode!r}")
        if mode in ("auto", "bar"):
            try:
                from tqdm import tqdm
            except ImportError:
                tqdm = None
            tty = getattr(self.stream, "isatty", lambda: False)()
            if tqdm is not None and (mode == "bar" or tty):
                self.bar = tqdm(total=total, initial=self.initial, desc=desc, unit="case",
                                file=self.stream, dynamic_ncols=True)
                self.mode = "bar"
                self._postfix()
                return
        self.mode = "text"
        self._line()

    @property
    def failures(self) -> Counter:
        return Counter({k: v for k, v in self.counts.items() if k not in self.ok})

    def _failure_text(self) -> str:
        fails = self.failures
        n = sum(fails.values())
        detail = ", ".join(f"{k} {v}" for k, v in sorted(fails.items()))
        return f"{n} failed" + (f" ({detail})" if n else "")

    def _postfix(self) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(self._failure_text(), refresh=False)

    def _line(self, final: bool = False) -> None:
        done = sum(self.counts.values())
        elapsed = time.monotonic() - self.t0
        ran = done - self.initial
        rate = ran / elapsed if elapsed > 0 and ran else math.nan
        eta = (self.total - done) / rate if ran else math.inf
        text = f"{self.desc}: {done}/{self.total} cases, {self._failure_text()}"
        if ran:
            per_min = rate * 60
            text += f", {per_min:.0f} cases/min" if per_min >= 100 else f", {per_min:.3g} cases/min"
        text += f", elapsed {_duration(elapsed)}" + ("" if final else f", ETA {_duration(eta)}")
        print(text, file=self.stream, flush=True)
        self.last = time.monotonic()

    def update(self, status: str) -> None:
        self.counts[status] += 1
        if self.bar is not None:
            self._postfix()
            self.bar.update(1)
        elif self.mode == "text" and time.monotonic() - self.last >= self.interval:
            self._line()

    def tick(self) -> None:
        if self.mode == "text" and time.monotonic() - self.last >= self.interval:
            self._line()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None
        elif self.mode == "text":
            self._line(final=True)
            self.mode = "none"


# --------------------------------------------------------------------------------------------
# interrupts
# --------------------------------------------------------------------------------------------
class _Stop(BaseException):
    """Raised in the main thread by the sweep's SIGINT/SIGTERM handler (not an Exception, so a
    case function's ``except Exception`` cannot swallow it)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


class _SignalGuard:
    """SIGINT and SIGTERM handlers for the duration of a run (main thread only). While a row is
    being written (``critical``), a signal is deferred until the write is complete."""

    def __init__(self):
        self.previous: dict[int, Any] = {}
        self.pending: int | None = None
        self.critical = False

    def _handler(self, signum, frame):
        if self.critical:
            self.pending = signum
        else:
            raise _Stop(signum)

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                try:
                    self.previous[sig] = signal.signal(sig, self._handler)
                except (ValueError, OSError):  # pragma: no cover
                    pass
        return self

    def __exit__(self, *exc):
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
        return self.n_done == self.n_cases

    def to_dict(self) -> dict:
        return {**self.__dict__, "complete": self.complete}


class SweepInterrupted(KeyboardInterrupt):
    """A sweep stopped by SIGINT or SIGTERM. ``report``: what was saved; ``signum``: the signal."""

    def __init__(self, report: SweepReport, signum: int):
        name = signal.Signals(signum).name
        super().__init__(f"sweep interrupted by {name}: {report.n_done} of {report.n_cases} "
                         f"cases are in {report.path}; run the same sweep again to resume")
        self.report, self.signum = report, signum


# --------------------------------------------------------------------------------------------
# the sweep
# --------------------------------------------------------------------------------------------
def _executor_width(executor: Executor) -> int:
    width = getattr(executor, "_max_workers", None)
    if isinstance(width, int) and width > 0:
        return width
    client = getattr(executor, "_client", None)      # dask.distributed's ClientExecutor
    if client is not None:
        try:
            return max(1, sum(client.nthreads().values()))
        except Exception:  # noqa: BLE001, S110 - a client that cannot tell: use the CPU count
            pass
    return os.cpu_count() or 1


def _terminate(pool: ProcessPoolExecutor) -> None:
    """Stop a process pool now: cancel what is queued, terminate the workers (the cases they are
    running are lost), and wait for its threads."""
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        try:
            process.terminate()
        except Exception:  # noqa: BLE001, S110 - already gone
            pass
    pool.shutdown(wait=True, cancel_futures=True)


class Sweep:
    """A resumable sweep: ``function(case, **fixed)`` for every case, results in ``path``.

    Parameters
    ----------
    function : top-level function of an importable module (workers import it by name; a
        :func:`functools.partial` of one is accepted, its keywords joining ``fixed``), returning
        a dict of JSON-able results (numpy values, complex numbers and NaN are converted by
        :func:`walker_library.results.to_jsonable`: NaN becomes null).
    cases : list of dicts of named values (numbers, strings, bools or lists).
    path : the JSON Lines results file (created if missing; see the module docstring).
    fixed : keyword arguments passed to every call (JSON-able; part of the sweep's identity).
    meta : extra header information (not part of the identity; a difference on resume warns).
    ok_statuses : statuses that are not failures, for the progress display.
    """

    def __init__(self, function: Callable, cases: Sequence[Mapping[str, Any]], path: str | Path, *,
                 fixed: Mapping[str, Any] | None = None, meta: Mapping[str, Any] | None = None,
                 ok_statuses: Sequence[str] = ("ok", "periodic")):
        fixed = dict(fixed or {})
        func = function
        if hasattr(func, "func") and hasattr(func, "keywords") and hasattr(func, "args"):
            if func.args:
                raise SweepError("a functools.partial case function may bind keyword arguments "
                                 "only (the case is the first positional argument)")
            fixed = {**func.keywords, **fixed}
            func = func.func
        self.function_name = _qualified_name(func)
        self.function = func
        self.fixed = {name: _plain_value(value, f"fixed argument {name!r}")
                      for name, value in fixed.items()}
        self.cases = [_normalize_case(c, i) for i, c in enumerate(cases)]
        if not self.cases:
            raise SweepError("the sweep has no cases")
        self.path = Path(path)
        self.meta = to_jsonable(dict(meta or {}))
        self.ok_statuses = tuple(ok_statuses)

    @property
    def identity(self) -> dict:
        """The sweep's identity in its results file: function, fixed arguments, case list."""
        return {"function": self.function_name, "fixed": self.fixed,
                "n_cases": len(self.cases), "cases_sha256": cases_sha256(self.cases)}

    def _header_line(self) -> bytes:
        from porthamiltonian import __version__ as ph_version
        header = {"format": FORMAT, "version": VERSION, "sweep": self.identity,
                  "created": _utc_now(), "meta": self.meta,
                  "software": {"porthamiltonian": ph_version, "python": platform.python_version(),
                               "host": socket.gethostname()}}
        return (json.dumps(header, allow_nan=False) + "\n").encode()

    # --- file ---------------------------------------------------------------------------------
    def _check_identity(self, header: dict) -> None:
        theirs, mine = header["sweep"], self.identity
        diffs = []
        if theirs.get("function") != mine["function"]:
            diffs.append(f"case function {theirs.get('function')} (file) vs {mine['function']} (now)")
        if theirs.get("fixed") != mine["fixed"]:
            diffs.append(f"fixed arguments {_canonical(theirs.get('fixed'))} (file) vs "
                         f"{_canonical(mine['fixed'])} (now)")
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
                    f"{_canonical(row['case'])}, but this sweep's case {cid} is "
                    f"{expected if isinstance(expected, str) else _canonical(expected)}; the file "
                    "was left unchanged: it was edited, or written by another sweep")
            if cid in done:
                warnings.warn(f"{self.path}, line {number}: case {cid} appears again; the first "
                              "row is kept", stacklevel=3)
                continue
            done[cid] = row
        return done

    def _open(self) -> tuple[_ResultsFile, dict[int, dict]]:
        path = self.path
        header_line = self._header_line()
        if not path.exists():
            _create(path, header_line)
        try:
            fh = open(path, "r+b")  # noqa: SIM115 - kept open (and locked) for the run
        except OSError as err:
            raise SweepFileError(f"{path}: cannot open the results file ({err.strerror})") from None
        _lock(fh, path)
        try:
            data = fh.read()
            if not data:             # an empty file (e.g. made by `touch`): nothing to lose
                fh.write(header_line)
                fh.flush()
                os.fsync(fh.fileno())
                return _ResultsFile(path, fh), {}
            scan = _scan(path, data)
            self._check_identity(scan.header)
            done = self._check_rows(scan.rows)
            if scan.header.get("meta", {}) != self.meta:
                keys = sorted(set(scan.header.get("meta", {})) | set(self.meta))
                changed = [k for k in keys if scan.header.get("meta", {}).get(k) != self.meta.get(k)]
                warnings.warn(f"{path}: resuming a sweep whose header metadata differ in "
                              f"{', '.join(changed)} (the file's are kept)", stacklevel=3)
            if scan.torn is not None:
                number, raw = scan.torn
                warnings.warn(f"{path}, line {number}: torn last line ({len(raw)} bytes, an "
                              "interrupted write) removed; that case runs again", stacklevel=3)
                fh.truncate(scan.good_end)
            fh.seek(0, os.SEEK_END)
            if scan.missing_newline:
                fh.write(b"\n")
            fh.flush()
            os.fsync(fh.fileno())
            return _ResultsFile(path, fh), done
        except BaseException:
            fh.close()
            raise

    def rows(self) -> list[dict]:
        """The rows in the file (file order), after checking it belongs to this sweep."""
        if not self.path.exists():
            return []
        scan = _scan(self.path, self.path.read_bytes())
        self._check_identity(scan.header)
        return list(self._check_rows(scan.rows).values())

    def pending(self) -> list[int]:
        """Indices of the cases not in the file yet."""
        done = {row["case_id"] for row in self.rows()}
        return [i for i in range(len(self.cases)) if i not in done]

    def table(self, *, pending: bool = False) -> list[dict]:
        """The tidy table of the file, one flat dict per case in case order (see :func:`table`);
        ``pending=True`` also lists the cases not run yet, with status ``"pending"``."""
        return table(self.rows(), self.cases, pending=pending)

    def to_csv(self, path: str | Path, *, pending: bool = False) -> Path:
        """Write :meth:`table` as CSV (see :func:`write_csv`)."""
        return write_csv(self.table(pending=pending), path)

    # --- running ------------------------------------------------------------------------------
    def run(self, executor: Executor | None = None, *, workers: int | None = None,
            serial: bool = False, progress: str | bool | None = "auto",
            progress_interval: float = 10.0, max_in_flight: int | None = None,
            mp_context=None) -> SweepReport:
        """Run the cases that are not in the results file yet; return a :class:`SweepReport`.

        executor : any :class:`concurrent.futures.Executor` (e.g. ``client.get_executor()`` of
            a dask.distributed client); it is not shut down. Default: a process pool of
            ``workers`` processes (default ``os.cpu_count()``), created and shut down here.
        serial : run the cases one after the other in this process (no executor).
        progress : "auto" (a tqdm bar when tqdm is installed and stderr is a terminal, else text
            lines), "bar", "text" (a line every ``progress_interval`` s and at the end) or "none".
        max_in_flight : cases submitted ahead (default twice the executor's workers): bounds
            what an interrupt loses and what is queued.

        Raises :class:`SweepInterrupted` on SIGINT/SIGTERM after saving, and
        :class:`~porthamiltonian.errors.SweepFileError` for a file it must not write to.
        """
        t0 = time.monotonic()
        results, done = self._open()
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
                prog = _Progress(progress, len(self.cases), counts, f"sweep {self.path.name}",
                                 self.ok_statuses, progress_interval)
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
                            for cid in todo:
                                record(_run_case(self.function, self.fixed, cid, self.cases[cid]))
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
            pickle.dumps((self.function, self.fixed))
        except Exception as err:  # noqa: BLE001 - any pickling failure says the same
            raise SweepError(f"the case function {self.function_name} and its fixed arguments "
                             f"must be picklable to reach worker processes: {err}") from None

    def _run_parallel(self, executor, workers, todo, record, prog, max_in_flight, mp_context) -> int:
        """Run ``todo`` through an executor; returns the number of cases lost (not recorded)."""
        owned = executor is None
        if workers is not None and workers < 1:
            raise SweepError(f"workers must be at least 1, got {workers}")

        def new_pool(n: int) -> ProcessPoolExecutor:
            return ProcessPoolExecutor(max_workers=n, initializer=_worker_init,
                                       mp_context=mp_context)

        n_workers = min(workers or os.cpu_count() or 1, len(todo))
        if owned:
            executor = new_pool(n_workers)
        window = max_in_flight or max(2, 2 * _executor_width(executor))
        queue, pending = deque(todo), {}
        lost = 0

        def submit() -> None:
            while queue and len(pending) < window:
                cid = queue.popleft()
                fut = executor.submit(_run_case, self.function, self.fixed, cid, self.cases[cid])
                pending[fut] = cid

        try:
            submit()
            while pending:
                finished, _ = wait(list(pending), timeout=0.25, return_when=FIRST_COMPLETED)
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
                    _terminate(executor)
                    for cid in suspects:
                        executor = new_pool(1)
                        row = self._outcome(executor.submit(_run_case, self.function, self.fixed,
                                                            cid, self.cases[cid]), cid, owned,
                                            isolated=True)
                        executor.shutdown(wait=True)
                        if isinstance(row, dict):
                            record(row)
                        else:
                            lost += 1
                    executor = new_pool(n_workers)
                prog.tick()
                submit()
        except BaseException:
            for fut in pending:
                fut.cancel()
            if owned:
                _terminate(executor)
            raise
        if owned:
            executor.shutdown(wait=True)
        return lost

    def _outcome(self, fut: Future, cid: int, owned: bool, isolated: bool = False):
        """A finished future: its row, "broken" (the process pool died), or "lost"."""
        try:
            return fut.result()
        except CancelledError:
            return "lost"
        except BrokenProcessPool as err:
            if isolated:
                return {"case_id": cid, "case": self.cases[cid], "status": "error", "result": None,
                        "message": f"the worker process died while running this case, twice "
                                   f"({type(err).__name__}: {err})",
                        "error_type": f"{type(err).__module__}.{type(err).__qualname__}",
                        "seconds": None, "worker": None}
            if owned:
                return "broken"
            raise SweepError(f"the executor broke ({type(err).__name__}: {err}); the cases done "
                             f"are saved in {self.path}: run the sweep again to resume") from None
        except (KeyboardInterrupt, SystemExit):
            return "lost"
        except Exception as err:  # noqa: BLE001 - the executor failed the case (dask's KilledWorker)
            return {"case_id": cid, "case": self.cases[cid], "status": "error", "result": None,
                    "message": f"the executor failed to run this case: {type(err).__name__}: {err}",
                    "error_type": f"{type(err).__module__}.{type(err).__qualname__}",
                    "seconds": None, "worker": None}


# --------------------------------------------------------------------------------------------
# tidy tables
# --------------------------------------------------------------------------------------------
def _flatten(prefix: str, value: Any, out: dict) -> None:
    if isinstance(value, dict) and value:
        for k, v in value.items():
            _flatten(f"{prefix}.{k}" if prefix else str(k), v, out)
    else:
        out[prefix] = value


def _flat_row(row: dict) -> dict:
    out: dict[str, Any] = {"case_id": row["case_id"], **row["case"], "status": row["status"]}
    result = row.get("result") or {}
    message = row.get("message") or result.get("message")
    flat: dict[str, Any] = {}
    for key, value in result.items():
        if key not in ("status", "message"):
            _flatten(key, value, flat)
    for key, value in flat.items():
        out[f"result.{key}" if key in out else key] = value
    out["message"] = message
    out["seconds"] = row.get("seconds")
    return out


def table(rows: Iterable[dict], cases: Sequence[Mapping[str, Any]] | None = None, *,
          pending: bool = False) -> list[dict]:
    """One flat dict per case, in case order: ``case_id``, the case's values, ``status``, the
    result's fields (nested dicts flattened as ``a.b``; a field named like a case value becomes
    ``result.NAME``), ``message`` (the result's, or the error's) and ``seconds``. With ``cases``
    and ``pending=True``, cases with no row appear with status ``"pending"``. The first row of a
    case counts. ``pandas.DataFrame(table(...))`` makes a data frame of it."""
    by_id: dict[int, dict] = {}
    for row in rows:
        by_id.setdefault(row["case_id"], row)
    ids = range(len(cases)) if cases is not None else sorted(by_id)
    out = []
    for cid in ids:
        row = by_id.get(cid)
        if row is not None:
            out.append(_flat_row(row))
        elif pending and cases is not None:
            out.append({"case_id": cid, **cases[cid], "status": "pending"})
    return out


def _csv_value(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (list, dict)):
        return json.dumps(value, allow_nan=False)
    return str(value)


def write_csv(rows: Sequence[Mapping[str, Any]], path: str | Path) -> Path:
    """Write table rows as CSV: the union of the rows' columns in first-seen order; empty for
    null, floats at full precision, true/false, lists as JSON."""
    columns: dict[str, None] = {}
    for row in rows:
        columns.update(dict.fromkeys(row))
    path = Path(path)
    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(list(columns))
        for row in rows:
            writer.writerow([_csv_value(row.get(c)) for c in columns])
    return path


# --------------------------------------------------------------------------------------------
# analyses: case functions for the command line
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Analysis:
    """A case function for ``walker sweep --analysis NAME``.

    function : ``fn(case, *, model, backend, **options) -> dict``, a callable or a lazily
        imported ``"module:function"``. prepare : optional ``prepare(cases, *, model, backend,
        **options)`` run once in the main process before the sweep (validate the cases, raising
        a ModelError, and warm the caches that forked workers inherit): :func:`prepare_walker`
        when the cases are walker parameters (gait, step-down), :func:`warm_walker` when they are
        not (a basin's section states). ok_statuses : statuses that are not failures. columns :
        result fields printed in the command line's table.

    A new analysis is one line, e.g. (its case function living in another module)::

        register_analysis("step-down", "walker_library.robustness:step_down_case",
                          "largest step down survived", ok_statuses=("ok",),
                          prepare="walker_library.sweeps:prepare_walker",
                          columns=("max_step_down", "contiguous", "speed"))
    """

    name: str
    function: str | Callable
    doc: str
    prepare: str | Callable | None = None
    ok_statuses: tuple[str, ...] = ("ok",)
    columns: tuple[str, ...] = ()

    def resolve(self) -> Callable:
        return _resolve(self.function)

    def resolve_prepare(self) -> Callable | None:
        return None if self.prepare is None else _resolve(self.prepare)


ANALYSES: dict[str, Analysis] = {}


def register_analysis(name: str, function: str | Callable, doc: str, *,
                      prepare: str | Callable | None = None,
                      ok_statuses: Sequence[str] = ("ok",), columns: Sequence[str] = (),
                      replace: bool = False) -> Analysis:
    """Make a case function available as ``walker sweep --analysis NAME``. ``function`` and
    ``prepare`` may be ``"module:function"`` strings, imported when the analysis is used."""
    if name in ANALYSES and not replace:
        raise SweepError(f"analysis {name!r} is registered already")
    entry = Analysis(name, function, doc, prepare, tuple(ok_statuses), tuple(columns))
    ANALYSES[name] = entry
    return entry


def get_analysis(name: str) -> Analysis:
    """A registered analysis, or an ad-hoc one for ``"module:function"``."""
    if name in ANALYSES:
        return ANALYSES[name]
    if ":" in name:
        return Analysis(name, name, f"case function {name}")
    raise SweepError(f"unknown analysis {name!r}; analyses: {', '.join(ANALYSES)} (or "
                     "module:function for a case function of your own)")


_WALKERS: dict[tuple[str, str | None], Any] = {}


def cached_walker(model: str, backend: str | None = None):
    """The walker of ``model`` (a walker file: a name from models/ or a path) at the file's
    parameter values, built once per process and back end (None: the walker's own default)."""
    key = (str(model), backend)
    walker = _WALKERS.get(key)
    if walker is None:
        from .walkers import load_walker
        walker = _WALKERS[key] = load_walker(model, None, backend=backend)
    return walker


def prepare_walker(cases: Sequence[Mapping[str, Any]], *, model: str,
                   backend: str | None = None, **options: Any) -> None:
    """Build the walker once (forked workers inherit it) and check every case's parameter names
    and values against the walker's specs, so a typo fails before the sweep starts."""
    walker = cached_walker(model, backend)
    specs = getattr(walker, "specs", None)
    for index, case in enumerate(cases):
        try:
            if specs is not None:
                unknown = sorted(set(case) - set(specs))
                if unknown:
                    raise ParameterValueError(
                        f"unknown parameter(s) {', '.join(unknown)} of {walker.name}; "
                        f"parameters: {', '.join(specs)}")
                for name, value in case.items():
                    specs[name].check(value)
            elif index == 0:
                walker.with_parameters(**case)
        except ParameterValueError as err:
            raise ParameterValueError(f"case {index} {_canonical(dict(case))}: {err}") from None


def warm_walker(cases: Sequence[Mapping[str, Any]], *, model: str, backend: str | None = None,
                params: Mapping[str, Any] | None = None, **options: Any) -> None:
    """Build the walker once (forked workers inherit it) and check the fixed ``params``
    overrides, for analyses whose cases are not walker parameters (e.g. a basin over section
    states, with the walker's parameters in ``params``)."""
    walker = cached_walker(model, backend)
    if params:
        walker.with_parameters(**params)


_THESIS_KEYS = ("theta", "theta_dot", "phi", "phi_dot")


def gait_summary(walker, result) -> dict:
    """The main fields of a :class:`~walker_library.gait.GaitResult` as a flat dict (SI units,
    angles in rad): status, period_steps, stable, max_multiplier (largest |Floquet multiplier|),
    multiplier_error, step_period (s), step_length (m), speed (m/s), energy_dissipated_per_step
    (J), max_theta, max_phi (rad), cost_of_transport (1), the fixed point in the thesis's terms
    (``fixed_point.theta``, ``.theta_dot``, ``.phi``, ``.phi_dot``; a rimless wheel: theta and
    theta_dot), fell_at_step and message. Null where not defined (no gait)."""
    d = result.to_dict()
    mults = [abs(complex(m)) for m in result.floquet_multipliers]
    out = {"status": d["status"], "period_steps": d["period_steps"], "stable": d["stable"],
           "max_multiplier": max(mults) if mults else None,
           "multiplier_error": d["multiplier_error"]}
    for key in ("step_period", "step_length", "speed", "energy_dissipated_per_step", "max_theta",
                "max_phi", "cost_of_transport"):
        out[key] = d.get(key)
    keys = _THESIS_KEYS if walker.legged else ("theta", *walker.thesis_section)
    fixed_point = d.get("fixed_point") or {}
    for key in dict.fromkeys(keys):
        out[f"fixed_point.{key}"] = fixed_point.get(key)
    out["fell_at_step"] = d.get("fell_at_step")
    out["message"] = d.get("message", "")
    return to_jsonable(out)


def gait_case(case: Mapping[str, Any], *, model: str, backend: str | None = None,
              max_period: int = 8, fd_step: float = 1e-4, n_iterate: int = 200) -> dict:
    """Case function of ``--analysis gait``: the walker ``model`` with the case's values as
    parameter overrides, :func:`walker_library.gait.analyze_gait` from its initial guess, and
    :func:`gait_summary` of the result."""
    from .gait import analyze_gait
    walker = cached_walker(model, backend)
    if case:
        walker = walker.with_parameters(**case)
    result = analyze_gait(walker, max_period=max_period, fd_step=fd_step, n_iterate=n_iterate)
    return gait_summary(walker, result)


register_analysis(
    "gait", "walker_library.sweeps:gait_case",
    "gait of the walker for each case: fixed point, Floquet multipliers, metrics",
    prepare="walker_library.sweeps:prepare_walker", ok_statuses=("periodic",),
    columns=("period_steps", "stable", "max_multiplier", "step_length", "speed"))
register_analysis(
    "step-down", "walker_library.robustness:step_down_case",
    "gait and step-down test for each case: max_step_down (m), contiguous, speed, energy per step",
    prepare="walker_library.sweeps:prepare_walker", ok_statuses=("ok",),
    columns=("gait_status", "max_step_down", "contiguous", "speed"))
register_analysis(
    "basin", "walker_library.robustness:basin_case",
    "one basin-of-attraction point per case (theta, theta_dot; walker parameters in "
    "--option params={...}): converged, fell or wandered",
    prepare="walker_library.sweeps:warm_walker", ok_statuses=("converged",),
    columns=("steps", "distance"))


# --------------------------------------------------------------------------------------------
# command line
# --------------------------------------------------------------------------------------------
def _option(pair: str) -> tuple[str, Any]:
    name, sep, value = pair.partition("=")
    if not sep or not name.strip().isidentifier():
        raise SweepError(f"--option takes NAME=VALUE, got {pair!r}")
    try:
        parsed = json.loads(value)
    except json.JSONDecodeError:
        parsed = value
    return name.strip(), parsed


def _fmt(value: Any) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def _print_table(rows: list[dict], names: list[str], columns: Sequence[str]) -> None:
    cols = ["case_id", *names, "status", *columns]
    cells = [[_fmt(row.get(c)) for c in cols] for row in rows]
    widths = [max(len(c), *(len(r[i]) for r in cells)) for i, c in enumerate(cols)]
    print("  ".join(c.ljust(w) for c, w in zip(cols, widths)))
    for r in cells:
        print("  ".join(v.ljust(w) for v, w in zip(r, widths)))


def cmd_sweep(args: argparse.Namespace) -> int:
    """``walker sweep``: run (or resume) a sweep; see the module docstring."""
    analysis = get_analysis(args.analysis)
    cases = parse_grid(args.grid)
    backend = args.sweep_backend or getattr(args, "backend", None)
    options = dict(_option(p) for p in args.option)
    fixed = {"model": args.model, "backend": backend, **options}
    meta: dict[str, Any] = {"analysis": analysis.name, "grid": list(args.grid)}
    try:
        from porthamiltonian import io as ph_io
        model_file = ph_io.model_path(args.model)
        meta["model_file"] = str(model_file)
        meta["model_file_sha256"] = hashlib.sha256(model_file.read_bytes()).hexdigest()
    except (ModelError, OSError):
        pass                        # load_walker reports a missing file
    sweep = Sweep(analysis.resolve(), cases, args.out, fixed=fixed, meta=meta,
                  ok_statuses=analysis.ok_statuses)
    if args.workers is not None and args.workers < 1:
        raise SweepError(f"--workers must be at least 1, got {args.workers}")
    prepare = analysis.resolve_prepare()
    if prepare is not None and sweep.pending():
        prepare(sweep.cases, **fixed)
    progress = args.progress or ("none" if args.json else "auto")
    client = cluster = None
    try:
        executor = None
        if args.scheduler:
            try:
                from distributed import Client, LocalCluster
            except ImportError:
                raise SweepError("--scheduler needs dask.distributed: pip install "
                                 "'porthamiltonian[distributed]'") from None
            if args.scheduler == "local":
                cluster = LocalCluster(n_workers=args.workers or os.cpu_count() or 1,
                                       threads_per_worker=1, processes=True,
                                       dashboard_address=None)
                client = Client(cluster)
            else:
                client = Client(args.scheduler)
            executor = client.get_executor()
        report = sweep.run(executor, workers=args.workers, serial=args.serial, progress=progress,
                           progress_interval=args.progress_interval)
    except SweepInterrupted as stop:
        print(f"interrupted: {stop}", file=sys.stderr)
        return 128 + stop.signum
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    rows = sweep.table()
    if args.csv:
        write_csv(rows, args.csv)
    if args.json:
        print(json.dumps({"file": str(sweep.path), "identity": sweep.identity,
                          "report": report.to_dict(), "table": rows}, indent=1, allow_nan=False))
    else:
        counts = ", ".join(f"{k} {v}" for k, v in sorted(report.status_counts.items()))
        print(f"{sweep.path}: {report.n_done}/{report.n_cases} cases ({counts}); this run "
              f"{report.n_run} case(s) in {report.seconds:.3g} s, {report.n_previously_done} "
              "already done")
        if len(rows) <= 60:
            _print_table(rows, list(cases[0]), analysis.columns)
        if args.csv:
            print(f"wrote {args.csv}")
    if report.n_lost:
        print(f"{report.n_lost} case(s) were lost by the executor; run the same command again "
              "to finish the sweep", file=sys.stderr)
        return 1
    return 0


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Register ``sweep`` on an argparse subparsers object (the ``walker`` command's)."""
    p = subparsers.add_parser(
        "sweep", help="run an analysis over a grid of parameters, resumably (JSON Lines file)",
        description="Run an analysis for every case of a parameter grid, appending one row per "
                    "case to a JSON Lines file as it finishes; rerunning the same command resumes "
                    "where it stopped. Exit status: 0 all cases done, 1 some lost (rerun), 2 bad "
                    "input or a refused file, 130/143 interrupted (rerun to resume).")
    p.add_argument("model", help="walker model name (models/) or path")
    p.add_argument("--analysis", default="gait",
                   help=f"one of {', '.join(ANALYSES)} (default: gait), or module:function for a "
                        "case function of your own, called as fn(case, model=MODEL, "
                        "backend=BACKEND, **options) and returning a dict")
    p.add_argument("--grid", action="append", default=[], required=True, metavar="NAME=SPEC",
                   help="an axis: NAME=start:stop:n (n values, ends included) or NAME=v1,v2,...; "
                        "repeat for a cartesian product (the last axis varies fastest)")
    p.add_argument("--out", required=True, metavar="FILE", help="results file (JSON Lines)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes of the local pool (default: os.cpu_count()), or of "
                        "--scheduler local")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="a dask.distributed scheduler address (tcp://host:8786), or 'local' for "
                        "a local dask cluster")
    p.add_argument("--serial", action="store_true", help="run in this process, one case at a time")
    p.add_argument("--option", action="append", default=[], metavar="NAME=VALUE",
                   help="extra keyword argument of the case function (JSON value), e.g. "
                        "max_period=4; part of the sweep's identity")
    p.add_argument("--backend", dest="sweep_backend", default=None,
                   help="python or numba (default: the walker's own)")
    p.add_argument("--csv", default=None, metavar="FILE", help="also write the table as CSV")
    p.add_argument("--progress", choices=("auto", "bar", "text", "none"), default=None,
                   help="progress display on stderr (default: auto; none with --json)")
    p.add_argument("--progress-interval", type=float, default=10.0, metavar="S",
                   help="seconds between text progress lines")
    p.add_argument("--json", action="store_true",
                   help="print the report and the table as one JSON document")
    p.set_defaults(func=cmd_sweep)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``walker sweep`` with ``argv`` (the arguments after ``sweep``)."""
    parser = argparse.ArgumentParser(prog="walker")
    sub = parser.add_subparsers(dest="command", required=True)
    add_parser(sub)
    args = parser.parse_args(["sweep", *(sys.argv[1:] if argv is None else argv)])
    try:
        return args.func(args)
    except ModelError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

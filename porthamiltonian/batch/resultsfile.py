"""The results file of a sweep: JSON Lines, one header line, then one row per finished case.

::

    {"format": "porthamiltonian-sweep", "version": 1,
     "sweep": {"function": "porthamiltonian.interfaces.sweeps:simulate_case",
               "fixed": {"model": "mass_spring_damper", "backend": "python", ...},
               "n_cases": 4, "cases_sha256": "..."},
     "created": "2026-...Z", "meta": {...}, "software": {...}}
    {"case_id": 2, "case": {"k": 4.0}, "status": "finished", "result": {...},
     "seconds": 0.26, "worker": "host:pid", "finished": "2026-...Z"}

Files written before the batch layer existed (``"format": "walker-sweep"``, same layout) are read
too. The header is written to a temporary file and linked into place, so a file never exists
without its header. Rows are appended with one ``write`` each and made durable (flush + fsync):
a hard kill can at worst leave a torn last line, which :func:`open_results` truncates with a
warning (that case runs again) and :func:`load_results` leaves out.

A file being written is held by an exclusive ``flock`` of the process that runs the sweep.
Processes forked from it (pool workers) do not keep it: an at-fork hook points their copy of the
descriptor at ``/dev/null``, so the lock is released the moment the sweep's own process dies —
a SIGKILLed sweep can be resumed at once, whatever its workers are still doing.
"""
from __future__ import annotations

import json
import os
import sys
import threading
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

if sys.platform != "win32":  # advisory locking (POSIX)
    import fcntl

from ..userfiles import make_folder, path_problem
from .errors import SweepFileError

__all__ = ["FORMAT", "VERSION", "ResultsFile", "load_results", "read_file", "read_header", "scan"]

FORMAT = "porthamiltonian-sweep"
VERSION = 1
#: formats read as FORMAT (the walker library's sweeps wrote this one, same layout)
_READ_FORMATS = (FORMAT, "walker-sweep")
_ROW_KEYS = ("case_id", "case", "status", "result")
_IDENTITY_KEYS = {"function", "fixed", "n_cases", "cases_sha256"}
_FIX = ("it was left unchanged; write the sweep to another file (--out), or delete this one if "
        "it is yours and unwanted")


def _parse_header(raw: bytes, path: Path) -> dict:
    what = f"{path}: not a sweep results file"
    try:
        header = json.loads(raw)
    except (UnicodeDecodeError, json.JSONDecodeError):
        raise SweepFileError(f"{what} (line 1 is not a JSON header line); {_FIX}") from None
    if not isinstance(header, dict) or header.get("format") not in _READ_FORMATS:
        raise SweepFileError(f"{what} (line 1 has no \"format\": \"{FORMAT}\"); {_FIX}")
    version = header.get("version")
    if not isinstance(version, int) or version > VERSION:
        raise SweepFileError(f"{path}, line 1: results file version {version!r} is not supported "
                             f"by this version of porthamiltonian (it reads version <= {VERSION}); "
                             "upgrade porthamiltonian, or write to another file")
    sweep = header.get("sweep")
    if not isinstance(sweep, dict) or not _IDENTITY_KEYS <= set(sweep):
        raise SweepFileError(f"{path}, line 1: the header has no complete \"sweep\" identity "
                             f"(function, fixed, n_cases, cases_sha256); {_FIX}")
    return header


class _BadRow(Exception):
    """What is wrong with a row (caught by :func:`scan`, which names the file and line)."""


def _parse_row(raw: bytes) -> dict:
    """A row of the file, or :class:`_BadRow` saying what is wrong with it."""
    try:
        row = json.loads(raw)
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise _BadRow(f"not JSON ({err})") from None
    if not isinstance(row, dict):
        raise _BadRow("not a JSON object")
    missing = [k for k in _ROW_KEYS if k not in row]
    if missing:
        raise _BadRow(f"missing {', '.join(missing)}")
    cid = row["case_id"]
    if not isinstance(cid, int) or isinstance(cid, bool) or cid < 0:
        raise _BadRow(f"case_id {cid!r} is not a case index")
    if not isinstance(row["case"], dict) or not isinstance(row["status"], str):
        raise _BadRow("case must be an object and status a string")
    return row


@dataclass
class Scan:
    """A results file read and checked line by line."""

    header: dict
    rows: list[tuple[int, dict]]     # (line number, row)
    good_end: int                    # byte offset after the last good line (incl. its newline)
    torn: tuple[int, bytes] | None   # (line number, bytes) of a torn last line
    missing_newline: bool            # the last row is complete JSON but lacks its newline


def scan(path: Path, data: bytes) -> Scan:
    """Check ``data`` (the bytes of ``path``): a header, valid rows, at most a torn last line;
    :class:`SweepFileError` naming the line for anything else."""
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
        except _BadRow as err:
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
        except _BadRow:
            torn = (len(complete) + 1, tail)
    return Scan(header, rows, offset, torn, missing_newline)


def read_file(path: Path) -> bytes:
    """The bytes of the results file ``path``; SweepFileError for a directory, a device, a
    pipe or a socket (by type: nothing is read from them) or a file that cannot be read."""
    if path.is_dir():
        raise SweepFileError(f"{path} is a directory; name a results file (e.g. "
                             f"{path / 'sweep.jsonl'})")
    problem = path_problem(path)
    if problem is None and not path.is_file():
        problem = "is a pipe, not a file"
    if problem is not None:
        raise SweepFileError(f"{path} {problem}; name a sweep results file")
    try:
        return path.read_bytes()
    except OSError as err:
        raise SweepFileError(f"{path}: cannot read the sweep results file ({err.strerror})") from None


def read_header(path: str | Path) -> dict:
    """The header (first line) of a sweep results file; SweepFileError if it has none."""
    path = Path(path)
    data = read_file(path)
    return _parse_header(data.split(b"\n", 1)[0], path)


def load_results(path: str | Path) -> list[dict]:
    """The rows of a sweep results file, in file (completion) order, as dicts with case_id,
    case, status, result, seconds (s, wall time in the worker), worker, finished (UTC) and, for
    an ``"error"`` row, message, error_type and traceback. A torn last line is left out with a
    warning (the file is not modified: the next run of the sweep truncates it)."""
    path = Path(path)
    found = scan(path, read_file(path))
    if found.torn:
        warnings.warn(f"{path}, line {found.torn[0]}: torn last line (an interrupted write) "
                      "left out", stacklevel=2)
    return [row for _, row in found.rows]


# --- locking ---------------------------------------------------------------------------------
_HELD: set[int] = set()          # descriptors of results files locked by this process
_HELD_GUARD = threading.Lock()


def _drop_inherited_locks() -> None:
    """In a freshly forked child: point the copies of the locked descriptors at /dev/null, so
    the child holds no reference to the locked file (the parent's lock dies with the parent).
    Closing them instead could later close an unrelated descriptor of the same number."""
    if not _HELD:
        return
    null = os.open(os.devnull, os.O_RDWR)
    try:
        for fd in list(_HELD):
            try:
                os.dup2(null, fd)
            except OSError:  # pragma: no cover - not open in the child
                pass
    finally:
        os.close(null)
    _HELD.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_drop_inherited_locks)


def _lock(fh: IO[bytes], path: Path) -> None:
    if sys.platform == "win32":  # pragma: no cover
        return
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        fh.close()
        raise SweepFileError(f"{path} is being written by another running sweep (it is locked); "
                             "wait for that one to finish, or write to another file") from None
    except OSError:  # pragma: no cover - a file system without flock: go on unlocked
        return
    with _HELD_GUARD:
        _HELD.add(fh.fileno())


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


def _create(path: Path, header_line: bytes) -> None:
    """Create ``path`` holding only the header, atomically; an existing file is left alone
    (its folder made first: a file in the way says so, not "File exists")."""
    make_folder(path.parent)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    try:
        with open(tmp, "wb") as fh:
            fh.write(header_line)
            fh.flush()
            os.fsync(fh.fileno())
        try:
            os.link(tmp, path)
        except FileExistsError:
            return
        except OSError:  # pragma: no cover - no hard links here: exclusive create instead
            try:
                with open(path, "xb") as fh:
                    fh.write(header_line)
                    fh.flush()
                    os.fsync(fh.fileno())
            except FileExistsError:
                return
        _fsync_dir(path)
    finally:
        try:
            tmp.unlink()
        except OSError:
            pass


class ResultsFile:
    """The open, locked results file of a running sweep; rows are appended durably.

    :meth:`open` creates the file (header only) if it is missing, locks it, checks it with
    ``check(scan)`` (the caller's identity check), then truncates a torn last line with a
    warning and positions at the end; :meth:`append` writes one row; :meth:`close` releases the lock.
    """

    def __init__(self, path: Path, fh: IO[bytes]):
        self.path, self._fh = path, fh

    @classmethod
    def open(cls, path: Path, header_line: bytes,
             check: Callable[[Scan | None], Any]) -> tuple[ResultsFile, Any]:
        """The open file and what ``check(scan)`` returned for it (``check`` raises to refuse
        the file; None is passed for a file that was empty), before anything is written."""
        if path.is_dir():
            raise SweepFileError(f"{path} is a directory; name a results file (e.g. "
                                 f"{path / 'sweep.jsonl'})")
        if os.path.lexists(path) or path.exists():
            problem = path_problem(path)
            if problem is None and not path.is_file():
                problem = "is a pipe, not a file (rows must be kept and read back to resume)"
            if problem is not None:
                raise SweepFileError(f"{path} {problem}; name a results file")
        if not path.exists():
            try:
                _create(path, header_line)
            except OSError as err:
                raise SweepFileError(f"{path}: cannot create the results file "
                                     f"({err.strerror or err})") from None
        try:
            fh = open(path, "r+b")  # noqa: SIM115 - kept open (and locked) for the run
        except OSError as err:
            raise SweepFileError(f"{path}: cannot open the results file ({err.strerror})") from None
        _lock(fh, path)
        results = cls(path, fh)
        try:
            data = fh.read()
            if not data:             # an empty file (e.g. made by `touch`): nothing to lose
                fh.write(header_line)
                results._sync()
                return results, check(None)
            found = scan(path, data)
            checked = check(found)
            if found.torn is not None:
                number, raw = found.torn
                warnings.warn(f"{path}, line {number}: torn last line ({len(raw)} bytes, an "
                              "interrupted write) removed; that case runs again", stacklevel=4)
                fh.truncate(found.good_end)
            fh.seek(0, os.SEEK_END)
            if found.missing_newline:
                fh.write(b"\n")
            results._sync()
            return results, checked
        except BaseException:
            results.close()
            raise

    def _sync(self) -> None:
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def append(self, row: dict) -> None:
        """Write one row (one line) and make it durable before returning; a write that fails (a
        full disk, a file system gone read-only) is a SweepFileError saying that the rows
        written before are kept and the sweep resumes."""
        line = (json.dumps(row, allow_nan=False, separators=(", ", ": ")) + "\n").encode()
        try:
            self._fh.write(line)
            self._sync()
        except OSError as err:
            raise SweepFileError(
                f"{self.path}: cannot write the results file ({err.strerror or err}); the sweep "
                "stopped there, and every row written before is kept (a partly written last "
                "line is removed when the sweep resumes): make room (or make the file system "
                "writable) and run the same command again to resume") from None

    def close(self) -> None:
        """Close the file, releasing its lock."""
        if not self._fh.closed:
            with _HELD_GUARD:
                _HELD.discard(self._fh.fileno())
            try:
                self._fh.close()
            except OSError:          # the rest of a row that could not be written (reported)
                pass

"""Files that a user names (a model file, a previous result, a results file to resume): read
within a bound, whatever the file claims to be.

:func:`read_bytes` and :func:`read_text` are the one reader of such files. They read at most
``limit`` bytes however large the file's ``st_size`` says it is (0 for ``/proc`` files and
devices); they refuse by type, each with its own message, what is not a file: a directory, a
device (``/dev/zero`` would give bytes forever, ``/dev/tty`` would wait for a keyboard), a
socket, a symlink loop, a path that does not exist; and they read a pipe (``simulate <(cat
m.toml)``, a named FIFO) within the same size bound and a time bound (:data:`PIPE_SECONDS` for the
first byte and between bytes), so a pipe that never writes cannot hang the command.
:func:`write_atomic` writes a file whole or not at all.

:func:`path_problem` tells, without reading, what is wrong with a path that is to be read;
:func:`output_problem` what is wrong with a path to write, before the work that makes the file;
:func:`replace_problem` what is at a path that a file written there must not replace;
:func:`make_folder` makes an output folder, saying what is in its way.
Errors are :class:`~porthamiltonian.errors.ModelFileError` starting with the ``label`` the
caller gives (how the user named the file: ``"--guess result.json"``, the path).
"""
from __future__ import annotations

import contextlib
import errno
import os
import select
import stat
import tempfile
from pathlib import Path

from .errors import ModelFileError

__all__ = ["PIPE_SECONDS", "is_pipe", "make_folder", "no_room", "output_problem", "path_problem",
           "read_bytes", "read_text", "replace_problem", "write_atomic"]

#: the longest wait (s) for a pipe's first byte and between its bytes
PIPE_SECONDS = 30.0
_CHUNK = 1 << 16


def _kind(mode: int) -> str | None:
    """What a file of this ``st_mode`` is, when it is not something to read: None for a regular
    file or a pipe."""
    if stat.S_ISDIR(mode):
        return "a directory, not a file"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device, not a file (a device has no end, or waits for input)"
    if stat.S_ISSOCK(mode):
        return "a socket, not a file"
    if stat.S_ISREG(mode) or stat.S_ISFIFO(mode):
        return None
    return "not a regular file"


def _os_problem(err: OSError) -> str:
    """The words for why a path cannot be opened."""
    if err.errno == errno.ENOENT:
        return "does not exist"
    if err.errno == errno.ELOOP:
        return "is a symbolic link that points to itself (a loop of links)"
    if err.errno == errno.ENOTDIR:
        return "does not exist (a part of its path is not a folder)"
    if err.errno in (errno.EACCES, errno.EPERM):
        return "cannot be read: permission denied"
    if err.errno == errno.ENAMETOOLONG:
        return "is not a valid path (the name is too long)"
    return f"cannot be read ({err.strerror or err})"


def no_room(what: str, err: OSError, variables: str = "TMPDIR") -> str:
    """The message for ``what`` (e.g. "cannot write x.c for the C compiler in /tmp/...") that
    could not be written (a full disk, a file size limit: the machine's problem, not a bug):
    why, and what to do, naming the environment ``variables`` that move the files."""
    return (f"{what} ({err.strerror or err}): free space in {tempfile.gettempdir()} (or raise "
            f"the file size limit), or point {variables} at a folder with room")


def path_problem(path: str | Path) -> str | None:
    """What is wrong with reading ``path`` (``"does not exist"``, ``"is a directory, not a
    file"``, ...), or None for a regular file or a pipe."""
    try:
        info = os.stat(path)
    except OSError as err:
        if err.errno == errno.ENOENT and os.path.lexists(path):
            return "is a symbolic link to nothing (its target does not exist)"
        return _os_problem(err)
    except ValueError:
        return "is not a valid path (it holds a NUL character)"
    kind = _kind(info.st_mode)
    return None if kind is None else f"is {kind}"


def output_problem(path: str | Path) -> str | None:
    """What is wrong with writing a file at ``path``, known before the work that makes it:
    ``"is a directory, not a file"``, or that its folder does not exist; None otherwise (a
    device such as ``/dev/stdout`` is written to)."""
    path = Path(path)
    if path.is_dir():
        return "is a directory, not a file"
    if not path.parent.is_dir():
        return f"cannot be written: the folder {path.parent} does not exist"
    return None


def make_folder(path: str | Path) -> Path:
    """Make the output folder ``path`` and its parents (before the work that fills it); what is
    in the way is a ModelFileError saying so (``mkdir`` said only "File exists" or "Not a
    directory")."""
    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise ModelFileError(f"{path} exists and is not a folder: give a folder to write "
                             "into") from None
    except NotADirectoryError:
        raise ModelFileError(f"{path} cannot be made: a part of its path is a file, not a "
                             "folder") from None
    return path


def replace_problem(path: str | Path) -> str | None:
    """What is at ``path`` that a file written there must not replace (a new file renamed into
    place, :func:`write_atomic`, would put a file where it was: as root, ``/dev/null`` became a
    file): ``"is a directory, not a file"``, ``"is a device, not a file"``, a socket or a pipe;
    None for nothing there, a regular file or a symbolic link (replaced, not written
    through)."""
    try:
        info = os.lstat(path)
    except (OSError, ValueError):
        return None                   # nothing there (or no valid path: the write will say)
    if stat.S_ISLNK(info.st_mode):
        return None
    if stat.S_ISCHR(info.st_mode) or stat.S_ISBLK(info.st_mode):
        return "is a device, not a file"
    kind = "a pipe, not a file" if stat.S_ISFIFO(info.st_mode) else _kind(info.st_mode)
    return None if kind is None else f"is {kind}"


def is_pipe(path: str | Path) -> bool:
    """True when ``path`` is a pipe (a FIFO, or a process substitution's ``/dev/fd/N``): it can
    be read once only."""
    try:
        return stat.S_ISFIFO(os.stat(path).st_mode)
    except (OSError, ValueError):
        return False


def _too_large(label: str, kind: str, limit: int, size: str) -> ModelFileError:
    return ModelFileError(f"{label}: the file is {size} long; a {kind} is at most {limit} bytes "
                          f"(is it a {kind}?)")


def _read_pipe(fd: int, limit: int, label: str, kind: str) -> bytes:
    """At most ``limit`` bytes of the pipe ``fd`` (opened non-blocking), waiting at most
    :data:`PIPE_SECONDS` for each chunk; a pipe that nothing writes to gives no data at once."""
    chunks: list[bytes] = []
    total = 0
    while True:
        try:
            chunk = os.read(fd, _CHUNK)
        except BlockingIOError:                 # a writer, no data yet
            ready, _, _ = select.select([fd], [], [], PIPE_SECONDS)
            if not ready:
                raise ModelFileError(f"{label}: the pipe sent nothing for {PIPE_SECONDS:g} s; "
                                     "is the command that writes it stuck? (give a file "
                                     "instead)") from None
            continue
        if not chunk:
            if not chunks:
                raise ModelFileError(f"{label} is a pipe that gave no data (does anything write "
                                     f"to it?); give a file, or a pipe that sends the {kind}")
            return b"".join(chunks)
        chunks.append(chunk)
        total += len(chunk)
        if total > limit:
            raise _too_large(label, kind, limit, f"more than {limit} bytes")


def read_bytes(path: str | Path, *, limit: int, label: str, kind: str) -> bytes:
    """The bytes of the file ``path``, at most ``limit`` of them; else a
    :class:`~porthamiltonian.errors.ModelFileError` starting with ``label`` saying what the path
    is (a directory, a device, a socket, a loop of links, missing, too large for a ``kind``)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as err:
        problem = path_problem(path) or _os_problem(err)
        raise ModelFileError(f"{label} {problem}") from None
    except ValueError:
        raise ModelFileError(f"{label} is not a valid path (it holds a NUL character)") from None
    try:
        info = os.fstat(fd)
        what = _kind(info.st_mode)
        if what is not None:
            raise ModelFileError(f"{label} is {what}")
        if stat.S_ISFIFO(info.st_mode):
            return _read_pipe(fd, limit, label, kind)
        if info.st_size > limit:
            raise _too_large(label, kind, limit, f"{info.st_size} bytes")
        os.set_blocking(fd, True)
        chunks, total = [], 0
        while total <= limit:                 # st_size may lie (/proc): read one byte more
            chunk = os.read(fd, min(_CHUNK, limit + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        if total > limit:
            raise _too_large(label, kind, limit, f"more than {limit} bytes")
        return b"".join(chunks)
    except OSError as err:
        raise ModelFileError(f"{label}: cannot read it ({err.strerror or err})") from None
    finally:
        os.close(fd)


def read_text(path: str | Path, *, limit: int, label: str, kind: str, language: str) -> str:
    """The UTF-8 text of the file ``path`` (:func:`read_bytes`: at most ``limit`` bytes); a
    byte-order mark at the start is dropped (editors on Windows write one). A file that is not
    UTF-8 is refused, saying that a ``kind`` is ``language`` text."""
    data = read_bytes(path, limit=limit, label=label, kind=kind)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise ModelFileError(f"{label}: not a UTF-8 text file (byte {err.start}: {err.reason}); "
                             f"a {kind} is {language} text") from None
    return text.removeprefix("\ufeff")


def write_atomic(path: Path, data: str | bytes, *, plain_mode: bool = False) -> None:
    """Write ``data`` (text as UTF-8) to ``path`` through a temporary file in the same folder,
    then rename: a reader sees the old file or the new one, never a part; a symbolic link at
    ``path`` is replaced, not written through. ``plain_mode``: the file gets the permissions a
    plain write would give it (0666 less the umask) instead of the temporary file's 0600."""
    raw = data.encode() if isinstance(data, str) else data
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        if plain_mode:
            umask = os.umask(0o022)
            os.umask(umask)
            os.fchmod(fd, 0o666 & ~umask)
        with os.fdopen(fd, "wb") as fh:
            fh.write(raw)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise

"""On-disk cache of compiled models: keyed by a hash of the model, trusted only when intact.

Key
---
The key hashes the model's canonical description (components with their arguments, bonds,
parameters, events, outputs), the sources of the package modules that determine the generated code
(the component classes' modules and what they import, the compiler, the back ends, the integration
loops and their C templates), the versions of sympy and of the code generator: editing the command line, the analyses or
a docstring of an unrelated module keeps every cached model.

Layout
------
Location: ``$PORTHAMILTONIAN_CACHE`` or ``~/.cache/porthamiltonian``, created with mode 0700. One
folder per entry, ``<cache>/<key>/``:

``meta.json``            the layout (states, parameters, outputs, events, energy parts, parameter
                         constraints) and the equations for display
``body.c``, ``body.py``  the generated code (one program printed as C and as Python); body.py
                         is added when a back end first needs it (python, numba): a C build
                         does not print it
``m<key>_<backend>.py``  a back end's module (python, numba), derived from body.py, added when
                         first needed
``m<key>_c.c``, ``m<key>_c_<platform>.so``  the C back end's translation unit and shared library
                         (``.dll`` on Windows), added when first needed; ``m<key>_c.log``, the
                         compiler's output when it failed (never read back, not recorded)
``addon-<name>.*``       an add-on: functions generated after the model's own and built beside
                         them, never into the model's library (the port-Hamiltonian form's,
                         ``ph``: :func:`porthamiltonian.compiler.compile_model` with ``ph=True``;
                         the declared outputs' Jacobian, ``out_jac``: a first linearization):
                         its record (``.json``) and bodies (``.c``; ``.py`` when first needed),
                         with its own back-end files ``m<key>_<name>_c.c``,
                         ``m<key>_<name>_c_<platform>.so``, ``m<key>_<name>_<backend>.py``
other files              artifacts a back end stores with :func:`store`
``manifest.json``        ``{"key": ..., "files": {name: sha256}}``: every file above
``__pycache__/``         numba's compiled functions (an index and a data file per function),
                         written when a function is first called: recorded in the manifest too
                         (``__pycache__/<file>``) as numba writes them, and verified before numba
                         unpickles them (:mod:`.numba_cache`); removed whenever the module is
                         written again or the entry is found damaged. Python's own bytecode is
                         never written or read: a generated module is compiled from its verified
                         text

An entry is created complete in a temporary folder and renamed into place, so concurrent sweep
workers can share one cache; files added later are written atomically (write, then rename) and
the manifest is updated under a lock. A process that makes an entry or its C library holds the
model's build lock, ``<cache>/.building-<key>`` (an empty file, :func:`building`): another
process compiling the same model at the same time waits for it and then reads the entry,
instead of running the symbolic stage and the C compiler a second time.

Integrity and trust (the rules a native back end follows too, through :func:`store`,
:func:`load_verified` and :func:`verified_path`)
----------------------------------------------------------------------------------------------
* Every file is verified against its sha256 in the manifest before it is used. A missing,
  truncated or edited file, a damaged manifest, or an entry whose files disagree with it gives one
  :class:`CacheWarning` naming the file; the entry (its ``__pycache__`` with it) is removed and
  rebuilt, or, for a back end's file, that file is stored again.
* The cache folder is used only when it is owned by the user and not writable by group or
  others, and every folder above it is owned by the user or root and not writable by everyone
  unless sticky (``/tmp``); so is every folder that anything is loaded from (an entry, its
  ``__pycache__``): an entry that fails the rule gives one warning and is removed and rebuilt
  (or, when it is not the user's to remove, built in the private temporary folder). Otherwise, or when it cannot be written (read-only), this process
  warns once, saying how to fix it (``chmod 700 DIR``, or another ``PORTHAMILTONIAN_CACHE``),
  reads nothing from it, and builds in a private temporary folder removed at exit (chosen over
  refusing to compile: the work goes on, only nothing is kept). Nothing is imported or unpickled
  from a folder that others can write.
* ``compile_model(..., use_cache=False)`` writes nothing to the cache (``persistent=False`` here):
  the module is built in the private temporary folder.

API for back ends
-----------------
``store(key, name, data, persistent=True) -> Path``
    write ``data`` (bytes or text) as file ``name`` of entry ``key`` and record its hash; the path
    (in the entry, or in the private temporary folder when not persistent or the cache is not
    usable).
``load_verified(key, name) -> bytes | None``
    the file's contents if it is recorded and intact; None if absent, or if damaged (then one
    warning, and the file is removed so that the caller stores it again).
``verified_path(key, name) -> Path | None``
    the same check, returning the path (for what must be loaded from a path, e.g. ``ctypes``).
"""
from __future__ import annotations

import atexit
import contextlib
import functools
import hashlib
import inspect
import json
import os
import re
import shutil
import stat
import sys
import tempfile
import threading
import warnings
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import CompilerError, OptionError
from ..userfiles import no_room, write_atomic

if TYPE_CHECKING:
    from ..modeling.model import Model, ModelDescription

# POSIX file locks for manifest updates (elsewhere, concurrent updates may lose a record, which
# only costs a rebuild of that file)
if sys.platform != "win32":
    import fcntl

_MANIFEST = "manifest.json"
_LOCK = ".lock"
_COMPILING = ".compiling"
_PYCACHE = "__pycache__"
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")


class CacheWarning(UserWarning):
    """The compiled-model cache is damaged, untrusted or not writable (the message says which
    file or folder and what happens instead)."""


def _warn(message: str) -> None:
    warnings.warn(message, CacheWarning, stacklevel=3)


def warn(message: str) -> None:
    """One :class:`CacheWarning` (for the back ends' checks of what they load from the cache)."""
    warnings.warn(message, CacheWarning, stacklevel=3)


# --- where -----------------------------------------------------------------------------------------
def configured_dir() -> Path:
    """The cache folder asked for: ``$PORTHAMILTONIAN_CACHE`` or ``~/.cache/porthamiltonian``."""
    return Path(os.environ.get("PORTHAMILTONIAN_CACHE", Path.home() / ".cache" / "porthamiltonian"))


_private: dict[str, Path] = {}
_refused: set[str] = set()


def private_dir() -> Path:
    """This process's private build folder (mode 0700, removed at exit)."""
    if "dir" not in _private:
        path = Path(tempfile.mkdtemp(prefix="porthamiltonian-"))
        atexit.register(shutil.rmtree, path, True)
        _private["dir"] = path
    return _private["dir"]


def cache_dir() -> Path | None:
    """The cache folder, created private (0700) if missing, or None when it cannot be trusted or
    written (one :class:`CacheWarning` per folder and process, with the fix)."""
    path = configured_dir().expanduser()
    key = str(path)
    if key in _refused:
        return None
    try:
        path.mkdir(mode=0o700, parents=True, exist_ok=True)
        problem = _untrusted(path)
        if problem is None and not os.access(path, os.W_OK | os.X_OK):
            problem = "it is not writable"
    except OSError as err:
        problem = f"it cannot be created ({err.strerror})"
    if problem is None:
        return path
    _refused.add(key)
    _warn(f"compiled-model cache {path}: {problem}; nothing is read from it, and this process "
          f"builds in a private temporary folder instead (slower: nothing is kept). Fix: "
          f"'chmod 700 {path}' if the folder is yours, or set PORTHAMILTONIAN_CACHE to a folder "
          "of your own")
    return None


def _untrusted(path: Path) -> str | None:
    """Why ``path`` cannot be trusted, or None: it must be the user's and not writable by group
    or others; each folder above it must belong to the user or root and not be writable by
    everyone unless sticky (as /tmp is; a group-writable home of a user-private group is fine)."""
    uid = os.getuid() if hasattr(os, "getuid") else None
    info = path.stat()
    if uid is not None and info.st_uid != uid:
        return f"it belongs to another user (uid {info.st_uid})"
    if info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return "it is writable by other users"
    if info.st_mode & 0o077:  # readable by others: tighten (our own folder)
        with contextlib.suppress(OSError):
            path.chmod(0o700)
    for parent in path.resolve().parents:
        pinfo = parent.stat()
        if uid is not None and pinfo.st_uid not in (uid, 0):
            return f"the folder above it, {parent}, belongs to another user"
        if pinfo.st_mode & stat.S_IWOTH and not pinfo.st_mode & stat.S_ISVTX:
            return f"the folder above it, {parent}, is writable by other users"
    return None


def private_problem(folder: Path) -> str | None:
    """Why files in ``folder`` (an entry of the cache, or a folder in it such as
    ``__pycache__``) cannot be loaded, or None: it must belong to the user and not be writable
    by group or others, like the cache folder itself (otherwise someone else could have put or
    changed files there, hashes and manifest included)."""
    try:
        info = folder.lstat()
    except OSError as err:
        return f"it cannot be examined ({err.strerror})"
    if stat.S_ISLNK(info.st_mode) or not stat.S_ISDIR(info.st_mode):
        return "it is not a folder (a link or a file is in its place)"
    uid = os.getuid() if hasattr(os, "getuid") else None
    if uid is not None and info.st_uid != uid:
        return f"it belongs to another user (uid {info.st_uid})"
    if info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return "it is writable by other users"
    return None


def _in_private_dir(path: Path) -> bool:
    return "dir" in _private and _private["dir"] in path.parents


def _usable(entry: Path) -> bool:
    """True when the entry folder may be read (:func:`private_problem`); otherwise one warning,
    and the entry is removed (it is rebuilt) when it is ours to remove. (This process's private
    folder is its own: made by it, mode 0700.)"""
    if _in_private_dir(entry):
        return True
    problem = private_problem(entry)
    if problem is None:
        return True
    _warn(f"compiled-model cache: {entry}: {problem}; nothing is loaded from it, and it is "
          "removed and rebuilt")
    _remove(entry)
    return False


def _base(persistent: bool) -> Path:
    """Where entries go: the cache folder; else (not usable) the private folder's ``cache``;
    ``scratch`` in the private folder for builds that are not to be kept (use_cache=False)."""
    base = cache_dir() if persistent else None
    if base is None:
        base = private_dir() / ("cache" if persistent else "scratch")
        base.mkdir(mode=0o700, exist_ok=True)
    return base


# --- the key ---------------------------------------------------------------------------------------
def model_key(model: Model | ModelDescription, options: dict[str, Any] | None = None) -> str:
    """A hash of everything that determines the generated code: the model's canonical
    description (:meth:`~porthamiltonian.modeling.model.ModelDescription.canonical`), the source of every
    package module the model's component classes depend on (their modules and, transitively, the
    package modules those import), the compiler and back-end sources, the versions of sympy
    and of the code generator, and the compiler's ``options`` (JSON-able; e.g. the parameters
    of a generated ``jac_p``), when given. (The files of an entry are read and written without
    sympy: only the key needs it.)"""
    import sympy

    from ..modeling.model import Model
    from .codegen import CODEGEN_VERSION

    description = model.freeze() if isinstance(model, Model) else model
    modules = {type(c).__module__ for c in description.components.values()}
    content = {"model": description.canonical(), "classes": _sources_hash(frozenset(modules)),
               "sympy": sympy.__version__, "codegen": CODEGEN_VERSION}
    if options:
        content["options"] = options
    blob = json.dumps(content, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:32]


_KEY = re.compile(r"[0-9a-f]{32}")


def model_key_form(key: str) -> bool:
    """True when ``key`` has the form of a :func:`model_key` (32 hexadecimal digits): a key read
    from a file names a folder of the cache only then."""
    return isinstance(key, str) and _KEY.fullmatch(key) is not None


_PACKAGE = Path(__file__).resolve().parent.parent
#: package modules that shape the generated code whatever the model holds
_CORE = ("compiler", "backends", "integrators", "modeling")
_IMPORT = re.compile(r"^\s*from\s+(\.+)([\w.]*)\s+import\s+([\w, ()]+)", re.MULTILINE)


@functools.cache
def _sources_hash(modules: frozenset[str]) -> str:
    """sha256 over the sources of ``modules`` (dotted names; those outside the package by name
    and, where found, source), the core modules, and every package module they import (the
    package's files read once per process: :func:`_package_file`)."""
    files: set[Path] = set()
    outside: list[str] = []
    todo = [_PACKAGE / name for name in _CORE]
    for module in modules:
        if module.split(".")[0] == _PACKAGE.name:
            todo.append(_PACKAGE.joinpath(*module.split(".")[1:]))
        else:
            outside.append(_outside_source(module))
    while todo:
        for path in _candidates(todo.pop()):
            if path not in files:
                files.add(path)
                todo += _package_file(path)[1]
    digest = hashlib.sha256()
    for path in sorted(files):
        digest.update(str(path.relative_to(_PACKAGE)).encode() + b"\0" + _package_file(path)[0])
    for text in sorted(outside):
        digest.update(text.encode())
    return digest.hexdigest()


@functools.cache
def _candidates(base: Path) -> tuple[Path, ...]:
    """The package's files that ``base`` names: every .py and .c file under a folder, else the
    module ``base``.py when it exists."""
    found = (sorted([*base.rglob("*.py"), *base.rglob("*.c")]) if base.is_dir()
             else [base.with_suffix(".py")])
    return tuple(path for path in found if path.is_file())


@functools.cache
def _package_file(path: Path) -> tuple[bytes, tuple[Path, ...]]:
    """A package file's bytes and the package modules its relative imports name: ``from .x
    import y``: module x; for a package x, its __init__ (which imports what it gathers) and
    the named submodules, not the whole package."""
    data = path.read_bytes()
    targets: list[Path] = []
    for dots, name, names in (_IMPORT.findall(data.decode()) if path.suffix == ".py" else ()):
        root = path.parent
        for _ in range(len(dots) - 1):
            root = root.parent
        target = root.joinpath(*name.split(".")) if name else root
        if target.is_dir():
            targets.append(target / "__init__")
            targets += [target / n.split(" as ")[0].strip()
                        for n in names.strip("()").split(",") if n.strip()]
        else:
            targets.append(target)
    return data, tuple(targets)


def _outside_source(module: str) -> str:
    """Source text of a component module defined outside the package (e.g. a user's own
    component), or its name when the source is not available."""
    try:
        return inspect.getsource(sys.modules[module])
    except (KeyError, OSError, TypeError):
        return module


# --- files and the manifest ------------------------------------------------------------------------
def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _check_file_name(name: str) -> None:
    if not (isinstance(name, str) and _NAME.fullmatch(name)) or name in (_MANIFEST, _LOCK,
                                                                         _COMPILING):
        raise OptionError(f"cache file name {name!r}: letters, digits, '_', '.', '-' only, not "
                         f"{_MANIFEST}")


_HELD = threading.local()


@contextlib.contextmanager
def _flock(folder: Path, name: str, optional: bool) -> Iterator[None]:
    """Hold an exclusive POSIX lock on the file ``name`` in ``folder``; reentrant within a
    thread (the lock files this thread holds). ``optional``: when the lock file cannot be made
    (a read-only entry) go on without a lock instead of raising OSError."""
    held = _HELD.__dict__.setdefault("files", set())
    lock = str(folder / name)
    if sys.platform == "win32" or lock in held:  # pragma: no cover - (Windows)
        yield
        return
    try:
        fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o600)
    except OSError:
        if not optional:
            raise
        yield
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        held.add(lock)
        yield
    finally:
        held.discard(lock)
        os.close(fd)


def _locked(entry: Path) -> contextlib.AbstractContextManager[None]:
    """Hold the entry's lock (manifest read-modify-write); reentrant within a thread."""
    return _flock(entry, _LOCK, optional=False)


def compiling(entry: Path) -> contextlib.AbstractContextManager[None]:
    """Hold the entry's compile lock (a file of its own, not the manifest's lock) while a back end
    compiles code that it keeps in the entry, e.g. numba's: a concurrent process (a sweep's or a
    test run's other worker) that wants the same code waits, then reads it from the cache
    instead of compiling it a second time. Reentrant within a thread; without POSIX file locks,
    or when the lock file cannot be made (a read-only entry), no lock."""
    return _flock(entry, _COMPILING, optional=True)


def building(key: str) -> contextlib.AbstractContextManager[None]:
    """Hold model ``key``'s build lock (the file ``.building-<key>`` in the cache folder) while
    this process makes its entry or its C library: a concurrent process (a sweep's or a test
    run's other worker) that compiles the same model waits, then reads what the first one made
    from the cache instead of making it a second time (the callers look again once they hold
    the lock). Reentrant within a thread; no lock when the cache folder is not usable (nothing
    is shared then) or the lock file cannot be made, and without POSIX file locks."""
    base = cache_dir()
    return contextlib.nullcontext() if base is None else _flock(base, f".building-{key}",
                                                               optional=True)


def _manifest(entry: Path) -> dict[str, str] | None:
    """The entry's file hashes, or None when the manifest is missing or damaged (warned)."""
    path = entry / _MANIFEST
    try:
        data = json.loads(path.read_bytes())
        files = data["files"]
        if data.get("key") != entry.name or not isinstance(files, dict) or not all(
                isinstance(k, str) and isinstance(v, str) for k, v in files.items()):
            raise TypeError("unexpected contents")
    except FileNotFoundError:
        if entry.exists():
            _warn(f"compiled-model cache: {path} is missing; the entry is rebuilt")
        return None
    except (OSError, ValueError, KeyError, TypeError) as err:
        _warn(f"compiled-model cache: {path} is damaged ({err}); the entry is rebuilt")
        return None
    return files


def _record(entry: Path, updates: dict[str, str | None]) -> None:
    """Set (hash) or drop (None) files in the entry's manifest, under its lock; a name ending
    in ``/`` or ``.`` drops every file whose name starts with it (under that folder, or of
    that module: :func:`drop_pycache`)."""
    with _locked(entry):
        try:
            files = json.loads((entry / _MANIFEST).read_bytes())["files"]
        except (OSError, ValueError, KeyError):
            files = {}
        for name, digest in updates.items():
            if name.endswith(("/", ".")):
                files = {k: v for k, v in files.items() if not k.startswith(name)}
            elif digest is None:
                files.pop(name, None)
            else:
                files[name] = digest
        write_atomic(entry / _MANIFEST, json.dumps({"key": entry.name, "files": files},
                                                   indent=1, sort_keys=True))


def _remove(entry: Path) -> None:
    """Remove a damaged entry (renamed away first, so a concurrent reader sees it gone)."""
    trash = entry.with_name(f".trash-{entry.name}-{os.getpid()}")
    with contextlib.suppress(OSError):
        os.replace(entry, trash)
        shutil.rmtree(trash, ignore_errors=True)


def _verified(entry: Path, name: str, files: dict[str, str]) -> bytes | None:
    """The bytes of ``name`` when they match the manifest; None (warned) otherwise."""
    try:
        data = (entry / name).read_bytes()
    except OSError:
        _warn(f"compiled-model cache: {entry / name} is missing; it is rebuilt")
        return None
    if _sha256(data) != files.get(name):
        _warn(f"compiled-model cache: {entry / name} does not match its recorded sha256 (damaged or "
              "edited); it is rebuilt")
        return None
    return data


# --- entries: layout and code ------------------------------------------------------------------------
#: the file of an entry holding the generated Python body: stored by the first build that
#: needs it (the python and numba back ends), optional in an entry (a C build leaves none)
PYTHON_BODY = "body.py"
_BODIES = {"python": PYTHON_BODY, "c": "body.c"}


def read(key: str) -> tuple[dict[str, Any], dict[str, str]] | None:
    """The entry's ``(meta, bodies)`` (bodies: ``{"c": ...}`` and, when the entry has it,
    ``"python"``) when present and intact; None on a miss. A damaged entry (a recorded file,
    the Python body's included, missing or not matching its sha256) is
    reported in one warning naming the file and removed (the caller rebuilds it). When the cache
    folder is not usable, this process's private folder serves instead."""
    entry = _base(True) / key
    if not entry.is_dir() or not _usable(entry):
        return None
    files = _manifest(entry)
    raw: dict[str, bytes] | None = None
    names = ("meta.json", *_BODIES.values())
    if files is not None and not set(names) & set(files):
        return None                     # only back-end files stored so far: a miss
    if files is not None:
        found = {name: _verified(entry, name, files) for name in names
                 if name != PYTHON_BODY or name in files}
        raw = {name: data for name, data in found.items() if data is not None}
        if len(raw) < len(found):
            raw = None
    if raw is not None:
        try:
            meta = json.loads(raw["meta.json"])
            return meta, {lang: raw[name].decode() for lang, name in _BODIES.items()
                          if name in raw}
        except (ValueError, UnicodeDecodeError) as err:
            _warn(f"compiled-model cache: {entry / 'meta.json'} cannot be read ({err}); the "
                  "entry is rebuilt")
    _remove(entry)
    return None


def write(key: str, meta: dict[str, Any], bodies: dict[str, str]) -> None:
    """Store a new entry (layout and code bodies by language: ``"c"``, and ``"python"`` when
    given, else stored later as :data:`PYTHON_BODY` with :func:`store`), complete or not at all
    (in this process's private folder when the cache folder is not usable)."""
    base = _base(True)
    try:
        staging = Path(tempfile.mkdtemp(prefix=f".new-{key}-", dir=base))
    except OSError as err:
        _warn(f"compiled-model cache {base}: cannot write ({err.strerror}); not cached")
        return
    try:
        contents = {"meta.json": json.dumps(meta, indent=1).encode(),
                    **{name: bodies[lang].encode() for lang, name in _BODIES.items()
                       if lang in bodies}}
        for name, data in contents.items():
            (staging / name).write_bytes(data)
        (staging / _MANIFEST).write_text(json.dumps(
            {"key": key, "files": {n: _sha256(d) for n, d in contents.items()}}, indent=1,
            sort_keys=True))
        os.chmod(staging, 0o700)
        try:
            os.rename(staging, base / key)
        except OSError:                 # another process stored it first, or a stale entry
            if read(key) is None:       # damaged (now removed), or holding back-end files only
                if (base / key).is_dir():
                    for name, data in contents.items():
                        store(key, name, data)
                else:
                    os.rename(staging, base / key)
    except OSError as err:
        _warn(f"compiled-model cache {base}: cannot write ({err.strerror}); not cached")
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _entry(key: str, persistent: bool) -> Path:
    """The entry folder of ``key`` (created in the private folder, or in the cache if missing)."""
    entry = _base(persistent) / key
    if entry.is_dir() and not _usable(entry) and os.path.lexists(entry):
        entry = _base(False) / key           # not ours to remove: build beside this process
    if not entry.is_dir():
        entry.mkdir(mode=0o700, exist_ok=True)
        _record(entry, {})
    return entry


def store(key: str, name: str, data: bytes | str, persistent: bool = True) -> Path:
    """Write file ``name`` of entry ``key`` atomically, record its sha256, return its path
    (in the private temporary folder when not ``persistent`` or the cache is not usable)."""
    _check_file_name(name)
    raw = data.encode() if isinstance(data, str) else data
    try:
        entry = _entry(key, persistent)
        write_atomic(entry / name, raw)
        _record(entry, {name: _sha256(raw)})
    except OSError as err:
        if not persistent:
            # nowhere to write (a full disk, a file size limit): the user's to fix, not a bug
            raise CompilerError(no_room(
                f"cannot write {name} of the compiled model {key} in {_base(False)}", err,
                "TMPDIR and PORTHAMILTONIAN_CACHE")) from err
        _warn(f"compiled-model cache {configured_dir()}: cannot write {name} ({err.strerror}); "
              "built in a private temporary folder instead")
        return store(key, name, raw, persistent=False)
    return entry / name


def load_verified(key: str, name: str) -> bytes | None:
    """The contents of file ``name`` of entry ``key`` if recorded and intact; None if absent or
    damaged (one warning; the file is dropped from the entry, to be stored again)."""
    path = verified_path(key, name)
    return None if path is None else path.read_bytes()


def verified_path(key: str, name: str) -> Path | None:
    """The path of file ``name`` of entry ``key`` after checking it against the manifest (in the
    cache, or in this process's private folder when the cache is not usable); None if absent or
    damaged (warned; the file is removed and dropped from the manifest)."""
    _check_file_name(name)
    entry = _base(True) / key
    if not (entry / name).is_file() or not _usable(entry):
        return None
    files = _manifest(entry)
    if files is None:
        _remove(entry)
        return None
    if name not in files:
        return None
    if _verified(entry, name, files) is None:
        with contextlib.suppress(OSError):
            (entry / name).unlink()
        _record(entry, {name: None})
        return None
    return entry / name


def discard(key: str, name: str) -> None:
    """Remove file ``name`` of entry ``key`` and its record (a library that failed its
    self-check: the next build replaces it)."""
    _check_file_name(name)
    entry = _base(True) / key
    with contextlib.suppress(OSError):
        (entry / name).unlink()
    if (entry / _MANIFEST).exists():
        _record(entry, {name: None})


def recorded(key: str, prefix: str = "") -> list[str]:
    """The names of the files recorded in entry ``key`` that start with ``prefix`` (none when
    the entry is absent or cannot be used)."""
    entry = _base(True) / key
    if not entry.is_dir() or not _usable(entry):
        return []
    return sorted(n for n in (_manifest(entry) or {}) if n.startswith(prefix) and "/" not in n)


def kept(path: Path) -> bool:
    """True when ``path`` lies in the cache folder (kept after this process ends)."""
    base = cache_dir()
    return base is not None and base.resolve() in Path(path).resolve().parents


def backend_module(key: str, backend: str, text: str, persistent: bool = True,
                   addon: str = "") -> Path:
    """Path of the back-end module for ``key`` (``m<key>_<backend>.py``; of its add-on
    ``addon``: ``m<key>_<addon>_<backend>.py``) with the text ``text``: the stored one when it
    is intact and the same, else written now (and the machine code numba compiled from an older
    one removed: :func:`drop_pycache`)."""
    name = f"m{key}{f'_{addon}' if addon else ''}_{backend}.py"
    path = verified_path(key, name) if persistent else None
    if path is None or path.read_bytes() != text.encode():
        path = store(key, name, text, persistent)
        drop_pycache(path.parent, path.stem)
    return path


def drop_pycache(entry: Path, module: str = "") -> None:
    """Remove the entry's ``__pycache__`` (numba's compiled functions) and its records; with
    ``module`` (a module's file stem, which numba's file names start with: ``<stem>.<function>
    -<line>...``), only that module's files (a model's add-on written keeps the model's own)."""
    if not module:
        shutil.rmtree(entry / _PYCACHE, ignore_errors=True)
    else:
        for path in (entry / _PYCACHE).glob(f"{module}.*"):
            with contextlib.suppress(OSError):
                path.unlink()
    if (entry / _MANIFEST).exists():
        _record(entry, {f"{_PYCACHE}/{f'{module}.' if module else ''}": None})


def read_recorded(entry: Path, path: Path) -> bytes | None:
    """The bytes of ``path``, a file the back end wrote in the entry's ``__pycache__`` and
    recorded (:func:`record_written`), when they match their record; None when it is absent.
    A file that is not recorded or does not match (damaged, or put there by someone else) is
    removed, with one warning, and None returned: the caller builds it again. Read under the
    entry's lock, so a concurrent writer's file is seen with its record."""
    name = Path(os.path.relpath(path, entry)).as_posix()
    with _locked(entry):
        try:
            data = path.read_bytes()
        except FileNotFoundError:
            return None
        except OSError as err:
            _warn(f"compiled-model cache: {path} cannot be read ({err.strerror}); it is rebuilt")
            return None
        files = _manifest(entry) or {}
        if files.get(name) == _sha256(data):
            return data
        why = ("is not recorded in the manifest (left by an interrupted build, or put there by "
               "someone else)" if name not in files else
               "does not match its recorded sha256 (damaged or edited)")
        _warn(f"compiled-model cache: {path} {why}; it is removed and rebuilt")
        with contextlib.suppress(OSError):
            path.unlink()
        _record(entry, {name: None})
    return None


def pycache_usable(entry: Path) -> bool:
    """Check the entry's ``__pycache__`` before a back end loads anything from it: True when it
    is absent, or private (:func:`private_problem`) with every file in it recorded and intact
    (the others are removed, one warning each: :func:`read_recorded`); a folder that is not
    private gives one warning and is removed (True when it is gone)."""
    folder = entry / _PYCACHE
    if not os.path.lexists(folder):
        return True
    problem = None if _in_private_dir(folder) else private_problem(folder)
    if problem is None:
        with _locked(entry):
            for path in sorted(folder.iterdir()):
                if path.is_dir() and not path.is_symlink():
                    shutil.rmtree(path, ignore_errors=True)
                else:
                    read_recorded(entry, path)
        return True
    _warn(f"compiled-model cache: {folder}: {problem}; nothing is loaded from it, and it is "
          "removed")
    with contextlib.suppress(OSError):
        if folder.is_symlink():
            folder.unlink()
    drop_pycache(entry)
    return not os.path.lexists(folder)


@contextlib.contextmanager
def record_written(entry: Path, paths: Callable[[], Iterable[Path]]) -> Iterator[None]:
    """Hold the entry's lock while the back end writes files of its ``__pycache__``, then
    record the sha256 of the files ``paths()`` names (those that exist) in the manifest."""
    with _locked(entry):
        yield
        updates: dict[str, str | None] = {}
        for path in paths():
            name = Path(os.path.relpath(path, entry)).as_posix()
            try:
                updates[name] = _sha256(Path(path).read_bytes())
            except OSError:
                updates[name] = None
        _record(entry, updates)


__all__ = [
    "PYTHON_BODY",
    "CacheWarning",
    "backend_module",
    "cache_dir",
    "compiling",
    "configured_dir",
    "discard",
    "drop_pycache",
    "kept",
    "load_verified",
    "model_key",
    "model_key_form",
    "private_dir",
    "private_problem",
    "pycache_usable",
    "read",
    "read_recorded",
    "record_written",
    "recorded",
    "store",
    "verified_path",
    "warn",
    "write",
    "write_atomic",
]

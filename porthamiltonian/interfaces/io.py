"""Model files: the TOML form of a model and of what a file adds to it, read and written back.

:func:`read` gives a :class:`ModelFile`: the :class:`~porthamiltonian.modeling.model.Model` and the file's
own metadata (description, ``[simulation]`` defaults, further ``[model]`` keys, the tables passed
through for other libraries); :func:`load` gives the model alone. Format (every section optional;
the full reference, generated from the component registry, with a worked example, is
docs/model-files.md)::

    bonds = ["force.p -> j", "j -> mass.p"]      # tail -> head: power flows tail to head;
                                                 # a junction's name alone makes a new port
    [model]
    name = "mass_spring_damper"    # default: the file's name
    description = "..."            # other keys and tables under [model] are kept
                                   # (ModelFile.meta) and saved back
    [walker]                       # a walker's hybrid description: kept as
                                   # ModelFile.sections["walker"] and saved back (read by
                                   # walker_library; see docs/walkers.md)
    [parameters]
    m = { value = 1.0, unit = "kg", doc = "mass" }   # or simply  m = 1.0
    k = 4.0

    [components.mass]
    type = "I"                  # a registered component type (porthamiltonian.modeling.component.REGISTRY)
    inertance = "m"             # arguments: numbers or expressions in parameters, t, states

    [components.sub]            # a sub-model: its own tables under [components.sub.model]
    type = "model"
    exposed = { p = "j.attach" }

    [[events]]
    name = "touchdown"; guard = "-mass.q"; direction = 1; terminal = true

    [outputs]
    position = "spring.q"

    [inputs]                    # signals bound at run time (docs/control.md)
    F = { unit = "N", doc = "applied force" }      # bind = "pid.y": bound in the model

    [simulation]                # defaults for the command line and check-energy
    t_end = 10.0; method = "Radau"; rtol = 1e-9; atol = 1e-12; energy_tolerance = 1e-6
    inputs = { F = 0.0 }        # constant inputs of those runs

    [linearize]                 # the operating point of `porthamiltonian linearize`
    trim = true                 # an equilibrium found from the states below (false: as given)
    states = { "arm.q.pivot" = 3.14159 }; inputs = { F = 0.0 }; free_inputs = []

Loading by name looks in ``$PORTHAMILTONIAN_MODELS`` (if set), then in the ``models/`` folder of the
source tree. Every problem of a file is reported at once, in one
:class:`~porthamiltonian.errors.ModelFileError` naming the file and, for each problem, the line
(TOML's line and column for a syntax error; else the line of the key path the problem carries,
:attr:`~porthamiltonian.errors.ModelError.path`, found by :class:`_Locator` from the text), the
component and the fix, with a suggestion for a misspelt name; no bare
KeyError/TypeError/ValueError escapes the reader (tests/unit/test_model_file_fuzz.py). One small
reader per section. Compile errors of a file's model name the file and line too when compiled
through :meth:`ModelFile.compile` (or within :meth:`ModelFile.located`).
"""
from __future__ import annotations

import difflib
import math
import os
import re
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .. import collector, userfiles
from ..errors import ModelError, ModelFileError, OptionError
from ..simulation.options import check_method, check_rtol, is_real

if TYPE_CHECKING:
    import tomllib

    from ..modeling.component import Component
    from ..modeling.model import Model, ModelDescription
    from ..simulation.compiled import CompiledModel

# The model layers (sympy, networkx) and the compiler are imported where a model is read, built
# or written, not with this module: finding and reading a file's text (:func:`model_path`,
# :func:`read_text`, :func:`locate`) stays light, for the warm start of a cached model.

#: top-level tables that the loader keeps as they are, for the libraries that read them
#: (``Model.sections``, written back on save): the walker library's ``[walker]`` table
PASSED_THROUGH = ("walker",)
#: a model's own tables (a sub-model has these)
_MODEL_TABLES = {"bonds", "model", "parameters", "components", "events", "outputs", "inputs"}
_CORE_SECTIONS = _MODEL_TABLES | {"simulation", "linearize"}
_SECTIONS = _CORE_SECTIONS | set(PASSED_THROUGH)
#: the ``type`` of a sub-model's table
SUB_MODEL = "model"


def models_dirs() -> list[Path]:
    """Folders searched for models by name."""
    dirs = [Path(d) for d in os.environ.get("PORTHAMILTONIAN_MODELS", "").split(os.pathsep) if d]
    dirs.append(Path(__file__).resolve().parents[2] / "models")
    return dirs


def available_models() -> list[str]:
    """Names of the model files found in :func:`models_dirs`."""
    names: dict[str, None] = {}
    for d in models_dirs():
        if d.is_dir():
            names.update((p.stem, None) for p in sorted(d.glob("*.toml")))
    return list(names)


def is_path(name_or_path: str | Path) -> bool:
    """True when ``name_or_path`` names a file rather than a model of :func:`models_dirs`: it
    ends in ``.toml``, holds a folder separator, or something other than a folder is there (a
    file, a pipe such as ``<(cat m.toml)``, a device, a broken link)."""
    text = os.fspath(name_or_path)
    if Path(text).suffix == ".toml" or os.sep in text or (os.altsep and os.altsep in text):
        return True
    return os.path.lexists(text) and not os.path.isdir(text)


def model_path(name_or_path: str | Path) -> Path:
    """Resolve a model name (file name without ``.toml``) or a path to a file that can be read
    (:func:`is_path`); a path that is a folder, a device, a loop of links or missing is refused
    with its own message (:func:`porthamiltonian.userfiles.path_problem`)."""
    path = Path(name_or_path)
    if is_path(name_or_path):
        problem = userfiles.path_problem(path)
        if problem is not None:
            raise ModelFileError(f"model file {os.fspath(name_or_path)} {problem}")
        return path
    for d in models_dirs():
        candidate = d / f"{name_or_path}.toml"
        if candidate.is_file():
            return candidate
    known = available_models()
    if path.is_dir():
        raise ModelFileError(f"{path} is a directory, not a model file, and no model is called "
                             f"{str(name_or_path)!r}{_suggest(name_or_path, known)}; available: "
                             f"{', '.join(known) or 'none'}")
    raise ModelFileError(f"no model called {name_or_path!r}{_suggest(name_or_path, known)}; "
                         f"available: {', '.join(known) or 'none'} (or give a path to a .toml "
                         "file)")


#: Largest model file read (bytes); the largest in models/ is ~20 kB.
MAX_FILE_SIZE = 4 * 1024 * 1024
#: Deepest nesting of tables and arrays in a model file (a multibody's inertia is 7 levels deep).
MAX_NESTING = 32


def _syntax_message(source: str, text: str, err: tomllib.TOMLDecodeError) -> str:
    """``source, line N, column M: TOML syntax error: <what>`` with the line quoted and the fix."""
    msg = str(err)
    match = re.search(r"\s*\(at line (\d+), column (\d+)\)\s*$", msg)
    if not match:
        match_end = re.search(r"\s*\(at end of document\)\s*$", msg)
        what = msg[:match_end.start()] if match_end else msg
        return (f"{source}, at the end of the file: TOML syntax error: {what}; a table, array or "
                "string is not closed (see docs/model-files.md for the format)")
    number, column = int(match.group(1)), int(match.group(2))
    lines = text.splitlines()
    quoted = lines[number - 1].strip() if 0 < number <= len(lines) else ""
    hint = ""
    if msg.startswith(("Cannot overwrite a value", "Cannot declare")):
        hint = ": a key or table is defined twice; keep one of them"
    return (f"{source}, line {number}, column {column}: TOML syntax error: "
            f"{msg[:match.start()]}{hint} (in {quoted!r}); fix the TOML syntax of that line "
            "(see docs/model-files.md for the format)")


# --- where things are in the text ---------------------------------------------------------------
_BARE = r"[A-Za-z0-9_-]+"
_KEY_PART = rf"(?:{_BARE}|\"(?:[^\"\\]|\\.)*\"|'[^']*')"
_KEY_RE = re.compile(rf"\s*({_KEY_PART}(?:\s*\.\s*{_KEY_PART})*)\s*=")
_HEADER_RE = re.compile(rf"\s*(\[\[?)\s*({_KEY_PART}(?:\s*\.\s*{_KEY_PART})*)\s*\]\]?\s*(#.*)?$")


def _key_parts(key: str) -> tuple[str, ...]:
    parts = re.findall(_KEY_PART, key)
    return tuple(p[1:-1] if p[:1] in "\"'" else p for p in parts)


def _strip_strings(line: str) -> str:
    """The line with string contents blanked and its comment removed (bracket counting)."""
    out, quote, i = [], "", 0
    while i < len(line):
        ch = line[i]
        if quote:
            if ch == "\\" and quote == '"':
                out.append("  ")
                i += 2
                continue
            if ch == quote:
                quote = ""
            out.append(ch if not quote else " ")
        elif ch in "\"'":
            quote = ch
            out.append(ch)
        elif ch == "#":
            break
        else:
            out.append(ch)
        i += 1
    return "".join(out)


class _Locator:
    """Line numbers of the tables and keys of a TOML text, by key path: ``("components",
    "damper")`` is the line of ``[components.damper]`` (or of ``damper = {...}`` under
    ``[components]``), ``("components", "damper", "resistance")`` that of its key, ``("events",
    1)`` the second ``[[events]]``. A best-effort reading of the text (it is valid TOML here)."""

    def __init__(self, text: str):
        self.lines = text.splitlines()
        self.where: dict[tuple[str | int, ...], int] = {}
        table: tuple[str | int, ...] = ()
        arrays: dict[tuple[str | int, ...], int] = {}
        depth = 0                     # open [ / { of a value continued on the next lines
        multiline = ""                # inside a multi-line string
        for number, line in enumerate(self.lines, 1):
            if multiline:
                if line.count(multiline) % 2 == 1:
                    multiline = ""
                continue
            if depth > 0:
                bare = _strip_strings(line)
                depth += bare.count("[") + bare.count("{") - bare.count("]") - bare.count("}")
                continue
            header = _HEADER_RE.match(line)
            if header:
                path: tuple[str | int, ...] = _key_parts(header.group(2))
                if header.group(1) == "[[":
                    index = arrays.get(path, -1) + 1
                    arrays[path] = index
                    path = (*path, index)
                table = path
                self.where.setdefault(path, number)
                continue
            key = _KEY_RE.match(line)
            if not key:
                continue
            path = (*table, *_key_parts(key.group(1)))
            self.where.setdefault(path, number)
            rest = line[key.end():]
            for quote in ('"""', "'''"):
                if rest.count(quote) % 2 == 1:
                    multiline = quote
            bare = _strip_strings(rest)
            depth = bare.count("[") + bare.count("{") - bare.count("]") - bare.count("}")
            if bare.lstrip().startswith("{"):          # an inline table: its keys on this line
                for inner in re.finditer(rf"[{{,]\s*({_KEY_PART})\s*=", rest):
                    self.where.setdefault((*path, *_key_parts(inner.group(1))), number)
            depth = max(depth, 0)

    def line(self, *path: str | int) -> int | None:
        """The line of ``path``, or of its longest prefix that is known."""
        path = tuple(path)
        while path:
            if path in self.where:
                return self.where[path]
            path = path[:-1]
        return None

    def find(self, needle: str, after: int | None = None) -> int | None:
        """The first line (from line ``after`` on) containing ``needle``."""
        for number, line in enumerate(self.lines, 1):
            if (after is None or number >= after) and needle in line:
                return number
        return None


def locate(text: str, *path: str | int) -> int | None:
    """The line of the table or key at ``path`` in the TOML ``text`` (e.g. ``locate(text,
    "walker", "rules", 2, "if")``: the ``if`` key of the third ``[[walker.rules]]``), or of its
    longest known prefix; None if not even the first part is found. For libraries that check
    the tables the loader passes through (:data:`PASSED_THROUGH`) and name lines in errors."""
    return _Locator(text).line(*path)


def _suggest(name: str | os.PathLike[str], known: Iterable[str]) -> str:
    close = difflib.get_close_matches(str(name), [str(k) for k in known], n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _type_name(value: Any) -> str:
    return {str: "a string", bool: "a boolean", int: "an integer", float: "a number",
            list: "an array", dict: "a table"}.get(type(value), type(value).__name__)


@dataclass(frozen=True)
class ModelFile:
    """A model file: the core :class:`~porthamiltonian.modeling.model.Model` and what the file adds to it.

    Attributes
    ----------
    model : the model (components, bonds, parameters, events, outputs).
    source : where it was read from (a path, ``"<string>"``), named by every error.
    text : the file's TOML text ("" when built from a structure): lines for errors.
    description : ``[model] description``.
    simulation : the ``[simulation]`` defaults of the command line and check-energy.
    meta : further keys and tables under ``[model]``, kept on save.
    sections : the tables passed through for other libraries (:data:`PASSED_THROUGH`, e.g. the
        walker library's ``[walker]``), kept on save.
    frozen : the model's frozen description as the reader checked it (None for a model file
        built in Python): what later stages compile, without freezing the model again.
    linearize : the ``[linearize]`` operating point (``states``, ``inputs``, ``trim``,
        ``free_inputs``, ``t``) of ``porthamiltonian linearize``.
    """

    model: Model
    source: str = "<python>"
    text: str = field(default="", repr=False)
    description: str = ""
    simulation: Mapping[str, Any] = field(default_factory=dict)
    meta: Mapping[str, Any] = field(default_factory=dict)
    sections: Mapping[str, Any] = field(default_factory=dict)
    frozen: ModelDescription | None = field(default=None, repr=False, compare=False)
    linearize: Mapping[str, Any] = field(default_factory=dict)

    def line(self, path: Sequence[str | int]) -> int | None:
        """The line of the key path ``path`` (or of its longest known prefix) in the text."""
        return _Locator(self.text).line(*path) if self.text else None

    def error(self, err: ModelError) -> ModelFileError:
        """``err`` as a ModelFileError naming this file and the line of its path; an error that
        lists several problems gives one line per problem."""
        if isinstance(err, ModelFileError):
            return err
        reader = _Reader(self.source, self.text)
        for problem in err.problems or (err,):
            reader.add(str(problem), *problem.path, kind=problem)
        return reader.error()

    @contextmanager
    def located(self) -> Iterator[None]:
        """Within this block, a ModelError is re-raised as :meth:`error` (file and line)."""
        try:
            yield
        except ModelFileError:
            raise
        except ModelError as err:
            raise self.error(err) from None

    def compile(self, backend: str = "auto", use_cache: bool = True) -> CompiledModel:
        """:func:`~porthamiltonian.compiler.compile_model` of the model, its errors naming this
        file and line."""
        from ..compiler import compile_model

        with self.located():
            return compile_model(self.model, backend=backend, use_cache=use_cache)


class _Reader:
    """Collects the problems of one model file, each with its line: ``add`` one, ``error`` the
    ModelFileError of all (``source, line N: message`` for one; ``source: K problems:`` and one
    indented ``line N: message`` each for several)."""

    def __init__(self, source: str, text: str):
        self.source = source
        self.locate = _Locator(text) if text else None
        self.found: list[tuple[int | None, str, ModelError | None]] = []
        #: full names of the parameters and components that could not be read
        self.missing: set[str] = set()

    def line(self, path: tuple, needle: str | None = None) -> int | None:
        if self.locate is None:
            return None
        if needle is not None:
            start = self.locate.line(*path) if path else None
            return self.locate.find(needle, start) or start
        return self.locate.line(*path) if path else None

    def add(self, message: str, *path: str | int, needle: str | None = None,
            kind: ModelError | None = None) -> None:
        """Record a problem: ``message`` about the key path ``path`` (the line of ``needle``
        from there on, when given); ``kind``: the error it came from (its type is kept)."""
        self.found.append((self.line(path, needle), message, kind))

    def __bool__(self) -> bool:
        return bool(self.found)

    def _one(self, line: int | None, message: str, kind: ModelError | None) -> ModelFileError:
        return ModelFileError(f"{self.source}{f', line {line}' if line else ''}: {message}",
                              path=kind.path if kind is not None else ())

    def error(self) -> ModelFileError:
        singles = [self._one(*found) for found in self.found]
        if len(singles) == 1:
            return singles[0]
        listed = "\n".join(f"  {f'line {line}: ' if line else ''}{message}"
                            for line, message, _ in self.found)
        return ModelFileError(f"{self.source}: {len(singles)} problems:\n{listed}",
                              problems=singles)

    def fail(self, message: str, *path: str | int) -> ModelFileError:
        """The error of one problem that stops the reading (the file is not a model file)."""
        self.add(message, *path)
        return self.error()


def read_text(path: Path, *, limit: int, label: str, kind: str, language: str) -> str:
    """The UTF-8 text of a file that a user names (a model file, a previous result), at most
    ``limit`` bytes whatever its size claims (:func:`porthamiltonian.userfiles.read_text`: a
    folder, a device, a socket or a loop of links refused by type, a pipe read within the same
    bound); else a :class:`ModelFileError` starting with ``label`` (how the user named it) and
    saying what a ``kind`` is (``language`` text, at most ``limit`` bytes)."""
    return userfiles.read_text(path, limit=limit, label=label, kind=kind, language=language)


def read(name_or_path: str | Path) -> ModelFile:
    """Read a model file by name or path: the :class:`ModelFile` (model and file metadata)."""
    path = model_path(name_or_path)
    text = read_text(path, limit=MAX_FILE_SIZE, label=str(path), kind="model file",
                     language="TOML")
    return reads(text, source=str(path))


@collector.paused()
def reads(text: str, source: str = "<string>") -> ModelFile:
    """Read a model from TOML text; ``source`` names it in error messages."""
    if not isinstance(text, str):
        raise ModelFileError(f"{source}: a model file is TOML text, got {_type_name(text)}")
    text = text.removeprefix("\ufeff")          # a byte-order mark (Windows editors write one)
    if len(text) > MAX_FILE_SIZE:
        raise ModelFileError(f"{source}: the text is {len(text)} characters long; a model file "
                             f"is at most {MAX_FILE_SIZE}")
    import tomllib  # (here: a warm start reads the text, keyed by it, but parses none)

    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ModelFileError(_syntax_message(source, text, err)) from None
    except RecursionError:
        raise ModelFileError(f"{source}: arrays or tables are nested too deeply (at most "
                             f"{MAX_NESTING} levels)") from None
    return file_from_dict(data, source=source, text=text)


def load(name_or_path: str | Path) -> Model:
    """The model of the model file ``name_or_path`` (see :func:`read` for the file's metadata)."""
    return read(name_or_path).model


def loads(text: str, source: str = "<string>") -> Model:
    """The model of TOML ``text`` (see :func:`reads`)."""
    return reads(text, source).model


def model_from_dict(data: dict[str, Any], source: str = "<dict>", text: str = "") -> Model:
    """The model of a parsed TOML structure (see :func:`file_from_dict`)."""
    return file_from_dict(data, source, text).model


def file_from_dict(data: dict[str, Any], source: str = "<dict>", text: str = "") -> ModelFile:
    """Read the parsed TOML structure ``data``. Every problem of the file is reported at once in
    one :class:`~porthamiltonian.errors.ModelFileError` naming ``source`` (and the line of each,
    when the TOML ``text`` is given); a bond naming a component that could not be read is not
    reported again, and unconnected ports are reported only when every component and bond
    was read."""
    from .. import library, mechanics  # noqa: F401 - register their component types

    r = _Reader(source, text)
    if not isinstance(data, dict):
        raise r.fail("a model file must be a TOML table")
    deep = _too_deep(data)
    if deep is not None:
        raise r.fail(f"tables and arrays are nested more than {MAX_NESTING} levels deep (under "
                     f"{'.'.join(map(str, deep[:4]))}...); a model file needs a few levels", *deep)
    unknown = sorted(set(data) - _SECTIONS)
    for name in unknown:
        r.add(f"unknown section {name!r}{_suggest(name, _SECTIONS)}; a model file has only "
              f"{', '.join(sorted(_CORE_SECTIONS))} (see docs/model-files.md)", name)
    name, description, meta = _read_head(data, source, r)
    model = _read_model(name, data, r, ())
    frozen = model.freeze()                    # the whole file (its sub-models are inside)
    for problem in frozen.problems(missing=r.missing if r else None):
        r.add(str(problem), *problem.path, kind=problem)
    simulation = _read_simulation(data, r)
    linearize = _read_linearize(data, r)
    if r:
        raise r.error()
    return ModelFile(model, source, text, description, simulation, meta,
                     {k: data[k] for k in PASSED_THROUGH if k in data}, frozen, linearize)


def _read_head(data: dict[str, Any], source: str, r: _Reader) -> tuple[str, str, dict[str, Any]]:
    """``[model]``: (name, description, the further keys)."""
    head = data.get("model", {})
    if not isinstance(head, dict):
        r.add(f"[model] must be a table (name = \"...\", description = \"...\"), got "
              f"{_type_name(head)}", "model")
        head = {}
    for key in ("name", "description"):
        if key not in head:
            continue
        value = head[key]
        problem = (f"must be a string, got {_type_name(value)}" if not isinstance(value, str)
                   else _text_problem(value, name=key == "name"))
        if problem:
            r.add(f"[model] {key} {problem}", "model", key)
    name, description = head.get("name"), head.get("description")
    return (name if isinstance(name, str) else Path(source).stem,
            description if isinstance(description, str) else "",
            {k: v for k, v in head.items() if k not in ("name", "description")})


def _read_model(name: str, data: dict[str, Any], r: _Reader, at: tuple) -> Model:
    """A model's own tables (at key path ``at``: ``()`` for the file, ``("components", "sub",
    "model")`` for a sub-model): parameters, components, bonds, events, outputs (the checks of
    the whole, :meth:`~porthamiltonian.modeling.model.ModelDescription.problems`, follow in
    :func:`file_from_dict`)."""
    from ..modeling.model import Model

    model = Model(name)
    prefix = "".join(f"{part}." for part in at[1::3])     # the sub-model's flattened prefix
    r.missing |= {prefix + n for n in _read_parameters(model, data.get("parameters", {}), r, at)}
    r.missing |= {prefix + n for n in _read_inputs(model, data.get("inputs", {}), r, at)}
    failed = _read_components(model, data.get("components", {}), r, at)
    r.missing |= {prefix + n for n in failed}
    _read_bonds(model, data.get("bonds", []), failed, r, at)
    _read_events(model, data.get("events", []), r, at)
    _read_outputs(model, data.get("outputs", {}), r, at)
    return model


def _read_parameters(model: Model, params: Any, r: _Reader, at: tuple) -> set[str]:
    """``[parameters]``: ``name = number`` or ``name = { value, unit, doc }``; the names of those
    that could not be read."""
    if not isinstance(params, dict):
        r.add(f"[parameters] must be a table of name = value, got {_type_name(params)}",
              *at, "parameters")
        return set()
    failed = set()
    for name, spec in params.items():
        failed.add(name)
        where = (*at, "parameters", name)
        value, unit, doc = spec, "", ""
        if isinstance(spec, dict):
            extra = sorted(set(spec) - {"value", "unit", "doc"})
            if "value" not in spec or extra:
                what = (f"unknown key {extra[0]!r}{_suggest(extra[0], ('value', 'unit', 'doc'))}"
                        if extra else "no value")
                r.add(f"parameter {name!r}: {what}; write {name} = {{ value = ..., unit = "
                      f"\"...\", doc = \"...\" }} or {name} = number", *where)
                continue
            bad = next((k for k in ("unit", "doc") if k in spec and not isinstance(spec[k], str)),
                       None)
            if bad is not None:
                r.add(f"parameter {name!r}: {bad} must be a string, got "
                      f"{_type_name(spec[bad])}", *where)
                continue
            value, unit, doc = spec["value"], spec.get("unit", ""), spec.get("doc", "")
        if not is_real(value):
            r.add(f"parameter {name!r} must be a number (SI units), got {_type_name(value)} "
                  f"{value!r}; write {name} = 1.0 or {name} = {{ value = 1.0, unit = \"...\" }}",
                  *where)
            continue
        try:
            model.parameter(name, value, unit, doc)
            failed.discard(name)
        except ModelError as err:
            r.add(str(err), *where, kind=err)
    return failed


_INPUT_KEYS = ("unit", "doc", "bind")


def _read_inputs(model: Model, inputs: Any, r: _Reader, at: tuple) -> set[str]:
    """``[inputs]``: ``name = { unit, doc, bind }`` (each key optional); the names of those
    that could not be read."""
    if not isinstance(inputs, dict):
        r.add(f"[inputs] must be a table of name = {{ unit = \"...\", doc = \"...\" }}, got "
              f"{_type_name(inputs)}", *at, "inputs")
        return set()
    failed = set()
    for name, spec in inputs.items():
        where = (*at, "inputs", name)
        extra = sorted(set(spec) - set(_INPUT_KEYS)) if isinstance(spec, dict) else []
        bad = next((k for k in ("unit", "doc", "bind") if isinstance(spec, dict) and k in spec
                    and not isinstance(spec[k], str)), None)
        if not isinstance(spec, dict) or extra or bad:
            what = (f"unknown key {extra[0]!r}{_suggest(extra[0], _INPUT_KEYS)}" if extra else
                    f"{bad} must be a string" if bad else f"got {_type_name(spec)}")
            r.add(f"input {name!r}: {what}; write {name} = {{ unit = \"...\", doc = \"...\" }} "
                  "(bind = \"expression\" binds it in the model)", *where)
            failed.add(name)
            continue
        try:
            model.input(name, spec.get("unit", ""), spec.get("doc", ""), spec.get("bind"))
        except ModelError as err:
            r.add(str(err), *where, kind=err)
            failed.add(name)
    return failed


def _read_components(model: Model, comps: Any, r: _Reader, at: tuple) -> set[str]:
    """``[components.NAME]`` tables (``type = "model"`` for a sub-model); the names of those
    that could not be read."""
    if not isinstance(comps, dict):
        r.add("[components] must hold one table per component: [components.NAME] with "
              f"type = \"KIND\", got {_type_name(comps)}", *at, "components")
        return set()
    failed = set()
    for name, spec in comps.items():
        where = (*at, "components", name)
        before = len(r.found)
        component = _read_component(name, spec, r, where)
        if component is not None:
            try:
                model.add(name, component)
            except ModelError as err:
                r.add(str(err), *where, kind=err)
        if len(r.found) > before:
            failed.add(name)
    return failed


def _read_component(name: str, spec: Any, r: _Reader, where: tuple) -> Component | Model | None:
    """One component (or sub-model) table, or None after recording its problem."""
    from ..modeling.component import REGISTRY, component_class

    kinds = ", ".join(sorted(REGISTRY))
    if not isinstance(spec, dict):
        r.add(f"component {name!r} must be a table ([components.{name}] with type = "
              f"\"KIND\" and its arguments), got {_type_name(spec)}", *where)
        return None
    if "type" not in spec:
        r.add(f"component {name!r} needs a 'type' (e.g. type = \"C\"); types: {kinds}", *where)
        return None
    kind = spec["type"]
    if not isinstance(kind, str):
        r.add(f"component {name!r}: type must be a string naming a component kind (e.g. type = "
              f"\"C\"), got {_type_name(kind)} {kind!r}; known types: {kinds}", *where, "type")
        return None
    if kind == SUB_MODEL:
        return _read_sub_model(name, spec, r, where)
    if kind not in REGISTRY:
        r.add(f"component {name!r}: unknown component type {kind!r}{_suggest(kind, REGISTRY)}; "
              f"known types: {kinds} (see docs/model-files.md)", *where, "type")
        return None
    cls = component_class(kind)
    args = {k: v for k, v in spec.items() if k != "type"}
    unknown = sorted(set(args) - set(cls.arguments))
    if unknown:
        arg = unknown[0]
        r.add(f"component {name!r}: {kind} has no argument {arg!r}{_suggest(arg, cls.arguments)}"
              f"; its arguments are: {', '.join(cls.arguments) or 'none'}", *where, arg)
        return None
    try:
        component = cls(**args)
        component.ports()             # declared ports: checks the port tables
    except ModelError as err:
        for problem in err.problems or (err,):     # each with its own line
            r.add(f"component {name!r}: {problem}", *where, *problem.path, kind=problem)
        return None
    except Exception as err:  # noqa: BLE001 - wrong value types reaching a component's checks
        r.add(f"component {name!r} ({kind}): invalid arguments: {type(err).__name__}: {err}; "
              f"see the fields of {kind} in docs/model-files.md", *where)
        return None
    return component


def _read_sub_model(name: str, spec: dict[str, Any], r: _Reader, where: tuple) -> Model | None:
    """``type = "model"``: a sub-model, its tables under ``model`` (as a file's), and
    ``exposed = { port = "component.port" }``."""
    extra = sorted(set(spec) - {"type", "model", "exposed"})
    inner, exposed = spec.get("model", {}), spec.get("exposed", {})
    if extra or not isinstance(inner, dict) or not isinstance(exposed, dict):
        r.add(f"sub-model {name!r}: write type = \"model\", a [components.{name}.model] table "
              f"(its parameters, components, bonds...) and exposed = {{ port = \"component.port\" "
              f"}}{f'; unknown key {extra[0]!r}' if extra else ''}", *where, *extra[:1])
        return None
    unknown = sorted(set(inner) - _MODEL_TABLES)
    for key in unknown:
        r.add(f"sub-model {name!r}: unknown table {key!r}{_suggest(key, _MODEL_TABLES)}; a "
              f"sub-model has {', '.join(sorted(_MODEL_TABLES))}", *where, "model", key)
    head = inner.get("model", {})
    sub = _read_model(head.get("name", name) if isinstance(head, dict) else name, inner, r,
                      (*where, "model"))
    for port, target in exposed.items():
        if not isinstance(target, str):
            r.add(f"sub-model {name!r}: exposed port {port!r} must name a \"component.port\", "
                  f"got {_type_name(target)}", *where, "exposed", port)
            continue
        try:
            sub.expose(port, target)
        except ModelError as err:
            r.add(f"sub-model {name!r}: {err}", *where, "exposed", port, kind=err)
    return sub


_BOND = re.compile(r"\s*([\w.]+)\s*->\s*([\w.]+)\s*")


def _read_bonds(model: Model, bonds: Any, failed: set[str], r: _Reader, at: tuple) -> None:
    """``bonds = ["tail.port -> head.port", ...]``; bonds naming a component that could not be
    read are skipped (its problem is reported)."""
    if not isinstance(bonds, list):
        r.add(f"'bonds' must be an array of \"tail.port -> head.port\" strings, got "
              f"{_type_name(bonds)}", *at, "bonds")
        return
    for bond in bonds:
        match = _BOND.fullmatch(bond) if isinstance(bond, str) else None
        needle = bond if isinstance(bond, str) else None
        if not match:
            shown = repr(bond) if isinstance(bond, str) else f"{bond!r} ({_type_name(bond)})"
            r.add(f"bond {shown} must read \"component.port -> component.port\" (a junction's "
                  "name alone adds a port to it)", *at, "bonds", needle=needle)
            continue
        if {match.group(1).split(".")[0], match.group(2).split(".")[0]} & failed:
            continue
        try:
            model.connect(match.group(1), match.group(2))
        except ModelError as err:
            r.add(f"bond {bond!r}: {err}", *at, "bonds", needle=needle, kind=err)


_EVENT_KEYS = ("name", "guard", "direction", "terminal")


def _read_events(model: Model, events: Any, r: _Reader, at: tuple) -> None:
    """``[[events]]`` tables: name, guard, direction, terminal."""
    if not isinstance(events, list):
        r.add("events are an array of tables: [[events]] with name = \"...\", guard = "
              f"\"expression\", direction = -1, 0 or 1, terminal = true/false; got "
              f"{_type_name(events)}", *at, "events")
        return
    for index, ev in enumerate(events):
        where = (*at, "events", index)
        problem = _event_problem(index, ev)
        if problem is not None:
            message, key = problem
            r.add(message, *where, *key)
            continue
        try:
            model.event(ev["name"], str(ev["guard"]), int(ev.get("direction", 0)),
                        ev.get("terminal", False))
        except ModelError as err:
            r.add(str(err), *where, kind=err)


def _event_problem(index: int, ev: Any) -> tuple[str, tuple] | None:
    """What is wrong with the ``index``-th ``[[events]]`` table and the key it is about."""
    if not isinstance(ev, dict) or not {"name", "guard"} <= set(ev):
        return (f"event #{index + 1} needs a name and a guard: [[events]] name = \"...\", guard = "
                "\"expression\""), ()
    extra = sorted(set(ev) - set(_EVENT_KEYS))
    if extra:
        return (f"event #{index + 1}: unknown key {extra[0]!r}{_suggest(extra[0], _EVENT_KEYS)}; "
                f"keys: {', '.join(_EVENT_KEYS)}"), (extra[0],)
    if not isinstance(ev["name"], str):
        return f"event #{index + 1}: name must be a string, got {_type_name(ev['name'])}", ("name",)
    if not isinstance(ev["guard"], str) and not is_real(ev["guard"]):
        return (f"event {ev['name']!r}: guard must be an expression (a string), got "
                f"{_type_name(ev['guard'])}"), ("guard",)
    direction = ev.get("direction", 0)
    if not is_real(direction) or direction not in (-1, 0, 1):
        return (f"event {ev['name']!r}: direction must be -1 (falling), 0 (both) or 1 (rising), "
                f"got {direction!r}"), ("direction",)
    if not isinstance(ev.get("terminal", False), bool):
        return (f"event {ev['name']!r}: terminal must be true or false, got "
                f"{ev['terminal']!r}"), ("terminal",)
    return None


def _read_outputs(model: Model, outputs: Any, r: _Reader, at: tuple) -> None:
    """``[outputs]``: ``name = "expression"``."""
    if not isinstance(outputs, dict):
        r.add(f"[outputs] must be a table of name = \"expression\", got {_type_name(outputs)}",
              *at, "outputs")
        return
    for name, expr in outputs.items():
        if not isinstance(expr, str) and not is_real(expr):
            r.add(f"output {name!r} must be an expression (a string), got {_type_name(expr)}",
                  *at, "outputs", name)
            continue
        try:
            model.output(name, str(expr))
        except ModelError as err:
            r.add(str(err), *at, "outputs", name, kind=err)


_SIM_TYPES = {"t_end": "number", "rtol": "number", "atol": "number", "max_step": "number",
              "energy_tolerance": "number", "method": "string", "initial": "table",
              "inputs": "table"}


def _table_entries(data: dict[str, Any], section: str, keys: Mapping[str, str],
                   r: _Reader) -> Iterator[tuple[str, Any]]:
    """The (key, value) pairs of the table ``[section]`` of ``data`` whose key is one of
    ``keys``, in the file's order; a ``[section]`` that is not a table, and every other key (with
    the nearest known one), are reported to ``r``."""
    table = data.get(section, {})
    if not isinstance(table, dict):
        r.add(f"[{section}] must be a table, got {_type_name(table)}", section)
        return
    for key, value in table.items():
        if key not in keys:
            r.add(f"[{section}] has no key {key!r}{_suggest(key, keys)}; it takes "
                  f"{', '.join(sorted(keys))}", section, key)
            continue
        yield key, value


def _read_simulation(data: dict[str, Any], r: _Reader) -> dict[str, Any]:
    """``[simulation]``: the command line's defaults, each key checked for its type."""
    for key, value in _table_entries(data, "simulation", _SIM_TYPES, r):
        kind = _SIM_TYPES[key]
        ok = ((kind == "number" and is_real(value) and math.isfinite(value) and value > 0)
              or (kind == "string" and isinstance(value, str))
              or (kind == "table" and isinstance(value, dict)
                  and all(is_real(v) and math.isfinite(v) for v in value.values())))
        if not ok:
            want = {"number": "a positive number", "string": "a string (e.g. \"Radau\")",
                    "table": f"a table of {'state' if key == 'initial' else 'input'} = "
                             "finite number"}[kind]
            r.add(f"[simulation] {key} must be {want}, got {_type_name(value)} {value!r}",
                  "simulation", key)
        elif key in ("rtol", "method"):
            try:
                (check_rtol if key == "rtol" else check_method)(value)
            except OptionError as err:
                r.add(f"[simulation] {err}", "simulation", key)
    sim = data.get("simulation", {})
    return dict(sim) if isinstance(sim, dict) else {}


_LINEARIZE_KEYS = {"states": "a table of state = number", "inputs": "a table of input = number",
                   "trim": "true or false", "free_inputs": "an array of input names",
                   "t": "a number"}


def _read_linearize(data: dict[str, Any], r: _Reader) -> dict[str, Any]:
    """``[linearize]``: the operating point of ``porthamiltonian linearize`` (keys checked for
    their types; names are checked against the compiled model when it is linearized)."""
    for key, value in _table_entries(data, "linearize", _LINEARIZE_KEYS, r):
        ok = {"states": lambda v: isinstance(v, dict) and all(
                  is_real(x) and math.isfinite(x) for x in v.values()),
              "inputs": lambda v: isinstance(v, dict) and all(
                  is_real(x) and math.isfinite(x) for x in v.values()),
              "trim": lambda v: isinstance(v, bool),
              "free_inputs": lambda v: isinstance(v, list) and all(isinstance(x, str) for x in v),
              "t": lambda v: is_real(v) and math.isfinite(v)}[key](value)
        if not ok:
            r.add(f"[linearize] {key} must be {_LINEARIZE_KEYS[key]}, got {_type_name(value)} "
                  f"{value!r}", "linearize", key)
    table = data.get("linearize", {})
    return dict(table) if isinstance(table, dict) else {}


_MAX_NAME, _MAX_DESCRIPTION = 200, 2000


def _text_problem(text: str, name: bool) -> str | None:
    """What is wrong with a model's name (``name``) or description, or None: one line of
    printable text, not too long; a name also without quotes and backslashes (it names the model
    in messages, file names and generated code)."""
    limit = _MAX_NAME if name else _MAX_DESCRIPTION
    if len(text) > limit:
        return f"is {len(text)} characters long; at most {limit}"
    bad = next((ch for ch in text if not ch.isprintable()), None)
    if bad is not None:
        return (f"must be one line of printable text; it holds {bad!r} at character "
                f"{text.index(bad) + 1}")
    if name:
        bad = next((ch for ch in text if ch in "\"'\\`"), None)
        if bad is not None or not text.strip():
            return (f"must be a plain name (letters, digits, spaces, '_', '-', ...), without "
                    f"quotes or backslashes; got {text!r}")
    return None


def _too_deep(data: Any) -> tuple[str | int, ...] | None:
    """The key path of a value nested more than MAX_NESTING levels deep, or None (iterative:
    no recursion on hostile input)."""
    stack: list[tuple[tuple[str | int, ...], Any]] = [((), data)]
    while stack:
        path, value = stack.pop()
        if len(path) > MAX_NESTING:
            return path
        if isinstance(value, dict):
            stack += [((*path, k), v) for k, v in value.items()]
        elif isinstance(value, list):
            stack += [((*path, i), v) for i, v in enumerate(value)]
    return None


def model_to_dict(model: Model | ModelFile) -> dict[str, Any]:
    """The TOML structure of a model or model file (sub-models as ``type = "model"`` tables
    with their own tables under ``model`` and their ``exposed`` ports; a model file's
    description, ``[model]`` keys, ``[simulation]`` and passed-through tables too)."""
    from ..modeling.model import Model

    record = model if isinstance(model, ModelFile) else ModelFile(model)
    model = record.model
    data: dict[str, Any] = {"model": {"name": model.name}}
    if record.description:
        data["model"]["description"] = record.description
    data["model"].update(record.meta)
    data["parameters"] = {n: ({"value": p.value, "unit": p.unit, "doc": p.doc} if (p.unit or p.doc)
                              else p.value) for n, p in model.parameters.items()}
    comps: dict[str, Any] = {}
    for name, comp in model.components():
        if isinstance(comp, Model):
            comps[name] = {"type": SUB_MODEL, "model": model_to_dict(comp),
                           "exposed": {k: ".".join(v) for k, v in comp.exposed.items()}}
        else:
            comps[name] = {"type": comp.kind, **_plain(comp)}
    data["components"] = comps
    data["bonds"] = [f"{u}.{d['tail']} -> {v}.{d['head']}" for u, v, d in model.graph.edges(data=True)]
    if model.events:
        data["events"] = [{"name": e.name, "guard": e.guard, "direction": e.direction,
                           "terminal": e.terminal} for e in model.events]
    if model.outputs:
        data["outputs"] = dict(model.outputs)
    if model.inputs:
        data["inputs"] = {n: {k: v for k, v in (("unit", i.unit), ("doc", i.doc),
                                                ("bind", i.bind)) if v}
                          for n, i in model.inputs.items()}
    if record.simulation:
        data["simulation"] = dict(record.simulation)
    if record.linearize:
        data["linearize"] = dict(record.linearize)
    data.update(record.sections)
    return data


def _plain(comp: Component) -> dict[str, Any]:
    return {k: v for k, v in comp.args.items() if v is not None}


def dumps(model: Model | ModelFile) -> str:
    """TOML text of a model or model file."""
    import tomli_w  # (only when a file is written)

    return tomli_w.dumps(model_to_dict(model))


def save(model: Model | ModelFile, path: str | Path) -> None:
    """Write a model or model file as a TOML model file."""
    Path(path).write_text(dumps(model))

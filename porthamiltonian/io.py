"""Model files: a TOML description of components, parameters and bonds that round-trips.

Format (every section optional; the full reference, generated from the component registry, with a
worked example, is docs/model-files.md)::

    bonds = ["force.p -> j", "j -> mass.p"]      # tail -> head: power flows tail to head;
                                                 # a junction's name alone makes a new port
    [model]
    name = "mass_spring_damper"    # default: the file's name
    description = "..."            # other keys and tables under [model] (e.g. [model.walker],
                                   # read by walker_library) are kept as Model.meta and saved back
    [walker]                       # a walker's hybrid description: kept as Model.sections["walker"]
                                   # and saved back (read by walker_library; see docs/walkers.md)

    [parameters]
    m = { value = 1.0, unit = "kg", doc = "mass" }   # or simply  m = 1.0
    k = 4.0

    [components.mass]
    type = "I"                  # a registered component type (porthamiltonian.component.REGISTRY)
    inertance = "m"             # arguments: numbers or expressions in parameters, t, states

    [[events]]
    name = "touchdown"; guard = "-mass.q"; direction = 1; terminal = true

    [outputs]
    position = "spring.q"

    [simulation]                # defaults for the command line and check-energy
    t_end = 10.0; method = "Radau"; rtol = 1e-9; atol = 1e-12; energy_tolerance = 1e-6

Loading by name looks in ``$PORTHAMILTONIAN_MODELS`` (if set), then in the ``models/`` folder of the
source tree. Every problem of a file is a :class:`~porthamiltonian.errors.ModelFileError` naming the
file, the line (TOML's line and column for a syntax error; else the line of the offending key,
table, bond or event, found by :class:`_Locator` from the text) or the component, and the fix,
with a suggestion for a misspelt name; no bare KeyError/TypeError/ValueError escapes the loader
(tests/unit/test_model_file_fuzz.py). Arguments nested in a Multibody are parsed when the model
compiles; their errors name the file, component, body or joint and field.
"""
from __future__ import annotations

import difflib
import math
import os
import re
import tomllib
from pathlib import Path
from typing import Any

import sympy as sp
import tomli_w

from .component import REGISTRY, Component, component_class
from .errors import ModelError, ModelFileError, OptionError
from .expressions import parse
from .mechanics.bodies import expression_fields
from .model import Model
from .options import check_rtol

#: top-level tables that the loader keeps as they are, for the libraries that read them
#: (``Model.sections``, written back on save): the walker library's ``[walker]`` table
PASSED_THROUGH = ("walker",)
_CORE_SECTIONS = {"bonds", "model", "parameters", "components", "events", "outputs", "simulation"}
_SECTIONS = _CORE_SECTIONS | set(PASSED_THROUGH)
_SIM_KEYS = {"t_end", "method", "rtol", "atol", "max_step", "energy_tolerance", "initial"}


def models_dirs() -> list[Path]:
    """Folders searched for models by name."""
    dirs = [Path(d) for d in os.environ.get("PORTHAMILTONIAN_MODELS", "").split(os.pathsep) if d]
    dirs.append(Path(__file__).resolve().parent.parent / "models")
    return dirs


def available_models() -> list[str]:
    """Names of the model files found in :func:`models_dirs`."""
    names: dict[str, None] = {}
    for d in models_dirs():
        if d.is_dir():
            names.update((p.stem, None) for p in sorted(d.glob("*.toml")))
    return list(names)


def model_path(name_or_path: str | Path) -> Path:
    """Resolve a model name (file name without ``.toml``) or a path to an existing file."""
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.exists():
        if not path.is_file():
            raise ModelFileError(f"model file {path} does not exist")
        return path
    for d in models_dirs():
        candidate = d / f"{name_or_path}.toml"
        if candidate.is_file():
            return candidate
    known = available_models()
    raise ModelFileError(f"no model called {name_or_path!r}{_suggest(name_or_path, known)}; "
                         f"available: {', '.join(known) or 'none'} (or give a path to a .toml "
                         "file)")


#: Largest model file read (bytes); the largest in models/ is ~20 kB.
MAX_FILE_SIZE = 4 * 1024 * 1024
#: Deepest nesting of tables and arrays in a model file (a multibody's inertia is 7 levels deep).
MAX_NESTING = 32


def load(name_or_path: str | Path) -> Model:
    """Load a model by name or path."""
    path = model_path(name_or_path)
    try:
        size = path.stat().st_size
        if size > MAX_FILE_SIZE:
            raise ModelFileError(f"{path}: the file is {size} bytes long; a model file is at most "
                                 f"{MAX_FILE_SIZE} bytes (is it a model file?)")
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as err:
        raise ModelFileError(f"{path}: not a UTF-8 text file (byte {err.start}: {err.reason}); "
                             "a model file is TOML text") from None
    except OSError as err:
        raise ModelFileError(f"{path}: cannot read the model file ({err.strerror})") from None
    return loads(text, source=str(path))


def loads(text: str, source: str = "<string>") -> Model:
    """Load a model from TOML text; ``source`` names it in error messages."""
    if not isinstance(text, str):
        raise ModelFileError(f"{source}: a model file is TOML text, got {_type_name(text)}")
    if len(text) > MAX_FILE_SIZE:
        raise ModelFileError(f"{source}: the text is {len(text)} characters long; a model file "
                             f"is at most {MAX_FILE_SIZE}")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ModelFileError(_syntax_message(source, text, err)) from None
    except RecursionError:
        raise ModelFileError(f"{source}: arrays or tables are nested too deeply (at most "
                             f"{MAX_NESTING} levels)") from None
    return model_from_dict(data, source=source, text=text)


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
        self.where: dict[tuple, int] = {}
        table: tuple = ()
        arrays: dict[tuple, int] = {}
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
                path = _key_parts(header.group(2))
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

    def line(self, *path) -> int | None:
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


def _suggest(name: str, known) -> str:
    close = difflib.get_close_matches(str(name), [str(k) for k in known], n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _type_name(value: Any) -> str:
    return {str: "a string", bool: "a boolean", int: "an integer", float: "a number",
            list: "an array", dict: "a table"}.get(type(value), type(value).__name__)


class _Fail:
    """Makes the ModelFileError of a model file: ``source, line N: message``."""

    def __init__(self, source: str, text: str):
        self.source = source
        self.locate = _Locator(text) if text else None

    def __call__(self, msg: str, *path, needle: str | None = None,
                 line: int | None = None) -> ModelFileError:
        if line is None and self.locate is not None:
            if needle is not None:
                start = self.locate.line(*path) if path else None
                line = self.locate.find(needle, start) or start
            elif path:
                line = self.locate.line(*path)
        return ModelFileError(f"{self.source}{f', line {line}' if line else ''}: {msg}")


def model_from_dict(data: dict[str, Any], source: str = "<dict>", text: str = "") -> Model:
    """Build a :class:`Model` from the parsed TOML structure, with errors naming ``source`` (and
    the line, when the TOML ``text`` is given)."""
    fail = _Fail(source, text)
    if not isinstance(data, dict):
        raise fail("a model file must be a TOML table")
    deep = _too_deep(data)
    if deep is not None:
        raise fail(f"tables and arrays are nested more than {MAX_NESTING} levels deep (under "
                   f"{'.'.join(map(str, deep[:4]))}...); a model file needs a few levels", *deep)
    unknown = sorted(set(data) - _SECTIONS)
    if unknown:
        name = unknown[0]
        raise fail(f"unknown section {name!r}{_suggest(name, _SECTIONS)}; a model file has only "
                   f"{', '.join(sorted(_CORE_SECTIONS))} (see docs/model-files.md)", name)
    head = data.get("model", {})
    if not isinstance(head, dict):
        raise fail(f"[model] must be a table (name = \"...\", description = \"...\"), got "
                   f"{_type_name(head)}", "model")
    for key in ("name", "description"):
        if key in head and not isinstance(head[key], str):
            raise fail(f"[model] {key} must be a string, got {_type_name(head[key])}", "model", key)
        if key in head:
            problem = _text_problem(head[key], name=key == "name")
            if problem:
                raise fail(f"[model] {key} {problem}", "model", key)
    name = head.get("name", Path(source).stem)
    model = Model(str(name), str(head.get("description", "")))
    model.meta = {k: v for k, v in head.items() if k not in ("name", "description")}
    model.sections = {k: data[k] for k in PASSED_THROUGH if k in data}
    try:
        _fill(model, data, fail)
    except ModelFileError:
        raise
    except ModelError as err:   # pragma: no cover - _fill wraps what it calls
        raise fail(str(err)) from None
    _check_expressions(model, fail)
    model.source = source
    return model


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


def _too_deep(data: Any) -> tuple | None:
    """The key path of a value nested more than MAX_NESTING levels deep, or None (iterative:
    no recursion on hostile input)."""
    stack = [((), data)]
    while stack:
        path, value = stack.pop()
        if len(path) > MAX_NESTING:
            return path
        if isinstance(value, dict):
            stack += [((*path, k), v) for k, v in value.items()]
        elif isinstance(value, list):
            stack += [((*path, i), v) for i, v in enumerate(value)]
    return None


def _check_expressions(model: Model, fail: _Fail) -> None:
    """Parse every expression now (component arguments and the fields nested in them, e.g. a
    Multibody's masses, event guards, outputs), so that a misspelt name or a syntax error is
    reported with its file and line (whether a dotted name such as ``spring.q`` exists is checked
    when the model compiles)."""
    params = {name: sp.Symbol(name, real=True) for name in model.parameters}
    comps = {name for name, _ in model.components()}

    def dotted(ref: str) -> sp.Symbol | None:
        return sp.Symbol(ref, real=True) if ref.split(".")[0] in comps else None

    def check(text, names, where, *path) -> None:
        try:
            parse(text, names, where, dotted)
        except ModelError as err:
            raise fail(str(err), *path) from None
        except Exception as err:  # noqa: BLE001 - sympy failing its own way: still a file error
            raise fail(f"{where}: cannot parse {text!r} ({type(err).__name__}: {err})",
                       *path) from None

    for name, comp in model.components():
        if isinstance(comp, Model):
            continue
        if comp.kind == "Multibody":
            fields = ((path, value, what, ()) for path, value, what in expression_fields(
                comp.args.get("bodies"), comp.args.get("joints"), comp.args.get("gravity")))
        else:
            fields = comp.expression_fields()
        for path, value, what, local in fields:
            names = {**params, **{n: sp.Symbol(n, real=True) for n in local}}
            check(value, names, f"component {name!r} {what}", "components", name, *path)
    for index, event in enumerate(model.events):
        check(event.guard, params, f"event {event.name!r} guard", "events", index, "guard")
    for name, expr in model.outputs.items():
        check(expr, params, f"output {name!r}", "outputs", name)


_EVENT_KEYS = ("name", "guard", "direction", "terminal")
_SIM_TYPES = {"t_end": "number", "rtol": "number", "atol": "number", "max_step": "number",
              "energy_tolerance": "number", "method": "string", "initial": "table"}


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _fill(model: Model, data: dict[str, Any], fail: _Fail) -> None:
    params = data.get("parameters", {})
    if not isinstance(params, dict):
        raise fail(f"[parameters] must be a table of name = value, got {_type_name(params)}",
                   "parameters")
    for name, spec in params.items():
        where = ("parameters", name)
        if isinstance(spec, dict):
            extra = sorted(set(spec) - {"value", "unit", "doc"})
            if "value" not in spec or extra:
                what = (f"unknown key {extra[0]!r}{_suggest(extra[0], ('value', 'unit', 'doc'))}"
                        if extra else "no value")
                raise fail(f"parameter {name!r}: {what}; write {name} = {{ value = ..., unit = "
                           f"\"...\", doc = \"...\" }} or {name} = number", *where)
            for key in ("unit", "doc"):
                if key in spec and not isinstance(spec[key], str):
                    raise fail(f"parameter {name!r}: {key} must be a string, got "
                               f"{_type_name(spec[key])}", *where)
            value, unit, doc = spec["value"], spec.get("unit", ""), spec.get("doc", "")
        else:
            value, unit, doc = spec, "", ""
        if not _is_number(value):
            raise fail(f"parameter {name!r} must be a number (SI units), got {_type_name(value)} "
                       f"{value!r}; write {name} = 1.0 or {name} = {{ value = 1.0, unit = \"...\" }}",
                       *where)
        try:
            model.parameter(name, value, unit, doc)
        except ModelError as err:
            raise fail(str(err), *where) from None
    comps = data.get("components", {})
    if not isinstance(comps, dict):
        raise fail("[components] must hold one table per component: [components.NAME] with "
                   f"type = \"KIND\", got {_type_name(comps)}", "components")
    for name, spec in comps.items():
        where = ("components", name)
        if not isinstance(spec, dict):
            raise fail(f"component {name!r} must be a table ([components.{name}] with type = "
                       f"\"KIND\" and its arguments), got {_type_name(spec)}", *where)
        if "type" not in spec:
            raise fail(f"component {name!r} needs a 'type' (e.g. type = \"C\"); types: "
                       f"{', '.join(sorted(REGISTRY))}", *where)
        kind = spec["type"]
        if not isinstance(kind, str):
            raise fail(f"component {name!r}: type must be a string naming a component kind "
                       f"(e.g. type = \"C\"), got {_type_name(kind)} {kind!r}; known types: "
                       f"{', '.join(sorted(REGISTRY))}", *where, "type")
        if kind not in REGISTRY:
            raise fail(f"component {name!r}: unknown component type {kind!r}"
                       f"{_suggest(kind, REGISTRY)}; known types: {', '.join(sorted(REGISTRY))} "
                       "(see docs/model-files.md)", *where)
        cls = component_class(kind)
        args = {k: v for k, v in spec.items() if k != "type"}
        unknown = sorted(set(args) - set(cls.arguments))
        if unknown:
            arg = unknown[0]
            raise fail(f"component {name!r}: {kind} has no argument {arg!r}"
                       f"{_suggest(arg, cls.arguments)}; its arguments are: "
                       f"{', '.join(cls.arguments) or 'none'}", *where, arg)
        try:
            component = cls(**args)
            component.ports()             # declared ports: checks domains and port tables
            model.add(name, component)
        except ModelError as err:
            raise fail(f"component {name!r}: {err}", *where, *_argument_path(err, args)) from None
        except Exception as err:  # noqa: BLE001 - wrong value types reaching a component's checks
            raise fail(f"component {name!r} ({kind}): invalid arguments: {type(err).__name__}: "
                       f"{err}; see the fields of {kind} in docs/model-files.md", *where,
                       *_argument_path(err, args)) from None
    bonds = data.get("bonds", [])
    if not isinstance(bonds, list):
        raise fail(f"'bonds' must be an array of \"tail.port -> head.port\" strings, got "
                   f"{_type_name(bonds)}", "bonds")
    for bond in bonds:
        match = re.fullmatch(r"\s*([\w.]+)\s*->\s*([\w.]+)\s*", bond) if isinstance(bond, str) else None
        needle = bond if isinstance(bond, str) else None
        if not match:
            shown = repr(bond) if isinstance(bond, str) else f"{bond!r} ({_type_name(bond)})"
            raise fail(f"bond {shown} must read \"component.port -> component.port\" (a "
                       "junction's name alone adds a port to it)", "bonds", needle=needle)
        try:
            model.connect(match.group(1), match.group(2))
        except ModelError as err:
            raise fail(f"bond {bond!r}: {err}", "bonds", needle=needle) from None
    events = data.get("events", [])
    if not isinstance(events, list):
        raise fail("events are an array of tables: [[events]] with name = \"...\", guard = "
                   f"\"expression\", direction = -1, 0 or 1, terminal = true/false; got "
                   f"{_type_name(events)}", "events")
    for index, ev in enumerate(events):
        where = ("events", index)
        if not isinstance(ev, dict) or not {"name", "guard"} <= set(ev):
            raise fail(f"event #{index + 1} needs a name and a guard: [[events]] name = \"...\", "
                       "guard = \"expression\"", *where)
        extra = sorted(set(ev) - set(_EVENT_KEYS))
        if extra:
            raise fail(f"event #{index + 1}: unknown key {extra[0]!r}"
                       f"{_suggest(extra[0], _EVENT_KEYS)}; keys: {', '.join(_EVENT_KEYS)}",
                       *where, extra[0])
        if not isinstance(ev["name"], str):
            raise fail(f"event #{index + 1}: name must be a string, got {_type_name(ev['name'])}",
                       *where, "name")
        if not isinstance(ev["guard"], str) and not _is_number(ev["guard"]):
            raise fail(f"event {ev['name']!r}: guard must be an expression (a string), got "
                       f"{_type_name(ev['guard'])}", *where, "guard")
        direction = ev.get("direction", 0)
        if not _is_number(direction) or direction not in (-1, 0, 1):
            raise fail(f"event {ev['name']!r}: direction must be -1 (falling), 0 (both) or 1 "
                       f"(rising), got {direction!r}", *where, "direction")
        terminal = ev.get("terminal", False)
        if not isinstance(terminal, bool):
            raise fail(f"event {ev['name']!r}: terminal must be true or false, got "
                       f"{terminal!r}", *where, "terminal")
        try:
            model.event(ev["name"], str(ev["guard"]), int(direction), terminal)
        except ModelError as err:
            raise fail(str(err), *where) from None
    outputs = data.get("outputs", {})
    if not isinstance(outputs, dict):
        raise fail(f"[outputs] must be a table of name = \"expression\", got {_type_name(outputs)}",
                   "outputs")
    for name, expr in outputs.items():
        if not isinstance(expr, str) and not _is_number(expr):
            raise fail(f"output {name!r} must be an expression (a string), got "
                       f"{_type_name(expr)}", "outputs", name)
        try:
            model.output(name, str(expr))
        except ModelError as err:
            raise fail(str(err), "outputs", name) from None
    sim = data.get("simulation", {})
    if not isinstance(sim, dict):
        raise fail(f"[simulation] must be a table, got {_type_name(sim)}", "simulation")
    for key, value in sim.items():
        if key not in _SIM_TYPES:
            raise fail(f"[simulation] has no key {key!r}{_suggest(key, _SIM_KEYS)}; it takes "
                       f"{', '.join(sorted(_SIM_KEYS))}", "simulation", key)
        kind = _SIM_TYPES[key]
        ok = ((kind == "number" and _is_number(value) and math.isfinite(value) and value > 0)
              or (kind == "string" and isinstance(value, str))
              or (kind == "table" and isinstance(value, dict)
                  and all(_is_number(v) for v in value.values())))
        if not ok:
            want = {"number": "a positive number", "string": "a string (e.g. \"Radau\")",
                    "table": "a table of state = number"}[kind]
            raise fail(f"[simulation] {key} must be {want}, got {_type_name(value)} {value!r}",
                       "simulation", key)
        if key == "rtol":
            try:
                check_rtol(value)
            except OptionError as err:
                raise fail(f"[simulation] {err}", "simulation", key) from None
    model.simulation = dict(sim)


def _argument_path(err: Exception, args: dict[str, Any]) -> tuple:
    """The key path (within a component's table) an error message is about, to point at its
    line: the names it quotes, followed down the argument tree (``body 'b' point 'tip'`` ->
    bodies.b.points.tip), then a key it names plainly before its first ``;`` (``Multibody
    gravity: ...``, ``unknown field(s) color``), or else an argument whose text value it quotes
    (``unknown domain 'fluid'`` -> domain)."""
    text = str(err)
    path: list = []
    node: Any = args
    for token in re.findall(r"'([^']*)'", text):
        if not isinstance(node, dict):
            break
        if token in node:
            path.append(token)
            node = node[token]
            continue
        for key, sub in node.items():
            if isinstance(sub, dict) and token in sub:
                path += [key, token]
                node = sub[token]
                break
    head = text.split(";")[0]             # what is wrong (the rest lists what is allowed)
    if isinstance(node, dict):
        for key in sorted(node, key=lambda k: -len(str(k))):
            if isinstance(key, str) and re.search(rf"(?<![\w.']){re.escape(key)}(?![\w'])", head):
                path.append(key)
                break
    if not path:
        for arg, value in args.items():
            if isinstance(value, (str, int, float)) and not isinstance(value, bool) and repr(value) in text:
                return (arg,)
    return tuple(path)


def model_to_dict(model: Model) -> dict[str, Any]:
    """The TOML structure of ``model`` (flat models only: sub-models are written by their code)."""
    data: dict[str, Any] = {"model": {"name": model.name}}
    if model.doc:
        data["model"]["description"] = model.doc
    data["model"].update(model.meta)
    data["parameters"] = {n: ({"value": p.value, "unit": p.unit, "doc": p.doc} if (p.unit or p.doc)
                              else p.value) for n, p in model.parameters.items()}
    comps: dict[str, Any] = {}
    for name, comp in model.components():
        if isinstance(comp, Model):
            comps[name] = {"type": "model", "model": model_to_dict(comp),
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
    if model.simulation:
        data["simulation"] = dict(model.simulation)
    data.update(model.sections)
    return data


def _plain(comp: Component) -> dict[str, Any]:
    return {k: v for k, v in comp.args.items() if v is not None}


def dumps(model: Model) -> str:
    """TOML text of ``model``."""
    return tomli_w.dumps(model_to_dict(model))


def save(model: Model, path: str | Path) -> None:
    """Write ``model`` as a TOML model file."""
    Path(path).write_text(dumps(model))

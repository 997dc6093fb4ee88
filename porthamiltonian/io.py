"""Model files: a TOML description of components, parameters and bonds that round-trips.

Format (every section but ``[model]`` optional)::

    bonds = ["force.p -> j", "j -> mass.p"]      # tail -> head: power flows tail to head;
                                                 # a junction's name alone makes a new port
    [model]
    name = "mass_spring_damper"
    description = "..."            # other keys and tables under [model] (e.g. [model.walker],
                                   # read by walker_library) are kept as Model.meta and saved back

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
source tree. Errors are :class:`~porthamiltonian.errors.ModelFileError` naming the file, the line
where it can be found, and the fix.
"""
from __future__ import annotations

import os
import re
import tomllib
from pathlib import Path
from typing import Any

import tomli_w

import sympy as sp

from .component import Component, component_class
from .errors import ModelError, ModelFileError
from .expressions import parse
from .model import Model

_SECTIONS = {"bonds", "model", "parameters", "components", "events", "outputs", "simulation"}
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
    raise ModelFileError(f"no model called {name_or_path!r}; available: "
                         f"{', '.join(available_models()) or 'none'} (or give a path to a .toml file)")


def load(name_or_path: str | Path) -> Model:
    """Load a model by name or path."""
    path = model_path(name_or_path)
    text = path.read_text()
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ModelFileError(f"{path}: TOML syntax error: {err}") from None
    return model_from_dict(data, source=str(path), text=text)


def loads(text: str, source: str = "<string>") -> Model:
    """Load a model from TOML text."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ModelFileError(f"{source}: TOML syntax error: {err}") from None
    return model_from_dict(data, source=source, text=text)


def _line(text: str, needle: str) -> str:
    for number, line in enumerate(text.splitlines(), 1):
        if needle in line:
            return f", line {number}"
    return ""


def model_from_dict(data: dict[str, Any], source: str = "<dict>", text: str = "") -> Model:
    """Build a :class:`Model` from the parsed TOML structure, with errors naming ``source``."""

    def fail(msg: str, needle: str = "") -> ModelFileError:
        return ModelFileError(f"{source}{_line(text, needle) if needle else ''}: {msg}")

    if not isinstance(data, dict):
        raise fail("a model file must be a TOML table")
    unknown = set(data) - _SECTIONS
    if unknown:
        raise fail(f"unknown section(s) {', '.join(sorted(unknown))}; allowed: "
                   f"{', '.join(sorted(_SECTIONS))}", sorted(unknown)[0])
    head = data.get("model", {})
    if not isinstance(head, dict):
        raise fail("[model] must be a table")
    model = Model(str(head.get("name", Path(source).stem)), str(head.get("description", "")))
    model.meta = {k: v for k, v in head.items() if k not in ("name", "description")}
    try:
        _fill(model, data, fail)
    except ModelFileError:
        raise
    except ModelError as err:
        raise fail(str(err)) from None
    _check_expressions(model, fail)
    model.source = source
    return model


def _check_expressions(model: Model, fail) -> None:
    """Parse every expression argument now, so that a misspelt name is reported with its file
    and line (nested arguments, e.g. of a Multibody, are checked when the model compiles)."""
    params = {name: sp.Symbol(name, real=True) for name in model.parameters}
    comps = {name for name, _ in model.components()}

    def dotted(ref: str) -> sp.Symbol | None:
        return sp.Symbol(ref, real=True) if ref.split(".")[0] in comps else None

    for name, comp in model.components():
        if isinstance(comp, Model):
            continue
        for arg_name, arg in comp.arguments.items():
            value = comp.args.get(arg_name)
            if not arg.symbolic or value is None:
                continue
            local = {n: sp.Symbol(n, real=True) for n in arg.local}
            try:
                parse(value, {**params, **local}, f"component {name!r} argument {arg_name!r}", dotted)
            except ModelError as err:
                raise fail(str(err), f"{arg_name} =") from None


def _fill(model: Model, data: dict[str, Any], fail) -> None:
    params = data.get("parameters", {})
    if not isinstance(params, dict):
        raise fail("[parameters] must be a table of name = value")
    for name, spec in params.items():
        if isinstance(spec, dict):
            extra = set(spec) - {"value", "unit", "doc"}
            if "value" not in spec or extra:
                raise fail(f"parameter {name!r}: write {name} = {{ value = ..., unit = \"...\", "
                           f"doc = \"...\" }} or {name} = number", f"{name} =")
            value, unit, doc = spec["value"], str(spec.get("unit", "")), str(spec.get("doc", ""))
        else:
            value, unit, doc = spec, "", ""
        try:
            model.parameter(name, value, unit, doc)
        except ModelError as err:
            raise fail(str(err), f"{name} =") from None
    comps = data.get("components", {})
    if not isinstance(comps, dict):
        raise fail("[components] must hold one table per component: [components.NAME]")
    for name, spec in comps.items():
        if not isinstance(spec, dict) or "type" not in spec:
            raise fail(f"component {name!r} needs a 'type' (e.g. type = \"C\")", f"[components.{name}]")
        args = {k: v for k, v in spec.items() if k != "type"}
        try:
            cls = component_class(str(spec["type"]))
            model.add(name, cls(**args))
        except ModelError as err:
            raise fail(f"component {name!r}: {err}", f"[components.{name}]") from None
    bonds = data.get("bonds", [])
    if not isinstance(bonds, list):
        raise fail("'bonds' must be a list of \"tail -> head\" strings")
    for bond in bonds:
        match = re.fullmatch(r"\s*([\w.]+)\s*->\s*([\w.]+)\s*", bond) if isinstance(bond, str) else None
        if not match:
            raise fail(f"bond {bond!r} must read \"component.port -> component.port\"", str(bond))
        try:
            model.connect(match.group(1), match.group(2))
        except ModelError as err:
            raise fail(f"bond {bond!r}: {err}", bond) from None
    for ev in data.get("events", []):
        if not isinstance(ev, dict) or not {"name", "guard"} <= set(ev):
            raise fail("each [[events]] needs a name and a guard", "[[events]]")
        model.event(str(ev["name"]), str(ev["guard"]), int(ev.get("direction", 0)),
                    bool(ev.get("terminal", False)))
    for name, expr in data.get("outputs", {}).items():
        model.output(name, str(expr))
    sim = data.get("simulation", {})
    if not isinstance(sim, dict) or set(sim) - _SIM_KEYS:
        raise fail(f"[simulation] takes only {', '.join(sorted(_SIM_KEYS))}", "[simulation]")
    model.simulation = dict(sim)


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
    return data


def _plain(comp: Component) -> dict[str, Any]:
    return {k: v for k, v in comp.args.items() if v is not None}


def dumps(model: Model) -> str:
    """TOML text of ``model``."""
    return tomli_w.dumps(model_to_dict(model))


def save(model: Model, path: str | Path) -> None:
    """Write ``model`` as a TOML model file."""
    Path(path).write_text(dumps(model))

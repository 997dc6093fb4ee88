"""Fuzzing the model-file loader (porthamiltonian.interfaces.io): random text, random TOML documents shaped
like model files, and mutations of the real files in models/ (a line deleted, duplicated or
swapped, a value's type changed, a component kind renamed, a bond broken, a table dropped, a
name in an expression misspelt, the file cut short).

Property: loading either gives a Model or raises ModelFileError (a ModelError naming the file);
compiling what loaded (python back end, the models that compile in well under a second) either
works or raises a ModelError. Never KeyError, TypeError, AttributeError, a bare
ValueError or anything else from inside the loader.
"""
from __future__ import annotations

import copy
import re
import string
import tomllib
from pathlib import Path

import tomli_w
from fuzzing import fuzz_settings
from hypothesis import HealthCheck, given
from hypothesis import strategies as st

from porthamiltonian import compile_model, io
from porthamiltonian.errors import ModelError, ModelFileError
from porthamiltonian.modeling.component import REGISTRY

MODELS_DIR = Path(io.__file__).resolve().parents[2] / "models"
FILES = {p.stem: p.read_text() for p in sorted(MODELS_DIR.glob("*.toml"))}
# compiled after loading (python back end, each well under a second): the models without a
# multibody and the small multibody ones; not the walkers (seconds each)
CHEAP = sorted(name for name, text in FILES.items()
               if "Multibody" not in text and "FreeBody" not in text) + [
    "bouncing_ball", "bouncing_ball_kelvin_voigt", "double_pendulum", "pendulum", "slider_arm"]
SETTINGS = fuzz_settings(200, deadline=None,
                         suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def check_load(text: str, source: str = "fuzz.toml", compile_it: bool = False) -> None:
    """The property: a Model or a ModelFileError naming ``source``; then, optionally, compile."""
    try:
        model = io.loads(text, source=source)
    except ModelFileError as err:
        assert str(err).startswith(source), str(err)
        return
    if compile_it:
        try:
            compile_model(model, backend="python", use_cache=False)
        except ModelError:
            pass


# --- random text -------------------------------------------------------------------------------
TOMLISH = st.text(alphabet=string.ascii_letters + string.digits + ' \n\t=[]{}.,"\'#-_>:+*/()',
                  max_size=300)


@SETTINGS
@given(st.one_of(st.text(max_size=200), TOMLISH))
def test_random_text_loads_or_raises_model_file_error(text):
    check_load(text)


# --- random TOML documents shaped like model files ----------------------------------------------
NAMES = st.sampled_from(["m", "k", "c", "x0", "t", "mass", "spring", "j", "p", "q", "bad name",
                         "", "type", "g", "slope"])
EXPRS = st.sampled_from(["k", "m*g", "2*k + c", "sin(t)", "k +", "unknown", "mass.p", "j.q",
                         "spring.q", "1e400", "(", "x0", "q**2/2", "", "t", "nan"])
SCALARS = st.one_of(st.integers(-3, 3), st.floats(allow_nan=False, allow_infinity=False),
                    st.booleans(), EXPRS, st.text(max_size=8))
VALUES = st.recursive(SCALARS, lambda inner: st.one_of(
    st.lists(inner, max_size=3), st.dictionaries(NAMES.filter(bool), inner, max_size=3)),
    max_leaves=6)


@st.composite
def components(draw):
    kind = draw(st.one_of(st.sampled_from(sorted(REGISTRY)), st.text(max_size=5), VALUES))
    spec = {"type": kind}
    cls = REGISTRY.get(kind) if isinstance(kind, str) else None
    arg_names = list(cls.arguments) if cls else []
    for key in draw(st.lists(st.one_of(st.sampled_from(arg_names or ["x"]), NAMES.filter(bool)),
                             max_size=4, unique=True)):
        spec[key] = draw(VALUES)
    if draw(st.booleans()):
        del spec["type"]
    return spec


BONDS = st.one_of(
    st.builds(lambda a, b: f"{a} -> {b}",
              st.sampled_from(["mass.p", "spring.p", "j", "damper.p", "force.p", "x.q", "j.p"]),
              st.sampled_from(["mass.p", "spring.p", "j", "damper.p", "force.p", "x.q", "j.p"])),
    st.text(max_size=12), VALUES)


@st.composite
def documents(draw):
    doc: dict = {}
    if draw(st.booleans()):
        doc["model"] = draw(st.one_of(st.fixed_dictionaries(
            {}, optional={"name": VALUES, "description": VALUES, "walker": VALUES}), VALUES))
    if draw(st.booleans()):
        doc["parameters"] = draw(st.dictionaries(NAMES.filter(bool), st.one_of(
            VALUES, st.fixed_dictionaries({"value": VALUES}, optional={"unit": VALUES, "doc": VALUES,
                                                                        "units": VALUES})),
            max_size=4))
    doc["components"] = draw(st.one_of(
        st.dictionaries(NAMES.filter(bool), components(), max_size=5), VALUES))
    doc["bonds"] = draw(st.one_of(st.lists(BONDS, max_size=5), VALUES))
    if draw(st.booleans()):
        doc["events"] = draw(st.one_of(st.lists(st.one_of(st.fixed_dictionaries(
            {"name": VALUES, "guard": st.one_of(EXPRS, VALUES)},
            optional={"direction": VALUES, "terminal": VALUES, "directon": VALUES}), VALUES),
            max_size=3), VALUES))
    if draw(st.booleans()):
        doc["outputs"] = draw(st.one_of(st.dictionaries(NAMES.filter(bool), st.one_of(EXPRS, VALUES),
                                                        max_size=3), VALUES))
    if draw(st.booleans()):
        doc["simulation"] = draw(st.one_of(st.dictionaries(st.sampled_from(
            ["t_end", "method", "rtol", "atol", "max_step", "energy_tolerance", "initial", "tend"]),
            VALUES, max_size=3), VALUES))
    if draw(st.booleans()):
        doc[draw(st.sampled_from(["solver", "parameter", "component"]))] = draw(VALUES)
    return doc


def _dump(doc: dict) -> str | None:
    try:
        return tomli_w.dumps(doc)
    except (TypeError, ValueError):    # e.g. an empty key: not TOML tomli-w can write
        return None


def _paths(tree, prefix=()):
    """Every key path of a parsed TOML document (tables and arrays), the root excluded."""
    items = tree.items() if isinstance(tree, dict) else enumerate(tree)
    for key, value in items:
        yield (*prefix, key)
        if isinstance(value, (dict, list)):
            yield from _paths(value, (*prefix, key))


PARSED = {name: tomllib.loads(text) for name, text in FILES.items()}


@st.composite
def perturbed_documents(draw):
    """A real model file's document with one or two subtrees replaced by random values,
    deleted, or given an extra random key: deep enough to reach every section's checks."""
    name = draw(st.sampled_from(sorted(PARSED)))
    doc = copy.deepcopy(PARSED[name])
    for _ in range(draw(st.integers(1, 2))):
        paths = list(_paths(doc))
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        action = draw(st.sampled_from(["replace", "replace", "delete", "add"]))
        if action == "replace":
            parent[path[-1]] = draw(VALUES)
        elif action == "delete":
            del parent[path[-1]]
        elif isinstance(parent[path[-1]], dict):
            parent[path[-1]][draw(NAMES.filter(bool))] = draw(VALUES)
    return name, doc


@SETTINGS
@given(perturbed_documents())
def test_perturbed_model_documents_load_or_raise_model_file_error(named_doc):
    name, doc = named_doc
    text = _dump(doc)
    if text is not None:
        check_load(text, source=f"{name}.toml (perturbed)", compile_it=name in CHEAP)
    try:
        io.model_from_dict(doc, source="fuzz-dict")
    except ModelFileError as err:
        assert str(err).startswith("fuzz-dict")


@SETTINGS
@given(documents())
def test_random_model_documents_load_or_raise_model_file_error(doc):
    text = _dump(doc)
    if text is not None:
        check_load(text, compile_it=True)
    try:                                # the parsed structure, without text: no line numbers
        io.model_from_dict(doc, source="fuzz-dict")
    except ModelFileError as err:
        assert str(err).startswith("fuzz-dict")


# --- mutations of the real model files -----------------------------------------------------------
ODD_VALUES = ['"text"', "1", "-3", "0.0", "true", "[1, \"a\"]", "{ a = 1 }", "1.5e300", "inf",
              "nan", '""', "[]", "{}", '"k +"', '"undefined_name"', '"mass.q"']


def _lines(text: str) -> list[str]:
    return text.splitlines() or [""]


def delete_line(text, i, _):
    lines = _lines(text)
    del lines[i % len(lines)]
    return "\n".join(lines)


def duplicate_line(text, i, _):
    lines = _lines(text)
    k = i % len(lines)
    lines.insert(k, lines[k])
    return "\n".join(lines)


def swap_lines(text, i, j):
    lines = _lines(text)
    a, b = i % len(lines), j % len(lines)
    lines[a], lines[b] = lines[b], lines[a]
    return "\n".join(lines)


def change_value_type(text, i, j):
    lines = _lines(text)
    keyed = [k for k, ln in enumerate(lines) if re.match(r"\s*[\w.\"-]+\s*=", ln)]
    if not keyed:
        return text
    k = keyed[i % len(keyed)]
    key = lines[k].split("=", 1)[0]
    lines[k] = f"{key}= {ODD_VALUES[j % len(ODD_VALUES)]}"
    return "\n".join(lines)


def rename_kind(text, i, j):
    kinds = sorted(REGISTRY) + ["Damper", "", "c", "multibody", "HuntCrossly"]
    matches = list(re.finditer(r'type = "(\w*)"', text))
    if not matches:
        return text
    m = matches[i % len(matches)]
    return text[:m.start()] + f'type = "{kinds[j % len(kinds)]}"' + text[m.end():]


def break_bond(text, i, j):
    matches = list(re.finditer(r'"([\w.]+) -> ([\w.]+)"', text))
    if not matches:
        return text
    m = matches[i % len(matches)]
    tail, head = m.group(1), m.group(2)
    broken = [f"{tail} => {head}", f"{tail} -> ", f"{head} -> {tail}", f"{tail}.zz -> {head}",
              f"{tail} -> nothing.p", f"{tail}->{tail}", "", f"{tail} -> {head} -> {tail}"]
    return text[:m.start()] + f'"{broken[j % len(broken)]}"' + text[m.end():]


def drop_table(text, i, _):
    lines = _lines(text)
    headers = [k for k, ln in enumerate(lines) if ln.lstrip().startswith("[")]
    if not headers:
        return text
    start = headers[i % len(headers)]
    end = next((k for k in headers if k > start), len(lines))
    return "\n".join(lines[:start] + lines[end:])


def misspell_name(text, i, j):
    matches = list(re.finditer(r'= "([A-Za-z_]\w*)"', text))
    if not matches:
        return text
    m = matches[i % len(matches)]
    name = m.group(1)
    new = [name + "x", name[:-1], name.upper(), "t", "pi", "sin"][j % 6]
    return text[:m.start(1)] + new + text[m.end(1):]


def truncate(text, i, _):
    return text[: i % (len(text) + 1)]


MUTATIONS = [delete_line, duplicate_line, swap_lines, change_value_type, rename_kind, break_bond,
             drop_table, misspell_name, truncate]


@SETTINGS
@given(st.sampled_from(sorted(FILES)), st.lists(st.tuples(st.sampled_from(MUTATIONS),
                                                          st.integers(0, 10_000),
                                                          st.integers(0, 10_000)),
                                                min_size=1, max_size=3))
def test_mutated_model_files_load_or_raise_model_file_error(name, mutations):
    text = FILES[name]
    for mutate, i, j in mutations:
        text = mutate(text, i, j)
    check_load(text, source=f"{name}.toml (mutated)", compile_it=name in CHEAP)


def test_load_from_a_path_names_the_path(tmp_path):
    """io.load reads the file (not UTF-8 text is a ModelFileError too)."""
    path = tmp_path / "binary.toml"
    path.write_bytes(b"\xff\xfe\x00[model]\n")
    try:
        io.load(path)
    except ModelFileError as err:
        assert str(err).startswith(f"{path}: not a UTF-8 text file")
    else:
        raise AssertionError("a binary file loaded")
    path.write_text(FILES["mass_spring_damper"].replace('type = "R"', 'type = "R"\ntype = "C"'))
    try:
        io.load(path)
    except ModelFileError as err:
        assert str(err).startswith(f"{path}, line ")
        assert "TOML syntax error: Cannot overwrite a value: a key or table is defined twice" in str(err)
    else:
        raise AssertionError("a duplicated key loaded")

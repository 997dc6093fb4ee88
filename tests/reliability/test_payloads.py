"""Hostile model files: every payload is refused with a ModelFileError naming the file, runs no
code, starts no process and writes no file (issue 10, items 1 and 2).

Each case writes a model file (models/mass_spring_damper.toml or models/pendulum.toml with one
field replaced) and loads it under an audit hook (tests/reliability/conftest.py) that records
any ``exec``/``compile``, process start or file opened for writing; the payloads that would act
try to create a marker file, and the compiled-model cache must stay as it was.

Payload classes: Python that reaches builtins through attribute chains (``__globals__``,
``__class__``, ``__subclasses__``), calls of Python and sympy functions (``eval``, ``exec``,
``__import__``, ``getattr``, ``sympify``, ``Symbol``), lambdas, comprehensions, conditionals,
f-strings, statements, look-alike (full-width) letters that Python would normalize, work bombs
(``9**9**9**9``, deep nesting, megabyte expressions, numbers beyond float64), docstring
break-outs in every kind of name (component, parameter, event, output, body, joint, point, model
name), control characters in the description, and deeply nested TOML arrays.
"""
from __future__ import annotations

import copy
import os
import tomllib

import pytest
import tomli_w

from porthamiltonian import io
from porthamiltonian.errors import ModelFileError

MARK = "@MARK@"   # replaced by the path of the marker file a payload would create

#: Python (and sympy) that would run code if it were evaluated
EXPRESSIONS = [
    "__import__('os').system('touch @MARK@')",
    "t.__class__.__mro__[-1].__subclasses__()",
    "sin.__globals__['__builtins__']['exec']('open(\"@MARK@\", \"w\")')",
    "().__class__.__base__.__subclasses__()",
    "k.__class__.__init__.__globals__['os'].system('touch @MARK@')",
    "Symbol('x').__class__",
    "Integer(1).__class__.__mro__",
    "(lambda: open('@MARK@', 'w'))()",
    "[c for c in ().__class__.__base__.__subclasses__()]",
    "eval(\"open('@MARK@', 'w')\")",
    "exec('import os')",
    "getattr(k, '__class__')",
    "k if open('@MARK@', 'w') else 0",
    "f'{open(\"@MARK@\", \"w\")}'",
    "\uff45\uff58\uff45\uff43('open(\"@MARK@\", \"w\")')",           # full-width 'exec'
    "k; import os; os.system('touch @MARK@')",
    "sympify('__import__(\"os\").system(\"touch @MARK@\")')",
    "Function('f')(k)",
    "k.func",
    "pi.evalf(1000000000)",
    "k[0]",
    "open('@MARK@', 'w')",
    "k @ k",
    "c*9**9**9**9",
    "(" * 5000 + "k" + ")" * 5000,
    "k" + " + k" * 200_000,
    "1e999 * k",
    "(k + 1)**100000",
    "x0 := 1",
    "\\N{LATIN SMALL LETTER A}",
]

def _doc(model_text, name: str) -> dict:
    return tomllib.loads(model_text(name))


def _put(doc: dict, path: tuple, value) -> dict:
    doc = copy.deepcopy(doc)
    node = doc
    for key in path[:-1]:
        node = node.setdefault(key, {}) if isinstance(key, str) else node[key]
    node[path[-1]] = value
    return doc


#: where an expression can sit: (model, key path of the field)
FIELDS = {
    "component argument": ("mass_spring_damper", ("components", "spring", "stiffness")),
    "initial value": ("mass_spring_damper", ("components", "spring", "q0")),
    "event guard": ("mass_spring_damper", ("events",)),
    "output": ("mass_spring_damper", ("outputs", "position")),
    "multibody mass": ("pendulum", ("components", "pendulum", "bodies", "bob", "mass")),
    "multibody com": ("pendulum", ("components", "pendulum", "bodies", "bob", "com", 2)),
    "multibody inertia": ("pendulum", ("components", "pendulum", "bodies", "bob", "inertia", 0)),
    "multibody point": ("pendulum", ("components", "pendulum", "bodies", "bob", "points", "tip", 2)),
    "joint q0": ("pendulum", ("components", "pendulum", "joints", "pivot", "q0")),
    "joint origin": ("pendulum", ("components", "pendulum", "joints", "pivot", "origin")),
    "gravity": ("pendulum", ("components", "pendulum", "gravity", 2)),
    "storage energy": ("mass_spring_damper", ("components", "store")),
}


def _with_expression(model_text, field: str, payload: str) -> dict:
    model, path = FIELDS[field]
    doc = _doc(model_text, model)
    if field == "event guard":
        return _put(doc, path, [{"name": "e", "guard": payload}])
    if field == "joint origin":
        return _put(doc, path, [0, 0, payload])
    if field == "storage energy":
        return _put(doc, path, {"type": "Storage", "energy": payload, "states": {"q": "C"}})
    return _put(doc, path, payload)


#: names that would break out of a docstring or a comment of generated code
BREAK_OUT = 'x"""; import os; os.system("touch @MARK@"); """'
C_COMMENT = "x*/ system(\"touch @MARK@\"); /*"


def _named(model_text, kind: str, name: str) -> dict:
    msd, pendulum = _doc(model_text, "mass_spring_damper"), _doc(model_text, "pendulum")
    if kind == "component":
        return _put(msd, ("components", name), {"type": "C", "stiffness": "k"})
    if kind == "parameter":
        return _put(msd, ("parameters", name), 1.0)
    if kind == "event":
        return _put(msd, ("events",), [{"name": name, "guard": "spring.q"}])
    if kind == "output":
        return _put(msd, ("outputs", name), "spring.q")
    if kind == "model name":
        return _put(msd, ("model", "name"), name)
    if kind == "description":
        return _put(msd, ("model", "description"), name)
    bodies = ("components", "pendulum", "bodies")
    if kind == "body":
        doc = _put(pendulum, (*bodies, name), pendulum["components"]["pendulum"]["bodies"]["bob"])
        return _put(doc, ("components", "pendulum", "joints", "pivot", "child"), name)
    if kind == "joint":
        joints = ("components", "pendulum", "joints")
        return _put(pendulum, (*joints, name), pendulum["components"]["pendulum"]["joints"]["pivot"])
    if kind == "point":
        return _put(pendulum, (*bodies, "bob", "points", name), [0, 0, 1])
    raise AssertionError(kind)


NAMES = [(kind, name) for kind in ("component", "parameter", "event", "output", "body", "joint",
                                   "point", "model name") for name in (BREAK_OUT, C_COMMENT)]
NAMES += [("description", 'ok\n"""\nimport os; os.system("touch @MARK@")\n"""'),
          ("description", "ok \x1b]0;owned\x07 \x1b[2J"),
          ("model name", "x\u202e}}txt.exe"),
          ("parameter", "__class__"), ("component", "__init__"), ("parameter", "pi"),
          ("component", "j\u0430")]                    # a Cyrillic 'а' in an identifier

CASES = ([pytest.param("expression", "component argument", p, id=f"argument-{i}")
          for i, p in enumerate(EXPRESSIONS)]
         + [pytest.param("expression", field, p, id=f"{field.replace(' ', '-')}-{i}")
            for field in FIELDS if field != "component argument"
            for i, p in enumerate(EXPRESSIONS[:6] + EXPRESSIONS[23:25])]
         + [pytest.param("name", kind, name, id=f"name-{kind.replace(' ', '-')}-{i}")
            for i, (kind, name) in enumerate(NAMES)])


def _load_refused(path, cache_dir, marker, audit) -> str:
    before = sorted(os.listdir(cache_dir))
    with audit() as events, pytest.raises(ModelFileError) as info:
        io.load(path)
    assert not events, events
    assert not marker.exists()
    assert sorted(os.listdir(cache_dir)) == before
    message = str(info.value)
    assert message.startswith(str(path)), message
    assert len(message) < 2000, message[:300]
    return message


@pytest.fixture(scope="module")
def own_cache(isolated_cache, tmp_path_factory):
    """A cache folder of this module's own: the tests assert that loading a hostile file adds
    nothing to the cache, which another process sharing the session's cache could."""
    path = tmp_path_factory.mktemp("payload_cache")
    path.chmod(0o700)
    mp = pytest.MonkeyPatch()
    mp.setenv("PORTHAMILTONIAN_CACHE", str(path))
    yield path
    mp.undo()


@pytest.fixture(scope="module", autouse=True)
def _warm(own_cache, model_text):
    """Load benign files first, so that lazy imports do not count as executed code."""
    for name in ("mass_spring_damper", "pendulum"):
        io.loads(model_text(name))


@pytest.mark.parametrize("what, field, payload", CASES)
def test_payload_is_refused_without_running_anything(what, field, payload, model_text, tmp_path,
                                                     own_cache, audit):
    marker = tmp_path / "PWNED"
    payload = payload.replace(MARK, str(marker))
    doc = (_with_expression(model_text, field, payload) if what == "expression"
           else _named(model_text, field, payload))
    path = tmp_path / "hostile.toml"
    path.write_text(tomli_w.dumps(doc))
    message = _load_refused(path, own_cache, marker, audit)
    if what == "expression" and field in ("component argument", "event guard", "output"):
        assert ", line " in message, message          # the line of the offending key


@pytest.mark.parametrize("depth", [40, 5000])
def test_deeply_nested_arrays_are_a_model_file_error(depth, model_text, tmp_path, own_cache,
                                                     audit):
    """TOML arrays nested deeper than io.MAX_NESTING (40: tomllib parses it; 5000: tomllib runs
    out of recursion) are refused, as promised: no bare Python error from loading."""
    text = model_text("mass_spring_damper").replace(
        'stiffness = "k"', "stiffness = " + "[" * depth + "1" + "]" * depth)
    path = tmp_path / "nested.toml"
    path.write_text(text)
    message = _load_refused(path, own_cache, tmp_path / "PWNED", audit)
    assert "nested" in message

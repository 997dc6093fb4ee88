"""Messages of malformed model files (porthamiltonian.io): each names the file, the line where the
problem is (TOML's own line for syntax errors; the line of the offending key, table, bond or
event otherwise) or the component, and says what to write instead. The messages are pinned
here word for word, so a change to them is a visible decision."""
from __future__ import annotations

from pathlib import Path

import pytest

from porthamiltonian import io
from porthamiltonian.component import REGISTRY
from porthamiltonian.errors import ModelFileError

MODELS_DIR = Path(io.__file__).resolve().parent.parent / "models"
MSD = (MODELS_DIR / "mass_spring_damper.toml").read_text()
BALL = (MODELS_DIR / "bouncing_ball.toml").read_text()
# the registered kinds, as messages list them (test modules may register kinds of their own)
def kinds() -> str:
    """The registered kinds now (other tests register components of their own)."""
    return ", ".join(sorted(REGISTRY))


def line_of(text: str, needle: str, start: int = 1) -> int:
    return next(i for i, line in enumerate(text.splitlines(), 1) if i >= start and needle in line)


def message(text: str, tmp_path: Path, name: str = "model.toml") -> tuple[str, Path]:
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(ModelFileError) as info:
        io.load(path)
    return str(info.value), path


def edit(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


# --- TOML syntax ---------------------------------------------------------------------------------
def test_toml_syntax_error_gives_line_column_the_line_and_the_fix(tmp_path):
    text = edit(MSD, "[components.damper]", "[components.damper")
    msg, path = message(text, tmp_path)
    n = line_of(text, "[components.damper")
    assert msg == (f"{path}, line {n}, column 19: TOML syntax error: Expected ']' at the end of a "
                   "table declaration (in '[components.damper'); fix the TOML syntax of that line "
                   "(see docs/model-files.md for the format)")


def test_duplicated_key_says_it_is_defined_twice(tmp_path):
    text = edit(MSD, 'resistance = "c"', 'resistance = "c"\nresistance = "k"')
    msg, path = message(text, tmp_path)
    n = line_of(text, 'resistance = "k"')
    assert msg == (f"{path}, line {n}, column 17: TOML syntax error: Cannot overwrite a value: a "
                   "key or table is defined twice; keep one of them (in 'resistance = \"k\"'); fix "
                   "the TOML syntax of that line (see docs/model-files.md for the format)")


def test_unclosed_array_at_the_end_of_the_file(tmp_path):
    msg, path = message('bonds = ["force.p -> j"\n', tmp_path)
    assert msg == (f"{path}, at the end of the file: TOML syntax error: Unclosed array; a table, "
                   "array or string is not closed (see docs/model-files.md for the format)")


def test_not_utf8_text(tmp_path):
    path = tmp_path / "binary.toml"
    path.write_bytes(b"x = 1\n\xff\n")
    with pytest.raises(ModelFileError) as info:
        io.load(path)
    assert str(info.value) == (f"{path}: not a UTF-8 text file (byte 6: invalid start byte); a "
                               "model file is TOML text")


# --- sections ------------------------------------------------------------------------------------
def test_unknown_section_suggests_the_right_one(tmp_path):
    text = MSD + "\n[output]\nx = \"spring.q\"\n"
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, '[output]')}: unknown section 'output' (did you "
                   "mean 'outputs'?); a model file has only bonds, components, events, model, "
                   "outputs, parameters, simulation (see docs/model-files.md)")


def test_model_name_must_be_a_string(tmp_path):
    text = edit(MSD, 'name = "mass_spring_damper"', "name = 3")
    msg, path = message(text, tmp_path)
    assert msg == f"{path}, line {line_of(text, 'name = 3')}: [model] name must be a string, got an integer"


# --- parameters ------------------------------------------------------------------------------------
def test_parameter_value_must_be_a_number(tmp_path):
    text = edit(MSD, "k = { value = 4.0,", 'k = { value = "four",')
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 'k = {')}: parameter 'k' must be a number (SI "
                   "units), got a string 'four'; write k = 1.0 or k = { value = 1.0, unit = \"...\" }")


def test_parameter_table_with_a_misspelt_key(tmp_path):
    text = edit(MSD, 'unit = "N/m"', 'units = "N/m"')
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 'k = {')}: parameter 'k': unknown key 'units' "
                   "(did you mean 'unit'?); write k = { value = ..., unit = \"...\", doc = \"...\" } "
                   "or k = number")


def test_non_finite_parameter(tmp_path):
    text = edit(MSD, "k = { value = 4.0,", "k = { value = inf,")
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 'k = {')}: model 'mass_spring_damper' parameter "
                   "'k': parameter value must be finite, got inf")


# --- components ------------------------------------------------------------------------------------
def test_unknown_component_kind_suggests_the_closest(tmp_path):
    text = edit(BALL, 'floor = { type = "HuntCrossley", x', 'floor = { type = "HuntCrossly", x')
    msg, path = message(text, tmp_path)
    n = line_of(text, 'type = "HuntCrossly", x =')
    assert msg == (f"{path}, line {n}: component 'floor': unknown "
                   f"component type 'HuntCrossly' (did you mean 'HuntCrossley'?); known types: "
                   f"{kinds()} (see docs/model-files.md)")


def test_component_type_must_be_a_string(tmp_path):
    text = edit(MSD, 'type = "R"', "type = 3")
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 'type = 3')}: component 'damper': type must be a "
                   f"string naming a component kind (e.g. type = \"C\"), got an integer 3; known "
                   f"types: {kinds()}")


def test_component_without_type_or_not_a_table(tmp_path):
    text = edit(MSD, 'type = "R"\n', "")
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, '[components.damper]')}: component 'damper' needs "
                   f"a 'type' (e.g. type = \"C\"); types: {kinds()}")
    msg, path = message("[components]\nwheel = 3\n", tmp_path)
    assert msg == (f"{path}, line 2: component 'wheel' must be a table ([components.wheel] with "
                   "type = \"KIND\" and its arguments), got an integer")


def test_unknown_component_argument_points_at_its_line(tmp_path):
    text = edit(MSD, 'resistance = "c"', 'resistence = "c"')
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 'resistence')}: component 'damper': R has no "
                   "argument 'resistence' (did you mean 'resistance'?); its arguments are: "
                   "domain, resistance, effort, flow, dim")


def test_unknown_name_in_an_expression_points_at_the_components_own_line(tmp_path):
    """Two components with a `stiffness` key: the line is the second one's."""
    text = MSD + '\n[components.spring2]\ntype = "C"\nstiffness = "kk"\n'
    text = edit(text, '"j -> damper.p"', '"j -> damper.p", "j -> spring2.p"')
    msg, path = message(text, tmp_path)
    n = line_of(text, 'stiffness = "kk"')
    assert n > line_of(text, 'stiffness = "k"')
    assert msg == (f"{path}, line {n}: component 'spring2' argument 'stiffness': unknown name(s) kk "
                   "in 'kk'; known names here: F, c, k, m, x0 (declare model parameters under "
                   "[parameters])")


def test_expression_error_in_an_inline_table_points_at_its_line(tmp_path):
    text = edit(BALL, 'stiffness = "K", damping = "lam"', 'stiffness = "K", damping = "lam *"')
    msg, path = message(text, tmp_path)
    n = line_of(text, 'damping = "lam *"')
    assert msg == (f"{path}, line {n}: component 'floor' argument "
                   "'damping': cannot parse 'lam *': the expression ends too early: expected a "
                   "number, a name or '('")


def test_argument_of_the_wrong_type(tmp_path):
    text = edit(MSD, 'resistance = "c"', "resistance = [1, 2]")
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 'resistance = [1, 2]')}: component 'damper' "
                   "argument 'resistance': expected a number or an expression, got [1, 2]")


def test_unknown_domain_points_at_the_domain_line(tmp_path):
    text = edit(MSD, 'type = "R"', 'type = "R"\ndomain = "fluid"')
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 'domain = ')}: component 'damper': unknown "
                   "domain 'fluid'; known domains: electric, hydraulic, magnetic, rotation, "
                   "screw, thermal, translation")


def test_multibody_error_points_at_the_nested_key(tmp_path):
    text = edit(BALL, 'type = "translational"', 'type = "hinge"')
    msg, path = message(text, tmp_path)
    n = line_of(text, 'type = "hinge"')
    assert msg == (f"{path}, line {n}: component 'ball': Multibody "
                   "joint 'drop': type must be one of revolute, prismatic, translational, "
                   "universal, spherical, free, weld, got 'hinge'")
    text = edit(BALL, "inertia = 0", "inertia = 0\ncolour = 1")
    msg, path = message(text, tmp_path)
    assert msg.startswith(f"{path}, line {line_of(text, 'colour')}: component 'ball': Multibody "
                          "body 'b': unknown field(s) colour; fields: mass, com, inertia")


MM = 'mass = "mm"'


def test_multibody_expression_error_names_file_line_component_and_body(tmp_path):
    """Expressions nested in a Multibody are parsed when the file loads (not only when it
    compiles), so their errors carry the line too."""
    text = edit(BALL, 'mass = "m"', MM)
    msg, path = message(text, tmp_path, "ball.toml")
    assert msg == (f"{path}, line {line_of(text, MM)}: component 'ball' body 'b' "
                   "mass: unknown name(s) mm in 'mm'; known names here: B, K, g, h0, lam, m, n, "
                   "r, vx0, vz0 (declare model parameters under [parameters])")


# --- bonds ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("bond, expected", [
    ("j.p => damper.p", ("bond 'j.p => damper.p' must read \"component.port -> component.port\" "
                         "(a junction's name alone adds a port to it)")),
    ("j -> dampr.p", ("bond 'j -> dampr.p': model 'mass_spring_damper' has no component 'dampr'; "
                      "components: force, j, mass, spring, damper")),
    ("j -> damper.q", "bond 'j -> damper.q': component 'damper' (R) has no port 'q'; ports: p"),
])
def test_bad_bond_names_the_bond_and_its_line(tmp_path, bond, expected):
    text = edit(MSD, '"j -> damper.p"', f'"{bond}"')
    msg, path = message(text, tmp_path)
    assert msg == f"{path}, line {line_of(text, bond)}: {expected}"


def test_bond_on_its_own_line_of_a_multiline_array(tmp_path):
    text = edit(MSD, 'bonds = ["force.p -> j", "j -> mass.p", "j -> spring.p", "j -> damper.p"]',
                'bonds = [\n  "force.p -> j",\n  "j -> mass.p",\n  "j -> spring.p",\n'
                '  "j -> damper.p",\n  "j -> damper.p",\n]')
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 'j -> damper.p')}: bond 'j -> damper.p': port "
                   "damper.p is already connected; a port takes one bond (use a junction to join "
                   "more)")


def test_bonds_must_be_an_array_of_strings(tmp_path):
    text = edit(MSD, 'bonds = ["force.p -> j", "j -> mass.p", "j -> spring.p", "j -> damper.p"]',
                'bonds = "force.p -> j"')
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 'bonds =')}: 'bonds' must be an array of "
                   "\"tail.port -> head.port\" strings, got a string")
    text = edit(MSD, '"j -> damper.p"', "3")
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 'bonds =')}: bond 3 (an integer) must read "
                   "\"component.port -> component.port\" (a junction's name alone adds a port to it)")


# --- events, outputs, simulation ---------------------------------------------------------------------
EVENT = '\n[[events]]\nname = "stretched"\nguard = "spring.q - 0.2"\ndirection = 1\n'


@pytest.mark.parametrize("old, new, key, expected", [
    ("direction = 1", 'direction = "up"', "direction",
     "event 'stretched': direction must be -1 (falling), 0 (both) or 1 (rising), got 'up'"),
    ("direction = 1", "direction = 0.5", "direction",
     "event 'stretched': direction must be -1 (falling), 0 (both) or 1 (rising), got 0.5"),
    ("direction = 1", 'terminal = "yes"', "terminal",
     "event 'stretched': terminal must be true or false, got 'yes'"),
    ("direction = 1", "directon = 1", "directon",
     ("event #1: unknown key 'directon' (did you mean 'direction'?); keys: name, guard, "
      "direction, terminal")),
    ('name = "stretched"', "name = 7", "name", "event #1: name must be a string, got an integer"),
    ('guard = "spring.q - 0.2"', 'guard = "spring.q -"', "guard",
     ("event 'stretched' guard: cannot parse 'spring.q -': the expression ends too early: "
      "expected a number, a name or '('")),
    ('guard = "spring.q - 0.2"', 'guard = "spring.q - qmax"', "guard",
     ("event 'stretched' guard: unknown name(s) qmax in 'spring.q - qmax'; known names here: F, "
      "c, k, m, x0 (declare model parameters under [parameters])")),
])
def test_bad_event_points_at_its_key(tmp_path, old, new, key, expected):
    text = MSD + edit(EVENT, old, new)
    msg, path = message(text, tmp_path)
    assert msg == f"{path}, line {line_of(text, key + ' =', line_of(text, '[[events]]'))}: {expected}"


def test_events_must_be_an_array_of_tables(tmp_path):
    text = MSD + '\n[events]\nname = "a"\n'
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, '[events]')}: events are an array of tables: "
                   "[[events]] with name = \"...\", guard = \"expression\", direction = -1, 0 or 1, "
                   "terminal = true/false; got a table")
    text = MSD + '\n[[events]]\nname = "a"\n'
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, '[[events]]')}: event #1 needs a name and a "
                   "guard: [[events]] name = \"...\", guard = \"expression\"")


def test_bad_outputs(tmp_path):
    text = MSD + '\n[outputs]\nposition = "spring.q +"\n'
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 'position =')}: output 'position': cannot parse "
                   "'spring.q +': the expression ends too early: expected a number, a name or '('")
    text = MSD + "\n[outputs]\nposition = [1]\n"
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 'position =')}: output 'position' must be an "
                   "expression (a string), got an array")
    text = "outputs = 1\n" + MSD
    msg, path = message(text, tmp_path)
    assert msg == f"{path}, line 1: [outputs] must be a table of name = \"expression\", got an integer"


def test_bad_simulation_settings(tmp_path):
    text = edit(MSD, "t_end = 20.0", "tend = 20.0")
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 'tend')}: [simulation] has no key 'tend' (did you "
                   "mean 't_end'?); it takes atol, energy_tolerance, initial, max_step, method, "
                   "rtol, t_end")
    text = edit(MSD, "t_end = 20.0", 't_end = "long"')
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 't_end')}: [simulation] t_end must be a positive "
                   "number, got a string 'long'")
    text = edit(MSD, 'method = "Radau"', "method = 4")
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 'method = 4')}: [simulation] method must be a "
                   "string (e.g. \"Radau\"), got an integer 4")
    text = edit(MSD, "rtol = 1e-9", "rtol = -1e-9")
    msg, path = message(text, tmp_path)
    assert msg == (f"{path}, line {line_of(text, 'rtol')}: [simulation] rtol must be a positive "
                   "number, got a number -1e-09")


def test_model_from_dict_names_its_source_without_a_line():
    with pytest.raises(ModelFileError) as info:
        io.model_from_dict({"components": {"x": {"type": "Q"}}}, source="<built in code>")
    assert str(info.value).startswith("<built in code>: component 'x': unknown component type 'Q'")

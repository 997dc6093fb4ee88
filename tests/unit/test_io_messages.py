"""Messages of malformed model files (porthamiltonian.interfaces.io): each is a ModelFileError naming the
file, the line where the problem is (TOML's own line for syntax errors; the line of the offending
key, table, bond or event otherwise), the names involved, and what to write instead. The tests pin
the error type, the file and line, the names and the hint, not whole sentences: a message may be
reworded, but not lose what it names or what it tells the user to do."""
from __future__ import annotations

from pathlib import Path

import pytest

from porthamiltonian import io
from porthamiltonian.errors import ModelFileError

MODELS_DIR = Path(io.__file__).resolve().parents[2] / "models"
MSD = (MODELS_DIR / "mass_spring_damper.toml").read_text()
BALL = (MODELS_DIR / "bouncing_ball.toml").read_text()


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


def check(msg: str, where: str, *names: str, hint: str = "") -> None:
    """``msg`` is one problem about ``where`` (``"<file>, line N"`` or ``"<file>"``), names every
    one of ``names`` and gives the ``hint``."""
    assert msg.startswith(f"{where}: ") and "\n" not in msg, msg
    for name in (*names, hint):
        assert name in msg, (name, msg)


# --- TOML syntax ---------------------------------------------------------------------------------
def test_toml_syntax_error_gives_line_column_the_line_and_the_fix(tmp_path):
    text = edit(MSD, "[components.damper]", "[components.damper")
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, '[components.damper')}, column 19",
          "TOML syntax error", "Expected ']'", "'[components.damper'",
          hint="fix the TOML syntax of that line")


def test_duplicated_key_says_it_is_defined_twice(tmp_path):
    text = edit(MSD, 'resistance = "c"', 'resistance = "c"\nresistance = "k"')
    msg, path = message(text, tmp_path)
    n = line_of(text, 'resistance = "k"')
    check(msg, f"{path}, line {n}, column 17",
          "TOML syntax error", "'resistance = \"k\"'", hint="defined twice; keep one of them")


def test_unclosed_array_at_the_end_of_the_file(tmp_path):
    msg, path = message('bonds = ["force.p -> j"\n', tmp_path)
    check(msg, f"{path}, at the end of the file", "Unclosed array",
          hint="a table, array or string is not closed")


def test_not_utf8_text(tmp_path):
    path = tmp_path / "binary.toml"
    path.write_bytes(b"x = 1\n\xff\n")
    with pytest.raises(ModelFileError) as info:
        io.load(path)
    check(str(info.value), str(path), "not a UTF-8 text file", "byte 6",
          hint="a model file is TOML text")


# --- sections ------------------------------------------------------------------------------------
def test_unknown_section_suggests_the_right_one(tmp_path):
    text = MSD + "\n[output]\nx = \"spring.q\"\n"
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, '[output]')}", "unknown section 'output'",
          "bonds, components, events, inputs, linearize, model, outputs, parameters, simulation",
          hint="did you mean 'outputs'?")


def test_model_name_must_be_a_string(tmp_path):
    text = edit(MSD, 'name = "mass_spring_damper"', "name = 3")
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, 'name = 3')}", "[model] name", "an integer",
          hint="must be a string")


# --- parameters ------------------------------------------------------------------------------------
def test_parameter_value_must_be_a_number(tmp_path):
    text = edit(MSD, "k = { value = 4.0,", 'k = { value = "four",')
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, 'k = {')}", "parameter 'k'", "'four'",
          hint='write k = 1.0 or k = { value = 1.0, unit = "..." }')


def test_parameter_table_with_a_misspelt_key(tmp_path):
    text = edit(MSD, 'unit = "N/m"', 'units = "N/m"')
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, 'k = {')}", "parameter 'k'", "unknown key 'units'",
          "did you mean 'unit'?", hint='write k = { value = ..., unit = "...", doc = "..." }')


def test_non_finite_parameter(tmp_path):
    text = edit(MSD, "k = { value = 4.0,", "k = { value = inf,")
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, 'k = {')}", "model 'mass_spring_damper'",
          "parameter 'k'", "inf", hint="must be finite")


# --- components ------------------------------------------------------------------------------------
def test_unknown_component_kind_suggests_the_closest(tmp_path):
    text = edit(BALL, 'floor = { type = "HuntCrossley", x', 'floor = { type = "HuntCrossly", x')
    msg, path = message(text, tmp_path)
    n = line_of(text, 'type = "HuntCrossly", x =')
    check(msg, f"{path}, line {n}", "component 'floor'",
          "unknown component type 'HuntCrossly'", "known types: 0, 1, ActuatedSpringDamper, Actuator, C,",
          hint="did you mean 'HuntCrossley'?")


def test_component_type_must_be_a_string(tmp_path):
    text = edit(MSD, 'type = "R"', "type = 3")
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, 'type = 3')}", "component 'damper'", "an integer 3",
          "known types:", hint='type must be a string naming a component kind (e.g. type = "C")')


def test_component_without_type_or_not_a_table(tmp_path):
    text = edit(MSD, 'type = "R"\n', "")
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, '[components.damper]')}", "component 'damper'",
          "types: 0, 1, ActuatedSpringDamper, Actuator, C,", hint="needs a 'type' (e.g. type = \"C\")")
    msg, path = message("[components]\nwheel = 3\n", tmp_path)
    check(msg, f"{path}, line 2", "component 'wheel'", "an integer",
          hint='must be a table ([components.wheel] with type = "KIND" and its arguments)')


def test_unknown_component_argument_points_at_its_line(tmp_path):
    text = edit(MSD, 'resistance = "c"', 'resistence = "c"')
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, 'resistence')}", "component 'damper'",
          "R has no argument 'resistence'", "domain, resistance, effort, flow, dim",
          hint="did you mean 'resistance'?")


def test_unknown_name_in_an_expression_points_at_the_components_own_line(tmp_path):
    """Two components with a `stiffness` key: the line is the second one's."""
    text = MSD + '\n[components.spring2]\ntype = "C"\nstiffness = "kk"\n'
    text = edit(text, '"j -> damper.p"', '"j -> damper.p", "j -> spring2.p"')
    msg, path = message(text, tmp_path)
    n = line_of(text, 'stiffness = "kk"')
    assert n > line_of(text, 'stiffness = "k"')
    check(msg, f"{path}, line {n}", "component 'spring2' argument 'stiffness'",
          "unknown name(s) kk", "known names here: F, c, k, m, x0",
          hint="declare model parameters under [parameters]")


def test_expression_error_in_an_inline_table_points_at_its_line(tmp_path):
    text = edit(BALL, 'stiffness = "K", damping = "lam"', 'stiffness = "K", damping = "lam *"')
    msg, path = message(text, tmp_path)
    n = line_of(text, 'damping = "lam *"')
    check(msg, f"{path}, line {n}",
          "component 'floor' argument 'damping'", "cannot parse 'lam *'",
          hint="expected a number, a name or '('")


def test_argument_of_the_wrong_type(tmp_path):
    text = edit(MSD, 'resistance = "c"', "resistance = [1, 2]")
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, 'resistance = [1, 2]')}",
          "component 'damper' argument 'resistance'", "[1, 2]",
          hint="expected a number or an expression")


def test_unknown_domain_points_at_the_domain_line(tmp_path):
    text = edit(MSD, 'type = "R"', 'type = "R"\ndomain = "fluid"')
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, 'domain = ')}", "component 'damper'",
          "unknown domain 'fluid'",
          hint="known domains: electric, hydraulic, magnetic, rotation, screw, stiffness, thermal, translation")


def test_multibody_error_points_at_the_nested_key(tmp_path):
    text = edit(BALL, 'type = "translational"', 'type = "hinge"')
    msg, path = message(text, tmp_path)
    n = line_of(text, 'type = "hinge"')
    check(msg, f"{path}, line {n}", "component 'ball'", "joint 'drop'", "'hinge'",
          hint="type must be one of revolute, prismatic, translational, universal, spherical, "
               "free, weld")
    text = edit(BALL, "inertia = 0", "inertia = 0\ncolour = 1")
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, 'colour')}", "component 'ball'", "body 'b'",
          "unknown field(s) colour", hint="fields: mass, com, inertia")


MM = 'mass = "mm"'


def test_multibody_expression_error_names_file_line_component_and_body(tmp_path):
    """Expressions nested in a Multibody are parsed when the file loads (not only when it
    compiles), so their errors carry the line too."""
    text = edit(BALL, 'mass = "m"', MM)
    msg, path = message(text, tmp_path, "ball.toml")
    check(msg, f"{path}, line {line_of(text, MM)}", "component 'ball' body 'b' mass",
          "unknown name(s) mm", "known names here: B, K, g, h0, lam, m, n, r, vx0, vz0",
          hint="declare model parameters under [parameters]")


# --- bonds ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("bond, names, hint", [
    ("j.p => damper.p", ["bond 'j.p => damper.p'"],
     "must read \"component.port -> component.port\""),
    ("j -> dampr.p", ["bond 'j -> dampr.p'", "model 'mass_spring_damper'", "'dampr'"],
     "components: force, j, mass, spring, damper"),
    ("j -> damper.q", ["bond 'j -> damper.q'", "component 'damper' (R)", "no port 'q'"],
     "ports: p"),
])
def test_bad_bond_names_the_bond_and_its_line(tmp_path, bond, names, hint):
    text = edit(MSD, '"j -> damper.p"', f'"{bond}"')
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, bond)}", *names, hint=hint)


def test_bond_on_its_own_line_of_a_multiline_array(tmp_path):
    text = edit(MSD, 'bonds = ["force.p -> j", "j -> mass.p", "j -> spring.p", "j -> damper.p"]',
                'bonds = [\n  "force.p -> j",\n  "j -> mass.p",\n  "j -> spring.p",\n'
                '  "j -> damper.p",\n  "j -> damper.p",\n]')
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, 'j -> damper.p')}", "bond 'j -> damper.p'",
          "damper.p is already connected", hint="use a junction to join more")


def test_bonds_must_be_an_array_of_strings(tmp_path):
    text = edit(MSD, 'bonds = ["force.p -> j", "j -> mass.p", "j -> spring.p", "j -> damper.p"]',
                'bonds = "force.p -> j"')
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, 'bonds =')}", "'bonds'", "a string",
          hint="must be an array of \"tail.port -> head.port\" strings")
    text = edit(MSD, '"j -> damper.p"', "3")
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, 'bonds =')}", "bond 3 (an integer)",
          hint="must read \"component.port -> component.port\"")


# --- events, outputs, simulation ---------------------------------------------------------------------
EVENT = '\n[[events]]\nname = "stretched"\nguard = "spring.q - 0.2"\ndirection = 1\n'


@pytest.mark.parametrize("old, new, key, names, hint", [
    ("direction = 1", 'direction = "up"', "direction", ["event 'stretched'", "'up'"],
     "direction must be -1 (falling), 0 (both) or 1 (rising)"),
    ("direction = 1", "direction = 0.5", "direction", ["event 'stretched'", "0.5"],
     "direction must be -1 (falling), 0 (both) or 1 (rising)"),
    ("direction = 1", 'terminal = "yes"', "terminal", ["event 'stretched'", "'yes'"],
     "terminal must be true or false"),
    ("direction = 1", "directon = 1", "directon", ["event #1", "unknown key 'directon'",
                                                   "keys: name, guard, direction, terminal"],
     "did you mean 'direction'?"),
    ('name = "stretched"', "name = 7", "name", ["event #1", "an integer"], "must be a string"),
    ('guard = "spring.q - 0.2"', 'guard = "spring.q -"', "guard",
     ["event 'stretched' guard", "cannot parse 'spring.q -'"], "expected a number, a name or '('"),
    ('guard = "spring.q - 0.2"', 'guard = "spring.q - qmax"', "guard",
     ["event 'stretched' guard", "unknown name(s) qmax", "known names here: F, c, k, m, x0"],
     "declare model parameters under [parameters]"),
])
def test_bad_event_points_at_its_key(tmp_path, old, new, key, names, hint):
    text = MSD + edit(EVENT, old, new)
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, key + ' =', line_of(text, '[[events]]'))}", *names,
          hint=hint)


def test_events_must_be_an_array_of_tables(tmp_path):
    text = MSD + '\n[events]\nname = "a"\n'
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, '[events]')}", "got a table",
          hint="events are an array of tables: [[events]] with name = \"...\"")
    text = MSD + '\n[[events]]\nname = "a"\n'
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, '[[events]]')}", "event #1",
          hint="needs a name and a guard")


def test_bad_outputs(tmp_path):
    text = MSD + '\n[outputs]\nposition = "spring.q +"\n'
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, 'position =')}", "output 'position'",
          "cannot parse 'spring.q +'", hint="expected a number, a name or '('")
    text = MSD + "\n[outputs]\nposition = [1]\n"
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, 'position =')}", "output 'position'", "an array",
          hint="must be an expression (a string)")
    text = "outputs = 1\n" + MSD
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line 1", "[outputs]", "an integer",
          hint="must be a table of name = \"expression\"")


@pytest.mark.parametrize("old, new, needle, names, hint", [
    ("t_end = 20.0", "tend = 20.0", "tend", ["[simulation]", "no key 'tend'",
                                             "atol, energy_tolerance, initial, inputs, max_step, method"],
     "did you mean 't_end'?"),
    ("t_end = 20.0", 't_end = "long"', "t_end", ["[simulation] t_end", "'long'"],
     "must be a positive number"),
    ('method = "auto"', "method = 4", "method = 4", ["[simulation] method", "an integer 4"],
     "must be a string (e.g. \"Radau\")"),
    ("rtol = 1e-9", "rtol = -1e-9", "rtol", ["[simulation] rtol", "-1e-09"],
     "must be a positive number"),
])
def test_bad_simulation_settings(tmp_path, old, new, needle, names, hint):
    text = edit(MSD, old, new)
    msg, path = message(text, tmp_path)
    check(msg, f"{path}, line {line_of(text, needle)}", *names, hint=hint)


def test_model_from_dict_names_its_source_without_a_line():
    with pytest.raises(ModelFileError) as info:
        io.model_from_dict({"components": {"x": {"type": "Q"}}}, source="<built in code>")
    check(str(info.value), "<built in code>", "component 'x'", "unknown component type 'Q'",
          hint="known types:")


def test_several_problems_come_in_one_error_each_with_its_line(tmp_path):
    """A misspelt kind, a bond to a missing port and an unknown name in another component: one
    error, one line per problem, in the order of the file's sections; the bond to the component
    that could not be read is not reported again."""
    text = edit(MSD, 'type = "R"', 'type = "Resistor"')
    text = edit(text, '"j -> spring.p"', '"j -> spring.p", "j -> mass.q"')
    text = edit(text, 'stiffness = "k"', 'stiffness = "kk"')
    msg, path = message(text, tmp_path)
    lines = msg.splitlines()
    assert lines[0] == f"{path}: 3 problems:"
    where = [line_of(text, needle) for needle in ('type = "Resistor"', "bonds =",
                                                  'stiffness = "kk"')]
    assert [line.split(":")[0] for line in lines[1:]] == [f"  line {n}" for n in where]
    for needle in ("'Resistor'", "no port 'q'", "unknown name(s) kk"):
        assert needle in msg

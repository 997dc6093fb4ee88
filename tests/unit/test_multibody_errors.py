"""User errors of the Multibody component (porthamiltonian.mechanics.multibody): each raises its
typed exception (porthamiltonian.errors) with a message naming the body, joint or port involved
and, where there is one, the fix. Checked at construction (``Multibody(...)``), at connection
(``Model.connect``), at compilation (``symbolic``) and from a model file (``io.loads``)."""
from __future__ import annotations

from pathlib import Path

import pytest

import porthamiltonian as ph
from porthamiltonian import errors, io, symbolic
from porthamiltonian.mechanics import Multibody
from porthamiltonian.mechanics.multibody import KERNEL_LINKS

ROOT = Path(__file__).resolve().parents[2]


def revolute(parent: str, child: str, **more) -> dict:
    return {"type": "revolute", "parent": parent, "child": child, "axis": "y", **more}


def rod(mass=1.0, **more) -> dict:
    return {"mass": mass, "com": [0, 0, -0.5], **more}


def build(bodies: dict, joints: dict, **more) -> Multibody:
    return Multibody(bodies=bodies, joints=joints, **more)


def compile_symbolic(multibody: Multibody):
    model = ph.Model("mb_model")
    model.add("mb", multibody)
    return symbolic(model)


# --- bodies -----------------------------------------------------------------------------------
@pytest.mark.parametrize("mass", [0, 0.0, -1.5])
def test_non_positive_mass_names_the_body(mass):
    with pytest.raises(errors.ModelError) as info:
        build({"shank": rod(mass)}, {"knee": revolute("world", "shank")})
    msg = str(info.value)
    assert "'shank'" in msg and "mass must be positive" in msg and str(mass) in msg


def test_missing_mass_names_the_body_and_the_unit():
    with pytest.raises(errors.ModelError) as info:
        build({"shank": {"com": [0, 0, -0.5]}}, {"knee": revolute("world", "shank")})
    assert "'shank'" in str(info.value) and "needs a mass" in str(info.value)


@pytest.mark.parametrize("inertia, eigenvalues", [
    ([1.0, -1.0, 1.0], "-1.0"),                                  # principal moments
    ([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]], "-1.0"),  # indefinite 3x3
    ([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 2.0]], "2.0"),   # 0 + 1 < 2: no such body
    ([1.0, 1.0, 3.0], "3.0"),                                    # the triangle inequality
])
def test_inconsistent_inertia_names_the_body_and_the_eigenvalues(inertia, eigenvalues):
    """A rotational inertia no mass distribution has (negative, indefinite, or moments that
    break the triangle inequality I1 + I2 >= I3) is refused; a thin rod ([I, I, 0]) is not."""
    with pytest.raises(errors.ModelError) as info:
        build({"thigh": rod(inertia=inertia)}, {"hip": revolute("world", "thigh")})
    msg = str(info.value)
    assert "'thigh'" in msg and "physically consistent" in msg and "triangle inequality" in msg
    assert "eigenvalues" in msg and eigenvalues in msg
    build({"thigh": rod(inertia=[0.0, 1.0, 1.0])}, {"hip": revolute("world", "thigh")})


def test_non_symmetric_inertia_is_rejected():
    with pytest.raises(errors.ModelError) as info:
        build({"thigh": rod(inertia=[[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])},
              {"hip": revolute("world", "thigh")})
    assert "'thigh'" in str(info.value) and "symmetric" in str(info.value)


def test_malformed_inertia_lists_the_accepted_forms():
    with pytest.raises(errors.ModelError) as info:
        build({"thigh": rod(inertia=[1.0, 2.0])}, {"hip": revolute("world", "thigh")})
    msg = str(info.value)
    assert "'thigh'" in msg and "point mass" in msg and "3x3" in msg


def test_unknown_body_field_lists_the_fields():
    with pytest.raises(errors.ModelError) as info:
        build({"thigh": rod(colour="red")}, {"hip": revolute("world", "thigh")})
    msg = str(info.value)
    assert "'thigh'" in msg and "colour" in msg and "mass, com, inertia, points" in msg


def test_com_with_two_components_names_the_body():
    with pytest.raises(errors.ModelError) as info:
        build({"thigh": {"mass": 1.0, "com": [0, -0.5]}}, {"hip": revolute("world", "thigh")})
    assert "'thigh'" in str(info.value) and "three components" in str(info.value)


# --- joints and tree structure ----------------------------------------------------------------
def test_second_parent_joint_in_the_tree_points_to_the_loops_table():
    """A body hanging on two tree joints (a four-bar-like loop) is refused with the joint, the
    body, the joint it already hangs on, and where a loop-closing joint is declared."""
    with pytest.raises(errors.ModelError) as info:
        build({"a": rod(), "b": rod()},
              {"j1": revolute("world", "a"), "j2": revolute("world", "b"), "j3": revolute("a", "b")})
    msg = str(info.value)
    assert "'j3'" in msg and "'b'" in msg and "'j2'" in msg
    assert "kinematic loop" in msg and "'loops' table" in msg


def test_joint_cycle_without_the_world_is_refused():
    with pytest.raises(errors.ModelError) as info:
        build({"a": rod(), "b": rod()}, {"j1": revolute("b", "a"), "j2": revolute("a", "b")})
    msg = str(info.value)
    assert "cycle" in msg and "'world'" in msg and ("'a'" in msg or "'b'" in msg)


def test_unknown_parent_body_lists_the_bodies():
    with pytest.raises(errors.UnknownComponentError) as info:
        build({"thigh": rod(), "shank": rod()},
              {"hip": revolute("pelvis", "thigh"), "knee": revolute("thigh", "shank")})
    msg = str(info.value)
    assert "'hip'" in msg and "'pelvis'" in msg and "'world'" in msg
    assert "thigh" in msg and "shank" in msg
    assert isinstance(info.value, errors.ModelError)


def test_unknown_child_body_lists_the_bodies():
    with pytest.raises(errors.UnknownComponentError) as info:
        build({"thigh": rod()}, {"hip": revolute("world", "thigh"), "knee": revolute("thigh", "shin")})
    msg = str(info.value)
    assert "'knee'" in msg and "'shin'" in msg and "thigh" in msg


def test_body_on_no_joint_is_named():
    with pytest.raises(errors.ModelError) as info:
        build({"thigh": rod(), "foot": rod()}, {"hip": revolute("world", "thigh")})
    msg = str(info.value)
    assert "foot" in msg and "no joint" in msg and "weld" in msg


def test_unknown_joint_type_lists_the_types():
    with pytest.raises(errors.ModelError) as info:
        build({"thigh": rod()}, {"hip": {"type": "hinge", "parent": "world", "child": "thigh"}})
    msg = str(info.value)
    assert "'hip'" in msg and "'hinge'" in msg
    for kind in ("revolute", "prismatic", "translational", "weld"):
        assert kind in msg


@pytest.mark.parametrize("axes", [None, [], "xz"])
def test_translational_joint_without_axes_shows_an_example(axes):
    joint = {"type": "translational", "parent": "world", "child": "hip_body"}
    if axes is not None:
        joint["axes"] = axes
    with pytest.raises(errors.ModelError) as info:
        build({"hip_body": {"mass": 3.0}}, {"hip": joint})
    msg = str(info.value)
    assert "'hip'" in msg and "needs axes" in msg and "['x', 'z']" in msg


def test_translational_joint_with_an_unknown_axis_names_it():
    with pytest.raises(errors.ModelError) as info:
        build({"hip_body": {"mass": 3.0}},
              {"hip": {"type": "translational", "parent": "world", "child": "hip_body",
                       "axes": ["x", "w"]}})
    msg = str(info.value)
    assert "'hip'" in msg and "'w'" in msg and "'x', 'y' or 'z'" in msg


def test_translational_joint_with_a_repeated_axis_is_refused_naming_the_coordinate():
    """Two coordinates along the same axis would make the mass matrix singular; refused at the
    latest when the model compiles (a duplicated state name)."""
    with pytest.raises(errors.ModelError) as info:
        compile_symbolic(build({"hip_body": {"mass": 3.0}},
                               {"hip": {"type": "translational", "parent": "world",
                                        "child": "hip_body", "axes": ["x", "x"]}}))
    assert "hip.x" in str(info.value)


@pytest.mark.parametrize("axis", [None, [0, 0, 0], "w", [1, 0]])
def test_revolute_joint_with_a_bad_axis_names_the_joint(axis):
    joint = {"type": "revolute", "parent": "world", "child": "thigh"}
    if axis is not None:
        joint["axis"] = axis
    with pytest.raises(errors.ModelError) as info:
        build({"thigh": rod()}, {"hip": joint})
    assert "'hip'" in str(info.value) and "axis" in str(info.value)


def test_misspelt_joint_field_is_refused_naming_it():
    """A joint field the Multibody does not know (here ``orgin`` for ``origin``) must be an error
    listing the known fields, as it is for bodies: silently ignored, it puts the joint at the
    parent's origin and gives a wrong model without any message."""
    with pytest.raises(errors.ModelError) as info:
        build({"a": rod(), "b": rod()},
              {"j1": revolute("world", "a"), "j2": revolute("a", "b", orgin=[0, 0, -1.0])})
    msg = str(info.value)
    assert "'j2'" in msg and "orgin" in msg and "origin" in msg


def test_initial_values_of_the_wrong_length_name_the_joint():
    with pytest.raises(errors.ModelError) as info:
        compile_symbolic(build({"hip_body": {"mass": 3.0}},
                               {"hip": {"type": "translational", "parent": "world",
                                        "child": "hip_body", "axes": ["x", "z"], "q0": [1.0]}}))
    msg = str(info.value)
    assert "'hip'" in msg and "q0 needs 2 value(s)" in msg


def test_repeated_port_name_between_a_point_and_a_joint_is_refused():
    with pytest.raises(errors.ModelError) as info:
        build({"thigh": rod(points={"knee": [0, 0, -1]})}, {"knee": revolute("world", "thigh")})
    assert "unique" in str(info.value) and "knee" in str(info.value)


def test_plane_other_than_xz_is_refused():
    with pytest.raises(errors.ModelError) as info:
        build({"thigh": rod()}, {"hip": revolute("world", "thigh")}, plane="xy")
    assert "'xz'" in str(info.value)


def test_gravity_with_two_components_is_a_model_error_naming_gravity():
    """gravity = [0, -9.81] (a planar habit) must raise a ModelError that names the gravity
    argument, at construction or at the latest when the model compiles — not a bare sympy
    ShapeError from inside the Multibody's build."""
    with pytest.raises(errors.ModelError) as info:
        compile_symbolic(build({"thigh": rod()}, {"hip": revolute("world", "thigh")},
                               gravity=[0, -9.81]))
    assert "gravity" in str(info.value)


def test_misspelt_expression_in_a_body_names_component_and_body():
    with pytest.raises(errors.UnknownParameterError) as info:
        compile_symbolic(build({"thigh": rod(mass="m_thigh")}, {"hip": revolute("world", "thigh")}))
    msg = str(info.value)
    assert "'mb'" in msg and "'thigh'" in msg and "m_thigh" in msg


def test_missing_bodies_or_joints_show_the_expected_table():
    with pytest.raises(errors.ModelError) as info:
        build({}, {"hip": revolute("world", "thigh")})
    assert "needs 'bodies'" in str(info.value)
    with pytest.raises(errors.ModelError) as info:
        build({"thigh": rod()}, {})
    assert "needs 'joints'" in str(info.value)


# --- ports ------------------------------------------------------------------------------------
def _pendulum_model() -> ph.Model:
    model = ph.Model("pend")
    model.add("mb", build({"bob": rod(points={"tip": [0, 0, -1]})},
                          {"pivot": revolute("world", "bob")}, plane="xz"))
    model.add("j", ph.OneJunction())
    return model


def test_connecting_to_a_missing_port_lists_the_available_ports():
    model = _pendulum_model()
    with pytest.raises(errors.UnknownPortError) as info:
        model.connect("mb.knee", "j")
    msg = str(info.value)
    assert "'mb'" in msg and "Multibody" in msg and "'knee'" in msg
    assert "pivot" in msg and "tip" in msg


def test_weld_joint_has_no_port():
    model = ph.Model("welded")
    model.add("mb", build({"a": rod(), "b": rod()},
                          {"pivot": revolute("world", "a"),
                           "glue": {"type": "weld", "parent": "a", "child": "b",
                                    "origin": [0, 0, -1]}}))
    model.add("j", ph.OneJunction())
    with pytest.raises(errors.UnknownPortError) as info:
        model.connect("mb.glue", "j")
    assert "'glue'" in str(info.value) and "pivot" in str(info.value)


def test_point_port_dimension_mismatch_names_both_ports():
    """A planar point port carries (x, z): a one-dimensional force source cannot drive it."""
    model = _pendulum_model()
    model.add("force", ph.Se(effort=1.0))
    with pytest.raises(errors.DimensionMismatchError) as info:
        model.connect("force.p", "mb.tip")
    msg = str(info.value)
    assert "force.p" in msg and "mb.tip" in msg


# --- from a model file ------------------------------------------------------------------------
PENDULUM_TOML = """
bonds = [BOND]

[model]
name = "bad_pendulum"

[components.j]
type = "1"

[components.mb]
type = "Multibody"
plane = "xz"

[components.mb.bodies.bob]
mass = MASS
com = [0, 0, -1]
points = { tip = [0, 0, -1] }

[components.mb.joints.pivot]
type = "revolute"
parent = "world"
child = "bob"
axis = "y"
"""


def test_model_file_with_a_bad_body_names_the_file_component_and_body():
    text = PENDULUM_TOML.replace("BOND", "").replace("MASS", "-2.0")
    with pytest.raises(errors.ModelFileError) as info:
        io.loads(text, source="bad_pendulum.toml")
    msg = str(info.value)
    assert msg.startswith("bad_pendulum.toml")
    assert "component 'mb'" in msg and "'bob'" in msg and "mass must be positive" in msg


def test_model_file_bond_to_a_missing_port_lists_the_ports():
    text = PENDULUM_TOML.replace("BOND", '"mb.ankle -> j"').replace("MASS", "1.0")
    with pytest.raises(errors.ModelFileError) as info:
        io.loads(text, source="bad_pendulum.toml")
    msg = str(info.value)
    assert msg.startswith("bad_pendulum.toml, line 2")
    assert "'ankle'" in msg and "pivot" in msg and "tip" in msg


# --- loops and constraints (porthamiltonian.mechanics.closure) --------------------------------
TWO_RODS = {"a": rod(points={"tip_a": [0, 0, -1]}), "b": rod(points={"tip_b": [0, 0, -1]})}
TWO_PIVOTS = {"j1": revolute("world", "a"), "j2": revolute("world", "b", origin=[1, 0, 0])}


@pytest.mark.parametrize("more, kind, path, words", [
    ({"loops": {"L": {"type": "revolute", "parent": "a", "child": "c", "axis": "y"}}},
     errors.UnknownComponentError, ("loops", "L", "child"), ["'c' is not a body", "a, b, world"]),
    ({"loops": {"L": {"type": "free", "parent": "a", "child": "b"}}},
     errors.ModelError, ("loops", "L", "type"), ["type must be one of", "'free'"]),
    ({"loops": {"L": {"type": "revolute", "parent": "a", "child": "b", "axis": "y",
                      "orign": [0, 0, 0]}}},
     errors.ModelError, ("loops", "L", "orign"), ["unknown field(s) orign", "child_origin"]),
    ({"loops": {"L": {"type": "revolute", "parent": "a", "child": "a", "axis": "y"}}},
     errors.ModelError, ("loops", "L", "child"), ["parent and child are the same body"]),
    ({"loops": {"L": {"type": "universal", "parent": "a", "child": "b", "axes": ["x", "x"]}}},
     errors.ModelError, ("loops", "L", "axes"), ["must be perpendicular"]),
    ({"constraints": {"P": {"type": "point", "point": "tip_c"}}},
     errors.UnknownComponentError, ("constraints", "P", "point"), ["'tip_c'", "tip_a, tip_b"]),
    ({"constraints": {"P": {"type": "lock", "joint": "j9"}}},
     errors.UnknownComponentError, ("constraints", "P", "joint"), ["'j9'", "j1, j2"]),
    ({"constraints": {"P": {"type": "rolling", "body": "a", "axis": "y"}}},
     errors.ModelError, ("constraints", "P"), ["needs a radius (m)"]),
    ({"constraints": {"tip_a": {"type": "point", "point": "tip_b"}}},
     errors.ModelError, ("constraints", "tip_a"), ["already used"]),
    ({"constraints": {"P": {"type": "glue"}}},
     errors.ModelError, ("constraints", "P", "type"), ["point, lock, rolling, sphere", "'glue'"]),
])
def test_bad_loop_or_constraint_names_the_entry_and_field(more, kind, path, words):
    """Each malformed entry of the loops and constraints tables: its typed error names the
    entry and the field (the key path the model-file reader turns into a line)."""
    with pytest.raises(kind) as info:
        build(TWO_RODS, TWO_PIVOTS, **more)
    assert tuple(info.value.path) == path
    for word in words:
        assert word in str(info.value)


def test_every_bad_loop_and_constraint_entry_is_reported_at_once():
    """Five problems in three entries (an unknown field and an unknown child in one loop, an
    unknown type and a body closed on itself in another, a lock on an unknown joint): one
    ValidationError listing all five, each a typed error with its key path, in table order."""
    more = {"loops": {"L": {"type": "revolute", "parent": "a", "child": "c", "axis": "y",
                            "orign": [0, 0, 0]},
                      "M": {"type": "hinge", "parent": "b", "child": "b"}},
            "constraints": {"P": {"type": "lock", "joint": "j9"}}}
    with pytest.raises(errors.ValidationError) as info:
        build(TWO_RODS, TWO_PIVOTS, **more)
    found = [(type(e), tuple(e.path)) for e in info.value.problems]
    assert found == [(errors.ModelError, ("loops", "L", "orign")),
                     (errors.UnknownComponentError, ("loops", "L", "child")),
                     (errors.ModelError, ("loops", "M", "type")),
                     (errors.ModelError, ("loops", "M", "child")),
                     (errors.UnknownComponentError, ("constraints", "P", "joint"))]
    assert "5 problems" in str(info.value) and "loop 'M'" in str(info.value)


def test_bad_loop_entries_in_a_model_file_are_each_given_their_line():
    """The same collection read from a model file: one ModelFileError, one line per problem."""
    text = (ROOT / "models" / "four_bar.toml").read_text()
    text = text.replace('child = "rocker"\norigin = ["b", 0, 0]',
                        'child = "rockr"\norign = ["b", 0, 0]')
    assert "rockr" in text
    text += ('\n[components.linkage.constraints.E]\ntype = "lock"\njoint = "nope"\n')
    with pytest.raises(errors.ModelFileError) as info:
        io.loads(text, "bad_four_bar.toml")
    lines = str(info.value).splitlines()
    assert lines[0] == "bad_four_bar.toml: 3 problems:"
    numbers = [int(line.split(":")[0].split()[-1]) for line in lines[1:]]
    where = text.splitlines()
    assert [where[n - 1].split("=")[0].strip() for n in numbers] == ["orign", "child", "joint"]
    assert all("component 'linkage'" in line for line in lines[1:])


def test_more_constraint_rows_than_velocities_is_refused_when_compiling():
    """Two rods on two pivots with the tips joined twice in x and z: 4 rows on 2 velocities."""
    joined = {"type": "point", "point": "tip_a", "to": "tip_b", "axes": ["x", "z"]}
    mb = build(TWO_RODS, TWO_PIVOTS, constraints={"P": joined, "Q": dict(joined)})
    with pytest.raises(errors.ModelError) as info:
        compile_symbolic(mb)
    assert "4 constraint rows (P: 2, Q: 2) on 2 velocities" in str(info.value)


def test_dependent_constraint_rows_are_refused_with_the_rank(isolated_cache):
    """The tips joined twice along x (2 rows on 2 velocities, rank 1): the run is refused before
    it starts with a ModelError naming both constraints, the dependent rows and the rank (the
    saddle-point matrix is singular, so no multiplier exists)."""
    joined = {"type": "point", "point": "tip_a", "to": "tip_b", "axes": ["x"]}
    model = ph.Model("redundant")
    model.add("mb", build(TWO_RODS, TWO_PIVOTS, constraints={"P": joined, "Q": dict(joined)}))
    compiled = ph.compile_model(model, backend="python")
    with pytest.raises(errors.ModelError) as info:
        compiled.simulate(0.1)
    msg = str(info.value)
    assert "rank 1" in msg and "P, Q" in msg and "P.x, Q.x" in msg and "redundant" in msg


def test_a_configuration_that_cannot_be_assembled_is_refused_with_the_residual(isolated_cache):
    """A rod's tip (1 m from its pivot) held on the line x = 3 m: no configuration
    closes; the StateError quotes the residual after the Newton steps and the rows furthest
    off."""
    pin = {"type": "point", "point": "tip_a", "position": [3, 0, 0], "axes": ["x"]}
    model = ph.Model("unreachable")
    model.add("mb", build(TWO_RODS, TWO_PIVOTS, constraints={"pin": pin}))
    compiled = ph.compile_model(model, backend="python")
    with pytest.raises(errors.StateError) as info:
        compiled.simulate(0.1)
    msg = str(info.value)
    assert "cannot be assembled" in msg and "residual 2" in msg and "pin.x" in msg


def test_the_kernel_solves_loops_and_constraints_and_auto_writes_small_ones_out():
    """``formulation = "kernel"`` with a constraint calls the kernel's constrained entry (the
    numbers: tests/validation/test_closed_loops_kernel.py), after the state entry whose work it
    reuses; ``"auto"`` writes a small closed tree out symbolically even with an axis off the
    coordinate axes (which gives an open tree the kernel), and gives a closed tree of more than
    KERNEL_LINKS links the kernel, as an open one."""
    joined = {"type": "point", "point": "tip_a", "to": "tip_b", "axes": ["x"]}
    calls = compile_symbolic(build(TWO_RODS, TWO_PIVOTS, constraints={"P": joined},
                                   formulation="kernel")).calls
    assert {call.entry for call in calls.values()} >= {"mb_state", "mb_constrained"}
    assert calls["mb.mb.constrained"].after == "mb.mb.state"
    tilted = {"j1": revolute("world", "a", axis=[0.6, 0, 0.8]),
              "j2": revolute("world", "b", origin=[1, 0, 0])}
    assert compile_symbolic(build(TWO_RODS, tilted)).calls            # auto: the kernel
    assert not compile_symbolic(build(TWO_RODS, tilted, constraints={"P": joined})).calls
    chain = {f"l{k}": rod(points={f"tip{k}": [0, 0, -1]}) for k in range(KERNEL_LINKS + 1)}
    hinges = {f"j{k}": revolute("world" if k == 0 else f"l{k - 1}", f"l{k}",
                                origin=[0, 0, 0 if k == 0 else -1])
              for k in range(KERNEL_LINKS + 1)}
    pinned = {"P": {"type": "point", "point": f"tip{KERNEL_LINKS}", "axes": ["x"]}}
    assert compile_symbolic(build(chain, hinges)).calls
    assert compile_symbolic(build(chain, hinges, constraints=pinned)).calls

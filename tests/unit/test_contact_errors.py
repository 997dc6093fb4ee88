"""User errors of the contact, friction and spring library (porthamiltonian.library): each raises
its typed exception (porthamiltonian.errors) with a message naming the component and the argument
(and, where there is one, the fix). Checked when the model is compiled (``symbolic``), where the
component's name is known, and from a model file (``io.loads`` then ``compile_model``)."""
from __future__ import annotations

import pytest

import porthamiltonian as ph
from porthamiltonian import errors, io, symbolic
from porthamiltonian.library import (
    HuntCrossley,
    KelvinVoigt,
    SCVSFriction,
    SpringDamper,
    VariableSpringDamper,
)

BALL = dict(bodies={"b": {"mass": 1.0, "inertia": 0, "points": {"tip": [0, 0, 0]}}},
            joints={"drop": {"type": "translational", "parent": "world", "child": "b",
                             "axes": ["x", "z"], "q0": [0, 0.1]}},
            plane="xz")


def contact_model(contact, friction=None) -> ph.Model:
    """A ball whose point 'tip' is bonded to ``contact`` (named 'floor'), and to ``friction``
    (named 'fric') through a 1-junction when given."""
    m = ph.Model("contact_errors")
    m.parameter("K", 1e6)
    m.add("ball", ph.Multibody(**BALL))
    m.add("floor", contact)
    if friction is None:
        m.connect("ball.tip", "floor.p")
    else:
        m.add("j", ph.OneJunction())
        m.add("fric", friction)
        m.connect("ball.tip", "j")
        m.connect("j", "floor.p")
        m.connect("j", "fric.p")
    return m


def hc(**args):
    return HuntCrossley(**{"x": "ball.tip.x", "z": "ball.tip.z", "stiffness": "K",
                           "damping": 1e5, **args})


def kv(**args):
    return KelvinVoigt(**{"x": "ball.tip.x", "z": "ball.tip.z", "stiffness": "K",
                          "damping": 100.0, **args})


def scvs(**args):
    return SCVSFriction(**{"normal_force": "floor.Fn", "mu_st": 0.5, "mu_c": 0.25, "mu_v": 0.025,
                           "slope": 500, "v_st": 0.02, **args})


def assert_names(err: Exception, *words: str) -> None:
    msg = str(err)
    for word in words:
        assert word in msg, (word, msg)


# --- normal contact ----------------------------------------------------------------------------
@pytest.mark.parametrize("make", [hc, kv], ids=["HuntCrossley", "KelvinVoigt"])
@pytest.mark.parametrize("argument", ["stiffness", "damping"])
def test_negative_stiffness_or_damping_names_component_and_argument(make, argument):
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(contact_model(make(**{argument: -2.0})))
    assert_names(info.value, "'floor'", f"'{argument}'", ">= 0", "-2")


def test_negative_stiffness_as_an_expression_is_caught_too():
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(contact_model(hc(stiffness="-3*2")))
    assert_names(info.value, "'floor'", "'stiffness'", "-6")


@pytest.mark.parametrize("n", [0, 0.0, -1.5])
def test_non_positive_exponent_names_component_and_argument(n):
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(contact_model(hc(exponent=n)))
    assert_names(info.value, "'floor'", "'exponent'", "> 0")


def test_negative_mode_flag_is_rejected():
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(contact_model(hc(active=-1)))
    assert_names(info.value, "'floor'", "'active'")


def test_unknown_surface_names_component_argument_and_the_known_surfaces():
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(contact_model(hc(surface="slop")))
    assert_names(info.value, "'floor'", "'surface'", "'slop'", "'plane'", "'slope'", "'step'")


def test_plane_with_a_slope_points_to_the_slope_surface():
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(contact_model(hc(slope=0.1)))
    assert_names(info.value, "'floor'", "'plane'", "slope", "surface = 'slope'")


def test_slope_with_a_step_points_to_the_step_surface():
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(contact_model(hc(surface="slope", slope=0.1, step_height=0.01)))
    assert_names(info.value, "'floor'", "step_height", "surface = 'step'")


def test_negative_step_height_is_rejected():
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(contact_model(hc(surface="step", step_height=-0.01)))
    assert_names(info.value, "'floor'", "'step_height'")


def test_kelvin_voigt_clip_must_be_a_boolean():
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(contact_model(kv(clip="yes")))
    assert_names(info.value, "'floor'", "'clip'", "true or false")


def test_contact_without_position_signals_names_the_missing_arguments():
    with pytest.raises(errors.ModelError) as info:
        HuntCrossley(stiffness=1e6)
    assert_names(info.value, "HuntCrossley", "x", "z")


def test_contact_position_naming_an_unknown_component_names_the_argument():
    with pytest.raises(errors.UnknownParameterError) as info:
        symbolic(contact_model(hc(z="bal.tip.z")))
    assert_names(info.value, "'floor'", "'z'", "bal.tip.z")


# --- friction ----------------------------------------------------------------------------------
def test_friction_without_normal_force_source_names_the_friction_component():
    with pytest.raises(errors.DanglingPortError) as info:
        symbolic(contact_model(hc(), scvs(normal_force=None)))
    assert_names(info.value, "'fric'", "normal-force source", "normal_force", ".Fn")


@pytest.mark.parametrize("source", ["ball.tip.z", "9.81", "K*1e-5"])
def test_friction_normal_force_that_is_not_a_contact_force_names_the_argument(source):
    with pytest.raises(errors.UnknownParameterError) as info:
        symbolic(contact_model(hc(), scvs(normal_force=source)))
    assert_names(info.value, "'fric'", "'normal_force'", "contact's normal force", source)


def test_friction_normal_force_of_an_unknown_component_names_the_argument():
    with pytest.raises(errors.UnknownParameterError) as info:
        symbolic(contact_model(hc(), scvs(normal_force="flor.Fn")))
    assert_names(info.value, "'fric'", "'normal_force'", "flor.Fn")


def test_friction_reading_two_contacts_is_rejected():
    model = contact_model(hc(), scvs(normal_force="floor.Fn + wall.Fn"))
    model.add("wall", hc(surface="slope", slope=1.5))
    model.connect("j", "wall.p")
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(model)
    assert_names(info.value, "'fric'", "'normal_force'", "floor", "wall", "one friction element")


def test_coulomb_above_static_friction_names_both_arguments():
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(contact_model(hc(), scvs(mu_c=0.6, mu_st=0.5)))
    assert_names(info.value, "'fric'", "'mu_c'", "'mu_st'", "0.6", "0.5")


@pytest.mark.parametrize("argument, value, rule", [("mu_st", -0.1, ">= 0"), ("mu_v", -1, ">= 0"),
                                                   ("slope", -5, ">= 0"), ("v_st", 0, "> 0"),
                                                   ("v_st", -0.02, "> 0")])
def test_negative_friction_parameters_name_component_and_argument(argument, value, rule):
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(contact_model(hc(), scvs(**{argument: value})))
    assert_names(info.value, "'fric'", f"'{argument}'", rule)


# --- springs -----------------------------------------------------------------------------------
def spring_model(spring) -> ph.Model:
    m = ph.Model("spring_errors")
    m.parameter("k", 100.0)
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0))
    m.add("leg", spring)
    m.connect("j", "mass.p")
    m.connect("j", "leg.p")
    return m


@pytest.mark.parametrize("cls", [SpringDamper, VariableSpringDamper])
@pytest.mark.parametrize("args, argument", [({"stiffness": -1.0}, "stiffness"),
                                            ({"stiffness": "k", "damping": -0.5}, "damping"),
                                            ({"stiffness": "k", "alpha": -0.1, "mass": 1}, "alpha"),
                                            ({"stiffness": "k", "alpha": 0.1, "mass": -1}, "mass")])
def test_negative_spring_parameters_name_component_and_argument(cls, args, argument):
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(spring_model(cls(**args)))
    assert_names(info.value, "'leg'", f"'{argument}'", ">= 0")


def test_damping_and_damper_rule_together_are_rejected():
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(spring_model(SpringDamper(stiffness="k", damping=1.0, alpha=0.1, mass=1.0)))
    assert_names(info.value, "'leg'", "'damping'", "'alpha'", "'mass'")


@pytest.mark.parametrize("given, missing", [({"alpha": 0.15}, "alpha"), ({"mass": 3.1}, "mass")])
def test_damper_rule_needs_alpha_and_mass(given, missing):
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(spring_model(VariableSpringDamper(stiffness="k", **given)))
    assert_names(info.value, "'leg'", "'alpha'", "'mass'", f"only {missing}")


@pytest.mark.parametrize("stiffness", ["k*(1 + sin(t))", "k*(1 + mass.p**2)"])
def test_linear_spring_with_modulated_stiffness_points_to_the_variable_spring(stiffness):
    with pytest.raises(errors.ParameterValueError) as info:
        symbolic(spring_model(SpringDamper(stiffness=stiffness)))
    assert_names(info.value, "'leg'", "'stiffness'", "VariableSpringDamper")


# --- from a model file -------------------------------------------------------------------------
def test_model_file_error_names_the_file_and_the_component():
    text = (io.models_dirs()[-1] / "block_on_incline.toml").read_text()
    text = text.replace('mu_st = "mu_st", mu_c = "mu_c"', 'mu_st = 0.5, mu_c = 0.7')
    record = io.reads(text, source="bad_incline.toml")
    with pytest.raises(errors.ModelFileError) as info:
        record.compile(backend="python", use_cache=False)
    assert_names(info.value, "bad_incline.toml", "'friction'", "'mu_c'", "'mu_st'")


def test_model_file_with_friction_lacking_its_normal_force_names_the_component():
    text = (io.models_dirs()[-1] / "block_on_incline.toml").read_text()
    text = text.replace('normal_force = "ground.Fn", ', "")
    record = io.reads(text, source="no_normal.toml")
    with pytest.raises(errors.ModelFileError) as info:
        record.compile(backend="python", use_cache=False)
    assert_names(info.value, "no_normal.toml", "'friction'", "normal-force source")

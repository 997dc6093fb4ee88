"""Walker files are the walkers (docs/walkers.md): a model plus its ``[walker]`` table.

* every shipped walker loads from its file alone, and load -> save -> load gives the same
  description, the same model and (simplest walker, nominal walker) the same gait, bit for bit;
* a walker built in Python from components plus the description's dataclasses walks the gait
  of the same walker loaded from its file (to 1e-9);
* an edited component is honoured (one foot's SCVS friction swapped for a viscous damper);
* a bad description is a ModelFileError naming the file, the line and the part, before any
  model is compiled; several problems are reported together;
* the transitions expose what saltation matrices need (guard, reset map and its Jacobian).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from porthamiltonian import Model, Multibody, Revolute, RigidBody, Weld, io
from porthamiltonian.errors import ModelFileError
from walker_library import (
    Completion,
    Foot,
    HybridWalker,
    Rule,
    Section,
    Terrain,
    WalkerSpec,
    analyze_gait,
    build_walker,
    compass_walker,
    load_walker,
    read_walker,
    save_walker,
    simplest_walker,
)
from walker_library.core.files import SHIPPED
from walker_library.core.hybrid import Integration
from walker_library.core.reading import walker_spec

MODELS = Path(io.__file__).resolve().parents[2] / "models"


# --- files round-trip ----------------------------------------------------------------------------
@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_walker_file_round_trips(name, tmp_path):
    """read -> save -> read: the same WalkerSpec (every rule, the section, the relabelling, ...)
    and the same model (components, bonds, parameters, events)."""
    spec, _ = read_walker(name)
    again, _ = read_walker(save_walker(spec, tmp_path / f"{name}.toml"))
    assert again == spec
    a, b = io.model_to_dict(spec.model), io.model_to_dict(again.model)
    for key in ("components", "bonds", "parameters", "events"):
        assert a[key] == b[key], key


@pytest.mark.parametrize("make", [simplest_walker, compass_walker])
def test_a_saved_walker_walks_the_same_gait(make, tmp_path):
    """The gait of a saved walker is the original's, bit for bit (same compiled model)."""
    w = make()
    again = load_walker(save_walker(w, tmp_path / "copy.toml"))
    z = w.initial_guess()
    np.testing.assert_array_equal(again.initial_guess(), z)
    a, b = w.walk(z, 2), again.walk(z, 2)
    np.testing.assert_array_equal(a[-1].z_next, b[-1].z_next)
    assert [s.duration for s in a] == [s.duration for s in b]


# --- the same walker, built in Python --------------------------------------------------------------
def python_simplest_walker() -> HybridWalker:
    """Garcia's simplest walker from components and the description's dataclasses (what
    models/simplest_walker.toml says, written in Python)."""
    m = Model("simplest_walker_py")
    for name, value in (("slope", 0.009), ("M", 1.0), ("beta", 1e-9), ("l", 1.0), ("g", 1.0),
                        ("theta0", 0.2), ("theta_dot0", -0.2), ("phi_dot0", -0.015),
                        ("contact_margin", 1e-12), ("fall_fraction", 0.5), ("stance_x", 0.0),
                        ("stance_z", 0.0), ("ground_z", 0.0), ("step_down", 0.0)):
        m.parameter(name, value)
    m.add("walker", Multibody(
        bodies={"stance_leg": RigidBody(mass="M", com=[0, 0, "l"],
                                        points={"hip_centre": [0, 0, "l"], "stance_foot": [0, 0, 0]}),
                "swing_leg": RigidBody(mass="beta*M", com=[0, 0, "-l"],
                                       points={"swing_foot": [0, 0, "-l"]}),
                "stance_foot_body": RigidBody(mass="beta*M")},
        joints={"stance": Revolute(parent="world", child="stance_leg", axis="y",
                                   origin=["stance_x", 0, "stance_z"], q0="-theta0", v0="-theta_dot0"),
                "hip": Revolute(parent="stance_leg", child="swing_leg", axis="y", origin=[0, 0, "l"],
                                q0="2*theta0", v0="phi_dot0"),
                "stance_ankle": Weld(parent="stance_leg", child="stance_foot_body")},
        gravity=["g*sin(slope)", 0, "-g*cos(slope)"], plane="xz"))
    m.event("heel_strike", "walker.swing_foot.z - ground_z + contact_margin", direction=-1)
    m.event("fall", "walker.hip_centre.z - stance_z - fall_fraction*l", direction=-1)
    spec = WalkerSpec(
        model=m,
        feet=(Foot("stance", "walker.stance_foot"), Foot("swing", "walker.swing_foot")),
        modes={"stance_x": 0.0, "stance_z": 0.0, "ground_z": "-step_down"},
        rules=(Rule("heel_strike", when=("walker.swing_foot.x - stance_x > 1e-6*l",),
                    set={"stance_x": "walker.swing_foot.x", "stance_z": "walker.swing_foot.z"},
                    foot="swing", impact="walker.swing_foot", heel_strike=True),
               Rule("fall", fall=True)),
        section=Section(("walker.q.stance", "walker.v.stance", "walker.v.hip"),
                        complete=(Completion("walker.q.hip", value="-2*walker.q.stance"),),
                        thesis={"theta_dot": "-walker.v.stance", "phi": "-2*walker.q.stance",
                                "phi_dot": "walker.v.hip"},
                        stance="stance"),
        angles={"theta": "-walker.q.stance", "phi": "walker.q.hip"},
        terrain=Terrain("step_down", ("ground_z",)),
        relabel={"walker.q.stance": "walker.q.stance + walker.q.hip", "walker.q.hip": "-walker.q.hip"},
        guess={"walker.q.stance": "-theta0", "walker.v.stance": "-theta_dot0",
               "walker.v.hip": "phi_dot0"},
        integration=Integration(backend="python", method="DOP853", rtol=1e-12, atol=1e-24,
                                max_step=0.25, max_step_time=20.0),
        mass="M*(1 + 2*beta)", leg_length="l", hip="walker.hip_centre")
    return build_walker(spec)


def test_python_built_walker_walks_the_file_walkers_gait():
    """The simplest walker built in Python and loaded from its file: the same gait to 1e-9 (fixed
    point, step period, multipliers)."""
    a, b = analyze_gait(python_simplest_walker()), analyze_gait(simplest_walker())
    assert a.status == b.status == "periodic"
    for key in ("theta", "theta_dot", "phi", "phi_dot"):
        assert a.fixed_point[key] == pytest.approx(b.fixed_point[key], abs=1e-9)
    assert a.metrics.step_period == pytest.approx(b.metrics.step_period, abs=1e-9)
    ma, mb = (sorted(r.floquet_multipliers, key=lambda c: (c.real, c.imag)) for r in (a, b))
    assert max(abs(x - y) for x, y in zip(ma, mb)) < 1e-9


# --- an edited component is honoured ------------------------------------------------------------------
def test_swapping_one_foots_friction_for_a_viscous_damper_changes_the_walk(tmp_path):
    """fric1 (SCVS friction at foot 1's sole, compass_walker_sole_friction: a 2-D point port)
    becomes a linear viscous damper on the sole point while foot 1's contact is on (R on the 2-D
    point port, resistance B_sole·c1): the walker is that edited model (its component kinds), it
    walks with a closed ledger, and its stride is not the original's (C back end in both
    passes: the subject is the edited description, and numba would compile the edited model's
    functions for this one test, ~40 s in the numba pass)."""
    text = (MODELS / "compass_walker_sole_friction.toml").read_text()
    line = next(ln for ln in text.splitlines() if ln.startswith("fric1 = "))
    edited = text.replace(line, 'fric1 = { type = "R", dim = 2, resistance = "B_sole*c1" }').replace(
        "lam = { value", 'B_sole = { value = 5.0, unit = "N*s/m", doc = "sole damper" }\nlam = { value', 1)
    path = tmp_path / "viscous_foot.toml"
    path.write_text(edited)
    w = load_walker(path, backend="c")
    assert w.spec.model.component("fric1").kind == "R"
    assert w.spec.model.component("fric2").kind == "SCVSFriction"
    original = load_walker("compass_walker_sole_friction", backend="c")
    z = original.initial_guess()
    a, b = original.stride(z), w.stride(z, record=True)
    assert a.status == "step"
    assert np.max(np.abs(b.info["trajectory"].residual)) < 1e-7
    assert b.status != a.status or abs(a.duration - b.duration) > 1e-4


# --- bad descriptions ---------------------------------------------------------------------------------
def _line(text: str, needle: str) -> int:
    return next(i for i, ln in enumerate(text.splitlines(), 1) if needle in ln)


@pytest.fixture
def no_compilation(monkeypatch):
    """Fail the test if a walker's model gets compiled."""
    from walker_library.core import walker as core

    def refuse(*a, **k):
        raise AssertionError("a model was compiled before the description was checked")
    monkeypatch.setattr(core, "compile_model", refuse)


@pytest.mark.parametrize("name,old,new,needle,part", [
    ("compass_walker", 'foot1 = { point = "walker.foot1", contact = "floor1" }',
     'foot1 = { point = "walker.foot1", contact = "floor3" }', 'contact = "floor3"',
     "foot 'foot1': contact 'floor3' is not a component"),
    ("compass_walker", '"walker.q.leg2" = "walker.q.leg1"\n', '"walker.q.leg2" = "walker.q.leg2"\n',
     '"walker.q.leg2" = "walker.q.leg2"', "not a permutation"),
    ("simplest_walker", 'coordinates = ["walker.q.stance", "walker.v.stance", "walker.v.hip"]',
     'coordinates = ["walker.q.stance", "walker.v.stance", "walker.v.knee"]', "walker.v.knee",
     "section coordinate 'walker.v.knee' is not a state"),
    ("simplest_walker", 'guard = "walker.swing_foot.z - ground_z + contact_margin"',
     'guard = "walker.swing_toe.z - ground_z + contact_margin"', "walker.swing_toe.z",
     "event 'heel_strike' guard"),
    ("compass_walker", 'if = ["c1 == 0", "walker.foot1.x - walker.foot2.x > front_margin"]',
     'if = ["c1 == 0", "walker.foot1.x - walker.foot3.x > front_margin"]', "walker.foot3.x",
     "[[walker.rules]] #3 condition"),
    # found by fuzzing the [walker] tables (each was a TypeError, IndexError, StopIteration or
    # ValueError from inside the walker, or a run-time error without the file's name)
    ("compass_walker", 'foot = "foot1"', "foot = []", "foot = []",
     "[[walker.rules]] #3 foot must be a non-empty string, got []"),
    ("compass_gait", 'hip = "walker.hip_centre"\n', "", "[walker]",
     "[walker] hip is missing: a walker with impact rules needs it"),
    ("compass_walker", 'stance = "foot1"\n', "", "[walker.section]",
     ("[walker.section] stance is missing: the foot that stands on the surface at the section, "
      "one of foot1, foot2")),
    ("compass_walker", 'drop = "step_down"\n', "", "[walker.terrain]",
     "[walker.terrain] drop is missing"),
    ("compass_walker", 'method = "Rodas5P"', 'method = "numba"', 'method = "numba"',
     "[walker.integration] unknown method 'numba'; choose 'auto' or one of Rodas4, Rodas5P"),
    ("compass_walker", 'backend = "auto"', 'backend = "gpu"', 'backend = "gpu"',
     "[walker.integration] backend must be \"auto\" or one of c, numba, python, got 'gpu'"),
    ("compass_walker", "rtol = 1e-9,", "rtol = 1e-300,", "rtol = 1e-300,",
     "[walker.integration] rtol must be >= 2.22e-14"),
    ("compass_walker", "rtol = 1e-9,", "rtol = 1e-9, max_steps_per_stride = 2.5,",
     "max_steps_per_stride = 2.5",
     ("[walker.integration] max_steps_per_stride must be a whole number of steps up to 1e9, "
      "got 2.5")),
    ("compass_walker", "rtol = 1e-9,", "rtol = 1e-9, max_steps_per_stride = 10000000000,",
     "max_steps_per_stride = 1", "max_steps_per_stride must be a whole number"),
    ("compass_walker", "rtol = 1e-9,", "rtol = 1e-9, max_steps_per_stride = 0,",
     "max_steps_per_stride = 0",
     "[walker.integration] max_steps_per_stride must be a positive number, got 0"),
])
def test_a_bad_description_names_file_line_and_part(name, old, new, needle, part, tmp_path,
                                                    no_compilation):
    text = (MODELS / f"{name}.toml").read_text()
    assert old in text
    bad = tmp_path / f"bad_{name}.toml"
    bad.write_text(text.replace(old, new, 1))
    with pytest.raises(ModelFileError) as err:
        load_walker(bad)
    msg = str(err.value)
    assert msg.startswith(f"{bad}, line {_line(bad.read_text(), needle)}:"), msg
    assert part in msg


def test_several_problems_are_reported_together(tmp_path, no_compilation):
    text = (MODELS / "simplest_walker.toml").read_text()
    text = text.replace('foot = "swing"', 'foot = "swimg"').replace('on = "fall"', 'on = "falls"')
    text = text.replace('slope = "(-pi/4, pi/4)"', 'slope = "(-pi/4; pi/4)"')
    bad = tmp_path / "three.toml"
    bad.write_text(text)
    with pytest.raises(ModelFileError) as err:
        load_walker(bad)
    msg = str(err.value)
    assert msg.startswith(f"{bad}: 3 problems in its [walker] table")
    for needle in ("foot 'swimg'", "on = 'falls' is not an event", "range of 'slope'"):
        assert needle in msg
    for needle in ('foot = "swimg"', 'on = "falls"', 'slope = "(-pi/4; pi/4)"'):
        assert f"line {_line(text, needle)}:" in msg


def test_a_model_without_walker_table_is_not_a_walker(no_compilation):
    with pytest.raises(ModelFileError, match="not a walker file"):
        load_walker("pendulum")


def test_walker_spec_from_a_table_in_python():
    """walker_spec reads a table as TOML gives it (the Python route to the same dataclasses)."""
    spec, _ = read_walker("rimless_wheel")
    again = walker_spec(spec.model, spec.to_table())
    assert again == spec


# --- what the transitions expose ------------------------------------------------------------------
def test_transitions_expose_guard_reset_and_jacobian():
    """For saltation matrices: each transition's guard is the model's compiled event guard (zero
    at the recorded heel strike), its parameters after, and its reset map with a Jacobian; the
    rigid impact's Jacobian against a central difference of the map itself, the relabelling's is
    its matrix (exact)."""
    w = simplest_walker()
    s = w.stride(w.initial_guess())
    fired = s.info["fired"][-1]
    tr = fired.transition
    assert tr.heel_strike and tr.impact is not None and tr.direction == -1
    assert abs(tr.guard(w.model, fired.t, fired.x_minus, fired.p_minus)) < 1e-12
    J = tr.reset_jacobian(fired.t, fired.x_minus, fired.p_minus)
    assert J.shape == (w.model.n_states,) * 2 and np.all(np.isfinite(J))
    x_plus, p_plus, _ = tr.apply(fired.t, fired.x_minus, fired.p_minus,
                                 w.outputs(fired.t, fired.x_minus, fired.p_minus))
    np.testing.assert_array_equal(x_plus, fired.x_plus)
    np.testing.assert_array_equal(p_plus, fired.p_plus)
    np.testing.assert_array_equal(tr.impact.relabel.matrix(), [[1.0, 1.0], [0.0, -1.0]])
    assert math.isclose(float(p_plus[w.model.param_names.index("stance_x")]),
                        w.output("walker.swing_foot.x", fired.x_minus, fired.p_minus))


def test_a_built_walker_loads_without_symbolic_work_and_a_damaged_layout_is_rebuilt(
        tmp_path, monkeypatch):
    """The names a description is checked against (the model's layout) are computed once per
    model and kept by the compiler in the model's cache entry (verified by sha256): a second
    load runs no symbolic compiler; a damaged layout file is detected (one warning), the layout
    computed again, and the walker is the same. (The loads after the first read the file in
    full, as a load without a walker snapshot does: test_warm_start.py tests the snapshot.)"""
    from porthamiltonian import compiler
    from porthamiltonian.compiler import cache
    monkeypatch.setenv("PORTHAMILTONIAN_CACHE", str(tmp_path / "cache"))
    calls = []
    real = compiler._symbolic_model          # (behind symbolic() and every build)
    monkeypatch.setattr(compiler, "_symbolic_model",
                        lambda m, claim: calls.append(1) or real(m, claim))

    def full_read():
        spec, text = read_walker("simplest_walker")
        return build_walker(spec, backend="python", text=text)

    first = load_walker("simplest_walker", backend="python")
    assert len(calls) == 3      # the layout; the walker's model; the impact's floating model
    again = full_read()
    assert len(calls) == 3 and again.plan.outputs == first.plan.outputs
    path = cache.verified_path(cache.model_key(first.spec.frozen), "layout.json")
    path.write_text(path.read_text().replace("slope", "slope_"))
    with pytest.warns(UserWarning, match="layout.json"):
        damaged = full_read()
    assert len(calls) == 4
    assert damaged.plan.names == first.plan.names
    np.testing.assert_array_equal(damaged.initial_guess(), first.initial_guess())


# --- one warm load: each product built once ----------------------------------------------------------
def _walker_expressions(table: dict) -> int:
    """How many expressions a [walker] table holds (each a place in the file): start values,
    conditions (two sides each), set values, relabelling, angles, guess and its helpers, range
    bounds (two each), completions (a value, or the sides of an equation that are not section
    coordinates), thesis coordinates, the labelling (two sides), mass and leg length."""
    section = table["section"]
    coords = set(section["coordinates"])
    completions = 0
    for entry in section.get("complete", {}).values():
        if isinstance(entry, dict) and "such_that" in entry:
            completions += sum(side.strip() not in coords
                               for side in entry["such_that"].split("="))
        else:
            completions += 1
    guess = table.get("guess", {})
    return (len(table.get("modes", {}))
            + sum(2 * len(r.get("if", [])) + len(r.get("set", {})) for r in table["rules"])
            + len(table.get("relabel", {})) + len(table.get("angles", {}))
            + len([k for k in guess if k != "where"]) + len(guess.get("where", {}))
            + sum(b.strip(" []()").lower().lstrip("+-") != "inf"
                  for r in table.get("ranges", {}).values()
                  for b in r.removesuffix("integer").strip().split(","))
            + completions + len(section.get("thesis", {}))
            + 2 * ("labelling" in section) + 2)


def test_a_warm_load_freezes_the_model_once_and_parses_each_expression_once(monkeypatch):
    """One warm load of "compliant_leg_walker" read in full (its layout and compiled model
    cached, no walker snapshot: test_warm_start.py tests that one) freezes the model once and
    parses no expression twice: at most one parse per expression of the file (the model's: every
    expression field of its components, its events' guards and its outputs; the walker table's:
    counted from the TOML table). It used to freeze the model 5 times and parse 289 expressions
    (each of the 16 condition strings 3 times)."""
    import sys

    from porthamiltonian.modeling import expressions
    from porthamiltonian.modeling.model import Model as ModelClass
    load_walker("compliant_leg_walker")                  # warm the cache
    record = io.read("compliant_leg_walker")
    frozen = record.frozen
    in_model = (sum(len(list(c.expression_fields())) for c in frozen.components.values())
                + len(frozen.events) + len(frozen.outputs))
    in_table = _walker_expressions(record.sections["walker"])
    parses, freezes = [], []
    real_parse, real_freeze = expressions.parse, ModelClass.freeze

    def parse(text, *args, **kwargs):
        parses.append(text)
        return real_parse(text, *args, **kwargs)

    def freeze(self):
        freezes.append(self.name)
        return real_freeze(self)

    for module in list(sys.modules.values()):
        if getattr(module, "parse", None) is real_parse:
            monkeypatch.setattr(module, "parse", parse)
    monkeypatch.setattr(ModelClass, "freeze", freeze)
    spec, text = read_walker("compliant_leg_walker")
    walker = build_walker(spec, text=text)
    assert freezes == ["compliant_leg_walker"]
    assert 0 < len(parses) <= in_model + in_table, (len(parses), in_model, in_table)
    assert walker.initial_guess().shape == (10,)

"""User errors: each raises its typed exception (porthamiltonian.errors) with a message naming the
parts involved; integration failures end with a status and a message, never a traceback."""
from __future__ import annotations

import math
import re

import numpy as np
import pytest

import porthamiltonian as ph
from porthamiltonian import errors, io
from porthamiltonian.compiler import compile_model, symbolic
from porthamiltonian.modeling.component import component_class


class Planar(ph.Component):
    """A 2-dimensional translational damper (test-only): e = b f on a planar port (power in)."""

    kind = "TestPlanarDamper"
    arguments = {"damping": ph.Arg("damping", "N*s/m")}

    def ports(self):
        return [ph.Port("p", "translation", dim=2, orientation="in")]

    def build(self, b, damping):
        p = b.port("p")
        b.equation(p.e, damping * p.f, "e = b f")
        b.dissipate(p.power)


def _mass_spring() -> ph.Model:
    m = ph.Model("ms")
    m.parameter("k", 4.0)
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0))
    m.add("spring", ph.C(stiffness="k", q0=0.1))
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    return m


# --- connection errors ------------------------------------------------------------------------
def test_domain_mismatch_names_both_ports():
    m = ph.Model("x")
    m.add("cap", ph.C(domain="electric", stiffness=1.0))
    m.add("force", ph.Se(effort=1.0))
    with pytest.raises(errors.DomainMismatchError) as info:
        m.connect("force.p", "cap.p")
    msg = str(info.value)
    assert "force.p" in msg and "cap.p" in msg
    assert "translation" in msg and "electric" in msg
    assert isinstance(info.value, errors.ConnectError)


def test_dimension_mismatch_names_both_ports():
    m = ph.Model("x")
    m.add("force", ph.Se(effort=1.0))
    m.add("planar", Planar(damping=1.0))
    with pytest.raises(errors.DimensionMismatchError) as info:
        m.connect("force.p", "planar.p")
    msg = str(info.value)
    assert "force.p" in msg and "planar.p" in msg
    assert "dimension 1" in msg and "dimension 2" in msg


def test_orientation_error_names_the_port_and_the_fix():
    m = ph.Model("x")
    m.add("spring", ph.C(stiffness=1.0))
    m.add("force", ph.Se(effort=1.0))
    with pytest.raises(errors.OrientationError) as info:
        m.connect("spring.p", "force.p")  # a storage's port takes power in: it cannot be a tail
    msg = str(info.value)
    assert "spring.p" in msg and "force.p" in msg
    m.add("j", ph.OneJunction())
    with pytest.raises(errors.OrientationError) as info:
        m.connect("j", "force.p")  # a source's port gives power out: it cannot be a head
    assert "force.p" in str(info.value) and "j." in str(info.value)


def _c_and_i() -> ph.Model:
    m = ph.Model("x")
    m.add("spring", ph.C(stiffness=4.0))
    m.add("mass", ph.I(inertance=1.0))
    return m


@pytest.mark.parametrize("tail,head", [("spring.p", "mass.p"), ("mass.p", "spring.p")])
def test_two_power_in_ports_are_told_to_meet_at_a_junction_not_to_swap(tail, head):
    """A C and an I both take power in: no bond joins them in either direction, so the message
    suggests no swap (it used to suggest one whose error suggested swapping back) but a
    junction, and doing what it says gives a model that compiles and oscillates."""
    m = _c_and_i()
    with pytest.raises(errors.OrientationError) as info:
        m.connect(tail, head)
    msg = str(info.value)
    assert tail in msg and head in msg and "junction" in msg
    assert f"connect({head!r}, {tail!r})" not in msg
    with pytest.raises(errors.OrientationError) as swapped:
        m.connect(head, tail)                    # the swap fails too, with the same advice
    assert "junction" in str(swapped.value)
    assert f"connect('j', {tail!r}) and connect('j', {head!r})" in msg
    m.add("j", ph.OneJunction())
    m.connect("j", tail)
    m.connect("j", head)
    traj = compile_model(m, backend="python").simulate(
        math.pi, x0={"spring.q": 1.0}, method="Radau", rtol=1e-10, atol=1e-12)
    assert traj.status == "finished"
    assert traj["spring.q"][-1] == pytest.approx(math.cos(2.0 * math.pi), abs=1e-6)


def test_two_sources_are_told_to_meet_at_a_junction_and_a_possible_swap_is_suggested():
    """Two power-out ports (an effort and a flow source) get the junction, a power-in tail on
    a power-out head gets the reversed bond, which then works."""
    m = ph.Model("x")
    m.add("force", ph.Se(effort=1.0))
    m.add("speed", ph.Sf(flow=2.0))
    m.add("damper", ph.R(resistance=3.0))
    with pytest.raises(errors.OrientationError) as info:
        m.connect("force.p", "speed.p")
    msg = str(info.value)
    assert "junction" in msg and "connect('force.p', 'j') and connect('speed.p', 'j')" in msg
    with pytest.raises(errors.OrientationError) as info:
        m.connect("damper.p", "force.p")
    assert "use connect('force.p', 'damper.p')" in str(info.value)
    m.connect("force.p", "damper.p")             # the suggested bond is admissible


def test_no_bare_value_error_runtime_error_or_assert_in_the_packages():
    """User-facing paths raise the typed errors of porthamiltonian.errors: no ``raise
    ValueError``, ``raise RuntimeError`` or ``assert`` statement in either package (an assert
    vanishes under ``python -O``; a bare ValueError names no part)."""
    import ast
    from pathlib import Path

    root = Path(ph.__file__).resolve().parents[1]
    found = []
    for package in ("porthamiltonian", "walker_library"):
        for path in sorted((root / package).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                raised = node.exc if isinstance(node, ast.Raise) else None
                name = raised.func if isinstance(raised, ast.Call) else raised
                if isinstance(node, ast.Assert) or (
                        isinstance(name, ast.Name) and name.id in ("ValueError", "RuntimeError")):
                    found.append(f"{path.relative_to(root)}:{node.lineno}")
    assert found == []


def test_dangling_port_names_component_and_port():
    m = ph.Model("x")
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0))
    m.add("spring", ph.C(stiffness=1.0))
    m.connect("j", "mass.p")
    with pytest.raises(errors.DanglingPortError, match=r"spring\.p"):
        m.validate()
    with pytest.raises(errors.DanglingPortError, match=r"spring\.p"):
        compile_model(m, backend="python")


def test_duplicate_component_name():
    m = ph.Model("x")
    m.add("spring", ph.C(stiffness=1.0))
    with pytest.raises(errors.DuplicateNameError, match="'spring'"):
        m.add("spring", ph.C(stiffness=2.0))


def test_duplicate_parameter_name():
    m = ph.Model("x")
    m.parameter("k", 1.0)
    with pytest.raises(errors.DuplicateNameError, match="'k'"):
        m.parameter("k", 2.0)


def test_unknown_component_type_lists_known_types():
    with pytest.raises(errors.UnknownComponentError) as info:
        component_class("Spring")
    msg = str(info.value)
    assert "'Spring'" in msg and "Se" in msg and "C" in msg


def test_unknown_component_name_in_connect():
    m = _mass_spring()
    with pytest.raises(errors.UnknownComponentError, match="'damper'"):
        m.connect("j", "damper.p")


def test_unknown_port_names_component_and_ports():
    m = ph.Model("x")
    m.add("spring", ph.C(stiffness=1.0))
    m.add("force", ph.Se(effort=1.0))
    with pytest.raises(errors.UnknownPortError) as info:
        m.connect("force.p", "spring.q")
    msg = str(info.value)
    assert "'spring'" in msg and "'q'" in msg and "ports: p" in msg


# --- structure errors -------------------------------------------------------------------------
def test_algebraic_loop_names_the_resistors():
    """Se → 1 → {R1, TF → 0 → {R2, R3}}: with linear resistors only, R1's effort needs the common
    flow, which is the sum of R2's and R3's flows, which need the 0-junction effort V − e_R1: a
    loop with no storage in it (Karnopp et al., System Dynamics, §5: resistive fields)."""
    m = ph.Model("loop")
    m.parameter("V", 1.0)
    m.add("src", ph.Se(effort="V"))
    m.add("j1", ph.OneJunction())
    m.add("tf", ph.TF(ratio=1))
    m.add("j0", ph.ZeroJunction())
    for name, r in (("R1", 1), ("R2", 2), ("R3", 3)):
        m.add(name, ph.R(resistance=r))
    m.connect("src.p", "j1")
    m.connect("j1", "R1.p")
    m.connect("j1", "tf.p1")
    m.connect("tf.p2", "j0")
    m.connect("j0", "R2.p")
    m.connect("j0", "R3.p")
    with pytest.raises(errors.AlgebraicLoopError) as info:
        symbolic(m)
    msg = str(info.value)
    for name in ("R1", "R2", "R3"):
        assert re.search(rf"\b{name}\b", msg), msg
    assert isinstance(info.value, errors.StructureError)


def test_two_masses_on_one_junction_need_derivative_causality():
    m = ph.Model("x")
    m.add("j", ph.OneJunction())
    m.add("m1", ph.I(inertance=1.0))
    m.add("m2", ph.I(inertance=2.0))
    m.add("spring", ph.C(stiffness=1.0))
    for port in ("m1.p", "m2.p", "spring.p"):
        m.connect("j", port)
    with pytest.raises(errors.DerivativeCausalityError) as info:
        symbolic(m)
    msg = str(info.value)
    assert "m1" in msg and "m2" in msg
    assert "spring" not in msg


# --- parameters -------------------------------------------------------------------------------
def test_unknown_parameter_in_expression_names_component_and_argument():
    m = ph.Model("x")
    m.parameter("k", 1.0)
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance="mass_kg"))
    m.add("spring", ph.C(stiffness="k"))
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    with pytest.raises(errors.UnknownParameterError) as info:
        symbolic(m)
    msg = str(info.value)
    assert "'mass'" in msg and "'inertance'" in msg and "mass_kg" in msg


def test_sympy_constant_names_are_not_silently_accepted():
    """``E``, ``I``, ``S``, ``N`` are ordinary (unknown) names in expressions, not sympy constants."""
    m = ph.Model("x")
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0))
    m.add("spring", ph.C(stiffness="E"))
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    with pytest.raises(errors.UnknownParameterError, match="'stiffness'"):
        symbolic(m)


def test_unknown_parameter_at_run_time():
    compiled = compile_model(_mass_spring(), backend="python")
    with pytest.raises(errors.UnknownParameterError) as info:
        compiled.params({"nope": 1})
    assert "'nope'" in str(info.value) and "k" in str(info.value)
    with pytest.raises(errors.UnknownParameterError, match="'nope'"):
        compiled.simulate(1.0, params={"nope": 1.0})


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_non_finite_parameter_is_rejected(value):
    compiled = compile_model(_mass_spring(), backend="python")
    with pytest.raises(errors.ParameterValueError, match="'k'"):
        compiled.params({"k": value})
    with pytest.raises(errors.ParameterValueError, match="'k'"):
        compiled.simulate(1.0, params={"k": value})
    with pytest.raises(errors.ParameterValueError, match="'k'"):
        ph.Model("y").parameter("k", value)


def test_non_numeric_parameter_is_rejected():
    compiled = compile_model(_mass_spring(), backend="python")
    with pytest.raises(errors.ParameterValueError, match="'k'"):
        compiled.params({"k": "stiff"})


# --- states -----------------------------------------------------------------------------------
def test_wrong_initial_state_length_names_the_states():
    compiled = compile_model(_mass_spring(), backend="python")
    with pytest.raises(errors.StateError, match=r"mass\.p.*spring\.q|spring\.q.*mass\.p"):
        compiled.simulate(1.0, x0=np.zeros(3))
    with pytest.raises(errors.StateError, match="'spring.x'"):
        compiled.simulate(1.0, x0={"spring.x": 1.0})


# --- failing integrations end with a status ---------------------------------------------------
def test_negative_stiffness_diverges_with_status_not_exception():
    """m q'' = +k q from q0 at rest: q = q0 cosh(ωt), p = m ω q0 sinh(ωt), ω = √(k/m) = 10.
    With divergence_bound 1e6 the run ends "diverged" when p ≈ m ω q0 e^{ωt}/2 = 1e6, i.e. at
    t = ln(2e6 / (m ω q0)) / ω ≈ 1.911 s (q0 = 1e-3), with a message."""
    m = ph.Model("unstable")
    m.parameter("k", 100.0)
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0))
    m.add("spring", ph.C(stiffness="-k", q0=1e-3))
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    traj = compile_model(m, backend="python").simulate(100.0, divergence_bound=1e6)
    assert traj.status == "diverged"
    assert not traj.success
    assert "1e+06" in traj.message
    t_expected = math.log(2e6 / (1.0 * 10.0 * 1e-3)) / 10.0
    # divergence is checked once per accepted step: the run keeps the last step below the bound
    assert t_expected - 0.02 < traj.t_final <= t_expected
    assert abs(traj["mass.p"][-1]) <= 1e6


def _exploding_source() -> ph.Model:
    m = ph.Model("exploding")
    m.add("force", ph.Se(effort="exp(t*100)"))
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0))
    m.connect("force.p", "j")
    m.connect("j", "mass.p")
    return m


def test_exploding_source_ends_with_status_and_message():
    traj = compile_model(_exploding_source(), backend="python").simulate(100.0)
    assert traj.status in ("diverged", "failed")
    assert traj.message
    # p = (e^{100 t} − 1)/100 reaches 1e12 at t = ln(1e14 + 1)/100 ≈ 0.3224 s; divergence is
    # checked once per accepted step, and the run keeps the last step below the bound
    t_cross = math.log(1e14 + 1) / 100
    assert t_cross - 2e-3 < traj.t_final <= t_cross
    assert abs(traj["mass.p"][-1]) <= 1e12


def test_overflowing_source_keeps_the_integrated_part_of_the_run():
    """With a divergence bound too large to trigger, exp(100 t) overflows inside the integrator
    (the supplied power F·v overflows first, near t = 3.5 s). The run must still end with a status,
    and the trajectory must hold what was integrated before the failure (not be empty, and not
    report the failure at t = 0)."""
    traj = compile_model(_exploding_source(), backend="python").simulate(
        100.0, divergence_bound=1e300, rtol=1e-3, atol=1e-6)
    assert traj.status in ("diverged", "failed")
    assert traj.message
    assert len(traj.t) > 100
    assert traj.t_final > 3.0
    assert f"t = {traj.t_final:.6g}" in traj.message


def test_unknown_integration_method():
    compiled = compile_model(_mass_spring(), backend="python")
    with pytest.raises(errors.ModelError, match="'Euler'"):
        compiled.simulate(1.0, method="Euler")


def test_validate_reports_every_problem_of_a_model_at_once():
    """Three mistakes (a misspelt parameter, an unconnected damper, a guard that does not parse)
    come in one ValidationError that lists all three, each a typed problem with its path."""
    m = ph.Model("three_mistakes")
    m.parameter("k", 4.0, "N/m")
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0))
    m.add("spring", ph.C(stiffness="kk"))
    m.add("damper", ph.R(resistance=0.1))
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    m.event("stretched", "spring.q >")
    with pytest.raises(errors.ValidationError) as info:
        m.validate()
    problems = info.value.problems
    assert [type(p) for p in problems] == [errors.DanglingPortError, errors.UnknownParameterError,
                                           errors.ExpressionError]
    assert [p.path for p in problems] == [("components", "damper"),
                                          ("components", "spring", "stiffness"),
                                          ("events", 0, "guard")]
    msg = str(info.value)
    assert msg.startswith("model 'three_mistakes' has 3 problems:")
    for needle in ("damper.p", "connect it", "'spring'", "kk", "'stretched'", "cannot parse"):
        assert needle in msg
    with pytest.raises(errors.ValidationError):        # the compiler checks the same way
        compile_model(m, backend="python")


def test_a_model_file_with_three_mistakes_reports_all_three_with_their_lines():
    text = """
[parameters]
k = 4.0
[components.j]
type = "1"
[components.mass]
type = "I"
inertance = 1.0
[components.spring]
type = "Spring"
stiffness = "k"
[components.damper]
type = "R"
resistance = "c"
bonds = []
"""
    text = 'bonds = ["j -> mass.p", "j -> spring.p", "j -> dampr.p"]\n' + text.replace(
        "bonds = []\n", "")
    with pytest.raises(errors.ModelFileError) as info:
        io.loads(text, source="three.toml")
    lines = text.splitlines()

    def line(needle: str) -> int:
        return next(i for i, t in enumerate(lines, 1) if needle in t)

    msg = str(info.value)
    assert msg.startswith("three.toml: 3 problems:\n")
    where = [line(needle) for needle in ('type = "Spring"', "bonds =", 'resistance = "c"')]
    assert [p.args[0].split(":")[0] for p in info.value.problems] == [
        f"three.toml, line {n}" for n in where]
    for needle in ("unknown component type 'Spring'", "did you mean", "no component 'dampr'",
                   "unknown name(s) c", "'damper'"):
        assert needle in msg

"""The Model graph: bonds as directed edges (tail -> head = direction of positive power), junction
ports created by connections, and junction-to-junction bonds."""
from __future__ import annotations

import numpy as np
import pytest

import porthamiltonian as ph
from porthamiltonian import compile_model, io, symbolic
from porthamiltonian.errors import DerivativeCausalityError, ModelError


def test_bonds_are_directed_edges_with_port_names():
    m = ph.Model("x")
    m.add("force", ph.Se(effort=1.0))
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0))
    m.connect("force.p", "j")
    m.connect("j", "mass.p")
    edges = sorted((u, v, d["tail"], d["head"]) for u, v, d in m.graph.edges(data=True))
    assert edges == [("force", "j", "p", "p1"), ("j", "mass", "p2", "p")]


def test_a_port_takes_one_bond():
    m = ph.Model("x")
    m.add("force", ph.Se(effort=1.0))
    m.add("j", ph.OneJunction())
    m.add("k", ph.OneJunction())
    m.connect("force.p", "j")
    with pytest.raises(ModelError, match=r"force\.p"):
        m.connect("force.p", "k")


def test_component_names_must_be_identifiers():
    with pytest.raises(ModelError, match="'my spring'"):
        ph.Model("x").add("my spring", ph.C(stiffness=1.0))


def mass_on_maxwell_element(direct: bool) -> ph.Model:
    """Mass m (1-junction, velocity v) on a Maxwell element: spring k and damper c in series, i.e.
    sharing one force on a 0-junction whose flows add up to v. The junctions are bonded directly
    (``direct``) or through a TF of ratio 1."""
    m = ph.Model("mass_on_maxwell")
    m.parameter("k", 4.0)
    m.parameter("c", 10.0)
    m.parameter("q0", 0.1)
    m.add("j1", ph.OneJunction())
    m.add("j0", ph.ZeroJunction(domain="translation"))
    m.add("mass", ph.I(inertance=1.0))
    m.add("spring", ph.C(stiffness="k", q0="q0"))
    m.add("damper", ph.R(resistance="c"))
    m.connect("j1", "mass.p")
    if direct:
        m.connect("j1", "j0")
    else:
        m.add("tf", ph.TF(ratio=1))
        m.connect("j1", "tf.p1")
        m.connect("tf.p2", "j0")
    m.connect("j0", "spring.p")
    m.connect("j0", "damper.p")
    return m


def maxwell_momentum(t, m=1.0, k=4.0, c=10.0, q0=0.1):
    """Momentum of the mass: with F = k q the spring force, p' = −F and F' = k p/m − (k/c) F, so
    p'' + (k/c) p' + (k/m) p = 0, p(0) = 0, p'(0) = −k q0 [Ogata §5-3 form]:
    p(t) = −(k q0/ω_d) e^{−σ t} sin(ω_d t), σ = k/(2c), ω_d = √(k/m − σ²)."""
    sigma = k / (2 * c)
    wd = np.sqrt(k / m - sigma**2)
    return -(k * q0 / wd) * np.exp(-sigma * t) * np.sin(wd * t)


@pytest.mark.parametrize("direct", [False, True], ids=["through_TF", "direct_bond"])
def test_mass_on_maxwell_element_matches_closed_form(direct):
    """The junction-to-junction bond works both through a unit TF and directly (one junction
    declaring its domain, as the error for two domain-less junctions advises); the momentum matches
    ``maxwell_momentum`` to 1e-8 of k q0/ω_d and the ledger closes."""
    compiled = compile_model(mass_on_maxwell_element(direct), backend="python")
    assert set(compiled.state_names) == {"mass.p", "spring.q"}
    traj = compiled.simulate(5.0, method="DOP853", dense_output=True, rtol=1e-11, atol=1e-14)
    t = np.linspace(0.0, 5.0, 101)
    p = traj.sol(t)[compiled.state_index("mass.p")]
    assert np.max(np.abs(p - maxwell_momentum(t))) < 1e-8 * 4.0 * 0.1 / 2.0
    assert traj.relative_residual < 1e-9


def test_two_domainless_junctions_cannot_be_bonded():
    m = ph.Model("x")
    m.add("j1", ph.OneJunction())
    m.add("j0", ph.ZeroJunction())
    with pytest.raises(ModelError, match="domain"):
        m.connect("j1", "j0")


def test_two_springs_on_one_zero_junction_are_dependent_storages():
    """Two springs in series without a mass between them share one force: k1 q1 = k2 q2 ties their
    states, so one would need derivative causality."""
    m = mass_on_maxwell_element(direct=False)
    m.add("spring2", ph.C(stiffness=1.0))
    m.connect("j0", "spring2.p")
    with pytest.raises(DerivativeCausalityError) as info:
        symbolic(m)
    assert "spring" in str(info.value) and "spring2" in str(info.value)


def _oscillator(name: str, junction: ph.OneJunction, spring: ph.C) -> ph.Model:
    m = ph.Model(name)
    m.add("j", junction)
    m.add("mass", ph.I(inertance=1.0))
    m.add("spring", spring)
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    return m


def test_one_component_instance_serves_two_models():
    """Components are values: one junction and one spring added to two models (one of them
    with a third bond on the junction) leave both models valid, and each oscillates at its own
    closed-form frequency (ω = √(k/m): x(t) = q0 cos t for k = m = 1; with a damper c = 0.2 the
    envelope is q0 e^{-c t/2})."""
    junction, spring = ph.OneJunction(), ph.C(stiffness=1.0, q0=0.1)
    plain = _oscillator("plain_osc", junction, spring)
    damped = _oscillator("damped_osc", junction, spring)
    damped.add("damper", ph.R(resistance=0.2))
    damped.connect("j", "damper.p")
    assert [p.name for p in plain.ports("j")] == ["p1", "p2"]
    assert [p.name for p in damped.ports("j")] == ["p1", "p2", "p3"]
    assert junction.ports() == [] and not hasattr(junction, "extra_ports")
    for model in (plain, damped):
        model.validate()
    t_end = 2 * np.pi
    a = compile_model(plain, backend="python").simulate(t_end, rtol=1e-10, atol=1e-12)
    b = compile_model(damped, backend="python").simulate(t_end, rtol=1e-10, atol=1e-12)
    assert a["spring.q"][-1] == pytest.approx(0.1, rel=1e-7)
    omega_d = np.sqrt(1 - 0.1**2)     # q0 e^{-t/10} (cos ω_d t + sin(ω_d t) / (10 ω_d))
    expected = 0.1 * np.exp(-t_end / 10) * (np.cos(omega_d * t_end)
                                            + np.sin(omega_d * t_end) / (10 * omega_d))
    assert b["spring.q"][-1] == pytest.approx(expected, rel=1e-7)


def test_components_are_immutable():
    spring = ph.C(stiffness=1.0)
    with pytest.raises(AttributeError, match="immutable"):
        spring.args = {}
    with pytest.raises(TypeError):
        spring.args["stiffness"] = 2.0
    bodies = {"bob": {"mass": 1.0, "com": [0, 0, -1.0]}}
    arm = ph.Multibody(bodies=bodies, joints={"pin": {"type": "revolute", "parent": "world",
                                                     "child": "bob", "axis": "y"}})
    bodies["bob"]["mass"] = -5.0                   # the caller's table, not the component's
    assert arm.args["bodies"]["bob"]["mass"] == 1.0


def test_replace_swaps_a_component_and_keeps_its_bonds():
    """``Model.replace`` is the Python form of the one-line swap of a model file: the damper of a
    damped oscillator becomes a stiffer one (its bonds kept; the envelope q0 e^{-c t/2} changes
    with c), and a component without the bonded port is reported by validate, naming it."""
    model = _oscillator("swap_osc", ph.OneJunction(), ph.C(stiffness=1.0, q0=0.1))
    model.add("damper", ph.R(resistance=0.2))
    model.connect("j", "damper.p")
    new = model.replace("damper", ph.R(resistance=0.4))
    assert model.component("damper") is new
    t_end = 2 * np.pi
    traj = compile_model(model, backend="python").simulate(t_end, rtol=1e-10, atol=1e-12)
    omega_d = np.sqrt(1 - 0.2**2)     # c = 0.4: q0 e^{-t/5} (cos ω_d t + sin(ω_d t) / (5 ω_d))
    expected = 0.1 * np.exp(-t_end / 5) * (np.cos(omega_d * t_end)
                                           + np.sin(omega_d * t_end) / (5 * omega_d))
    assert traj["spring.q"][-1] == pytest.approx(expected, rel=1e-7)
    with pytest.raises(ModelError, match=r"'damper' \(TF\) has no port 'p'"):
        model.replace("damper", ph.TF(ratio=2.0))  # ports p1, p2: the bond to damper.p
    with pytest.raises(ModelError, match=r"damper\.p"):
        model.replace("damper", ph.Se(effort=0.0))  # a source gives power: the bond takes it
    assert model.component("damper") is new        # a refused swap changes nothing
    with pytest.raises(ModelError, match="no component 'nope'"):
        model.replace("nope", ph.R(resistance=1.0))


def test_a_description_parses_each_expression_once_and_with_outputs_only_the_new_ones(
        monkeypatch):
    """Reading, laying out and compiling a model each validate its description: the
    expressions are parsed once per description (and a description made by with_outputs parses
    only its new outputs), and what is found is the same every time: a bad new output is
    reported, the good ones are not."""
    from porthamiltonian.modeling import model as model_module

    calls: list[str] = []
    parse = model_module.parse

    def counting(text, *args, **kwargs):
        calls.append(str(text))
        return parse(text, *args, **kwargs)

    monkeypatch.setattr(model_module, "parse", counting)
    description = io.load("mass_spring_damper").freeze()
    assert description.validate() is description
    first = len(calls)
    assert first > 0
    assert description.validate() is description and description.problems() == []
    assert len(calls) == first
    more = description.with_outputs({"twice_k": "2 * k", "bad": "2 * no_such_parameter"})
    found = more.problems()
    assert calls[first:] == ["2 * k", "2 * no_such_parameter"]
    assert [type(e).__name__ for e in found] == ["UnknownParameterError"]
    assert "no_such_parameter" in str(found[0]) and "output 'bad'" in str(found[0])
    assert [str(e) for e in more.problems()] == [str(e) for e in found]
    assert len(calls) == first + 2

"""Hierarchical models: a sub-model (a Model with exposed ports) inside a parent model flattens to
the same equations and simulation as the equivalent flat model, with prefixed names."""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import porthamiltonian as ph
from porthamiltonian import compile_model, io, symbolic


def spring_damper(q0=0.1) -> ph.Model:
    """Spring k and damper c sharing one velocity (1-junction), exposing the junction as ``p``."""
    sd = ph.Model("spring_damper")
    sd.parameter("k", 4.0, "N/m")
    sd.parameter("c", 0.4, "N*s/m")
    sd.add("j", ph.OneJunction(domain="translation"))
    sd.add("spring", ph.C(stiffness="k", q0=q0))
    sd.add("damper", ph.R(resistance="c"))
    sd.connect("j", "spring.p")
    sd.connect("j", "damper.p")
    sd.expose("p", "j.attach")
    return sd


def mass_with_sub(sub: ph.Model) -> ph.Model:
    top = ph.Model("msd_hierarchical")
    top.parameter("m", 1.0, "kg")
    top.parameter("F", 0.0, "N")
    top.add("force", ph.Se(effort="F"))
    top.add("j", ph.OneJunction())
    top.add("mass", ph.I(inertance="m"))
    top.add("sd", sub)
    top.connect("force.p", "j")
    top.connect("j", "mass.p")
    top.connect("j", "sd.p")
    return top


def test_flattened_names_are_prefixed():
    flat = mass_with_sub(spring_damper()).freeze()
    assert set(flat.components) == {"force", "j", "mass", "sd.j", "sd.spring", "sd.damper"}
    assert list(flat.parameters) == ["m", "F", "sd.k", "sd.c"]
    sym = symbolic(mass_with_sub(spring_damper()))
    assert sym.param_names == ["m", "F", "sd.k", "sd.c"]
    assert set(sym.state_names) == {"mass.p", "sd.spring.q"}
    assert "sd.spring.p.e" in sym.outputs


def test_sub_model_gives_the_flat_state_equations():
    """Renaming sd.k → k, sd.c → c, sd.spring.q → spring.q, the hierarchical model has exactly the
    state equations, Hamiltonian, dissipation and supply of models/mass_spring_damper.toml."""
    hier = symbolic(mass_with_sub(spring_damper()))
    flat = symbolic(io.load("mass_spring_damper"))
    by_name = {str(s): s for s in [*flat.states, *flat.params]}
    rename = {s: by_name[str(s).removeprefix("sd.")] for s in [*hier.states, *hier.params]}
    hier_rhs = dict(zip(hier.state_names, hier.rhs))
    flat_rhs = dict(zip(flat.state_names, flat.rhs))
    for name, rhs in hier_rhs.items():
        assert sp.simplify(rhs.xreplace(rename) - flat_rhs[name.removeprefix("sd.")]) == 0, name
    for attr in ("hamiltonian", "p_diss", "p_in"):
        assert sp.simplify(getattr(hier, attr).xreplace(rename) - getattr(flat, attr)) == 0, attr


def test_sub_model_simulates_like_the_flat_model(compile_named):
    """Same trajectory (1e-12 relative, same output times) as the flat model, also after changing
    the sub-model's parameters by their prefixed names at run time."""
    hier = compile_model(mass_with_sub(spring_damper()), backend="python")
    flat = compile_named("mass_spring_damper")
    t_eval = np.linspace(0.0, 5.0, 101)
    for hier_params, flat_params in [({}, {}), ({"sd.k": 9.0, "sd.c": 1.5, "F": 0.3},
                                               {"k": 9.0, "c": 1.5, "F": 0.3})]:
        a = hier.simulate(5.0, params=hier_params, t_eval=t_eval, method="DOP853", rtol=1e-10,
                          atol=1e-13)
        b = flat.simulate(5.0, params=flat_params, t_eval=t_eval, method="DOP853", rtol=1e-10,
                          atol=1e-13)
        for name in ("mass.p", "spring.q"):
            xa = a[name if name == "mass.p" else "sd." + name]
            xb = b[name]
            assert np.max(np.abs(xa - xb)) <= 1e-12 * np.max(np.abs(xb)), name
        assert a.ledger()["dissipated"] == pytest.approx(b.ledger()["dissipated"], rel=1e-12)


def test_sub_model_initial_value_from_its_own_parameter():
    """An initial value written with a sub-model parameter (q0 = "x0" inside the sub-model) is
    that parameter, prefixed: sd.x0."""
    sub = spring_damper(q0="x0")
    sub.parameter("x0", 0.25, "m")
    compiled = compile_model(mass_with_sub(sub), backend="python")
    assert "sd.x0" in compiled.param_names
    x = compiled.initial_state()
    assert x[compiled.state_index("sd.spring.q")] == 0.25
    x = compiled.initial_state(compiled.params({"sd.x0": -0.5}))
    assert x[compiled.state_index("sd.spring.q")] == -0.5


def test_two_instances_of_a_sub_model_keep_separate_parameters():
    """Two instances of the same sub-model, each on its own mass, get separate parameters
    (left.k, right.k ...): with right.k = 16 and right.c = 0 the right oscillator is undamped,
    q = 0.1 cos(4 t) (m = 1), while the left one keeps its default damping."""
    top = ph.Model("two_oscillators")
    for name in ("left", "right"):
        top.add(f"j_{name}", ph.OneJunction())
        top.add(f"mass_{name}", ph.I(inertance=1.0))
        top.add(name, spring_damper())
        top.connect(f"j_{name}", f"mass_{name}.p")
        top.connect(f"j_{name}", f"{name}.p")
    compiled = compile_model(top, backend="python")
    assert {"left.k", "left.c", "right.k", "right.c"} <= set(compiled.param_names)
    traj = compiled.simulate(3.0, params={"right.k": 16.0, "right.c": 0.0}, method="DOP853",
                             dense_output=True,
                             rtol=1e-10, atol=1e-13)
    # undamped right oscillator: q = 0.1 cos(4 t); damped left one follows the flat model
    t = np.linspace(0.0, 3.0, 31)
    q_right = traj.sol(t)[compiled.state_index("right.spring.q")]
    assert np.max(np.abs(q_right - 0.1 * np.cos(4.0 * t))) < 1e-8
    assert abs(traj.x_final[compiled.state_index("left.spring.q")]) < 0.1


def test_a_model_with_a_sub_model_round_trips_through_files(tmp_path):
    """A sub-model saves as a ``type = "model"`` table (its own tables under ``model``, its
    exposed ports) and loads back: the same text again, the same state equations, and the same
    trajectory (1e-12 relative) as the model built in Python."""
    built = mass_with_sub(spring_damper())
    path = tmp_path / "hierarchical.toml"
    io.save(built, path)
    loaded = io.load(path)
    assert io.dumps(loaded) == path.read_text()
    sub = loaded.component("sd")
    assert isinstance(sub, ph.Model) and sub.exposed == {"p": ("j", "attach")}
    a, b = symbolic(built), symbolic(loaded)
    assert a.state_names == b.state_names and a.equations == b.equations
    assert a.param_names == b.param_names == ["m", "F", "sd.k", "sd.c"]
    ta = compile_model(built, backend="python").simulate(5.0, rtol=1e-10, atol=1e-13)
    tb = compile_model(loaded, backend="python").simulate(5.0, rtol=1e-10, atol=1e-13)
    np.testing.assert_allclose(tb["sd.spring.q"], ta["sd.spring.q"], rtol=1e-12, atol=1e-15)


def test_a_sub_model_problem_in_a_file_points_at_its_line(tmp_path):
    text = io.dumps(mass_with_sub(spring_damper())).replace('resistance = "c"',
                                                            'resistance = "cc"')
    with pytest.raises(ph.errors.ModelFileError) as info:
        io.loads(text, source="hier.toml")
    line = next(i for i, t in enumerate(text.splitlines(), 1) if 'resistance = "cc"' in t)
    assert str(info.value).startswith(f"hier.toml, line {line}: ")
    assert "unknown name(s) cc" in str(info.value) and "'sd.damper'" in str(info.value)

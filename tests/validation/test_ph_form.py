"""The explicit port-Hamiltonian form [ẋ; w; y] = (J − R)[∇H; z(w); u] on every shipped model.

The form is derived from the model's junction structure alone (the cut build of
porthamiltonian/compiler/phform.py) and ∇H by differentiating H (the generated chain rule); the
model's own state equations come from the ordinary build. So the check that (J − R)[∇H; z; u]
reproduces the compiled right-hand side is a second derivation of the dynamics, and the
junction structure M₀ being skew a structural passivity certificate. At 5 states per model
(around the initial state, and around the origin where contacts are pressed in): the right-hand
side to 1e-10 relative (measured <= 3e-16), M₀ + M₀ᵀ = 0 and R ⪰ 0 to round-off (<= 1e-12
relative; measured <= 3e-16), z(w)·w >= 0 for every nonlinear dissipator (PHMatrices.check).
Every shipped multibody is symbolic (``formulation = "auto"``); two are checked again with their
tree evaluated by the kernel (porthamiltonian/mechanics/kernel.c), where ∇H passes through the
kernel's tangents.
"""
from __future__ import annotations

import numpy as np
import pytest

from porthamiltonian import Model, OneJunction, R, Se, compile_model, io, symbolic
from porthamiltonian.errors import PassivityError
from porthamiltonian.modeling.elements import I


def _states(model, count: int = 5) -> list[np.ndarray]:
    """States near the initial one (even draws, 1e-2 scale) and near the origin (odd draws, 0.3
    scale), quaternions normalised (the form holds on |q| = 1, where a joint's stabilising term
    vanishes)."""
    rng = np.random.default_rng(7)
    out = []
    for k in range(count):
        x = (model.initial_state() + 0.01 * rng.normal(size=model.n_states) if k % 2 == 0
             else 0.3 * rng.normal(size=model.n_states))
        for i, name in enumerate(model.state_names):
            if name.endswith((".qw", ".q.w")):
                x[i:i + 4] /= np.linalg.norm(x[i:i + 4])
        out.append(x)
    return out


@pytest.mark.parametrize("name", io.available_models())
def test_ph_form_reproduces_the_right_hand_side(name):
    model = compile_model(io.load(name), backend="python", ph=True)
    for x in _states(model):
        form = model.ph_matrices(x, **({"u": np.zeros(len(model.input_names))}
                                      if model.input_names else {}))
        errors = form.check()
        assert errors["rhs"] < 1e-10, (name, errors)
        assert errors["w"] < 1e-10, (name, errors)
        assert errors["skew"] < 1e-12, (name, errors)
        assert errors["R_min"] > -1e-12, (name, errors)
        np.testing.assert_array_equal(form.J, -form.J.T)
        np.testing.assert_array_equal(form.R, form.R.T)


@pytest.mark.parametrize("name", ["heavy_top", "compliant_leg_walker_3d"])
def test_ph_form_of_a_kernel_multibody(name):
    """The spherical top (its Lie–Poisson block) and the 3-D compliant walker (contacts and
    frictions at its feet, sites of the kernel) with ``formulation = "kernel"``: the cut build
    writes the Poisson structure out symbolically, ∇H (½ pᵀv + V and the contacts' energies of
    the feet's heights) comes through the kernel's tangents. The checks hold, and J, R and ∇H
    equal the symbolic formulation's to 1e-12 relative. (The symbolic one is the shipped file
    itself, ``formulation = "auto"``: the build of the test above, read from the cache.)"""
    data = io.model_to_dict(io.load(name))
    for comp in data["components"].values():
        if comp.get("type") == "Multibody":
            comp["formulation"] = "kernel"
    data["model"]["name"] = f"{name}_kernel"
    forms = {"kernel": compile_model(io.model_from_dict(data), backend="python", ph=True),
             "symbolic": compile_model(io.load(name), backend="python", ph=True)}
    assert forms["kernel"].meta.kernels == ("multibody",)
    assert forms["symbolic"].meta.kernels == ()
    for x in _states(forms["symbolic"], 3):
        kernel, sym = (forms[f].ph_matrices(x) for f in ("kernel", "symbolic"))
        errors = kernel.check()
        assert errors["rhs"] < 1e-10 and errors["skew"] < 1e-12, (name, errors)
        for part in ("J", "R", "gradient"):
            new, old = getattr(kernel, part), getattr(sym, part)
            assert np.max(np.abs(new - old)) <= 1e-12 * max(np.max(np.abs(old)), 1.0), part


def test_mass_spring_damper_form_in_closed_form():
    """J = [[0, −1, 1], [1, 0, 0], [−1, 0, 0]] and R = diag(c, 0, 0) over [∂H/∂p, ∂H/∂q, u]
    (the symbolic form), and at a point ∇H = (p/m, k q), u = F."""
    sym = symbolic(io.load("mass_spring_damper"))
    form = sym.ph_form()
    assert form.state_names == ["mass.p", "spring.q"]
    assert form.J.tolist() == [[0, -1, 1], [1, 0, 0], [-1, 0, 0]]
    assert str(form.R) == "Matrix([[c, 0, 0], [0, 0, 0], [0, 0, 0]])"


def _active(law: dict) -> Model:
    m = Model("active")
    m.add("src", Se(effort="sin(t)"))
    m.add("j", OneJunction())
    m.add("mass", I(inertance=1.0))
    m.add("pump", R(**law))
    m.connect("src.p", "j")
    m.connect("j", "mass.p")
    m.connect("j", "pump.p")
    return m


def test_an_active_linear_dissipator_is_refused_naming_it():
    """An R whose law is e = −2 f (negative resistance written as a law) would make R indefinite:
    PassivityError naming the component."""
    with pytest.raises(PassivityError, match="component 'pump'"):
        symbolic(_active({"effort": "-2*f"})).ph_form()


def test_an_active_nonlinear_dissipator_is_refused_naming_it():
    """e = −f³: z(w)·w = −w⁴ < 0 wherever the flow is not zero: PassivityError naming it."""
    model = compile_model(_active({"effort": "-f**3"}), backend="python", ph=True)
    with pytest.raises(PassivityError, match="component 'pump'"):
        model.ph_matrices([0.5]).check()

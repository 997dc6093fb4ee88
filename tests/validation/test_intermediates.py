"""Compiler intermediates that read implicit-block unknowns (velocity level), and the modulation
power of an energy that reads intermediates.

* The Jacobian through velocity-level intermediates (the multibody's body twists and momenta,
  which read the velocities solved from M(q) v = p) equals central finite differences of ẋ.
* A storage whose energy reads a multibody point position (an output written with the
  multibody's intermediates) as a modulation input gets its modulation power booked: the
  numeric power balance dH/dt − P_in + P_diss vanishes.
* An implicit block may not read velocity-level intermediates (its Jacobian would be wrong):
  a clear error.
* Intermediates that read port variables (port level, e.g. a friction's slip from its port's
  flow) give the same functions as the law written out; a port variable solved from its own
  intermediate is an algebraic loop, and a stored energy may not read them: clear errors.
"""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from multibody_cases import random_states, tree3d_model

import porthamiltonian as ph
from porthamiltonian.mechanics.bodies import Revolute, RigidBody
from porthamiltonian.modeling.component import Component


def _central_differences(model, y: np.ndarray, p) -> np.ndarray:
    """∂ẋ/∂x of a compiled model at the augmented state y by central differences, step 1e-6."""
    fd = np.empty((len(y), len(y)))
    for j in range(len(y)):
        step = np.zeros(len(y))
        step[j] = 1e-6
        fd[:, j] = (np.asarray(model.functions.rhs(0.0, y + step, p))
                    - np.asarray(model.functions.rhs(0.0, y - step, p))) / 2e-6
    return fd


def test_jacobian_through_velocity_level_intermediates_matches_finite_differences():
    """tree3d (every joint and port kind, 7 coordinates): ∂ẋ/∂x at 3 random states against a
    central difference with step 1e-6 (|x| ~ 1), to 1e-6 of the largest entry of each row."""
    model = ph.compile_model(tree3d_model(), backend="python")
    pn = model.native_params(model.param_defaults)
    for x in random_states(model, 5, 3):
        y = model.augment(x)
        jac = np.asarray(model.functions.jac(0.0, y, pn))
        fd = _central_differences(model, y, pn)
        scale = np.max(np.abs(fd), axis=1, keepdims=True) + 1e-12
        assert np.max(np.abs(jac - fd) / scale) < 1e-6


def test_modulation_through_a_point_position_is_booked():
    """A pendulum whose pivot carries a VariableSpringDamper with K = k0 (1 + 4 x_tip²): the
    stiffness reads the tip's x (a multibody output written with intermediates). The power the
    modulation injects, ½ (∂K/∂x_tip) ẋ_tip z², is booked: the numeric power balance at random
    states is < 1e-7 of the largest power, and P_in is not zero."""
    m = ph.Model("modulated_pendulum")
    m.parameter("k0", 3.0, "N*m/rad")
    m.add("pend", ph.Multibody(
        bodies={"bob": RigidBody(mass=1.0, com=[0, 0, -1], inertia=[0.1, 0.1, 0.1],
                                 points={"tip": [0, 0, -1]})},
        joints={"pin": Revolute(parent="world", child="bob", axis="y", q0=0.4, v0=1.0)},
        gravity=[0, 0, -9.81], plane="xz"))
    m.add("spring", ph.library.springs.VariableSpringDamper(
        stiffness="k0*(1 + 4*pend.tip.x**2)", damping=0.2, domain="rotation", q0=0.1))
    m.connect("pend.pin", "spring.p")
    model = ph.compile_model(m, backend="python")
    p = model.param_defaults
    rng = np.random.default_rng(3)
    for _ in range(5):
        x = model.initial_state() + rng.uniform(-0.5, 0.5, model.n_states)
        _, P_diss, P_in = model.energy(0.0, x, p)
        assert abs(P_in) > 1e-3
        balance = model.power_balance(0.0, x, p)
        assert abs(balance) < 1e-7 * max(abs(P_in), abs(P_diss), 1.0)


class _StagedBlock(Component):
    """Test-only: an implicit block (u) whose matrix reads a velocity-level intermediate (w, of
    the block v): solved in a second stage, after v (porthamiltonian/compiler/structure.py)."""

    kind = "TestStagedBlock"

    def ports(self):
        return []

    def build(self, b):
        x = b.state("x", initial=1)
        (v,) = b.implicit("v", sp.Matrix([[2]]), sp.Matrix([x]))
        w = b.intermediate("w", v * x)
        (u,) = b.implicit("u", sp.Matrix([[w]]), sp.Matrix([x]))
        b.output("u", u)
        b.equation(b.der(x), v)


def test_a_block_reading_a_velocity_level_intermediate_is_solved_in_a_second_stage():
    """v = x/2, w = v x, u = x/w = 2/x: the staged block's value at several states (to 1e-14;
    it was refused before the stages existed); the state's rate ẋ = v keeps its exact
    Jacobian 1/2."""
    m = ph.Model("staged")
    m.add("c", _StagedBlock())
    model = ph.compile_model(m, backend="python", use_cache=False)
    p = model.param_defaults
    for x in (0.5, 1.0, 3.0):
        u = model.output("c.u", 0.0, np.array([x]), p)
        assert u == pytest.approx(2 / x, rel=1e-14)
        assert model.jacobian(0.0, np.array([x]))[0, 0] == pytest.approx(0.5, rel=1e-14)


# --- port-level intermediates: intermediates that read port variables -----------------------------
class _CubicDamper(Component):
    """Test-only: a damper e = c f³ + d f, written directly."""

    kind = "TestCubicDamper"

    def ports(self):
        from porthamiltonian.modeling.ports import Port
        return [Port("p", "translation", orientation="in")]

    def law(self, b, w1, w2):
        b.equation(b.port("p").e, 0.7 * w1 * w2 + 0.3 * w1)
        b.dissipate(b.port("p").e * b.port("p").f)

    def build(self, b):
        f = b.port("p").f
        self.law(b, f, f**2)


class _StagedCubicDamper(_CubicDamper):
    """The same law with intermediates of the port's flow: w1 = f, w2 = w1²."""

    kind = "TestStagedCubicDamper"

    def build(self, b):
        w1 = b.intermediate("w1", b.port("p").f)
        self.law(b, w1, b.intermediate("w2", w1**2))


class _LoopDamper(_CubicDamper):
    """The port's flow solved from an intermediate of itself: f = 2 w + e, w = f."""

    kind = "TestLoopDamper"

    def build(self, b):
        port = b.port("p")
        b.equation(port.f, 2 * b.intermediate("w", port.f) + port.e)


class _FlowEnergyDamper(_StagedCubicDamper):
    """The staged damper with a stored energy that reads its port's flow (not allowed)."""

    kind = "TestFlowEnergyDamper"

    def build(self, b):
        x = b.state("x", initial=1)
        b.equation(b.der(x), -x)
        b.energy(b.intermediate("w", b.port("p").f) * x**2)
        super().build(b)


def _mass_on_cubic_damper(component: Component) -> ph.Model:
    m = ph.Model("mass_on_damper")
    m.add("mass", ph.I(domain="translation", inertance=2.0, p0=1.5))
    m.add("spring", ph.C(domain="translation", compliance=0.5, q0=0.2))
    m.add("d", component)
    m.add("j", ph.OneJunction())
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    m.connect("j", "d.p")
    return m


def test_port_level_intermediates_equal_the_expanded_law():
    """A damper whose law reads its port's flow through intermediates (port level: substituted
    after the structure is solved) gives the same ẋ, Jacobian, dissipated power and outputs as
    the same law written out, at random states; its Jacobian equals central differences."""
    staged = ph.compile_model(_mass_on_cubic_damper(_StagedCubicDamper()), backend="python",
                              use_cache=False)
    plain = ph.compile_model(_mass_on_cubic_damper(_CubicDamper()), backend="python",
                             use_cache=False)
    assert staged.state_names == plain.state_names
    p = staged.native_params(staged.param_defaults)
    rng = np.random.default_rng(11)
    for _ in range(5):
        y = staged.augment(rng.uniform(-2, 2, staged.n_states))
        for fn in ("rhs", "jac", "energy", "outputs"):
            np.testing.assert_allclose(np.asarray(getattr(staged.functions, fn)(0.0, y, p)),
                                       np.asarray(getattr(plain.functions, fn)(0.0, y, p)),
                                       rtol=1e-13, atol=1e-13)
        jac = np.asarray(staged.functions.jac(0.0, y, p))
        fd = _central_differences(staged, y, p)
        np.testing.assert_allclose(jac, fd, rtol=1e-6, atol=1e-6 * np.max(np.abs(fd)))


def test_a_port_variable_solved_from_its_own_intermediate_is_an_algebraic_loop():
    from porthamiltonian.errors import AlgebraicLoopError
    m = ph.Model("spring_on_damper")          # the spring sets the effort, the damper the flow
    m.add("spring", ph.C(domain="translation", compliance=0.5, q0=0.2))
    m.add("d", _LoopDamper())
    m.add("j", ph.ZeroJunction())
    m.connect("j", "spring.p")
    m.connect("j", "d.p")
    with pytest.raises(AlgebraicLoopError, match="d.w .*algebraic loop"):
        ph.compile_model(m, backend="python", use_cache=False)


def test_a_stored_energy_reading_a_port_level_intermediate_is_refused():
    from porthamiltonian.errors import ModelError
    with pytest.raises(ModelError, match="component 'd': its stored energy depends on port"):
        ph.compile_model(_mass_on_cubic_damper(_FlowEnergyDamper()),
                         backend="python", use_cache=False)

"""Compiler intermediates that read implicit-block unknowns (velocity level), and the modulation
power of an energy that reads intermediates.

* The Jacobian through velocity-level intermediates (the multibody's body twists and momenta,
  which read the velocities solved from M(q) v = p) equals central finite differences of ẋ.
* A storage whose energy reads a multibody point position (an output written with the
  multibody's intermediates) as a modulation input gets its modulation power booked: the
  numeric power balance dH/dt − P_in + P_diss vanishes.
* An implicit block may not read velocity-level intermediates (its Jacobian would be wrong):
  a clear error.
"""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from multibody_cases import random_states, tree3d_model

import porthamiltonian as ph
from porthamiltonian.component import Component
from porthamiltonian.errors import UnknownParameterError
from porthamiltonian.mechanics.bodies import Revolute, RigidBody


def test_jacobian_through_velocity_level_intermediates_matches_finite_differences():
    """tree3d (every joint and port kind, 7 coordinates): ∂ẋ/∂x at 3 random states against a
    central difference with step 1e-6 (|x| ~ 1), to 1e-6 of the largest entry of each row."""
    model = ph.compile_model(tree3d_model(), backend="python")
    pn = model.native_params(model.param_defaults)
    for x in random_states(model, 5, 3):
        y = model.augment(x)
        jac = np.asarray(model.functions.jac(0.0, y, pn))
        fd = np.empty_like(jac)
        for j in range(len(y)):
            step = np.zeros(len(y))
            step[j] = 1e-6
            fd[:, j] = (np.asarray(model.functions.rhs(0.0, y + step, pn))
                        - np.asarray(model.functions.rhs(0.0, y - step, pn))) / 2e-6
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


class _LeakyBlock(Component):
    """Test-only: an implicit block that reads a velocity-level intermediate (not allowed)."""

    kind = "TestLeakyBlock"

    def ports(self):
        return []

    def build(self, b):
        x = b.state("x", initial=1)
        (v,) = b.implicit("v", sp.Matrix([[2]]), sp.Matrix([x]))
        w = b.intermediate("w", v * x)
        b.implicit("u", sp.Matrix([[w]]), sp.Matrix([x]))
        b.equation(b.der(x), v)


def test_a_block_reading_a_velocity_level_intermediate_is_refused():
    m = ph.Model("leaky")
    m.add("c", _LeakyBlock())
    with pytest.raises(UnknownParameterError, match="implicit block c.u0.. may depend on"):
        ph.compile_model(m, backend="python", use_cache=False)

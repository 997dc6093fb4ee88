"""Frame (wrench/twist) ports of a Multibody and the RigidBody/joint records.

Reference: a rigid pendulum about a fixed axis driven by a constant torque τ from rest turns by
θ = τ t² / (2 I) with I = m l² + I_c (parallel-axis theorem), whatever point of the body the
torque is applied at: a pure torque is a free vector.
"""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import porthamiltonian as ph
from porthamiltonian.mechanics.bodies import Prismatic, Revolute, RigidBody, Translational, Weld
from porthamiltonian.modeling.component import Arg, Component
from porthamiltonian.modeling.ports import Port


class _Wrench(Component):
    """A constant wrench (τ_y, f_x) source on a screw port (test-only)."""

    kind = "TestConstantWrench"
    arguments = {"tau": Arg("torque about y (N m)"), "fx": Arg("force along x (N)", default=0)}

    def ports(self):
        return [Port("p", "screw", 6, "out")]

    def build(self, b, tau, fx):
        p = b.port("p")
        b.equation(p.e, sp.Matrix([0, tau, 0, fx, 0, 0]))
        b.supply(p.power)


def _driven(frame_at):
    m = ph.Model("driven_" + str(frame_at).replace(".", "_").replace("-", "m"))
    m.add("arm", ph.Multibody(
        bodies={"bob": RigidBody(mass=1.0, com=[0, 0, -1], inertia=[0.1, 0.1, 0.1],
                                 frames={"hub": [0, 0, frame_at]})},
        joints={"pin": Revolute(parent="world", child="bob", axis="y")}, gravity=[0, 0, 0]))
    m.add("motor", _Wrench(tau=0.5))
    m.connect("motor.p", "arm.hub")
    return m


@pytest.mark.parametrize("frame_at", [0.0, -0.5, -2.0])
def test_pure_torque_on_any_frame_turns_the_pendulum_as_tau_t2_over_2I(frame_at):
    compiled = ph.compile_model(_driven(frame_at), backend="python")
    traj = compiled.simulate(2.0, rtol=1e-11, atol=1e-13)
    inertia = 1.0 * 1.0**2 + 0.1
    assert traj["arm.q.pin"][-1] == pytest.approx(0.5 * 2.0**2 / (2 * inertia), rel=1e-9)
    assert traj.relative_residual < 1e-10


def test_force_on_a_frame_of_a_slider_accelerates_it_as_f_over_m():
    """A force f along x on a frame of a 2 kg cart on a prismatic x joint: x = f t²/(2 m)."""
    m = ph.Model("pushed_cart")
    m.add("cart", ph.Multibody(bodies={"body": RigidBody(mass=2.0, inertia=[1, 1, 1],
                                                         frames={"handle": [0.3, 0, 0.2]})},
                               joints={"rail": Prismatic(parent="world", child="body", axis="x")},
                               gravity=[0, 0, 0]))
    m.add("hand", _Wrench(tau=0, fx=3.0))
    m.connect("hand.p", "cart.handle")
    traj = ph.compile_model(m, backend="python").simulate(1.5, rtol=1e-11, atol=1e-13)
    assert traj["cart.q.rail"][-1] == pytest.approx(3.0 * 1.5**2 / (2 * 2.0), rel=1e-10)


def test_records_equal_the_tables_they_stand_for():
    """RigidBody/joint records build the same model (same equations) as the plain tables."""
    records = ph.Multibody(
        bodies={"hip": RigidBody(mass=3.0), "leg": RigidBody(mass=0.1, com=[0, 0, -0.35]),
                "foot": RigidBody(mass=0.1, points={"tip": [0, 0, 0]})},
        joints={"free": Translational(parent="world", child="hip", axes=("x", "z")),
                "hip_joint": Revolute(parent="hip", child="leg", axis="y", q0=0.2),
                "ankle": Weld(parent="leg", child="foot", origin=[0, 0, -0.7])}, plane="xz")
    tables = ph.Multibody(
        bodies={"hip": {"mass": 3.0}, "leg": {"mass": 0.1, "com": [0, 0, -0.35]},
                "foot": {"mass": 0.1, "points": {"tip": [0, 0, 0]}}},
        joints={"free": {"type": "translational", "parent": "world", "child": "hip", "axes": ["x", "z"]},
                "hip_joint": {"type": "revolute", "parent": "hip", "child": "leg", "axis": "y", "q0": 0.2},
                "ankle": {"type": "weld", "parent": "leg", "child": "foot", "origin": [0, 0, -0.7]}},
        plane="xz")
    systems = []
    for comp in (records, tables):
        m = ph.Model("records_vs_tables")
        m.add("w", comp)
        systems.append(ph.symbolic(m))
    assert [str(e) for e in systems[0].rhs] == [str(e) for e in systems[1].rhs]
    assert systems[0].hamiltonian == systems[1].hamiltonian


def test_rigid_body_record_refuses_non_positive_mass():
    with pytest.raises(ph.errors.ModelError, match="mass must be positive"):
        RigidBody(mass=0.0)


def test_event_guard_reads_a_body_point_output():
    """A guard written with a component output (the tip's x position) fires where the pendulum
    passes the vertical: at a quarter of the small-amplitude period 2π√(l/g) (θ0 = 0.01 rad, the
    amplitude correction θ0²/16 is below 1e-5)."""
    m = ph.Model("pendulum_guard")
    m.add("arm", ph.Multibody(
        bodies={"bob": RigidBody(mass=1.0, com=[0, 0, -1], points={"tip": [0, 0, -1]})},
        joints={"pin": Revolute(parent="world", child="bob", axis="y", q0=0.01)},
        gravity=[0, 0, -9.81], plane="xz"))
    m.event("vertical", "arm.tip.x", direction=0, terminal=True)
    traj = ph.compile_model(m, backend="python").simulate(5.0, rtol=1e-11, atol=1e-13)
    assert traj.status == "event"
    quarter = 2 * np.pi * np.sqrt(1.0 / 9.81) / 4
    assert traj.events[0][1] == "vertical"
    assert traj.events[0][0] == pytest.approx(quarter, rel=2e-5)


def test_two_body_frame_ports_bonded_directly_are_refused_naming_both():
    """Two screw ports that both impose their twist (a multibody's frame port, a free body's
    port) cannot share a bond: the compiler refuses the pair as structurally singular and names
    both components (why screw ports need no frame types: mechanics/screw.py)."""
    m = ph.Model("two_bodies_one_bond")
    m.add("arm", ph.Multibody(
        bodies={"bob": RigidBody(mass=1.0, com=[0, 0, -1], inertia=[0.1, 0.1, 0.1],
                                 frames={"hub": [0, 0, 0]})},
        joints={"pin": Revolute(parent="world", child="bob", axis="y")}, gravity=[0, 0, 0]))
    m.add("ball", ph.mechanics.FreeBody(mass=1.0, inertia=[0.1, 0.1, 0.1]))
    m.connect("arm.hub", "ball.body")
    with pytest.raises(ph.errors.StructureError) as info:
        ph.symbolic(m)
    assert "structurally singular" in str(info.value)
    assert "arm" in str(info.value) and "ball" in str(info.value)

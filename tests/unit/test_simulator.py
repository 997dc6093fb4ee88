"""The simulator's result and the compiled model's point evaluations.

* A :class:`~porthamiltonian.Trajectory` is immutable and carries the parameter values in force at
  each point: a ball whose gravity an event action switches off at its first ground contact
  (t₁ = √(2h/g), closed form) has g before t₁ and 0 after, in ``traj.p`` and ``traj["g"]``; after
  the switch it flies up at constant speed v₁ = g t₁ (no gravity).
* Statuses are a :class:`~porthamiltonian.simulation.simulate.Status` whose values are the strings users see.
* ``CompiledModel.outputs``/``output``/``guards`` agree with the trajectory's columns and with the
  closed forms at a point (spring force k q, guard value q).
* ``CompiledModel.simulate`` is :func:`porthamiltonian.simulation.simulate` itself (one signature).
"""
from __future__ import annotations

import inspect
import math

import numpy as np
import pytest

import porthamiltonian as ph
from porthamiltonian.simulation.simulate import Status

G, H = 9.81, 1.0


def ball() -> ph.CompiledModel:
    m = ph.Model("ball_switching_gravity")
    m.parameter("g", G, "m/s^2")
    m.add("j", ph.OneJunction())
    m.add("ball", ph.I(inertance=1.0))
    m.add("height", ph.C(energy="g*q", q0=H))
    m.connect("j", "ball.p")
    m.connect("j", "height.p")
    m.event("ground", "height.q", direction=-1, terminal=True)
    return ph.compile_model(m, backend="python")


@pytest.fixture(scope="module")
def switched():
    model = ball()
    ip = model.state_index("ball.p")

    def bounce(t, x, p):
        x = x.copy()
        x[ip] = -x[ip]
        return ph.Reset(x=x, params={"g": 0.0})

    return model.simulate(1.0, actions={"ground": bounce}, rtol=1e-10, atol=1e-12)


def test_trajectory_carries_the_parameters_in_force_at_each_point(switched):
    t1 = math.sqrt(2 * H / G)
    assert switched.status == Status.FINISHED == "finished"
    assert switched.events[0] == (pytest.approx(t1, rel=1e-9), "ground")
    g = switched["g"]
    np.testing.assert_array_equal(switched.p[:, 0], g)
    before, after = switched.t < t1 - 1e-9, switched.t > t1 + 1e-9
    assert np.all(g[before] == G) and np.all(g[after] == 0.0)
    v1 = G * t1                                    # flies up at constant speed after the switch
    np.testing.assert_allclose(switched["ball.p"][after], v1, rtol=1e-8)


def test_trajectory_is_immutable(switched):
    with pytest.raises(AttributeError, match="immutable"):
        switched.status = "failed"
    with pytest.raises(ValueError, match="read-only"):
        switched.t[0] = 5.0
    with pytest.raises(ValueError, match="read-only"):
        switched["ball.p"][0] = 5.0
    switched.events.append((0.0, "mine"))          # a copy: the result keeps its own
    assert len(switched.events) == 1


def test_statuses_are_an_enum_of_the_strings_users_see():
    assert [s.value for s in Status] == ["finished", "event", "failed", "diverged"]
    traj = ball().simulate(1.0)                    # terminal event without action
    assert traj.status is Status.EVENT and f"{traj.status}" == "event"


def test_compiled_model_evaluates_outputs_and_guards_at_a_point():
    m = ph.Model("spring_point")
    m.parameter("k", 4.0, "N/m")
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance=1.0))
    m.add("spring", ph.C(stiffness="k", q0=0.3))
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    m.event("cross", "spring.q")
    model = ph.compile_model(m, backend="python")
    x, p = np.array([0.2, 0.7]), model.params(k=9.0)
    assert model.state_names == ["mass.p", "spring.q"]
    assert model.output("spring.p.e", 0.0, x, p) == pytest.approx(9.0 * 0.7, rel=1e-15)
    assert model.guards(0.0, x, p).tolist() == [pytest.approx(0.7, rel=1e-15)]
    traj = model.simulate(0.5, params={"k": 9.0})
    row = model.outputs(float(traj.t[-1]), traj.x[-1], traj.p[-1])
    np.testing.assert_allclose(row, traj.outputs[-1], rtol=1e-15)
    with pytest.raises(ph.errors.StateError, match="no state or output 'spring.F'"):
        model.output("spring.F", 0.0, x, p)


def test_compiled_model_simulate_is_simulate_itself():
    assert ph.CompiledModel.simulate is ph.simulate
    assert "**" not in str(inspect.signature(ph.simulate))

"""Open models against independent references: linearizations against closed forms, controller
blocks against python-control, discrete sampling instants, input bindings, LQR design.

References (each test states its numbers and tolerance):

* Linearizations of textbook systems derived by hand in the (q, p) coordinates the compiler uses:
  the mass–spring–damper ṗ = F − k q − c p/m, q̇ = p/m; the pendulum ṗ = −m g l sin θ, θ̇ =
  p/(m l²) at θ = 0 and θ = π; the double pendulum of two uniform rods at the downward
  equilibrium, A = [[0, M₀⁻¹], [−K, 0]] with M₀ and the potential's Hessian K written out for
  relative angles; the cart-pole at its upright equilibrium. All to 1e-10.
* python-control (``control.forced_response``, ``control.feedback``, ``control.lqr``) for the PID
  and transfer-function loops and the LQR gain: step responses to 1e-8, closed-loop eigenvalues
  eig(A − B K) to 1e-8.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from porthamiltonian import C, I, Model, OneJunction, R, Se, compile_model, io
from porthamiltonian.errors import InputError, ModelError
from porthamiltonian.library import (
    PID,
    Actuator,
    DiscretePID,
    DiscreteStateSpace,
    LookupTable,
    Saturation,
    Sensor,
    StateSpace,
    Sum,
    TransferFunction,
    ZeroOrderHold,
)
from porthamiltonian.simulation.inputs import Samples
from porthamiltonian.simulation.linearize import point

K_SPRING, C_DAMP, MASS = 4.0, 0.4, 1.5


@pytest.fixture(scope="module")
def control():
    """python-control, imported by the tests that use it (0.8 s of imports: not at collection,
    where every pytest-xdist worker imports every test module)."""
    import control as module
    return module


def msd(drive: str = "F", controller=None) -> Model:
    """Mass (MASS), spring (k), damper (c) on a 1-junction, driven by an actuator whose effort is
    ``drive``; input F when ``drive`` reads it; ``controller`` added as component "ctrl"."""
    m = Model("msd")
    m.parameter("k", K_SPRING, "N/m")
    m.parameter("c", C_DAMP, "N*s/m")
    m.parameter("r", 1.0, "m")
    if "F" in drive:
        m.input("F", "N", "force")
    m.add("act", Actuator(effort=drive))
    m.add("j", OneJunction())
    m.add("mass", I(inertance=MASS))
    m.add("spring", C(stiffness="k"))
    m.add("damper", R(resistance="c"))
    m.connect("act.p", "j")
    for e in ("mass", "spring", "damper"):
        m.connect("j", f"{e}.p")
    if controller is not None:
        m.add("ctrl", controller)
    m.output("position", "spring.q")
    m.output("velocity", "mass.p.f")
    return m


@pytest.fixture(scope="module")
def open_msd():
    return compile_model(msd(), backend="python")


# --- linearization against closed forms ------------------------------------------------------------
def test_mass_spring_damper_linearization_is_exact(open_msd):
    """States (mass.p, spring.q; the actuator's work, a quadrature, left out): A = [[−c/m, −k],
    [1/m, 0]], B = [[1], [0]]; outputs (q, p/m):
    C = [[0, 1], [1/m, 0]], D = 0 — to 1e-12 (exact arithmetic of the generated Jacobians)."""
    point_x = {"mass.p": 0.3, "spring.q": -0.1}
    lin = open_msd.linearize(x=point_x, u=[2.0], params={"k": 9.0})
    assert lin.states == ("mass.p", "spring.q") and lin.inputs == ("F",)
    assert lin.outputs == ("position", "velocity")
    np.testing.assert_allclose(lin.A, [[-C_DAMP / MASS, -9.0], [1 / MASS, 0]], rtol=0, atol=1e-12)
    np.testing.assert_allclose(lin.B, [[1.0], [0.0]], rtol=0, atol=1e-12)
    np.testing.assert_allclose(lin.C, [[0, 1], [1 / MASS, 0]], rtol=0, atol=1e-12)
    np.testing.assert_allclose(lin.D, [[0.0], [0.0]], atol=0)
    # the derivative at the point, by hand (states act.work, mass.p, spring.q)
    np.testing.assert_allclose(open_msd.derivative(x=point_x, u=[2.0], params={"k": 9.0}),
                               [2.0 * 0.3 / MASS, 2.0 - 9.0 * -0.1 - C_DAMP * 0.3 / MASS,
                                0.3 / MASS], rtol=1e-14)


@pytest.fixture(scope="module")
def pendulum():
    return compile_model(io.load("pendulum"), backend="python")


@pytest.mark.parametrize("theta, sign", [(0.0, -1.0), (math.pi, 1.0)])
def test_pendulum_linearization_at_both_equilibria(pendulum, theta, sign):
    """Point pendulum (m = 1, l = 1, g = 9.81): A = [[0, 1/(m l²)], [∓ m g l, 0]] at θ = 0 (stable)
    and θ = π (unstable), found by trim from 0.2 rad away (residual <= 1e-12), to 1e-10."""
    result = pendulum.trim(x={"pendulum.q.pivot": theta + 0.2, "pendulum.p.pivot": 0.1})
    assert result.success and result.residual <= 1e-12
    assert result.x[0] == pytest.approx(theta, abs=1e-12)
    lin = pendulum.linearize(x=result.x)
    np.testing.assert_allclose(lin.A, [[0, 1], [sign * 9.81, 0]], rtol=0, atol=1e-10)
    expected = np.sqrt(complex(sign * 9.81))
    assert sorted(lin.eigenvalues, key=lambda v: (v.real, v.imag)) == pytest.approx(
        sorted([-expected, expected], key=lambda v: (v.real, v.imag)), abs=1e-10)


def test_double_pendulum_linearization_matches_the_textbook_matrices():
    """Two uniform rods (m1, l1, m2, l2 of models/double_pendulum.toml), relative angles, at the
    downward equilibrium: M₀ = [[m1 l1²/3 + m2 (l1² + l1 l2 + l2²/3), m2 (l1 l2/2 + l2²/3)],
    [·, m2 l2²/3]], K = [[m1 g l1/2 + m2 g (l1 + l2/2), m2 g l2/2], [m2 g l2/2, m2 g l2/2]],
    A = [[0, M₀⁻¹], [−K, 0]] in (q, p) — to 1e-10."""
    model = compile_model(io.load("double_pendulum"), backend="python")
    m1, l1, m2, l2, g = 1.0, 1.0, 0.5, 0.8, 9.81
    M0 = np.array([[m1 * l1**2 / 3 + m2 * (l1**2 + l1 * l2 + l2**2 / 3),
                    m2 * (l1 * l2 / 2 + l2**2 / 3)],
                   [m2 * (l1 * l2 / 2 + l2**2 / 3), m2 * l2**2 / 3]])
    K = np.array([[m1 * g * l1 / 2 + m2 * g * (l1 + l2 / 2), m2 * g * l2 / 2],
                  [m2 * g * l2 / 2, m2 * g * l2 / 2]])
    lin = model.linearize(x=np.zeros(4))
    A = np.block([[np.zeros((2, 2)), np.linalg.inv(M0)], [-K, np.zeros((2, 2))]])
    assert lin.states == ("arm.q.shoulder", "arm.q.elbow_joint", "arm.p.shoulder",
                          "arm.p.elbow_joint")
    np.testing.assert_allclose(lin.A, A, rtol=0, atol=1e-10)


@pytest.fixture(scope="module")
def cart_pole():
    return compile_model(io.load("cart_pole"), backend="python")


def test_cart_pole_linearization_at_the_upright_equilibrium(cart_pole, control):
    """M(0) = [[M + m, m l], [m l, m l² + m l²/3]], ṗ_θ = m g l θ: A = [[0, M(0)⁻¹], [diag(0, m g
    l), 0]], B = e_{p_x} — to 1e-10; outputs (x, θ): C = [I 0], D = 0."""
    M, m, l, g = 1.0, 0.2, 0.5, 9.81
    Mq = np.array([[M + m, m * l], [m * l, m * l**2 + m * l**2 / 3]])
    lin = cart_pole.linearize(x=np.zeros(4), u=[0.0])
    A = np.block([[np.zeros((2, 2)), np.linalg.inv(Mq)], [np.diag([0.0, m * g * l]),
                                                          np.zeros((2, 2))]])
    np.testing.assert_allclose(lin.A, A, rtol=0, atol=1e-10)
    np.testing.assert_allclose(lin.B, [[0], [0], [1], [0]], atol=1e-12)
    np.testing.assert_allclose(lin.C, np.hstack([np.eye(2), np.zeros((2, 2))]), atol=0)
    sys = lin.to_control()
    assert isinstance(sys, control.StateSpace) and sys.ninputs == 1 and sys.noutputs == 2


def test_accelerations_are_the_exact_rates_of_the_velocities(pendulum):
    """A multibody's velocity output v and its acceleration v̇: for the point pendulum
    v̇ = −(g/l) sin θ (the closed form) to 1e-14 relative, and along a run."""
    acc = pendulum.accelerations(x=[0.7, 0.4])
    assert acc == {"pendulum.a.pivot": pytest.approx(-9.81 * math.sin(0.7), rel=1e-14)}
    traj = pendulum.simulate(0.5)
    np.testing.assert_allclose(traj["pendulum.a.pivot"],
                               -9.81 * np.sin(traj["pendulum.q.pivot"]), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(traj["pendulum.v.pivot"], traj["pendulum.p.pivot"], rtol=1e-14)


def test_parameter_jacobian_is_exact(open_msd):
    """∂ẋ/∂(k, c) of the mass–spring–damper: ∂ṗ/∂k = −q, ∂ṗ/∂c = −p/m, the rest zero (the
    generated jac_p, the same chain rule as jac), to 1e-14."""
    J = open_msd.parameter_jacobian(["k", "c"], x={"mass.p": 0.3, "spring.q": -0.1}, u=[0.0])
    np.testing.assert_allclose(J, [[0, 0], [0.1, -0.3 / MASS], [0, 0]], rtol=0, atol=1e-14)


# --- controllers against python-control ------------------------------------------------------------
T_GRID = np.linspace(0.0, 8.0, 161)


def _plant(control):
    """The mass–spring–damper 1 / (m s² + c s + k) as python-control's transfer function."""
    return control.tf([1.0], [MASS, C_DAMP, K_SPRING])


def _step_error(control, controller, C_s) -> float:
    """max |y − y_ref| over T_GRID of the unit-setpoint step response of the loop ``controller``
    (error r − q) around the mass–spring–damper, against python-control's forced_response of
    feedback(C P, 1)."""
    model = compile_model(msd("ctrl.y", controller), backend="python")
    traj = model.simulate(T_GRID[-1], method="Radau", t_eval=T_GRID, rtol=1e-12, atol=1e-14)
    loop = control.feedback(C_s * _plant(control), 1)
    _, y = control.forced_response(loop, T_GRID, np.ones_like(T_GRID))
    return float(np.max(np.abs(traj["spring.q"] - y)))


def test_pid_step_response_matches_python_control(control):
    """PID kp + ki/s + kd s/(tf s + 1) on the mass–spring–damper: the step response equals
    python-control's to 1e-8 (measured ~4e-14)."""
    kp, ki, kd, tf = 10.0, 5.0, 2.0, 0.05
    s = control.tf("s")
    error = _step_error(control, PID(input="r - spring.q", kp=kp, ki=ki, kd=kd, tf=tf),
                        kp + ki / s + kd * s / (tf * s + 1))
    assert error < 1e-8


def test_transfer_function_step_response_matches_python_control(control):
    """A lead compensator 5 (s + 2)/(s + 10) as a TransferFunction block: the step response equals
    python-control's to 1e-8; the same as a StateSpace block (its controllable form written out)."""
    C_s = control.tf([5.0, 10.0], [1.0, 10.0])
    assert _step_error(control, TransferFunction(input="r - spring.q", num=[5, 10], den=[1, 10]),
                       C_s) < 1e-8
    assert _step_error(control, StateSpace(inputs=["r - spring.q"], A=[[-10]], B=[[1]], C=[[-40]],
                                  D=[[5]]), C_s) < 1e-8


def test_replace_swaps_the_controller(control):
    """Model.replace puts a TransferFunction where the PID was; the closed loop's linearization has
    the new controller's states, and its eigenvalues those of python-control's feedback loop."""
    model = msd("ctrl.y", PID(input="r - spring.q", kp=10.0, ki=5.0))
    model.replace("ctrl", TransferFunction(input="r - spring.q", num=[5, 10], den=[1, 10]))
    compiled = compile_model(model, backend="python")
    assert "ctrl.x1" in compiled.state_names and "ctrl.I" not in compiled.state_names
    lin = compiled.linearize()
    poles = control.poles(control.feedback(control.tf([5.0, 10.0], [1.0, 10.0]) * _plant(control), 1))
    np.testing.assert_allclose(np.sort_complex(lin.eigenvalues), np.sort_complex(poles),
                               atol=1e-10)


def test_pid_anti_windup_limits_the_output_and_the_integral():
    """A saturated PID (limits ±2 N, the step needing 1.6 N at rest) holds its output within the
    limits and settles at the setpoint (1e-4 after 40 s); back-calculation keeps the integral
    below the one the same PID winds up to without limits' tracking; the ledger books the
    actuator's work and closes (relative residual < 1e-8 at rtol 1e-8)."""
    def run(limits: bool):
        extra = {"u_min": -2, "u_max": 2, "tt": 0.3} if limits else {}
        pid = PID(input="r - spring.q", kp=10.0, ki=5.0, kd=4.0, tf=0.05, **extra)
        return compile_model(msd("ctrl.y", pid), backend="python").simulate(40.0,
                                                                            params={"r": 0.4})
    traj, free = run(True), run(False)
    assert np.max(np.abs(traj["ctrl.y"])) <= 2.0 + 1e-12 < np.max(np.abs(free["ctrl.y"]))
    assert traj["spring.q"][-1] == pytest.approx(0.4, abs=1e-4)
    ledger = traj.ledger()
    assert ledger["relative_residual"] < 1e-8
    assert ledger["actuators"]["act"] == pytest.approx(ledger["supplied"], rel=1e-9)


def test_saturation_and_lookup_table_laws():
    """Saturation clips, LookupTable interpolates linearly and holds beyond its ends (values of the
    outputs at chosen inputs, exact)."""
    m = Model("blocks")
    m.input("u")
    m.add("sat", Saturation(input="u", lower=-1, upper=2))
    m.add("table", LookupTable(input="u", x=[0, 1, 3], y=[0, 10, 0]))
    m.add("sink", R(resistance=1.0))
    m.add("src", Se(effort="sat.y + table.y"))
    m.connect("src.p", "sink.p")
    model = compile_model(m, backend="python")
    for u, sat, table in ((-3.0, -1.0, 0.0), (0.5, 0.5, 5.0), (2.0, 2.0, 5.0), (9.0, 2.0, 0.0)):
        pt = point(model, u=[u])
        values = model.outputs(pt.t, pt.y, pt.p)
        assert values[model.output_index("sat.y")] == sat
        assert values[model.output_index("table.y")] == table


# --- discrete-time controllers -------------------------------------------------------------------
@pytest.mark.parametrize("backend", ["python", "c"])
def test_discrete_pid_samples_exactly_at_k_T(backend):
    """A DiscretePID (T = 0.1 s) on the mass–spring–damper, run from t0 = 0.3 s: its held output
    changes only at t0 + k T exactly (floating point equality), and each new value is the
    discrete law computed by hand from the state just before the instant (to 1e-12)."""
    T, kp, ki, kd = 0.1, 8.0, 4.0, 0.5
    model = compile_model(msd("ctrl.y", DiscretePID(input="r - spring.q", period=T, kp=kp, ki=ki,
                                                    kd=kd)), backend=backend)
    t0 = 0.3
    traj = model.simulate(t0 + 2.0, t_start=t0)
    t, y = traj.t, traj["ctrl.y"]
    jumps = np.nonzero(np.diff(y))[0]
    assert len(jumps) >= 15
    k = np.round((t[jumps + 1] - t0) / T)
    np.testing.assert_array_equal(t[jumps + 1], t0 + k * T)     # exactly t0 + k T
    assert np.all(t[jumps] == t[jumps + 1])                      # before and after, same instant
    q = traj["spring.q"]
    integral, e_prev = 0.0, 0.0
    samples = [t0 + j * T for j in range(20) if t0 + j * T < traj.t_final]
    for tk in samples:
        at = np.nonzero(t == tk)[0]
        e = 1.0 - q[at[0]]
        integral += ki * T * e
        value = kp * e + integral + kd * (e - e_prev) / T
        e_prev = e
        assert y[at[-1]] == pytest.approx(value, abs=1e-12)


def test_zero_order_hold_and_discrete_state_space():
    """A ZeroOrderHold of sin(t) holds sin(kT) on [kT, (k+1)T); a DiscreteStateSpace accumulator
    x_{k+1} = x_k + u_k, y_k = x_k with u = 1 outputs k at t = kT."""
    m = Model("hold")
    m.add("zoh", ZeroOrderHold(input="sin(t)", period=0.25))
    m.add("acc", DiscreteStateSpace(inputs=["1"], A=[[1]], B=[[1]], C=[[1]], period=0.5))
    m.add("sink", R(resistance=1.0))
    m.add("src", Se(effort="zoh.y"))
    m.connect("src.p", "sink.p")
    traj = compile_model(m, backend="python").simulate(2.0)
    for tk, value in zip(traj.t, traj["zoh.y"]):
        k = math.floor(tk / 0.25 + 1e-12)
        assert value in (pytest.approx(math.sin(k * 0.25)), pytest.approx(math.sin((k - 1) * 0.25)))
    assert traj["acc.y"][-1] == 3.0 and traj["acc.x1"][-1] == 4.0


# --- input bindings ----------------------------------------------------------------------------------
def _run(model, inputs, **options):
    return model.simulate(6.0, inputs=inputs, rtol=1e-11, atol=1e-13, **options)


def test_every_binding_of_a_constant_gives_the_same_trajectory(open_msd):
    """F = 2 N as a number, held samples, interpolated samples, a callable (scipy path) and bound
    in the model: the final states agree to 1e-8 (integration tolerance 1e-11)."""
    runs = [_run(open_msd, {"F": 2.0}),
            _run(open_msd, {"F": Samples([0, 1, 2], [2, 2, 2], "zoh")}),
            _run(open_msd, {"F": Samples([0, 6], [2, 2], "linear")}),
            _run(open_msd, {"F": lambda t, x: 2.0}),
            _run(open_msd, lambda t, x: [2.0]),
            _run(open_msd, [2.0])]
    bound = msd()
    bound.bind_input("F", "2")
    runs.append(compile_model(bound, backend="python").simulate(6.0, rtol=1e-11, atol=1e-13))
    for traj in runs[1:]:
        np.testing.assert_allclose(traj.x_final, runs[0].x_final, rtol=0, atol=1e-8)
    np.testing.assert_allclose(runs[0]["F"], 2.0)


def test_every_binding_of_a_ramp_gives_the_same_trajectory(open_msd):
    """F = 0.5 t as linearly interpolated samples, a callable, and bound in the model to the
    expression 0.5*t: final states agree to 1e-8; held samples every 1 ms approach it (1e-3)."""
    ramp = _run(open_msd, {"F": Samples([0, 3, 6], [0, 1.5, 3.0], "linear")})
    called = _run(open_msd, {"F": lambda t, x: 0.5 * t})
    bound = msd()
    bound.bind_input("F", "0.5*t")
    compiled = compile_model(bound, backend="python").simulate(6.0, rtol=1e-11, atol=1e-13)
    for traj in (called, compiled):
        np.testing.assert_allclose(traj.x_final, ramp.x_final, rtol=0, atol=1e-8)
    t = np.arange(0, 6.0005, 0.001)
    held = open_msd.simulate(6.0, inputs={"F": Samples(t, 0.5 * t, "zoh")})
    np.testing.assert_allclose(held.x_final, ramp.x_final, atol=1e-3)
    np.testing.assert_allclose(ramp["F"], 0.5 * ramp.t, atol=1e-12)


def test_input_errors_are_typed_and_named(open_msd):
    """Unbound, unknown, wrong-shaped and not-covering inputs raise InputError naming the input."""
    cases = [
        (None, "not bound"),
        ({}, "F"),
        ({"F": 1.0, "G": 2.0}, "no input(s) G"),
        ({"F": "one"}, "'F'"),
        ([1.0, 2.0], "1 numbers"),
        ({"F": Samples([0.5, 1.0], [1, 2])}, "start at t = 0.5"),
        ({"F": Samples([0, 1.0], [1, 2], "linear")}, "end at t = 1"),
    ]
    for inputs, words in cases:
        with pytest.raises(InputError, match=words.replace("(", r"\(").replace(")", r"\)")):
            open_msd.simulate(2.0, inputs=inputs)
    with pytest.raises(InputError, match="equal length"):
        Samples([0, 1, 2], [1, 2])
    with pytest.raises(InputError, match="shape"):
        open_msd.simulate(1.0, inputs={"F": lambda t, x: [1.0, 2.0]})
    with pytest.raises(InputError, match="compiled loop"):
        open_msd.simulate(1.0, inputs={"F": lambda t, x: 1.0}, method="Rodas5P")
    with pytest.raises(InputError, match="u must have 1"):
        open_msd.linearize(u=[1.0, 2.0])
    with pytest.raises(ModelError, match="is an input"):
        open_msd.params({"F": 1.0})


# --- LQR design loop -------------------------------------------------------------------------------
def test_lqr_design_loop_on_the_cart_pole(cart_pole, control):
    """Linearize the cart-pole at its upright equilibrium, design an LQR (Q = diag(10, 100, 1, 1),
    R = 0.1) with python-control, put −K x back as a Sum block bound to the input F: the closed
    loop's linearization has eig(A − B K) to 1e-8, and the nonlinear loop brings the rod upright
    (|θ|, |x| < 1e-4 after 10 s) from θ0 = ±0.1, ±0.2, ±0.3 rad."""
    lin = cart_pole.linearize(x=np.zeros(4), u=[0.0])
    K, _, _ = control.lqr(lin.A, lin.B, np.diag([10.0, 100.0, 1.0, 1.0]), 0.1)
    loop = io.load("cart_pole")
    loop.add("lqr", Sum(inputs=list(lin.states), signs=[float(-k) for k in K[0]]))
    loop.bind_input("F", "lqr.y")
    closed = compile_model(loop, backend="python")
    assert closed.input_names == []
    cl = closed.linearize(x=np.zeros(4))
    np.testing.assert_allclose(np.sort_complex(cl.eigenvalues),
                               np.sort_complex(np.linalg.eigvals(lin.A - lin.B @ K)), atol=1e-8)
    for theta0 in (-0.3, -0.2, -0.1, 0.1, 0.2, 0.3):
        traj = closed.simulate(10.0, params={"theta0": theta0})
        assert traj.status == "finished"
        assert abs(traj["cart_pole.q.pivot"][-1]) < 1e-4 and abs(traj["cart_pole.q.slider"][-1]) < 1e-4


# --- open ports ---------------------------------------------------------------------------------
def test_an_open_port_is_an_input_output_pair_booked_as_supplied():
    """A mass–spring–damper whose 1-junction is exposed and left open: the input is the force
    the environment imposes (N), the declared output ``shaft.y`` the junction's velocity, so
    C = [1/m, 0] over (p, q), B = [1, 0]; for a constant force u the supplied energy is
    u (q(T) − q(0)) (∫ u y dt with y = q̇) to 1e-8 relative."""
    m = Model("open")
    m.add("j", OneJunction(domain="translation"))
    m.add("mass", I(inertance=MASS))
    m.add("spring", C(stiffness=K_SPRING))
    m.add("damper", R(resistance=C_DAMP))
    for element in ("mass", "spring", "damper"):
        m.connect("j", f"{element}.p")
    m.expose("shaft", "j")
    model = compile_model(m, backend="python")
    assert model.input_names == ["shaft"] and model.declared_outputs == ["shaft.y"]
    lin = model.linearize(u=[0.0])
    np.testing.assert_allclose(lin.B, [[1.0], [0.0]], atol=1e-14)
    np.testing.assert_allclose(lin.C, [[1 / MASS, 0.0]], atol=1e-14)
    traj = model.simulate(5.0, inputs={"shaft": 1.5}, rtol=1e-11, atol=1e-13)
    q = traj["spring.q"]
    assert traj.ledger()["supplied"] == pytest.approx(1.5 * (q[-1] - q[0]), rel=1e-8)


def test_trim_finds_the_input_that_holds_a_state(open_msd):
    """The force that holds the spring at q = 0.5 m at rest is k q = 2 N (free input F, the
    states given; and with the momentum free too), to 1e-12."""
    held = open_msd.trim(x={"spring.q": 0.5, "mass.p": 0.0}, u=[0.0], free_states=[],
                         free_inputs=["F"])
    assert held.success and held.u[0] == pytest.approx(K_SPRING * 0.5, abs=1e-12)
    square = open_msd.trim(x={"spring.q": 0.5, "mass.p": 0.3}, u=[0.0],
                           free_states=["mass.p"], free_inputs=["F"])
    assert square.success and square.u[0] == pytest.approx(2.0, abs=1e-12)
    assert square.x[open_msd.state_index("mass.p")] == pytest.approx(0.0, abs=1e-12)


def test_trim_from_a_point_beyond_float64_does_not_claim_an_equilibrium():
    """From q = 1e308 m (found by fuzzing ``linearize --at``): ∂ẋ/∂z · z overflows, and the
    relative convergence test (residual <= tol (1 + inf)) passed with |dx/dt| = 2e308; now trim
    fails and says why, without numpy's overflow warning."""
    model = compile_model(msd("F"), backend="python")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        far = model.trim(x={"spring.q": 1e308, "mass.p": 0.0}, u=[0.0])
    assert not far.success and "beyond the float64 range" in far.message
    near = model.trim(x={"spring.q": 0.5, "mass.p": 0.0}, u=[0.0])
    assert near.success and near.x[model.state_index("spring.q")] == pytest.approx(0.0, abs=1e-12)


def test_a_sensor_reads_a_flow():
    """A Sensor of the mass's flow (its velocity) with gain 2 and a unit: 2 p/m along a run."""
    m = msd("F")
    m.add("speedometer", Sensor(input="mass.p.f", gain=2, unit="m/s"))
    model = compile_model(m, backend="python")
    traj = model.simulate(2.0, inputs={"F": 1.0})
    np.testing.assert_allclose(traj["speedometer.y"], 2 * traj["mass.p"] / MASS, rtol=1e-14)
    assert model.units["speedometer.y"] == "m/s"

"""Validation of the 3D contact and friction (porthamiltonian.library.contact3d / .friction3d)
against closed forms.

Closed forms (rigid bodies, Coulomb friction μ, slope γ, gravity g; e.g. any text on rigid-body
dynamics, the sphere and disc on an incline):
* rolling without slipping (friction enough: μ ≥ tan γ / (1 + m r²/I)): the centre accelerates at
  a = g sin γ / (1 + I/(m r²)) along the slope, (5/7) g sin γ for a solid sphere (I = 2/5 m r²),
  (2/3) g sin γ for a disc (I = ½ m r²), and ω = v / r;
* sliding (μ below that): a = g (sin γ − μ cos γ), ω̇ = μ m g cos γ r / I (5/2 μ g cos γ / r for
  the sphere), the slip speed grows at β = a − r ω̇, and friction dissipates
  μ m g cos γ × (slip distance ½ β T²).
The regularised SCVS law never sticks: a rolling body creeps at the slip speed v* where
μ(v*) = (needed tangential force)/(normal force) — computed here from the 1D law — which is the
law's regularisation error (v*/v ≈ 2e-4 at 1 s here).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import porthamiltonian as ph
from porthamiltonian import io
from porthamiltonian.errors import ModelError, ParameterValueError

G, GAMMA, M, R = 9.81, 0.3, 1.0, 0.05
SCVS = {"mu_st": 0.5, "mu_c": 0.25, "mu_v": 0.025, "s": 500.0, "v_st": 0.02}


def mu_1d(v: float, mu_st: float, mu_c: float, mu_v: float, s: float, v_st: float) -> float:
    """The 1D SCVS coefficient, the literal 20-sim formula (v ≥ 0)."""
    E = math.exp(-((v / v_st) ** 2))
    return (mu_c + (mu_st * abs(math.tanh(s * v)) - mu_c) * E) + mu_v * v


@pytest.fixture(scope="module")
def sphere(isolated_cache):
    return ph.compile_model(io.load("sphere_on_slope"))


def along(traj) -> np.ndarray:
    """The centre's coordinate down the slope (m)."""
    return traj["ball.c.x"] * math.cos(GAMMA) - traj["ball.c.z"] * math.sin(GAMMA)


def fit_acceleration(t: np.ndarray, s: np.ndarray, t0: float) -> float:
    keep = t >= t0
    return 2 * np.polyfit(t[keep], s[keep], 2)[0]


def spin(traj) -> np.ndarray:
    """|ω| (rad/s) from the body-axis angular momentum of the isotropic sphere (L = I ω)."""
    L = np.array([traj[f"ball.p.float.w{a}"] for a in "xyz"])
    return np.linalg.norm(L, axis=0) / (0.4 * M * R**2)


def test_solid_sphere_rolls_without_slipping(sphere):
    """Friction enough ((2/7) tan γ = 0.088 < μ_c): after the first 0.2 s the centre accelerates
    at (5/7) g sin γ to 1e-7 relative, |ω| r = v up to the creep v*, which equals the regularised
    law's closed-form creep speed to 1e-6; the sphere stays in the plane y = 0 and the ledger
    closes to 1e-8 of the energy in play."""
    traj = sphere.simulate(1.0, rtol=1e-10, atol=1e-12, max_step=0.005)
    assert traj.status == "finished"
    t, s = traj.t, along(traj)
    a = fit_acceleration(t, s, 0.2)
    assert a == pytest.approx(5 / 7 * G * math.sin(GAMMA), rel=1e-7)   # measured 4e-10
    # the speed at the end from the same fit (a difference of the last two points is the speed
    # half a step earlier: off by a h / 2, which depends on the method's last step)
    keep = t >= 0.2
    v = float(np.polyval(np.polyder(np.polyfit(t[keep], s[keep], 2)), t[-1]))
    creep = brentq(lambda x: mu_1d(x, **{k: SCVS[k] for k in ("mu_st", "mu_c", "mu_v", "v_st")},
                                   s=SCVS["s"]) - 2 / 7 * math.tan(GAMMA), 1e-9, 0.005)
    assert traj["friction.v"][-1] == pytest.approx(creep, rel=1e-6)   # measured 4e-8
    assert spin(traj)[-1] * R == pytest.approx(v - creep, abs=1e-4 * v)
    assert np.max(np.abs(traj["ball.c.y"])) < 1e-12
    assert traj["ground.Fn"][-1] == pytest.approx(M * G * math.cos(GAMMA), rel=1e-6)
    ledger = traj.ledger()
    assert abs(ledger["relative_residual"]) < 1e-8
    assert traj["ball.float.q_norm"][-1] == pytest.approx(1.0, abs=1e-8)


def test_solid_sphere_slides_with_too_little_friction(sphere):
    """μ = 0.05 < (2/7) tan γ: the centre accelerates at g (sin γ − μ cos γ) and the spin at
    (5/2) μ g cos γ / r (both to 1e-7 relative after 0.05 s); the friction's dissipation
    (∫ Fn μ(a) a dt) equals μ m g cos γ × the slip distance ∫ a dt to 1e-5 (the regularisation's
    share, μ m g cos γ ∫ (1 − tanh(s a)) a dt, measured 1.5e-6 relative). The slip distance
    itself exceeds the ideal ½ β T² by the regularisation's start-up: friction below μ while
    a < ~1/s leaves a slip-speed offset of (7/2) μ g cos γ ∫ (1 − tanh(s a)) dt ≈ 1 mm/s; it
    equals the slip distance of the reduced scalar law ȧ = g sin γ − (7/2) g cos γ μ(a),
    integrated by scipy, to 1e-5, and the ideal one to 2.5e-3."""
    mu = 0.05
    traj = sphere.simulate(1.0, rtol=1e-10, atol=1e-12, max_step=0.005,
                           params={"mu_st": mu, "mu_c": mu, "mu_v": 0.0})
    assert traj.status == "finished"
    t = traj.t
    a = fit_acceleration(t, along(traj), 0.05)
    assert a == pytest.approx(G * (math.sin(GAMMA) - mu * math.cos(GAMMA)), rel=1e-7)
    keep = t >= 0.05
    alpha = np.polyfit(t[keep], spin(traj)[keep], 1)[0]
    assert alpha == pytest.approx(2.5 * mu * G * math.cos(GAMMA) / R, rel=1e-7)

    law = {"mu_st": mu, "mu_c": mu, "mu_v": 0.0, "s": SCVS["s"], "v_st": SCVS["v_st"]}
    reduced = solve_ivp(lambda _, y: [G * math.sin(GAMMA) - 3.5 * G * math.cos(GAMMA)
                                      * mu_1d(max(y[0], 0.0), **law), y[0]],
                        (0.0, t[-1]), [0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-14)
    slip = np.trapezoid(traj["friction.v"], t)
    assert slip == pytest.approx(reduced.y[1, -1], rel=1e-5)
    beta = G * (math.sin(GAMMA) - 3.5 * mu * math.cos(GAMMA))
    assert slip == pytest.approx(0.5 * beta * t[-1] ** 2, rel=2.5e-3)
    dissipated = np.trapezoid(traj["friction.Ft"] * traj["friction.v"], t)
    assert dissipated == pytest.approx(mu * M * G * math.cos(GAMMA) * slip, rel=1e-5)  # 1.5e-6
    ledger = traj.ledger()
    assert ledger["dissipated"] == pytest.approx(dissipated, rel=1e-4)
    assert abs(ledger["relative_residual"]) < 1e-8


def test_rolling_resistance_and_spin_friction_dissipate(sphere):
    """The optional torques: with a rolling lever arm c_r the rolling sphere's acceleration drops
    by c_r/r · m g cos γ/(m + I/r²) (a torque c_r Fn against the rolling; closed form to 1e-4), and
    their dissipation enters the ledger, which closes."""
    c_r = 0.001
    traj = sphere.simulate(1.0, rtol=1e-10, atol=1e-12, max_step=0.005,
                           params={"c_roll": c_r, "c_spin": 0.002})
    a = fit_acceleration(traj.t, along(traj), 0.2)
    expected = (M * G * math.sin(GAMMA) - c_r / R * M * G * math.cos(GAMMA)) / (1.4 * M)
    assert a == pytest.approx(expected, rel=1e-4)
    assert abs(traj.ledger()["relative_residual"]) < 1e-8


DISC = """
bonds = ["disc.c -> ground.p", "disc.cf -> friction.p"]
[model]
name = "disc_on_slope"
[parameters]
m = { value = 1.0, unit = "kg" }
r = { value = 0.05, unit = "m" }
gamma = { value = 0.3, unit = "rad" }
[components]
ground = { type = "HuntCrossley3D", plane = "xz", x = "disc.c.x", z = "disc.c.z", radius = "r", stiffness = 1e6, damping = 1e7, surface = "slope", slope = "gamma" }
friction = { type = "SCVSFriction3D", plane = "xz", normal_force = "ground.Fn", radius = "r", mu_st = 0.5, mu_c = 0.25, mu_v = 0.025, slope = 500, v_st = 0.02 }
[components.disc]
type = "Multibody"
plane = "xz"
gravity = [0, 0, -9.81]
[components.disc.bodies.hub]
mass = "m"
inertia = 0
[components.disc.bodies.wheel]
mass = "0*m"
inertia = ["m*r**2/4", "m*r**2/2", "m*r**2/4"]
world_frames = { c = [0, 0, 0], cf = [0, 0, 0] }
[components.disc.joints.slide]
type = "translational"
parent = "world"
child = "hub"
axes = ["x", "z"]
q0 = ["(r - m*9.81*cos(gamma)/1e6)*sin(gamma)", "(r - m*9.81*cos(gamma)/1e6)*cos(gamma)"]
[components.disc.joints.roll]
type = "revolute"
parent = "hub"
child = "wheel"
axis = "y"
"""


def test_disc_rolls_on_a_line_in_the_plane(isolated_cache):
    """The same components in the x-z plane (port (ω_y, v_x, v_z)): a disc (I = ½ m r²) rolls
    down the slope at (2/3) g sin γ (1e-5 relative), its material contact point's slip
    v_t − ω_y r (not v_t − ω_y r cos α of a point fixed on a spoke) stays at the creep speed,
    and its angle turns by (s − ∫ slip dt)/r (1e-6 relative)."""
    model = ph.compile_model(io.loads(DISC))
    traj = model.simulate(1.0, rtol=1e-10, atol=1e-12, max_step=0.005)
    assert traj.status == "finished"
    s = traj["disc.c.x"] * math.cos(GAMMA) - traj["disc.c.z"] * math.sin(GAMMA)
    assert fit_acceleration(traj.t, s, 0.2) == pytest.approx(2 / 3 * G * math.sin(GAMMA), rel=1e-5)
    creep = brentq(lambda x: mu_1d(x, **{k: SCVS[k] for k in ("mu_st", "mu_c", "mu_v", "v_st")},
                                   s=SCVS["s"]) - math.tan(GAMMA) / 3, 1e-9, 0.005)
    assert traj["friction.v"][-1] == pytest.approx(creep, rel=1e-3)
    assert traj["disc.q.slide.z"][0] != 0
    turned = (traj["disc.q.roll"][-1] - traj["disc.q.roll"][0]) * R
    slipped = np.trapezoid(traj["friction.vx"] * math.cos(GAMMA)
                           - traj["friction.vz"] * math.sin(GAMMA), traj.t)
    assert turned + slipped == pytest.approx(s[-1] - s[0], rel=1e-6)
    assert abs(traj.ledger()["relative_residual"]) < 1e-8


BALL = """
bonds = ["ball.c -> ground.p"]
[model]
name = "ball_on_step"
[parameters]
h = { value = 0.02, unit = "m" }
[components]
ground = { type = "HuntCrossley3D", x = "ball.c.x", y = "ball.c.y", z = "ball.c.z", radius = 0.05, stiffness = 1e5, damping = 1e4, exponent = 1.5, surface = "step", slope = 0.1, step_height = "h", step_x = 0.0 }
[components.ball]
type = "Multibody"
gravity = [0, 0, -9.81]
[components.ball.bodies.body]
mass = 0.5
world_frames = { c = [0, 0, 0] }
[components.ball.joints.slide]
type = "translational"
parent = "world"
child = "body"
axes = ["x", "y", "z"]
q0 = [0.3, 0.1, 0.2]
v0 = [0, 0.5, 0]
"""


def test_sphere_on_a_step_penetration_and_bounce(isolated_cache):
    """The step surface in 3D: the penetration is r minus the centre's normal distance from the
    lower plane past the edge (closed form at the initial point), the ball (Hertz exponent 3/2)
    falls, bounces and the ledger closes to 1e-8; y moves freely at its initial rate."""
    model = ph.compile_model(io.loads(BALL))
    traj = model.simulate(0.6, rtol=1e-10, atol=1e-12, max_step=0.005)
    assert traj.status == "finished"
    gamma, h, r = 0.1, 0.02, 0.05
    x, z = 0.3, 0.2
    distance = x * math.sin(gamma) + z * math.cos(gamma) + h * math.cos(gamma)
    assert traj["ground.z"][0] == pytest.approx(r - distance, abs=1e-12)
    assert np.max(traj["ground.Fn"]) > 0
    assert traj["ball.c.y"][-1] == pytest.approx(0.1 + 0.5 * 0.6, rel=1e-9)
    assert abs(traj.ledger()["relative_residual"]) < 1e-8


def test_bad_arguments_are_refused_by_name(isolated_cache):
    """A plane other than 'xz', a negative radius and a friction without a contact are typed
    errors naming the component and argument."""
    bad_plane = BALL.replace("radius = 0.05,", 'radius = 0.05, plane = "xy",')
    with pytest.raises(ParameterValueError, match="plane"):
        ph.compile_model(io.loads(bad_plane))
    with pytest.raises(ParameterValueError, match="radius"):
        ph.compile_model(io.loads(BALL.replace("radius = 0.05", "radius = -0.05")))
    orphan = DISC.replace('normal_force = "ground.Fn"', 'normal_force = "2.0"')
    with pytest.raises(ModelError, match="normal force"):
        ph.compile_model(io.loads(orphan))

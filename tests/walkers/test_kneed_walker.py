"""The kneed passive walker (``models/kneed_walker.toml``): a knee that locks by a plastic impact
onto its constraint (rule ``engage``), a heel strike that keeps the locked knee's rows.

Source [CHEN]: V. F. Hsu Chen, "Passive Dynamic Walking with Knees: A Point Foot Model", M.Eng.
thesis, MIT EECS, 2007: Table 3.1 (the parameters of the file), sec. 3.3 (slope 0.0504 rad; the
fixed point just after heel strike, 4 digits, angles from the vertical: q1 = 0.1877,
q2 = q3 = -0.2884 rad, q1_dot = -1.1014, q2_dot = q3_dot = -0.0399 rad/s), sec. 3.3.1 (return-map
eigenvalues 0.4053 and -0.2129 +- 0.3454i). The thesis's numbers are read through secondary
transcriptions; its eigenvalues are a least-squares fit to 25 perturbed runs, not a Jacobian, and
its fixed point comes from a fixed-step simulation, so the comparison with them is loose, each
tolerance stated with its reason. Our own exact results are pinned as regressions (1e-6).

The momentum checks are independent of the model's mass matrix: angular momenta are summed over
the five point masses from hand-written planar kinematics of the coordinates and rates.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from porthamiltonian.errors import ModelFileError
from walker_library import analyze_gait, load_walker

GAMMA = 0.0504
CHEN_Q1, CHEN_Q2 = 0.1877, -0.2884                # rad from the vertical, just after heel strike
CHEN_Q1_DOT, CHEN_Q2_DOT = -1.1014, -0.0399        # rad/s
CHEN_EIG = (0.4053, complex(-0.2129, 0.3454))
#: our exact results at the thesis's slope (regression, 1e-6): theta, theta_dot, phi_dot, and the
#: multipliers (the stride Jacobian's eigenvalues, error estimate 2e-9)
OURS = (0.23858546025605, -1.10958733118964, -1.05243922496028)
OURS_EIG = (complex(0.35257373880424, 0.55221145530298), 0.14382267382876)


@pytest.fixture(scope="module")
def walker():
    return load_walker("kneed_walker")


@pytest.fixture(scope="module")
def gait(walker):
    return analyze_gait(walker)


@pytest.fixture(scope="module")
def two_steps(walker, gait):
    """Two strides from the fixed point, with every transition's state before and after."""
    z = np.array([gait.fixed_point[n] for n in walker.section])
    strides = walker.walk(z, 2)
    assert [s.status.value for s in strides] == ["step", "step"]
    return strides


def test_the_gait_is_the_thesis_fixed_point(gait):
    """theta = q1 + gamma (the slope-normal angle), theta_dot = q1_dot, phi = q1 - q2 and the
    swing thigh's rate q2_dot = theta_dot - phi_dot. Published to 4 digits, but the thesis's
    fixed-step search puts q1 5e-4 rad and q1_dot 0.8 % from the exact fixed point (an independent
    reproduction with an exact Jacobian finds ours, 0.23859 and -1.10959): within 1 % for q1 and
    q1_dot; q2_dot = q1_dot - phi_dot is a difference of two rates near 1.1 rad/s, so 1 % of them
    is 0.011 rad/s: within 0.02 rad/s. Ours pinned to 1e-6."""
    assert gait.status == "periodic" and gait.period_steps == 1 and gait.stable
    th = gait.fixed_point
    theta = th["theta"]
    assert th["phi"] == pytest.approx(2 * theta, abs=1e-12)
    assert theta - GAMMA == pytest.approx(CHEN_Q1, rel=1e-2)
    assert th["phi"] == pytest.approx(CHEN_Q1 - CHEN_Q2, rel=1e-2)
    assert th["theta_dot"] == pytest.approx(CHEN_Q1_DOT, rel=1e-2)
    assert th["theta_dot"] - th["phi_dot"] == pytest.approx(CHEN_Q2_DOT, abs=2e-2)
    assert (theta, th["theta_dot"], th["phi_dot"]) == pytest.approx(OURS, abs=1e-6)


def test_the_multipliers(gait):
    """The thesis's eigenvalues are a least-squares fit to 25 perturbed runs (max |lambda| 0.41);
    the only claim they support is a stable gait, which ours is (max |lambda| 0.655, a complex
    pair and a real one, as the independent exact-Jacobian reproduction's 0.353 +- 0.552i, 0.144,
    which ours match to its 3 digits). Ours pinned to 1e-6 (their error estimate ~2e-9)."""
    mu = sorted(gait.floquet_multipliers, key=lambda z: (-abs(z), z.imag))
    assert max(abs(m) for m in mu) < 1 and max(abs(m) for m in CHEN_EIG) < 1
    assert max(gait.multiplier_errors) < 1e-7
    assert mu[0] == pytest.approx(OURS_EIG[0].conjugate(), abs=1e-6) or \
        mu[0] == pytest.approx(OURS_EIG[0], abs=1e-6)
    assert {round(m.real, 3) for m in mu[:2]} == {0.353} and abs(mu[0].imag) == pytest.approx(
        0.552, abs=5e-4)
    assert mu[2] == pytest.approx(OURS_EIG[1], abs=1e-6)
    assert gait.metrics.step_period == pytest.approx(0.56432817, abs=1e-6)


def test_the_multipliers_by_differences_of_strides(walker, gait):
    """The multipliers come from the variational equations with the saltation at the knee strike
    (the impact onto the constraint) and the heel strike; central differences of whole strides
    (h = 1e-5, truncation error ~1e-10, the strides' error ~1e-12 / h) give the same to 1e-7."""
    z = np.array([gait.fixed_point[n] for n in walker.section])

    def stride(z):
        return walker.stride(z).z_next

    h = 1e-5
    J = np.column_stack([(stride(z + h * e) - stride(z - h * e)) / (2 * h) for e in np.eye(3)])
    fd = sorted(np.linalg.eigvals(J), key=lambda m: (abs(m), m.imag))
    exact = sorted(gait.floquet_multipliers, key=lambda m: (abs(m), m.imag))
    assert np.max(np.abs(np.array(fd) - np.array(exact))) < 1e-7


# --- the angular momenta, from the point masses --------------------------------------------------
def _masses(walker, x, p):
    """(mass, position, velocity) of the five point masses (slope frame x, z) and the points
    (stance foot, hip, swing foot), from the coordinates and rates by hand-written kinematics:
    an absolute angle a turns a body's z axis to (sin a, cos a)."""
    P = dict(zip(walker.model.param_names, p))
    st, hp, kn = (walker.model.state_index(f"walker.q.{j}") for j in ("stance", "hip", "knee"))
    v = walker.velocities(x, p)
    a1, b1, a2, b2 = P["a1"], P["b1"], P["a2"], P["b2"]
    ls, lt = a1 + b1, a2 + b2
    angles = np.array([x[st], x[st] + x[hp], x[st] + x[hp] + x[kn]])
    rates = np.array([v[0], v[0] + v[1], v[0] + v[1] + v[2]])

    def e(k):
        return np.array([np.sin(angles[k]), np.cos(angles[k])])

    def de(k):
        return rates[k] * np.array([np.cos(angles[k]), -np.sin(angles[k])])

    foot = np.array([P["stance_x"], P["stance_z"]])
    pts = {"stance": (foot, np.zeros(2))}
    pts["hip"] = (foot + (ls + lt) * e(0), (ls + lt) * de(0))
    knee = (pts["hip"][0] - lt * e(1), pts["hip"][1] - lt * de(1))
    pts["swing"] = (knee[0] - ls * e(2), knee[1] - ls * de(2))
    stance = [(P["m_s"], foot + a1 * e(0), a1 * de(0)),
              (P["m_t"], foot + (ls + a2) * e(0), (ls + a2) * de(0))]
    hip = [(P["m_H"], *pts["hip"])]
    swing = [(P["m_t"], pts["hip"][0] - b2 * e(1), pts["hip"][1] - b2 * de(1)),
             (P["m_s"], knee[0] - b1 * e(2), knee[1] - b1 * de(2))]
    return {"stance": stance, "hip": hip, "swing": swing}, pts, rates


def _angular(masses, about):
    """Angular momentum (kg m^2/s, about the slope's y axis up to sign) of ``masses`` about the
    point ``about`` (position, velocity: the momentum about a moving point uses absolute
    velocities)."""
    return sum(m * ((r - about)[1] * w[0] - (r - about)[0] * w[1]) for m, r, w in masses)


def _fired(strides, name):
    return [f for s in strides for f in s.info["fired"] if f.transition.event == name]


def test_knee_strike_conserves_whole_body_and_swing_leg_momenta(walker, two_steps):
    """The knee strike's impulses act at the stance foot (the pin) and inside the swing leg (the
    lock): the whole walker's angular momentum about the stance foot and the swing leg's about
    the hip are conserved (1e-12 relative); after it the knee's rate is zero (the lock holds)."""
    strikes = _fired(two_steps, "knee_strike")
    assert len(strikes) == 2
    for f in strikes:
        before, pts, _ = _masses(walker, f.x_minus, f.p_minus)
        after, _, rates = _masses(walker, f.x_plus, f.p_plus)
        foot, hip = pts["stance"][0], pts["hip"][0]
        every = [*before["stance"], *before["hip"], *before["swing"]]
        total = _angular(every, foot)
        assert _angular([*after["stance"], *after["hip"], *after["swing"]], foot) == \
            pytest.approx(total, rel=1e-12)
        leg = _angular(before["swing"], hip)
        assert _angular(after["swing"], hip) == pytest.approx(leg, rel=1e-12, abs=1e-14)
        assert rates[2] - rates[1] == pytest.approx(0.0, abs=1e-12)
        assert f.p_plus[walker.model.param_names.index("knee_locked")] == 1.0
        assert f.info["impact_energy_lost"] > 0


def test_heel_strike_conserves_momenta_and_keeps_the_knee_locked(walker, two_steps):
    """The heel strike's impulses act at the striking foot and inside the locked swing leg: the
    whole walker's angular momentum about the striking foot and the trailing (old stance) leg's
    about the hip are conserved (1e-12 relative). The legs exchange: after it the striking foot is
    the stance foot, the trailing leg the swing leg, straight (knee rate 0: the locked rows were
    in the impact) and unlocked."""
    strikes = _fired(two_steps, "heel_strike")
    assert len(strikes) == 2
    for f in strikes:
        before, pts, _ = _masses(walker, f.x_minus, f.p_minus)
        after, pts_after, rates = _masses(walker, f.x_plus, f.p_plus)
        contact = pts["swing"][0]
        assert pts_after["stance"][0] == pytest.approx(contact, abs=1e-12)
        every_before = [*before["stance"], *before["hip"], *before["swing"]]
        every_after = [*after["stance"], *after["hip"], *after["swing"]]
        total = _angular(every_before, contact)
        assert _angular(every_after, contact) == pytest.approx(total, rel=1e-12)
        trailing = _angular(before["stance"], pts["hip"][0])
        hip_after = pts_after["hip"][0]
        assert _angular(after["swing"], hip_after) == pytest.approx(trailing, rel=1e-12)
        assert rates[2] - rates[1] == pytest.approx(0.0, abs=1e-12)
        assert f.p_plus[walker.model.param_names.index("knee_locked")] == 0.0


def test_the_ledger_books_both_impacts(two_steps):
    """Per step the energy dissipated is the knee strike's and the heel strike's kinetic-energy
    losses, and it equals the potential energy released (a periodic gait): the ledger's residual
    at 1e-9 of the energy dissipated per step."""
    for s in two_steps:
        lost = sum(f.info["impact_energy_lost"] for f in s.info["fired"])
        assert s.energy_dissipated == pytest.approx(lost, rel=1e-9)
        assert s.potential_released == pytest.approx(s.energy_dissipated, rel=1e-8)
        assert abs(s.energy_residual) < 1e-9 * s.energy_dissipated
    knee = [f.info["impact_energy_lost"] for f in _fired(two_steps, "knee_strike")]
    assert 0.01 < knee[0] < 0.03          # 0.0164 J of the 0.374 J a step dissipates


# --- bad entries --------------------------------------------------------------------------------
ENGAGE = 'engage = "walker.knee_lock"'


@pytest.mark.parametrize("old,new,needle,message", [
    (ENGAGE, 'engage = "walker.knee_lok"', "knee_lok",
     ("[[walker.rules]] #1: engage 'walker.knee_lok' is not a loop or constraint of a multibody "
     "(did you mean 'walker.knee_lock'?)")),
    (ENGAGE, ENGAGE + '\nimpact = "walker.swing_foot"', ENGAGE,
     "[[walker.rules]] #1: a rule applies one impact: at a point (impact) or onto a constraint"),
    (ENGAGE, ENGAGE + "\nset = { knee_locked = 1 }", ENGAGE,
     "engage 'walker.knee_lock' sets its switch 'knee_locked' to 1 itself"),
    ('active = "knee_locked"', 'active = "1"', ENGAGE,
     "engage 'walker.knee_lock': its 'active' is '1', not a mode"),
    ('joint = "knee"', 'joint = "hip"', 'impact = "walker.swing_foot"',
     ("[[walker.rules]] #2: the impact releases the pinned root joint 'stance', but constraint "
     "'knee_lock' is written on the root body 'stance_leg' or a joint on it")),
])
def test_a_bad_engage_names_file_line_and_rule(old, new, needle, message, tmp_path):
    """Every bad entry of the constraint rules is a ModelFileError naming the file, the line of
    the rule's key and the rule."""
    text = (Path(__file__).parents[2] / "models" / "kneed_walker.toml").read_text()
    assert old in text
    bad = tmp_path / "bad_kneed_walker.toml"
    bad.write_text(text.replace(old, new, 1))
    with pytest.raises(ModelFileError) as err:
        load_walker(bad)
    msg = str(err.value)
    line = next(i for i, ln in enumerate(bad.read_text().splitlines(), 1) if needle in ln)
    assert msg.startswith(f"{bad}, line {line}:"), msg
    assert message in msg, msg


def test_a_heel_strike_with_the_knee_bent_is_a_fall(walker):
    """Launched with a fast stance leg (theta_dot = -1.6 rad/s), the swing foot reaches the slope in
    front of the stance foot before its knee has straightened: the thesis's rule makes that a fall
    (a result, reason the event), not a step and not an error."""
    s = walker.walk(np.array([-0.2386, 1.6, -0.2]), 1, record=True)[-1]
    assert s.status.value == "fell" and s.reason == "heel_strike"
    x = s.info["trajectory"].x[-1]
    assert x[walker.model.state_index("walker.q.knee")] > 0.3   # flexed 0.343 rad
    assert walker.output("walker.swing_foot.x", x) > 0.05   # in front of the stance foot (at 0)


# --- a loop engaged by a rule ---------------------------------------------------------------------
LOCK = '''[components.walker.constraints.knee_lock]
type = "lock"
joint = "knee"
active = "knee_locked"'''
#: the same lock as a loop-closing joint: a translational joint between the swing thigh and
#: shank at the knee, free in the plane (axes x, z), so its only row is the relative rotation's,
#: phi = sin(q_knee) (the lock's row times cos(q_knee) = 1 at extension)
LOOP = '''[components.walker.loops.knee_lock]
type = "translational"
parent = "swing_thigh"
child = "swing_shank"
origin = [0, 0, "-(a2 + b2)"]
axes = ["x", "z"]
active = "knee_locked"'''


def test_a_loop_engaged_by_a_rule_locks_the_knee_as_the_constraint_does(walker, gait, two_steps,
                                                                      tmp_path):
    """The rule ``engage = "walker.knee_lock"`` on a loop (the knee's lock written as a loop joint,
    ``LOOP``) instead of a constraint: the knee strike's plastic impact onto the loop's row, then
    the loop active until the heel strike. From the gait's fixed point the stride is the lock's:
    the knee strike's loss (Kelvin's, the same projection) to 1e-9 relative and the next section
    state to 1e-9; the ledger closes (1e-9 of the energy dissipated); between the engagement and
    the heel strike the loop stays closed: its residual and its velocity row at the heel strike
    ≤ 1e-9 (rad, rad/s), the knee rate zero just after the engagement (1e-12)."""
    text = (Path(__file__).parents[2] / "models" / "kneed_walker.toml").read_text()
    assert LOCK in text
    path = tmp_path / "kneed_walker_loop.toml"
    path.write_text(text.replace(LOCK, LOOP))
    looped = load_walker(path)
    model = looped.model
    assert "walker.phi.knee_lock.wy" in model.output_names
    z = np.array([gait.fixed_point[n] for n in walker.section])
    (stride,) = looped.walk(z, 1)
    ref = two_steps[0]
    assert stride.status.value == "step"
    assert stride.z_next == pytest.approx(ref.z_next, abs=1e-9)
    (knee,) = _fired([stride], "knee_strike")
    lost = knee.info["impact_energy_lost"]
    assert lost == pytest.approx(_fired([ref], "knee_strike")[0].info["impact_energy_lost"],
                                 rel=1e-9)
    assert knee.p_plus[model.param_names.index("knee_locked")] == 1.0
    _, _, rates = _masses(looped, knee.x_plus, knee.p_plus)
    assert rates[2] - rates[1] == pytest.approx(0.0, abs=1e-12)
    assert abs(stride.energy_residual) < 1e-9 * stride.energy_dissipated
    (heel,) = _fired([stride], "heel_strike")
    y = model.outputs(heel.t, heel.x_minus, heel.p_minus)
    for name in ("walker.phi.knee_lock.wy", "walker.velocity.knee_lock.wy"):
        assert abs(y[model.output_index(name)]) < 1e-9, name

"""Closed kinematic loops (porthamiltonian.mechanics.closure, .constrained) on published
multibody benchmarks and closed forms.

References
----------
[Norton] R. L. Norton, *Design of Machinery*, 5th ed., McGraw-Hill 2012, §4.5 (position analysis
    of the four-bar: the intersection of the circles about A and B) and §6.7 (velocities).
[HW] E. Hairer, G. Wanner, *Solving Ordinary Differential Equations II*, 2nd ed., Springer 1996,
    §VII.7, Andrews' squeezing mechanism; [TestSet] F. Mazzia, C. Magherini, *Test Set for
    Initial Value Problem Solvers*, release 2.4, Univ. of Bari 2008, problem "andrews" (the
    reference solution at t = 0.03 s, computed with PSIDE at rtol = atol = 1e-14; the
    consistent initial values with λ(0)).
[IFToMM] M. González, D. Dopico, U. Lugrís, J. Cuadrado, "A benchmarking system for MBS
    simulation software", *Multibody Syst. Dyn.* 16 (2006) 179–190, and the IFToMM Library of
    Computational Benchmark Problems, "spatial rigid slider-crank mechanism": the reference
    curve of the slider's position (Δt = 0.01 s, 0–5 s; the library's solution with the crank's
    centre of mass at mid-crank and the rod a slender body, total energy 0.76643568 J).
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import porthamiltonian as ph
from porthamiltonian import errors, io
from porthamiltonian.simulation.assembly import AssemblyWarning

FOUR_BAR = {"a": 0.1, "b": 0.35, "c": 0.3, "d": 0.42}


def four_bar_closed_form(theta2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """θ3 (coupler) and θ4 (rocker) of the open four-bar for crank angles θ2 [Norton]: C is the
    intersection of the circle of radius b about A = a e(θ2) and of radius c about B = (d, 0)
    to the left of A→B."""
    a, b, c, d = (FOUR_BAR[k] for k in "abcd")
    ax, az = a * np.cos(theta2), a * np.sin(theta2)
    fx, fz = d - ax, -az
    f = np.hypot(fx, fz)
    theta3 = np.arctan2(fz, fx) + np.arccos((b**2 + f**2 - c**2) / (2 * b * f))
    cx, cz = ax + b * np.cos(theta3), az + b * np.sin(theta3)
    return theta3, np.arctan2(cz, cx - d)


def wrapped(x: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * np.asarray(x)))


def residuals(model, traj, kind: str) -> float:
    """max over the run and the rows of |φ| (kind "phi") or |G v| (kind "velocity")."""
    return max(float(np.max(np.abs(traj[o]))) for o in model.output_names if f".{kind}." in o)


@pytest.fixture(scope="module")
def four_bar(isolated_cache):
    return ph.compile_model(io.load("four_bar"), backend="c")


@pytest.fixture(scope="module")
def four_bar_turn(four_bar):
    """0.3 s: the crank turns 10.1 rad (more than a full turn)."""
    return four_bar.simulate(0.3, method="Rodas5P", rtol=1e-10, atol=1e-12)


def test_four_bar_follows_the_closed_form_over_a_full_crank_turn(four_bar_turn):
    """Coupler and rocker angles against [Norton]'s closed form at every step of a run at
    rtol 1e-10: to 1e-9 rad (measured 6.0e-10), with the crank past a full turn."""
    traj = four_bar_turn
    assert traj["theta2"][-1] > 2 * math.pi + 1
    theta3, theta4 = four_bar_closed_form(traj["theta2"])
    assert np.max(np.abs(wrapped(traj["theta3"] - theta3))) < 1e-9
    assert np.max(np.abs(wrapped(traj["theta4"] - theta4))) < 1e-9


def test_four_bar_conserves_energy_and_stays_on_its_constraints(four_bar, four_bar_turn):
    """No damping: H = T + V is conserved — the constraint forces do no work — to 1e-9 of the
    energy in play (measured 2e-10); |φ| ≤ 1e-9 m and |G v| ≤ 1e-8 m/s (measured 1.8e-10 and
    1.2e-9, at crank-tip speeds of 3 m/s). Regression: θ2(0.3 s) = 10.11568075 rad (the run's
    own value, to 1e-8 rad)."""
    traj = four_bar_turn
    assert traj.relative_residual < 1e-9
    assert float(np.ptp(traj.H)) / traj.energy_scale < 1e-9
    assert residuals(four_bar, traj, "phi") < 1e-9
    assert residuals(four_bar, traj, "velocity") < 1e-8
    assert traj["theta2"][-1] == pytest.approx(10.1156807524, abs=1e-8)


def test_four_bar_closed_by_a_stiff_spring_converges_to_the_joint(four_bar, four_bar_turn):
    """The loop closed by an isotropic spring of stiffness k instead of the joint (closed = 0):
    at t = 0.3 s the angles differ from the jointed linkage's by O(1/k) — the error falls tenfold
    per decade of k (measured 5.8e-3, 5.7e-4 rad at k = 1e6, 1e7 N/m: ratio 10.2)."""
    ref = np.array([four_bar_turn[k][-1] for k in ("theta2", "theta3", "theta4")])
    errors_k = []
    for k in (1e6, 1e7):
        traj = four_bar.simulate(0.3, params={"closed": 0.0, "k_loop": k}, method="Rodas5P",
                                 rtol=1e-9, atol=1e-11)
        assert traj.relative_residual < 1e-7
        errors_k.append(np.max(np.abs([traj[n][-1] for n in ("theta2", "theta3", "theta4")]
                                      - ref)))
    assert errors_k[1] < 1e-3
    assert 7 < errors_k[0] / errors_k[1] < 14


def four_bar_energy_terms(theta2: float, h: float = 1e-4) -> tuple[float, float, float]:
    """(V', V'', m_eff) at crank angle θ2 from [Norton]'s closed form, by central differences:
    V the potential (g = 9.81, the model's masses), m_eff the kinetic energy per ½ θ̇2²."""
    a, b, c = FOUR_BAR["a"], FOUR_BAR["b"], FOUR_BAR["c"]
    m2, m3, m4, g = 0.5, 1.0, 1.0, 9.81

    def V(t2):
        t3, t4 = four_bar_closed_form(np.array(t2))
        return g * (m2 * a / 2 * np.sin(t2) + m3 * (a * np.sin(t2) + b / 2 * np.sin(t3))
                    + m4 * c / 2 * np.sin(t4))

    (t3m, t4m), (t3p, t4p) = (four_bar_closed_form(np.array(theta2 + s * 1e-6)) for s in (-1, 1))
    w3, w4 = (t3p - t3m) / 2e-6, (t4p - t4m) / 2e-6
    t3, _ = four_bar_closed_form(np.array(theta2))
    v3 = a * np.array([-np.sin(theta2), np.cos(theta2)]) + b / 2 * w3 * np.array(
        [-np.sin(t3), np.cos(t3)])
    m_eff = m2 * a**2 / 3 + m3 * v3 @ v3 + m3 * b**2 / 12 * w3**2 + m4 * c**2 / 3 * w4**2
    dV = (V(theta2 + h) - V(theta2 - h)) / (2 * h)
    d2V = (V(theta2 + h) - 2 * V(theta2) + V(theta2 - h)) / h**2
    return float(dV), float(d2V), float(m_eff)


def test_trim_of_the_four_bar_stays_on_its_constraints(four_bar):
    """Trim (ẋ = 0) of the linkage at rest keeps every iterate on the constraints, so it finds an
    equilibrium of the mechanism (not a point off the constraints where the drift stabilization
    balances gravity): |φ| at round-off, V'(θ2) = 0 by [Norton]'s closed form (to 1e-7 N m,
    measured 6e-10, the differences' error), and the linearization's eigenvalues ±√(−V''/m_eff) of
    this unstable equilibrium (to 1e-6 relative, the differences' accuracy; measured 8.5e-9)
    beside the stabilization's −10s."""
    p = {"w0": 0.0}
    result = four_bar.trim(x=four_bar.initial_state(four_bar.params(p)), params=p)
    assert result.success, result.message
    y = four_bar.outputs(0.0, four_bar.augment(result.x), four_bar.params(p))
    assert max(abs(y[four_bar.output_index(o)]) for o in four_bar.output_names
               if ".phi." in o) < 1e-12
    theta2 = float(result.x[four_bar.state_index("linkage.q.crank")])
    dV, d2V, m_eff = four_bar_energy_terms(theta2)
    assert abs(dV) < 1e-7 and d2V < 0
    lam = np.linalg.eigvals(four_bar.linearize(x=result.x, params=p).A)
    mechanism = lam[np.abs(lam.real + 10) > 1e-3]
    assert np.sort(mechanism.real) == pytest.approx(
        [-math.sqrt(-d2V / m_eff), math.sqrt(-d2V / m_eff)], rel=1e-6)


def test_four_bar_off_its_constraints_is_assembled_with_a_warning(four_bar):
    """An initial rocker angle 0.05 rad off the closed configuration: a warning quoting the
    residual, and the run starts on the manifold (|φ(0)| at round-off, 1e-13)."""
    x0 = four_bar.initial_state()
    x0[four_bar.state_index("linkage.q.rocker")] += 0.05
    with pytest.warns(AssemblyWarning, match=r"position residual 0\.0138.*Newton projection"):
        traj = four_bar.simulate(1e-3, x0=x0, method="Rodas5P", rtol=1e-10, atol=1e-12)
    assert max(abs(traj[o][0]) for o in four_bar.output_names if ".phi." in o) < 1e-13


def test_four_bar_that_cannot_close_is_refused_before_it_runs(four_bar):
    """A ground link longer than the three others together (d = 0.9 m > a + b + c): the
    closed-form initial angles cannot be evaluated; the ParameterValueError names the joint, the
    expression and the parameter values."""
    with pytest.raises(errors.ParameterValueError, match=r"joint 'coupler' q0 = acos.*d = 0\.9"):
        four_bar.simulate(1e-3, params={"d": 0.9})


def test_a_run_continued_from_its_end_state_is_not_warned_about(four_bar, four_bar_turn):
    """The drift a run leaves (|φ| ~ 1e-10) is projected silently when a run continues."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", AssemblyWarning)
        four_bar.simulate(0.31, x0=four_bar_turn.x_final, t_start=0.3, method="Rodas5P",
                          rtol=1e-10, atol=1e-12)


# --- Andrews' squeezing mechanism ------------------------------------------------------------
#: [TestSet]'s reference positions at t = 0.03 s (andrews.f, subroutine solut)
ANDREWS_Q = {"beta": 0.1581077119629904e+02, "theta": -0.1575637105984298e+02,
             "gamma": 0.4082224013073101e-01, "phi": -0.5347301163226948e+00,
             "delta": 0.5244099658805304e+00, "omega": 0.5347301163226948e+00,
             "epsilon": 0.1048080741042263e+01}
#: its multipliers λ1..λ6 at t = 0 and t = 0.03 s (the forces at E, [HW]'s x, y axes: our x, z)
ANDREWS_LAMBDA_0 = [98.5668703962410896057654982170, -6.12268834425566265503114393122,
                    0, 0, 0, 0]
ANDREWS_LAMBDA_T = [0.1991753333731910e+03, -0.2975531228015052e+02, 0.2306654119098399e+02,
                    0.3145271365475927e+02, 0.2264249232082739e+02, 0.1161740700019673e+02]
ANDREWS_REACTIONS = [f"squeezer.reaction.{e}.{r}" for e in ("E3", "E4", "E6") for r in "xz"]


@pytest.fixture(scope="module")
def andrews(isolated_cache):
    model = ph.compile_model(io.load("andrews_squeezer"), backend="python")
    return model, model.simulate(0.03, method="Rodas5P", rtol=1e-8, atol=1e-10)


def test_andrews_positions_at_t_end_match_the_test_set(andrews):
    """The seven angles at t = 0.03 s against [TestSet]'s reference: relative error ≤ 1e-6 at
    rtol 1e-8 (the issue's bar; measured: γ 4.2e-7, the others ≤ 6.5e-8). Regression (the run's
    own values, to the 3e-8 the C and Python back ends differ by at this tolerance):
    γ(0.03) = 0.040822222800."""
    _, traj = andrews
    rel = {k: abs(traj[k][-1] - v) / abs(v) for k, v in ANDREWS_Q.items()}
    assert max(rel.values()) <= 1e-6, rel
    assert traj["gamma"][-1] == pytest.approx(0.040822222800, rel=1e-7)


def test_andrews_constraint_forces_match_the_test_sets_multipliers(andrews):
    """The reactions at E are [TestSet]'s multipliers (same rows, same signs): at t = 0 to 1e-12
    relative (measured 3e-15), at t = 0.03 s to 1e-5 (measured ≤ 3.1e-6; multipliers are
    acceleration-level, one order less accurate than positions)."""
    _, traj = andrews
    start = np.array([traj[r][0] for r in ANDREWS_REACTIONS])
    assert start == pytest.approx(ANDREWS_LAMBDA_0, rel=1e-12, abs=1e-12)
    end = np.array([traj[r][-1] for r in ANDREWS_REACTIONS])
    assert end == pytest.approx(ANDREWS_LAMBDA_T, rel=1e-5)


def test_andrews_multipliers_keep_the_constraints_at_acceleration_level_off_the_manifold(andrews):
    """At a state off the constraints (angles and momenta perturbed), the generated ṗ (with the
    multipliers) satisfies the index-reduced rows G a + Ġ v = −γ G v (γ = 10, the default) with
    a = M⁻¹(ṗ − Ṁ v) and Ṁ v, Ġ v by central differences of the matrices M and G along v: a
    second derivation of the velocity products the generated code forms recursively. Measured
    8e-12 relative to |Ġ v| (the differences' error)."""
    model, _ = andrews
    rng = np.random.default_rng(3)
    p = model.params()
    x = model.initial_state() + 0.05 * rng.standard_normal(model.n_states)
    n = model.n_states // 2

    def matrix(name: str, y: np.ndarray) -> np.ndarray:
        return model.matrix(f"squeezer.{name}", 0.0, y, p)

    v = np.linalg.solve(matrix("M", x), x[n:])
    step = np.zeros(model.n_states)
    step[:n] = 1e-5 * v / np.max(np.abs(v))
    h = 1e-5 / np.max(np.abs(v))
    Mdot_v, Gdot_v = ((matrix(k, x + step) - matrix(k, x - step)) @ v / (2 * h)
                      for k in ("M", "G"))
    a = np.linalg.solve(matrix("M", x), model.derivative(0.0, x)[n:] - Mdot_v)
    rows = matrix("G", x) @ a + Gdot_v + 10.0 * matrix("G", x) @ v
    assert np.max(np.abs(rows)) <= 1e-9 * np.max(np.abs(Gdot_v))


def test_andrews_energy_ledger_closes(andrews):
    """The motor supplies 0.524 J in 0.033 N m × Δβ (to 1e-9: the ledger's quadrature); H(T) − H(0) − supplied ≤ 1e-7 of the energy in play
    (measured 1.3e-8: the constraint forces do no work); drift |φ| ≤ 3.5e-9 m, 10 rtol of the
    35 mm link B–E (measured 1.7e-9 m)."""
    model, traj = andrews
    assert traj.E_in[-1] == pytest.approx(0.033 * (traj["beta"][-1] - traj["beta"][0]),
                                          rel=1e-9)
    assert traj.relative_residual < 1e-7
    assert residuals(model, traj, "phi") < 3.5e-9


# --- the IFToMM spatial slider-crank ---------------------------------------------------------
#: [IFToMM]'s reference curve (González), slider x (m) at selected times (s)
SLIDER = {0.10: 0.226785384, 0.27: 0.290058606, 0.50: 0.184952803, 1.00: 0.211754668,
          2.00: 0.289063554, 3.00: 0.228450093, 4.00: 0.188208161, 5.00: 0.240761815}


@pytest.fixture(scope="module")
def slider_crank(isolated_cache):
    """The run over the benchmark's 5 s in segments ending at the reference times (the compiled
    Rodas loop keeps no dense output; each segment continues from the last's end state)."""
    model = ph.compile_model(io.load("spatial_slider_crank"), backend="c")
    x, start, out, runs = None, 0.0, {}, []
    for t in SLIDER:
        traj = model.simulate(t, x0=x, t_start=start, method="Rodas5P", rtol=1e-9, atol=1e-11)
        x, start, out[t] = traj.x_final, t, traj["slider"][-1]
        runs.append(traj)
    return model, out, runs


def test_slider_crank_follows_the_iftomm_reference(slider_crank):
    """The slider's position against [IFToMM]'s reference curve at eight times over 5 s: within
    1e-4 m (the library publishes no tolerance; the curve is tabulated to 1e-9 m at 0.01 s. The
    error grows with the phase to 4.2e-5 m at 5 s; the same model integrated as a 1-DOF
    Lagrangian in the crank angle with DOP853 at 1e-12 gives x(5 s) = 0.2407196, as here).
    Regression: x(5 s) = 0.24071957 (to 1e-7 m)."""
    _, out, _ = slider_crank
    err = {t: out[t] - ref for t, ref in SLIDER.items()}
    assert max(abs(e) for e in err.values()) < 1e-4, err
    assert out[5.0] == pytest.approx(0.24071957, abs=1e-7)


def test_slider_crank_energy_is_the_benchmarks_and_is_conserved(slider_crank):
    """E(0) = 0.76643568 J ([IFToMM]'s value for this inertia variant, exact to the digits);
    conserved to 1e-8 of the energy in play over every segment, and H(5 s) within 5e-8 J of E(0)
    (measured 3.7e-9 J; each restart also projects the velocities onto G v = 0, which removes
    the velocity error's kinetic energy); |φ| ≤ 1e-9 m."""
    model, _, runs = slider_crank
    assert runs[0].H[0] == pytest.approx(0.76643568, abs=5e-9)
    for traj in runs:
        assert traj.relative_residual < 1e-8
        assert residuals(model, traj, "phi") < 1e-9
    assert runs[-1].H[-1] == pytest.approx(0.76643568, abs=5e-8)


# --- rolling without slipping (nonholonomic) -------------------------------------------------
@pytest.fixture(scope="module")
def rolling_disc(isolated_cache):
    return ph.compile_model(io.load("rolling_disc"), backend="c")


def axle_tilt(model, traj) -> np.ndarray:
    """asin of the world z component of the disc's axle (body y): the lean (rad)."""
    qw, qx, qy, qz = (traj.x[:, model.state_index(f"mb.q.free.{c}")]
                      for c in ("qw", "qx", "qy", "qz"))
    norm = qw**2 + qx**2 + qy**2 + qz**2
    return np.arcsin(np.clip(2 * (qy * qz + qw * qx) / norm, -1, 1))


@pytest.mark.parametrize("factor, falls", [(0.9, True), (1.1, False)])
def test_rolling_disc_is_stable_upright_above_the_classical_speed(rolling_disc, factor, falls):
    """A thin uniform disc rolling upright is stable iff v² > g r / 3 (Neimark & Fufaev,
    *Dynamics of Nonholonomic Systems*, 1972): nudged by a lean rate of 1e-3 rad/s, at 0.9 of
    that speed it leaves the upright motion, leaning past 0.3 rad within 6 s (measured 0.49 rad),
    at 1.1 its lean stays below 1e-3 rad (measured 4.3e-4). Energy is conserved to 1e-8 of the energy in play (the rolling
    constraint does no work) and the contact point's velocity (the no-slip rows, G v) stays
    below 1e-8 m/s."""
    v = factor * math.sqrt(9.81 * 0.3 / 3)
    traj = rolling_disc.simulate(6.0, params={"v": v, "lean_rate": 1e-3}, method="Rodas5P",
                                 rtol=1e-10, atol=1e-12)
    lean = np.max(np.abs(axle_tilt(rolling_disc, traj)))
    assert (lean > 0.3) if falls else (lean < 1e-3), lean
    assert traj.relative_residual < 1e-8
    assert residuals(rolling_disc, traj, "velocity") < 1e-8


# --- a constraint switched by an event: a knee that locks -------------------------------------
KNEE = """
[model]
name = "locking_knee"

[parameters]
locked = 0.0

[components.mb]
type = "Multibody"

[components.mb.bodies.thigh]
mass = 2.0
com = [0, 0, -0.2]
inertia = [0.03, 0.03, 0.03]

[components.mb.bodies.shank]
mass = 1.0
com = [0, 0, -0.25]
inertia = [0.02, 0.02, 0.02]

[components.mb.joints.hip]
type = "revolute"
parent = "world"
child = "thigh"
axis = "y"
q0 = 0.3
v0 = -1.0

[components.mb.joints.knee]
type = "revolute"
parent = "thigh"
child = "shank"
origin = [0, 0, -0.4]
axis = "y"
q0 = -0.4
v0 = 3.0

[components.mb.constraints.lock]
type = "lock"
joint = "knee"
active = "locked"

[[events]]
name = "knee_strike"
guard = "mb.q.knee - locked"        # off once locked
direction = 1
"""


@pytest.fixture(scope="module")
def knee(isolated_cache):
    return ph.compile_model(io.loads(KNEE, "locking_knee.toml"), backend="python")


def test_knee_locks_by_a_plastic_impact_onto_its_constraint(knee):
    """A two-segment leg swinging from a hip pivot, its knee free until it reaches full extension
    (the event), then locked (``switching.engage``: the plastic impact onto the lock, then the
    constraint active). The lock's impulse acts on the knee coordinate only, so the momentum
    conjugate to the hip angle — the leg's angular momentum about the hip — is conserved through
    the impact (to 1e-12), the knee rate after it is zero and the hip rate is that momentum over
    the locked leg's inertia about the hip (both to 1e-12); afterwards the knee stays straight
    (|q_knee| ≤ 1e-9 over 1 s) and the energy ledger closes with the impact's loss booked as
    dissipated (to 1e-9; the loss is Kelvin's ½ Δvᵀ M Δv)."""
    from porthamiltonian.simulation.switching import engage

    action = engage(knee, "mb", "lock", "locked")
    traj = knee.simulate(1.0, actions={"knee_strike": action}, method="Radau", rtol=1e-11,
                         atol=1e-13)
    assert [name for _, name in traj.events] == ["knee_strike"]
    t_hit = traj.events[0][0]
    k = int(np.searchsorted(traj.t, t_hit)) + 1       # the event's point after the impact
    ih, ik = knee.state_index("mb.p.hip"), knee.state_index("mb.p.knee")
    before, after = traj.x[k - 1], traj.x[k]
    assert traj.t[k - 1] == traj.t[k] == t_hit
    assert after[ih] == pytest.approx(before[ih], rel=1e-12)
    p = knee.params({"locked": 1.0})
    M = knee.matrix("mb.M", t_hit, after, p)
    v_plus = np.linalg.solve(M, after[[ih, ik]])
    assert v_plus[1] == pytest.approx(0.0, abs=1e-12)
    assert v_plus[0] == pytest.approx(after[ih] / M[0, 0], rel=1e-12)
    v_minus = np.linalg.solve(M, before[[ih, ik]])
    loss = 0.5 * (v_minus - v_plus) @ M @ (v_minus - v_plus)
    assert traj.E_diss[k] - traj.E_diss[k - 1] == pytest.approx(loss, rel=1e-9)
    assert loss > 0.01
    assert np.max(np.abs(traj["mb.q.knee"][k:])) < 1e-9
    assert traj.relative_residual < 1e-9


def test_switching_a_constraint_that_does_not_exist_names_the_known_ones(knee):
    from porthamiltonian.simulation.switching import engage, release

    with pytest.raises(errors.ModelError, match=r"no loop or constraint 'lok' \(lock\)"):
        engage(knee, "mb", "lok", "locked")
    with pytest.raises(errors.ModelError, match=r"'walker' is not a multibody.*\(mb\)"):
        release(knee, "walker", "lock", "locked")
    with pytest.raises(errors.ModelError, match=r"'lockd' is not a parameter"):
        release(knee, "mb", "lock", "lockd")

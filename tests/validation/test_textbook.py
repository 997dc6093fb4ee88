"""Validation against closed-form solutions of textbook systems and independent computations.

Each test states the formula it checks against and where it comes from. Errors are measured
relative to a named scale (initial displacement, steady state, initial energy...).

References
----------
[Ogata] K. Ogata, *Modern Control Engineering*, 5th ed., Prentice Hall 2010: §5-3 (second-order
        systems, step and free response), §3-5 (DC motor / armature-controlled servomotor).
[Nilsson] J. W. Nilsson, S. A. Riedel, *Electric Circuits*, 10th ed., Pearson 2015, ch. 8
        (natural and step response of RLC circuits).
[Karnopp] D. Karnopp, D. Margolis, R. Rosenberg, *System Dynamics: Modeling, Simulation and
        Control of Mechatronic Systems*, 5th ed., Wiley 2012 (bond graphs, power balance).
"""
from __future__ import annotations

import hashlib
import itertools
import math
import os
import subprocess
import sys

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import quad

import porthamiltonian
from porthamiltonian import compile_model, compiler, io, power_balance, symbolic
from porthamiltonian.modeling.expressions import TIME
from porthamiltonian.simulation.assembly import consistent, constraint_rows


# --------------------------------------------------------------------------------------------
# Mass-spring-damper
# --------------------------------------------------------------------------------------------
def msd_closed_form(t, m, k, c, F, x0):
    """Displacement of m x'' + c x' + k x = F with x(0) = x0, x'(0) = 0 [Ogata §5-3].

    With ω_n = √(k/m), ζ = c / (2√(k m)) and the static offset x_s = F/k, x = x_s + (x0 − x_s) φ(t):
      ζ < 1:  φ = e^{−ζω_n t} (cos ω_d t + ζ/√(1−ζ²) sin ω_d t),   ω_d = ω_n √(1−ζ²)
      ζ = 1:  φ = (1 + ω_n t) e^{−ω_n t}
      ζ > 1:  φ = (s₁ e^{s₂ t} − s₂ e^{s₁ t}) / (s₁ − s₂),   s₁,₂ = −ζω_n ± ω_n √(ζ²−1)
    """
    wn = math.sqrt(k / m)
    zeta = c / (2 * math.sqrt(k * m))
    if math.isclose(zeta, 1.0, rel_tol=0, abs_tol=1e-15):
        phi = (1 + wn * t) * np.exp(-wn * t)
    elif zeta < 1:
        wd = wn * math.sqrt(1 - zeta**2)
        phi = np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))
    else:
        s1 = -zeta * wn + wn * math.sqrt(zeta**2 - 1)
        s2 = -zeta * wn - wn * math.sqrt(zeta**2 - 1)
        phi = (s1 * np.exp(s2 * t) - s2 * np.exp(s1 * t)) / (s1 - s2)
    xs = F / k
    return xs + (x0 - xs) * phi


@pytest.mark.parametrize(
    "regime, c",
    [("underdamped", 0.4), ("critically_damped", 4.0), ("overdamped", 8.0)],  # ζ = 0.1, 1, 2
)
@pytest.mark.parametrize("F", [0.0, 0.6])
def test_mass_spring_damper_matches_closed_form(compile_named, regime, c, F):
    """spring.q(t) of models/mass_spring_damper.toml (m = 1, k = 4, x0 = 0.1) equals the closed
    form of ``msd_closed_form`` [Ogata §5-3] to 1e-6·x0 at rtol 1e-10, for the free response
    (F = 0) and the step response to a constant force (offset F/k). DOP853 (the system is not
    stiff); the stiff default method is checked in the next test."""
    model = compile_named("mass_spring_damper")
    m, k, x0 = 1.0, 4.0, 0.1
    params = {"m": m, "k": k, "c": c, "F": F, "x0": x0}
    traj = model.simulate(10.0, params=params, method="DOP853", dense_output=True, rtol=1e-10, atol=1e-13)
    assert traj.status == "finished", traj.message
    t = np.linspace(0.0, 10.0, 401)
    q = traj.sol(t)[model.state_index("spring.q")]
    error = np.max(np.abs(q - msd_closed_form(t, m, k, c, F, x0))) / x0
    assert error < 1e-6, f"{regime}, F = {F}: max |x − x_exact| / x0 = {error:.2e}"
    # the stored steps (not only the dense output) agree as well
    stored = traj["spring.q"]
    error_steps = np.max(np.abs(stored - msd_closed_form(traj.t, m, k, c, F, x0))) / x0
    assert error_steps < 1e-6


def test_mass_spring_damper_radau_matches_closed_form(compile_named):
    """Same closed form [Ogata §5-3] with the default stiff method (Radau, analytic Jacobian):
    underdamped step response, error < 1e-6·x0 at rtol 1e-10."""
    model = compile_named("mass_spring_damper")
    params = {"m": 1.0, "k": 4.0, "c": 0.4, "F": 0.6, "x0": 0.1}
    traj = model.simulate(5.0, params=params, dense_output=True, rtol=1e-10, atol=1e-13)
    t = np.linspace(0.0, 5.0, 201)
    q = traj.sol(t)[model.state_index("spring.q")]
    assert np.max(np.abs(q - msd_closed_form(t, **params))) / 0.1 < 1e-6


def test_mass_spring_damper_step_response_settles_at_F_over_k(compile_named):
    """Final value theorem for the step response: x(∞) = F/k [Ogata §5-3], checked at t = 40 s
    with ζ = 1 (e^{−ω_n t}(1 + ω_n t) ≈ 1e-33), relative 1e-8."""
    model = compile_named("mass_spring_damper")
    traj = model.simulate(40.0, params={"c": 4.0, "F": 2.0, "k": 4.0}, method="DOP853",
                          rtol=1e-10, atol=1e-13)
    q_end = traj.x_final[model.state_index("spring.q")]
    assert abs(q_end - 2.0 / 4.0) / 0.5 < 1e-8
    assert abs(traj.x_final[model.state_index("mass.p")]) < 1e-9


# --------------------------------------------------------------------------------------------
# Series RLC circuit
# --------------------------------------------------------------------------------------------
def rlc_charge_step(t, V, L, Cap, Res):
    """Capacitor charge of a series RLC circuit switched onto V at t = 0 (q = i = 0), underdamped
    [Nilsson ch. 8; Ogata §5-3 with x → q, m → L, c → R, k → 1/C, F → V]:
      q(t) = C V [1 − e^{−ζω₀t} (cos ω_d t + ζ/√(1−ζ²) sin ω_d t)],
      ω₀ = 1/√(LC), ζ = (R/2)√(C/L), ω_d = ω₀√(1−ζ²)."""
    w0 = 1 / math.sqrt(L * Cap)
    zeta = Res / 2 * math.sqrt(Cap / L)
    wd = w0 * math.sqrt(1 - zeta**2)
    return Cap * V * (1 - np.exp(-zeta * w0 * t) * (np.cos(wd * t)
                                                     + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t)))


@pytest.fixture(scope="module")
def rlc_run(compile_named):
    """models/rlc_circuit.toml over 0.3 s (≈ 5 periods), DOP853 at rtol 1e-11."""
    model = compile_named("rlc_circuit")
    return model, model.simulate(0.3, method="DOP853", dense_output=True, rtol=1e-11, atol=1e-16)


def test_rlc_capacitor_charge_matches_closed_form_step_response(rlc_run):
    """capacitor.q(t) of models/rlc_circuit.toml (ω₀ = 100 rad/s, ζ = 0.25) matches
    ``rlc_charge_step`` to 1e-7 of the final charge C V."""
    model, traj = rlc_run
    V, L, Cap, Res = 1.0, 0.1, 1e-3, 5.0
    assert traj.status == "finished", traj.message
    t = np.linspace(0.0, 0.3, 301)
    q = traj.sol(t)[model.state_index("capacitor.q")]
    error = np.max(np.abs(q - rlc_charge_step(t, V, L, Cap, Res))) / (Cap * V)
    assert error < 1e-7, f"max |q − q_exact| / (C V) = {error:.2e}"


def test_rlc_supplied_energy_equals_V_times_charge(rlc_run):
    """A constant source V supplies E_in(T) = ∫ V i dt = V q(T) exactly (i = dq/dt, q(0) = 0).
    Checked against the simulated charge (1e-9 relative) and the closed-form charge (1e-7)."""
    model, traj = rlc_run
    V, L, Cap, Res = 1.0, 0.1, 1e-3, 5.0
    q_T = traj.x_final[model.state_index("capacitor.q")]
    E_in = traj.ledger()["supplied"]
    assert abs(E_in - V * q_T) / (V * Cap * V) < 1e-9
    assert abs(E_in - V * rlc_charge_step(0.3, V, L, Cap, Res)) / (V * Cap * V) < 1e-7
    assert traj.relative_residual < 1e-9


# --------------------------------------------------------------------------------------------
# DC motor
# --------------------------------------------------------------------------------------------
DC = {"V": 12.0, "R_a": 1.0, "L_a": 0.5e-3, "k_m": 0.05, "J": 1e-4, "b": 1e-4}


def test_dc_motor_steady_speed_matches_closed_form(compile_named):
    """Armature-controlled DC motor [Ogata §3-5]: in steady state L di/dt = 0 and J dω/dt = 0 give
    ω_ss = k_m V / (R_a b + k_m²). rotor.p / J at t = 2 s (≈ 50 slow time constants) to 1e-8."""
    model = compile_named("dc_motor")
    traj = model.simulate(2.0, rtol=1e-10, atol=1e-15)
    assert traj.status == "finished", traj.message
    omega = traj.x_final[model.state_index("rotor.p")] / DC["J"]
    omega_ss = DC["k_m"] * DC["V"] / (DC["R_a"] * DC["b"] + DC["k_m"] ** 2)
    assert abs(omega - omega_ss) / omega_ss < 1e-8
    current = traj.x_final[model.state_index("winding_inductance.p")] / DC["L_a"]
    assert abs(current - DC["b"] * omega_ss / DC["k_m"]) / current < 1e-8  # k_m i = b ω


def test_dc_motor_slow_time_constant_matches_characteristic_root(compile_named):
    """The speed transfer function ω/V = k / (L J s² + (L b + R J) s + (R b + k²)) [Ogata §3-5]
    has two real poles here (−26.3 and −1975 1/s). Late in the spin-up only the slow pole is left:
    ω_ss − ω(t) ∝ e^{s_slow t}. The log-slope between t = 0.15 s and 0.35 s matches s_slow to 1e-4
    relative."""
    model = compile_named("dc_motor")
    R, L, k, J, b, V = DC["R_a"], DC["L_a"], DC["k_m"], DC["J"], DC["b"], DC["V"]
    roots = np.roots([L * J, L * b + R * J, R * b + k**2])
    assert np.all(np.isreal(roots))
    s_slow = float(np.max(roots.real))
    traj = model.simulate(0.4, method="DOP853", dense_output=True, rtol=1e-11, atol=1e-16)
    omega_ss = k * V / (R * b + k**2)
    t1, t2 = 0.15, 0.35
    omega = traj.sol(np.array([t1, t2]))[model.state_index("rotor.p")] / J
    d1, d2 = omega_ss - omega
    slope = math.log(d2 / d1) / (t2 - t1)
    assert abs(slope - s_slow) / abs(s_slow) < 1e-4, (slope, s_slow)


def test_dc_motor_energy_supplied_equals_dissipated_plus_stored(compile_named):
    """Energy ledger [Karnopp ch. 4]: E_in(T) = E_diss(T) + H(T) − H(0) to 1e-9 of E_in, with H(0) = 0
    (motor at rest, no current); H(T) = ½ L i² + ½ J ω² is all kinetic + magnetic energy."""
    model = compile_named("dc_motor")
    traj = model.simulate(0.5, rtol=1e-10, atol=1e-15)
    led = traj.ledger()
    assert led["H0"] == 0.0
    assert abs(led["supplied"] - led["dissipated"] - led["HT"]) / led["supplied"] < 1e-9
    i = traj.x_final[model.state_index("winding_inductance.p")] / DC["L_a"]
    w = traj.x_final[model.state_index("rotor.p")] / DC["J"]
    assert led["HT"] == pytest.approx(0.5 * DC["L_a"] * i**2 + 0.5 * DC["J"] * w**2, rel=1e-12)
    assert led["dissipated"] > 0 and led["supplied"] > led["dissipated"]


# --------------------------------------------------------------------------------------------
# LC oscillator
# --------------------------------------------------------------------------------------------
def test_lc_oscillator_conserves_energy_over_100_periods(compile_named):
    """Lossless LC tank (L = C = 1, q(0) = q0 = 1): H is a first integral, and q(t) = q0 cos(t/√(LC))
    [Nilsson ch. 8]. Over 100 periods (T = 200π) with DOP853 at rtol 1e-12:
    max |H − H(0)| / H(0) < 1e-8 and |q(T) − q0 cos(T/√(LC))| < 1e-6·q0."""
    model = compile_named("lc_oscillator")
    method = "DOP853"
    T = 200 * math.pi
    traj = model.simulate(T, method=method, rtol=1e-12, atol=1e-14)
    assert traj.status == "finished", traj.message
    H = traj.H
    drift = np.max(np.abs(H - H[0])) / H[0]
    assert H[0] == pytest.approx(0.5, rel=1e-15)
    assert drift < 1e-8, f"{method}: relative energy drift {drift:.2e}"
    q_T = traj.x_final[model.state_index("capacitor.q")]
    assert abs(q_T - math.cos(T / math.sqrt(1.0 * 1.0))) < 1e-6
    assert traj.relative_residual < 1e-8


# --------------------------------------------------------------------------------------------
# Modulated spring
# --------------------------------------------------------------------------------------------
def test_modulated_spring_supplied_energy_matches_quadrature(model_run):
    """A stiffness K(t) = k0 (1 + a sin ωt) receives the power ∂H/∂K · K̇ = ½ K̇(t) q² with
    K̇ = k0 a ω cos ωt [Karnopp, modulated C-fields]. E_in(T) from the ledger equals
    ∫₀ᵀ ½ K̇ q² dt computed with scipy.integrate.quad on the dense output, to 1e-6 relative."""
    model, traj = model_run("modulated_spring")  # its own settings: Radau, rtol 1e-10, T = 5 s
    k0, a, w = 100.0, 0.5, 20.0
    T = traj.t_final
    assert T == 5.0
    assert traj.status == "finished", traj.message
    iq = model.state_index("spring.q")

    def power(t):
        return 0.5 * k0 * a * w * math.cos(w * t) * traj.sol(t)[iq] ** 2

    edges = np.linspace(0.0, T, 101)  # pieces shorter than a modulation period
    E_quad = sum(quad(power, lo, hi, epsabs=0.0, epsrel=1e-10, limit=200)[0]
                 for lo, hi in itertools.pairwise(edges))
    E_in = traj.ledger()["supplied"]
    assert abs(E_in - E_quad) / abs(E_in) < 1e-6, (E_in, E_quad)
    assert E_in > 100.0  # parametric pumping at ω = 2ω_n does supply a lot of energy


def test_modulated_spring_symbolic_supply_is_half_Kdot_q_squared():
    """The compiler's P_in for models/modulated_spring.toml is ½ K̇(t) q² with
    K(t) = k0 (1 + a sin(ω t)), symbolically (no external source in the model)."""
    sym = symbolic(io.load("modulated_spring"))
    par = dict(zip(sym.param_names, sym.params))
    q = sym.states[sym.state_names.index("spring.q")]
    K = par["k0"] * (1 + par["a"] * sp.sin(par["w"] * TIME))
    expected = sp.Rational(1, 2) * sp.diff(K, TIME) * q**2
    assert sp.simplify(sym.p_in - expected) == 0, sym.p_in


# --------------------------------------------------------------------------------------------
# Power balance of every shipped model
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", io.available_models())
def test_power_balance_vanishes_at_random_points(name):
    """dH/dt − P_in + P_diss ≡ 0 along the state equations [Karnopp ch. 4 / the pH form
    dH/dt = −∂Hᵀ R ∂H + yᵀu]; evaluated at 20 random states, parameters and times it is below
    1e-9 of the size of its terms. Models with implicit blocks (a mass matrix solved numerically)
    are checked numerically instead (CompiledModel.power_balance: a fourth-order central
    difference of H along ẋ against P_in − P_diss) to 1e-8 of |H|·max(1, |ẋ|) + |P_in| + |P_diss|
    (the round-off and truncation scale of the difference). Whether a model has implicit
    blocks is read from its solved structure (the compiler's structure solve, reused by the
    compile or the symbolic assembly that follows): the models checked numerically need no symbolic
    assembly of their own."""
    description = io.load(name).freeze()          # (loaded and frozen once for both branches)
    if compiler._solved(description.validate())[0].system.blocks:
        _numeric_power_balance(name, description)
        return
    sym = symbolic(description)
    balance = power_balance(sym)
    n = len(sym.states)
    dH = sp.diff(sym.hamiltonian, TIME) + sum(sp.diff(sym.hamiltonian, x) * f
                                             for x, f in zip(sym.states, sym.rhs[:n]))
    args = [TIME, *sym.states, *sym.params]
    f_balance = sp.lambdify(args, balance, "math")
    f_scale = sp.lambdify(args, sp.Abs(dH) + sp.Abs(sym.p_in) + sp.Abs(sym.p_diss), "math")
    rng = np.random.default_rng(20240611)
    for _ in range(20):
        t = rng.uniform(0.0, 10.0)
        x = rng.uniform(-2.0, 2.0, n)
        p = np.asarray(sym.param_defaults) * rng.uniform(0.5, 2.0, len(sym.params))
        values = [t, *x, *p]
        scale = f_scale(*values)
        assert abs(f_balance(*values)) <= 1e-9 * max(scale, 1e-300), (name, values)


def _numeric_power_balance(name, description):
    """(A multibody with loops or constraints balances its power on its constraints, where the
    constraint forces do no work: its random states lie within 0.1 of the initial state and are
    moved onto the constraints, as a run's initial state is.)"""
    compiled = compile_model(description, backend="python")
    rng = np.random.default_rng(20240611)
    n, p = compiled.n_states, np.asarray(compiled.param_defaults)
    constrained = bool(constraint_rows(compiled))
    for _ in range(20):
        t = rng.uniform(0.0, 10.0)
        x = rng.uniform(-2.0, 2.0, n)
        if constrained:
            x = consistent(compiled, compiled.initial_state(p) + 0.05 * x, p, t, warn=False)
        y = compiled.augment(x)
        xdot = np.asarray(compiled.functions.rhs(t, y, compiled.native_params(p)))
        H, p_diss, p_in = compiled.energy(t, y, p)
        scale = abs(H) * max(1.0, np.max(np.abs(xdot[:n]))) + abs(p_in) + abs(p_diss)
        assert abs(compiled.power_balance(t, x, p)) <= 1e-8 * scale, (name, x)


@pytest.mark.parametrize("name", io.available_models())
def test_energy_residual_within_model_tolerance(energy_check, model_settings, name):
    """Simulated with its own [simulation] settings (C back end), each model's ledger
    residual max |H − H(0) + E_diss − E_in| / energy scale stays below its energy_tolerance.
    The numbers are the session's one ``check-energy`` run's (tests/conftest.py), which simulates
    each model so, rather than a second simulation of every model here. (The python back end
    evaluates the same generated program: test_backends compares every function of every model
    on the two back ends.)"""
    line = energy_check.line(name)
    assert line["status"] == "finished", line["text"]
    assert line["tol"] == float(model_settings(name)["energy_tolerance"]), line["text"]
    assert line["ok"] and line["rel"] < line["tol"], line["text"]


# --------------------------------------------------------------------------------------------
# Determinism
# --------------------------------------------------------------------------------------------
def test_same_simulation_twice_is_bit_identical(compile_named):
    """Two runs of the same simulation give bit-identical times, states and ledger."""
    model = compile_named("modulated_spring")
    a = model.simulate(0.5, rtol=1e-9, atol=1e-12)
    b = model.simulate(0.5, rtol=1e-9, atol=1e-12)
    assert np.array_equal(a.t, b.t)
    assert np.array_equal(a.y, b.y)
    assert np.array_equal(a.H, b.H)


def test_cold_and_warm_compile_give_bit_identical_trajectories(tmp_path, monkeypatch):
    """A compile that generates code (fresh cache folder, then use_cache=False) and one served from
    the on-disk cache (without running the symbolic compiler) simulate bit-identically."""
    monkeypatch.setenv("PORTHAMILTONIAN_CACHE", str(tmp_path))
    model = io.load("rlc_circuit")
    cold = compile_model(model, backend="python", use_cache=False)
    cold_again = compile_model(model, backend="python")            # fresh folder: cache miss
    entry = tmp_path / cold.key                                    # the cache entry's folder
    assert (entry / "meta.json").is_file() and (entry / "body.py").is_file()

    def no_symbolic(*args, **kwargs):
        raise AssertionError("a warm compile must not run the symbolic compiler")

    monkeypatch.setattr(porthamiltonian.compiler, "_symbolic_model", no_symbolic)  # (every build)
    warm = compile_model(io.load("rlc_circuit"), backend="python")
    assert warm.key == cold.key and warm.source == cold.source
    assert warm.state_names == cold.state_names and warm.param_names == cold.param_names
    runs = [c.simulate(0.1, params={"Res": 3.0}, rtol=1e-8, atol=1e-12)
            for c in (cold, cold_again, warm)]
    for run in runs[1:]:
        assert np.array_equal(run.t, runs[0].t)
        assert np.array_equal(run.y, runs[0].y)


def test_python_and_numba_backends_agree(compile_named):
    """The numba back end runs the same generated source as the python reference: trajectories
    of scipy's Radau on each back end's functions agree to 1e-12 relative (on the same output
    times)."""
    model = io.load("dc_motor")
    py = compile_named("dc_motor")
    nb = compile_model(model, backend="numba")
    assert nb.backend == "numba" and py.backend == "python"
    t_eval = np.linspace(0.0, 0.2, 201)
    a = py.simulate(0.2, t_eval=t_eval, method="Radau", rtol=1e-10, atol=1e-14)
    b = nb.simulate(0.2, t_eval=t_eval, method="Radau", rtol=1e-10, atol=1e-14)
    assert a.status == b.status == "finished"
    scale = np.max(np.abs(a.y), axis=1, keepdims=True)
    assert np.max(np.abs(a.y - b.y) / scale) < 1e-12
    x = np.array([0.01, 0.02, 0.3, 0.4])
    p = py.param_defaults
    for fn in ("rhs", "energy"):
        ra = np.asarray(getattr(py.functions, fn)(0.1, x, py.native_params(p)))
        rb = np.asarray(getattr(nb.functions, fn)(0.1, x, nb.native_params(p)))
        np.testing.assert_allclose(rb, ra, rtol=1e-12, atol=0)


_HASH_SCRIPT = """
import hashlib
from porthamiltonian import compile_model, io
for name in ("dc_motor", "modulated_spring", "mass_spring_damper"):
    source = compile_model(io.load(name), backend="python", use_cache=False).source
    print(name, hashlib.sha256(source.encode()).hexdigest())
"""


def test_generated_source_independent_of_hash_seed(tmp_path):
    """Code generation is deterministic: two interpreters with different PYTHONHASHSEED (and
    separate caches) generate byte-identical source for three shipped models."""
    procs = [subprocess.Popen([sys.executable, "-c", _HASH_SCRIPT], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True,
                              env={**os.environ, "PYTHONHASHSEED": seed,
                                   "PORTHAMILTONIAN_CACHE": str(tmp_path / f"cache{seed}")})
             for seed in ("1", "4242")]  # run concurrently
    outputs = []
    for proc in procs:
        out, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err
        outputs.append(out)
    assert outputs[0] == outputs[1]
    assert len(outputs[0].splitlines()) == 3
    # and the same as this process generates
    here = compile_model(io.load("dc_motor"), backend="python")
    assert f"dc_motor {hashlib.sha256(here.source.encode()).hexdigest()}" in outputs[0]

"""Benchmark of the multibody component (issue 3): compile time and one RHS + Jacobian evaluation,
library vs hand-written numpy, for three mechanisms.

Run::

    python benchmarks/bench_mechanics.py            # full run: chains N = 2, 4, 6, 10; numba for
                                                    # the walkers and N = 2, 4 (~6 min)
    python benchmarks/bench_mechanics.py --quick    # chains N = 2, 4, python back end, 1 repeat
    python benchmarks/bench_mechanics.py --no-numba # full run without the numba back end
    python benchmarks/bench_mechanics.py --models chain6,chain10 --numba-all   # numba, big chains

Models (all planar, x-z plane, gravity (0, 0, −g)):

* walker4: models/walker_skeleton.toml, the compass-walker skeleton of the thesis's walker (Table 2.3; hip point
  mass 3 kg on a translational x-z joint, two uniform legs 0.01 kg / 0.7 m on revolute hip joints,
  point feet 0.1 kg welded at the leg ends): 4 coordinates (x, z, θ1, θ2), 8 states.
* walker6: the same with each foot on a prismatic joint along its leg axis (telescopic legs),
  built in Python (as in tests/validation/test_mechanics.py): 6 coordinates, 12 states.
* chainN: N uniform rods (mass m_i = 1 + 0.1 i kg, length l_i = 0.5 + 0.05 i m, all different)
  hanging from each other on revolute joints about y (relative joint angles q_i), 2N states.

Hand-written baselines (what a competent numpy user writes for the same states, conjugate momenta
and equations; checked against the library's RHS and Jacobian, and the Jacobian against central
differences, before anything is timed):

* walkers: the closed-form mass matrix M(q), its first and second derivatives and the gravity
  potential's gradient and Hessian written out by hand (sparse entries), then
  v = M⁻¹p, q̇ = v, ṗ_k = ½ vᵀ ∂_k M v − ∂_k V, and the analytic Jacobian
  ∂v/∂q = −M⁻¹ D (D[:, k] = ∂_k M v), ∂v/∂p = M⁻¹, ∂ṗ/∂p = Dᵀ M⁻¹,
  ∂ṗ_k/∂q_j = ½ vᵀ ∂_kj M v + D[:, k]·∂v/∂q_j − ∂_kj V.
* chains: the standard recursive formulas in absolute angles φ = S q (S lower-triangular ones):
  M^φ_jk = C_jk cos(φ_j − φ_k) + δ_jk I_j with C = Λᵀ diag(m) Λ (Λ_ij = l_j for j < i, l_i/2 for
  j = i), V = −g Σ_j μ_j cos φ_j (μ = Λᵀ m), vectorised over all pairs; the canonical point
  transformation p_φ = S⁻ᵀ p_q gives the library's coordinates, and the Jacobian is
  blockdiag(S⁻¹, Sᵀ) J_φ blockdiag(S, S⁻ᵀ).

Measured (wall clock, medians):

* compile, cold: ``compile_model(model, backend)`` in a fresh subprocess with an empty cache
  folder ($PORTHAMILTONIAN_CACHE), which it fills, then the first rhs + jac + energy call (numba: the
  JIT compilation); cached: a second fresh subprocess on the warm cache with use_cache=True;
  medians of 3 (python) or a single run (numba, and chain10);
* one RHS + Jacobian evaluation (``timeit``) at a fixed generic state, library back end(s) vs
  the hand-written pair; ratio = hand / library (> 1: the library is faster).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
import timeit
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # same LAPACK threading for library and hand-written code

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
WALKER = {"M": 3.0, "m_l": 0.01, "m_f": 0.1, "L": 0.7, "g": 9.81}


# ------------------------------------------------------------------------------------------------
# models, with the library
# ------------------------------------------------------------------------------------------------
def walker4_model():
    import porthamiltonian  # noqa: F401  (registers Multibody)
    from porthamiltonian import io

    return io.load(ROOT / "models" / "walker_skeleton.toml")


def walker6_model():
    """The skeleton with telescopic legs: feet on prismatic joints along the leg axis (the
    test suite's model, tests/validation/test_mechanics.py)."""
    sys.path.insert(0, str(ROOT / "tests" / "validation"))
    from test_mechanics import walker6_model as model

    return model()


def chain_masses_lengths(n: int) -> tuple[np.ndarray, np.ndarray]:
    i = np.arange(1, n + 1)
    return 1.0 + 0.1 * i, 0.5 + 0.05 * i


def chain_model(n: int):
    """The N-link chain of tests/validation/multibody_cases.py (masses and lengths as
    :func:`chain_masses_lengths`)."""
    sys.path.insert(0, str(ROOT / "tests" / "validation"))
    from multibody_cases import chain_model as model

    return model(n)


def generic_chain_model(n: int):
    """The N-link chain about random 3D axes of tests/validation/multibody_cases.py."""
    sys.path.insert(0, str(ROOT / "tests" / "validation"))
    from multibody_cases import generic_chain_model as model

    return model(n)


def build(spec: str):
    """A benchmark model by name: walker4, walker6, chainN (planar), gchainN (generic axes);
    ``:kernel`` or ``:symbolic`` after the name sets the Multibody's formulation."""
    name, _, formulation = spec.partition(":")
    if name == "walker4":
        model = walker4_model()
    elif name == "walker6":
        model = walker6_model()
    elif name.startswith("gchain"):
        model = generic_chain_model(int(name.removeprefix("gchain")))
    else:
        model = chain_model(int(name.removeprefix("chain")))
    if formulation:
        sys.path.insert(0, str(ROOT / "tests" / "validation"))
        from multibody_cases import with_formulation

        model = with_formulation(model, formulation)
    return model


# ------------------------------------------------------------------------------------------------
# the same models, by hand
# ------------------------------------------------------------------------------------------------
def _hamiltonian_pair(n, mechanics):
    """RHS and Jacobian of q̇ = M⁻¹p, ṗ_k = ½ vᵀ ∂_k M v − ∂_k V from a function
    ``mechanics(q) -> (M, dM (n, n, n), d2M (n, n, n, n) or a sparse list, dV, d2V)``; the state
    layout is the library's (q, p, E_diss, E_in)."""

    def rhs(t, y, p=None):
        q, mom = y[:n], y[n:2 * n]
        M, dM, _, dV, _ = mechanics(q, second=False)
        v = np.linalg.solve(M, mom)
        out = np.zeros(2 * n + 2)
        out[:n] = v
        out[n:2 * n] = 0.5 * ((dM @ v) @ v) - dV
        return out

    def jac(t, y, p=None):
        q, mom = y[:n], y[n:2 * n]
        M, dM, d2M, _dV, d2V = mechanics(q, second=True)
        Minv = np.linalg.inv(M)
        v = Minv @ mom
        D = (dM @ v).T                                     # D[:, k] = ∂_k M v
        dv_dq = -Minv @ D
        H2 = (d2M @ v) @ v                                 # vᵀ ∂_kj M v
        J = np.zeros((2 * n + 2, 2 * n + 2))
        J[:n, :n] = dv_dq
        J[:n, n:2 * n] = Minv
        J[n:2 * n, :n] = 0.5 * H2 + D.T @ dv_dq - d2V
        J[n:2 * n, n:2 * n] = D.T @ Minv
        return J

    return rhs, jac


def hand_walker4(M=3.0, m_l=0.01, m_f=0.1, L=0.7, g=9.81):
    """The 4-coordinate compass-gait skeleton (x, z, θ1, θ2), absolute leg angles:
    M = [[m_t, 0, −a c1, −a c2], [0, m_t, a s1, a s2], [·, ·, J, 0], [·, ·, 0, J]],
    a = L (m_l/2 + m_f), J = L² (m_l/3 + m_f), V = g (m_t z − a c1 − a c2)."""
    mt = M + 2 * m_l + 2 * m_f
    a = L * (m_l / 2 + m_f)
    J = L**2 * (m_l / 3 + m_f)
    n = 4

    def mechanics(q, second):
        s1, c1, s2, c2 = np.sin(q[2]), np.cos(q[2]), np.sin(q[3]), np.cos(q[3])
        Mq = np.array([[mt, 0.0, -a * c1, -a * c2],
                       [0.0, mt, a * s1, a * s2],
                       [-a * c1, a * s1, J, 0.0],
                       [-a * c2, a * s2, 0.0, J]])
        dM = np.zeros((n, n, n))
        for k, (s, c) in ((2, (s1, c1)), (3, (s2, c2))):
            dM[k, 0, k] = dM[k, k, 0] = a * s
            dM[k, 1, k] = dM[k, k, 1] = a * c
        dV = np.array([0.0, g * mt, g * a * s1, g * a * s2])
        if not second:
            return Mq, dM, None, dV, None
        d2M = np.zeros((n, n, n, n))
        for k, (s, c) in ((2, (s1, c1)), (3, (s2, c2))):
            d2M[k, k, 0, k] = d2M[k, k, k, 0] = a * c
            d2M[k, k, 1, k] = d2M[k, k, k, 1] = -a * s
        d2V = np.diag([0.0, 0.0, g * a * c1, g * a * c2])
        return Mq, dM, d2M, dV, d2V

    return _hamiltonian_pair(n, mechanics)


def hand_walker6(M=3.0, m_l=0.01, m_f=0.1, L=0.7, g=9.81):
    """The 6-coordinate skeleton (x, z, θ1, θ2, d1, d2): foot i at r_i = L + d_i along leg i,
    b_i = m_l L/2 + m_f r_i: M_xθi = −b_i c_i, M_zθi = b_i s_i, M_xdi = −m_f s_i, M_zdi = −m_f c_i,
    M_θiθi = m_l L²/3 + m_f r_i², M_didi = m_f; V = g (m_t z − Σ b_i c_i)."""
    mt = M + 2 * m_l + 2 * m_f
    n = 6

    def mechanics(q, second):
        Mq = np.zeros((n, n))
        Mq[0, 0] = Mq[1, 1] = mt
        dM = np.zeros((n, n, n))
        dV = np.zeros(n)
        dV[1] = g * mt
        d2M = np.zeros((n, n, n, n)) if second else None
        d2V = np.zeros((n, n)) if second else None
        for th, dk in ((2, 4), (3, 5)):
            s, c = np.sin(q[th]), np.cos(q[th])
            r = L + q[dk]
            b = m_l * L / 2 + m_f * r
            Mq[0, th] = Mq[th, 0] = -b * c
            Mq[1, th] = Mq[th, 1] = b * s
            Mq[0, dk] = Mq[dk, 0] = -m_f * s
            Mq[1, dk] = Mq[dk, 1] = -m_f * c
            Mq[th, th] = m_l * L**2 / 3 + m_f * r**2
            Mq[dk, dk] = m_f
            # ∂/∂θ
            dM[th, 0, th] = dM[th, th, 0] = b * s
            dM[th, 1, th] = dM[th, th, 1] = b * c
            dM[th, 0, dk] = dM[th, dk, 0] = -m_f * c
            dM[th, 1, dk] = dM[th, dk, 1] = m_f * s
            # ∂/∂d
            dM[dk, 0, th] = dM[dk, th, 0] = -m_f * c
            dM[dk, 1, th] = dM[dk, th, 1] = m_f * s
            dM[dk, th, th] = 2 * m_f * r
            dV[th] = g * b * s
            dV[dk] = -g * m_f * c
            if second:
                d2M[th, th, 0, th] = d2M[th, th, th, 0] = b * c
                d2M[th, th, 1, th] = d2M[th, th, th, 1] = -b * s
                d2M[th, th, 0, dk] = d2M[th, th, dk, 0] = m_f * s
                d2M[th, th, 1, dk] = d2M[th, th, dk, 1] = m_f * c
                for i, j in ((th, dk), (dk, th)):
                    d2M[i, j, 0, th] = d2M[i, j, th, 0] = m_f * s
                    d2M[i, j, 1, th] = d2M[i, j, th, 1] = m_f * c
                d2M[dk, dk, th, th] = 2 * m_f
                d2V[th, th] = g * b * c
                d2V[th, dk] = d2V[dk, th] = g * m_f * s
        return Mq, dM, d2M, dV, d2V

    return _hamiltonian_pair(n, mechanics)


def hand_chain(n: int, g: float = 9.81):
    """Chain of N uniform rods, relative joint angles q, vectorised absolute-angle formulas."""
    m, l = chain_masses_lengths(n)
    a, inertia = l / 2, m * l**2 / 12
    lam = np.zeros((n, n))                          # Λ_ij: lever of joint j for the centre of i
    for i in range(n):
        lam[i, :i] = l[:i]
        lam[i, i] = a[i]
    C = lam.T @ (m[:, None] * lam)
    mu = lam.T @ m
    S = np.tril(np.ones((n, n)))                    # φ = S q
    S_inv = np.linalg.inv(S)                        # q̇ = S⁻¹ φ̇ (differences)
    S_inv_T = S_inv.T                               # p_φ = S⁻ᵀ p_q
    eye = np.eye(n)

    def parts(y):
        phi = np.cumsum(y[:n])
        p_phi = y[n:2 * n].copy()
        p_phi[:-1] -= y[n + 1:2 * n]
        delta = phi[:, None] - phi[None, :]
        cos_d, sin_d = np.cos(delta), np.sin(delta)
        M = C * cos_d + np.diag(inertia)
        return phi, p_phi, C * cos_d, C * sin_d, M

    def rhs(t, y, p=None):
        phi, p_phi, _, Cs, M = parts(y)
        w = np.linalg.solve(M, p_phi)
        pdot_phi = -w * (Cs @ w) - g * mu * np.sin(phi)
        out = np.zeros(2 * n + 2)
        out[:n] = w
        out[1:n] -= w[:-1]                                  # q̇ = S⁻¹ φ̇
        out[n:2 * n] = np.cumsum(pdot_phi[::-1])[::-1]      # ṗ_q = Sᵀ ṗ_φ
        return out

    def jac(t, y, p=None):
        phi, p_phi, Cc, Cs, M = parts(y)
        Minv = np.linalg.inv(M)
        w = Minv @ p_phi
        Csw, Ccw = Cs @ w, Cc @ w
        D = -np.diag(Csw) + Cs * w[None, :]          # D[:, m] = ∂M/∂φ_m w
        dw_dphi = -Minv @ D
        G = -np.diag(Csw) - w[:, None] * Cs          # ∂ṗ/∂w
        E = -w[:, None] * (eye * Ccw[:, None] - Cc * w[None, :]) - np.diag(g * mu * np.cos(phi))
        J = np.zeros((2 * n + 2, 2 * n + 2))
        J[:n, :n] = S_inv @ dw_dphi @ S
        J[:n, n:2 * n] = S_inv @ Minv @ S_inv_T
        J[n:2 * n, :n] = S.T @ (E + G @ dw_dphi) @ S
        J[n:2 * n, n:2 * n] = S.T @ (G @ Minv) @ S_inv_T
        return J

    return rhs, jac


def hand_pair(spec: str):
    if spec == "walker4":
        return hand_walker4()
    if spec == "walker6":
        return hand_walker6()
    return hand_chain(int(spec.removeprefix("chain")))


def test_state(spec: str, n: int) -> np.ndarray:
    """A generic state (no symmetric configuration, all velocities non-zero), with ledger zeros."""
    rng = np.random.default_rng(2026)
    if spec.startswith("walker"):
        q = np.array([1.0, 0.74, 0.3, -0.25, 0.02, -0.03][:n])
    else:
        q = rng.uniform(-0.8, 0.8, n)
    return np.concatenate((q, rng.uniform(-0.5, 0.5, n), (0.0, 0.0)))


# ------------------------------------------------------------------------------------------------
# measurements
# ------------------------------------------------------------------------------------------------
def child(spec: str, backend: str, use_cache: bool) -> None:
    """Run in a fresh subprocess: compile, then the first rhs + jac + energy call; JSON out."""
    from porthamiltonian import compile_model

    model = build(spec)
    t0 = time.perf_counter()
    compiled = compile_model(model, backend=backend, use_cache=use_cache)
    t1 = time.perf_counter()
    y = compiled.augment(compiled.initial_state())
    pn = compiled.native_params(compiled.param_defaults)
    compiled.functions.rhs(0.0, y, pn)
    compiled.functions.jac(0.0, y, pn)
    compiled.functions.energy(0.0, y, pn)
    t2 = time.perf_counter()
    print(json.dumps({"compile": t1 - t0, "first_call": t2 - t1}))


def run_child(spec: str, backend: str, use_cache: bool, cache_dir: str) -> dict:
    env = dict(os.environ, PORTHAMILTONIAN_CACHE=cache_dir)
    out = subprocess.run([sys.executable, __file__, "--child", spec, backend,
                          "cached" if use_cache else "cold"],
                         capture_output=True, text=True, env=env, timeout=3600, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def compile_times(spec: str, backend: str, repeats: int, warm_dir: str) -> dict:
    """Medians over ``repeats`` pairs (cold in an empty cache folder, then cached on it); the
    last pair runs in ``warm_dir`` (empty at first), which is left warm for the timings."""
    cold, cold_first, cached, cached_first = [], [], [], []
    for k in range(repeats):
        with tempfile.TemporaryDirectory(prefix="ph_bench_mech_") as scratch:
            cache_dir = warm_dir if k == repeats - 1 else scratch
            a = run_child(spec, backend, True, cache_dir)     # cold: the folder is empty
            b = run_child(spec, backend, True, cache_dir)
        cold.append(a["compile"])
        cold_first.append(a["first_call"])
        cached.append(b["compile"])
        cached_first.append(b["first_call"])
    med = statistics.median
    return {"cold": med(cold), "cold_first": med(cold_first), "cached": med(cached),
            "cached_first": med(cached_first)}


def check_hand_against_library(spec: str, compiled, rhs, jac) -> tuple[float, float, float]:
    """Max relative differences: RHS (hand vs library), Jacobian (hand vs library) and Jacobian
    (hand vs central differences of the hand RHS), at 5 generic states."""
    n = compiled.n_states
    pn = compiled.native_params(compiled.param_defaults)
    rng = np.random.default_rng(1)
    d_rhs = d_jac = d_fd = 0.0
    for k in range(5):
        y = test_state(spec, n // 2)
        y[:n] += rng.uniform(-0.2, 0.2, n) * k
        f_lib = np.asarray(compiled.functions.rhs(0.0, y, pn))
        J_lib = np.asarray(compiled.functions.jac(0.0, y, pn))
        f_hand, J_hand = rhs(0.0, y), jac(0.0, y)
        d_rhs = max(d_rhs, np.max(np.abs(f_hand - f_lib)) / np.max(np.abs(f_lib)))
        d_jac = max(d_jac, np.max(np.abs(J_hand - J_lib)) / np.max(np.abs(J_lib)))
        h = 1e-6
        J_fd = np.column_stack([(rhs(0.0, y + h * e) - rhs(0.0, y - h * e)) / (2 * h)
                                for e in np.eye(n + 2)])
        d_fd = max(d_fd, np.max(np.abs(J_fd - J_hand)) / np.max(np.abs(J_hand)))
    return d_rhs, d_jac, d_fd


def eval_time(fn, number: int, repeats: int) -> float:
    """Median wall time of one call (s)."""
    fn()
    return statistics.median(timeit.repeat(fn, number=number, repeat=repeats)) / number


def machine() -> str:
    import numba
    import scipy
    import sympy

    cpu = "?"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = os.getloadavg() if hasattr(os, "getloadavg") else ("?",)
    return (f"{platform.platform()}, nproc = {os.cpu_count()}, CPU {cpu!r}, load average "
            f"{', '.join(f'{x:.2f}' for x in load)}\nPython {platform.python_version()}, numpy "
            f"{np.__version__}, scipy {scipy.__version__}, sympy {sympy.__version__}, numba "
            f"{numba.__version__}, BLAS threads {os.environ.get('OPENBLAS_NUM_THREADS')}")


def library_sources_mtime() -> float:
    """Latest modification time of the library's sources: the cache key hashes the compiler, so
    an edit during the run turns a "cached" measurement into a cold one (reported at the end)."""
    return max(p.stat().st_mtime for p in (ROOT / "porthamiltonian").rglob("*.py"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="chains N = 2, 4; python; 1 repeat")
    parser.add_argument("--no-numba", action="store_true", help="skip the numba back end")
    parser.add_argument("--numba-all", action="store_true",
                        help="numba for the chains N = 6, 10 too (JIT of minutes)")
    parser.add_argument("--models", help="comma-separated subset, e.g. walker4,chain10")
    parser.add_argument("--child", nargs=3, metavar=("SPEC", "BACKEND", "MODE"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        spec, backend, mode = args.child
        child(spec, backend, mode == "cached")
        return

    specs = ["walker4", "walker6", "chain2", "chain4"] + ([] if args.quick else ["chain6", "chain10"])
    numba_specs = set() if (args.quick or args.no_numba) else {"walker4", "walker6", "chain2", "chain4"}
    if args.numba_all:
        numba_specs |= {"chain6", "chain10"}
    if args.models:
        specs = args.models.split(",")
    compile_repeats = 1 if args.quick else 3
    number, repeats = (200, 5) if args.quick else (500, 9)
    started = time.time()
    sources_mtime = library_sources_mtime()
    print(f"bench_mechanics.py {'--quick' if args.quick else '(full)'}, "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    print(machine())
    print()

    from porthamiltonian import compile_model

    compile_rows, eval_rows, check_rows = [], [], []
    for spec in specs:
        backends = ["python"] + (["numba"] if spec in numba_specs else [])
        with tempfile.TemporaryDirectory(prefix="ph_bench_mech_warm_") as warm_dir:
            for backend in backends:
                # one repeat for chain10 (~90 s cold) and for numba (JIT of tens of seconds)
                reps = 1 if (spec == "chain10" or backend == "numba") else compile_repeats
                ct = compile_times(spec, backend, reps, warm_dir)
                compile_rows.append((spec, backend, reps, ct))
                print(f"  compiled {spec} ({backend}): cold {ct['cold']:.2f} s, cached "
                      f"{ct['cached']:.3f} s", flush=True)
            os.environ["PORTHAMILTONIAN_CACHE"] = warm_dir      # the warm cache: no recompiling
            libs = {b: compile_model(build(spec), backend=b) for b in backends}
            for compiled in libs.values():                      # numba: load the JIT cache now
                y0 = compiled.augment(compiled.initial_state())
                pn0 = compiled.native_params(compiled.param_defaults)
                compiled.functions.rhs(0.0, y0, pn0)
                compiled.functions.jac(0.0, y0, pn0)
        rhs, jac = hand_pair(spec)
        lib = libs["python"]
        check_rows.append((spec, lib.n_states, *check_hand_against_library(spec, lib, rhs, jac)))
        y = test_state(spec, lib.n_states // 2)
        t_hand_rhs = eval_time(lambda: rhs(0.0, y), number, repeats)
        t_hand_jac = eval_time(lambda: jac(0.0, y), number, repeats)
        times = {}
        for backend, compiled in libs.items():
            f = compiled.functions
            pn = compiled.native_params(compiled.param_defaults)
            times[backend] = (eval_time(lambda: f.rhs(0.0, y, pn), number, repeats),
                              eval_time(lambda: f.jac(0.0, y, pn), number, repeats))
        eval_rows.append((spec, lib.n_states, t_hand_rhs, t_hand_jac, times))

    print("\n### Hand-written vs library (max relative differences at 5 states)\n")
    print("| model | states | RHS hand vs lib | Jacobian hand vs lib | Jacobian hand vs central diff |")
    print("|---|---|---|---|---|")
    for spec, n, d_rhs, d_jac, d_fd in check_rows:
        print(f"| {spec} | {n} | {d_rhs:.1e} | {d_jac:.1e} | {d_fd:.1e} |")

    print("\n### Compile (fresh subprocess each; cold = use_cache=False, empty cache; medians)\n")
    print("| model | back end | repeats | cold compile [s] | cold first call rhs+jac+energy [s] | "
          "cached compile [s] | cached first call [s] |")
    print("|---|---|---|---|---|---|---|")
    for spec, backend, reps, ct in compile_rows:
        print(f"| {spec} | {backend} | {reps} | {ct['cold']:.3f} | {ct['cold_first']:.3f} | "
              f"{ct['cached']:.3f} | {ct['cached_first']:.3f} |")

    print("\n### One RHS + Jacobian evaluation (timeit median; ratio = hand / library)\n")
    print("| model | states | hand numpy [us] (rhs / jac) | python [us] (rhs / jac) | ratio | "
          "numba [us] (rhs / jac) | ratio |")
    print("|---|---|---|---|---|---|---|")
    for spec, n, hr, hj, times in eval_rows:
        hand = hr + hj
        cells = [f"| {spec} | {n} | {1e6 * hand:.1f} ({1e6 * hr:.1f} / {1e6 * hj:.1f})"]
        for backend in ("python", "numba"):
            if backend in times:
                r, j = times[backend]
                cells.append(f"{1e6 * (r + j):.1f} ({1e6 * r:.1f} / {1e6 * j:.1f}) | "
                             f"{hand / (r + j):.2f}")
            else:
                cells.append("– | –")
        print(" | ".join(cells) + " |")
    print(f"\ntotal run time {time.time() - started:.0f} s")
    if library_sources_mtime() != sources_mtime:
        print("WARNING: porthamiltonian/ sources changed during the run; cached compile times "
              "measured after the change may be cold ones (re-run)")


if __name__ == "__main__":
    main()

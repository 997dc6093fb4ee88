"""Benchmark of the contact library (issue 4): a 10 s ball drop on a Hunt–Crossley floor with
K = 1e6 N/m, per integrator, library vs a hand-written numpy version under scipy, in the same run.

Run::

    python benchmarks/bench_contact.py              # 10 s, 3 interleaved rounds (~10 min here)
    python benchmarks/bench_contact.py --quick      # 1 s, 1 round
    python benchmarks/bench_contact.py --rounds 5

Model: models/bouncing_ball.toml with its defaults: a point mass m = 1 kg (radius r = 0.05 m: the
contact point is r below the centre) on a Multibody translational x/z joint, dropped from
h0 = 0.5 m onto the plane z = 0, F = K z + λ z ż (n = 1), K = 1e6 N/m, λ = 1e5 N s/m² (clipped at
F ≥ 0), gravity 9.81 m/s². States: q_x, q_z, p_x, p_z, then the ledger states E_diss, E_in. Over
10 s the ball makes ~117 bounces: Hunt–Crossley impacts become more elastic as the impact speed
falls (e → 1 as λ v / K → 0), so it keeps hopping; each impact lasts ~3 ms and has to be resolved
by the step size control (the stiff part: ω = √(K/m) = 1000 rad/s). rtol 1e-8, atol 1e-10, the
model's two non-terminal events (touchdown / lift-off: the penetration r − q_z crossing zero) on
in every run.

Variants (each timed as the median wall-clock time of ``--rounds`` runs, the variants interleaved
with the order rotated every round):

* library: ``compile_model(model)`` (back end "auto" = numba) then ``simulate(10, method=...)``:
  Rodas4 (the compiled step loop, the default), and scipy's Radau, BDF, LSODA through
  ``simulate``'s own step loop, with the analytic Jacobian and with ``jacobian=False`` (scipy's
  finite differences);
* hand-written: the same six equations written by hand in numpy (RHS and analytic Jacobian, with
  the same Piecewise branches: contact, clipping) under ``scipy.integrate.solve_ivp`` with the same
  method, tolerances and two events, with ``jac=`` and without. Checked against the library's
  generated RHS and Jacobian (and the Jacobian against central differences) at random states
  inside and outside the contact, before anything is timed.

Reported per variant: median time, accepted steps, RHS and Jacobian evaluations, events found,
the ledger's relative residual (library) and the final height difference to the hand-written run.
Ratio = hand-written time / library time (> 1: the library is faster). For Rodas4 (no scipy
counterpart) the ratio is against the hand-written run of each scipy method with the Jacobian,
and against the fastest of them.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # same LAPACK threading for library and hand-written code

import numpy as np
from machine import machine_info
from scipy.integrate import solve_ivp

RTOL, ATOL = 1e-8, 1e-10
M, R, H0, K, LAM, G = 1.0, 0.05, 0.5, 1e6, 1e5, 9.81
SCIPY_METHODS = ("Radau", "BDF", "LSODA")


# ------------------------------------------------------------------------------------------------
# hand-written numpy version
# ------------------------------------------------------------------------------------------------
def hand_rhs(t, y):
    """ẏ for y = (q_x, q_z, p_x, p_z, E_diss, E_in): free flight plus the clipped Hunt–Crossley
    force on the tip (penetration z = r − q_z, ż = −p_z/m)."""
    qz, px, pz = y[1], y[2], y[3]
    z = R - qz
    zd = -pz / M
    force = 0.0
    p_diss = 0.0
    if z > 0.0:
        law = K + LAM * zd
        if law > 0.0:
            force = z * law
            p_diss = LAM * z * zd * zd
        else:
            p_diss = -K * z * zd
    return np.array([px / M, pz / M, 0.0, -M * G + force, p_diss, 0.0])


def hand_jac(t, y):
    """∂ẏ/∂y of :func:`hand_rhs`, by hand."""
    qz, pz = y[1], y[3]
    J = np.zeros((6, 6))
    J[0, 2] = 1.0 / M
    J[1, 3] = 1.0 / M
    z = R - qz
    zd = -pz / M
    if z > 0.0:
        law = K + LAM * zd
        if law > 0.0:
            J[3, 1] = -law                          # ∂F/∂q_z = ∂F/∂z · (−1)
            J[3, 3] = -z * LAM / M                  # ∂F/∂p_z = z λ · (−1/m)
            J[4, 1] = -LAM * zd * zd
            J[4, 3] = -2.0 * LAM * z * zd / M
        else:
            J[4, 1] = K * zd
            J[4, 3] = K * z / M
    return J


def hand_event(t, y):
    return R - y[1]


hand_event.terminal = False


def hand_run(method: str, jac: bool, t_end: float):
    y0 = np.array([0.0, H0 + R, 0.0, 0.0, 0.0, 0.0])
    sol = solve_ivp(hand_rhs, (0.0, t_end), y0, method=method, rtol=RTOL, atol=ATOL,
                    jac=hand_jac if jac else None, events=[hand_event])
    assert sol.status == 0, sol.message
    return sol


# ------------------------------------------------------------------------------------------------
# checks before timing
# ------------------------------------------------------------------------------------------------
def check_against_library(model) -> dict:
    p = model.native_params(model.params())
    rng = np.random.default_rng(4)
    worst_rhs = worst_jac = worst_fd = 0.0
    for k in range(300):
        y = np.array([rng.uniform(-1, 1), R + rng.uniform(-2e-3, 2e-3), rng.uniform(-3, 3),
                      rng.uniform(-30, 30) if k % 3 == 0 else rng.uniform(-3, 3),
                      rng.uniform(0, 5), 0.0])
        f_lib = np.asarray(model.functions.rhs(0.0, y, p))
        J_lib = np.asarray(model.functions.jac(0.0, y, p))
        f_hand, J_hand = hand_rhs(0.0, y), hand_jac(0.0, y)
        worst_rhs = max(worst_rhs, np.max(np.abs(f_lib - f_hand)) / max(1.0, np.max(np.abs(f_hand))))
        worst_jac = max(worst_jac, np.max(np.abs(J_lib - J_hand)) / max(1.0, np.max(np.abs(J_hand))))
        h = 1e-7 * np.maximum(1e-3, np.abs(y))
        fd = np.column_stack([(hand_rhs(0, y + h[i] * e) - hand_rhs(0, y - h[i] * e)) / (2 * h[i])
                              for i, e in enumerate(np.eye(6))])
        if abs(R - y[1]) > 1e-5:  # away from the kink at z = 0
            law = K + LAM * (-y[3] / M)
            if abs(law) > 1e-3 * K:
                worst_fd = max(worst_fd, np.max(np.abs(fd - J_hand)) / max(1.0, np.max(np.abs(J_hand))))
    assert worst_rhs < 1e-12 and worst_jac < 1e-12 and worst_fd < 1e-5, (worst_rhs, worst_jac, worst_fd)
    return {"rhs": worst_rhs, "jac": worst_jac, "fd": worst_fd}


# ------------------------------------------------------------------------------------------------
# timing
# ------------------------------------------------------------------------------------------------
def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1 s horizon, 1 round")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--t-end", type=float, default=10.0)
    args = parser.parse_args(argv)
    t_end = 1.0 if args.quick else args.t_end
    rounds = 1 if args.quick else args.rounds

    info = machine_info()
    print(f"date {info['date']}; {info['nproc']} cores, {info['cpu']}; {info['platform']}; "
          f"load average {info['load']}")
    print(f"python {info['python']}, numpy {info['numpy']}, scipy {info['scipy']}, "
          f"sympy {info['sympy']}, numba {info['numba']}; BLAS threads "
          f"{os.environ.get('OPENBLAS_NUM_THREADS')}")
    print(f"ball drop: {t_end:g} s, K = {K:g} N/m, lambda = {LAM:g} N s/m^2, rtol {RTOL:g}, "
          f"atol {ATOL:g}; {rounds} round(s)\n", flush=True)

    os.environ["PORTHAMILTONIAN_CACHE"] = tempfile.mkdtemp(prefix="phbench_contact_")
    from porthamiltonian import compile_model, io

    t0 = time.perf_counter()
    model = compile_model(io.load("bouncing_ball"))          # back end "auto" (numba)
    t_compile = time.perf_counter() - t0
    t0 = time.perf_counter()
    model.simulate(1e-3)                                      # JIT of the functions + Rodas4 loop
    for method in SCIPY_METHODS:
        model.simulate(1e-3, method=method)
    t_jit = time.perf_counter() - t0
    print(f"compile (cold, {model.backend}): {t_compile:.2f} s; first calls (JIT): {t_jit:.1f} s")
    checks = check_against_library(model)
    print(f"hand-written vs library at 300 random states: max rel. diff RHS {checks['rhs']:.1e}, "
          f"Jacobian {checks['jac']:.1e}; hand Jacobian vs central differences {checks['fd']:.1e}\n",
          flush=True)

    variants = [("library", "Rodas4", True)]
    for method in SCIPY_METHODS:
        for jac in (True, False):
            variants += [("library", method, jac), ("hand", method, jac)]
    times: dict[tuple, list[float]] = {v: [] for v in variants}
    stats: dict[tuple, dict] = {}
    for r in range(rounds):
        order = variants[r % len(variants):] + variants[: r % len(variants)]
        for v in order:
            who, method, jac = v
            t0 = time.perf_counter()
            if who == "library":
                traj = model.simulate(t_end, method=method, jacobian=jac, rtol=RTOL, atol=ATOL)
                elapsed = time.perf_counter() - t0
                assert traj.status == "finished", traj.message
                stats[v] = {"steps": len(traj.t) - 1, "nfev": traj.nfev, "njev": traj.njev,
                            "events": len(traj.events), "residual": traj.relative_residual,
                            "z_end": float(traj.x_final[1])}
            else:
                sol = hand_run(method, jac, t_end)
                elapsed = time.perf_counter() - t0
                stats[v] = {"steps": len(sol.t) - 1, "nfev": sol.nfev, "njev": sol.njev,
                            "events": len(sol.t_events[0]), "z_end": float(sol.y[1, -1])}
            times[v].append(elapsed)
            print(f"  round {r + 1}: {who:7s} {method:6s} jac={jac!s:5s} {elapsed:8.3f} s",
                  flush=True)
    med = {v: statistics.median(ts) for v, ts in times.items()}

    print("\n| method | Jacobian | hand numpy + solve_ivp [s] (steps / nfev / njev) | library numba "
          "[s] (steps / nfev / njev) | ratio hand/library | events hand / lib | max abs dz(T) lib "
          "vs hand [m] | ledger rel. residual |")
    print("|---|---|---|---|---|---|---|---|")
    for method in SCIPY_METHODS:
        for jac in (True, False):
            h, lib = ("hand", method, jac), ("library", method, jac)
            sh, sl = stats[h], stats[lib]
            print(f"| {method} | {'analytic' if jac else 'finite diff.'} | {med[h]:.3f} "
                  f"({sh['steps']} / {sh['nfev']} / {sh['njev']}) | {med[lib]:.3f} "
                  f"({sl['steps']} / {sl['nfev']} / {sl['njev']}) | {med[h] / med[lib]:.2f} | "
                  f"{sh['events']} / {sl['events']} | {abs(sl['z_end'] - sh['z_end']):.1e} | "
                  f"{sl['residual']:.1e} |")
    rod = ("library", "Rodas4", True)
    s = stats[rod]
    hand_jac_times = {m: med[("hand", m, True)] for m in SCIPY_METHODS}
    best = min(hand_jac_times, key=hand_jac_times.get)
    ratios = ", ".join(f"{hand_jac_times[m] / med[rod]:.0f}x vs {m}" for m in SCIPY_METHODS)
    print(f"| Rodas4 (compiled loop, default) | analytic | — | {med[rod]:.3f} ({s['steps']} / "
          f"{s['nfev']} / {s['njev']}) | {ratios} (fastest hand-written: {best}, "
          f"{hand_jac_times[best] / med[rod]:.1f}x) | — / {s['events']} | "
          f"{abs(s['z_end'] - stats[('hand', best, True)]['z_end']):.1e} vs {best} | "
          f"{s['residual']:.1e} |")
    print(f"\nload average at the end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

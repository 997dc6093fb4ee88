"""Benchmark of dense output: a compiled method's interpolant against scipy's Radau's, and
against the hand-written baseline (numpy right-hand side and Jacobian under
``scipy.integrate.solve_ivp(..., method="Radau", dense_output=True)``), in the same run.

Model: models/mass_spring_damper.toml with k = 4 N/m, c = 0.8 N s/m (ζ = 0.2), released from
x0 = 0.1 m, over 60 s (30 damped periods). Each variant integrates the run and makes its
interpolant, then evaluates it on 60 001 times; the error is the largest difference from the
closed form (Ogata, Modern Control Engineering, §5-3) over those times, so that the variants
are compared at their accuracy, not their rtol.

Variants (CPU time of the integration and the interpolant, median of ``--rounds`` interleaved
rounds; the evaluation on the grid is timed apart):

* ``Rodas5P + Hermite``: ``simulate(..., method="Rodas5P", dense_output=True)`` on the C back
  end: the compiled loop, then the quintic Hermite interpolant of its steps
  (porthamiltonian.simulation.dense);
* ``Radau (ours)``: ``simulate(..., method="Radau", dense_output=True)``: scipy's Radau through
  the library's step loop, its own interpolants;
* ``Radau (hand-written)``: the baseline.

Ratio: the baseline's time over the variant's (> 1: faster than the baseline).

With ``--t-eval N`` the variants store the solution at N equally spaced times instead
(``simulate(..., t_eval=...)`` with method "auto": the compiled method's interpolant at the
times; Radau through the library; the baseline ``solve_ivp(..., t_eval=...)``), and the error is
taken at those times.

Run::

    python benchmarks/bench_dense_output.py                  # rtol 1e-6 and 1e-9, 7 rounds
    python benchmarks/bench_dense_output.py --rounds 3 --rtols 1e-9
    python benchmarks/bench_dense_output.py --t-eval 601     # the values at 601 times
"""
from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np
from scipy.integrate import solve_ivp

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info

from porthamiltonian import compile_model, io

M, K, C, X0, T_END = 1.0, 4.0, 0.8, 0.1, 60.0


def closed_form(t: np.ndarray) -> np.ndarray:
    """x(t) of m x'' + c x' + k x = 0, x(0) = x0, x'(0) = 0."""
    wn, zeta = math.sqrt(K / M), C / (2 * math.sqrt(K * M))
    wd = wn * math.sqrt(1 - zeta**2)
    return X0 * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2)
                                          * np.sin(wd * t))


def hand_written(rtol: float, t_eval: np.ndarray | None = None):
    """The baseline: states (p, q), ṗ = −k q − c p / m, q̇ = p / m, with its Jacobian; its
    interpolant, or (``t_eval``) its values there."""
    def rhs(t, y):
        return np.array([-K * y[1] - C * y[0] / M, y[0] / M])

    jac = np.array([[-C / M, -K], [1.0 / M, 0.0]])
    sol = solve_ivp(rhs, (0.0, T_END), [0.0, X0], method="Radau", rtol=rtol, atol=rtol * 1e-3,
                    jac=lambda t, y: jac, dense_output=t_eval is None, t_eval=t_eval)
    return sol.y[1] if t_eval is not None else lambda t: sol.sol(t)[1]


def ours(model, method: str, rtol: float, t_eval: np.ndarray | None = None):
    """The library's run: its interpolant, or (``t_eval``) its values there."""
    q = model.state_index("spring.q")
    traj = model.simulate(T_END, params={"k": K, "c": C}, method=method, rtol=rtol,
                          atol=rtol * 1e-3, dense_output=t_eval is None, t_eval=t_eval)
    return traj.y[q] if t_eval is not None else lambda t: traj.sol(t)[q]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--rtols", default="1e-6,1e-9")
    ap.add_argument("--t-eval", type=int, default=0,
                    help="store the solution at this many times instead (0: dense output)")
    args = ap.parse_args()
    print("machine:", machine_info())
    model = compile_model(io.load("mass_spring_damper"), backend="c")
    te = np.linspace(0.0, T_END, args.t_eval) if args.t_eval else None
    grid = te if te is not None else np.linspace(0.0, T_END, 60_001)
    exact = closed_form(grid)
    where = f"the {args.t_eval} times" if te is not None else "the grid"
    print(f"\n| rtol | variant | CPU [ms] (median) | ratio to baseline | grid evaluation [ms] | "
          f"largest error on {where} |")
    print("|---|---|---|---|---|---|")
    for rtol in (float(r) for r in args.rtols.split(",")):
        first = "auto (t_eval)" if te is not None else "Rodas5P + Hermite"
        variants = {first: lambda: ours(model, "auto" if te is not None else "Rodas5P", rtol,
                                        te),
                    "Radau (ours)": lambda: ours(model, "Radau", rtol, te),
                    "Radau (hand-written)": lambda: hand_written(rtol, te)}
        times: dict[str, list[float]] = {k: [] for k in variants}
        keys = list(variants)
        made = {}
        for r in range(args.rounds):
            for k in keys[r % len(keys):] + keys[:r % len(keys)]:
                t0 = time.process_time()
                made[k] = variants[k]()
                times[k].append(time.process_time() - t0)
        base = statistics.median(times["Radau (hand-written)"])
        for k in keys:
            t0 = time.process_time()
            values = made[k] if te is not None else made[k](grid)
            evaluation = time.process_time() - t0
            error = float(np.max(np.abs(values - exact)))
            med = statistics.median(times[k])
            print(f"| {rtol:g} | {k} | {1e3 * med:.1f} | {base / med:.1f} | "
                  f"{1e3 * evaluation:.1f} | {error:.1e} |")
    print("\nload at the end:", " ".join(f"{x:.2f}" for x in os.getloadavg()))


if __name__ == "__main__":
    main()

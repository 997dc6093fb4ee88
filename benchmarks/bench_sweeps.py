"""Sweep throughput (issue 6): cases per minute of the Fig. 2.22 step-down sweep (max step-down
over the slope) and of the Fig. 2.21 basin (grid points at γ = 0.007) on the nominal walker
(compass_walker), serial versus a local process pool, in the same run.

Run::

    python benchmarks/bench_sweeps.py              # 4 slopes, 25 basin points (~8 min here)
    python benchmarks/bench_sweeps.py --quick      # 2 slopes, 9 basin points

Each variant runs the same cases into a fresh results file (nothing resumed); the pool is a
``ProcessPoolExecutor`` with one worker per core (forked workers inherit the walker, compiled
once in the parent: the time excludes compilation; each variant finds its gaits itself — the
gait cache is cleared before every run so forked workers do not inherit it). Step-down cases
differ a lot in cost (a slope with a large step-down walks more heights), so the pool's speed-up
on few cases is bounded by the slowest case.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from machine import machine_info

from walker_library import robustness
from walker_library.robustness import basin_case, step_down_case
from walker_library.sweeps import Sweep, cached_walker


def run(function, cases, fixed, **how) -> tuple[float, list[dict]]:
    robustness._GAITS.clear()        # every variant finds its gaits itself (forked workers
    with tempfile.TemporaryDirectory() as tmp:    # would inherit the parent's cache)
        sw = Sweep(function, cases, Path(tmp) / "r.jsonl", fixed=fixed)
        t0 = time.perf_counter()
        sw.run(progress="none", **how)
        return time.perf_counter() - t0, sw.table()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--workers", type=int, default=None)
    args = parser.parse_args(argv)
    info = machine_info()
    print(f"date {info['date']}; {info['nproc']} cores, {info['cpu']}; load {info['load']}")
    print(f"python {info['python']}, numpy {info['numpy']}, scipy {info['scipy']}, "
          f"numba {info['numba']}")
    t0 = time.perf_counter()
    walker = cached_walker("compass_walker")
    walker.walk(walker.initial_guess(), 1)
    print(f"compass_walker compiled and warmed in {time.perf_counter() - t0:.1f} s")
    slopes = [0.005, 0.011] if args.quick else [0.005, 0.007, 0.011, 0.013]
    sd_cases = [{"slope": s} for s in slopes]
    sd_fixed = {"model": "compass_walker", "resolution": 2e-4}
    from walker_library.gait import analyze_gait
    fp = analyze_gait(walker.with_parameters(slope=0.007)).fixed_point
    k = 3 if args.quick else 5
    # the basin study's grid (θ/0.4 within ±0.025, θ̇/0.8 within ±0.1), k × k points
    basin_cases = [{"theta": fp["theta"] + 0.4 * 0.025 * a, "theta_dot": fp["theta_dot"] + 0.8 * 0.1 * b}
                   for a in [-1 + 2 * i / (k - 1) for i in range(k)]
                   for b in [-1 + 2 * i / (k - 1) for i in range(k)]]
    basin_fixed = {"model": "compass_walker", "params": {"slope": 0.007}}
    print(f"\n{'sweep':28s} {'cases':>5s} {'serial s':>9s} {'pool s':>8s} {'serial/min':>10s} "
          f"{'pool/min':>9s} {'speed-up':>8s}")
    for name, fn, cases, fixed in (("Fig. 2.22 step-down/slope", step_down_case, sd_cases, sd_fixed),
                                   ("Fig. 2.21 basin, γ = 0.007", basin_case, basin_cases,
                                    basin_fixed)):
        ts, rows_s = run(fn, cases, fixed, serial=True)
        tp, rows_p = run(fn, cases, fixed, workers=args.workers)
        same = [r.get("status") for r in rows_s] == [r.get("status") for r in rows_p]
        print(f"{name:28s} {len(cases):5d} {ts:9.1f} {tp:8.1f} {60 * len(cases) / ts:10.2f} "
              f"{60 * len(cases) / tp:9.2f} {ts / tp:8.2f}" + ("" if same else "  (rows differ!)"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

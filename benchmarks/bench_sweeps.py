"""Sweep throughput: cases per minute of the Fig. 2.22 step-down sweep (max step-down over the
slope) and of the Fig. 2.21 basin (grid points at γ = 0.007) on the nominal walker
(compass_walker), serial versus a local process pool, in the same run.

Run::

    python benchmarks/bench_sweeps.py                 # 4 slopes, 10 × 10 basin points
    python benchmarks/bench_sweeps.py --quick         # 2 slopes, 3 × 3 basin points
    python benchmarks/bench_sweeps.py --full-basin    # also the 50 × 50 basin (issue 26: <= 45 s, 2 workers)

Each variant runs the same cases into a fresh results file (nothing resumed); the pool is the
sweep's own ``ProcessPoolExecutor``, one worker per core (forked workers inherit the walker,
compiled once in the parent: the times exclude compilation). The basin runs in three ways:

* serial — in this process, the gait found once before the sweep;
* pool, gait per worker — each worker finds the gait itself before its first point (how basin
  sweeps ran before porthamiltonian.batch: the case function found and cached it per process);
* pool, gait shipped — the gait found once in the parent and handed to every worker with the
  pool (the sweep's shared argument), which is what ``walker sweep --analysis basin`` and
  ``walker reproduce basin`` do now.

The gait cache is cleared before every variant, so forked workers never inherit a gait. The
back end is the walker's default (``backend=None``): printed at the top, with the method the
basin's points are walked with (``--basin-method``: "auto", the basin's own choice, QBDF for
this stiff walker; "walker" the file's Rodas5P; or a method name). A basin point's walk ends at
the first step within the tolerance of the fixed point (robustness.recovers).
"""
from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from pathlib import Path

from machine import machine_info

from porthamiltonian.batch import Sweep
from walker_library.analyses.cases import basin_case, step_down_case, walker_cache
from walker_library.analyses.robustness import basin_walker

MODEL = "compass_walker"
SLOPE = 0.007


def _cpu() -> float:
    """CPU seconds (user + system) of this process and of its finished children (pool workers)."""
    return sum(getattr(resource.getrusage(who), f) for who in (resource.RUSAGE_SELF,
               resource.RUSAGE_CHILDREN) for f in ("ru_utime", "ru_stime"))


CPU: dict[str, float] = {}


def run(function, cases, fixed, shared=None, **how) -> tuple[float, list[dict]]:
    """Wall time (s) and table of a fresh sweep; the gait cache cleared first. Its CPU time
    (this process and the pool's workers) goes into ``CPU["last"]``."""
    walker_cache().clear_gaits()
    with tempfile.TemporaryDirectory() as tmp:
        sw = Sweep(function, cases, Path(tmp) / "r.jsonl", fixed=fixed, shared=shared)
        t0, c0 = time.perf_counter(), _cpu()
        sw.run(progress="none", **how)
        CPU["last"] = _cpu() - c0
        return time.perf_counter() - t0, sw.table()


def basin_cases(fp: dict, k: int) -> list[dict]:
    """The basin study's grid (θ/0.4 within ±0.025, θ̇/0.8 within ±0.1), k × k points."""
    s = [-1 + 2 * i / (k - 1) for i in range(k)]
    return [{"theta": fp["theta"] + 0.4 * 0.025 * a, "theta_dot": fp["theta_dot"] + 0.8 * 0.1 * b}
            for a in s for b in s]


def _row(name: str, n: int, seconds: float, note: str = "") -> None:
    print(f"{name:52s} {n:6d} {seconds:9.1f} {60 * n / seconds:10.1f}  {note}".rstrip())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 slopes, 3 × 3 basin points")
    parser.add_argument("--workers", type=int, default=None, help="pool size (default: cores)")
    parser.add_argument("--basin-n", type=int, default=None, metavar="K",
                        help="basin grid points per axis (default: 10, --quick: 3)")
    parser.add_argument("--basin-only", action="store_true", help="skip the step-down sweep")
    parser.add_argument("--full-basin", action="store_true",
                        help="also the 50 × 50 basin with the gait shipped")
    parser.add_argument("--basin-method", default="auto", metavar="M",
                        help="integration of the basin's walks: auto (default), walker (the "
                             "file's own) or a method name")
    args = parser.parse_args(argv)
    info = machine_info()
    print(f"date {info['date']}; {info['nproc']} cores, {info['cpu']}; load {info['load']}")
    print(f"python {info['python']}, numpy {info['numpy']}, scipy {info['scipy']}, "
          f"numba {info['numba']}")
    t0 = time.perf_counter()
    walker = walker_cache().walker(MODEL)
    walker.walk(walker.initial_guess(), 1)
    backend = walker.backend
    print(f"{MODEL} ({backend} back end) compiled and warmed in "
          f"{time.perf_counter() - t0:.1f} s")
    t0 = time.perf_counter()
    _, gait = walker_cache().gait(MODEL, None, {"slope": SLOPE})
    t_gait = time.perf_counter() - t0
    print(f"gait at slope {SLOPE}: {gait.status}, found in {t_gait:.1f} s")
    pool = {"workers": args.workers}
    method = None if args.basin_method == "walker" else args.basin_method
    print(f"basin points walked with {basin_walker(walker, method).options.method}")

    print(f"\n{'sweep':52s} {'cases':>6s} {'wall s':>9s} {'cases/min':>10s}")
    if not args.basin_only:
        slopes = [0.005, 0.011] if args.quick else [0.005, 0.007, 0.011, 0.013]
        sd_cases = [{"slope": s} for s in slopes]
        sd_fixed = {"model": MODEL, "resolution": 2e-4}
        ts, rows_s = run(step_down_case, sd_cases, sd_fixed, serial=True)
        tp, rows_p = run(step_down_case, sd_cases, sd_fixed, **pool)
        same = [r.get("max_step_down") for r in rows_s] == [r.get("max_step_down") for r in rows_p]
        _row("Fig. 2.22 step-down/slope, serial", len(sd_cases), ts)
        _row("Fig. 2.22 step-down/slope, pool", len(sd_cases), tp,
             f"speed-up {ts / tp:.2f}" + ("" if same else "  (rows differ!)"))

    k = args.basin_n or (3 if args.quick else 10)
    cases = basin_cases(gait.fixed_point, k)
    fixed = {"model": MODEL, "params": {"slope": SLOPE}, "method": method}
    shipped = {"gait": gait}
    t_serial, rows_serial = run(basin_case, cases, fixed, shipped, serial=True)
    t_worker, rows_worker = run(basin_case, cases, fixed, None, **pool)
    t_shipped, rows_shipped = run(basin_case, cases, fixed, shipped, **pool)
    cpu_shipped = CPU["last"]
    statuses = [[r["status"] for r in rows] for rows in (rows_serial, rows_worker, rows_shipped)]
    same = statuses[0] == statuses[1] == statuses[2]
    name = f"Fig. 2.21 basin {k}x{k}, γ = {SLOPE}"
    _row(f"{name}, serial", len(cases), t_serial)
    _row(f"{name}, pool, gait per worker", len(cases), t_worker)
    _row(f"{name}, pool, gait shipped", len(cases), t_shipped,
         f"{t_worker / t_shipped:.2f}x the per-worker variant" + ("" if same else "  (rows differ!)"))
    per_min = 60 * len(cases) / t_shipped
    workers = args.workers or os.cpu_count() or 1
    print(f"\n50 x 50 basin at {per_min:.0f} points/min (gait shipped): "
          f"{2500 * 60 / per_min:.0f} s + {t_gait:.0f} s for the gait (target: <= 45 s); "
          f"CPU {cpu_shipped / len(cases):.3f} s per point: "
          f"{2500 * cpu_shipped / len(cases) / workers:.0f} s on {workers} idle cores; "
          f"load now {os.getloadavg()[0]:.1f}")
    if args.full_basin:
        cases = basin_cases(gait.fixed_point, 50)
        t_full, rows = run(basin_case, cases, fixed, shipped, **pool)
        converged = sum(r["status"] == "converged" for r in rows)
        _row(f"Fig. 2.21 basin 50x50, γ = {SLOPE}, pool, gait shipped", len(cases), t_full,
             f"{converged} converged, {sum(r['steps'] for r in rows)} strides; CPU "
             f"{CPU['last']:.0f} s ({CPU['last'] / workers:.0f} s on {workers} idle cores); "
             f"load at the end {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Work-precision of the compiled stiff methods (Rodas4, Rodas5P) on the compliant walkers.

For each walker (its model file's integration settings: max_step, the C back end unless
``--backend``): the fixed point z* (Rodas4, rtol 1e-10), then a reference walk of ``--strides``
strides from z* with Rodas5P at rtol 1e-12 (``--ref-rtol``), atol = rtol / 100 (checked
against Rodas4 at the same tolerances: their difference is printed), then for each method and rtol (atol = rtol / 100)
the same walk: the error (max abs difference of the section states after each stride, and of
the stride durations, against the reference), the accepted steps, right-hand-side and Jacobian
evaluations, and the wall time (median of ``--repeats``, the methods interleaved).

The last table compares the methods at equal accuracy: for each Rodas4 run, the time Rodas5P
needs for the same error (log-log interpolation between its runs) and the ratio.

Run::

    python benchmarks/bench_stiff_methods.py                      # both walkers, ~2 min
    python benchmarks/bench_stiff_methods.py --walkers compass_walker --max-step inf
"""
from __future__ import annotations

import argparse
import itertools
import math
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import numpy as np
from machine import machine_info

from walker_library import find_fixed_point, load_walker

METHODS = ("Rodas4", "Rodas5P")
RTOLS = (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)


_BASE: dict = {}


def walker_with(name: str, backend: str, method: str, rtol: float, atol: float,
                max_step: float | None):
    if (name, backend) not in _BASE:
        _BASE[name, backend] = load_walker(name, backend=backend)
    return _BASE[name, backend].with_options(
        method=method, rtol=rtol, atol=atol, **({} if max_step is None else {"max_step": max_step}))


def run(walker, z, strides: int):
    """(section states, durations, accepted steps, nfev, njev, seconds)."""
    t0 = time.perf_counter()
    out = walker.walk(z, strides, record=True)
    seconds = time.perf_counter() - t0
    if len(out) < strides or out[-1].status != "step":
        return None
    tr = out[-1].info["trajectory"]
    return (np.array([s.z_next for s in out]), np.array([s.duration for s in out]),
            len(tr.t) - len(tr.segments), tr.nfev, tr.njev, seconds)


def study(name: str, args) -> None:
    print(f"\n=== {name} ===", flush=True)
    fp_walker = walker_with(name, args.backend, "Rodas4", 1e-10, 1e-12, args.max_step)
    fp = find_fixed_point(fp_walker, tol=1e-10)
    if not fp.converged:
        print(f"no fixed point: {fp.message}")
        return
    z = fp.z
    r = args.ref_rtol
    ref = run(walker_with(name, args.backend, "Rodas5P", r, r * 1e-2, args.max_step), z,
              args.strides)
    check = run(walker_with(name, args.backend, "Rodas4", r, r * 1e-2, args.max_step), z,
                args.strides)
    print(f"backend {fp_walker.backend}; max_step {fp_walker.options.max_step}; "
          f"{args.strides} strides from z* (|z*| = {np.max(np.abs(z)):.3g}); reference Rodas5P "
          f"rtol {r:g}: {ref[2]} steps; Rodas4 rtol {r:g} differs from it by "
          f"{np.max(np.abs(check[0] - ref[0])):.1e} (states), "
          f"{np.max(np.abs(check[1] - ref[1])):.1e} s (durations)", flush=True)
    rows = {}
    walkers = {(m, r): walker_with(name, args.backend, m, r, r * 1e-2, args.max_step)
               for m in METHODS for r in RTOLS}
    for w in walkers.values():            # load (and compile) before timing
        w.stride(z)
    times: dict = {k: [] for k in walkers}
    results = {}
    for _ in range(args.repeats):
        for key, w in walkers.items():
            res = run(w, z, args.strides)
            results[key] = res
            if res is not None:
                times[key].append(res[5])
    print("\n| method | rtol | error of z (max abs) | error of durations [s] | steps | nfev | "
          "njev | time [ms] |")
    print("|---|---|---|---|---|---|---|---|")
    for (m, r), res in results.items():
        if res is None:
            print(f"| {m} | {r:.0e} | fell | | | | | |")
            continue
        err = float(np.max(np.abs(res[0] - ref[0])))
        derr = float(np.max(np.abs(res[1] - ref[1])))
        ms = 1e3 * statistics.median(times[(m, r)])
        rows[(m, r)] = (err, ms, res[2])
        print(f"| {m} | {r:.0e} | {err:.2e} | {derr:.2e} | {res[2]} | {res[3]} | {res[4]} | "
              f"{ms:.1f} |")
    print("\n| Rodas4 rtol | its error | Rodas4 [ms] (steps) | Rodas5P at that error [ms] "
          "(steps, interpolated) | time ratio Rodas4 / Rodas5P |")
    print("|---|---|---|---|---|")
    five = sorted((e, ms, st) for (m, _), (e, ms, st) in rows.items() if m == "Rodas5P")
    for (m, r), (err, ms, steps) in rows.items():
        if m != "Rodas4":
            continue
        t5, s5 = interpolate(five, err)
        print(f"| {r:.0e} | {err:.2e} | {ms:.1f} ({steps}) | "
              f"{'-' if t5 is None else f'{t5:.1f} ({s5:.0f})'} | "
              f"{'-' if t5 is None else f'{ms / t5:.2f}'} |")


def interpolate(points, err):
    """(time, steps) at ``err`` on the log-log line through the two nearest points bracketing
    it; None outside their range."""
    for (e0, t0, s0), (e1, t1, s1) in itertools.pairwise(points):
        if e0 <= err <= e1 and e0 > 0:
            w = (math.log(err) - math.log(e0)) / (math.log(e1) - math.log(e0)) if e1 > e0 else 0
            return (math.exp(math.log(t0) + w * (math.log(t1) - math.log(t0))),
                    math.exp(math.log(s0) + w * (math.log(s1) - math.log(s0))))
    return None, None


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--walkers", default="compass_walker,compliant_leg_walker")
    parser.add_argument("--backend", default="c")
    parser.add_argument("--strides", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--ref-rtol", type=float, default=1e-12,
                        help="rtol of the reference runs (atol = rtol / 100)")
    parser.add_argument("--max-step", type=float, default=None,
                        help="override the walker files' max_step (s); 'inf' for none")
    args = parser.parse_args(argv)
    info = machine_info()
    print(f"date {info['date']}; {info['nproc']} cores, {info['cpu']}; {info['platform']}; "
          f"load average {info['load']}; python {info['python']}, numpy {info['numpy']}")
    for name in args.walkers.split(","):
        study(name.strip(), args)
    print(f"\nload average at the end: {' '.join(f'{x:.2f}' for x in __import__('os').getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

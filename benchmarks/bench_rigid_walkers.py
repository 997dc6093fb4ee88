"""The rigid walkers' integrator: scipy's DOP853 against the compiled Rodas5P and QBDF loops.

For each rigid walker file (simplest_walker, compass_gait, rimless_wheel, kneed_walker,
rigid_compass_walker, controlled_symmetry_walker), at its own ``[walker] integration`` tolerances
(rtol 1e-12) with only the method changed: the fixed point found by each method (its largest
difference from DOP853's, section units) and the time of one stride from it (``walk(z, 1,
reuse=False)``: integrated every time; the methods interleaved, medians of ``--rounds``, and
each method's median over DOP853's). The files stride on Rodas5P (their swing phases are not
stiff; DOP853 was their method before, see CHANGELOG.md).

Run::

    python benchmarks/bench_rigid_walkers.py --rounds 15
"""
from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from machine import machine_info
from timing import fresh_walk, interleaved

from walker_library import load_walker
from walker_library.analyses.poincare import find_fixed_point

WALKERS = ("simplest_walker", "compass_gait", "rimless_wheel", "kneed_walker",
           "rigid_compass_walker", "controlled_symmetry_walker")
METHODS = ("DOP853", "Rodas5P", "QBDF")


def main(argv: list[str] | None = None) -> None:
    """Print the machine, then one row per walker and method."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--rounds", type=int, default=15, help="interleaved rounds (median)")
    parser.add_argument("--walkers", default=",".join(WALKERS),
                        help="comma-separated walker files (default: the six rigid walkers)")
    args = parser.parse_args(argv)
    names = args.walkers.split(",")
    unknown = sorted(set(names) - set(WALKERS))
    if unknown:
        parser.error(f"unknown walker(s) {', '.join(unknown)}; choose among {', '.join(WALKERS)}")
    print(machine_info())
    print(f"\n| walker | method | stride (ms, median of {args.rounds}) | / DOP853 | "
          "fixed point − DOP853's |")
    print("|---|---|---|---|---|")
    for name in names:
        base = load_walker(name)
        walkers = {m: base.with_options(method=m) for m in METHODS}
        points = {m: find_fixed_point(w) for m, w in walkers.items()}
        if not all(fp.converged for fp in points.values()):
            print(f"| {name} | no fixed point from the guess: "
                  f"{ {m: fp.message for m, fp in points.items()} } |")
            continue
        z = points["DOP853"].z
        times = interleaved({m: (lambda w=w: fresh_walk(w, z, 1)) for m, w in walkers.items()},
                            args.rounds)
        ref = statistics.median(times["DOP853"])
        for m in METHODS:
            t = statistics.median(times[m])
            diff = float(np.max(np.abs(points[m].z - z)))
            print(f"| {name} | {m} | {1e3 * t:.2f} | {t / ref:.2f} | {diff:.1e} |")


if __name__ == "__main__":
    main()

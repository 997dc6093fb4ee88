"""The cost of exact gradients by parameters (issue 25's targets).

1. A stride's gradient by 3 parameters against a stride with state sensitivities. For each
   walker (its file's settings; C back end) at its fixed point z*, in interleaved rounds (order
   rotated), one stride from z*:

   * ``plain``      without sensitivities (``walker.stride``);
   * ``state``      with the section's state sensitivities (``walker.stride_sensitivity``: the
                    stride Jacobian, what the multipliers need);
   * ``gradient``   with the state and 3 parameter columns and the derivatives of duration,
                    step length and ledger (``walker_library.core.gradients.stride_gradient``).

   Printed: median wall times and the ratio gradient / state (target ≤ 2). The first call of
   ``gradient`` compiles the model's ∂f/∂p once (not timed).

2. A walker optimization: the gait evaluations a gradient method needs, against a grid
   (``--optimize``): the simplest walker's most efficient gait with ρ ≤ 0.6 (1 parameter,
   tests/walkers/test_optimize.py), its least ρ over the slope (a kink at the optimum: the
   epigraph formulation against ρ itself), and with ``--optimize-vsw`` the thesis's
   variable-stiffness walker over K1, K2, α (minimise the largest multiplier with the cost of
   transport ≤ 0.0095, epigraph; ~30 s per gait evaluation at load 14 on 2 cores: ~10 min).

Run::

    python benchmarks/bench_gradients.py                          # three walkers, ~2 min
    python benchmarks/bench_gradients.py --walkers compass_gait --rounds 9 --optimize
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from machine import machine_info
from timing import fresh_walk, interleaved

from walker_library import find_fixed_point, load_walker
from walker_library.analyses.optimize import optimize_gait
from walker_library.core.gradients import stride_gradient

#: the 3 parameters differentiated per walker
NAMES = {"compass_gait": ["slope", "m_H", "a"], "compass_walker": ["slope", "K", "l"],
         "simplest_walker": ["slope", "l", "g"],
         "variable_stiffness_walker": ["K1", "K2", "alpha"],
         "smooth_stiffness_walker": ["K_leg", "kappa", "alpha"]}


def bench_stride(name: str, rounds: int) -> None:
    walker = load_walker(name, backend="c")
    z = find_fixed_point(walker, walker.initial_guess(),
                         tol=float(getattr(walker, "gait_tolerance", 1e-10))).z
    names = NAMES[name]
    variants = {"plain": lambda: fresh_walk(walker, z, 1),
                "state": lambda: walker.stride_sensitivity(z),
                "gradient": lambda: stride_gradient(walker, z, names)}
    for run in variants.values():          # compile, warm caches
        run()
    times = interleaved(variants, rounds)
    med = {k: statistics.median(v) for k, v in times.items()}
    print(f"{name} ({', '.join(names)}; {rounds} rounds): " + ", ".join(
        f"{k} {1e3 * v:.1f} ms" for k, v in med.items())
        + f"; gradient / state = {med['gradient'] / med['state']:.2f} (target <= 2), "
          f"state / plain = {med['state'] / med['plain']:.1f}")


def bench_optimize(vsw: bool) -> None:
    problems = [("simplest_walker", ["slope"], "cost_of_transport",
                 ["max_multiplier_modulus <= 0.6"], {"slope": (0.001, 0.012)}, "auto"),
                *(("simplest_walker", ["slope"], "max_multiplier_modulus", [],
                   {"slope": (0.008, 0.0145)}, form) for form in ("epigraph", "direct"))]
    if vsw:
        problems.append(("variable_stiffness_walker", ["K1", "K2", "alpha"],
                         "max_multiplier_modulus", ["cost_of_transport <= 0.0095"],
                         {"K1": (1500, 12000), "K2": (1500, 16000), "alpha": (0.1, 0.35)},
                         "auto"))
    for name, vary, objective, cons, bounds, form in problems:
        t0 = time.perf_counter()
        r = optimize_gait(load_walker(name, backend="c"), vary, objective, constraints=cons,
                          bounds=bounds, step_down="none", formulation=form,
                          max_evaluations=60)
        print(f"optimize {name} over {', '.join(vary)} ({r.formulation}): {objective} -> "
              f"{r.values.get(objective, float('nan')):.6g} at {r.optimum}; {r.message}; "
              f"{r.evaluations} gait evaluations, {r.iterations} iterations "
              f"({time.perf_counter() - t0:.0f} s; target <= 30 evaluations; a grid of 10 "
              f"values per parameter: {10 ** len(vary)})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--walkers", default="compass_gait,compass_walker,"
                                             "variable_stiffness_walker")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--optimize", action="store_true")
    parser.add_argument("--optimize-vsw", action="store_true")
    args = parser.parse_args()
    print(machine_info())
    for name in args.walkers.split(","):
        bench_stride(name.strip(), args.rounds)
    if args.optimize or args.optimize_vsw:
        bench_optimize(args.optimize_vsw)


if __name__ == "__main__":
    main()

"""The cost of sensitivities (``simulate(..., sensitivity=...)``) on one stride of a walker, and the
accuracy of the stride Jacobian they give against finite differences.

For each walker (the C back end; its file's integration settings, Rodas5P): the fixed point z*,
then, in interleaved rounds (order rotated), one stride from z* as ``HybridWalker.walk`` runs it
(``model.simulate`` with the mode machine's actions, to the heel strike):

* ``plain``        without sensitivities (the baseline of every ratio);
* ``section``      with Φ seeded by the lift's Jacobian (k directions: the walker's case; the
                   mode machine's actions give the resets' Jacobians);
* ``full``         with Φ = ∂x/∂x₀ over all n model states;
* ``jacobian``     the whole exact stride Jacobian, :meth:`HybridWalker.stride_sensitivity`
                   (:func:`walker_library.core.variational.stride_sensitivity`: the run with k
                   directions plus the differences of lift and projection);
* ``fd``           central finite differences of ``HybridWalker.stride`` (2 k strides).

Printed: median wall times, ratios to ``plain``, accepted steps, jac and rhs evaluations, and the
largest multiplier error of ``jacobian`` and ``fd`` against a reference (the exact Jacobian at
rtol / 1000, max_step 2e-5). Run::

    python benchmarks/bench_sensitivity.py                        # compass_walker, ~1 min
    python benchmarks/bench_sensitivity.py --walkers compass_walker,simplest_walker --rounds 9
"""
from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import numpy as np
from machine import machine_info
from timing import interleaved

from porthamiltonian.simulation.differences import jacobian as difference_jacobian
from walker_library import find_fixed_point, load_walker
from walker_library.analyses.poincare import jacobian as fd_jacobian
from walker_library.core.machine import WalkLog


def _eig(J: np.ndarray) -> np.ndarray:
    return np.array(sorted(np.linalg.eigvals(J), key=lambda c: (-abs(c), -c.imag)))


def bench(name: str, rounds: int) -> None:
    walker = load_walker(name, backend="c").with_options(method="Rodas5P")
    z = find_fixed_point(walker, walker.initial_guess()).z
    model, o = walker.model, walker.options
    p_start = walker.start_params()
    x0 = walker.lift(z, p_start)
    p0 = walker.machine.start(x0, p_start)
    lift = difference_jacobian(lambda w: walker.lift(w, p_start), z, 1.0).value

    def stride(seeds):
        log = WalkLog(1)        # with sensitivities, the resets give their Jacobians too
        actions = walker.machine.actions(log, None if seeds is False else ())
        return model.simulate(o.max_step_time, x0=x0, params=dict(zip(model.param_names, p0)),
                              method="Rodas5P", rtol=o.rtol, atol=o.atol, max_step=o.max_step,
                              actions=actions, max_events=200, sensitivity=seeds)

    variants = {"plain": lambda: stride(False), "section": lambda: stride(lift),
                "full": lambda: stride(True), "jacobian": lambda: walker.stride_sensitivity(z),
                "fd": lambda: fd_jacobian(walker, z, step=1e-5)}
    counts = {k: stride(v) for k, v in (("plain", False), ("section", lift), ("full", True))}
    times = interleaved(variants, rounds)
    tight = walker.with_options(rtol=max(o.rtol * 1e-3, 3e-14), atol=o.atol * 1e-3,
                                max_step=min(o.max_step, 2e-5))
    ref = tight.stride_sensitivity(z).jacobian
    errors = {"jacobian": walker.stride_sensitivity(z).jacobian,
              "fd": fd_jacobian(walker, z, step=1e-5)}
    base = statistics.median(times["plain"])
    print(f"\n### {name} (n = {model.n_states} states, k = {len(z)} section coordinates, "
          f"rtol {o.rtol:g}, {rounds} rounds)\n")
    print("| variant | median [ms] | / plain | steps | jac | rhs | max multiplier error |")
    print("|---|---|---|---|---|---|---|")
    for k in variants:
        med = statistics.median(times[k])
        tr = counts.get(k)
        steps = f"{len(tr.t)}" if tr is not None else "–"
        jac = f"{tr.njev}" if tr is not None else "–"
        rhs = f"{tr.nfev}" if tr is not None else "–"
        err = (f"{np.max(np.abs(_eig(errors[k]) - _eig(ref))):.1e}" if k in errors else "–")
        print(f"| {k} | {med * 1e3:.1f} | {med / base:.2f} | {steps} | {jac} | {rhs} | {err} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--walkers", default="compass_walker")
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    info = machine_info()
    print(" ".join(f"{k}={v}" for k, v in info.items()))
    for name in args.walkers.split(","):
        bench(name, args.rounds)
    print(f"\nload at the end: {machine_info()['load']}")


if __name__ == "__main__":
    main()

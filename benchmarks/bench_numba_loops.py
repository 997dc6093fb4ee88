"""The numba back end's one loop for all models against loops compiled with the model.

The numba back end compiles the integration loops once, taking the model's functions as numba
first-class functions (porthamiltonian/backends/numba_loops.py). This measures what the call
through an address costs per step: a walker's stride is run on the numba back end and every call
of its compiled loop recorded; then the same calls are run through

* the shared loop (what the back end uses), and
* the same templates compiled into the model's own module, ``fn`` bound to its functions there
  (direct calls: the loops as they were compiled before, with each model),

each output of every call compared (bit for bit), then the calls timed in interleaved rounds
(medians, wall time: the loops are single-threaded; read the ratio, the machine's load is
printed). The second variant compiles the loops for this model (about 30 s of CPU).

    python benchmarks/bench_numba_loops.py --walkers compass_walker compliant_leg_walker
"""
from __future__ import annotations

import argparse
import os
import statistics
import time
import types
import warnings
from typing import Any

import numpy as np


def _specialised(model: Any, method: str) -> Any:
    """The loop of ``method`` compiled into a copy of the model's numba module (no cache), with
    its functions bound inside the module."""
    from porthamiltonian.backends import module
    from porthamiltonian.integrators import LOOPS, python_loops

    symbol = LOOPS[method]
    text = module.module_text(model.source, "numba").replace("_njit(cache=True)", "_njit")
    text += ("\n\n" + python_loops() + f"\n\n@_jit\ndef bound(*args):\n    return integrate_"
             f"{symbol}((rhs, jac, guards, jac_p), *args)\n")
    mod = types.ModuleType("_bench_specialised")
    exec(compile(text, "<specialised>", "exec"), mod.__dict__)  # noqa: S102 - our own text
    return mod.bound


def _equal(a: tuple, b: tuple) -> bool:
    """The loop's 15-tuples equal, the buffers compared up to their filled lengths."""
    for i, (x, y) in enumerate(zip(a, b, strict=True)):
        if i in (3, 4):
            x, y = x[:a[5]], y[:a[5]]
        elif i in (10, 11):
            x, y = x[:a[12]], y[:a[12]]
        if not np.array_equal(x, y):
            return False
    return True


def measure(name: str, rounds: int) -> dict:
    from walker_library import load_walker

    walker = load_walker(name, backend="numba")
    loops = walker.model.functions.loops
    method = walker.options.method
    shared = loops[method]
    calls: list[list[Any]] = []

    def record(*args: Any) -> Any:
        calls.append([a.copy() if isinstance(a, np.ndarray) else a for a in args])
        return shared(*args)

    loops[method] = record
    try:
        walker.stride(walker.initial_guess())
    finally:
        loops[method] = shared
    specialised = _specialised(walker.model, method)
    equal = all(_equal(shared(*a), specialised(*a)) for a in calls)
    steps = sum(shared(*a)[8] for a in calls)
    times: dict[str, list[float]] = {"shared": [], "specialised": []}
    for r in range(rounds):
        order = [("shared", shared), ("specialised", specialised)]
        for label, loop in order if r % 2 == 0 else order[::-1]:
            t0 = time.perf_counter()
            for a in calls:
                loop(*a)
            times[label].append(time.perf_counter() - t0)
    med = {k: statistics.median(v) for k, v in times.items()}
    return {"walker": name, "method": method, "steps": steps, "bit_for_bit": equal,
            "shared_us_per_step": 1e6 * med["shared"] / steps,
            "specialised_us_per_step": 1e6 * med["specialised"] / steps,
            "ratio": med["shared"] / med["specialised"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--walkers", nargs="+", default=["compass_walker"])
    parser.add_argument("--rounds", type=int, default=15)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    print(f"load average {os.getloadavg()[0]:.1f}")
    for name in args.walkers:
        r = measure(name, args.rounds)
        print(f"{r['walker']} ({r['method']}, {r['steps']} steps): shared "
              f"{r['shared_us_per_step']:.1f} us/step, specialised "
              f"{r['specialised_us_per_step']:.1f} us/step, ratio {r['ratio']:.3f}, "
              f"bit for bit {r['bit_for_bit']}")
    print(f"load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()

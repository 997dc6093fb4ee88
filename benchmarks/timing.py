"""How the benchmarks time variants against each other (ratios against a same-run baseline), and
walks that integrate every time they are timed."""
from __future__ import annotations

import time
from collections.abc import Callable, Mapping


def interleaved(variants: Mapping[str, Callable[[], object]], rounds: int) -> dict[str, list[float]]:
    """The wall times [s] of each variant over ``rounds`` rounds: every variant once a round, the
    order rotated by one each round, so that a change of the machine's load falls on all alike."""
    times: dict[str, list[float]] = {k: [] for k in variants}
    keys = list(variants)
    for r in range(rounds):
        for k in keys[r % len(keys):] + keys[:r % len(keys)]:
            t0 = time.perf_counter()
            variants[k]()
            times[k].append(time.perf_counter() - t0)
    return times


def fresh_walk(walker, z, n_steps: int) -> list:
    """``walker.walk(z, n_steps)`` integrated every time (``reuse=False``: a repeated walk is
    otherwise cut from the walker's last walk, HybridWalker.walk), so that each timed walk
    integrates its strides."""
    return walker.walk(z, n_steps, reuse=False)

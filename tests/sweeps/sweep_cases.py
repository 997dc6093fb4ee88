"""Cheap, deterministic case functions for the sweep tests (importable by worker processes:
the tests put this folder on PYTHONPATH for subprocesses; pytest puts it on sys.path)."""
from __future__ import annotations

import math
import os
import signal
import time


def square_case(case, *, delay=0.0, scale=1.0, model=None, backend=None):
    """x**2 and a transcendental of (x, y), after sleeping ``delay`` seconds. ``model`` and
    ``backend`` are what ``walker sweep MODEL`` passes to every case function (unused here)."""
    if delay:
        time.sleep(delay)
    x, y = case["x"], case.get("y", 0.0)
    return {"status": "ok", "square": scale * x * x, "mix": math.sin(x) * math.exp(-y),
            "nested": {"sum": x + y}}


def mixed_case(case):
    """A failing case of every kind: x < 0 raises, x == 0 falls, x == 1 returns no status,
    x == 2 returns NaN (stored as null), x == 3 returns a non-dict; else ok."""
    x = case["x"]
    if x < 0:
        raise ValueError(f"negative x = {x}")
    if x == 0:
        return {"status": "fell", "message": "fell at step 3"}
    if x == 1:
        return {"value": 1.0}
    if x == 2:
        return {"status": "ok", "value": math.nan}
    if x == 3:
        return [x]
    return {"status": "ok", "value": float(x)}


def crash_case(case):
    """Kills its own worker process when case["crash"] is true (a segfault stand-in)."""
    if case.get("crash"):
        os.kill(os.getpid(), signal.SIGKILL)
    time.sleep(0.05)
    return {"status": "ok", "x": case["x"]}


# the real walker sweep of the tests: simplest_walker gait over 4 slopes, C back end (its exact
# Floquet multipliers cost ~2 strides there, ~100 on the python back end)
GAIT_CASES = [{"slope": 0.004}, {"slope": 0.009}, {"slope": 0.014}, {"slope": 0.019}]
GAIT_FIXED = {"model": "simplest_walker", "backend": "c"}

CALLS: list[float] = []          # x of every call made in this process (serial runs)
INTERRUPT_AT: float | None = None


def counting_case(case):
    """Records its call in CALLS; raises KeyboardInterrupt (a Ctrl-C stand-in, in-process)
    when case["x"] == INTERRUPT_AT."""
    if INTERRUPT_AT is not None and case["x"] == INTERRUPT_AT:
        raise KeyboardInterrupt
    CALLS.append(case["x"])
    return {"status": "ok", "double": 2 * case["x"]}


def ticking_case(case):
    """Reports case["x"] units of work named "iteration" (porthamiltonian.batch.tick)."""
    from porthamiltonian.batch import tick
    for _ in range(int(case["x"])):
        tick("iteration")
        time.sleep(0.01)
    return {"status": "ok"}

"""Benchmark of starting at once (issue 26, item 4): a warm ``walker gait``, and the Python
overhead of one right-hand side call.

**Warm start.** ``walker gait WALKER --json`` end to end in fresh processes, on a private cache
that a first (cold) run filled, two variants interleaved round by round:

* ``warm``  — as a user's second run: the walker restored from its snapshot
  (walker_library/core/warm.py), neither sympy nor networkx imported;
* ``full``  — the same command after the snapshot file is removed: the walker file read in full
  (model built, expressions parsed with sympy, graph built with networkx, plan checked), the
  compiled model still from the cache: what every warm run did before snapshots (and the run
  stores the snapshot again).

With ``--baseline DIR`` (another checkout, e.g. ``git archive <commit> | tar -x -C DIR``) a third
variant, ``baseline``, runs the same warm command from DIR (its own cache, filled by its own cold
run), interleaved with the others: the before/after of a change. ``--command simulate --model
NAME`` measures ``porthamiltonian simulate NAME --json`` instead (its snapshot:
porthamiltonian/interfaces/warm.py).

Each run records its wall time, its CPU time (user + system, from ``getrusage`` of the child; the
user part also apart) and the 1-minute load average at its start; medians over ``--rounds`` and
the ratio warm / full of the medians (same run, same load). The machine is shared: the CPU times
move much less with the load than the wall times. ``--breakdown`` adds one in-process split of a
warm run (import, load, analysis; CPU seconds). ``--no-full`` leaves the ``full`` variant out
(its rounds cost seconds each: a before/after of the warm run alone); ``--cold`` adds the
variants ``cold`` (and ``base-cold`` with ``--baseline``): the same command on an empty cache of
its own each round (the model built and compiled, the snapshot stored). ``--bytecode``: the
children import from bytecode (a temporary folder, filled by the untimed first runs) even where
``$PYTHONDONTWRITEBYTECODE`` is set, as an installed package does; without it, where that
variable is set and the trees have no ``__pycache__``, every run compiles the source of every
module it imports (on this project's warm ``walker gait``, ~0.2 s of CPU).

**Call overhead.** One right-hand side of ``mass_spring_damper`` (2 states) on the C back end
from Python, ``compiled.functions.rhs(t, y, p)`` (the fast path of
porthamiltonian.backends.native: buffers with addresses taken once, a GIL-keeping prototype),
against the same call made as it was before (each call converting its arguments with numpy,
asking for the three arrays' addresses and releasing the GIL around the C function), interleaved
in blocks of ``--calls`` calls; medians of µs per call and their ratio.

Run::

    python benchmarks/bench_warm_start.py                    # both parts (about a minute)
    python benchmarks/bench_warm_start.py --rounds 9 --walker compliant_leg_walker --breakdown
    python benchmarks/bench_warm_start.py --only warm --baseline /tmp/before   # before/after
    python benchmarks/bench_warm_start.py --only warm --command simulate --walker pendulum
"""
from __future__ import annotations

import argparse
import ctypes
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.machine import machine_info

#: the bytecode folder of the children (``--bytecode``; empty: as the environment says)
_PYCACHE: list[str] = []


def _env(cache: Path, root: Path = ROOT) -> dict:
    env = {**os.environ, "PORTHAMILTONIAN_CACHE": str(cache), "PORTHAMILTONIAN_QUIET": "1",
           "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    if _PYCACHE:                    # imports from bytecode, as from an installed package
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = _PYCACHE[0]
    return env


def _timed(command: list[str], env: dict,
           root: Path = ROOT) -> tuple[float, float, float, float]:
    """(wall s, CPU s of the child, its user CPU s, load average at the start) of one run of
    ``command``."""
    load = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, env=env, cwd=root, check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    user = after.ru_utime - before.ru_utime
    return wall, user + after.ru_stime - before.ru_stime, user, load


def _private_cache() -> Path:
    cache = Path(tempfile.mkdtemp(prefix="bench-warm-"))
    os.chmod(cache, 0o700)
    return cache


def _cold(command: list[str], root: Path = ROOT) -> tuple[float, float, float, float]:
    """:func:`_timed` of ``command`` run from ``root`` on an empty cache of its own."""
    cache = _private_cache()
    try:
        return _timed(command, _env(cache, root), root)
    finally:
        shutil.rmtree(cache, ignore_errors=True)


def warm_start(walker: str, rounds: int, breakdown: bool, baseline: Path | None = None,
               what: str = "gait", full: bool = True, cold: bool = False) -> None:
    cache = _private_cache()
    base_cache = _private_cache()
    env = _env(cache)
    command = ([sys.executable, "-m", "walker_library", "gait", walker, "--json"] if what == "gait"
               else [sys.executable, "-m", "porthamiltonian", "simulate", walker, "--json"])
    try:
        wall, cpu, _, load = _timed(command, env)
        print(f"cold run (build, cache filled): {wall:.2f} s wall, {cpu:.2f} s CPU, load {load:.2f}")
        snapshots = list(cache.glob("s*/snapshot.json"))
        if len(snapshots) != 1:
            raise SystemExit(f"expected one snapshot in {cache}, found {len(snapshots)}")
        results: dict[str, list[tuple[float, float, float, float]]] = {"warm": []}
        if full:
            results["full"] = []
        if cold:
            results["cold"] = []
        if baseline is not None:
            results["baseline"] = []
            if cold:
                results["base-cold"] = []
            _timed(command, _env(base_cache, baseline), baseline)   # its cold run
            _timed(command, _env(base_cache, baseline), baseline)   # (its bytecode written)
        _timed(command, env)                                         # (this tree's likewise)
        for _ in range(rounds):
            if full:
                snapshots[0].unlink()
                results["full"].append(_timed(command, env))
                if not snapshots[0].is_file():
                    raise SystemExit("the full read did not store the snapshot again")
            results["warm"].append(_timed(command, env))
            if baseline is not None:
                results["baseline"].append(_timed(command, _env(base_cache, baseline), baseline))
            if cold:
                results["cold"].append(_cold(command))
                if baseline is not None:
                    results["base-cold"].append(_cold(command, baseline))
        print(f"\n{' '.join(command[2:])}, end to end ({rounds} interleaved rounds; medians"
              f"{'; from bytecode' if _PYCACHE else ''})")
        print(f"{'variant':8s} {'wall s':>8s} {'CPU s':>8s} {'user s':>8s}  load (min-max)   "
              "all wall times")
        med = {}
        for name, rows in results.items():
            walls, cpus, users, loads = zip(*rows)
            med[name] = (statistics.median(walls), statistics.median(cpus))
            print(f"{name:8s} {med[name][0]:8.3f} {med[name][1]:8.3f} "
                  f"{statistics.median(users):8.3f}  {min(loads):.2f}-{max(loads):.2f}  "
                  f"{' '.join(f'{w:.2f}' for w in walls)}")
        if full:
            print(f"ratio warm/full: wall {med['warm'][0] / med['full'][0]:.2f}, "
                  f"CPU {med['warm'][1] / med['full'][1]:.2f}")
        if baseline is not None:
            print(f"ratio warm/baseline (warm): wall {med['warm'][0] / med['baseline'][0]:.2f}, "
                  f"CPU {med['warm'][1] / med['baseline'][1]:.2f}")
        if cold and baseline is not None:
            print(f"ratio cold/base-cold: wall {med['cold'][0] / med['base-cold'][0]:.2f}, "
                  f"CPU {med['cold'][1] / med['base-cold'][1]:.2f}")
        if breakdown and what == "gait":
            code = (
                "import time, sys, json\nt0 = time.process_time()\n"
                "import walker_library.cli\n"
                "from walker_library.core.files import load_walker\n"
                "from walker_library.analyses.gait import analyze_gait\n"
                "t1 = time.process_time()\n"
                f"w = load_walker({walker!r})\nt2 = time.process_time()\n"
                "r = analyze_gait(w, None)\nr.to_json()\nt3 = time.process_time()\n"
                "print(json.dumps([t1 - t0, t2 - t1, t3 - t2, "
                "[m for m in ('sympy', 'networkx', 'matplotlib') if m in sys.modules]]))\n")
            out = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, check=True,
                                 capture_output=True, text=True).stdout
            imp, load_s, analysis, heavy = eval_json(out)
            print(f"warm run in-process (CPU s): imports {imp:.3f}, load_walker {load_s:.3f}, "
                  f"gait analysis {analysis:.3f}; symbolic libraries imported: {heavy or 'none'}")
    finally:
        shutil.rmtree(cache, ignore_errors=True)
        shutil.rmtree(base_cache, ignore_errors=True)


def eval_json(text: str):
    import json

    return json.loads(text.strip().splitlines()[-1])


def call_overhead(calls: int, blocks: int) -> None:
    cache = Path(tempfile.mkdtemp(prefix="bench-call-"))
    os.chmod(cache, 0o700)
    os.environ["PORTHAMILTONIAN_CACHE"] = str(cache)
    os.environ["PORTHAMILTONIAN_QUIET"] = "1"
    try:
        import numpy as np

        from porthamiltonian import io
        from porthamiltonian.backends import native
        from porthamiltonian.compiler import cache as ph_cache

        m = io.read("mass_spring_damper").compile(backend="c")
        p = m.params()
        y = m.augment(m.initial_state(p)) + 0.25
        pn = m.native_params(p)
        fast = m.functions.rhs
        path = ph_cache.verified_path(m.key, native.library_name(m.key, native.compiler_identity()))
        fn = ctypes.CDLL(str(path)).ph_rhs
        fn.restype = None
        fn.argtypes = (ctypes.c_double, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)
        n, n_p, shape = len(y), len(pn), (len(y),)

        def before(t, x, q):
            """The call as the C back end made it before the fast path."""
            x = native._vector(x, n, "x")
            q = native._vector(q, n_p, "p")
            out = np.empty(shape)
            fn(t, native._pointer(x), native._pointer(q), native._pointer(out))
            return out

        assert np.array_equal(before(0.1, y, pn), fast(0.1, y, pn))
        times: dict[str, list[float]] = {"before": [], "fast": []}
        for _ in range(blocks):
            for name, f in (("before", before), ("fast", fast)):
                start = time.perf_counter()
                for _ in range(calls):
                    f(0.1, y, pn)
                times[name].append((time.perf_counter() - start) / calls * 1e6)
        med = {k: statistics.median(v) for k, v in times.items()}
        print(f"\nPython call of one right-hand side, mass_spring_damper ({m.n_states} states, "
              f"C back end), {blocks} interleaved blocks of {calls} calls; medians, load "
              f"{os.getloadavg()[0]:.2f}")
        for k, v in med.items():
            print(f"{k:8s} {v:7.2f} µs per call   (min {min(times[k]):.2f})")
        print(f"ratio fast/before: {med['fast'] / med['before']:.2f}")
    finally:
        shutil.rmtree(cache, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--walker", default="compass_walker")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--calls", type=int, default=20000)
    ap.add_argument("--blocks", type=int, default=15)
    ap.add_argument("--breakdown", action="store_true")
    ap.add_argument("--only", choices=("warm", "calls"), default=None)
    ap.add_argument("--baseline", type=Path, default=None, metavar="DIR",
                    help="another checkout whose warm run is interleaved with this one's")
    ap.add_argument("--command", choices=("gait", "simulate"), default="gait",
                    help="walker gait WALKER, or porthamiltonian simulate WALKER (any model)")
    ap.add_argument("--no-full", dest="full", action="store_false",
                    help="leave out the full-read variant (the warm run, and the baseline's)")
    ap.add_argument("--cold", action="store_true",
                    help="also the command on an empty cache each round (this tree's and the "
                         "baseline's)")
    ap.add_argument("--bytecode", action="store_true",
                    help="children import from bytecode (a temporary folder) even when "
                         "$PYTHONDONTWRITEBYTECODE is set, as an installed package does")
    args = ap.parse_args()
    print(machine_info())
    if args.bytecode:
        _PYCACHE.append(tempfile.mkdtemp(prefix="bench-warm-pycache-"))
    try:
        if args.only != "calls":
            warm_start(args.walker, args.rounds, args.breakdown, args.baseline, args.command,
                       args.full, args.cold)
    finally:
        for folder in _PYCACHE:
            shutil.rmtree(folder, ignore_errors=True)
    if args.only != "warm":
        call_overhead(args.calls, args.blocks)


if __name__ == "__main__":
    main()

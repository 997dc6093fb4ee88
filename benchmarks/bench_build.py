"""Benchmark of building models: cold build to the first result, warm build, generated size.

Cases:

* ``compass_walker``, ``compliant_leg_walker``: the walker files of models/ (``load_walker``,
  which checks the description and compiles the model), then the first finished stride from the
  walker's initial guess;
* ``chainN`` (N = 2, 5, 10, 20, 40 by default): N uniform rods on revolute joints
  (bench_mechanics.chain_model), ``compile_model`` then 1 s of simulation (method "auto");
* ``gchainN``: N links on revolute joints about random 3D axes (generic_chain_model of
  tests/validation/multibody_cases.py), the same; ``chainN:symbolic``, ``gchainN:kernel``…: with
  the Multibody's formulation set (default "auto": the kernel for generic axes and long chains).

Each case runs in fresh subprocesses: **cold** with an empty ``$PORTHAMILTONIAN_CACHE`` (the
phases from the build line the library prints — symbolic, code generation, native compile —
then the first stride or the 1 s simulation, and the total from before ``import porthamiltonian``
to the first result), then **warm** on the cache the cold run filled (build and first result).
The **generated size** is read from the cache entry: bytes of the C and Python bodies and the
operations in the C body (arithmetic operators and function calls after cse); the growth
exponent of the chains is the slope of log(size) against log(N) between N = 10 and the largest N
that finished. Every run records the 1-minute load average at its start and the CPU time
(user + system) of the process and its children (the C compiler): on the shared machine the wall
times move with the load by 2-3x, the CPU times much less. ``--repeats`` interleaves rounds of all
cases (medians); ``--baseline DIR`` builds the same cases from another source tree (e.g. ``git
archive main`` or a ``git worktree``) interleaved with this one, for before/after comparisons in
one run, and prints the ratio of the cold builds' CPU times (medians and round by round).
``--bytecode``: the children import from bytecode in a shared temporary folder even where
``$PYTHONDONTWRITEBYTECODE`` is set (an installed package has its bytecode; without it every
cold run also compiles the package's 300 modules). The size columns include the lines of the C
and Python bodies. A case that
exceeds ``--timeout`` seconds is reported as such.

``--phases`` measures instead the CPU time of each phase of the two walkers' builds in fresh
subprocesses (the symbolic model, code generation, printing the C body, the C compiler on the
model's unit and on the loops' unit), this tree against ``--baseline``'s modules run by this
script, interleaved over ``--repeats`` rounds: a steadier before/after than the whole cold build
on a loaded machine (no imports, no scheduling).

``--walker-3d`` measures the 3D walker against the 2D one (issue 15): the 3D fixed point found
by Newton from compass_walker_sole_friction's fixed point (its 2D twin: friction at the sole
point; lateral coordinates 0; the iterations printed) and the time per stride of
compass_walker_3d (w = 0) against that walker's from their fixed points
(interleaved rounds, medians); its cold and warm builds are the ``compass_walker_3d`` case.

``--opt-levels`` measures instead the C compiler's optimisation levels on the two walkers: build
time of the translation unit at -O0/-O1/-O2/-O3 and at -O1 with the loop at -O2 (the
library's choice, see porthamiltonian.backends.native.FLAGS; median of 3) against the time per stride of a
walk from the fixed point (median of interleaved rounds), which is how
porthamiltonian.backends.native.FLAGS was chosen.

Run::

    python benchmarks/bench_build.py                          # all cases, C back end (~10 min)
    python benchmarks/bench_build.py --cases compass_walker,chain10 --backends c,numba
    python benchmarks/bench_build.py --opt-levels
    python benchmarks/bench_build.py --cases compass_walker,compliant_leg_walker,chain10,chain20,chain40 \\
        --repeats 5 --once chain40             # the issue-11 targets: medians, interleaved
    mkdir /tmp/main && git archive main | tar -x -C /tmp/main
    python benchmarks/bench_build.py --cases compass_walker,compliant_leg_walker --repeats 5 \\
        --baseline /tmp/main                   # before / after, interleaved
    python benchmarks/bench_build.py --cases compass_walker,compass_walker_3d --walker-3d
    python benchmarks/bench_build.py --phases --repeats 5 --baseline /tmp/main
"""
from __future__ import annotations

import argparse
import inspect
import json
import math
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

_T_START = time.perf_counter()
ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

WALKERS = ("compass_walker", "compliant_leg_walker")
WALKER_3D = "compass_walker_3d"
PLANAR_TWIN = "compass_walker_sole_friction"   # the 2D walker compass_walker_3d equals at w = 0
CHAINS = (2, 5, 10, 20, 40)
_BUILD_LINE = re.compile(r"building (.*?): (.*), (\d+) kB")


# --- the child: one build ------------------------------------------------------------------------
def child(case: str, backend: str) -> None:
    """Build ``case`` and compute its first result; print one JSON line of timings."""
    t0 = time.perf_counter()
    import porthamiltonian  # noqa: F401
    import walker_library  # noqa: F401
    t_import = time.perf_counter() - t0
    t0 = time.perf_counter()
    if case in (*WALKERS, WALKER_3D):
        from walker_library import load_walker
        walker = load_walker(case, backend=backend)
        t_build = time.perf_counter() - t0
        t0 = time.perf_counter()
        stride = walker.stride(walker.initial_guess())
        status, used = stride.status, walker.backend
    else:
        from bench_mechanics import build

        from porthamiltonian import compile_model
        model = compile_model(build(case), backend=backend)
        t_build = time.perf_counter() - t0
        t0 = time.perf_counter()
        status, used = model.simulate(1.0).status, model.backend
    t_first = time.perf_counter() - t0
    print(json.dumps({"import": t_import, "build": t_build, "first": t_first,
                      "total": time.perf_counter() - _T_START, "status": status,
                      "backend": used}))


def run_child(case: str, backend: str, cache: str, timeout: float, tree: Path = ROOT) -> dict:
    """One build in a fresh subprocess of ``tree``'s code (this tree, or a baseline tree with
    the same script); ``cpu``: user + system seconds of the process and its children (the C
    compiler), which the machine's load changes less than the wall times."""
    env = dict(os.environ, PORTHAMILTONIAN_CACHE=cache,
               PYTHONPATH=os.pathsep.join([str(tree), *_EXTRA_PATH]))
    env.pop("PORTHAMILTONIAN_QUIET", None)
    if _PYCACHE:                    # imports from bytecode, as from an installed package
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = _PYCACHE[0]
    t0 = time.perf_counter()
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    try:
        out = subprocess.run([sys.executable, str(tree / "benchmarks" / "bench_build.py"),
                              "--child", case, "--backends", backend], env=env,
                             capture_output=True, text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return {"error": f"timeout after {timeout:.0f} s"}
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode != 0:
        return {"error": out.stderr.strip().splitlines()[-1] if out.stderr.strip() else "failed"}
    result = json.loads(out.stdout.strip().splitlines()[-1])
    result["wall"] = wall
    result["cpu"] = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    for line in out.stderr.splitlines():
        match = _BUILD_LINE.search(line)
        if match:                       # every model built (a walker may build two)
            for part in match.group(2).split(", "):
                name, value, _ = part.split(" ")
                result[name] = result.get(name, 0.0) + float(value)
    return result


#: the parent's PYTHONPATH entries, after the tree's (e.g. a folder whose sitecustomize drops
#: an editable install's finder, so that each tree imports its own package)
_EXTRA_PATH = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
#: the bytecode folder the children share (``--bytecode``), filled by one untimed build per
#: tree before the rounds
_PYCACHE: list[str] = []


def generated_size(cache: str) -> dict:
    """Bytes and lines of the bodies and operations in the C body (of the largest entry); the
    Python body's are 0 when the entry has none (a C build prints none)."""
    best: dict = {}
    for entry in Path(cache).iterdir():
        c, py = entry / "body.c", entry / "body.py"
        if not c.is_file():
            continue
        text = c.read_text()
        body = text[text.index("#define PH_N"):]
        ops = len(re.findall(r"(?<![eE])[-+*/](?!=)", body)) + len(re.findall(r"\b[a-z]+\(", body))
        if c.stat().st_size > best.get("c_bytes", 0):
            python = py.read_text() if py.is_file() else ""
            best = {"c_bytes": c.stat().st_size, "py_bytes": len(python.encode()), "ops": ops,
                    "c_lines": text.count("\n"), "py_lines": python.count("\n")}
    return best


def _load() -> float:
    return os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")


def _median(runs: list[dict], key: str) -> float | None:
    values = [r[key] for r in runs if key in r]
    return statistics.median(values) if values else None


def build_cases(args) -> None:
    """``--repeats`` rounds; in each, every case (and back end) once cold then once warm, the
    cases interleaved so that a change of the machine's load hits all of them alike. Every run
    records the 1-minute load average at its start; the table gives medians and the load range."""
    cases = [c for c in args.cases.split(",") if c]
    once = {c for c in args.once.split(",") if c}
    trees = {"this": ROOT}
    if args.baseline:
        trees["baseline"] = Path(args.baseline).resolve()
    variants = [(case, backend, tree) for case in cases for backend in args.backends.split(",")
                for tree in trees]
    runs: dict = {v: {"cold": [], "warm": [], "size": {}} for v in variants}
    if args.bytecode:
        _PYCACHE.append(tempfile.mkdtemp(prefix="phbench_pycache_"))
        for tree in trees.values():          # one untimed build fills it
            scratch = tempfile.mkdtemp(prefix="phbench_warmup_")
            run_child(cases[0], args.backends.split(",")[0], scratch, args.timeout, tree)
            shutil.rmtree(scratch, ignore_errors=True)
    for rnd in range(args.repeats):
        # this tree and the baseline alternate which goes first
        for case, backend, tree in sorted(variants, key=lambda v: (
                variants.index(v) // len(trees), (list(trees).index(v[2]) + rnd) % len(trees))):
            if rnd and case in once:
                continue
            rec = runs[case, backend, tree]
            cache = tempfile.mkdtemp(prefix=f"phbench_build_{case}_")
            load = _load()
            cold = run_child(case, backend, cache, args.timeout, trees[tree])
            cold["load"] = load
            rec["cold"].append(cold)
            if "error" not in cold:
                load = _load()
                warm = run_child(case, backend, cache, args.timeout, trees[tree])
                warm["load"] = load
                rec["warm"].append(warm)
                rec["size"] = generated_size(cache)
            shutil.rmtree(cache, ignore_errors=True)
            print(f"round {rnd + 1} {case} / {backend} / {tree}: cold {cold}\n  warm "
                  f"{rec['warm'][-1] if rec['warm'] else '-'}", flush=True)
    print(f"\n## Cold and warm builds (fresh subprocesses; cold = empty cache; medians of "
          f"{args.repeats} interleaved rounds unless n says otherwise)")
    if args.baseline:
        print(f"(baseline: {trees['baseline']})")
    print("\n| case | tree | back end | n | cold: symbolic [s] | code [s] | C [s] | build [s] | "
          "first result [s] | import [s] | **total to first result [s]** (min-max) | CPU [s] | "
          "warm: import [s] | build [s] | first result [s] | total [s] | load (1 min) | C body "
          "[kB] | Python body [kB] | operations (C) | lines C / Python |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    chains = []
    for (case, backend, tree), rec in runs.items():
        cold = [r for r in rec["cold"] if "error" not in r]
        if not cold:
            print(f"| {case} | {tree} | {backend} | 0 | {rec['cold'][0]['error']} |")
            continue
        warm, size = rec["warm"], rec["size"]

        def f(rs, k):
            m = _median(rs, k)
            return "-" if m is None else f"{m:.2f}"
        totals = [r["total"] for r in cold]
        loads = [r["load"] for r in rec["cold"] + warm]
        print(f"| {case} | {tree} | {cold[0].get('backend', backend)} | {len(cold)} | "
              f"{f(cold, 'symbolic')} | {f(cold, 'code')} | {f(cold, 'C')} | {f(cold, 'build')} | "
              f"{f(cold, 'first')} | {f(cold, 'import')} | **{f(cold, 'total')}** "
              f"({min(totals):.2f}-{max(totals):.2f}) | {f(cold, 'cpu')} | {f(warm, 'import')} | "
              f"{f(warm, 'build')} | "
              f"{f(warm, 'first')} | {f(warm, 'total')} | {min(loads):.1f}-{max(loads):.1f} | "
              f"{size.get('c_bytes', 0) / 1e3:.0f} | {size.get('py_bytes', 0) / 1e3:.0f} | "
              f"{size.get('ops', 0)} | {size.get('c_lines', 0)} / {size.get('py_lines', 0)} |")
        if case.startswith("chain") and ":" not in case and size and tree == "this":
            chains.append((int(case[5:]), size))
    if args.baseline:
        print("\n| case | back end | cold CPU [s] this / baseline (medians) | ratio | "
              "per round (paired) ratios |")
        print("|---|---|---|---|---|")
        for case in cases:
            for backend in args.backends.split(","):
                a, b = (runs[case, backend, t]["cold"] for t in ("this", "baseline"))
                ca, cb = _median(a, "cpu"), _median(b, "cpu")
                if ca is None or cb is None:
                    continue
                paired = [x["cpu"] / y["cpu"] for x, y in zip(a, b) if "cpu" in x and "cpu" in y]
                print(f"| {case} | {backend} | {ca:.2f} / {cb:.2f} | {ca / cb:.2f} | "
                      f"{', '.join(f'{r:.2f}' for r in paired)} |")
    big = sorted((n, s) for n, s in chains if n >= 10)
    if len(big) >= 2:
        (n0, s0), (n1, s1) = big[0], big[-1]
        for key in ("ops", "c_bytes"):
            slope = math.log(s1[key] / s0[key]) / math.log(n1 / n0)
            print(f"\ngrowth exponent of the chains' {key}, N = {n0} -> {n1}: {slope:.2f}")


# --- the phases of a build, in-process ------------------------------------------------------------
PHASES = ("symbolic", "program", "print", "cc model", "cc loops")


def phase_child(cases: str) -> None:
    """The CPU seconds of each phase of building each walker of ``cases`` (sympy's cache cleared
    before each): the symbolic model, ``codegen.program``, printing the C body, the C
    compiler on the model's unit and on the loops' unit (object files, the library's flags).
    The package comes from ``$PHBENCH_TREE`` (this script put its own tree first on the path)."""
    sys.path.insert(0, os.environ.get("PHBENCH_TREE", str(ROOT)))
    import sympy as sp

    from porthamiltonian.backends import native
    from porthamiltonian.compiler import symbolic
    from porthamiltonian.compiler.codegen import program
    from porthamiltonian.compiler.printers import c_source, python_source
    from porthamiltonian.interfaces import io

    def cc(text: str) -> float:
        with tempfile.TemporaryDirectory(prefix="phbench_phase_") as tmp:
            src = Path(tmp) / "unit.c"
            src.write_text(text)
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            subprocess.run([*native.compiler(), *(f for f in native.FLAGS if f != "-shared"),
                            "-c", "-o", str(Path(tmp) / "unit.o"), str(src)], check=True)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
        return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)

    out = {}
    for case in cases.split(","):
        sp.core.cache.clear_cache()
        t0 = time.process_time()
        sym = symbolic(io.load(case))
        t1 = time.process_time()
        prog = program(sym)
        t2 = time.process_time()
        c = c_source(prog)              # (the build prints no Python body for C)
        t3 = time.process_time()
        py = python_source(prog)
        out[case] = {"symbolic": t1 - t0, "program": t2 - t1, "print": t3 - t2,
                     "cc model": cc(native.model_unit(c, key="bench")),
                     "cc loops": cc(native.loop_source(*(  # (by the sizes: older trees)
                         (prog.n, prog.n_guards)
                         if inspect.signature(native.loop_source).parameters else ()))),
                     "lines": f"{c.count(chr(10))} / {py.count(chr(10))}"}
    print(json.dumps(out))


def phases(args) -> None:
    """``--phases``: :func:`phase_child` in fresh subprocesses of this tree and (``--baseline``)
    the other, interleaved over ``--repeats`` rounds; medians and the ratios this / baseline."""
    cases = [c for c in args.cases.split(",") if c in WALKERS] or list(WALKERS)
    trees = {"this": ROOT, **({"baseline": Path(args.baseline).resolve()} if args.baseline
                              else {})}
    runs: dict = {t: [] for t in trees}
    for rnd in range(args.repeats):
        for tree in (list(trees) if rnd % 2 == 0 else list(trees)[::-1]):
            env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(trees[tree]), *_EXTRA_PATH]),
                       PHBENCH_TREE=str(trees[tree]))
            out = subprocess.run([sys.executable, __file__, "--phase-child", ",".join(cases)],
                                 env=env, capture_output=True, text=True, check=True)
            runs[tree].append((_load(), json.loads(out.stdout.strip().splitlines()[-1])))
    print(f"\n## Phases of a cold build, CPU [s] in-process (medians of {args.repeats} "
          "interleaved rounds)")
    print("\n| walker | tree | " + " | ".join(PHASES) + " | sum | lines C / Python | load |")
    print("|---|---|" + "---|" * (len(PHASES) + 3))
    for case in cases:
        sums = {}
        for tree, rs in runs.items():
            med = {k: statistics.median(r[case][k] for _, r in rs) for k in PHASES}
            sums[tree] = med
            loads = [load for load, _ in rs]
            print(f"| {case} | {tree} | " + " | ".join(f"{med[k]:.3f}" for k in PHASES)
                  + f" | {sum(med.values()):.3f} | {rs[0][1][case]['lines']} | "
                  f"{min(loads):.1f}-{max(loads):.1f} |")
        if "baseline" in sums:
            a, b = sums["this"], sums["baseline"]
            print(f"| {case} | ratio | " + " | ".join(f"{a[k] / b[k]:.2f}" for k in PHASES)
                  + f" | {sum(a.values()) / sum(b.values()):.2f} | | |")


# --- optimisation levels -----------------------------------------------------------------------------
def opt_levels(args) -> None:
    from timing import fresh_walk

    from porthamiltonian.backends import native
    from walker_library import find_fixed_point, load_walker

    # (level, the loop template at -O2 under GCC): the library's choice is ("-O1", True)
    levels = (("-O0", False), ("-O1", False), ("-O2", False), ("-O3", False), ("-O1", True))
    print("\n## C optimisation level: build time of the translation unit vs time per stride")
    print("\n| walker | level | build [s] (median of 3) | library [kB] | time per stride [ms] "
          "(median) | stride / -O1 stride |")
    print("|---|---|---|---|---|---|")
    for name in WALKERS:
        walker = load_walker(name, backend="c")
        z = find_fixed_point(walker, tol=1e-8).z
        model = walker.model
        shapes = {k: tuple(v) for k, v in _shapes(model).items()}
        tmp = Path(tempfile.mkdtemp(prefix="phbench_opt_"))
        functions, builds, sizes = {}, {}, {}
        for level in levels:
            src = tmp / f"unit{level[1]}.c"
            src.write_text(native.translation_unit(model.source, loop_pragma=level[1]))
            times = []
            for rep in range(3):
                out = tmp / f"lib{level[0]}{level[1]}_{rep}.so"
                cmd = [*native.compiler(), level[0], *native.FLAGS[1:], "-o", str(out), str(src),
                       "-lm"]
                t0 = time.perf_counter()
                subprocess.run(cmd, check=True)
                times.append(time.perf_counter() - t0)
            builds[level] = statistics.median(times)
            sizes[level] = out.stat().st_size
            functions[level] = native.load(out, shapes, len(model.param_names))
        per: dict = {level: [] for level in levels}
        original = model.functions
        for _ in range(args.rounds):
            for level in levels:
                model.functions = functions[level]
                t0 = time.perf_counter()
                strides = fresh_walk(walker, z, args.strides)
                per[level].append((time.perf_counter() - t0) / len(strides))
        model.functions = original
        base = statistics.median(per["-O1", False])
        for level in levels:
            med = statistics.median(per[level])
            label = f"{level[0]}{', loop -O2 (default)' if level[1] else ''}"
            print(f"| {name} | {label} | {builds[level]:.2f} | {sizes[level] / 1e3:.0f} | "
                  f"{1e3 * med:.2f} | {med / base:.2f} |", flush=True)


def walker_3d(args) -> None:
    """Newton iterations to the 3D fixed point from the 2D one; time per stride, 3D vs 2D."""
    import numpy as np
    from timing import fresh_walk

    from walker_library import find_fixed_point, load_walker
    planar, spatial = load_walker(PLANAR_TWIN, backend="c"), load_walker(WALKER_3D, backend="c")
    z2 = find_fixed_point(planar, tol=1e-8).z
    lateral = len(spatial.section) - len(planar.section)
    fp3 = find_fixed_point(spatial, np.concatenate([z2, np.zeros(lateral)]), tol=1e-8)
    print(f"\n## 3D walker (w = 0) against {PLANAR_TWIN}\n\nNewton from the 2D fixed point: "
          f"{fp3.iterations} iterations, converged {fp3.converged}, |z3 - z2| (shared) "
          f"{np.max(np.abs(fp3.z[:len(z2)] - z2)):.1e}")
    per: dict = {PLANAR_TWIN: [], WALKER_3D: []}
    for _ in range(args.rounds):
        for name, walker, z in ((PLANAR_TWIN, planar, z2), (WALKER_3D, spatial, fp3.z)):
            t0 = time.perf_counter()
            strides = fresh_walk(walker, z, args.strides)
            per[name].append((time.perf_counter() - t0) / len(strides))
    base = statistics.median(per[PLANAR_TWIN])
    for name, times in per.items():
        print(f"time per stride, {name}: {1e3 * statistics.median(times):.2f} ms (median of "
              f"{args.rounds} interleaved rounds of {args.strides} strides); "
              f"ratio to {PLANAR_TWIN} {statistics.median(times) / base:.2f}", flush=True)


def _shapes(model) -> dict:
    """The result shapes of a compiled model's functions (as compile_model's metadata)."""
    n = model.n_states + 2
    shapes = {"rhs": (n,), "jac": (n, n), "energy": (3,),
              "outputs": (max(len(model.output_names), 1),),
              "guards": (max(len(model.events), 1),), "initial": (model.n_states,)}
    for k, name in enumerate(model.matrix_names):
        shapes[f"matrix_{k}"] = model.matrix(name, 0.0, model.augment(
            model.initial_state()), model.param_defaults).shape
    return shapes


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default=",".join([*WALKERS, WALKER_3D,
                                                      *(f"chain{n}" for n in CHAINS)]))
    parser.add_argument("--backends", default="c")
    parser.add_argument("--timeout", type=float, default=900.0,
                        help="seconds a subprocess may take (default 900)")
    parser.add_argument("--opt-levels", action="store_true")
    parser.add_argument("--repeats", type=int, default=1,
                        help="interleaved rounds of cold + warm builds (medians)")
    parser.add_argument("--baseline", metavar="DIR",
                        help="another source tree (e.g. git archive of main) built interleaved")
    parser.add_argument("--bytecode", action="store_true",
                        help="children import from bytecode (a shared temporary folder) even "
                             "when $PYTHONDONTWRITEBYTECODE is set, as an installed package does")
    parser.add_argument("--once", default="",
                        help="cases built in the first round only (e.g. chain40)")
    parser.add_argument("--walker-3d", action="store_true",
                        help="also: Newton iterations and time per stride, 3D vs 2D walker")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--strides", type=int, default=5)
    parser.add_argument("--phases", action="store_true",
                        help="instead: the CPU of each phase of the walkers' builds in-process "
                             "(symbolic, code generation, printing, the C compiler on the "
                             "model's and the loops' units), this tree against --baseline")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    parser.add_argument("--phase-child", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        child(args.child, args.backends)
        return 0
    if args.phase_child:
        phase_child(args.phase_child)
        return 0
    from machine import machine_info
    info = machine_info()
    print(f"date {info['date']}; {info['nproc']} cores, {info['cpu']}; {info['platform']}; "
          f"load average {info['load']}; python {info['python']}, numpy {info['numpy']}, "
          f"sympy {info['sympy']}, numba {info['numba']}; C compiler "
          f"{_compiler_version()}", flush=True)
    if args.opt_levels:
        opt_levels(args)
    elif args.phases:
        phases(args)
    else:
        build_cases(args)
    if args.walker_3d:
        walker_3d(args)
    print(f"\nload average at the end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


def _compiler_version() -> str:
    from porthamiltonian.backends import native
    cc = native.compiler()
    if cc is None:
        return "none"
    out = subprocess.run([*cc, "--version"], capture_output=True, text=True, check=False)
    return f"{' '.join(cc)}: {(out.stdout or out.stderr).splitlines()[0] if out.stdout or out.stderr else '?'}"


if __name__ == "__main__":
    sys.exit(main())

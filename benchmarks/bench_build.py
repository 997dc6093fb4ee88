"""Benchmark of building models: cold build to the first result, warm build, generated size.

Cases:

* ``compass_walker``, ``compliant_leg_walker``: the walker files of models/ (``load_walker``,
  which checks the description and compiles the model), then the first finished stride from the
  walker's initial guess;
* ``chainN`` (N = 2, 5, 10, 20, 40 by default): N uniform rods on revolute joints
  (bench_mechanics.chain_model), ``compile_model`` then 1 s of simulation (method "auto").

Each case runs in fresh subprocesses: **cold** with an empty ``$PORTHAMILTONIAN_CACHE`` (the
phases from the build line the library prints — symbolic, code generation, native compile —
then the first stride or the 1 s simulation, and the total from before ``import porthamiltonian``
to the first result), then **warm** on the cache the cold run filled (build and first result).
The **generated size** is read from the cache entry: bytes of the C and Python bodies and the
operations in the C body (arithmetic operators and function calls after cse); the growth
exponent of the chains is the slope of log(size) against log(N) between N = 10 and the largest N
that finished. A case that exceeds ``--timeout`` seconds is reported as such (the recursive
multibody, issue 11 item 1, is expected to bring the large chains in: rerun this script after it
lands).

``--opt-levels`` measures instead the C compiler's optimisation levels on the two walkers: build
time of the translation unit at -O0/-O1/-O2/-O3 and at -O1 with the loop at -O2 (the
library's choice, see porthamiltonian.backends.native.FLAGS; median of 3) against the time per stride of a
walk from the fixed point (median of interleaved rounds), which is how
porthamiltonian.backends.native.FLAGS was chosen.

Run::

    python benchmarks/bench_build.py                          # all cases, C back end (~10 min)
    python benchmarks/bench_build.py --cases compass_walker,chain10 --backends c,numba
    python benchmarks/bench_build.py --opt-levels
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
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
    if case in WALKERS:
        from walker_library import load_walker
        walker = load_walker(case, backend=backend)
        t_build = time.perf_counter() - t0
        t0 = time.perf_counter()
        stride = walker.stride(walker.initial_guess())
        status, used = stride.status, walker.backend
    else:
        from bench_mechanics import chain_model

        from porthamiltonian import compile_model
        model = compile_model(chain_model(int(case[len("chain"):])), backend=backend)
        t_build = time.perf_counter() - t0
        t0 = time.perf_counter()
        status, used = model.simulate(1.0).status, model.backend
    t_first = time.perf_counter() - t0
    print(json.dumps({"import": t_import, "build": t_build, "first": t_first,
                      "total": time.perf_counter() - _T_START, "status": status,
                      "backend": used}))


def run_child(case: str, backend: str, cache: str, timeout: float) -> dict:
    env = dict(os.environ, PORTHAMILTONIAN_CACHE=cache, PYTHONPATH=str(ROOT))
    env.pop("PORTHAMILTONIAN_QUIET", None)
    t0 = time.perf_counter()
    try:
        out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--child", case,
                              "--backends", backend], env=env, capture_output=True, text=True,
                             timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return {"error": f"timeout after {timeout:.0f} s"}
    wall = time.perf_counter() - t0
    if out.returncode != 0:
        return {"error": out.stderr.strip().splitlines()[-1] if out.stderr.strip() else "failed"}
    result = json.loads(out.stdout.strip().splitlines()[-1])
    result["wall"] = wall
    for line in out.stderr.splitlines():
        match = _BUILD_LINE.search(line)
        if match:                       # every model built (a walker may build two)
            for part in match.group(2).split(", "):
                name, value, _ = part.split(" ")
                result[name] = result.get(name, 0.0) + float(value)
    return result


def generated_size(cache: str) -> dict:
    """Bytes of the bodies and operations in the C body (of the largest entry)."""
    best: dict = {}
    for entry in Path(cache).iterdir():
        c, py = entry / "body.c", entry / "body.py"
        if not c.is_file():
            continue
        text = c.read_text()
        body = text[text.index("#define PH_N"):]
        ops = len(re.findall(r"(?<![eE])[-+*/](?!=)", body)) + len(re.findall(r"\b[a-z]+\(", body))
        if c.stat().st_size > best.get("c_bytes", 0):
            best = {"c_bytes": c.stat().st_size, "py_bytes": py.stat().st_size, "ops": ops}
    return best


def build_cases(args) -> None:
    cases = [c for c in args.cases.split(",") if c]
    rows = []
    for case in cases:
        for backend in args.backends.split(","):
            cache = tempfile.mkdtemp(prefix=f"phbench_build_{case}_")
            print(f"{case} / {backend}: cold ...", flush=True)
            cold = run_child(case, backend, cache, args.timeout)
            warm = (run_child(case, backend, cache, args.timeout) if "error" not in cold
                    else {"error": "(no cold build)"})
            size = generated_size(cache)
            rows.append((case, backend, cold, warm, size))
            print(f"  cold {cold}\n  warm {warm}\n  size {size}", flush=True)
    print("\n## Cold and warm builds (fresh subprocesses; cold = empty cache)")
    print("\n| case | back end | cold: symbolic [s] | code [s] | C [s] | build [s] | first "
          "result [s] | import [s] | total to first result [s] | warm: build [s] | first "
          "result [s] | C body [kB] | Python body [kB] | operations (C) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for case, backend, cold, warm, size in rows:
        if "error" in cold:
            print(f"| {case} | {backend} | {cold['error']} |||||||||||| ")
            continue
        used = cold.get("backend", backend)

        def f(d, k):
            return f"{d[k]:.2f}" if k in d else "-"
        print(f"| {case} | {used} | {f(cold, 'symbolic')} | {f(cold, 'code')} | {f(cold, 'C')} | "
              f"{f(cold, 'build')} | {f(cold, 'first')} | {f(cold, 'import')} | "
              f"{f(cold, 'total')} | {f(warm, 'build')} | {f(warm, 'first')} | "
              f"{size.get('c_bytes', 0) / 1e3:.0f} | {size.get('py_bytes', 0) / 1e3:.0f} | "
              f"{size.get('ops', 0)} |")
    chains = [(int(case[5:]), size) for case, _, cold, _, size in rows
              if case.startswith("chain") and "error" not in cold and size]
    big = [(n, s) for n, s in chains if n >= 10]
    if len(big) >= 2:
        (n0, s0), (n1, s1) = big[0], big[-1]
        for key in ("ops", "c_bytes"):
            slope = math.log(s1[key] / s0[key]) / math.log(n1 / n0)
            print(f"\ngrowth exponent of the chains' {key}, N = {n0} -> {n1}: {slope:.2f}")


# --- optimisation levels -----------------------------------------------------------------------------
def opt_levels(args) -> None:
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
                strides = walker.walk(z, args.strides)
                per[level].append((time.perf_counter() - t0) / len(strides))
        model.functions = original
        base = statistics.median(per["-O1", False])
        for level in levels:
            med = statistics.median(per[level])
            label = f"{level[0]}{', loop -O2 (default)' if level[1] else ''}"
            print(f"| {name} | {label} | {builds[level]:.2f} | {sizes[level] / 1e3:.0f} | "
                  f"{1e3 * med:.2f} | {med / base:.2f} |", flush=True)


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
    parser.add_argument("--cases", default=",".join([*WALKERS, *(f"chain{n}" for n in CHAINS)]))
    parser.add_argument("--backends", default="c")
    parser.add_argument("--timeout", type=float, default=900.0,
                        help="seconds a subprocess may take (default 900)")
    parser.add_argument("--opt-levels", action="store_true")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--strides", type=int, default=5)
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        child(args.child, args.backends)
        return 0
    from machine import machine_info
    info = machine_info()
    print(f"date {info['date']}; {info['nproc']} cores, {info['cpu']}; {info['platform']}; "
          f"load average {info['load']}; python {info['python']}, numpy {info['numpy']}, "
          f"sympy {info['sympy']}, numba {info['numba']}; C compiler "
          f"{_compiler_version()}", flush=True)
    if args.opt_levels:
        opt_levels(args)
    else:
        build_cases(args)
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

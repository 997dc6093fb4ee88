"""Symbolic build of multibody models: time and generated size, against a baseline source tree.

Measures, for compass_walker, compliant_leg_walker and the planar N-link pendulum chains of
tests/validation/multibody_cases.py: the time of ``porthamiltonian.compiler.symbolic`` (model ->
state equations, the multibody's build included) and of code generation (``codegen.program``:
cse, Jacobian, printed by ``printers.python_source``; ``codegen.generate`` in older trees), and
the generated Python module's size in operations (arithmetic, unary, call and
augmented-assignment nodes of its syntax tree) and bytes. ``gchainN`` are the chains about
random 3D axes; ``:kernel`` / ``:symbolic`` after a chain's name sets its Multibody's formulation.
(The code generator's entry point is ``codegen.program`` printed by ``printers.python_source``;
trees from before the printers, whose ``codegen.generate`` did both, are no longer supported as
baselines.) Every measurement runs
in a fresh interpreter (no sympy cache carried over; imports not timed); when a baseline tree is
given, its runs and this tree's alternate (interleaved), and the table gives medians and the
ratio baseline / this. The load average is printed before and after: the machine is shared.

Run::

    python benchmarks/bench_multibody_build.py                       # this tree only, 3 runs
    mkdir /tmp/old && git archive 340043a | tar -x -C /tmp/old       # the entrywise formulation
    python benchmarks/bench_multibody_build.py --baseline /tmp/old --repeats 3 \\
        --models compass_walker,compliant_leg_walker,chain10,chain20
    python benchmarks/bench_multibody_build.py --models chain2,chain5,chain10,chain20,chain40 --repeats 1

Sizes and the growth exponents log(size(2N)/size(N))/log 2 of the chains are printed too
(tests/validation/test_multibody_size.py asserts the exponent for N = 10 -> 20).
"""
from __future__ import annotations

import argparse
import itertools
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from machine import machine_info

ROOT = Path(__file__).resolve().parent.parent

CHILD = r"""
import ast, json, sys, time
sys.path.insert(0, {cases!r})
from multibody_cases import chain_model
from porthamiltonian import io
from porthamiltonian.compiler import symbolic
from porthamiltonian.compiler.codegen import program
from porthamiltonian.compiler.printers import python_source
def generate(sym):
    return python_source(program(sym))
spec = {spec!r}
if spec.startswith(("chain", "gchain")):
    from multibody_cases import generic_chain_model, with_formulation
    name, _, formulation = spec.partition(":")
    model = (generic_chain_model if name.startswith("g") else chain_model)(int(name.lstrip("gchain")))
    model = with_formulation(model, formulation) if formulation else model
else:
    model = io.load(spec)
t0 = time.perf_counter()
sym = symbolic(model)
t1 = time.perf_counter()
source = generate(sym)
t2 = time.perf_counter()
kinds = (ast.BinOp, ast.UnaryOp, ast.Call, ast.AugAssign)
ops = sum(isinstance(n, kinds) for n in ast.walk(ast.parse(source)))
print(json.dumps({{"symbolic": t1 - t0, "generate": t2 - t1, "ops": ops,
                  "bytes": len(source.encode())}}))
"""


def run(tree: Path, spec: str, timeout: float) -> dict:
    code = CHILD.format(cases=str(ROOT / "tests" / "validation"), spec=spec)
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "PYTHONPATH": str(tree), "PORTHAMILTONIAN_CACHE": cache}
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             env=env, timeout=timeout, cwd=str(tree), check=False)
    if out.returncode != 0:
        raise RuntimeError(f"{spec} in {tree}: {out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--models", default="compass_walker,compliant_leg_walker,chain2,chain5,"
                        "chain10,chain20,chain40")
    parser.add_argument("--baseline", type=Path, default=None,
                        help="a source tree to compare with (e.g. the pre-recursive commit)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--timeout", type=float, default=1800.0)
    args = parser.parse_args()
    info = machine_info()
    print(f"date {info['date']}; {info['nproc']} cores, {info['cpu']}; {info['platform']}; "
          f"Python {info['python']}, sympy {info['sympy']}; load average {info['load']}")
    trees = {"this": ROOT} | ({"baseline": args.baseline} if args.baseline else {})
    results: dict[str, dict[str, list[dict]]] = {t: {} for t in trees}
    for spec in args.models.split(","):
        for _ in range(args.repeats):
            for name, tree in trees.items():                 # interleaved
                results[name].setdefault(spec, []).append(run(tree, spec, args.timeout))
        row = []
        for name in trees:
            runs = results[name][spec]
            sym = statistics.median(r["symbolic"] for r in runs)
            gen = statistics.median(r["generate"] for r in runs)
            row.append(f"{name}: symbolic {sym:6.2f} s + generate {gen:6.2f} s = {sym + gen:6.2f} s, "
                       f"{runs[0]['ops']} ops, {runs[0]['bytes'] / 1e3:.0f} kB")
        if args.baseline:
            this = statistics.median(r["symbolic"] + r["generate"] for r in results["this"][spec])
            base = statistics.median(r["symbolic"] + r["generate"]
                                     for r in results["baseline"][spec])
            row.append(f"ratio baseline/this {base / this:.2f}")
        print(f"{spec:22s} " + " | ".join(row), flush=True)
    for name in trees:
        chains = sorted((int(s[5:]), r[0]) for s, r in results[name].items()
                        if s.startswith("chain") and ":" not in s)
        for (n1, r1), (n2, r2) in itertools.pairwise(chains):
            e_ops = math.log(r2["ops"] / r1["ops"]) / math.log(n2 / n1)
            e_bytes = math.log(r2["bytes"] / r1["bytes"]) / math.log(n2 / n1)
            print(f"{name}: growth exponent N = {n1} -> {n2}: operations {e_ops:.2f}, "
                  f"bytes {e_bytes:.2f}")
    print(f"load average at the end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()

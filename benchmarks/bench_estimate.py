"""Calibration of porthamiltonian/compiler/estimate.py: the real cost of building multibody chains
beside what the estimate predicts before any work.

For each case (``chainN``: the planar N-link pendulum of tests/validation/multibody_cases.py;
``gchainN``: N links about random 3D axes; ``:kernel`` / ``:symbolic`` after the name sets the
Multibody's formulation, default auto), in a fresh interpreter with an empty cache: the C back
end's cold build (``compile_model``), the generated C body's bytes, the build's wall time, the
process's CPU time (from before the model is made to the library loaded, imports excluded) and
its children's (the C compiler: the model's unit and, cold, the one-time objects of the kernel
and the integration loops), the C compiler's peak resident memory (the largest child), and the
estimate's formulation, code bytes, memory and seconds (compared with the CPU of process and
compiler) with their ratios to the measured, and the time the estimate itself took.

Run::

    python benchmarks/bench_estimate.py --cases chain10,chain20,chain40,chain60,gchain10,gchain20
    python benchmarks/bench_estimate.py --cases chain10:symbolic,chain20:symbolic,chain40:symbolic
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from machine import machine_info

ROOT = Path(__file__).resolve().parent.parent

CHILD = r"""
import json, resource, sys, time
sys.path.insert(0, {cases!r})
from multibody_cases import chain_model, generic_chain_model, with_formulation
from porthamiltonian import compile_model
from porthamiltonian.compiler import estimate
spec = {spec!r}
name, _, formulation = spec.partition(":")
t0, c0 = time.perf_counter(), time.process_time()
model = (generic_chain_model if name.startswith("g") else chain_model)(int(name.lstrip("gchain")))
model = with_formulation(model, formulation) if formulation else model
description = model.freeze()
cost = estimate.estimate(description)
t1 = time.perf_counter()
compiled = compile_model(description, backend="c")
t2, c2 = time.perf_counter(), time.process_time()
kids = resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({{"estimate_s": t1 - t0, "wall": t2 - t0, "cpu": c2 - c0,
                  "cc_cpu": kids.ru_utime + kids.ru_stime, "cc_peak": kids.ru_maxrss * 1024,
                  "c_bytes": len(compiled.c_source.encode()), "kernel": bool(compiled.meta.kernels),
                  "est": {{"kernel": cost.kernel, "bytes": cost.code_bytes,
                          "memory": cost.memory_bytes, "seconds": cost.seconds}}}}))
"""


def run(spec: str, cache: str, timeout: float) -> dict:
    code = CHILD.format(cases=str(ROOT / "tests" / "validation"), spec=spec)
    env = {**os.environ, "PORTHAMILTONIAN_CACHE": cache, "PORTHAMILTONIAN_QUIET": "1",
           "PORTHAMILTONIAN_MAX_CODE_MB": "0"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         timeout=timeout, cwd=str(ROOT), check=False)
    if out.returncode != 0:
        raise SystemExit(f"{spec}: failed\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", default="chain10,chain20,chain40,chain60,gchain10,gchain20")
    parser.add_argument("--timeout", type=float, default=1800.0)
    args = parser.parse_args(argv)
    print(machine_info())
    print(f"load before: {os.getloadavg()}")
    head = (f"{'case':18} {'kernel':>6} {'C kB':>7} {'est kB':>7} {'ratio':>5} | {'wall s':>6} "
            f"{'cpu s':>6} {'cc s':>6} {'est s':>6} {'ratio':>5} | {'cc MB':>6} {'est MB':>6} "
            f"{'est t':>5}")
    print(head)
    for spec in args.cases.split(","):
        with tempfile.TemporaryDirectory() as cache:
            os.chmod(cache, 0o700)
            r = run(spec, cache, args.timeout)
        est = r["est"]
        total = r["cpu"] + r["cc_cpu"]
        print(f"{spec:18} {r['kernel']!s:>6} {r['c_bytes'] / 1e3:7.0f} {est['bytes'] / 1e3:7.0f} "
              f"{est['bytes'] / r['c_bytes']:5.2f} | {r['wall']:6.1f} {r['cpu']:6.1f} "
              f"{r['cc_cpu']:6.1f} {est['seconds']:6.1f} {est['seconds'] / total:5.2f} | "
              f"{r['cc_peak'] / 1e6:6.0f} {est['memory'] / 1e6:6.0f} {r['estimate_s']:5.2f}"
              + ("" if est["kernel"] == r["kernel"] else "  (estimate's formulation differs)"))
    print(f"load after: {os.getloadavg()}")


if __name__ == "__main__":
    main()

"""Benchmark of FMU export: the time to write an FMU of a compiled model, the first in a fresh
compiled-model cache and the ones after it, this tree against another (``--baseline DIR``).

Each round runs, per model and tree, a fresh subprocess with an empty ``$PORTHAMILTONIAN_CACHE``:
it compiles the model on the C back end (not timed), then exports it ``--exports`` times
(FMI 2.0, model exchange and co-simulation), timing each export's wall time and the CPU time
of the process and its children (the C compiler). The first export is the one a user of a new
cache waits for; the later ones reuse what the first left in the cache (the integration loops'
object: porthamiltonian.compiler.fmu_objects). Rounds interleave the trees; the table gives
medians over the rounds (later exports: the median of all of them) and the binary's size.

Models: mass_spring_damper (2 states), bouncing_ball (Hunt–Crossley contact, an event) and
heavy_top with ``formulation = "kernel"`` (the multibody kernel's object linked too).

Run::

    python benchmarks/bench_fmu_export.py --rounds 5
    mkdir /tmp/main && git archive <commit> | tar -x -C /tmp/main
    python benchmarks/bench_fmu_export.py --rounds 5 --baseline /tmp/main
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))
MODELS = ("mass_spring_damper", "bouncing_ball", "heavy_top:kernel")


def _cpu() -> float:
    own, children = (resource.getrusage(w) for w in (resource.RUSAGE_SELF,
                                                      resource.RUSAGE_CHILDREN))
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def child(case: str, exports: int) -> None:
    """Compile ``case`` (``name`` or ``name:kernel``) on C, export it ``exports`` times; one
    JSON line: the exports' wall and CPU seconds, the binary's bytes."""
    from porthamiltonian import compile_model, io

    name, _, formulation = case.partition(":")
    data = io.model_to_dict(io.load(name))
    if formulation:
        data["components"]["top"]["formulation"] = formulation
    model = compile_model(io.model_from_dict(data), backend="c")
    walls, cpus = [], []
    with tempfile.TemporaryDirectory() as folder:
        for i in range(exports):
            c0, t0 = _cpu(), time.perf_counter()
            path = model.export_fmu(Path(folder) / f"m{i}.fmu", fmi=2)
            walls.append(time.perf_counter() - t0)
            cpus.append(_cpu() - c0)
        with zipfile.ZipFile(path) as zf:
            size = max(i.file_size for i in zf.infolist() if i.filename.startswith("binaries/"))
    print(json.dumps({"wall": walls, "cpu": cpus, "size": size}))


def run(tree: Path, case: str, exports: int) -> dict:
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, PORTHAMILTONIAN_CACHE=cache, PORTHAMILTONIAN_QUIET="1",
                   PYTHONPATH=str(tree))
        out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--child", case,
                              "--exports", str(exports)], env=env, capture_output=True,
                             text=True, check=True, cwd=str(tree))
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--exports", type=int, default=4, help="exports per process")
    parser.add_argument("--baseline", type=Path, help="another source tree, interleaved")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child, args.exports)
        return
    from machine import machine_info

    print(json.dumps(machine_info()))
    trees = {"this": ROOT, **({"baseline": args.baseline.resolve()} if args.baseline else {})}
    results: dict[tuple[str, str], list[dict]] = {}
    loads = []
    for _ in range(args.rounds):
        for case in MODELS:
            for label, tree in trees.items():
                loads.append(os.getloadavg()[0])
                results.setdefault((case, label), []).append(run(tree, case, args.exports))
    print(f"\n## FMU export (medians of {args.rounds} interleaved rounds; load "
          f"{min(loads):.1f}-{max(loads):.1f})\n")
    print("| model | tree | first export: wall [s] | CPU [s] | later exports: wall [s] | "
          "CPU [s] | binary [kB] |")
    print("|---|---|---|---|---|---|---|")
    for (case, label), runs in results.items():
        first_wall = statistics.median(r["wall"][0] for r in runs)
        first_cpu = statistics.median(r["cpu"][0] for r in runs)
        later_wall = statistics.median(w for r in runs for w in r["wall"][1:])
        later_cpu = statistics.median(c for r in runs for c in r["cpu"][1:])
        print(f"| {case} | {label} | {first_wall:.3f} | {first_cpu:.3f} | {later_wall:.3f} | "
              f"{later_cpu:.3f} | {runs[0]['size'] / 1024:.0f} |")


if __name__ == "__main__":
    main()

"""Command line ``walker``: gait analyses of the walker models.

    walker gait MODEL [--set NAME=VALUE ...] [--max-period K] [--fd-step H] [--json]
    walker walk MODEL [--set NAME=VALUE ...] [--steps N] [--json]
    walker step-down MODEL [--set NAME=VALUE ...] [--resolution H] [--h-max H] [--json]
    walker basin MODEL [--set NAME=VALUE ...] [--n N] [--span S] [--json]
    walker gsn MODEL [--set NAME=VALUE ...] [--json]
    walker report [MODEL] [--out DIR] [--set NAME=VALUE ...] [--steps N] [--basin]
    walker reproduce [STUDY ...] [--out DIR] [--quick] [--workers N | --serial | --scheduler ADDR]
    walker list
    walker export MODEL PATH [--set NAME=VALUE ...]

MODEL is a name from ``models/`` (a walker file: a model file with a ``[walker]`` table, see
docs/walkers.md) or a path to such a file; ``export`` writes the walker's file with the given
parameter values. ``--json`` prints
one JSON document (SI units, named fields) on stdout. Exit status: 0 on success (including a
walker that falls or has no gait: those are results), 2 on bad input (unknown model, unknown or
out-of-range parameter), with a message on stderr.
"""
from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence

from porthamiltonian.cli import parse_assignments, run

from . import sweeps
from .gait import analyze_gait, walk
from .results import to_json
from .robustness import basin, gait_sensitivity_norm, step_down
from .walkers import available_walkers, load_walker, save_walker


def _fmt(value) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.10g}"
    return str(value)


def cmd_gait(args) -> int:
    walker = load_walker(args.model, parse_assignments(args.set), backend=args.backend)
    result = analyze_gait(walker, max_period=args.max_period, fd_step=args.fd_step,
                          n_iterate=args.iterate)
    if args.json:
        print(result.to_json())
        return 0
    d = result.to_dict()
    print(f"{walker.name}: {d['status']} ({d['message']})")
    if d["status"] == "periodic":
        print(f"  period {d['period_steps']} step(s), {'stable' if d['stable'] else 'UNSTABLE'}")
        print("  fixed point on the Poincaré section (heel strike; rigid walkers: just after the "
              "impact, compliant walkers: at touchdown, before it):")
        for name, value in d["fixed_point"].items():
            print(f"    {name:20s} {_fmt(value)}")
        print("  Floquet multipliers (error estimate "
              f"{_fmt(d['multiplier_error'])}):")
        for m in d["floquet_multipliers"]:
            print(f"    {m['re']: .10f} {m['im']:+.10f}i   |λ| = {abs(complex(m['re'], m['im'])):.10f}")
    elif d["status"] == "fell":
        print(f"  fell during step {d['fell_at_step']} ({d['fall_reason']})")
    if d["last_iterate"]:
        print("  last iterate:", ", ".join(f"{k} = {_fmt(v)}" for k, v in d["last_iterate"].items()))
    for key in ("step_period", "step_length", "speed", "energy_dissipated_per_step",
                "potential_released_per_step", "max_theta", "max_phi", "cost_of_transport"):
        print(f"  {key:30s} {_fmt(d[key])}")
    return 0


def cmd_walk(args) -> int:
    walker = load_walker(args.model, parse_assignments(args.set), backend=args.backend)
    result = walk(walker, None, args.steps)
    if args.json:
        print(result.to_json())
        return 0
    print(f"{walker.name}: {result.steps_taken} steps" + (f", fell ({result.fall_reason})"
                                                          if result.fell else ""))
    for k, s in enumerate(result.steps, 1):
        print(f"  step {k:3d}: {s['status']:5s} T = {_fmt(s['duration'])}  length = "
              f"{_fmt(s['step_length'])}  dissipated = {_fmt(s['energy_dissipated'])}")
    print(f"  dissipated {result.energy_dissipated:.10g} J, potential released "
          f"{result.potential_released:.10g} J, max |energy residual| "
          f"{result.max_energy_residual:.3e} J (relative {result.relative_energy_residual:.3e})")
    return 0


def _progress(args, label: str):
    """A per-case progress line on stderr (stdout keeps the JSON document clean)."""
    if args.quiet:
        return None
    count = [0]

    def report(rec: dict) -> None:
        count[0] += 1
        detail = ", ".join(f"{k} = {_fmt(v)}" for k, v in rec.items() if k in ("h", "theta", "theta_dot"))
        print(f"{label} case {count[0]}: {detail}: {rec['status']}", file=sys.stderr, flush=True)
    return report


def cmd_step_down(args) -> int:
    walker = load_walker(args.model, parse_assignments(args.set), backend=args.backend)
    result = step_down(walker, resolution=args.resolution, h_max=args.h_max,
                       progress=_progress(args, "step-down"))
    if args.json:
        print(result.to_json())
        return 0
    print(f"{walker.name}: {result.message}")
    for c in result.cases:
        print(f"  h = {c['h'] * 1e3:8.3f} mm  {c['status']:9s} after {c['steps']} steps"
              + (f" ({c['reason']})" if c["reason"] else ""))
    return 0


def cmd_basin(args) -> int:
    walker = load_walker(args.model, parse_assignments(args.set), backend=args.backend)
    result = basin(walker, n=args.n, span=args.span, progress=_progress(args, "basin"))
    if args.json:
        print(result.to_json())
        return 0
    print(f"{walker.name}: {result.message}; radius {result.radius:.4g} (scaled units: theta/"
          f"{result.theta_scale:g}, theta_dot/{result.theta_dot_scale:g})")
    if result.status == "ok":
        mark = {"converged": "*", "fell": ".", "wandered": "~", "invalid": "x"}
        print("  rows: theta_dot (top = largest); columns: theta (left = smallest)")
        for j in reversed(range(len(result.theta_dot))):
            print(f"  {result.theta_dot[j]: .4f} " + "".join(mark[result.outcome[i][j]]
                                                          for i in range(len(result.theta))))
    return 0


def cmd_gsn(args) -> int:
    walker = load_walker(args.model, parse_assignments(args.set), backend=args.backend)
    result = gait_sensitivity_norm(walker)
    if args.json:
        print(to_json(result))
        return 0
    print(f"{walker.name}: {result.message}; error estimate {result.error:.2g}")
    for k, v in result.by_indicator.items():
        print(f"  {k:15s} {v:.6g}")
    return 0


def cmd_report(args) -> int:
    from .report import write_report
    walker = load_walker(args.model, parse_assignments(args.set), backend=args.backend)
    log = None if args.quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    result = write_report(walker, args.out, n_steps=args.steps, with_basin=args.basin,
                          with_step_down=not args.no_step_down, log=log)
    print(f"wrote {result.out / 'report.html'} ({len(result.files)} files, {result.seconds:.0f} s)")
    return 0


def cmd_reproduce(args) -> int:
    from .studies import STUDIES, run_studies
    if args.list:
        for study in STUDIES.values():
            print(f"{study.name:22s} {study.thesis:28s} {study.title}")
        return 0
    log = (lambda msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    options = {"quick": args.quick, "workers": args.workers, "serial": args.serial, "log": log,
               "progress": "none" if args.quiet else "auto"}
    client = None
    if args.scheduler:
        from distributed import Client
        client = Client(args.scheduler)
        options["executor"] = client.get_executor()
    try:
        summaries = run_studies(args.studies, args.out, **options)
    finally:
        if client is not None:
            client.close()
    for name, summary in summaries.items():
        if args.studies and name not in args.studies:
            continue
        print(f"{name} ({summary['thesis']}): {summary['seconds']:.0f} s")
        for row in summary.get("rows", []):
            dev = "" if row["deviation"] is None else f"  ({100 * row['deviation']:+.1f} %)"
            print(f"  {row['quantity']:45s} ours {_fmt(row['ours']):>14s}  thesis "
                  f"{_fmt(row['thesis']):>10s} {row['unit']}{dev}")
    print(f"results in {args.out}")
    return 0


def cmd_list(args) -> int:
    names = available_walkers()
    if args.json:
        print(json.dumps({"models": names}))
    else:
        print("walker models:", ", ".join(names) or "none")
    return 0


def cmd_export(args) -> int:
    walker = load_walker(args.model, parse_assignments(args.set))
    path = save_walker(walker, args.path, f"Walker file written by `walker export {args.model}` "
                       "(docs/walkers.md).")
    print(f"wrote {path}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="walker", description=__doc__.splitlines()[0])
    parser.add_argument("--backend", default=None,
                        help="a back end name or auto (default: the walker file's own, "
                             "[walker.integration] backend)")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("gait", help="find the gait: fixed point, Floquet multipliers, metrics")
    p.add_argument("model")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    p.add_argument("--max-period", type=int, default=8)
    p.add_argument("--fd-step", type=float, default=1e-4,
                   help="perturbation size of the Floquet Jacobian (the thesis used 0.001)")
    p.add_argument("--iterate", type=int, default=200,
                   help="steps iterated for period detection when period 1 fails")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_gait)
    p = sub.add_parser("walk", help="walk N steps from the initial guess; per-step records and "
                                    "the energy ledger")
    p.add_argument("model")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    p.add_argument("--steps", type=int, default=20)
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_walk)
    p = sub.add_parser("step-down", help="largest single drop of the surface survived, scanning "
                                         "upward (thesis 2.6)")
    p.add_argument("model")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    p.add_argument("--resolution", type=float, default=None,
                   help="height grid (m; default 2e-4 of the leg length)")
    p.add_argument("--h-max", type=float, default=None, help="largest height tried (m)")
    p.add_argument("--json", action="store_true")
    p.add_argument("--quiet", action="store_true", help="no per-case lines on stderr")
    p.set_defaults(func=cmd_step_down)
    p = sub.add_parser("basin", help="basin of attraction on a scaled (theta, theta_dot) grid")
    p.add_argument("model")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    p.add_argument("--n", type=int, default=11, help="grid points per axis")
    p.add_argument("--span", type=float, default=0.1,
                   help="half-width of the grid in scaled units (theta/0.4, theta_dot/0.8)")
    p.add_argument("--json", action="store_true")
    p.add_argument("--quiet", action="store_true", help="no per-case lines on stderr")
    p.set_defaults(func=cmd_basin)
    p = sub.add_parser("gsn", help="Gait Sensitivity Norm for a step-down disturbance")
    p.add_argument("model")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_gsn)
    p = sub.add_parser("report", help="the main job: HTML report (figures, GIF, JSON) of a walker")
    p.add_argument("model", nargs="?", default="compass_walker",
                   help="walker model (default: compass_walker, the thesis's nominal walker)")
    p.add_argument("--out", default="report", help="output directory (default: ./report)")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    p.add_argument("--steps", type=int, default=6, help="steps of the recorded walk")
    p.add_argument("--basin", action="store_true", help="also the basin of attraction (slow)")
    p.add_argument("--no-step-down", action="store_true", help="skip the step-down test")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.set_defaults(func=cmd_report)
    p = sub.add_parser("reproduce", help="rebuild the thesis's tables and figures (named studies)")
    p.add_argument("studies", nargs="*", help="studies to run (default: all; see --list)")
    p.add_argument("--out", default="reproduction", help="output directory")
    p.add_argument("--quick", action="store_true", help="coarse grids (minutes, not hours)")
    p.add_argument("--workers", type=int, default=None, help="process-pool size (default: cores)")
    p.add_argument("--serial", action="store_true", help="run the sweeps in this process")
    p.add_argument("--scheduler", default=None, help="dask.distributed scheduler address")
    p.add_argument("--list", action="store_true", help="list the studies and exit")
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(func=cmd_reproduce)
    sweeps.add_parser(sub)
    p = sub.add_parser("list", help="the walker model files")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_list)
    p = sub.add_parser("export", help="write a walker's model file (with --set values)")
    p.add_argument("model")
    p.add_argument("path")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    p.set_defaults(func=cmd_export)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    return run(build_parser(), argv)


if __name__ == "__main__":
    sys.exit(main())

"""Command line ``walker``: gait analyses of the walker models.

    walker gait MODEL [--set NAME=VALUE ...] [--guess FILE] [--max-period K]
                [--jacobian variational|fd] [--fd-step H] [--gradient NAMES] [--json]
    walker continue MODEL --param NAME=START:STOP [--set NAME=VALUE ...] [--guess FILE]
                    [--doublings N] [--jacobian variational|fd] [--json] [--out DIR]
    walker walk MODEL [--set NAME=VALUE ...] [--steps N] [--time-limit S] [--json]
    walker step-down MODEL [--set NAME=VALUE ...] [--resolution H] [--h-max H] [--time-limit S]
        [--json]
    walker basin MODEL [--set NAME=VALUE ...] [--n N] [--span S] [--time-limit S] [--json]
    walker gsn MODEL [--set NAME=VALUE ...] [--time-limit S] [--json]
    walker report [MODEL] [--out DIR] [--set NAME=VALUE ...] [--steps N] [--basin] [--view3d]
                  [--continuation NAME=START:STOP]
    walker sweep MODEL --grid NAME=SPEC ... --out FILE [--analysis NAME] [--option NAME=VALUE]
    walker reproduce [STUDY ...] [--out DIR] [--quick] [--workers N | --serial | --scheduler ADDR]
    walker list
    walker export MODEL PATH [--set NAME=VALUE ...] [--force]
    walker export-fmu MODEL --out FILE [--fmi 2|3] [--kind me|cs|both] [--steps N] [--set ...]
    walker optimize MODEL --vary NAMES --objective QUANTITY [--maximize] [--constraint C ...]
                    [--bounds NAME=LOW:HIGH ...] [--method SLSQP|trust-constr] [--record FILE]
                    [--step-down none|ends|path] [--max-evaluations N] [--formulation F]
                    [--set ...] [--json]

MODEL is a walker name from ``models/`` (a walker file: a model file with a ``[walker]`` table, see
docs/walkers.md; ``walker list`` names them) or a path to such a file; ``export`` writes the
walker's file with the given parameter values, ``export-fmu`` the walker with its mode machine as
an FMU (docs/fmu.md). Every option may be given anywhere after its
command (``--backend`` also before it). ``--json`` prints one JSON document (SI units, named
fields) on stdout; progress goes to stderr. Exit status: 0 on success (including a walker that
falls or has no gait: those are results), 2 on bad input (unknown model, unknown or
out-of-range parameter), with a message on stderr.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from porthamiltonian import userfiles
from porthamiltonian.batch.errors import SweepError
from porthamiltonian.batch.progress import activity
from porthamiltonian.errors import ModelError, ModelFileError
from porthamiltonian.interfaces import io as ph_io
from porthamiltonian.interfaces.cli import (
    BACKEND_OPTION,
    JSON_OPTION,
    QUIET_OPTION,
    SET_OPTION,
    add_fmu_parser,
    add_sweep_parser,
    at_least,
    backend_option,
    file_name,
    format_value,
    input_name,
    leaving,
    not_negative,
    parse_assignments,
    positive,
    rules,
    run,
    run_sweep,
)

from .analyses.gait import (
    GAIT_QUANTITIES,
    TIME_LIMIT,
    WALK_BLOCK,
    GaitResult,
    analyze_gait,
    gait_start,
    section_guess,
    walk,
)
from .analyses.series import MAX_SERIES_STEPS, check_series_steps
from .core.files import available_walkers, load_walker

# Each command imports the analyses it runs beyond the gait's (and, for text output, the report's
# labels): a warm `walker gait --json` loads neither the optimizer, the continuation, the
# gradients, the sweeps, the FMU export nor the report (tests/walkers/test_warm_start.py checks).
if TYPE_CHECKING:
    from .analyses.continuation import ContinuationResult
    from .core.walker import HybridWalker


def _fmt(value: Any) -> str:
    """A value as the walker's tables show it (10 significant digits)."""
    return format_value(value, 10)


def check_walker_name(model: str) -> str:
    """``model`` if it can name a walker: a path, a walker file of models/, or a model of models/
    (whose loading then says it is not a walker file); else a ModelFileError listing the walker
    models, with the closest one suggested."""
    if ph_io.is_path(model) or model in ph_io.available_models():
        return model                   # (loading a model that is no walker file says so)
    import difflib

    walkers = available_walkers()
    close = difflib.get_close_matches(model, walkers, n=1, cutoff=0.6)
    hint = f" (did you mean {close[0]}?)" if close else ""
    raise ModelFileError(f"no walker model called {model!r}{hint}; walker models: "
                         f"{', '.join(walkers) or 'none'}; or give the path to a walker file")


def _walker(args: argparse.Namespace) -> HybridWalker:
    """The walker named by ``args.model`` with the ``--set`` values and ``--backend``."""
    return load_walker(check_walker_name(args.model), parse_assignments(args.set),
                       backend=args.backend)


#: the largest guess file read (bytes): a `walker gait --json` result is a few kB
MAX_GUESS_BYTES = 10_000_000


def _read_guess(path: str) -> dict:
    """A previous ``walker gait --json`` result (the ``--guess`` option): a JSON object."""
    text = ph_io.read_text(Path(path), limit=MAX_GUESS_BYTES, label=f"--guess {path}",
                           kind="gait result", language="JSON")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise ModelFileError(f"--guess {path}: not a JSON document (line {err.lineno}: "
                             f"{err.msg}); give the output of `walker gait ... --json`") from None
    except RecursionError:
        raise ModelFileError(f"--guess {path}: arrays or objects are nested too deeply for a "
                             "gait result; give the output of `walker gait ... --json`") from None
    if not isinstance(data, dict):
        raise ModelFileError(f"--guess {path}: expected a JSON object (a `walker gait --json` "
                             "result)")
    return data


def _walker_and_guess(args: argparse.Namespace) -> tuple[HybridWalker, np.ndarray | None]:
    """The walker with the ``--set`` parameter values, and the section state that the ``--set``
    section coordinates and ``--guess`` file make (None if neither is given)."""
    values = parse_assignments(args.set)
    previous = _read_guess(args.guess) if getattr(args, "guess", None) is not None else None
    walker = load_walker(check_walker_name(args.model), None, backend=args.backend)
    coords = (set(walker.section) | set(walker.thesis_section)) - set(walker.parameters)
    unknown = [k for k in values if k not in coords and k not in walker.parameters]
    if unknown:
        raise ModelFileError(f"{walker.name}: --set {', '.join(unknown)}: neither a parameter "
                             f"nor a section coordinate; parameters: "
                             f"{', '.join(walker.parameters)}; section coordinates: "
                             f"{', '.join(walker.section)} (thesis: "
                             f"{', '.join(walker.thesis_section)})")
    params = {k: v for k, v in values.items() if k not in coords}
    named = {k: v for k, v in values.items() if k in coords}
    walker = walker.with_parameters(**params) if params else walker
    return walker, section_guess(walker, previous, named)


#: the default time limit of `walker continue` and `walker report --continuation` (s)
CONTINUATION_TIME_LIMIT = 3600.0


def _with_unit(walker: HybridWalker, key: str, value: Any) -> str:
    """``value`` and the unit of quantity ``key`` of ``walker`` ("nondim." in a nondimensional
    model; nothing for a ratio)."""
    from .report.labels import describe, is_nondimensional, shown_unit

    unit = describe(walker, key).unit
    shown = "" if unit == "1" else shown_unit(unit, is_nondimensional(walker))
    return f"{_fmt(value)} {shown}".rstrip()


def cmd_gait(args: argparse.Namespace) -> int:
    walker, guess = _walker_and_guess(args)
    names = None
    if args.gradient is not None:           # --gradient "": no names, refused by check_names
        from .analyses.gradients import gait_gradient
        from .core.gradients import check_names
        names = check_names(walker, _names(args.gradient))
    with activity(f"gait {walker.name}", enabled=not args.quiet) as shown:
        result = analyze_gait(walker, guess, max_period=args.max_period, fd_step=args.fd_step,
                              n_iterate=args.iterate, jacobian=args.jacobian,
                              continuation=not args.no_continuation,
                              log=None if args.quiet else shown.write,
                              time_limit=args.time_limit or None)
        if names and result.status == "periodic":
            z = np.array([result.fixed_point[k] for k in walker.section], dtype=float)
            grad = gait_gradient(walker, z, names, result.period_steps)
            if not grad.fell:
                result.gradients, result.gradient_errors = grad.gradients, grad.errors
                result.fixed_point_gradient = grad.fixed_point_gradient
    if args.json:
        print(result.to_json())
        return 0
    from .report.page import multiplier_cells

    d = result.to_dict()
    print(f"{walker.name}: {d['outcome'].replace('_', ' ')} ({d['message']})")
    if d["status"] == "periodic":
        certain = "" if d["stability_certain"] else " (the error bounds allow either verdict)"
        print(f"  period {d['period_steps']} step(s), "
              f"{'stable' if d['stable'] else 'UNSTABLE'}{certain}")
        print("  fixed point on the Poincaré section (heel strike; rigid walkers: just after the "
              "impact, compliant walkers: at touchdown, before it):")
        for name, value in d["fixed_point"].items():
            print(f"    {name:20s} {_with_unit(walker, name, value)}")
        print("  Floquet multipliers (± error bound), to the digits their error bounds support:")
        for m, e in zip(result.floquet_multipliers, result.multiplier_errors):
            (value, modulus), = multiplier_cells([m], e)[0]
            print(f"    {value:28s} |λ| {modulus} ± {e:.1g}")
        if len(d["orbits"]) > 1:
            print("  orbits found:")
            for o in d["orbits"]:
                print(f"    period {o['period_steps']}: max |λ| = {o['max_multiplier']:.6g} "
                      f"({'stable' if o['stable'] else 'unstable'}; {o['found_by']})")
    if d["fell_at_step"] is not None:
        print(f"  from the guess the walker fell during step {d['fell_at_step']} "
              f"({d['fall_reason']})")
    if d["last_iterate"]:
        print("  last iterate:", ", ".join(f"{k} = {_with_unit(walker, k, v)}"
                                           for k, v in d["last_iterate"].items()))
    if d["status"] == "periodic":
        for key in ("step_period", "step_length", "speed", "energy_dissipated_per_step",
                    "potential_released_per_step", "max_theta", "max_phi", "cost_of_transport"):
            print(f"  {key:30s} {_with_unit(walker, key, d[key])}")
    if result.gradients:
        errors = cast(dict, result.gradient_errors)     # set with the gradients
        print("  gradients (exact; the multiplier's ± its error bound):")
        for key, row in result.gradients.items():
            cells = [f"d/d{n} = {v:.8g}" + (f" ± {errors[key][n]:.1g}" if errors[key][n] else "")
                     for n, v in row.items()]
            print(f"    {key:28s} " + ", ".join(cells))
    elif names:
        print("  no gradients: no periodic orbit, or a stride of it fell")
    return 0


def cmd_optimize(args: argparse.Namespace) -> int:
    from .analyses.optimize import optimize_gait, parse_constraint
    from .core.gradients import check_names

    walker, guess = _walker_and_guess(args)
    vary = check_names(walker, _names(args.vary))
    constraints = [parse_constraint(c) for c in args.constraint]
    bounds = {}
    for item in args.bounds:
        name, sep, text = item.partition("=")
        low, sep2, high = text.partition(":")
        try:
            bounds[name.strip()] = (float(low), float(high))
        except ValueError:
            sep2 = ""
        if not (sep and sep2):
            raise ModelError(f"--bounds {item!r}: expected NAME=LOW:HIGH (numbers, inf allowed)")
    log = None if args.quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    result = optimize_gait(walker, vary, args.objective, maximize=args.maximize,
                           constraints=constraints, bounds=bounds, method=args.method,
                           max_evaluations=args.max_evaluations, tol=args.tol,
                           record=args.record, step_down=args.step_down, guess=guess, log=log,
                           formulation=args.formulation)
    if args.json:
        print(result.to_json())
        return 0
    sense = "max" if args.maximize else "min"
    print(f"{walker.name}: {sense} {args.objective} over {', '.join(vary)}"
          + (f" subject to {'; '.join(result.constraints)}" if result.constraints else "")
          + f": {result.message} ({result.iterations} iterations, {result.evaluations} gait "
            f"evaluations, {result.reused} read back, {result.seconds:.0f} s)")
    for n in vary:
        print(f"  {n:20s} {result.start[n]:.8g} -> {result.optimum.get(n, float('nan')):.8g}")
    for key, value in result.values.items():
        print(f"  {key:28s} {_with_unit(walker, key, value)}")
    if result.kkt:
        print(f"  first-order conditions ({result.formulation} problem): |grad L| = "
              f"{result.kkt['gradient_of_lagrangian']:.2g} "
              f"(|grad f| = {result.kkt['gradient']:.2g}, scaled units); active: "
              f"{', '.join(result.kkt['active']) or 'none'}")
    for key, drop in result.step_down.items():
        print(f"  max step-down at the {key:8s} {_fmt(drop)} m")
    return 0 if result.success else 1


def _names(text: str) -> list[str]:
    """Comma-separated parameter names (``--gradient K1,K2``)."""
    return [n.strip() for n in text.split(",") if n.strip()]


def _continuation(walker: HybridWalker, text: str, guess: np.ndarray | None, *,
                  doublings: int = 2, max_points: int = 400, jacobian: str = "variational",
                  log: Callable[[str], None] | None = None,
                  time_limit: float | None = None) -> ContinuationResult:
    """Continue the gait in ``text`` (NAME=START:STOP): the range and parameter are checked
    before any work, the gait at the start found by the full gait search; ``time_limit``
    (s) bounds the continuation."""
    from .analyses.continuation import ParameterPath, continue_gait, parse_range

    name, start, stop = parse_range(text)
    path = ParameterPath.single(walker, name, start, stop)
    z0, period = gait_start(walker, name, start, guess, jacobian=jacobian, log=log)
    return continue_gait(walker, path, guess=z0, period=period, jacobian=jacobian,
                         doublings=doublings, max_points=max_points, log=log,
                         time_limit=time_limit)


def cmd_continue(args: argparse.Namespace) -> int:
    walker, guess = _walker_and_guess(args)
    log = None if args.quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    # before the continuation: a bad --out loses no work
    out = userfiles.make_folder(args.out) if args.out else None
    result = _continuation(walker, args.param, guess, doublings=args.doublings,
                           max_points=args.max_points, jacobian=args.jacobian, log=log,
                           time_limit=args.time_limit or None)
    if out is not None:
        (out / "continuation.json").write_text(result.to_json())
        from .report.figures import fig_bifurcation
        fig_bifurcation(result, out / "bifurcation_diagram.png")
    if args.json:
        print(result.to_json())
        return 0
    label, unit = result.path.label, result.path.unit
    print(f"{walker.name}: continuation in {label} ({unit}) from {result.path.start:g} to "
          f"{result.path.stop:g}: {result.message} ({result.seconds:.0f} s)")
    for i, br in enumerate(result.branches):
        print(f"branch {i}: period {br.period}, {len(br.points)} points; from {br.origin}; "
              f"{br.end}")
        print(f"  {label:>14s}  max |λ|    stable  {'  '.join(walker.thesis_section)}")
        for p in br.points:
            w = walker.to_thesis(p.z)
            print(f"  {p.mu:14.10g}  {p.max_modulus:9.6f}  {'yes' if p.stable else 'no ':3s}     "
                  + "  ".join(f"{v: .6g}" for v in w))
    if result.bifurcations:
        print("bifurcations:")
        for b in result.bifurcations:
            print(f"  {b.kind:15s} branch {b.branch} (period {b.period}): {label} = "
                  f"{b.mu:.12g} ± {b.mu_error:.1g}, multiplier {b.multiplier:.8f}"
                  + ("" if b.child is None else
                     f"; joins period-{2 * b.period} branch {b.child} (followed already)"
                     if b.joins else f"; period-{2 * b.period} branch {b.child}"))
    if out is not None:
        print(f"wrote {out / 'continuation.json'} and bifurcation_diagram.png")
    return 0


def cmd_walk(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    walker = _walker(args)
    with activity(f"walk {walker.name}", enabled=not args.quiet):
        result = walk(walker, None, args.steps, deadline=start + (args.time_limit or math.inf))
    if args.json:
        print(result.to_json())
        return 0
    print(f"{walker.name}: {result.steps_taken} steps" + (f", fell ({result.fall_reason})"
                                                          if result.fell else "")
          + (f", stopped at the time limit ({args.time_limit:g} s; --time-limit)"
             if result.stopped else ""))
    for k, s in enumerate(result.steps, 1):
        if s["status"] == "fell":       # no heel strike: no length or energy of a step (NaN)
            print(f"  step {k:3d}: fell  T = {_fmt(s['duration'])} s")
            continue
        print(f"  step {k:3d}: {s['status']:5s} T = {_fmt(s['duration'])} s  length = "
              f"{_fmt(s['step_length'])} m  dissipated = {_fmt(s['energy_dissipated'])} J")
    if not result.steps:        # stopped before its first block: nothing integrated
        print("  no stride was integrated: no energy ledger")
        return 0
    print(f"  dissipated = {result.energy_dissipated:.10g} J, potential released = "
          f"{result.potential_released:.10g} J, max |energy residual| = "
          f"{result.max_energy_residual:.3e} J (relative {result.relative_energy_residual:.3e})")
    return 0


def _case_lines(args: argparse.Namespace, label: str,
                shown: Any) -> Callable[[dict], None] | None:
    """A per-case line on stderr (stdout keeps the JSON document clean), through ``shown``
    (the activity display); None with --quiet."""
    if args.quiet:
        return None
    count = [0]

    def report(rec: dict) -> None:
        count[0] += 1
        detail = ", ".join(f"{k} = {_fmt(rec[k])} {unit}" for k, unit in
                           (("h", "m"), ("theta", "rad"), ("theta_dot", "rad/s")) if k in rec)
        shown.write(f"{label} case {count[0]}: {detail}: {rec['status']}")
    return report


def _search_limit(p: argparse.ArgumentParser, scan: bool = False) -> None:
    """``--time-limit`` of a study that starts with the gait search (step-down, basin, gsn);
    ``scan``: it bounds the study's scan of cases too (step-down, basin)."""
    what = ("the study after S seconds: the gait search it starts from, then its scan, which "
            "starts no case after S (a case under way ends first)" if scan else
            "the gait search the study starts from after S seconds")
    p.add_argument("--time-limit", type=float, default=TIME_LIMIT, metavar="S",
                   help=f"stop {what} (default {TIME_LIMIT:g}; 0: no limit); without a gait "
                        "the study says so")


def _basin_n(option: str, n: int) -> None:
    """The rule of ``walker basin --n``: at least 2, and a grid the basin accepts
    (:func:`~walker_library.analyses.robustness.check_basin_size`), before the gait search."""
    from .analyses.robustness import check_basin_size

    at_least(2)(option, n)
    check_basin_size(n, option)


def _study_gait(walker: HybridWalker, args: argparse.Namespace) -> GaitResult:
    """The gait a study (step-down, basin, gsn) starts from: the search under --time-limit."""
    return analyze_gait(walker, time_limit=args.time_limit or None)


def _case_study(args: argparse.Namespace, label: str, study: Callable[..., Any],
                **options: Any) -> tuple[HybridWalker, Any] | None:
    """``study(walker, gait, progress=..., deadline=..., **options)`` (step_down, basin) on
    the walker of ``args`` and its gait (the search under --time-limit), the study's cases
    started within --time-limit of the command's start, under the activity display with a
    line per case (_case_lines); with --json its result is printed and None returned, else
    (walker, result) for the command to print."""
    start = time.perf_counter()
    walker = _walker(args)
    with activity(f"{label} {walker.name}", enabled=not args.quiet) as shown:
        result = study(walker, _study_gait(walker, args), progress=_case_lines(args, label, shown),
                       deadline=start + (args.time_limit or math.inf), **options)
    if args.json:
        print(result.to_json())
        return None
    return walker, result


def cmd_step_down(args: argparse.Namespace) -> int:
    from .analyses.robustness import step_down

    done = _case_study(args, "step-down", step_down, resolution=args.resolution,
                       h_max=args.h_max)
    if done is None:
        return 0
    walker, result = done
    print(f"{walker.name}: {result.message}")
    for c in result.cases:
        print(f"  h = {c['h'] * 1e3:8.3f} mm  {c['status']:9s} after {c['steps']} steps"
              + (f" ({c['reason']})" if c["reason"] else ""))
    return 0


def cmd_basin(args: argparse.Namespace) -> int:
    from .analyses.robustness import basin

    done = _case_study(args, "basin", basin, n=args.n, span=args.span)
    if done is None:
        return 0
    walker, result = done
    if result.status != "ok":            # no gait: no radius (NaN) to show
        print(f"{walker.name}: {result.message}")
        return 0
    print(f"{walker.name}: {result.message}; radius {result.radius:.4g} (scaled units: theta/"
          f"{result.theta_scale:g} rad, theta_dot/{result.theta_dot_scale:g} rad/s)")
    mark = {"converged": "*", "fell": ".", "wandered": "~", "invalid": "x", "not_run": " "}
    print("  rows: theta_dot in rad/s (top = largest); columns: theta (left = smallest)")
    for j in reversed(range(len(result.theta_dot))):
        print(f"  {result.theta_dot[j]: .4f} " + "".join(mark[result.outcome[i][j]]
                                                      for i in range(len(result.theta))))
    return 0


def cmd_gsn(args: argparse.Namespace) -> int:
    from .analyses.results import to_json
    from .analyses.robustness import gait_sensitivity_norm

    walker = _walker(args)
    with activity(f"gsn {walker.name}", enabled=not args.quiet):
        result = gait_sensitivity_norm(walker, _study_gait(walker, args))
    if args.json:
        print(to_json(result))
        return 0
    if result.status != "ok":            # no gait: no norm and no error estimate (NaN)
        print(f"{walker.name}: {result.message}")
        return 0
    unit = {"step_period": "s/m", "step_length": "m/m"}
    print(f"{walker.name}: {result.message} (per m of step-down); error estimate "
          f"{result.error:.2g}")
    for k, v in result.by_indicator.items():
        print(f"  {k:15s} {v:.6g} {unit.get(k, '')}".rstrip())
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from .report.writer import write_report
    walker = _walker(args)
    log = None if args.quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    continuation = None
    if args.continuation:
        continuation = _continuation(walker, args.continuation, None, log=log,
                                     time_limit=args.time_limit or None)
    result = write_report(walker, args.out, n_steps=args.steps, with_basin=args.basin,
                          with_step_down=not args.no_step_down, forces=args.forces,
                          view3d=args.view3d, continuation=continuation, log=log)
    print(f"wrote {result.out / 'report.html'} ({len(result.files)} files, {result.seconds:.0f} s)")
    return 0


def _option(pair: str) -> tuple[str, Any]:
    name, sep, value = pair.partition("=")
    if not sep or not name.strip().isidentifier():
        raise SweepError(f"--option takes NAME=VALUE, got {pair!r}")
    try:
        parsed = json.loads(value)
    except json.JSONDecodeError:
        parsed = value
    return name.strip(), parsed


def cmd_sweep(args: argparse.Namespace) -> int:
    from .analyses.cases import get_analysis

    analysis = get_analysis(args.analysis)
    options = dict(_option(p) for p in args.option)
    return run_sweep(args, analysis, {"model": args.model, "backend": args.backend, **options})


def cmd_reproduce(args: argparse.Namespace) -> int:
    from porthamiltonian.batch import open_executor

    from .report.studies import STUDIES, run_studies
    if args.list:
        for study in STUDIES.values():
            print(f"{study.name:22s} {study.thesis:28s} {study.title}")
        return 0
    log = (lambda msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    with open_executor(args.scheduler, args.workers) as executor:
        summaries = run_studies(args.studies, args.out, quick=args.quick, workers=args.workers,
                                serial=args.serial, executor=executor, log=log,
                                progress="none" if args.quiet else "auto")
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


def cmd_list(args: argparse.Namespace) -> int:
    names = available_walkers()
    if args.json:
        print(json.dumps({"models": names}))
    else:
        print("walker models:", ", ".join(names) or "none")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    from .core.files import check_target, save_walker

    check_target(args.path, overwrite=args.force)             # before any work
    walker = load_walker(check_walker_name(args.model), parse_assignments(args.set))
    path = save_walker(walker, args.path, f"Walker file written by `walker export {args.model}` "
                       "(docs/walkers.md).", overwrite=args.force)
    print(f"wrote {path}")
    return 0


def cmd_export_fmu(args: argparse.Namespace) -> int:
    from .core.fmu import export_walker_fmu

    walker = _walker(args)
    path = export_walker_fmu(walker, args.out, fmi=args.fmi, kind=args.kind, steps=args.steps)
    print(f"wrote {path}: walker {walker.name} as an FMI {args.fmi}.0 FMU ({args.kind}); its "
          "heel strikes: outputs walker.heel_strike.count and walker.heel_strike.time")
    return 0


def _guess_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--guess", type=input_name, default=None, metavar="FILE",
                   help="start from the fixed point of a previous `walker gait --json` result "
                        "(--set of a section coordinate, model's or thesis's, changes one value)")
    p.add_argument("--jacobian", choices=("variational", "fd"), default="variational",
                   help="the stride map's Jacobian: exact, from the variational equations with "
                        "saltation matrices (variational, default), or finite differences (fd, "
                        "the cross-check)")


def build_parser() -> argparse.ArgumentParser:
    """The ``walker`` command's parser."""
    from .analyses.cases import ANALYSES

    model_help = "walker model: a name from models/ (walker list) or a path to a walker file"
    parser = argparse.ArgumentParser(prog="walker", description=__doc__.splitlines()[0],
                                     parents=[backend_option(None)])
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    model_argument = argparse.ArgumentParser(add_help=False)
    model_argument.add_argument("model", help=model_help)
    # the analyses' options and their first argument, the walker model
    analysis = [BACKEND_OPTION, SET_OPTION, JSON_OPTION, QUIET_OPTION, model_argument]

    p = sub.add_parser("gait", parents=analysis,
                       help="find the gait: fixed point, Floquet multipliers, metrics")
    p.add_argument("--max-period", type=int, default=8, metavar="K",
                   help="longest period (steps) looked for when period 1 fails (default: 8)")
    p.add_argument("--fd-step", type=float, default=None, metavar="H",
                   help="with --jacobian fd: the largest finite-difference step, relative to "
                        "max(|z_j|, 1e-3) (default: 1e-3); the step kept is chosen per "
                        "coordinate below it, so the result does not depend on it")
    p.add_argument("--iterate", type=int, default=200, metavar="N",
                   help="steps iterated for period detection when period 1 fails (default: 200)")
    _guess_options(p)
    p.add_argument("--no-continuation", action="store_true",
                   help="do not continue the model file's nominal gait to these parameters when "
                        "the guess finds no stable gait")
    p.add_argument("--gradient", default=None, metavar="NAMES",
                   help="also the exact derivatives of the gait's quantities by these "
                        "parameters, comma-separated (e.g. K_leg,slope; JSON: \"gradients\")")
    p.add_argument("--time-limit", type=float, default=TIME_LIMIT, metavar="S",
                   help=f"stop the search after S seconds with what it found (default "
                        f"{TIME_LIMIT:g}; 0: no limit)")
    rules(p, max_period=at_least(1), fd_step=positive, iterate=at_least(1),
          time_limit=not_negative)
    p.set_defaults(func=cmd_gait)

    p = sub.add_parser("optimize", parents=analysis,
                       help="tune parameters for a gait quantity with exact gradients (SLSQP), "
                            "under constraints on others; every gait evaluation recorded")
    p.add_argument("--vary", required=True, metavar="NAMES",
                   help="the parameters to tune, comma-separated (they start from the file's "
                        "or --set values)")
    p.add_argument("--objective", required=True, choices=GAIT_QUANTITIES,
                   help="the gait quantity to minimise (--maximize: maximise)")
    p.add_argument("--maximize", action="store_true", help="maximise the objective")
    p.add_argument("--constraint", action="append", default=[], metavar="QUANTITY<=VALUE",
                   help="an inequality on a gait quantity, e.g. "
                        "'max_multiplier_modulus<=0.6' (repeatable)")
    p.add_argument("--bounds", action="append", default=[], metavar="NAME=LOW:HIGH",
                   help="bounds of a varied parameter (repeatable)")
    p.add_argument("--method", choices=("SLSQP", "trust-constr"), default="SLSQP",
                   help="scipy's optimizer (default: SLSQP)")
    p.add_argument("--max-evaluations", type=int, default=30, metavar="N",
                   help="the optimizer's iteration limit (default: 30)")
    p.add_argument("--tol", type=float, default=1e-6,
                   help="relative tolerance of the optimizer (default: 1e-6)")
    p.add_argument("--record", type=file_name, default=None, metavar="FILE",
                   help="record every gait evaluation in this JSON Lines file (run again: "
                        "evaluations in it are read back, not simulated)")
    p.add_argument("--step-down", choices=("none", "ends", "path"), default="ends",
                   help="the step-down test (not differentiated) at the start and the optimum "
                        "(ends, default), also at every accepted iterate (path), or never")
    p.add_argument("--guess", type=input_name, default=None, metavar="FILE",
                   help="start from the fixed point of a `walker gait --json` result")
    p.add_argument("--formulation", choices=("auto", "epigraph", "direct"), default="auto",
                   help="minimising max_multiplier_modulus: the smooth epigraph problem "
                        "(auto, default) or the largest modulus itself (direct), which is "
                        "not differentiable where two multipliers meet")
    rules(p, max_evaluations=at_least(1), tol=positive)
    p.set_defaults(func=cmd_optimize)

    p = sub.add_parser("continue", parents=analysis,
                       help="continuation of the gait in a parameter: branches, stability, "
                            "bifurcations, period doubling")
    p.add_argument("--param", required=True, metavar="NAME=START:STOP",
                   help="the run-time parameter and its range, e.g. slope=0.002:0.02")
    p.add_argument("--doublings", type=int, default=2, metavar="N",
                   help="period doublings to follow from flips (default: 2, period 1 -> 2 -> 4)")
    p.add_argument("--max-points", type=int, default=400, metavar="N",
                   help="points per branch at most (default: 400)")
    p.add_argument("--out", type=file_name, default=None, metavar="DIR",
                   help="write continuation.json and bifurcation_diagram.png there")
    p.add_argument("--time-limit", type=float, default=CONTINUATION_TIME_LIMIT, metavar="S",
                   help=f"start no new point after S seconds (default "
                        f"{CONTINUATION_TIME_LIMIT:g}; 0: no limit)")
    _guess_options(p)
    rules(p, doublings=at_least(0), max_points=at_least(2), time_limit=not_negative)
    p.set_defaults(func=cmd_continue)

    p = sub.add_parser("walk", parents=[BACKEND_OPTION, SET_OPTION, JSON_OPTION, QUIET_OPTION],
                       help="walk N steps from the initial guess; per-step records and the "
                            "energy ledger")
    p.add_argument("model", help=model_help)
    p.add_argument("--steps", type=int, default=20, metavar="N",
                   help=f"steps to walk (default: 20; in simulations of {WALK_BLOCK} strides "
                        "each, from the section state the last one ended in)")
    p.add_argument("--time-limit", type=float, default=TIME_LIMIT, metavar="S",
                   help=f"start no block of {WALK_BLOCK} strides after S seconds, and report the "
                        f"steps walked (default {TIME_LIMIT:g}; 0: no limit)")
    rules(p, steps=at_least(1), time_limit=not_negative)
    p.set_defaults(func=cmd_walk)

    p = sub.add_parser("step-down", parents=analysis,
                       help="largest single drop of the surface survived, scanning upward "
                            "(thesis §2.6)")
    p.add_argument("--resolution", type=float, default=None, metavar="H",
                   help="height grid (m; default: 2e-4 of the leg length)")
    p.add_argument("--h-max", type=float, default=None, metavar="H",
                   help="largest height tried (m; default: 0.1 of the leg length)")
    _search_limit(p, scan=True)
    rules(p, resolution=positive, h_max=positive, time_limit=not_negative)
    p.set_defaults(func=cmd_step_down)

    p = sub.add_parser("basin", parents=analysis,
                       help="basin of attraction on a scaled (theta, theta_dot) grid")
    p.add_argument("--n", type=int, default=11, help="grid points per axis (default: 11)")
    p.add_argument("--span", type=float, default=0.1,
                   help="half-width of the grid in scaled units (theta/0.4 rad, "
                        "theta_dot/0.8 rad/s; default: 0.1)")
    _search_limit(p, scan=True)
    rules(p, n=_basin_n, span=positive, time_limit=not_negative)
    p.set_defaults(func=cmd_basin)

    p = sub.add_parser("gsn", parents=analysis,
                       help="Gait Sensitivity Norm for a step-down disturbance")
    _search_limit(p)
    rules(p, time_limit=not_negative)
    p.set_defaults(func=cmd_gsn)

    p = sub.add_parser("report", parents=[BACKEND_OPTION, SET_OPTION, QUIET_OPTION],
                       help="the main job: HTML report (figures, GIF, JSON) of a walker")
    p.add_argument("model", nargs="?", default="compass_walker",
                   help="walker model (default: compass_walker, the thesis's nominal walker)")
    p.add_argument("--out", type=file_name, default="report", metavar="DIR",
                   help="output directory (default: ./report)")
    p.add_argument("--steps", type=int, default=6, metavar="N",
                   help=f"steps of the recorded walk (default: 6, at most {MAX_SERIES_STEPS})")
    p.add_argument("--basin", action="store_true", help="also the basin of attraction (slow)")
    p.add_argument("--no-step-down", action="store_true", help="skip the step-down test")
    p.add_argument("--continuation", default=None, metavar="NAME=START:STOP",
                   help="also the bifurcation diagram over a parameter's range (walker continue)")
    p.add_argument("--time-limit", type=float, default=CONTINUATION_TIME_LIMIT, metavar="S",
                   help=f"with --continuation: start no new point after S seconds (default "
                        f"{CONTINUATION_TIME_LIMIT:g}; 0: no limit)")
    p.add_argument("--forces", action="store_true",
                   help="draw the contact-force arrows in walk.gif (the page's player has a "
                        "switch for them either way)")
    view = p.add_mutually_exclusive_group()
    view.add_argument("--view3d", dest="view3d", action="store_true", default=None,
                      help="an interactive 3D view of the walk for a planar walker too (a 3D "
                           "walker always has one), with its still image view3d.png")
    view.add_argument("--no-view3d", dest="view3d", action="store_false",
                      help="no 3D view, not even for a 3D walker")
    rules(p, steps=check_series_steps, time_limit=not_negative)
    p.set_defaults(func=cmd_report)

    p = add_sweep_parser(
        sub, "run an analysis over a grid of parameters, resumably (JSON Lines file)",
        "Run an analysis for every case of a parameter grid, appending one row per case to a "
        "JSON Lines file as it finishes.")
    p.add_argument("model", help=model_help + " (passed to the case function as model=MODEL)")
    p.add_argument("--analysis", default="gait",
                   help=f"one of {', '.join(ANALYSES)} (default: gait), or module:function for a "
                        "case function of your own, called as fn(case, model=MODEL, "
                        "backend=BACKEND, **options) and returning a dict")
    p.add_argument("--option", action="append", default=[], metavar="NAME=VALUE",
                   help="extra keyword argument of the case function (a JSON value), e.g. "
                        "max_period=4; part of the sweep's identity; an option the function does "
                        "not take is refused")
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("reproduce", parents=[QUIET_OPTION],
                       help="rebuild the thesis's tables and figures (named studies)")
    p.add_argument("studies", nargs="*", metavar="STUDY",
                   help="studies to run (default: all; see --list)")
    p.add_argument("--out", type=file_name, default="reproduction", metavar="DIR",
                   help="output directory (default: ./reproduction)")
    p.add_argument("--quick", action="store_true", help="coarse grids (minutes, not hours)")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="process-pool size (default: one per core)")
    p.add_argument("--serial", action="store_true", help="run the sweeps in this process")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="a dask.distributed scheduler address, or 'local' for a local cluster")
    p.add_argument("--list", action="store_true", help="list the studies and exit")
    rules(p, workers=at_least(1))
    p.set_defaults(func=cmd_reproduce)

    p = sub.add_parser("list", parents=[JSON_OPTION], help="the walker model files")
    p.set_defaults(func=cmd_list)

    p = sub.add_parser("export", parents=[SET_OPTION],
                       help="write a walker's model file (with the --set values)")
    p.add_argument("model", help=model_help)
    p.add_argument("path", help="the model file to write (.toml)")
    p.add_argument("--force", action="store_true",
                   help="replace what is at PATH already (a link is replaced, not written "
                        "through)")
    p.set_defaults(func=cmd_export)

    p = add_fmu_parser(sub, "write the walker (its model and mode machine) as an FMU, starting "
                            "from its initial guess; docs/fmu.md", model_help, "walker.fmu", "cs")
    p.add_argument("--steps", type=int, default=5, metavar="N",
                   help="the default stop time is N times the walker's max_step_time (default: 5)")
    p.set_defaults(func=cmd_export_fmu)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """The ``walker`` command: the exit status (0 ok, 1 a failed check, 2 bad input)."""
    return run(build_parser(), argv)


def command() -> int:
    """The ``walker`` console script and ``python -m walker_library``: :func:`main`, then the
    process exits (:func:`porthamiltonian.interfaces.cli.leaving`)."""
    return leaving(main())


if __name__ == "__main__":
    sys.exit(command())

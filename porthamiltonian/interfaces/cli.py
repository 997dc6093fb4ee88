"""Command line ``porthamiltonian``: simulate, show, check-energy and sweep model files.

    porthamiltonian simulate MODEL [--set NAME=VALUE ...] [--t-end T] [--json] [--csv FILE]
    porthamiltonian show MODEL [--code [--backend c|numba|python]] [--ph]
    porthamiltonian linearize MODEL [--set NAME=VALUE ...] [--at NAME=VALUE ...] [--trim|--no-trim]
                          [--json]
    porthamiltonian check-energy [MODEL ...]
    porthamiltonian view MODEL [--set NAME=VALUE ...] [--t-end T] [--out DIR] [--rate R]
    porthamiltonian sweep MODEL --grid NAME=SPEC ... --out FILE [--t-end T] [--output NAME ...]
                          [--settle NAME [--band B]] [--workers N | --serial | --scheduler ADDR]
    porthamiltonian export-fmu MODEL --out FILE [--fmi 2|3] [--kind me|cs|both] [--set NAME=VALUE]
    porthamiltonian fit MODEL DATA.csv --param NAMES [--set NAME=VALUE ...] [--bounds NAME=LO:HI]
                          [--weight NAME=W] [--absolute-sigma] [--t-end T] [--json]

MODEL is a name from ``models/`` or a path to a ``.toml`` model file. Every option may be given
anywhere after its command (``--backend`` also before it). Exit status: 0 on success, 1 when a
check fails (or, for a sweep, some cases were lost: rerun it), 2 on bad input (``error: <message>``
on stderr, naming what is wrong; never a traceback), 3 on a bug in porthamiltonian (a traceback
and a request to report it), 130 when interrupted (Ctrl-C; 128 + the signal's number for a
sweep), 141 when the reader of the output went away (``| head``).

This module also holds what the ``walker`` command shares with this one: the parent parsers of
the common options (:data:`SET_OPTION`, :data:`JSON_OPTION`, :func:`backend_option`,
:data:`QUIET_OPTION`, :data:`SWEEP_OPTIONS`), :func:`file_name`, :func:`input_name`,
:func:`parse_assignments`, :func:`run_sweep` and the runner :func:`run`.
"""
from __future__ import annotations

import argparse
import gc
import hashlib
import json
import math
import os
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from typing import Any

from .. import backends, userfiles
from ..batch.analysis import Analysis
from ..batch.errors import SweepError
from ..batch.grids import MAX_CASES
from ..batch.progress import MODES
from ..batch.values import to_jsonable
from ..errors import ModelError, OptionError
from ..simulation.options import METHODS
from . import io

# A command's own machinery (the sweep runner and the model sweeps' cases, the FMU exporter, the
# compiler, the code printers, fitting, linearization) is imported inside the command that uses
# it: a warm run of one command (e.g. `walker gait`, which imports this module for the shared
# options) loads only what it runs.


# --- options shared by the commands (argparse parent parsers) ------------------------------------
def at_least(minimum: int) -> Callable[[str, Any], None]:
    """A rule of an option (see :func:`rules`): a whole number >= ``minimum``."""
    def check(option: str, value: Any) -> None:
        if value < minimum:
            raise OptionError(f"{option} must be at least {minimum}, got {value}")
    return check


def positive(option: str, value: float) -> None:
    """A rule of an option (see :func:`rules`): a finite number > 0."""
    if not (math.isfinite(value) and value > 0):
        raise OptionError(f"{option} must be a finite number > 0, got {value:g}")


def not_negative(option: str, value: float) -> None:
    """A rule of an option (see :func:`rules`): a finite number >= 0 (0 often means "none")."""
    if not (math.isfinite(value) and value >= 0):
        raise OptionError(f"{option} must be a finite number >= 0, got {value:g}")


def file_name(text: str) -> str:
    """The argparse type of an optional output (``--csv FILE``, ``--out DIR``): a path that is
    not empty (``--csv ""`` was taken as no option given: nothing written, without a word)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path; give the file or folder to write")
    return text


def input_name(text: str) -> str:
    """The argparse type of an optional input file (``walker gait --guess FILE``): a path that
    is not empty (``--guess ""`` was taken as no option given: the search started from the
    model file's guess, without a word)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path; give the file to read")
    return text


def check_output(option: str, path: str | None) -> None:
    """Before the work: an output file ``path`` of ``option`` (``--csv``) can be written (not
    a directory, in a folder that exists); else a ModelError saying so (the run that the file
    was to hold was lost when its writing failed after it)."""
    problem = None if path is None else userfiles.output_problem(path)
    if problem is not None:
        raise ModelError(f"{option} {path} {problem}; give a file in a folder that exists")


def rules(parser: argparse.ArgumentParser, **checks: Callable[[str, Any], None]) -> None:
    """Give the options of a command's ``parser`` their rules (``steps=at_least(1)``,
    ``rate=positive``): :func:`run` applies them before the command runs, so a bad value is
    an ``error: --steps must be at least 1, got 0`` (status 2) and never reaches the work."""
    parser.set_defaults(option_rules={**(parser.get_default("option_rules") or {}), **checks})


def _check_rules(args: argparse.Namespace) -> None:
    for dest, check in (getattr(args, "option_rules", None) or {}).items():
        value = getattr(args, dest, None)
        if value is not None:
            check(f"--{dest.replace('_', '-')}", value)


def _parent() -> argparse.ArgumentParser:
    return argparse.ArgumentParser(add_help=False)


#: ``--set NAME=VALUE`` (repeatable): parameter values, read by :func:`parse_assignments`
SET_OPTION = _parent()
SET_OPTION.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="give a parameter a value (SI units), e.g. --set k=9; repeatable")
#: ``--json``: one JSON document on stdout
JSON_OPTION = _parent()
JSON_OPTION.add_argument("--json", action="store_true",
                         help="print one JSON document on stdout (SI units, named fields)")
#: ``--progress-interval S`` of a single run (``simulate``, ``view``): see :class:`RunProgress`
RUN_PROGRESS_OPTION = _parent()
RUN_PROGRESS_OPTION.add_argument(
    "--progress-interval", type=float, default=5.0, metavar="S",
    help="seconds of wall time before the first progress line on stderr of a long run, then "
         "one every 6 S (default: 5, then every 30)")
RUN_PROGRESS_OPTION.set_defaults(option_rules={"progress_interval": positive})


def backend_option(default: str | None = argparse.SUPPRESS) -> argparse.ArgumentParser:
    """A parent parser of ``--backend`` (the names :mod:`porthamiltonian.backends` accepts).
    A command's top-level parser takes it with the command's default; its subcommands take
    :data:`BACKEND_OPTION` (no default), so the option works before and after the subcommand."""
    parent = _parent()
    parent.add_argument("--backend", choices=("auto", *backends.BACKENDS), default=default,
                        help="numeric back end; 'auto' picks the fastest one installed "
                             "(default: auto; walkers: the walker's own)")
    return parent


#: ``--backend NAME`` of a subcommand (see :func:`backend_option`)
BACKEND_OPTION = backend_option()
#: ``--quiet``: no progress display on stderr
QUIET_OPTION = _parent()
QUIET_OPTION.add_argument("--quiet", action="store_true",
                          help="no progress lines or bar on stderr")


#: the options of a resumable sweep (``porthamiltonian sweep``, ``walker sweep``)
SWEEP_OPTIONS = _parent()
SWEEP_OPTIONS.add_argument(
    "--grid", action="append", default=[], required=True, metavar="NAME=SPEC",
    help="an axis of the grid: NAME=start:stop:n (n values, both ends included) or "
         "NAME=v1,v2,...; repeat for a cartesian product (the last axis varies fastest)")
SWEEP_OPTIONS.add_argument(
    "--out", required=True, metavar="FILE",
    help="results file (JSON Lines, one row per finished case); rerunning the same command "
         "resumes it")
SWEEP_OPTIONS.add_argument("--workers", type=int, default=None, metavar="N",
                           help="worker processes of the local pool (default: one per core), or "
                                "of --scheduler local")
SWEEP_OPTIONS.add_argument("--serial", action="store_true",
                           help="run the cases in this process, one after the other")
SWEEP_OPTIONS.add_argument("--scheduler", default=None, metavar="ADDRESS",
                           help="run on a dask.distributed cluster: a scheduler address "
                                "(tcp://host:8786), or 'local' for a local cluster")
SWEEP_OPTIONS.add_argument("--max-cases", type=int, default=MAX_CASES, metavar="N",
                           help=f"refuse a grid of more cases than this (default {MAX_CASES}: a "
                                "case list takes about 0.5 kB of memory per case); 0: no limit")
SWEEP_OPTIONS.add_argument("--csv", type=file_name, default=None, metavar="FILE",
                           help="also write the table as CSV")
SWEEP_OPTIONS.add_argument("--progress", choices=MODES, default=None,
                           help="progress display on stderr (default: auto, a bar on a "
                                "terminal, else text lines; none with --json)")
SWEEP_OPTIONS.add_argument("--progress-interval", type=float, default=10.0, metavar="S",
                           help="seconds between text progress lines (default: 10)")


def add_sweep_parser(subparsers: argparse._SubParsersAction, help: str,
                     description: str) -> argparse.ArgumentParser:
    """Add a ``sweep`` command to ``subparsers``: ``--backend``, :data:`SWEEP_OPTIONS` and
    ``--json``, and the resume and exit-status rules after ``description``."""
    parser = subparsers.add_parser(
        "sweep", parents=[BACKEND_OPTION, SWEEP_OPTIONS, JSON_OPTION], help=help,
        description=f"{description} Rerunning the same command resumes the sweep where it "
                    "stopped (also after the command was killed). Exit status: 0 all cases "
                    "done, 1 some lost (rerun), 2 bad input or a refused file, 130/143 "
                    "interrupted (rerun to resume).")
    rules(parser, workers=at_least(1), progress_interval=not_negative, max_cases=at_least(0))
    return parser


def add_fmu_parser(subparsers: argparse._SubParsersAction, help: str, model_help: str,
                   example: str, kind: str) -> argparse.ArgumentParser:
    """The ``export-fmu`` subcommand's parser with the options every FMU export takes (the model,
    ``--out``, ``--fmi``, ``--kind``, whose default is ``kind``; ``example``: the FMU's file name
    shown in ``--out``'s help), for the command to add its own."""
    p = subparsers.add_parser("export-fmu", parents=[BACKEND_OPTION, SET_OPTION], help=help)
    p.add_argument("model", help=model_help)
    p.add_argument("--out", required=True, metavar="FILE", help=f"the FMU to write ({example})")
    p.add_argument("--fmi", type=int, choices=(2, 3), default=2,
                   help="FMI version: 2 (2.0, default) or 3 (3.0)")
    p.add_argument("--kind", choices=("me", "cs", "both"), default=kind,
                   help=f"model exchange (me), co-simulation (cs) or both (default: {kind})")
    return p


def parse_assignments(pairs: Sequence[str], option: str = "--set") -> dict[str, float]:
    """``["k=9", "slope=0.01"]`` (the ``--set`` options, or those of ``option``) ->
    ``{"k": 9.0, "slope": 0.01}``."""
    out = {}
    for pair in pairs:
        name, sep, value = pair.partition("=")
        if not sep or not name.strip():
            raise ModelError(f"{option} takes NAME=VALUE, got {pair!r}")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise ModelError(f"{option} {name}: {value!r} is not a number") from None
    return out


# --- sweeps ----------------------------------------------------------------------------------------
def _model_file_meta(model: str) -> dict[str, str]:
    """The model file a sweep's model name resolves to, and its sha256 (header metadata: a
    resumed sweep whose file changed warns); {} for a name that is no file (a builder)."""
    try:
        path = io.model_path(model)
    except ModelError:
        return {}
    if userfiles.is_pipe(path):
        raise SweepError(f"{model}: a sweep reads its model file again in every worker process, "
                         "and a pipe can be read once only; save the model to a file")
    data = userfiles.read_bytes(path, limit=io.MAX_FILE_SIZE, label=str(path), kind="model file")
    return {"model_file": str(path), "model_file_sha256": hashlib.sha256(data).hexdigest()}


def format_value(value: Any, digits: int = 6) -> str:
    """A value as a table shows it: ``-`` for None, a float to ``digits`` significant digits,
    anything else as ``str`` gives it."""
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.{digits}g}"
    return str(value)


def _print_table(rows: list[dict], names: list[str], columns: Sequence[str]) -> None:
    cols = ["case_id", *names, "status", *columns]
    cells = [[format_value(row.get(c)) for c in cols] for row in rows]
    widths = [max(len(c), *(len(r[i]) for r in cells)) for i, c in enumerate(cols)]
    print("  ".join(c.ljust(w) for c, w in zip(cols, widths)))
    for r in cells:
        print("  ".join(v.ljust(w) for v, w in zip(r, widths)))


def run_sweep(args: argparse.Namespace, analysis: Analysis, fixed: dict[str, Any],
              columns: Sequence[str] | None = None) -> int:
    """Run (or resume) the sweep of a ``sweep`` command: ``analysis`` over the cases of
    ``args.grid`` with the keyword arguments ``fixed``, into ``args.out``, then print the
    report and the table (``columns``: result fields shown; default the analysis's).

    Everything that can be refused is refused before any case runs: the grid, options the case
    function does not take, a results file that is a directory or belongs to another sweep, and
    (the analysis's ``prepare``) the cases themselves. Exit status: 0 when every case is in the
    file (failed cases included), 1 when some were lost by the executor (rerun to resume),
    128 + the signal's number when interrupted."""
    from ..batch import Sweep, SweepInterrupted, open_executor, parse_grid, write_csv

    cases = parse_grid(args.grid, args.max_cases or None)
    check_output("--csv", args.csv)
    meta = {"analysis": analysis.name, "grid": list(args.grid),
            **_model_file_meta(str(fixed.get("model", "")))}
    sweep = Sweep(analysis.resolve(), cases, args.out, fixed=fixed, meta=meta,
                  ok_statuses=analysis.ok_statuses)
    if sweep.pending():
        sweep.set_shared(analysis.run_prepare(sweep.cases, sweep.fixed))
    progress = args.progress or ("none" if args.json else "auto")
    try:
        with open_executor(args.scheduler, args.workers) as executor:
            report = sweep.run(executor, workers=args.workers, serial=args.serial,
                               progress=progress, progress_interval=args.progress_interval)
    except SweepInterrupted as stop:
        print(f"interrupted: {stop}", file=sys.stderr)
        return 128 + stop.signum
    rows = sweep.table()
    if args.csv:
        write_csv(rows, args.csv)
    if args.json:
        print(json.dumps({"file": str(sweep.path), "identity": sweep.identity,
                          "report": report.to_dict(), "table": rows}, indent=1, allow_nan=False))
    else:
        counts = ", ".join(f"{k} {v}" for k, v in sorted(report.status_counts.items()))
        print(f"{sweep.path}: {report.n_done}/{report.n_cases} cases ({counts}); this run "
              f"{report.n_run} case(s) in {report.seconds:.3g} s, {report.n_previously_done} "
              "already done")
        if len(rows) <= 60:
            _print_table(rows, list(cases[0]), analysis.columns if columns is None else columns)
        if args.csv:
            print(f"wrote {args.csv}")
    if report.n_lost:
        print(f"{report.n_lost} case(s) were lost by the executor; run the same command again "
              "to finish the sweep", file=sys.stderr)
        return 1
    return 0


def simulate_analysis() -> Analysis:
    """The analysis of ``porthamiltonian sweep``: one simulation per case
    (:func:`.sweeps.simulate_case`)."""
    from .sweeps import prepare_simulation, simulate_case

    return Analysis("simulate", simulate_case,
                    "simulate the model with each case's parameter values: status, ledger, "
                    "final/min/max of outputs, settling time", prepare=prepare_simulation,
                    ok_statuses=("finished", "event"))


def cmd_sweep(args: argparse.Namespace) -> int:
    """``porthamiltonian sweep``: simulate the model at every grid point (resumable)."""
    if not 0 < args.band < 1:
        raise SweepError(f"--band must be a fraction between 0 and 1 (0.02: the 2 % settling "
                         f"time), got {args.band!r}")
    fixed = {"model": args.model, "backend": args.backend, "t_end": args.t_end,
             "outputs": args.output or None, "settle": args.settle, "band": args.band}
    columns = ([f"final.{n}" for n in args.output] + (["settling_time"] if args.settle else [])
               + ["energy.dissipated", "energy.relative_residual"])
    return run_sweep(args, simulate_analysis(), fixed, columns)


# --- simulate, show, check-energy -------------------------------------------------------------------
class RunProgress:
    """Lines on stderr during a long run (``simulate``, ``view``): the simulated time reached
    and, at the pace so far, how long to the end, or where the run will stop at ``max_steps``
    (the first line after ``interval`` seconds of wall time, 5 by default, then one every six
    intervals, 30 s: a ``t_end = 1e12`` does not run silently). Called with the simulated time
    and the steps taken (:func:`~porthamiltonian.simulation.simulate.simulate`'s
    ``progress``)."""

    def __init__(self, name: str, t_end: float, t_start: float = 0.0,
                 max_steps: int = 10_000_000, clock: Callable[[], float] = time.monotonic,
                 interval: float = 5.0):
        self.name, self.t_end, self.t_start, self.max_steps = name, t_end, t_start, max_steps
        self.clock = clock
        self.start = clock()
        self.next = self.interval = interval

    def __call__(self, t: float, steps: int) -> None:
        """Report where the run is, if it is time for a line."""
        elapsed = self.clock() - self.start
        if elapsed < self.next or t <= self.t_start:
            return
        from ..compiler.estimate import duration_text

        self.next = elapsed + 6.0 * self.interval
        done = (t - self.t_start) / (self.t_end - self.t_start)
        line = (f"{self.name}: t = {t:.4g} s of {self.t_end:g} s ({100 * done:.3g} %) after "
                f"{elapsed:.0f} s, {steps} steps")
        if steps / done > self.max_steps:
            stop = self.t_start + (t - self.t_start) * self.max_steps / max(steps, 1)
            line += (f"; at this pace the run needs about {steps / done:.2g} steps and will stop "
                     f"at the limit of {self.max_steps} steps near t = {stop:.3g} s, in about "
                     f"{duration_text(elapsed * (self.max_steps / max(steps, 1) - 1))}")
        else:
            line += f"; about {duration_text(elapsed * (1 / done - 1))} to go at this pace"
        backends.report(line + " (Ctrl-C stops the run)")


def cmd_simulate(args: argparse.Namespace) -> int:
    """``porthamiltonian simulate``: one run, its final state and ledger (text or JSON)."""
    from .sweeps import SimulationModel

    check_output("--csv", args.csv)
    entry = SimulationModel.load(args.model, args.backend)
    model, compiled = entry.model, entry.compiled
    traj = entry.simulate(args.t_end, parse_assignments(args.set),
                          progress=RunProgress(model.name, entry.t_end(args.t_end),
                                               interval=args.progress_interval),
                          method=args.method)
    result: dict[str, Any] = {"model": model.name, "status": traj.status, "message": traj.message,
              "t_end": traj.t_final,
              "final_state": dict(zip(compiled.state_names, traj.x_final.tolist())),
              "energy": traj.ledger(), "nfev": traj.nfev, "events": traj.events}
    if args.csv:
        traj.to_csv(args.csv, outputs=True)
    if args.json:                  # (a run that overflowed: its inf and NaN as null)
        print(json.dumps(to_jsonable(result), indent=1, allow_nan=False))
    else:
        print(f"{model.name}: {traj.status} at t = {traj.t_final:g} s ({traj.message}); "
              f"{traj.nfev} right-hand-side evaluations")
        for name, value in result["final_state"].items():
            print(f"  {name:30s} {value: .10g} {compiled.units.get(name, '')}".rstrip())
        led = result["energy"]
        print(f"  energy: H(0) = {led['H0']:.10g} J, H(T) = {led['HT']:.10g} J, dissipated = "
              f"{led['dissipated']:.10g} J, supplied = {led['supplied']:.10g} J")
        print(f"  residual H(T) - H(0) + dissipated - supplied = {led['residual']:.3e} J "
              f"(max |r| / energy scale = {led['relative_residual']:.3e})")
    return 0 if traj.success else 1


def cmd_view(args: argparse.Namespace) -> int:
    """``porthamiltonian view``: simulate a model and write its 3D view and still image."""

    from .sweeps import SimulationModel
    from .viewer import scene_from_trajectory

    record = io.read(args.model)
    entry = SimulationModel.from_file(record, args.backend)
    out = userfiles.make_folder(args.out)   # before the run: a bad --out loses no work
    traj = entry.simulate(args.t_end, parse_assignments(args.set),
                          progress=RunProgress(entry.model.name, entry.t_end(args.t_end),
                                               interval=args.progress_interval))
    scene = scene_from_trajectory(traj, model=entry.model, rate=args.rate,
                                  title=entry.model.name)
    page = scene.to_html(out / "view.html", caption=record.description, still=False)
    still = scene.to_png(out / "view.png")
    print(f"wrote {page} and {still}: {len(scene.bodies)} bod{'y' if len(scene.bodies) == 1 else 'ies'}"
          f", {len(scene.t)} frames over {traj.t_final:g} s ({traj.status})")
    return 0 if traj.success else 1


def cmd_show(args: argparse.Namespace) -> int:
    """``porthamiltonian show``: components, bonds, parameters and the state equations (with
    ``--code``: the generated source of the chosen back end)."""
    from ..backends import module, native
    from ..compiler import compile_model, symbolic
    from ..compiler.phform import ph_text

    record = io.read(args.model)
    model = record.model
    if args.code:
        with record.located():
            compiled = compile_model(model, backend=args.backend)
        print(native.translation_unit(compiled.source) if compiled.backend == "c" else
              module.shown_text(compiled.source, compiled.backend), end="")
        return 0
    with record.located():
        flat = model.validate()
        sym = symbolic(flat)
        if args.ph:
            print(ph_text(sym.ph_form()), end="")
            return 0
    print(f"model {model.name}: {record.description}")
    print("components:")
    for name, comp in flat.components.items():
        ports = ", ".join(f"{p.name}[{p.domain}{'' if p.dim == 1 else f' x{p.dim}'}, "
                          f"{p.orientation or 'free'}]" for p in flat.ports[name])
        print(f"  {name:22s} {comp.kind:8s} {dict(comp.args)}  ports: {ports}")
    print("bonds (power tail -> head):")
    for (tc, tp), (hc, hp) in flat.bonds:
        print(f"  {tc}.{tp} -> {hc}.{hp}")
    print("parameters:")
    for name, par in flat.parameters.items():
        print(f"  {name:22s} = {par.value:<12g} {par.unit:10s} {par.doc}")
    print("states:", ", ".join(sym.state_names))
    print("state equations:")
    for line in sym.equations:
        print("  " + line)
    print(f"H      = {sym.hamiltonian}")
    print(f"P_diss = {sym.p_diss}")
    print(f"P_in   = {sym.p_in}")
    return 0


def cmd_linearize(args: argparse.Namespace) -> int:
    """``porthamiltonian linearize``: A, B, C, D and eigenvalues at the operating point
    (:mod:`porthamiltonian.interfaces.linearization`)."""
    from . import linearization

    return linearization.run_linearize(args, parse_assignments(args.at, "--at"),
                                       parse_assignments(args.set))


def cmd_fit(args: argparse.Namespace) -> int:
    """``porthamiltonian fit``: parameters fitted to a data file
    (:mod:`porthamiltonian.interfaces.fitting`)."""
    from . import fitting
    from .sweeps import SimulationModel

    entry = SimulationModel.load(args.model, args.backend)
    return fitting.run_fit(args, entry.compiled, parse_assignments(args.set),
                           entry.settings["atol"])


def cmd_check_energy(args: argparse.Namespace) -> int:
    """``porthamiltonian check-energy``: each model's energy balance against its tolerance."""
    from .sweeps import SimulationModel

    names = args.models or io.available_models()
    failed = []
    for name in names:
        try:
            entry = SimulationModel.load(name, args.backend)
            traj = entry.simulate(None)
        except ModelError as err:
            print(f"FAIL {name}: {err}")
            failed.append(name)
            continue
        rel, tol = traj.relative_residual, float(entry.settings["energy_tolerance"])
        ok = traj.success and rel <= tol
        print(f"{'ok  ' if ok else 'FAIL'} {name}: status {traj.status}, max |residual| / energy "
              f"scale = {rel:.2e} (tolerance {tol:.0e}), energy scale {traj.energy_scale:.3g} J")
        if not ok:
            failed.append(name)
    if failed:
        print(f"energy check failed for: {', '.join(failed)}")
        return 1
    print(f"energy balance closed for all {len(names)} models")
    return 0


def cmd_export_fmu(args: argparse.Namespace) -> int:
    """``porthamiltonian export-fmu``: the model as an FMU (docs/fmu.md)."""
    from ..fmu import export_fmu
    from ..integrators import TABLEAUS
    from .sweeps import check_settings, simulation_settings

    record = io.read(args.model)
    settings = simulation_settings(record.simulation)
    with record.located():
        compiled = record.compile(backend=args.backend)
        check_settings(compiled, settings)
    method = settings["method"] if settings["method"] in TABLEAUS else "Rodas5P"
    t_end = args.t_end if args.t_end is not None else settings.get("t_end")
    path = export_fmu(compiled, args.out, fmi=args.fmi, kind=args.kind,
                      params=parse_assignments(args.set), method=method, rtol=settings["rtol"],
                      atol=settings["atol"], max_step=settings.get("max_step", float("inf")),
                      stop_time=t_end, description=record.description,
                      x0=settings.get("initial"), inputs=_constant_inputs(settings.get("inputs")))
    kinds = {"me": "model exchange", "cs": "co-simulation",
             "both": "model exchange and co-simulation"}[args.kind]
    print(f"wrote {path}: FMI {args.fmi}.0 ({kinds}), {compiled.n_states} + 2 states (the ledger's "
          f"E_diss, E_in), {len(compiled.events)} event indicator(s), "
          f"{len(compiled.param_names)} parameters, {len(compiled.input_names)} input(s), "
          f"{len(compiled.output_names)} outputs")
    if "walker" in record.sections:
        print(f"note: {args.model} is a walker file: this FMU is its model with the modes fixed "
              "at their values (as `porthamiltonian simulate` runs it); `walker export-fmu` "
              "exports the walker with its mode machine", file=sys.stderr)
    return 0


def _constant_inputs(inputs: Any) -> dict[str, float] | None:
    """The numbers of a model file's ``[simulation] inputs`` (the FMU's input start values)."""
    if not isinstance(inputs, dict):
        return None
    return {k: v for k, v in inputs.items() if isinstance(v, (int, float))
            and not isinstance(v, bool)}


def build_parser() -> argparse.ArgumentParser:
    """The ``porthamiltonian`` command's parser."""
    from . import fitting, linearization

    model_help = "model: a name from models/ (see check-energy's list) or a path to a .toml file"
    parser = argparse.ArgumentParser(prog="porthamiltonian", description=__doc__.splitlines()[0],
                                     parents=[backend_option("auto")])
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    p = sub.add_parser("simulate", parents=[BACKEND_OPTION, SET_OPTION, JSON_OPTION,
                                            RUN_PROGRESS_OPTION],
                       help="simulate a model and print its final state and energy ledger")
    p.add_argument("model", help=model_help)
    p.add_argument("--t-end", type=float, default=None, metavar="T",
                   help="end time (s; default: the model file's [simulation] t_end)")
    p.add_argument("--csv", type=file_name, metavar="FILE",
                   help="also write the trajectory (time, states, ledger, outputs) as CSV")
    p.add_argument("--method", choices=("auto", *METHODS), default=None,
                   help="integration method (default: the model file's [simulation] method; "
                        "docs/backends.md)")
    p.set_defaults(func=cmd_simulate)
    p = sub.add_parser("view", parents=[BACKEND_OPTION, SET_OPTION, RUN_PROGRESS_OPTION],
                       help="simulate a model and write an interactive 3D view of its bodies "
                            "(view.html, works offline) and a still image (view.png)")
    p.add_argument("model", help=model_help + "; its bodies need poses: a FreeBody, or a "
                   "Multibody body with outputs <multibody>.<body>.pose.x|y|z|qw|qx|qy|qz")
    p.add_argument("--t-end", type=float, default=None, metavar="T",
                   help="end time (s; default: the model file's [simulation] t_end)")
    p.add_argument("--out", type=file_name, default="view", metavar="DIR",
                   help="output directory (default: ./view)")
    p.add_argument("--rate", type=float, default=30.0, metavar="R",
                   help="frames per second of simulated time (default: 30; at most 900 "
                        "frames)")
    rules(p, rate=positive)
    p.set_defaults(func=cmd_view)
    p = sub.add_parser("show", parents=[BACKEND_OPTION],
                       help="components, ports, bonds, states, parameters and equations, or "
                            "the generated code (--code)")
    p.add_argument("model", help=model_help)
    p.add_argument("--code", action="store_true",
                   help="print the generated source the back end compiles (--backend: c, "
                        "numba or python; default auto, the back end in use)")
    p.add_argument("--ph", action="store_true",
                   help="print the explicit port-Hamiltonian form: J, R, the dissipators' "
                        "z(w) and the ports' u")
    p.set_defaults(func=cmd_show)
    p = linearization.add_linearize_parser(sub, [BACKEND_OPTION, SET_OPTION, JSON_OPTION],
                                           model_help)
    p.set_defaults(func=cmd_linearize)
    p = sub.add_parser("check-energy", parents=[BACKEND_OPTION],
                       help="simulate models and check their energy residual")
    p.add_argument("models", nargs="*", metavar="MODEL",
                   help="models to check (default: every model in models/)")
    p.set_defaults(func=cmd_check_energy)
    p = add_sweep_parser(
        sub, "simulate a model for every case of a parameter grid, resumably",
        "Simulate MODEL once per case of a parameter grid (the case's values bound as "
        "parameters), appending one row per case to a JSON Lines file: the run's status and "
        "energy ledger, final value, minimum and maximum of chosen outputs, and a settling time.")
    p.add_argument("model", help=model_help)
    p.add_argument("--t-end", type=float, default=None, metavar="T",
                   help="end time of every run (s; default: the model file's [simulation] t_end)")
    p.add_argument("--output", action="append", default=[], metavar="NAME",
                   help="a state or named output whose final value, minimum and maximum are "
                        "recorded (repeatable; default: every state)")
    p.add_argument("--settle", default=None, metavar="NAME",
                   help="also record the settling time (s) of this state or output")
    p.add_argument("--band", type=float, default=0.02, metavar="B",
                   help="settling band as a fraction of the largest deviation from the final "
                        "value (default: 0.02, the 2%% settling time)")
    p.set_defaults(func=cmd_sweep)
    p = fitting.add_fit_parser(sub, [BACKEND_OPTION, SET_OPTION, JSON_OPTION, QUIET_OPTION,
                                     RUN_PROGRESS_OPTION], model_help)
    rules(p, time_limit=not_negative, progress_interval=positive)
    p.set_defaults(func=cmd_fit)
    p = add_fmu_parser(sub, "write the model as an FMU (FMI 2.0 or 3.0, model exchange and/or "
                            "co-simulation) for other tools; docs/fmu.md", model_help,
                       "model.fmu", "both")
    p.add_argument("--t-end", type=float, default=None, metavar="T",
                   help="the FMU's default stop time (s; default: the model file's [simulation] "
                        "t_end)")
    p.set_defaults(func=cmd_export_fmu)
    return parser


#: exit statuses of :func:`run`
EXIT_USER_ERROR, EXIT_BUG, EXIT_INTERRUPTED, EXIT_BROKEN_PIPE = 2, 3, 130, 141


def run(parser: argparse.ArgumentParser, argv: Sequence[str] | None = None) -> int:
    """Parse ``argv`` and run the chosen command, shared by the ``walker`` command.

    * bad input — a :class:`ModelError` (unknown model, bad file, out-of-range option or
      parameter) or a file that cannot be read or written: ``error: <message>`` on stderr, exit
      status 2, no traceback (argparse's own usage errors exit 2 too);
    * Ctrl-C: ``interrupted`` on stderr, status 130, no traceback;
    * the reader of stdout went away (``walker list | head``): no message, status 141;
    * anything else is a bug in the project: the traceback, then a line asking to report it,
      status 3.

    Warnings (e.g. a damaged cache entry being rebuilt) are printed as ``warning: <message>``.
    The one-time build of a model that is not cached yet is reported in one line on stderr
    (:func:`porthamiltonian.backends.report`; not with ``--quiet``).
    """
    args = parser.parse_args(argv)
    try:
        _check_rules(args)
        with warnings.catch_warnings(), backends.quiet(getattr(args, "quiet", False)):
            warnings.showwarning = _show_warning
            status = args.func(args)
            sys.stdout.flush()                 # a closed pipe shows here, not at exit
        return status
    except ModelError as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_USER_ERROR
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        _detach_stdout()
        return EXIT_BROKEN_PIPE
    except OSError as err:
        if err.filename is None:
            return _report_bug()
        print(f"error: {err.filename}: {err.strerror or err}", file=sys.stderr)
        return EXIT_USER_ERROR
    except Exception:  # noqa: BLE001 - a bug: report it, with the traceback
        return _report_bug()


def _show_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  file: Any = None, line: str | None = None) -> None:
    print(f"warning: {message}", file=sys.stderr)


def _detach_stdout() -> None:
    """Point stdout at /dev/null, so that flushing it at exit raises nothing more."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def _report_bug() -> int:
    import traceback

    traceback.print_exc()
    print("error: this is a bug in porthamiltonian, not a problem with your input; please report "
          "it with the command line and the traceback above", file=sys.stderr)
    return EXIT_BUG


def main(argv: Sequence[str] | None = None) -> int:
    """The ``porthamiltonian`` command: the exit status (0 ok, 1 a failed check, 2 bad input)."""
    return run(build_parser(), argv)


def leaving(status: int) -> int:
    """``status``, with every object still alive frozen for the garbage collector
    (:func:`gc.freeze`), for a command whose process exits next: the interpreter's exit then
    skips collecting them (after a build, ≈ 0.13 s of a cold ``walker gait`` went to traversing
    sympy's expressions at exit). Exit handlers still run and files are still closed."""
    gc.freeze()
    return status


def command() -> int:
    """The ``porthamiltonian`` console script and ``python -m porthamiltonian``: :func:`main`,
    then the process exits (:func:`leaving`)."""
    return leaving(main())


if __name__ == "__main__":
    sys.exit(command())

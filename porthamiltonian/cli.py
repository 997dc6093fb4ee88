"""Command line ``porthamiltonian``: simulate, show and check-energy for model files.

    porthamiltonian simulate MODEL [--set NAME=VALUE ...] --t-end T [--json] [--csv FILE]
    porthamiltonian show MODEL
    porthamiltonian check-energy [MODEL ...]

MODEL is a name from ``models/`` or a path to a ``.toml`` model file. Exit status: 0 on success,
1 when a check fails, 2 on bad input (``error: <message>`` on stderr, naming what is wrong; never
a traceback), 3 on a bug in porthamiltonian (a traceback and a request to report it), 130 when
interrupted (Ctrl-C), 141 when the reader of the output went away (``| head``).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import traceback
import warnings
from collections.abc import Sequence

from . import io
from .compiler import compile_model
from .errors import ModelError

_DEFAULTS = {"method": "auto", "rtol": 1e-9, "atol": 1e-12, "energy_tolerance": 1e-6}


def parse_assignments(pairs: Sequence[str]) -> dict[str, float]:
    """``["k=9", "slope=0.01"]`` (the ``--set`` options) -> ``{"k": 9.0, "slope": 0.01}``."""
    out = {}
    for pair in pairs:
        name, sep, value = pair.partition("=")
        if not sep or not name.strip():
            raise ModelError(f"--set takes NAME=VALUE, got {pair!r}")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise ModelError(f"--set {name}: {value!r} is not a number") from None
    return out


def _run(model_ref: str, params: dict[str, float], t_end: float | None = None, backend: str = "auto"):
    model = io.load(model_ref)
    sim = {**_DEFAULTS, **model.simulation}
    compiled = compile_model(model, backend=backend)
    t_end = t_end if t_end is not None else sim.get("t_end")
    if t_end is None:
        raise ModelError(f"model {model.name!r} has no [simulation] t_end; pass --t-end")
    traj = compiled.simulate(float(t_end), params=params, method=sim["method"], rtol=sim["rtol"],
                             atol=sim["atol"], **({"max_step": sim["max_step"]} if "max_step" in sim else {}))
    return model, compiled, traj, sim


def cmd_simulate(args) -> int:
    model, compiled, traj, _ = _run(args.model, parse_assignments(args.set), args.t_end, args.backend)
    result = {"model": model.name, "status": traj.status, "message": traj.message,
              "t_end": traj.t_final,
              "final_state": dict(zip(compiled.state_names, traj.x_final.tolist())),
              "energy": traj.ledger(), "nfev": traj.nfev, "events": traj.events}
    if args.csv:
        traj.to_csv(args.csv, outputs=True)
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        print(f"{model.name}: {traj.status} at t = {traj.t_final:g} ({traj.message}); {traj.nfev} "
              "right-hand-side evaluations")
        for name, value in result["final_state"].items():
            print(f"  {name:30s} {value: .10g}")
        led = result["energy"]
        print(f"  energy: H(0) = {led['H0']:.10g} J, H(T) = {led['HT']:.10g} J, dissipated = "
              f"{led['dissipated']:.10g} J, supplied = {led['supplied']:.10g} J")
        print(f"  residual H(T) - H(0) + dissipated - supplied = {led['residual']:.3e} J "
              f"(max |r| / energy scale = {led['relative_residual']:.3e})")
    return 0 if traj.success else 1


def cmd_show(args) -> int:
    from .compiler import symbolic

    model = io.load(args.model)
    flat = model.flatten()
    print(f"model {model.name}: {model.doc}")
    print("components:")
    for name, comp in flat.components.items():
        ports = ", ".join(f"{p.name}[{p.domain}{'' if p.dim == 1 else f' x{p.dim}'}, "
                          f"{p.orientation or 'free'}]" for p in comp.all_ports())
        print(f"  {name:22s} {comp.kind:8s} {comp.args}  ports: {ports}")
    print("bonds (power tail -> head):")
    for (tc, tp), (hc, hp) in flat.bonds:
        print(f"  {tc}.{tp} -> {hc}.{hp}")
    print("parameters:")
    for name, par in flat.parameters.items():
        print(f"  {name:22s} = {par.value:<12g} {par.unit:10s} {par.doc}")
    sym = symbolic(model)
    print("states:", ", ".join(sym.state_names))
    print("state equations:")
    for line in sym.equations:
        print("  " + line)
    print(f"H      = {sym.hamiltonian}")
    print(f"P_diss = {sym.p_diss}")
    print(f"P_in   = {sym.p_in}")
    return 0


def cmd_check_energy(args) -> int:
    names = args.models or io.available_models()
    failed = []
    for name in names:
        try:
            model, _, traj, sim = _run(name, {}, None, args.backend)
        except ModelError as err:
            print(f"FAIL {name}: {err}")
            failed.append(name)
            continue
        rel, tol = traj.relative_residual, float(sim["energy_tolerance"])
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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="porthamiltonian", description=__doc__.splitlines()[0])
    parser.add_argument("--backend", default="auto", help="auto (default), python or numba")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("simulate", help="simulate a model and print its final state and energy ledger")
    p.add_argument("model")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    p.add_argument("--t-end", type=float, default=None)
    p.add_argument("--json", action="store_true")
    p.add_argument("--csv", metavar="FILE")
    p.set_defaults(func=cmd_simulate)
    p = sub.add_parser("show", help="components, ports, bonds, states, parameters and equations")
    p.add_argument("model")
    p.set_defaults(func=cmd_show)
    p = sub.add_parser("check-energy", help="simulate models and check their energy residual")
    p.add_argument("models", nargs="*")
    p.set_defaults(func=cmd_check_energy)
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
    """
    args = parser.parse_args(argv)
    try:
        with warnings.catch_warnings():
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


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"warning: {message}", file=sys.stderr)


def _detach_stdout() -> None:
    """Point stdout at /dev/null, so that flushing it at exit raises nothing more."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def _report_bug() -> int:
    traceback.print_exc()
    print("error: this is a bug in porthamiltonian, not a problem with your input; please report "
          "it with the command line and the traceback above", file=sys.stderr)
    return EXIT_BUG


def main(argv: Sequence[str] | None = None) -> int:
    return run(build_parser(), argv)


if __name__ == "__main__":
    sys.exit(main())

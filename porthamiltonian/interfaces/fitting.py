"""``porthamiltonian fit MODEL DATA.csv --param k,c``: a model's parameters fitted to measured
data (:func:`porthamiltonian.simulation.fitting.fit`), as text or JSON.

The data file is read as hostile input: at most :data:`MAX_DATA_BYTES` bytes of UTF-8 text
(:func:`.io.read_text`), comma-separated, ``#`` lines are comments; the first row names the
columns: ``t`` (or ``time``, s) first, then one column per state or output of the model (its
samples: an empty cell is a gap, so each output may have its own sample times), or per event
of the model (the times of its first, second, ... occurrence, one per row, the ``t`` cell of
those rows ignored). Every other cell must be a finite number. A problem is a
:class:`~porthamiltonian.errors.DataError` naming the file, the line and the column.
"""
from __future__ import annotations

import argparse
import csv
import io as _io
import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..backends import report
from ..batch.values import to_jsonable
from ..errors import DataError, OptionError
from . import io

if TYPE_CHECKING:
    from ..simulation.fitting import FitResult

#: the largest data file read (bytes)
MAX_DATA_BYTES = 50_000_000
#: the most columns of a data file
MAX_COLUMNS = 1000


def read_data(path: str, events: list[str]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The data file ``path`` (module docstring) as (fit's data mapping {name: (t, values)},
    event times {event: times}); ``events``: the model's event names."""
    text = io.read_text(Path(path), limit=MAX_DATA_BYTES, label=path, kind="data file",
                        language="CSV")
    rows = [(k, row) for k, row in enumerate(csv.reader(_io.StringIO(text)), 1)
            if row and not row[0].lstrip().startswith("#") and any(c.strip() for c in row)]
    if not rows:
        raise DataError(f"{path}: no header row (the first row names the columns: t, then "
                        "outputs)")
    line, header = rows[0]
    names = [c.strip() for c in header]
    if len(names) > MAX_COLUMNS:
        raise DataError(f"{path} line {line}: {len(names)} columns; at most {MAX_COLUMNS}")
    if names[0] not in ("t", "time"):
        raise DataError(f"{path} line {line}: the first column must be the time, named t or "
                        f"time; got {names[0]!r}")
    if len(set(names)) != len(names) or not all(names):
        raise DataError(f"{path} line {line}: every column needs a name of its own, got "
                        f"{names}")
    values = np.full((len(rows) - 1, len(names)), np.nan)
    for r, (line, row) in enumerate(rows[1:]):
        if len(row) != len(names):
            raise DataError(f"{path} line {line}: {len(row)} cells for {len(names)} columns "
                            f"({', '.join(names)})")
        for c, cell in enumerate(row):
            cell = cell.strip()
            if not cell:
                continue
            try:
                v = float(cell)
            except ValueError:
                v = math.nan
            if not math.isfinite(v):
                raise DataError(f"{path} line {line}, column {names[c]!r}: {cell[:40]!r} is not "
                                "a finite number (leave the cell empty for a gap)")
            values[r, c] = v
    t = values[:, 0]
    data, times = {}, {}
    for c, name in enumerate(names[1:], 1):
        if name in events:
            times[name] = values[np.isfinite(values[:, c]), c]
            continue
        rows_ok = np.isfinite(values[:, c])
        if np.any(rows_ok & ~np.isfinite(t)):
            line = rows[1 + int(np.flatnonzero(rows_ok & ~np.isfinite(t))[0])][0]
            raise DataError(f"{path} line {line}: a sample of {name!r} without a time")
        data[name] = (t[rows_ok], values[rows_ok, c])
    return data, times


def _pairs(items: list[str], option: str) -> dict[str, str]:
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise OptionError(f"{option} {item!r}: expected NAME=VALUE")
        out[name.strip()] = value.strip()
    return out


def _number(text: str, option: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise OptionError(f"{option}: {text!r} is not a number") from None


def run_fit(args: argparse.Namespace, compiled: Any, values: dict[str, float],
            atol: Any = 1e-10) -> int:
    """The command: fit, print, exit status 0 (fitted), 1 (unidentifiable or not converged);
    ``atol``: the model file's."""
    from ..simulation.fitting import fit  # (the fit's machinery: only when fitting)

    names = [n.strip() for n in args.param.split(",") if n.strip()]
    data, times = read_data(args.data, [e.name for e in compiled.events])
    bounds = {}
    for name, text in _pairs(args.bounds, "--bounds").items():
        low, sep, high = text.partition(":")
        if not sep:
            raise OptionError(f"--bounds {name}={text}: expected NAME=LOW:HIGH")
        bounds[name] = (_number(low, "--bounds"), _number(high, "--bounds"))
    weights = {k: _number(v, "--weight") for k, v in _pairs(args.weight, "--weight").items()}
    result = fit(compiled, data or None, names, events=times or None, bounds=bounds,
                 weights=weights, values=values, t_end=args.t_end, method=args.method,
                 rtol=args.rtol, atol=atol, absolute_sigma=args.absolute_sigma,
                 deadline=time.perf_counter() + (args.time_limit or math.inf),
                 progress=FitProgress(compiled.name, interval=args.progress_interval))
    if args.json:
        print(json.dumps(to_jsonable(result.to_dict()), indent=1))
    else:
        _print(compiled.name, result)
    return 0 if result.identifiable and result.converged else 1


class FitProgress:
    """Lines on stderr during a long fit (``porthamiltonian fit``; not with ``--quiet``): the
    runs made, the last run's cost and the best so far (the first line after ``interval``
    seconds of wall time, then one every six intervals, as a long run's lines). Called with the
    runs made and the last run's cost (:func:`~porthamiltonian.simulation.fitting.fit`'s
    ``progress``)."""

    def __init__(self, name: str, interval: float = 5.0,
                 clock: Callable[[], float] = time.monotonic):
        self.name, self.clock, self.interval = name, clock, interval
        self.start = clock()
        self.next = interval
        self.best = math.inf

    def __call__(self, runs: int, cost: float) -> None:
        """Note the run; report the fit's progress if it is time for a line."""
        self.best = min(self.best, cost)
        elapsed = self.clock() - self.start
        if elapsed < self.next:
            return
        self.next = elapsed + 6.0 * self.interval
        report(f"{self.name}: fit, {runs} runs after {elapsed:.0f} s; cost {cost:.4g} (best "
               f"{self.best:.4g}) (Ctrl-C stops it; --time-limit bounds it)")


def _print(name: str, r: FitResult) -> None:
    if not r.identifiable:
        print(f"{name}: not fitted: {r.message}")
        print("  singular values (scaled):", ", ".join(f"{v:.3g}" for v in r.singular_values))
        return
    pct = f"{100 * r.confidence:g} %"
    print(f"{name}: {'converged' if r.converged else 'NOT converged'} ({r.status}: {r.message}); "
          f"{r.nfev} runs, {r.n_data} residuals, s = {r.sigma:.4g}")
    for p in r.params:
        lo, hi = r.intervals[p]
        print(f"  {p:20s} {r.estimates[p]: .8g} ± {r.standard_errors[p]:.3g}   {pct}: "
              f"[{lo:.6g}, {hi:.6g}]   (from {r.initial[p]:.6g})")
    for out, rms in r.rms.items():
        print(f"  residual RMS {out:24s} {rms:.4g}")
    if len(r.params) > 1:
        print("  correlations:")
        for p, row in zip(r.params, r.correlation):
            print(f"    {p:18s} " + " ".join(f"{v: .3f}" for v in row))


def add_fit_parser(sub: Any, parents: list, model_help: str) -> argparse.ArgumentParser:
    """The ``fit`` subcommand's parser."""
    p = sub.add_parser("fit", parents=parents,
                       help="fit parameters to measured data (CSV): estimates, 95 %% intervals, "
                            "residuals, identifiability")
    p.add_argument("model", help=model_help)
    p.add_argument("data", help="the data file: CSV, a column t (s), then one column per state, "
                                "output or event of the model (docs/fitting.md)")
    p.add_argument("--param", required=True, metavar="NAMES",
                   help="the parameters to fit, comma-separated (they start from --set values "
                        "or the model's)")
    p.add_argument("--bounds", action="append", default=[], metavar="NAME=LOW:HIGH",
                   help="bounds of a fitted parameter (repeatable; inf allowed)")
    p.add_argument("--weight", action="append", default=[], metavar="NAME=W",
                   help="1/sigma of an output's or event's samples (repeatable; default 1)")
    p.add_argument("--absolute-sigma", action="store_true",
                   help="the weights are true 1/sigma (else the noise level is estimated from "
                        "the residuals)")
    p.add_argument("--t-end", type=float, default=None, metavar="T",
                   help="end of the runs (s; default: the last sample)")
    p.add_argument("--method", default="Rodas5P", choices=("Rodas5P", "Rodas4", "QBDF"),
                   help="the compiled integrator (default: Rodas5P)")
    p.add_argument("--rtol", type=float, default=1e-8, help="relative tolerance (default 1e-8)")
    p.add_argument("--time-limit", type=float, default=0.0, metavar="S",
                   help="start no run after S seconds: the result is then the best point the "
                        "runs reached, not converged (default 0: no limit)")
    return p

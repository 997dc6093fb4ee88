"""porthamiltonian.batch: resumable parameter sweeps of any model, through any Executor.

A sweep runs a case function over a list of cases (dicts of named values, e.g. from
:func:`grid`) and appends one JSON row per finished case to a results file; rerunning it resumes
where it stopped, after Ctrl-C, SIGTERM or even a SIGKILL of its main process. The rows load as a
tidy table or a pandas data frame in one call::

    from porthamiltonian.batch import Sweep, grid, read_dataframe
    from porthamiltonian.interfaces.sweeps import simulate_case

    cases = grid(k=[1.0, 4.0, 9.0], c=[0.4, 0.8])
    Sweep(simulate_case, cases, "msd.jsonl",
          fixed={"model": "mass_spring_damper", "t_end": 60.0, "settle": "spring.q"}).run()
    df = read_dataframe("msd.jsonl")               # columns k, c, status, settling_time, ...

Modules: :mod:`.grids` (cases, grids, command-line axis specs), :mod:`.resultsfile` (the JSON
Lines file: header, rows, lock, torn-line repair), :mod:`.runner` (:class:`Sweep`: executors,
signals, crashed and orphaned workers), :mod:`.executors` (dask.distributed), :mod:`.progress`
(work ticks, progress bars), :mod:`.table` (tidy rows, CSV, data frames), :mod:`.analysis`
(named case functions for the command lines), :mod:`.simulation` (the generic case: simulate a
model per case; settling time), :mod:`.values` (JSON values), :mod:`.errors`.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from ..lazy import lazy_names

# (eager: the function ``table`` must shadow the module of the same name, as it always did)
from .table import read_dataframe, table, to_dataframe, write_csv

#: where each public name lives, imported when first used: a command that only shows progress or
#: writes JSON values (a warm ``walker gait``) does not load the sweep runner and its
#: multiprocessing, concurrent.futures and socket modules
_NAMES = {
    "Analysis": "analysis", "SweepError": "errors", "SweepFileError": "errors",
    "open_executor": "executors", "cases_sha256": "grids", "grid": "grids",
    "parse_axis": "grids", "parse_grid": "grids", "activity": "progress", "tick": "progress",
    "FORMAT": "resultsfile", "VERSION": "resultsfile", "load_results": "resultsfile",
    "read_header": "resultsfile", "Sweep": "runner", "SweepInterrupted": "runner",
    "SweepReport": "runner", "run_case": "runner", "to_jsonable": "values",
}


#: the public names, their module imported on first use (see :data:`_NAMES`)
__getattr__, __dir__ = lazy_names(__name__, _NAMES)


if TYPE_CHECKING:
    from .analysis import Analysis
    from .errors import SweepError, SweepFileError
    from .executors import open_executor
    from .grids import cases_sha256, grid, parse_axis, parse_grid
    from .progress import activity, tick
    from .resultsfile import FORMAT, VERSION, load_results, read_header
    from .runner import Sweep, SweepInterrupted, SweepReport, run_case
    from .values import to_jsonable

__all__ = [
    "FORMAT", "VERSION", "Analysis", "Sweep", "SweepError", "SweepFileError", "SweepInterrupted",
    "SweepReport", "activity", "cases_sha256", "grid", "load_results", "open_executor",
    "parse_axis", "parse_grid", "read_dataframe", "read_header", "run_case", "table", "tick",
    "to_dataframe", "to_jsonable", "write_csv",
]

"""Cases and grids: a case is a dict of named values (``{"k": 4.0, "c": 0.4}``).

:func:`grid` is the cartesian product of named axes (the last axis varying fastest);
:func:`parse_axis` and :func:`parse_grid` read command-line specs ``NAME=start:stop:n`` (n values,
both ends included) and ``NAME=v1,v2,...``; :func:`cases_sha256` hashes a case list for a
sweep's identity.
"""
from __future__ import annotations

import hashlib
import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from ..errors import CostError
from .errors import SweepError
from .values import canonical, plain_value

__all__ = ["MAX_CASES", "cases_sha256", "check_size", "grid", "normalize_case", "parse_axis",
           "parse_grid"]


def normalize_case(case: Any, index: int) -> dict[str, Any]:
    """Case ``index`` as a dict of JSON values; :class:`SweepError` if it is not a mapping of
    non-empty names to numbers, strings, bools, lists or dicts."""
    if not isinstance(case, Mapping):
        raise SweepError(f"case {index} is {type(case).__name__} {case!r}; a case is a dict of "
                         "named values, e.g. {'slope': 0.009}")
    out = {}
    for name, value in case.items():
        if not isinstance(name, str) or not name:
            raise SweepError(f"case {index}: names must be non-empty strings, got {name!r}")
        out[name] = plain_value(value, f"case {index} {name!r}")
    return out


def cases_sha256(cases: Sequence[Mapping[str, Any]]) -> str:
    """SHA-256 of the canonical JSON of a case list (sorted keys, no spaces): part of a sweep's
    identity, so that a results file is resumed only by the sweep that wrote it."""
    return hashlib.sha256(canonical([dict(c) for c in cases]).encode()).hexdigest()


#: the most cases a grid makes without asking: a case list costs about 0.5 kB of memory per
#: case (and a sweep's identity hashes it), 100 000 cases about 50 MB and a second
MAX_CASES = 100_000


def check_size(sizes: Mapping[str, int], max_cases: int | None = MAX_CASES) -> int:
    """The number of cases of axes with these ``sizes`` (name -> number of values), before any
    is made; :class:`~porthamiltonian.errors.CostError` when it exceeds ``max_cases`` (None: no
    limit), with the estimate and how to allow more."""
    n = math.prod(sizes.values())
    if max_cases is not None and n > max_cases:
        shape = " x ".join(f"{size} ({name})" for name, size in sizes.items())
        raise CostError(f"the grid has {n:,} cases ({shape}); that is more than {max_cases:,}, so "
                        f"it is refused before any case is made (its case list alone would take "
                        f"about {_memory(n)} of memory, and each case is a run). Use fewer values "
                        "per axis, or allow more with --max-cases N (max_cases=N in Python)")
    return n


def _memory(n_cases: int) -> str:
    size = 500.0 * n_cases
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if size >= scale:
            return f"{size / scale:.3g} {unit}"
    return f"{size / 1e3:.3g} kB"


def grid(max_cases: int | None = MAX_CASES, **axes: Any) -> list[dict[str, Any]]:
    """The cartesian product of named axes, as a list of cases.

    Each axis is a list, tuple, range or numpy array of values (a scalar is a one-value axis).
    Order is deterministic: axes in the order given, the last one varying fastest, e.g.
    ``grid(a=[1, 2], b=[10, 20])`` -> ``[{a:1,b:10}, {a:1,b:20}, {a:2,b:10}, {a:2,b:20}]``.
    Numpy scalars become Python numbers (cases are stored as JSON). More than ``max_cases``
    cases (default :data:`MAX_CASES`; None: no limit) are refused before any is made
    (:func:`check_size`).
    """
    names, values = [], []
    for name, axis in axes.items():
        if isinstance(axis, (str, bytes)) or not isinstance(axis, Iterable):
            axis = [axis]
        axis = [plain_value(v, f"axis {name!r}") for v in axis]
        if not axis:
            raise SweepError(f"axis {name!r} has no values")
        names.append(name)
        values.append(axis)
    check_size(dict(zip(names, map(len, values))), max_cases)
    return [dict(zip(names, combo)) for combo in itertools.product(*values)]


def _number(text: str, spec: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise SweepError(f"grid {spec!r}: {text.strip()!r} is not a number") from None
    if not math.isfinite(value):
        raise SweepError(f"grid {spec!r}: {text.strip()!r} is not finite")
    return value


def parse_axis(spec: str, max_cases: int | None = MAX_CASES) -> tuple[str, list[float]]:
    """Parse a command-line axis: ``NAME=start:stop:n`` (n evenly spaced values, both ends
    included; rounded to 15 significant digits so that 0.004:0.019:4 gives 0.009, not
    0.009000000000000001), ``NAME=v1,v2,...`` or ``NAME=v``; n above ``max_cases`` is refused
    before the values are made."""
    name, sep, rhs = spec.partition("=")
    name = name.strip()
    if not sep or not name.isidentifier():
        raise SweepError(f"grid {spec!r}: write NAME=start:stop:n or NAME=v1,v2,... "
                         "(e.g. slope=0.004:0.014:6 or K=1e4,2e4)")
    if ":" in rhs:
        parts = rhs.split(":")
        if len(parts) != 3:
            raise SweepError(f"grid {spec!r}: a range is start:stop:n (three fields), got {rhs!r}")
        start, stop = _number(parts[0], spec), _number(parts[1], spec)
        try:
            n = int(parts[2])
        except ValueError:
            raise SweepError(f"grid {spec!r}: n = {parts[2].strip()!r} must be a whole number "
                             "of values") from None
        if n < 1:
            raise SweepError(f"grid {spec!r}: n = {n} must be at least 1")
        check_size({name: n}, max_cases)
        if n == 1:
            return name, [start]
        step = (stop - start) / (n - 1)
        return name, [float(f"{start + k * step:.15g}") for k in range(n - 1)] + [stop]
    values = [_number(v, spec) for v in rhs.split(",")] if rhs.strip() else []
    if not values:
        raise SweepError(f"grid {spec!r}: no values after '='")
    return name, values


def parse_grid(specs: Sequence[str], max_cases: int | None = MAX_CASES) -> list[dict[str, float]]:
    """The cases of command-line axis specs (see :func:`parse_axis`), in :func:`grid` order;
    more than ``max_cases`` cases are refused before any is made (:func:`check_size`)."""
    sizes: dict[str, int] = {}
    for spec in specs:                      # the grid's size first, nothing made yet
        name, _, rhs = spec.partition("=")
        parts = rhs.split(":")
        try:
            size = int(parts[2]) if len(parts) == 3 else None
        except ValueError:
            size = None
        if size is None or size < 1:
            name, values = parse_axis(spec, max_cases)       # a list, or an error to report
            size = len(values)
        sizes[name.strip()] = size
    check_size(sizes, max_cases)
    axes: dict[str, list[float]] = {}
    for spec in specs:
        name, values = parse_axis(spec, max_cases)
        if name in axes:
            raise SweepError(f"grid axis {name!r} is given twice; give each axis once")
        axes[name] = values
    return grid(max_cases, **axes)

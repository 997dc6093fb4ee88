"""Tidy tables of sweep results: one flat dict per case, CSV, and a pandas DataFrame.

:func:`table` flattens the rows of a results file (nested result dicts become ``a.b`` columns);
:func:`write_csv` writes it; :func:`to_dataframe` and :func:`read_dataframe` give a
:class:`pandas.DataFrame` (pandas is the optional ``frames`` extra, in ``.[all]``) — one call from
a results file to a data frame::

    from porthamiltonian.batch import read_dataframe
    df = read_dataframe("msd.jsonl")          # index case_id; columns k, c, status, ...
"""
from __future__ import annotations

import csv
import json
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pandas is optional (the frames extra)
    import pandas as pd

__all__ = ["read_dataframe", "table", "to_dataframe", "write_csv"]


def _flatten(prefix: str, value: Any, out: dict) -> None:
    if isinstance(value, dict) and value:
        for k, v in value.items():
            _flatten(f"{prefix}.{k}" if prefix else str(k), v, out)
    else:
        out[prefix] = value


def _flat_row(row: dict) -> dict:
    out: dict[str, Any] = {"case_id": row["case_id"], **row["case"], "status": row["status"]}
    result = row.get("result") or {}
    message = row.get("message") or result.get("message")
    flat: dict[str, Any] = {}
    for key, value in result.items():
        if key not in ("status", "message"):
            _flatten(key, value, flat)
    for key, value in flat.items():
        out[f"result.{key}" if key in out else key] = value
    out["message"] = message
    out["seconds"] = row.get("seconds")
    return out


def table(rows: Iterable[dict[str, Any]], cases: Sequence[Mapping[str, Any]] | None = None, *,
          pending: bool = False) -> list[dict]:
    """One flat dict per case, in case order: ``case_id``, the case's values, ``status``, the
    result's fields (nested dicts flattened as ``a.b``; a field named like a case value becomes
    ``result.NAME``), ``message`` (the result's, or the error's) and ``seconds``. With ``cases``
    and ``pending=True``, cases with no row appear with status ``"pending"``. The first row of a
    case counts."""
    by_id: dict[int, dict[str, Any]] = {}
    for row in rows:
        by_id.setdefault(row["case_id"], row)
    ids = range(len(cases)) if cases is not None else sorted(by_id)
    out = []
    for cid in ids:
        first = by_id.get(cid)
        if first is not None:
            out.append(_flat_row(first))
        elif pending and cases is not None:
            out.append({"case_id": cid, **cases[cid], "status": "pending"})
    return out


def _csv_value(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (list, dict)):
        return json.dumps(value, allow_nan=False)
    return str(value)


def write_csv(rows: Sequence[Mapping[str, Any]], path: str | Path) -> Path:
    """Write table rows as CSV: the union of the rows' columns in first-seen order; empty for
    null, floats at full precision, true/false, lists as JSON."""
    columns: dict[str, None] = {}
    for row in rows:
        columns.update(dict.fromkeys(row))
    path = Path(path)
    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(list(columns))
        for row in rows:
            writer.writerow([_csv_value(row.get(c)) for c in columns])
    return path


def to_dataframe(rows: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
    """Table rows as a :class:`pandas.DataFrame` indexed by ``case_id`` (null values as NaN in
    numeric columns)."""
    try:
        import pandas as pd
    except ImportError:
        from .errors import SweepError
        raise SweepError("data frames need pandas: pip install 'porthamiltonian[frames]'") from None
    columns: dict[str, None] = {}
    for row in rows:
        columns.update(dict.fromkeys(row))
    frame = pd.DataFrame([dict(r) for r in rows], columns=list(columns))
    return frame.set_index("case_id") if "case_id" in frame else frame


def read_dataframe(path: str | Path) -> pd.DataFrame:
    """The tidy table of a results file as a pandas DataFrame (see :func:`to_dataframe`), rows
    in case order. Only the file is read: no need to rebuild the sweep."""
    from .resultsfile import load_results
    return to_dataframe(table(load_results(path)))

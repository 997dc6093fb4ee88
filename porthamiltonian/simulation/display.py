"""Quick looks in a notebook: compact HTML summaries and one-call plots.

* :func:`trajectory_html`, :func:`model_html`, :func:`sweep_html`, :func:`records_html` — what
  ``_repr_html_`` of :class:`~porthamiltonian.simulation.trajectory.Trajectory`,
  :class:`~porthamiltonian.simulation.compiled.CompiledModel` and :class:`~porthamiltonian.batch.Sweep`
  show in Jupyter: a few short tables (status, ledger, states with units, the first rows), never
  a wall of numbers;
* :func:`plot_trajectory` — ``Trajectory.plot()``: chosen states, outputs or ledger terms over
  time, broken at events (a reset is not part of the flow), units in the labels;
* :func:`event_split` — the continuous pieces of a run (shared with the walker figures).

matplotlib is imported only when something is plotted; plots use pyplot, so a notebook shows
them inline as usual, and return the Axes (as pandas' plots do).
"""
from __future__ import annotations

import html
import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["event_split", "model_html", "plot_trajectory", "records_html", "sweep_html",
           "trajectory_html"]

#: rows shown before "… and N more"
MAX_ROWS = 12
_STYLE = ('style="border-collapse:collapse;font-size:12.5px;margin:2px 0 8px" '
          'class="porthamiltonian"')


def _num(value: Any) -> str:
    if value is None:
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return "—" if not math.isfinite(v) else f"{v:.6g}"
    return str(value)


def _table(head: Sequence[str], rows: Iterable[Sequence[Any]], total: int | None = None) -> str:
    th = "".join(f'<th style="text-align:left;padding:2px 8px">{html.escape(h)}</th>'
                 for h in head)
    body = []
    rows = list(rows)
    for row in rows[:MAX_ROWS]:
        cells = []
        for v in row:
            align = "right" if isinstance(v, (int, float, np.number)) and not isinstance(v, bool) \
                else "left"
            cells.append(f'<td style="text-align:{align};padding:2px 8px">'
                         f"{html.escape(_num(v))}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    n = len(rows) if total is None else total
    more = (f'<tr><td colspan="{len(head)}" style="padding:2px 8px;color:#666">… and '
            f"{n - min(len(rows), MAX_ROWS)} more</td></tr>" if n > MAX_ROWS else "")
    return f"<table {_STYLE}><thead><tr>{th}</tr></thead><tbody>{''.join(body)}{more}</tbody></table>"


def _title(text: str, detail: str = "") -> str:
    extra = f' <span style="color:#666">{html.escape(detail)}</span>' if detail else ""
    return f"<div><b>{html.escape(text)}</b>{extra}</div>"


def trajectory_html(traj: Any) -> str:
    """A trajectory's summary: status, span, points and events; the ledger; the states' final
    values with units."""
    model = traj.model
    t = traj.t
    units = getattr(model, "units", {}) or {}
    events = [name for _, name in traj.events]
    counted = ", ".join(f"{name} ×{events.count(name)}" for name in dict.fromkeys(events))
    head = _title(f"Trajectory of {model.name}",
                  f"{traj.status}: t = {_num(t[0])} … {_num(t[-1])} s, {len(t)} points, "
                  f"{len(events)} event(s){': ' + counted if counted else ''}")
    led = traj.ledger()
    ledger = _table(["H(0) (J)", "H(T) (J)", "dissipated (J)", "supplied (J)",
                     "max |residual| (J)", "relative"],
                    [[led["H0"], led["HT"], led["dissipated"], led["supplied"],
                      led["max_abs_residual"], led["relative_residual"]]])
    x = traj.x_final
    states = _table(["state", "final value", "unit"],
                    [[name, float(x[i]), units.get(name, "")]
                     for i, name in enumerate(model.state_names)])
    return f"<div>{head}{ledger}{states}</div>"


def model_html(model: Any) -> str:
    """A compiled model's summary: back end, states with units, parameters with defaults and
    units, outputs and events (counted, the first few named)."""
    units = getattr(model, "units", {}) or {}
    outputs = list(model.output_names)
    events = ", ".join(e.name for e in model.events) or "none"
    head = _title(f"CompiledModel {model.name}",
                  f"back end {model.backend}; {model.n_states} states, {len(model.param_names)} "
                  f"parameters, {len(outputs)} outputs; events: {events}")
    states = _table(["state", "unit"], [[n, units.get(n, "")] for n in model.state_names])
    params = _table(["parameter", "default", "unit"],
                    [[n, float(v), u] for n, v, u in zip(model.param_names, model.param_defaults,
                                                        model.param_units)])
    return f'<div>{head}<div style="display:flex;gap:24px;flex-wrap:wrap">{states}{params}</div></div>'


def records_html(rows: Sequence[Mapping[str, Any]], columns: Sequence[str] | None = None,
                 title: str = "") -> str:
    """A table of flat records (e.g. a sweep's tidy rows), the first :data:`MAX_ROWS` shown."""
    if columns is None:
        seen: dict[str, None] = {}
        for row in rows[:MAX_ROWS]:
            seen.update(dict.fromkeys(row))
        columns = [c for c in seen if c not in ("message", "seconds")][:10]
    body = _table(list(columns), [[row.get(c) for c in columns] for row in rows[:MAX_ROWS]],
                  total=len(rows))
    return (_title(title) if title else "") + body


def sweep_html(sweep: Any) -> str:
    """A sweep's summary: its file, cases done by status, the first rows of its table."""
    rows = sweep.table()
    counts: dict[str, int] = {}
    for row in rows:
        counts[row["status"]] = counts.get(row["status"], 0) + 1
    status = ", ".join(f"{k} {v}" for k, v in sorted(counts.items())) or "nothing run yet"
    head = _title(f"Sweep of {sweep.function_name}",
                  f"{len(rows)} of {len(sweep.cases)} cases in {sweep.path} ({status})")
    return f"<div>{head}{records_html(rows) if rows else ''}</div>"


def event_split(t: np.ndarray) -> list[slice]:
    """The continuous pieces of a recorded run: an event that restarts the integration (a
    reset) stores the state just before it and after it at the same time, so the pieces split
    where the time repeats."""
    cuts = np.flatnonzero(np.diff(t) == 0) + 1
    bounds = [0, *cuts.tolist(), len(t)]
    return [slice(a, b) for a, b in itertools.pairwise(bounds) if b > a]


def plot_trajectory(traj: Any, *names: str, ax: Any = None, events: bool = True) -> Any:
    """Plot states, outputs or ledger terms (``"H"``, ``"E_diss"``, ``"E_in"``,
    ``"residual"``) over time; default: every state. Lines break at events (a reset is not part
    of the flow); ``events`` draws the event times as dotted lines. Returns the Axes."""
    from ..escaping import plain_text

    with plain_text():                  # names and the title are model text: never mathtext
        return _plot(traj, names, ax, events)


def _plot(traj: Any, names: tuple[str, ...], ax: Any, events: bool) -> Any:
    import matplotlib.pyplot as plt

    from .frames import LEDGER_UNITS
    model = traj.model
    names = names or tuple(model.state_names)
    units = {**(getattr(model, "units", {}) or {}), **LEDGER_UNITS}
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 3.5), layout="constrained")
    t = traj.t
    pieces = event_split(t)
    for k, name in enumerate(names):
        y = np.asarray(traj[name])
        unit = units.get(name, "")
        color = f"C{k % 10}"
        for j, piece in enumerate(pieces):
            ax.plot(t[piece], y[piece], color=color,
                    label=(f"{name} ({unit})" if unit else name) if j == 0 else None)
    if events and traj.events:
        for k, (te, _) in enumerate(traj.events):
            ax.axvline(te, color="0.6", ls=":", lw=0.8, label="events" if k == 0 else None)
    shown = {units.get(n, "") for n in names}
    ax.set_xlabel("t (s)")
    if len(shown) == 1 and "" not in shown:
        ax.set_ylabel(f"({shown.pop()})")
    ax.set_title(f"{model.name}: {traj.status}", fontsize=10)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    return ax

"""Quick looks at a gait in a notebook: ``GaitResult._repr_html_`` and ``GaitResult.plot()``
(and ``ContinuationResult.figure``), registered as the results' views when this module is
imported (:func:`walker_library.analyses.results.register_view`; the package imports it).

:func:`gait_html` is a compact summary — the status, the gait metrics and the fixed point with
readable labels and units, the Floquet multipliers to the digits their error estimate supports
(:mod:`walker_library.labels`, :mod:`walker_library.report_page`). :func:`plot_gait` walks the
gait from its fixed point and draws the limit cycle (θ̇ over θ, resets dashed) beside the
multipliers in the complex plane, with pyplot (inline in a notebook); it returns the Axes.
"""
from __future__ import annotations

import html
from types import SimpleNamespace
from typing import Any

import numpy as np

from ..analyses.continuation import ContinuationResult
from ..analyses.gait import GaitResult
from ..analyses.results import register_view
from . import page as P
from .figures import fig_bifurcation
from .labels import METRICS, describe, is_nondimensional, shown_unit

__all__ = ["gait_html", "plot_gait"]


def gait_html(gait: Any, walker: Any = None) -> str:
    """The summary table of a :class:`~walker_library.gait.GaitResult`."""
    nondim = is_nondimensional(walker if walker is not None else _file_of(gait.model))
    head = (f"<div><b>Gait of {html.escape(gait.model)}</b> <span style=\"color:#666\">"
            f"{html.escape(gait.status)}: {html.escape(gait.message)}"
            f"{'; nondimensional model' if nondim else ''}</span></div>")
    m = gait.metrics.to_dict()
    metrics = P.table(["metric", "value", "unit"],
                      [[METRICS[k].label, m[k], shown_unit(METRICS[k].unit, nondim)] for k in
                       ("step_period", "step_length", "speed", "energy_dissipated_per_step",
                        "cost_of_transport") if k in m], numeric=(1,), stack=False)
    parts = [head, '<div style="display:flex;gap:24px;flex-wrap:wrap">', metrics]
    fp = gait.fixed_point or {}
    if gait.status == "periodic":
        keys = [k for k in gait.thesis_section if k in fp]
        parts.append(P.table(["fixed point", "value", "unit"],
                             [[P.named(describe(walker, k).label, k), fp[k],
                               shown_unit(describe(walker, k).unit, nondim)] for k in keys],
                             numeric=(1,), stack=False))
        rows, _ = P.multiplier_cells(gait.floquet_multipliers, gait.multiplier_error)
        parts.append(P.table(["multiplier λ", "|λ|"], rows, numeric=(0, 1), stack=False))
    parts.append("</div>")
    return "".join(parts)


def _file_of(model: str) -> Any:
    """The walker file's description (no compilation) for the labels, or None."""
    from porthamiltonian.errors import ModelError

    from ..core.files import read_walker
    try:
        spec, _ = read_walker(model)
    except (ModelError, OSError):
        return None
    return SimpleNamespace(spec=spec, multibody="")


def plot_gait(gait: Any, walker: Any = None, *, steps: int = 2) -> Any:
    """Limit cycle (``steps`` steps from the fixed point) and multipliers, side by side; returns
    the two Axes. ``walker``: the walker the gait belongs to (default: loaded by the gait's model
    name and parameters). A gait that is not periodic gets its message instead."""
    import matplotlib.pyplot as plt

    from ..analyses.series import walk_series
    from ..core.files import load_walker
    from .figures import STYLE, draw_multipliers, draw_phase
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(1, 2, figsize=(9, 3.8), layout="constrained")
        if gait.status != "periodic":
            for ax in axes:
                ax.set_axis_off()
            axes[0].text(0, 0.5, f"{gait.model}: {gait.status}\n{gait.message}", fontsize=9,
                         wrap=True)
            return axes
        if walker is None:
            walker = load_walker(gait.model, gait.parameters)
        z = np.array([gait.fixed_point[k] for k in walker.section])
        period = gait.metrics.step_period
        series = walk_series(walker, z, steps, max_step=period / 150 if period > 0 else None)
        draw_phase(axes[0], series, "theta", is_nondimensional(walker), labels=True)
        axes[0].legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncols=2)
        draw_multipliers(axes[1], gait.floquet_multipliers, gait.multiplier_error)
        axes[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
        fig.suptitle(f"{gait.model}: {gait.message}", fontsize=10)
    return axes


register_view(GaitResult, "html", gait_html)
register_view(GaitResult, "plot", plot_gait)
register_view(ContinuationResult, "figure", fig_bifurcation)

"""The report's figures (matplotlib, Agg back end, PNG): angles, limit cycle, energy ledger,
energy per step, Floquet multipliers, step-down, basin of attraction, bifurcation diagram.

Conventions of every figure: a reset (a heel strike relabels the legs and, for a rigid walker,
applies the impact) is not part of the flow, so curves break at events and the jump is drawn
dashed; heel strikes are marked (dotted lines in time plots, open/filled circles just before and
after on phase portraits); other events (a foot lifting off, the mid-stance scuff) get small
ticks; legends sit outside the data. Units follow :mod:`walker_library.labels` (``nondim`` for
a nondimensional model). Each ``fig_*`` function writes ``path`` and returns the PNG's bytes.

matplotlib is imported when a figure is drawn, never at import time (the ``plots`` extra). The
figures are :class:`matplotlib.figure.Figure` objects drawn without pyplot, so making a report
neither needs a display nor changes the back end of an interactive session (a notebook).
"""
from __future__ import annotations

import io
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any, ParamSpec, TypeVar

import numpy as np

from porthamiltonian.escaping import PLAIN_TEXT
from porthamiltonian.simulation.display import event_split

from ..analyses.series import GaitSeries
from .labels import shown_unit

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["DPI", "STYLE", "draw_multipliers", "draw_phase", "event_split", "fig_angles", "fig_basin",
           "fig_bifurcation", "fig_energy", "fig_energy_per_step",
           "fig_floquet", "fig_limit_cycle", "fig_step_down", "heel_strike_points", "pyplot",
           "save_figure"]

DPI = 110
#: matplotlib settings of the report's figures (no mathtext: names and units from model files
#: are plain text; the figures' own mathematical labels ask for it, porthamiltonian.escaping)
STYLE: dict[Any, Any] = {"font.size": 9, "axes.titlesize": 10, "legend.fontsize": 8,
                         "axes.spines.top": False, "axes.spines.right": False, **PLAIN_TEXT}
_P = ParamSpec("_P")
_R = TypeVar("_R")
_JUMP: dict[str, Any] = {"ls": (0, (3, 2)), "lw": 0.9, "alpha": 0.8}
_HEEL: dict[str, Any] = {"color": "0.35", "ls": ":", "lw": 0.9}


def pyplot() -> ModuleType:
    """matplotlib.pyplot on the Agg back end (no window), with the report's style (for scripts
    that draw with pyplot, e.g. the reproduction studies)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    plt.rcParams.update(STYLE)
    return plt


def new_figure(**kw: Any) -> Figure:
    """A :class:`matplotlib.figure.Figure` in the report's style, constrained layout, no pyplot
    (``kw``: Figure's arguments, e.g. ``figsize``). Draw inside :func:`styled`."""
    from matplotlib.figure import Figure
    return Figure(layout=kw.pop("layout", "constrained"), **kw)


def styled(fn: Callable[_P, _R]) -> Callable[_P, _R]:
    """Run a figure function inside the report's matplotlib style (:data:`STYLE`)."""
    import functools

    @functools.wraps(fn)
    def wrapper(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        import matplotlib
        with matplotlib.rc_context(STYLE):
            return fn(*args, **kwargs)
    return wrapper


def save_figure(fig: Figure, path: Path | None) -> bytes:
    """The figure as PNG bytes (written to ``path`` if given); a pyplot figure is closed."""
    import sys
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    if "matplotlib.pyplot" in sys.modules:
        sys.modules["matplotlib.pyplot"].close(fig)
    data = buf.getvalue()
    if path is not None:
        Path(path).write_bytes(data)
    return data


def heel_strike_points(s: GaitSeries) -> list[tuple[int, int]]:
    """(index just before, index just after) of each heel strike of the series."""
    out = []
    for te in s.step_times:
        at = np.flatnonzero(np.abs(s.t - te) <= 1e-12 * max(1.0, abs(te)))
        if len(at) >= 2:
            out.append((int(at[0]), int(at[-1])))
    return out


def _other_events(s: GaitSeries) -> list[tuple[float, str]]:
    """The events that end no step (a foot lifting off, the mid-stance scuff, ...)."""
    strikes = s.step_times
    return [(t, name) for t, name in s.events
            if not np.any(np.abs(strikes - t) <= 1e-12 * max(1.0, abs(t)))]


def _flow(ax: Axes, x: np.ndarray, y: np.ndarray, pieces: Sequence[slice], color: str,
          label: str | None, lw: float = 1.3) -> None:
    """Draw ``y(x)`` piece by piece, each reset between pieces dashed when it jumps."""
    for k, piece in enumerate(pieces):
        ax.plot(x[piece], y[piece], color=color, lw=lw, label=label if k == 0 else None)
        if k + 1 < len(pieces):
            a, b = piece.stop - 1, pieces[k + 1].start
            if abs(y[b] - y[a]) + abs(x[b] - x[a]) > 1e-9 * (1 + np.nanmax(np.abs(y))):
                ax.plot([x[a], x[b]], [y[a], y[b]], color=color, **_JUMP)


def _mark_events(ax: Axes, s: GaitSeries, with_labels: bool = True) -> None:
    for k, te in enumerate(s.step_times):
        ax.axvline(te, **_HEEL, label="heel strike" if with_labels and k == 0 else None)
    others = _other_events(s)
    if others:
        names = ", ".join(sorted({name.rstrip("0123456789") for _, name in others}))
        ax.plot([t for t, _ in others], np.zeros(len(others)), "|", color="0.45", ms=7, mew=1.2,
                transform=ax.get_xaxis_transform(), clip_on=False,
                label=f"events that end no step ({names})" if with_labels else None)


def _jump_legend_entry(ax: Axes) -> None:
    ax.plot([], [], color="0.3", **_JUMP, label="reset at heel strike (a jump, not flow)")


@styled
def fig_angles(s: GaitSeries, path: Path | None, nondimensional: bool = False) -> bytes:
    """θ and φ over time."""
    fig = new_figure(figsize=(7.5, 3.4))
    ax = fig.subplots()
    pieces = event_split(s.t)
    _flow(ax, s.t, s.theta, pieces, "C0", "θ stance-leg angle")
    if np.any(np.isfinite(s.phi)):
        _flow(ax, s.t, s.phi, pieces, "C1", "φ angle between the legs")
    _jump_legend_entry(ax)
    _mark_events(ax, s)
    ax.set_xlabel(f"t ({shown_unit('s', nondimensional)})")
    ax.set_ylabel("angle (rad)")
    fig.legend(loc="outside upper center", ncols=2, frameon=False)
    return save_figure(fig, path)


@styled
def fig_limit_cycle(s: GaitSeries, path: Path | None, nondimensional: bool = False) -> bytes:
    """Phase portraits (θ̇ over θ, φ̇ over φ): the flow solid, the heel-strike resets dashed."""
    legged = bool(np.any(np.isfinite(s.phi)))
    fig = new_figure(figsize=(7.5 if legged else 4.2, 3.6))
    axes = fig.subplots(1, 2 if legged else 1, squeeze=False)[0]
    draw_phase(axes[0], s, "theta", nondimensional, labels=True)
    if legged:
        draw_phase(axes[1], s, "phi", nondimensional)
    fig.legend(loc="outside lower center", ncols=4 if legged else 2, frameon=False)
    return save_figure(fig, path)


def draw_phase(ax: Axes, s: GaitSeries, angle: str, nondimensional: bool = False,
               labels: bool = False) -> None:
    """One phase portrait (``angle`` "theta" or "phi") on ``ax``: the flow solid, the
    heel-strike resets dashed, the states just before (open) and after (filled) marked;
    ``labels``: with legend labels."""
    x, y = getattr(s, angle), getattr(s, f"{angle}_dot")
    symbol, color, title = ((r"\theta", "C0", "stance leg") if angle == "theta"
                            else (r"\varphi", "C1", "between the legs"))
    _flow(ax, x, y, event_split(s.t), color, "flow (one curve per step)" if labels else None)
    strikes = heel_strike_points(s)
    if strikes:
        pre = [a for a, _ in strikes]
        post = [b for _, b in strikes]
        ax.plot(x[pre], y[pre], "o", mfc="white", mec="k", ms=5, zorder=3,
                label="just before heel strike" if labels else None)
        ax.plot(x[post], y[post], "o", color="k", ms=4, zorder=3,
                label="just after heel strike" if labels else None)
    if labels:
        ax.plot([], [], color="0.3", **_JUMP, label="heel-strike reset (jump, not flow)")
    ax.set_xlabel(f"${symbol}$ (rad)", parse_math=True)       # our own mathtext: asked for
    ax.set_ylabel(f"$\\dot{{{symbol}}}$ ({'nondim.' if nondimensional else 'rad/s'})",
                  parse_math=True)
    ax.set_title(title)


@styled
def fig_energy(s: GaitSeries, path: Path | None, nondimensional: bool = False) -> bytes:
    """The energy ledger over time, and its residual."""
    unit = shown_unit("J", nondimensional)
    fig = new_figure(figsize=(7.5, 5.2))
    a, b = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [3, 1.2]})
    pieces = event_split(s.t)
    _flow(a, s.t, s.V - s.V[0], pieces, "C0", "potential V − V(0)")
    _flow(a, s.t, s.T, pieces, "C1", "kinetic T")
    _flow(a, s.t, s.H - s.H[0], pieces, "C2", "total H − H(0)")
    a.plot(s.t, s.E_diss, color="C3", lw=1.3, label="dissipated E_diss")
    if np.any(s.E_in != 0):
        a.plot(s.t, s.E_in, color="C4", lw=1.3, label="supplied E_in")
    _mark_events(a, s)
    a.set_ylabel(f"energy ({unit})")
    top = float(np.max(np.abs(s.residual), initial=0.0))
    e = math.floor(math.log10(top)) if top > 0 else 0
    b.plot(s.t, s.residual / 10.0**e, color="k", lw=0.8)
    _mark_events(b, s, with_labels=False)
    power = "" if e == 0 else "10" + str(e).translate(str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")) + " "
    b.set_ylabel(f"residual ({power}{unit})")
    b.set_xlabel(f"t ({shown_unit('s', nondimensional)})")
    b.set_title("ledger residual H − H(0) + E_diss − E_in (zero up to integration error)",
                fontsize=8, loc="left")
    fig.legend(loc="outside upper center", ncols=3, frameon=False)
    return save_figure(fig, path)


@styled
def fig_energy_per_step(s: GaitSeries, path: Path | None, nondimensional: bool = False) -> bytes:
    """Energy dissipated and potential energy released, step by step."""
    steps = [x for x in s.strides if not x.fell]
    k = np.arange(1, len(steps) + 1)
    fig = new_figure(figsize=(6, 2.9))
    ax = fig.subplots()
    ax.bar(k - 0.2, [x.energy_dissipated for x in steps], 0.4, label="dissipated")
    ax.bar(k + 0.2, [x.potential_released for x in steps], 0.4, label="potential released")
    ax.set_xlabel("step")
    ax.set_xticks(k)
    ax.set_ylabel(f"energy per step ({shown_unit('J', nondimensional)})")
    fig.legend(loc="outside upper center", ncols=2, frameon=False)
    return save_figure(fig, path)


def _clusters(points: np.ndarray, radius: float) -> list[list[int]]:
    """Indices of points grouped when closer than ``radius`` (single linkage)."""
    groups: list[list[int]] = []
    for i, p in enumerate(points):
        near = [g for g in groups if min(abs(points[j] - p) for j in g) < radius]
        merged = [i] + [j for g in near for j in g]
        groups = [g for g in groups if g not in near] + [merged]
    return groups


@styled
def fig_floquet(multipliers: Sequence[complex], error: float, path: Path | None) -> bytes:
    """The Floquet multipliers in the complex plane with the unit circle (the stability limit)
    and the disc |λ| < ε of the error estimate; overlapping multipliers are counted (×n)."""
    fig = new_figure(figsize=(4.4, 4.2))
    draw_multipliers(fig.subplots(), multipliers, error)
    fig.legend(loc="outside lower center", ncols=2, frameon=False)
    return save_figure(fig, path)


def draw_multipliers(ax: Axes, multipliers: Sequence[complex], error: float) -> None:
    """The multipliers on ``ax`` (see :func:`fig_floquet`), with legend labels."""
    from matplotlib.patches import Circle
    m = np.asarray(multipliers, dtype=complex)
    u = np.linspace(0, 2 * math.pi, 361)
    ax.plot(np.cos(u), np.sin(u), color="0.45", lw=1, label="unit circle |λ| = 1")
    eps = float(error) if error is not None and math.isfinite(error) else 0.0
    small = np.abs(m) < eps
    if eps > 0:
        ax.add_patch(Circle((0, 0), max(eps, 0.012), color="C0", alpha=0.25, lw=0,
                            label=f"|λ| < ε = {eps:.1g} (error estimate)"))
    big = m[~small]
    ax.plot(big.real, big.imag, "o", mfc="none", mec="C3", mew=1.5, ms=8, label="multiplier λ")
    for group in _clusters(big, 0.04):
        if len(group) > 1:
            c = big[group[0]]
            ax.annotate(f"×{len(group)}", (c.real, c.imag), xytext=(7, 5),
                        textcoords="offset points", color="C3", fontsize=8)
    if np.any(small):
        ax.annotate(f"{int(small.sum())} with |λ| < ε", (0, 0), xytext=(10, -14),
                    textcoords="offset points", color="C0", fontsize=8)
    lim = max(1.15, 1.1 * float(np.max(np.abs(m), initial=0.0)))
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_aspect("equal")
    ax.axhline(0, color="0.85", lw=0.6, zorder=0)
    ax.axvline(0, color="0.85", lw=0.6, zorder=0)
    ax.set_xlabel("Re λ")
    ax.set_ylabel("Im λ")


@styled
def fig_step_down(r: Any, path: Path | None, nondimensional: bool = False) -> bytes:
    """The step-down cases (mm): survived or fell, and the largest drop survived."""
    scale, unit = (1.0, "nondim.") if nondimensional else (1e3, "mm")
    fig = new_figure(figsize=(7, 2.3))
    ax = fig.subplots()
    colors = {"converged": "C2", "fell": "C3", "wandered": "C1", "invalid": "0.5"}
    for status, color in colors.items():
        h = [c["h"] * scale for c in r.cases if c["status"] == status]
        if h:
            ax.plot(h, np.zeros(len(h)), "o", color=color, ms=6, label=status)
    if r.max_step_down:
        ax.axvline(r.max_step_down * scale, color="0.4", ls="--", lw=0.9,
                   label=f"largest survived: {r.max_step_down * scale:.3g} {unit}")
    ax.set_yticks([])
    ax.spines["left"].set_visible(False)
    ax.set_xlabel(f"step-down height h ({unit})")
    fig.legend(loc="outside upper center", ncols=5, frameon=False)
    return save_figure(fig, path)


@styled
def fig_basin(r: Any, path: Path | None) -> bytes:
    """The basin grid in the thesis's scaled coordinates."""
    fig = new_figure(figsize=(4.8, 4.6))
    ax = fig.subplots()
    th = np.array(r.theta) / r.theta_scale
    thd = np.array(r.theta_dot) / r.theta_dot_scale
    ok = np.array([[o == "converged" for o in row] for row in r.outcome])
    A, B = np.meshgrid(th, thd, indexing="ij")
    ax.plot(A[ok], B[ok], "*", color="C2", ms=8, label="converges to the gait")
    ax.plot(A[~ok], B[~ok], ".", color="0.5", ms=5, label="falls or wanders")
    ax.plot(r.fixed_point["theta"] / r.theta_scale, r.fixed_point["theta_dot"] / r.theta_dot_scale,
            "*", color="C3", ms=13, label="fixed point")
    ax.set_xlabel(f"$\\theta$ / {r.theta_scale:g} rad", parse_math=True)
    ax.set_ylabel(f"$\\dot{{\\theta}}$ / {r.theta_dot_scale:g} rad/s", parse_math=True)
    fig.legend(loc="outside lower center", ncols=3, frameon=False)
    return save_figure(fig, path)


def _runs(points: Sequence[Any]) -> list[list[Any]]:
    """Consecutive branch points of equal stability (each run shares its end point with the
    next)."""
    runs: list[list[Any]] = []
    for p in points:
        if runs and runs[-1][-1].stable != p.stable:
            runs[-1].append(p)
            runs.append([p])
        elif runs:
            runs[-1].append(p)
        else:
            runs.append([p])
    return runs


@styled
def fig_bifurcation(c: Any, path: Path | None) -> bytes:
    """The bifurcation diagram of a continuation (:class:`.continuation.ContinuationResult`):
    max |λ| (top) and each step's duration of the orbit (bottom, s) against the parameter;
    stable solid, unstable dashed; bifurcations marked."""
    fig = new_figure(figsize=(7, 6))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    top = 1.0
    for i, br in enumerate(c.branches):
        color = f"C{i % 10}"
        for run in _runs(br.points):
            style = "-" if run[0].stable else "--"
            mu = [p.mu for p in run]
            ax1.plot(mu, [p.max_modulus for p in run], style, color=color, lw=1.2)
            for k in range(br.period):
                ax2.plot(mu, [p.durations[k] for p in run], style, color=color, lw=1.2)
        top = max([top] + [p.max_modulus for p in br.points])
        ax1.plot([], [], "-", color=color, label=f"branch {i}: period {br.period}")
    marks = {"flip": "o", "fold": "s", "branch_point": "^", "neimark_sacker": "D"}
    for b in c.bifurcations:
        ax1.plot(b.mu, abs(b.multiplier), marks[b.kind], color="k", ms=5, mfc="none")
        for d in b.point.durations:
            ax2.plot(b.mu, d, marks[b.kind], color="k", ms=5, mfc="none")
    for kind, m in marks.items():
        if any(b.kind == kind for b in c.bifurcations):
            ax1.plot([], [], m, color="k", mfc="none", label=kind.replace("_", "–"))
    ax1.axhline(1.0, color="0.5", lw=0.7)
    ax1.set_ylim(0.0, min(top, 3.0) * 1.05)
    ax1.set_ylabel("max |Floquet multiplier|")
    ax1.legend(fontsize=7)
    ax2.set_ylabel("duration of each step (s)")
    unit = f" ({c.path.unit})" if c.path.unit and c.path.unit != "1" else ""
    ax2.set_xlabel(f"{c.path.label}{unit}")
    ax1.set_title(f"{c.model}: bifurcation diagram (solid: stable, dashed: unstable)")
    return save_figure(fig, path)

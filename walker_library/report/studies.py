"""The thesis's results, reproduced on our models: named studies run by ``walker reproduce``.

Each :class:`Study` rebuilds one table or figure group of the thesis (M. Jafarian 2010,
"Variable stiffness for robust and energy efficient 2D bipedal locomotion", MSc report 022CE2010,
University of Twente; the walkers are described in docs/walkers.md) and writes into
``OUT/<study>/``: its sweeps' results files
(JSON Lines, resumable: see :mod:`porthamiltonian.batch`), its figures (PNG) and ``summary.json``
— the thesis's numbers beside ours where the thesis states them (``rows``: quantity, ours,
thesis, unit, deviation). ``OUT/reproduction.json`` collects the summaries.

Studies (``walker reproduce --list``):

=====================  ==========================================================================
table_2_3              nominal walker at γ = 0.009: step period, step length, speed, max θ, max φ,
                       energy per step, max step-down (Table 2.3)
damping_calibration    energy dissipated per impact over the contact damping λ; the calibrated λ
                       (§2.3.2, Fig. 2.12)
time_plots             θ/φ over time, limit cycles, energies over steps (Figs. 2.13–2.15, 2.17–2.18)
slope_multipliers      continuation over the slope: multipliers, the flip (period-1/period-2
                       boundary) located, the period-2/4 branches; walker gait from the default
                       guess at each slope of the table (Table 2.2)
rigid_bifurcations     the simplest walker's and the compass gait's branches over the slope: flips
                       located, period-2/4 branches (the compass gait's to period 8), the unstable
                       short-period gait (Garcia et al. 1998, Goswami et al. 1998)
step_down_slope        maximum step-down over the slope (Fig. 2.22)
basin                  basin of attraction at γ = 0.007 and 0.012 (Figs. 2.21, 2.23)
damper_factor          compliant leg: stable stiffness range and step-down over α (Fig. 3.3)
leg_stiffness          compliant leg at α = 0.15: step-down, speed, energy per step over K, and
                       robustness over speed, rigid (over slope) vs compliant (over K); the gait
                       continued in K (lowest stable K, period doubling) (Figs. 3.4–3.6)
variable_stiffness     K1 → K2 against constant K (φ_max from each K1's own constant gait):
                       speed, step-down, F–Δz loop, injected energy (Figs. 3.7–3.8, Table 3.1)
recommendations        the thesis's §4.2: step-down over foot radius, hip stiffness and ankle
                       stiffness around the nominal walker, against the rigid-leg walker
compliance_3d          the thesis's closing question in 3D: step-down and lateral pushes (roll
                       rate, lateral hip velocity) survived over K_leg, 3D compliant against 3D
                       rigid legs (compliant_leg_walker_3d, compass_walker_3d)
kneed_walker           beyond the thesis: Hsu Chen's kneed walker (M.Eng. thesis, MIT 2007) — its
                       fixed point, step period and eigenvalues beside the published ones, the
                       angles and multipliers; over the slope the fold and period doublings
=====================  ==========================================================================

``quick=True`` runs every study on coarse grids (the tests use it); the full grids are the
defaults. Sweeps run through a process pool by default (``workers``), serially with
``serial=True``, or through any executor (e.g. a dask client's).
"""
from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from porthamiltonian.batch import Sweep
from porthamiltonian.errors import ModelError
from porthamiltonian.userfiles import make_folder

from ..analyses.cases import basin_case, step_down_case, walker_cache
from ..analyses.continuation import ContinuationResult, continue_gait
from ..analyses.gait import analyze_gait, gait_start
from ..analyses.monodromy import floquet
from ..analyses.poincare import find_fixed_point
from ..analyses.results import to_json, to_jsonable
from ..analyses.robustness import recovers, step_down
from ..analyses.series import walk_series
from .figures import (
    fig_angles,
    fig_bifurcation,
    fig_energy,
    fig_energy_per_step,
    fig_floquet,
    fig_limit_cycle,
    pyplot,
    save_figure,
)

if TYPE_CHECKING:
    from ..core.walker import HybridWalker

__all__ = ["STUDIES", "Study", "StudyContext", "run_studies"]

NOMINAL = "compass_walker"
RIGID_SLOPES = (0.002, 0.004, 0.006, 0.007, 0.008, 0.009, 0.010, 0.011, 0.012, 0.013, 0.014,
                0.015, 0.016, 0.017)


@dataclass
class StudyContext:
    """Where a study writes and how it runs its sweeps."""

    out: Path
    quick: bool = False
    workers: int | None = None
    serial: bool = False
    executor: Executor | None = None
    progress: str = "auto"
    log: Callable[[str], None] = print

    def sweep(self, name: str, function: Callable, cases: list[dict], *, study: str | None = None,
              shared: dict | None = None, **fixed: Any) -> list[dict]:
        """Run (or resume) a sweep into ``<study dir>/<name>.jsonl`` (``study``: another
        study's directory, to share its sweep; ``shared``: the sweep's shared arguments, see
        :class:`porthamiltonian.batch.Sweep`); rows in case order."""
        where = self.out if study is None else self.out.parent / study
        where.mkdir(parents=True, exist_ok=True)
        sw = Sweep(function, cases, where / f"{name}.jsonl", fixed=fixed, shared=shared)
        sw.run(self.executor, workers=self.workers, serial=self.serial, progress=self.progress)
        return sw.table()

    def path(self, name: str) -> Path:
        """The file ``name`` in the study's directory."""
        return self.out / name


@dataclass
class Study:
    """A named reproduction: ``run(ctx) -> summary dict`` (JSON-able, with ``rows`` comparing
    with the thesis where it states numbers)."""

    name: str
    title: str
    thesis: str
    run: Callable[[StudyContext], dict]
    models: tuple[str, ...] = field(default_factory=tuple)


def _row(quantity: str, ours: Any, thesis: Any, unit: str, note: str = "") -> dict:
    dev = None
    if isinstance(ours, (int, float)) and isinstance(thesis, (int, float)) and thesis:
        dev = (float(ours) - thesis) / abs(thesis)
    return {"quantity": quantity, "ours": ours, "thesis": thesis, "unit": unit, "deviation": dev,
            "note": note}


def _mm(rows: list[dict]) -> list[float]:
    """Each row's max_step_down in mm (NaN where there is none)."""
    return [np.nan if r.get("max_step_down") is None else 1e3 * r["max_step_down"] for r in rows]


def _at_nominal_slope(rows: list[dict]) -> dict:
    """The row of a sweep over the slope at the nominal γ = 0.009 ({} if absent)."""
    return next((r for r in rows if abs(r["slope"] - 0.009) < 1e-12), {})


def _walker(name: str, **params: float) -> HybridWalker:
    from ..core.files import load_walker
    return load_walker(name, params or None, backend=None)


def _save_axes(fig: Any, ax: Any, path: Path, xlabel: str, ylabel: str, title: str, *,
               title_size: int = 10, legend: int = 8) -> None:
    """Label ``ax`` (its axes, its title in ``title_size`` pt, its legend in ``legend`` pt; 0: no
    legend), lay ``fig`` out and save it to ``path``."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=title_size)
    if legend:
        ax.legend(fontsize=legend)
    fig.tight_layout()
    save_figure(fig, path)


def _plot_xy(path: Path, xs: Sequence[float], series: dict[str, list], xlabel: str, ylabel: str, title: str,
             hlines: dict[str, float] | None = None) -> None:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 3.6))
    for label, ys in series.items():
        ax.plot(xs, [np.nan if y is None else y for y in ys], "o-", label=label, ms=4)
    for label, y in (hlines or {}).items():
        ax.axhline(y, ls="--", lw=0.8, color="0.4")
        ax.text(xs[0], y, f" {label}", fontsize=7, va="bottom")
    _save_axes(fig, ax, path, xlabel, ylabel, title, legend=8 if len(series) > 1 else 0)


# --- Table 2.3 -----------------------------------------------------------------------------------
def run_table_2_3(ctx: StudyContext) -> dict:
    w = _walker(NOMINAL)
    gait = analyze_gait(w)
    sd = step_down(w, gait, resolution=2e-4 if ctx.quick else 1e-4)
    m = gait.metrics
    rows = [
        _row("step period", m.step_period, None, "s", "lost from the thesis text"),
        _row("step length", m.step_length, None, "m", "lost from the thesis text"),
        _row("speed", m.speed, 0.274, "m/s"),
        _row("max θ", m.max_theta, None, "rad", "lost from the thesis text"),
        _row("max φ", m.max_phi, None, "rad", "lost from the thesis text"),
        _row("energy dissipated per step", m.energy_dissipated_per_step, 0.08, "J"),
        _row("max step-down", sd.max_step_down, 0.0024, "m",
             f"grid {sd.resolution * 1e3:g} mm, boundaries bisected to "
             f"{sd.boundary_tol * 1e3:g} mm; contiguous: {sd.contiguous}"),
        _row("largest |Floquet multiplier|",
             max(abs(complex(x)) for x in gait.floquet_multipliers), None, "1"),
        _row("contact stiffness K", w.parameters["K"], 1.0e6, "N/m", "App. A"),
        _row("contact damping λ", w.parameters["lam"], None, "N·s/m²",
             "lost in the thesis; calibrated its way (damping_calibration)"),
    ]
    (ctx.out / "gait.json").write_text(gait.to_json())
    (ctx.out / "step_down.json").write_text(sd.to_json())
    return {"rows": rows, "gait_status": gait.status, "step_down_contiguous": sd.contiguous}


# --- Fig. 2.12 ----------------------------------------------------------------------------------
def run_damping_calibration(ctx: StudyContext) -> dict:
    from ..analyses.calibration import calibrate_damping
    w = _walker(NOMINAL)
    lams = np.logspace(5, 10, 6 if ctx.quick else 21)
    cal = calibrate_damping(w, lams=lams)
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 3.4))
    ax.semilogx(cal.lam, cal.dissipated, "o-")
    ax.axvline(cal.calibrated_lam, ls="--", color="C3", lw=0.8)
    _save_axes(fig, ax, ctx.path("fig_2_12_dissipation_over_lambda.png"),
               "Hunt–Crossley damping λ (N·s/m²)", "energy dissipated per impact (J)",
               f"calibrated λ = {cal.calibrated_lam:.3g} (smallest λ within {cal.rel_tol:g} of "
               "the maximum)", title_size=9, legend=0)
    (ctx.out / "calibration.json").write_text(to_json(cal.to_dict()))
    return {"rows": [_row("calibrated λ", cal.calibrated_lam, None, "N·s/m²",
                          "the thesis's value is lost ('e7' in App. A)"),
                     _row("max dissipation per impact", cal.max_dissipated, 0.08, "J",
                          "thesis: energy per step")]}


# --- Figs. 2.13–2.18 -----------------------------------------------------------------------------
def run_time_plots(ctx: StudyContext) -> dict:
    w = _walker(NOMINAL)
    gait = analyze_gait(w)
    z = np.array([gait.fixed_point[k] for k in w.section])
    s = walk_series(w, z, 3 if ctx.quick else 8, max_step=gait.metrics.step_period / 150)
    fig_angles(s, ctx.path("fig_2_13_angles.png"))
    fig_limit_cycle(s, ctx.path("fig_2_14_2_15_limit_cycle.png"))
    fig_energy(s, ctx.path("fig_2_17_2_18_energy.png"))
    fig_energy_per_step(s, ctx.path("energy_per_step.png"))
    return {"rows": [_row("max |ledger residual| over the walk", float(np.max(np.abs(s.residual))),
                          None, "J"),
                     _row("steps", len(s.strides), None, "1")]}


# --- Table 2.2 -----------------------------------------------------------------------------------
def _slopes(ctx: StudyContext) -> list[float]:
    return [0.004, 0.009, 0.014, 0.017] if ctx.quick else list(RIGID_SLOPES) + [0.018, 0.019, 0.020]


def _branch_rows(result: ContinuationResult, label: str) -> list[dict]:
    """The continuation's points as table rows (no section coordinates)."""
    keep = ("branch", "period_steps", label, "max_multiplier", "stable", "step_period")
    return [{k: r[k] for k in keep} for r in result.table()]


def _default_guess_gaits(ctx: StudyContext, model: str, key: str, values: list[float],
                         result: ContinuationResult) -> list[dict]:
    """``walker gait`` from the default guess at each value (its full search: guess, iteration,
    continuation from the file's nominal gait), beside what the continuation found there: a
    stable orbit on some branch (and its period)."""
    rows = []
    for v in values:
        w = _walker(model, **{key: v})
        g = analyze_gait(w)
        stable_here = _stable_on_branches(result, v)
        rows.append({key: v, "outcome": g.outcome, "period_steps": g.period_steps,
                     "stable": g.stable,
                     "max_multiplier": max((abs(complex(m)) for m in g.floquet_multipliers),
                                           default=None),
                     "speed": g.metrics.speed,
                     "continuation_stable_periods": stable_here})
        ctx.log(f"  walker gait {model} --set {key}={v:g}: {g.outcome} (period "
                f"{g.period_steps}); continuation: stable periods {stable_here}")
    return rows


def _stable_on_branches(result: ContinuationResult, value: float) -> list[int]:
    """Periods of the branches with a stable orbit at ``value`` (interpolated between two
    stable neighbouring points)."""
    periods = set()
    for br in result.branches:
        for a, b in zip(br.points, br.points[1:]):
            if min(a.mu, b.mu) <= value <= max(a.mu, b.mu) and a.stable and b.stable:
                periods.add(br.period)
    return sorted(periods)


def run_slope_multipliers(ctx: StudyContext) -> dict:
    """Table 2.2 / §2.5 on the continuation of the nominal walker's gait over the slope
    (:func:`~.continuation.continue_gait`): the period-1 branch with its multipliers, the flip
    (period doubling) located, the period-2 (and period-4) branches switched onto, unstable
    branches followed; and ``walker gait`` from the default guess at each slope of the table."""
    lo, hi = (0.009, 0.014) if ctx.quick else (0.002, 0.020)
    w0 = _walker(NOMINAL)
    z0, period = gait_start(w0, "slope", lo)
    result = continue_gait(w0, "slope", lo, hi, guess=z0, period=period,
                           doublings=0 if ctx.quick else 2, log=ctx.log)
    (ctx.out / "continuation.json").write_text(result.to_json())
    fig_bifurcation(result, ctx.path("table_2_2_bifurcation_diagram.png"))
    flips = [b for b in result.bifurcations if b.kind == "flip" and b.period == 1]
    boundary = flips[0] if flips else None
    stable_mu = [p.mu for br in result.branches for p in br.points if p.stable]
    rows = [_row("period-1/period-2 boundary (flip)", None if boundary is None else boundary.mu,
                 0.0157, "rad", "located by continuation" + (
                     f" (± {boundary.mu_error:.1g} from the multiplier's error)" if boundary
                     else ": no flip in the range")),
            _row("upper end of the stable gaits (any period)",
                 max(stable_mu) if stable_mu else None, 0.018, "rad",
                 f"largest slope with a stable orbit on the branches followed up to {hi}")]
    out = {"rows": rows, "table": _branch_rows(result, "slope"),
           "bifurcations": [b.to_dict(w0) for b in result.bifurcations]}
    if not ctx.quick:
        out["walker_gait"] = _default_guess_gaits(ctx, NOMINAL, "slope", _slopes(ctx), result)
    return out


# --- the classic rigid walkers' bifurcations -------------------------------------------------------
#: (label, walker, range, guess in the thesis's section coordinates (None: the walker's own),
#: period doublings, the published first flip (rad) and its source)
RIGID_CONTINUATIONS = (
    ("simplest walker, long-period gait", "simplest_walker", (0.002, 0.019), None, 2, 0.0151,
     "Garcia et al. 1998: period doubling near 0.0151, chaos up to 0.019"),
    ("simplest walker, short-period gait", "simplest_walker", (0.009, 0.019),
     (-0.205, 0.386, -0.015), 0, None, "Garcia et al. 1998, Table 1: unstable"),
    ("compass gait", "compass_gait", (0.01, 0.1), None, 3, None,
     "Goswami et al. 1998: period-doubling cascade into chaos over the slope"),
)


def run_rigid_bifurcations(ctx: StudyContext) -> dict:
    """The simplest walker (Garcia et al. 1998) and the compass gait (Goswami et al. 1998)
    continued over the slope: flips located, the period-2 and period-4 branches (the compass
    gait's on to period 8), the unstable short-period gait."""
    rows: list[dict] = []
    out: dict[str, Any] = {}
    for label, model, (lo, hi), guess, doublings, published, source in RIGID_CONTINUATIONS:
        if ctx.quick:
            if guess is not None:
                continue
            (lo, hi), doublings = ((0.014, 0.0155) if model == "simplest_walker"
                                   else (0.075, 0.0775)), 1
        w = _walker(model)
        start = w.with_parameters(slope=lo)
        z = None if guess is None else start.from_thesis(np.array(guess))
        z0, period = gait_start(w, "slope", lo, z)
        result = continue_gait(w, "slope", lo, hi, guess=z0, period=period, doublings=doublings,
                               log=ctx.log)
        name = f"{model}_{'short' if guess is not None else 'main'}"
        (ctx.out / f"{name}.json").write_text(result.to_json())
        fig_bifurcation(result, ctx.path(f"{name}_bifurcation_diagram.png"))
        out[name] = {"bifurcations": [b.to_dict(w) for b in result.bifurcations],
                     "branches": [{"period_steps": b.period, "points": len(b.points),
                                   "origin": b.origin, "end": b.end} for b in result.branches]}
        flips = [b for b in result.bifurcations if b.kind == "flip"]
        for b in flips:
            rows.append(_row(f"{label}: flip of the period-{b.period} gait", b.mu,
                             published if b.period == 1 else None, "rad",
                             f"{np.degrees(b.mu):.4f}°, ± {b.mu_error:.1g}; {source}"))
        if not flips:
            stable = any(p.stable for br in result.branches for p in br.points)
            rows.append(_row(f"{label}: bifurcations over {lo}–{hi}",
                             len(result.bifurcations), None, "1",
                             f"{'a stable' if stable else 'no stable'} orbit on the branch; "
                             f"{source}"))
    out["rows"] = rows
    return out


# --- Fig. 2.22 -----------------------------------------------------------------------------------
def _rigid_step_down(ctx: StudyContext) -> tuple[list[float], list[dict]]:
    """The nominal (rigid-leg) walker's step-down over the slope: the sweep of step_down_slope,
    shared with leg_stiffness (one results file, computed once)."""
    slopes = [0.005, 0.009, 0.013] if ctx.quick else list(RIGID_SLOPES)
    rows = ctx.sweep("step_down_over_slope", step_down_case, [{"slope": s} for s in slopes],
                     study="step_down_slope", model=NOMINAL,
                     resolution=2e-4 if ctx.quick else 1e-4)
    return slopes, rows


def run_step_down_slope(ctx: StudyContext) -> dict:
    slopes, rows = _rigid_step_down(ctx)
    _plot_xy(ctx.path("fig_2_22_step_down_over_slope.png"), slopes,
             {"max step-down (mm)": _mm(rows)},
             "slope γ (rad)", "max step-down (mm)", "Step-down over the slope (open: not contiguous)")
    return {"rows": [_row("max step-down at γ = 0.009", _at_nominal_slope(rows).get("max_step_down"),
                          0.0024, "m")],
            "table": [{k: r.get(k) for k in ("slope", "status", "max_step_down", "contiguous",
                                             "speed", "energy_dissipated_per_step")}
                      for r in rows]}


# --- Figs. 2.21, 2.23 ----------------------------------------------------------------------------
def run_basin(ctx: StudyContext) -> dict:
    n, span = (5, (0.025, 0.1)) if ctx.quick else (11, (0.025, 0.1))   # scaled θ, θ̇ half-widths
    out: dict[str, Any] = {"rows": [], "basins": {}}
    for slope in (0.007, 0.012):
        w = _walker(NOMINAL, slope=slope)
        gait = analyze_gait(w)
        if gait.status != "periodic":
            out["rows"].append(_row(f"basin at γ = {slope}", None, None, "", gait.message))
            continue
        fp = gait.fixed_point
        s = np.linspace(-1.0, 1.0, n)
        cases = [{"theta": float(fp["theta"] + 0.4 * span[0] * a),
                  "theta_dot": float(fp["theta_dot"] + 0.8 * span[1] * b)} for a in s for b in s]
        rows = ctx.sweep(f"basin_{slope:g}", basin_case, cases, model=NOMINAL,
                         params={"slope": slope}, shared={"gait": gait})
        ok = np.array([r["status"] == "converged" for r in rows]).reshape(n, n)
        plt = pyplot()
        fig, ax = plt.subplots(figsize=(4.5, 4))
        A, B = np.meshgrid(span[0] * s + fp["theta"] / 0.4, span[1] * s + fp["theta_dot"] / 0.8,
                           indexing="ij")
        ax.plot(A[ok], B[ok], "*", color="C2", ms=8, label="converges")
        ax.plot(A[~ok], B[~ok], ".", color="0.5", ms=4, label="does not")
        ax.plot(fp["theta"] / 0.4, fp["theta_dot"] / 0.8, "*", color="C3", ms=12)
        _save_axes(fig, ax, ctx.path(f"fig_2_21_basin_{slope:g}.png"), "θ / 0.4 rad",
                   "θ̇ / 0.8 rad/s", f"Basin of attraction, γ = {slope}", legend=7)
        out["basins"][str(slope)] = {"fraction": float(ok.mean()), "n": n, "span": span}
        out["rows"].append(_row(f"basin fraction converged at γ = {slope}", float(ok.mean()), None,
                                "1", f"{n}×{n} grid, ±{span[0]} (θ/0.4) × ±{span[1]} (θ̇/0.8)"))
    return out


# --- Chapter 3 ----------------------------------------------------------------------------------
COMPLIANT = "compliant_leg_walker"
VARIABLE = "variable_stiffness_walker"


def _guesses(ctx: StudyContext, model: str, cases: list[dict], order_key: str) -> list[dict]:
    """A ``guess`` (the gait's section state) for each case by continuation
    (serial, cheap next to the step-down tests): cases sorted by their distance in
    ``order_key`` from the walker's defaults, each gait search started from the nearest case
    already solved. A case with no gait keeps the walker's own initial guess."""
    base = _walker(model)
    solved: list[tuple[dict, np.ndarray]] = []
    out: list[dict] = [{} for _ in cases]
    order = sorted(range(len(cases)),
                   key=lambda i: abs(math.log(cases[i][order_key] / base.parameters[order_key])))
    for i in order:
        w = base.with_parameters(**cases[i])
        near = min(solved, key=lambda cz: sum(abs(math.log(cases[i][k] / cz[0][k]))
                                              for k in cases[i]), default=None)
        g = analyze_gait(w, guess=None if near is None else near[1])
        if g.status == "periodic" and g.period_steps == 1:
            solved.append((cases[i], np.array([g.fixed_point[k] for k in w.section])))
            out[i] = {"guess": [float(g.fixed_point[k]) for k in w.section]}
        ctx.log(f"  guess {cases[i]}: {g.status}")
    return [{**c, **o} for c, o in zip(cases, out)]


def run_damper_factor(ctx: StudyContext) -> dict:
    alphas = [0.1, 0.2] if ctx.quick else [0.1, 0.15, 0.2, 0.3]
    Ks = [6000.0] if ctx.quick else [2000.0, 6000.0, 10000.0]
    cases = _guesses(ctx, COMPLIANT, [{"alpha": a, "K_leg": k} for a in alphas for k in Ks],
                     "K_leg")
    rows = ctx.sweep("step_down_over_alpha_K", step_down_case, cases, model=COMPLIANT,
                     resolution=2e-4)
    table = [{k: r.get(k) for k in ("alpha", "K_leg", "status", "gait_status", "max_step_down",
                                    "contiguous", "speed")} for r in rows]
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 3.6))
    for k in Ks:
        sel = [r for r in rows if r["K_leg"] == k]
        ax.plot([r["alpha"] for r in sel], _mm(sel), "o-", label=f"K = {k:g} N/m")
        for r in sel:
            if r.get("contiguous") is False and r.get("max_step_down"):
                ax.plot(r["alpha"], 1e3 * r["max_step_down"], "x", color="k")
    _save_axes(fig, ax, ctx.path("fig_3_3_over_alpha.png"), "damper factor α",
               "max step-down (mm)", "Compliant leg over α (x: not contiguous = 'chaotic')")
    good = [a for a in alphas
            if all(r.get("gait_status") == "periodic" and r.get("contiguous")
                   for r in rows if r["alpha"] == a)]
    return {"rows": [_row("α with a gait and a contiguous step-down at every K tried",
                          ", ".join(f"{a:g}" for a in good) or None, "0.13–0.25", "1")],
            "table": table}


def run_leg_stiffness(ctx: StudyContext) -> dict:
    Ks = [3000.0, 9000.0] if ctx.quick else [1500.0, 2000.0, 3000.0, 4500.0, 6000.0, 7500.0,
                                             9000.0, 10000.0]
    cases = _guesses(ctx, COMPLIANT, [{"K_leg": k} for k in Ks], "K_leg")
    rows = ctx.sweep("step_down_over_K", step_down_case, cases, model=COMPLIANT,
                     resolution=2e-4 if ctx.quick else 1e-4)
    _, rigid_rows = _rigid_step_down(ctx)
    rigid9 = _at_nominal_slope(rigid_rows)
    sd = _mm(rows)
    extra = {}
    if not ctx.quick:
        extra = _stiffness_continuation(ctx, Ks)
    _plot_xy(ctx.path("fig_3_4_step_down_over_K.png"), Ks, {"compliant leg": sd}, "K (N/m)",
             "max step-down (mm)", "Step-down over leg stiffness (α = 0.15, γ = 0.009)",
             {"rigid legs, γ = 0.009": 1e3 * (rigid9.get("max_step_down") or 0.0)})
    _plot_xy(ctx.path("fig_3_5_speed_energy_over_K.png"), Ks,
             {"speed (m/s)": [r.get("speed") for r in rows],
              "energy per step (J)": [r.get("energy_dissipated_per_step") for r in rows]},
             "K (N/m)", "value (SI)", "Speed and energy per step over K",
             {"rigid speed": rigid9.get("speed") or 0.0})
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 3.6))
    ax.plot([r.get("speed") for r in rigid_rows], _mm(rigid_rows), "o-",
            label="rigid legs (over slope)")
    ax.plot([r.get("speed") for r in rows], sd, "s-", label="compliant legs (over K)")
    _save_axes(fig, ax, ctx.path("fig_3_6_robustness_over_speed.png"), "speed (m/s)",
               "max step-down (mm)", "Robustness over speed (Fig. 3.6)")
    stable = [r["K_leg"] for r in rows
              if r.get("gait_status") == "periodic" and r.get("stable")]
    faster = [r["K_leg"] for r in rows
              if (r.get("speed") or 0) > (rigid9.get("speed") or math.inf)]
    better = [r["K_leg"] for r in rows
              if (r.get("contiguous_limit") or 0) > (rigid9.get("contiguous_limit") or math.inf)]
    return {"rows": [
        _row("lowest stable K on the grid", min(stable) if stable else None, 1500.0, "N/m"),
        *extra.get("rows", []),
        _row("lowest K faster than the rigid leg", min(faster) if faster else None, 3000.0, "N/m"),
        _row("lowest K more robust than the rigid leg (contiguous step-down)",
             min(better) if better else None, 4500.0, "N/m"),
    ], "table": [{k: r.get(k) for k in ("K_leg", "gait_status", "period_steps", "stable",
                                        "max_step_down", "contiguous_limit", "contiguous",
                                        "survived_intervals", "speed",
                                        "energy_dissipated_per_step")} for r in rows],
        **{k: v for k, v in extra.items() if k != "rows"}}


def _stiffness_continuation(ctx: StudyContext, Ks: list[float]) -> dict:
    """The compliant-leg walker's gait continued in K_leg from the file's 6000 N/m down to
    1000 N/m (with the period doublings), and ``walker gait`` from the default guess at each K
    of the grid: the lowest stable K and the period-1/period-2 boundary."""
    w0 = _walker(COMPLIANT)
    z0, period = gait_start(w0, "K_leg", w0.parameters["K_leg"])
    result = continue_gait(w0, "K_leg", w0.parameters["K_leg"], 1000.0, guess=z0,
                           period=period, doublings=1, log=ctx.log)
    (ctx.out / "continuation_K_leg.json").write_text(result.to_json())
    fig_bifurcation(result, ctx.path("continuation_K_leg.png"))
    flips = [b for b in result.bifurcations if b.kind == "flip" and b.period == 1]
    stable = [p.mu for br in result.branches for p in br.points if p.stable]
    rows = [_row("lowest stable K (continuation, any period)", min(stable) if stable else None,
                 1500.0, "N/m", "the branches followed from 6000 down to 1000 N/m"),
            _row("period-1/period-2 boundary (flip)", flips[0].mu if flips else None, None,
                 "N/m", "located by continuation" if flips else "no flip above 1000 N/m")]
    return {"rows": rows, "continuation": _branch_rows(result, "K_leg"),
            "bifurcations": [b.to_dict(w0) for b in result.bifurcations],
            "walker_gait": _default_guess_gaits(ctx, COMPLIANT, "K_leg", Ks, result)}


def run_variable_stiffness(ctx: StudyContext) -> dict:
    constant: list[dict[str, Any]] = [{"K_leg": 6000.0, "alpha": 0.15}, {"K_leg": 8000.0, "alpha": 0.15},
                {"K_leg": 12000.0, "alpha": 0.15}]
    variable: list[dict[str, Any]] = [{"K1": 6000.0, "K2": 8000.0, "alpha": 0.2},
                {"K1": 6000.0, "K2": 12000.0, "alpha": 0.3},
                {"K1": 8000.0, "K2": 12000.0, "alpha": 0.2}]
    if ctx.quick:
        constant, variable = constant[:1], variable[:1]
    res = 2e-4 if ctx.quick else 1e-4
    variable = [{**c, "phi_max": _phi_max(ctx, c)} for c in variable]
    constant = _guesses(ctx, COMPLIANT, constant, "K_leg")
    variable = _guesses(ctx, VARIABLE, variable, "K2")
    crow = ctx.sweep("constant_K", step_down_case, constant, model=COMPLIANT, resolution=res)
    vrow = ctx.sweep("variable_K", step_down_case, variable, model=VARIABLE, resolution=res)
    extra = {}
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    for label, model, case in (("variable", VARIABLE, variable[0]),
                               ("constant K1", COMPLIANT,
                                {"K_leg": variable[0]["K1"], "alpha": variable[0]["alpha"]})):
        guess = case.get("guess")
        w = _walker(model, **{k: v for k, v in case.items() if k != "guess"})
        gait = analyze_gait(w, guess=guess)
        if gait.status != "periodic":
            continue
        z = np.array([gait.fixed_point[k] for k in w.section])
        strides = w.walk(z, 2, record=True)
        traj = strides[-1].info["trajectory"]
        ax.plot(1e3 * np.asarray(traj["spring1.z"]), traj["spring1.p.e"], lw=1, label=label)
        if model == VARIABLE:
            extra["energy_injected_per_step"] = float(traj.E_in[-1] / len(strides))
            fig_energy(walk_series(w, z, 2), ctx.path("fig_3_8_energy_variable.png"))
    _save_axes(fig, ax, ctx.path("fig_3_7_force_compression.png"),
               "leg spring extension Δz (mm; < 0: compressed)", "leg spring force F (N)",
               "F–Δz loop of leg 1 over two steps (Fig. 3.7)")
    table = ([{"kind": "constant", **{k: r.get(k) for k in ("K_leg", "alpha", "speed", "max_step_down",
                                                           "contiguous_limit", "contiguous")}}
              for r in crow]
             + [{"kind": "variable", **{k: r.get(k) for k in ("K1", "K2", "alpha", "phi_max",
                                                              "speed", "max_step_down",
                                                              "contiguous_limit", "contiguous")}}
                for r in vrow])
    rows = [_row("energy injected per step (K1 → K2)", extra.get("energy_injected_per_step"),
                 None, "J", "½ K̇ z² booked as supplied in the ledger")]
    return {"rows": rows, "table": table}


def _phi_max(ctx: StudyContext, case: dict) -> float:
    """φ_max of a variable-stiffness case by its definition (the thesis's Eq. 3.3): the peak |φ|
    of the gait with the constant stiffness K1 (this walker with K2 = K1, the same α)."""
    w = _walker(VARIABLE, K1=case["K1"], K2=case["K1"], alpha=case["alpha"])
    g = analyze_gait(w)
    if g.status != "periodic" or not g.stable:
        raise ModelError(f"variable_stiffness: no stable constant-K1 gait at K1 = {case['K1']:g}, "
                         f"α = {case['alpha']:g} to take φ_max from ({g.message})")
    ctx.log(f"  φ_max at K1 = {case['K1']:g}, α = {case['alpha']:g}: {g.metrics.max_phi:.5f} rad")
    return float(g.metrics.max_phi)


HIP = "hip_and_leg_spring_walker"
ANKLE = "ankle_stiffness_walker"
#: the recommendations study's families: (parameter, walker, full grid, quick grid, label, unit)
RECOMMENDED = (
    ("R", NOMINAL, [0.02, 0.05, 0.08, 0.1, 0.15, 0.2], [0.05, 0.1], "foot radius R", "m"),
    ("K_hip", HIP, [0.02, 0.05, 0.1, 0.15, 0.2], [0.05, 0.1], "hip stiffness K_hip", "N·m/rad"),
    ("K_ankle", ANKLE, [5.0, 10.0, 20.0, 50.0, 200.0], [10.0, 50.0], "ankle stiffness K_ankle",
     "N·m/rad"),
)


def run_recommendations(ctx: StudyContext) -> dict:
    """The thesis's §4.2 recommendations around the nominal walker at γ = 0.009: the maximum
    step-down over the foot radius (compass_walker), the hip stiffness
    (hip_and_leg_spring_walker: the compliant-leg walker with a hip spring) and the ankle
    stiffness (ankle_stiffness_walker), against the rigid-leg walker's: compass_walker itself,
    the foot radius sweep's R = 5 cm case."""
    res = 2e-4 if ctx.quick else 1e-4
    results = {}
    for key, model, full, quick, _, _ in RECOMMENDED:
        values = quick if ctx.quick else full
        cases = _guesses(ctx, model, [{key: v} for v in values], key)
        results[key] = ctx.sweep(f"step_down_over_{key}", step_down_case, cases, model=model,
                                 resolution=res)
    nominal = next((r for r in results["R"] if abs(r["R"] - 0.05) < 1e-12), {})
    rigid_mm = 1e3 * (nominal.get("max_step_down") or math.nan)
    plt = pyplot()
    fig, axes = plt.subplots(1, len(RECOMMENDED), figsize=(11, 3.6), sharey=True)
    rows, table = [], []
    for ax, (key, model, full, quick, label, unit) in zip(axes, RECOMMENDED):
        values = quick if ctx.quick else full
        result = results[key]
        mm = _mm(result)
        ax.plot(values, mm, "o-", label=model)
        for r in result:
            if r.get("contiguous") is False and r.get("max_step_down"):
                ax.plot(r[key], 1e3 * r["max_step_down"], "x", color="k")
        ax.axhline(rigid_mm, ls="--", color="C3", lw=0.8, label="rigid legs, R = 5 cm")
        ax.set_xscale("log" if key == "K_ankle" else "linear")
        ax.set_xlabel(f"{label} ({unit})")
        ax.legend(fontsize=7)
        best = max((r for r in result if r.get("max_step_down") is not None),
                   key=lambda r: r["max_step_down"], default=None)
        rows.append(_row(f"best step-down over {label}",
                         None if best is None else 1e3 * best["max_step_down"], None, "mm",
                         "" if best is None else f"at {key} = {best[key]:g} (rigid legs: "
                         f"{rigid_mm:.2f} mm)"))
        table += [{"walker": model, "parameter": key, "value": r[key],
                   **{k: r.get(k) for k in ("gait_status", "period_steps", "max_step_down",
                                            "contiguous", "speed", "max_multiplier",
                                            "energy_dissipated_per_step")}} for r in result]
    axes[0].set_ylabel("max step-down (mm)")
    fig.suptitle("The thesis's recommendations (§4.2) at γ = 0.009 (x: not contiguous)",
                 fontsize=10)
    fig.tight_layout()
    save_figure(fig, ctx.path("recommendations_step_down.png"))
    beats = [t for t in table if (t.get("max_step_down") or 0) * 1e3 > rigid_mm]
    return {"rows": rows, "table": table, "rigid_step_down_mm": rigid_mm,
            "better_than_rigid": beats}


# --- compliance in 3D ------------------------------------------------------------------------------
RIGID_3D = "compass_walker_3d"
COMPLIANT_3D = "compliant_leg_walker_3d"
PUSHES_3D = {"roll_rate": "walker.v.pelvis.x", "hip_vy": "walker.v.hip_joint.y"}


def _largest(survives: Callable[[float], bool], high: float, resolution: float) -> float:
    """The largest x in [0, high] with ``survives(x)``, by bisection to ``resolution`` (assumes
    the survived set is an interval from 0; ``high`` itself when it survives)."""
    if survives(high):
        return high
    low = 0.0
    while high - low > resolution:
        mid = 0.5 * (low + high)
        low, high = (mid, high) if survives(mid) else (low, mid)
    return low


def robustness_3d_case(case: dict, *, model: str, horizon: int = 3, n_steps: int = 20,
                       tol: float = 1e-4, h_max: float = 0.02, h_resolution: float = 1e-4,
                       push_max: float = 0.5, push_resolution: float = 1e-4) -> dict:
    """A 3D walker's robustness at the case's parameters (``guess``: a section state near the
    gait): its period-1 fixed point (Newton) and Floquet multipliers; the largest step-down (m)
    after which the walker returns within ``tol`` of the fixed point in at most 5 × ``n_steps``
    steps; and for each push of :data:`PUSHES_3D` (a section velocity raised at the fixed point:
    roll rate in rad/s, lateral hip velocity in m/s) the largest one after which it still walks
    ``horizon`` steps without falling (a laterally unstable gait recovers from no lateral push:
    the horizon makes the measure finite). Bisection to the resolutions."""
    params = dict(case)
    guess = params.pop("guess", None)
    walker = walker_cache().walker(model, None, params)
    fp = find_fixed_point(walker, walker.initial_guess() if guess is None else guess)
    if not fp.converged:
        return {"status": "no_gait", "message": fp.message}
    z = fp.z
    mults = sorted((complex(m) for m in floquet(walker, z, period=1).multipliers),
                   key=lambda m: -abs(m))

    def drop_survived(h: float) -> bool:
        return recovers(walker, z, z[None, :], n_steps=n_steps, tol=tol, ground_drop=h).survived

    def push_survived(index: int) -> Callable[[float], bool]:
        def survived(dv: float) -> bool:
            pushed = z.copy()
            pushed[index] += dv
            return not walker.walk(pushed, horizon)[-1].fell
        return survived

    out = {"status": "ok", "guess": [float(x) for x in z],
           "multipliers": [[m.real, m.imag] for m in mults],
           "max_multiplier": abs(mults[0]),
           "max_step_down": _largest(drop_survived, h_max, h_resolution)}
    for name, coordinate in PUSHES_3D.items():
        out[f"max_{name}_push"] = _largest(push_survived(walker.section.index(coordinate)),
                                           push_max, push_resolution)
    strides = walker.walk(z, 1)
    out["speed"] = strides[0].step_length / strides[0].duration
    return to_jsonable(out)


def run_compliance_3d(ctx: StudyContext) -> dict:
    """Figs. 3.3–3.6's question in 3D (w = 0: the sagittal gait is the 2D one, so the step-downs
    are the 2D walkers'; the lateral pushes are new). K_leg by continuation from the nominal
    file's 6000 N/m, neighbour by neighbour; the rigid legs (compass_walker_3d) as the reference
    row."""
    Ks = [6000.0] if ctx.quick else [3000.0, 4500.0, 6000.0, 7500.0, 9000.0]
    grid: dict[str, Any] = ({"h_resolution": 5e-4, "push_resolution": 1e-3, "horizon": 2} if ctx.quick else {})
    base = _walker(COMPLIANT_3D)
    start = Ks.index(base.parameters["K_leg"])
    guesses: dict[float, list[float]] = {}
    for path in (Ks[start:], Ks[start::-1]):      # outward from the file's K_leg, neighbour by
        z = base.initial_guess()                  # neighbour (a jump lands on another orbit)
        for k in path:
            fp = find_fixed_point(base.with_parameters(K_leg=k), z)
            if not fp.converged:
                break
            z = fp.z
            guesses[k] = [float(x) for x in z]
    cases = [{"K_leg": k, **({"guess": guesses[k]} if k in guesses else {})} for k in Ks]
    rows = ctx.sweep("robustness_over_K", robustness_3d_case, cases, model=COMPLIANT_3D, **grid)
    rigid = ctx.sweep("robustness_rigid", robustness_3d_case, [{"w": 0.0}], model=RIGID_3D,
                      **grid)[0]
    keys = ("K_leg", "status", "max_multiplier", "max_step_down", "max_roll_rate_push",
            "max_hip_vy_push", "speed")
    table = [{k: r.get(k) for k in keys} for r in rows]
    _plot_xy(ctx.path("fig_3d_robustness_over_K.png"), Ks,
             {"step-down (mm)": _mm(rows),
              "roll-rate push (10 mrad/s)": [100 * (r.get("max_roll_rate_push") or math.nan)
                                             for r in rows],
              "lateral hip push (10 mm/s)": [100 * (r.get("max_hip_vy_push") or math.nan)
                                             for r in rows]},
             "K_leg (N/m)", "largest survived", "3D walker (w = 0): robustness over K_leg",
             {"rigid legs, step-down (mm)": 1e3 * (rigid.get("max_step_down") or 0.0)})
    ok = [r for r in rows if r.get("status") == "ok"]
    best = max(ok, key=lambda r: r["max_step_down"], default={})
    return {"rows": [
        _row("largest step-down, compliant legs (best K_leg)", 1e3 * best["max_step_down"]
             if best else None, None, "mm", f"K_leg = {best.get('K_leg')} N/m"),
        _row("largest step-down, rigid legs", 1e3 * (rigid.get("max_step_down") or 0.0), None,
             "mm"),
        _row("laterally unstable at every K_leg (|λ| > 1, Kuo 1999)",
             all(r["max_multiplier"] > 1 for r in ok) and rigid.get("max_multiplier", 0) > 1,
             None, ""),
    ], "table": table, "rigid": {k: rigid.get(k) for k in keys[1:]}}


# --- the kneed walker (Hsu Chen 2007) -----------------------------------------------------------
KNEED = "kneed_walker"
#: V. F. Hsu Chen, "Passive Dynamic Walking with Knees: A Point Foot Model", M.Eng. thesis, MIT
#: EECS, 2007, sec. 3.3 (slope 0.0504 rad): the fixed point just after heel strike (4 digits,
#: angles from the vertical: q1 the stance leg, q2 = q3 the swing thigh and shank), the step
#: period (digitised from its Fig. 3-4, ± 2 %) and sec. 3.3.1's return-map eigenvalues (a
#: least-squares fit to 25 perturbed runs, not a Jacobian)
CHEN_FIXED_POINT = {"q1": 0.1877, "q2": -0.2884, "q1_dot": -1.1014, "q2_dot": -0.0399}
CHEN_STEP_PERIOD = 0.559
CHEN_EIGENVALUES = (0.4053, complex(-0.2129, 0.3454), complex(-0.2129, -0.3454))
#: the slope ranges continued from the thesis's slope: down past the fold where the period-1
#: gait ends, up through its period doubling and the period-2 orbit's
KNEED_SLOPES = ((0.0504, 0.03, 0), (0.0504, 0.12, 1))


def run_kneed_walker(ctx: StudyContext) -> dict:
    """Hsu Chen's kneed walker: the gait at the thesis's slope beside its fixed point, step period
    and eigenvalues (ours in its coordinates: q1 = θ − γ, q2 = q1 − φ, q̇1 = θ̇, q̇2 = θ̇ − φ̇),
    the angles over a few strides and the multipliers; the full study also continues the gait
    over the slope (the fold and period doublings: no published numbers to compare with)."""
    w = _walker(KNEED)
    gamma = float(w.parameters["slope"])
    gait = analyze_gait(w)
    if gait.status != "periodic":
        raise ModelError(f"{KNEED}: no gait at the thesis's slope ({gait.message})")
    fp = gait.fixed_point
    q1, q1_dot = fp["theta"] - gamma, fp["theta_dot"]
    mu = list(gait.floquet_multipliers)
    chen = max(abs(e) for e in CHEN_EIGENVALUES)
    rows = [
        _row("q1, stance leg from the vertical", q1, CHEN_FIXED_POINT["q1"], "rad",
             "the thesis's from a fixed-step search; ours the exact fixed point"),
        _row("q2 = q3, swing leg from the vertical", q1 - fp["phi"], CHEN_FIXED_POINT["q2"],
             "rad"),
        _row("q̇1", q1_dot, CHEN_FIXED_POINT["q1_dot"], "rad/s"),
        _row("q̇2 = q̇3", q1_dot - fp["phi_dot"], CHEN_FIXED_POINT["q2_dot"], "rad/s",
             "a difference of two rates near 1.1 rad/s"),
        _row("step period", gait.metrics.step_period, CHEN_STEP_PERIOD, "s",
             "the thesis's digitised from its Fig. 3-4 (± 2 %)"),
        _row("max |return-map eigenvalue|", max(abs(m) for m in mu), chen, "1",
             f"ours the stride Jacobian's (± {gait.multiplier_error:.1g}), the thesis's a "
             "least-squares fit to 25 perturbed runs: both stable"),
    ]
    z = np.array([gait.fixed_point[k] for k in w.section])
    series = walk_series(w, z, 2 if ctx.quick else 4, max_step=gait.metrics.step_period / 150)
    fig_angles(series, ctx.path("angles.png"))
    fig_floquet(mu, gait.multiplier_error, ctx.path("multipliers.png"))
    out: dict[str, Any] = {"gait": to_jsonable(gait.to_dict())}
    for lo, hi, doublings in () if ctx.quick else KNEED_SLOPES:
        result = continue_gait(w, "slope", lo, hi, guess=z, period=1, doublings=doublings,
                               log=ctx.log)
        name = f"slope_{'down' if hi < lo else 'up'}"
        (ctx.out / f"{name}.json").write_text(result.to_json())
        fig_bifurcation(result, ctx.path(f"{name}_bifurcation_diagram.png"))
        for b in result.bifurcations:
            rows.append(_row(f"{b.kind} of the period-{b.period} gait over the slope", b.mu, None,
                             "rad", f"{np.degrees(b.mu):.4f}°, ± {b.mu_error:.1g}"))
    out["rows"] = rows
    return out


STUDIES: dict[str, Study] = {s.name: s for s in [
    Study("table_2_3", "Nominal gait at γ = 0.009", "Table 2.3", run_table_2_3, (NOMINAL,)),
    Study("damping_calibration", "Energy per impact over λ; calibration", "§2.3.2, Fig. 2.12",
          run_damping_calibration, (NOMINAL,)),
    Study("time_plots", "θ/φ time plots, limit cycles, energies", "Figs. 2.13–2.15, 2.17–2.18",
          run_time_plots, (NOMINAL,)),
    Study("slope_multipliers", "Floquet multipliers over slope; period doubling", "Table 2.2",
          run_slope_multipliers, (NOMINAL,)),
    Study("rigid_bifurcations", "Simplest walker and compass gait over the slope",
          "Garcia 1998, Goswami 1998", run_rigid_bifurcations,
          ("simplest_walker", "compass_gait")),
    Study("step_down_slope", "Maximum step-down over slope", "Fig. 2.22", run_step_down_slope,
          (NOMINAL,)),
    Study("basin", "Basin of attraction at γ = 0.007 and 0.012", "Figs. 2.21, 2.23", run_basin,
          (NOMINAL,)),
    Study("damper_factor", "Compliant leg over the damper factor α", "Fig. 3.3",
          run_damper_factor, (COMPLIANT,)),
    Study("leg_stiffness", "Compliant leg over K; robustness over speed", "Figs. 3.4–3.6",
          run_leg_stiffness, (COMPLIANT, NOMINAL)),
    Study("variable_stiffness", "Variable against constant stiffness", "Figs. 3.7–3.8, Table 3.1",
          run_variable_stiffness, (COMPLIANT, VARIABLE)),
    Study("recommendations", "Foot radius, hip and ankle stiffness against step-down", "§4.2",
          run_recommendations, (NOMINAL, HIP, ANKLE)),
    Study("compliance_3d", "Step-down and lateral pushes over K_leg in 3D",
          "§4.2 (\"build a 3D model and study the effects of applying compliancy to it\")",
          run_compliance_3d, (COMPLIANT_3D, RIGID_3D)),
    Study("kneed_walker", "A walker with knees: gait, multipliers, slope range",
          "Hsu Chen 2007, sec. 3.3 (beyond the thesis)", run_kneed_walker, (KNEED,)),
]}


def run_studies(names: list[str] | None, out: str | Path, **options: Any) -> dict:
    """Run the named studies (default: all) into ``out``; return {name: summary}. Options are
    :class:`StudyContext` fields (quick, workers, serial, executor, progress, log)."""
    names = list(names or STUDIES)
    unknown = [n for n in names if n not in STUDIES]
    if unknown:
        raise ModelError(f"unknown stud{'y' if len(unknown) == 1 else 'ies'} "
                         f"{', '.join(repr(n) for n in unknown)}; studies: {', '.join(STUDIES)}")
    out = Path(out)
    summaries = {}
    index_path = out / "reproduction.json"
    if index_path.exists():
        summaries = json.loads(index_path.read_text())
    for name in names:
        study = STUDIES[name]
        ctx = StudyContext(out / name, **options)
        make_folder(ctx.out)
        ctx.log(f"study {name}: {study.title} ({study.thesis})")
        t0 = time.perf_counter()
        summary = study.run(ctx)
        summary.update({"title": study.title, "thesis": study.thesis,
                        "seconds": time.perf_counter() - t0})
        (ctx.out / "summary.json").write_text(to_json(summary))
        summaries[name] = to_jsonable(summary)
        out.mkdir(parents=True, exist_ok=True)
        index_path.write_text(to_json(summaries))
        ctx.log(f"study {name}: done in {summary['seconds']:.0f} s")
    return summaries


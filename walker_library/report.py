"""The main job: a self-contained HTML report of a walker's gait (``walker report``).

:func:`write_report` runs the analyses on one walker — the gait (fixed point, Floquet
multipliers, metrics), a recorded walk of a few steps from the fixed point (angles, limit cycle,
energy ledger), the step-down test, the Gait Sensitivity Norm, optionally the basin of attraction
— and writes into ``out``:

* ``report.html`` — one file with every figure embedded (data URIs), readable offline;
* the figures as PNG files (``angles.png``, ``limit_cycle.png``, ``energy.png``,
  ``energy_per_step.png``, ``floquet.png``, ``step_down.png``, ``basin.png``) and the animation
  ``walk.gif``;
* the results as JSON (``gait.json``, ``step_down.json``, ``gsn.json``, ``basin.json``,
  ``report.json`` with all of them and the thesis comparison), SI units, named fields.

A walker without a gait (it falls, or no fixed point is found) still gets a report: the status,
the message and the walk until the fall.

Plots use matplotlib (the ``plots`` extra) with the Agg back end; nothing is shown on screen.
"""
from __future__ import annotations

import base64
import html
import io
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .continuation import ContinuationResult
from .gait import GaitResult, analyze_gait
from .protocol import Walker
from .results import to_json
from .robustness import BasinResult, StepDownResult, basin, gait_sensitivity_norm, step_down
from .series import GaitSeries, walk_series

__all__ = ["THESIS_REFERENCE", "ReportResult", "write_report"]

#: published numbers to compare with, by model: (field, value, unit, source)
THESIS_REFERENCE: dict[str, list[tuple[str, float, str, str]]] = {
    "compass_walker": [
        ("speed", 0.274, "m/s", "thesis Table 2.3 / §3.1"),
        ("energy_dissipated_per_step", 0.08, "J", "thesis Table 2.3"),
        ("max_step_down", 0.0024, "m", "thesis Table 2.3"),
    ],
    "rigid_compass_walker": [
        ("speed", 0.274, "m/s", "thesis Table 2.3 (arc feet, compliant contact)"),
        ("energy_dissipated_per_step", 0.08, "J", "thesis Table 2.3 (arc feet, compliant contact)"),
    ],
    "simplest_walker": [
        ("theta", 0.20031090049483, "rad", "Garcia et al. 1998, Table 1 (γ = 0.009)"),
        ("theta_dot", -0.19983247291764, "rad/s", "Garcia et al. 1998, Table 1"),
    ],
}

_FIG = {"dpi": 110}


@dataclass
class ReportResult:
    """What :func:`write_report` wrote: the directory, the files, the analyses and the time."""

    out: Path
    files: list[str]
    gait: GaitResult
    step_down: StepDownResult | None
    basin: BasinResult | None
    seconds: float


def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def save_figure(fig, path: Path) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", **_FIG)
    pyplot().close(fig)
    data = buf.getvalue()
    path.write_bytes(data)
    return data


def fig_angles(s: GaitSeries, path: Path) -> bytes:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 3.2))
    ax.plot(s.t, s.theta, label="θ (stance leg)")
    if np.any(np.isfinite(s.phi)):
        ax.plot(s.t, s.phi, label="φ (between the legs)")
    for te in s.step_times:
        ax.axvline(te, color="0.85", lw=0.8, zorder=0)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("angle (rad)")
    ax.legend(loc="best", fontsize=8)
    ax.set_title("Leg angles over the steps (heel strikes: grey lines)")
    fig.tight_layout()
    return save_figure(fig, path)


def fig_limit_cycle(s: GaitSeries, path: Path) -> bytes:
    plt = pyplot()
    legged = bool(np.any(np.isfinite(s.phi)))
    fig, axes = plt.subplots(1, 2 if legged else 1, figsize=(7.5 if legged else 4, 3.4))
    axes = np.atleast_1d(axes)
    axes[0].plot(s.theta, s.theta_dot, lw=1)
    axes[0].set_xlabel("θ (rad)")
    axes[0].set_ylabel("θ̇ (rad/s)")
    axes[0].set_title("stance leg")
    if legged:
        axes[1].plot(s.phi, s.phi_dot, lw=1, color="C1")
        axes[1].set_xlabel("φ (rad)")
        axes[1].set_ylabel("φ̇ (rad/s)")
        axes[1].set_title("between the legs")
    fig.suptitle("Limit cycle (phase portraits over the recorded steps)", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def fig_energy(s: GaitSeries, path: Path) -> bytes:
    plt = pyplot()
    fig, (a, b) = plt.subplots(2, 1, figsize=(7, 5), sharex=True,
                               gridspec_kw={"height_ratios": [3, 1]})
    a.plot(s.t, s.V - s.V[0], label="potential V − V(0)")
    a.plot(s.t, s.T, label="kinetic T")
    a.plot(s.t, s.H - s.H[0], label="total H − H(0)")
    a.plot(s.t, s.E_diss, label="dissipated E_diss")
    if np.any(s.E_in != 0):
        a.plot(s.t, s.E_in, label="supplied E_in")
    a.set_ylabel("energy (J)")
    a.legend(loc="best", fontsize=8)
    a.set_title("Energy ledger over the steps")
    b.plot(s.t, s.residual, color="k", lw=0.8)
    b.set_ylabel("residual (J)")
    b.set_xlabel("t (s)")
    fig.tight_layout()
    return save_figure(fig, path)


def fig_energy_per_step(s: GaitSeries, path: Path) -> bytes:
    plt = pyplot()
    steps = [x for x in s.strides if not x.fell]
    k = np.arange(1, len(steps) + 1)
    fig, ax = plt.subplots(figsize=(6, 3))
    ax.bar(k - 0.2, [x.energy_dissipated for x in steps], 0.4, label="dissipated")
    ax.bar(k + 0.2, [x.potential_released for x in steps], 0.4, label="potential released")
    ax.set_xlabel("step")
    ax.set_ylabel("energy per step (J)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path)


def fig_floquet(gait: GaitResult, path: Path) -> bytes:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(3.6, 3.6))
    u = np.linspace(0, 2 * math.pi, 200)
    ax.plot(np.cos(u), np.sin(u), color="0.6", lw=0.8)
    m = np.array(gait.floquet_multipliers, dtype=complex)
    ax.plot(m.real, m.imag, "x", ms=8, color="C3")
    ax.set_aspect("equal")
    ax.set_xlabel("Re λ")
    ax.set_ylabel("Im λ")
    ax.set_title("Floquet multipliers", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def fig_step_down(r: StepDownResult, path: Path) -> bytes:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 2.6))
    colors = {"converged": "C2", "fell": "C3", "wandered": "C1"}
    for c in r.cases:
        ax.plot(c["h"] * 1e3, 0, "o", color=colors.get(c["status"], "k"))
    for status, color in colors.items():
        ax.plot([], [], "o", color=color, label=status)
    if r.max_step_down:
        ax.axvline(r.max_step_down * 1e3, color="0.5", ls="--", lw=0.8)
    ax.set_yticks([])
    ax.set_xlabel("step-down h (mm)")
    ax.legend(fontsize=8, ncol=3, loc="upper right")
    ax.set_title(r.message, fontsize=9)
    fig.tight_layout()
    return save_figure(fig, path)


def fig_basin(r: BasinResult, path: Path) -> bytes:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(4.5, 4))
    th = np.array(r.theta) / r.theta_scale
    thd = np.array(r.theta_dot) / r.theta_dot_scale
    for i, a in enumerate(th):
        for j, b in enumerate(thd):
            ok = r.outcome[i][j] == "converged"
            ax.plot(a, b, "*" if ok else ".", color="C2" if ok else "0.5", ms=8 if ok else 4)
    ax.plot(r.fixed_point["theta"] / r.theta_scale, r.fixed_point["theta_dot"] / r.theta_dot_scale,
            "*", color="C3", ms=12)
    ax.set_xlabel(f"θ / {r.theta_scale:g} rad")
    ax.set_ylabel(f"θ̇ / {r.theta_dot_scale:g} rad/s")
    ax.set_title("Basin of attraction (stars converge)", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def _animation(s: GaitSeries, path: Path, *, frames: int = 60, fps: int = 15) -> bytes:
    """A GIF of the stick figure in the slope frame (x down the slope, z along its normal)."""
    plt = pyplot()
    from matplotlib.animation import FuncAnimation, PillowWriter
    idx = np.unique(np.searchsorted(s.t, np.linspace(s.t[0], s.t[-1], frames)).clip(0, len(s.t) - 1))
    pts = np.concatenate([s.hip[:, None, :], s.feet], axis=1)
    lo, hi = pts.reshape(-1, 2).min(axis=0), pts.reshape(-1, 2).max(axis=0)
    pad = 0.1 * max(hi - lo)
    fig, ax = plt.subplots(figsize=(6, 3))
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(min(lo[1], 0.0) - pad, hi[1] + pad)
    ax.set_aspect("equal")
    ax.axhline(0.0, color="0.4", lw=1)
    legs = [ax.plot([], [], lw=2, color=f"C{k}")[0] for k in range(s.feet.shape[1])]
    hip = ax.plot([], [], "o", color="k", ms=8)[0]
    label = ax.text(0.01, 0.95, "", transform=ax.transAxes, fontsize=8, va="top")
    ax.set_xlabel("x along the slope (m)")
    ax.set_ylabel("z normal (m)")

    def draw(i):
        k = idx[i]
        for f, line in enumerate(legs):
            line.set_data([s.hip[k, 0], s.feet[k, f, 0]], [s.hip[k, 1], s.feet[k, f, 1]])
        hip.set_data([s.hip[k, 0]], [s.hip[k, 1]])
        label.set_text(f"t = {s.t[k]:.2f} s, step {int(s.step[k]) + 1}")
        return [*legs, hip, label]

    anim = FuncAnimation(fig, draw, frames=len(idx), blit=True)
    anim.save(str(path), writer=PillowWriter(fps=fps))
    plt.close(fig)
    return path.read_bytes()


def _table(rows: list[tuple], head: tuple) -> str:
    cells = "".join(f"<th>{html.escape(str(h))}</th>" for h in head)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(_fmt(c))}</td>" for c in r) + "</tr>"
                   for r in rows)
    return f"<table><thead><tr>{cells}</tr></thead><tbody>{body}</tbody></table>"


def _fmt(v) -> str:
    if v is None:
        return "—"
    if isinstance(v, float):
        return "—" if not math.isfinite(v) else f"{v:.6g}"
    return str(v)


def _comparison(walker: Walker, gait_d: dict, sd: StepDownResult | None) -> list[dict]:
    rows = []
    for field, value, unit, source in THESIS_REFERENCE.get(walker.name, []):
        if field == "max_step_down":
            ours = sd.max_step_down if sd is not None else None
        elif field in ("theta", "theta_dot"):
            ours = gait_d["fixed_point"].get(field)
        else:
            ours = gait_d.get(field)
        dev = (ours - value) / abs(value) if isinstance(ours, float) and value else None
        rows.append({"quantity": field, "ours": ours, "published": value, "unit": unit,
                     "deviation": dev, "source": source})
    return rows


_CSS = """body{font-family:sans-serif;max-width:980px;margin:2em auto;color:#222}
table{border-collapse:collapse;margin:.5em 0 1.2em}td,th{border:1px solid #ccc;padding:3px 8px;
font-size:13px;text-align:left}th{background:#f3f3f3}img{max-width:100%;display:block;
margin:.4em 0 1.2em}code{background:#f5f5f5;padding:1px 3px}.bad{color:#b00}"""

#: marks the page as rendered when every image decoded (checked by the headless-browser test)
_SCRIPT = """window.addEventListener('load',function(){var im=document.images,ok=0;
for(var i=0;i<im.length;i++){if(im[i].complete&&im[i].naturalWidth>0){ok++;}}
document.body.setAttribute('data-images-ok',ok+'/'+im.length);});"""


def write_report(walker: Walker, out: str | Path, *, n_steps: int = 6, with_step_down: bool = True,
                 with_basin: bool = False, basin_n: int = 9, step_down_resolution: float | None = None,
                 log=None, continuation: ContinuationResult | None = None) -> ReportResult:
    """Analyse ``walker`` and write the report into directory ``out`` (module docstring).
    ``log`` (a callable taking a string) receives progress lines; ``continuation``: a
    continuation of the gait (:func:`~.continuation.continue_gait`) whose bifurcation diagram,
    bifurcations and branch table the report includes."""
    t0 = time.perf_counter()
    say = log or (lambda msg: None)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files: list[str] = []
    images: dict[str, tuple[str, bytes]] = {}

    def put(name: str, data: bytes, mime: str = "image/png") -> None:
        files.append(name)
        images[name] = (mime, data)

    def dump(name: str, obj) -> None:
        (out / name).write_text(to_json(obj) + "\n")
        files.append(name)

    say(f"{walker.name}: gait analysis")
    gait = analyze_gait(walker)
    gait_d = gait.to_dict()
    dump("gait.json", gait_d)
    periodic = gait.status == "periodic"
    z0 = (np.array([gait.fixed_point[k] for k in walker.section]) if periodic
          else np.asarray(walker.initial_guess(), dtype=float))
    say(f"{walker.name}: recorded walk of {n_steps} steps")
    period = gait.metrics.step_period if periodic and math.isfinite(gait.metrics.step_period) else 1.0
    series = walk_series(walker, z0, n_steps, max_step=period / 150)
    put("angles.png", fig_angles(series, out / "angles.png"))
    put("limit_cycle.png", fig_limit_cycle(series, out / "limit_cycle.png"))
    put("energy.png", fig_energy(series, out / "energy.png"))
    put("energy_per_step.png", fig_energy_per_step(series, out / "energy_per_step.png"))
    say(f"{walker.name}: animation")
    put("walk.gif", _animation(_first_steps(series, 3), out / "walk.gif"), "image/gif")
    sd = bas = gsn = None
    if periodic:
        put("floquet.png", fig_floquet(gait, out / "floquet.png"))
        if with_step_down:
            say(f"{walker.name}: step-down test")
            sd = step_down(walker, gait, resolution=step_down_resolution)
            dump("step_down.json", sd)
            put("step_down.png", fig_step_down(sd, out / "step_down.png"))
        say(f"{walker.name}: gait sensitivity norm")
        gsn = gait_sensitivity_norm(walker, gait)
        dump("gsn.json", gsn)
        if with_basin:
            say(f"{walker.name}: basin of attraction ({basin_n}×{basin_n})")
            bas = basin(walker, gait, n=basin_n)
            dump("basin.json", bas)
            put("basin.png", fig_basin(bas, out / "basin.png"))
    if continuation is not None:
        put("bifurcation_diagram.png", continuation.figure(out / "bifurcation_diagram.png"))
        dump("continuation.json", continuation.to_dict())
    comparison = _comparison(walker, gait_d, sd)
    ledger = {"max_abs_residual": float(np.max(np.abs(series.residual))),
              "energy_dissipated": float(series.E_diss[-1]), "energy_supplied": float(series.E_in[-1]),
              "steps": len([s for s in series.strides if not s.fell])}
    summary = {"model": walker.name, "gait": gait_d, "step_down": sd, "gsn": gsn, "basin": bas,
               "comparison": comparison, "walk_ledger": ledger,
               "continuation": None if continuation is None else continuation.to_dict()}
    dump("report.json", summary)
    page = _html(walker, gait, gait_d, sd, gsn, bas, comparison, ledger, images, continuation)
    (out / "report.html").write_text(page)
    files.append("report.html")
    seconds = time.perf_counter() - t0
    say(f"{walker.name}: report written to {out / 'report.html'} in {seconds:.1f} s")
    return ReportResult(out, files, gait, sd, bas, seconds)


def _first_steps(s: GaitSeries, n: int) -> GaitSeries:
    """The first ``n`` steps of a series (for the animation)."""
    keep = s.step < n
    return GaitSeries(**{k: (v[keep] if isinstance(v, np.ndarray) and len(v) == len(keep) else v)
                         for k, v in s.__dict__.items()})


def _img(images: dict, name: str, alt: str) -> str:
    if name not in images:
        return ""
    mime, data = images[name]
    return (f'<img src="data:{mime};base64,{base64.b64encode(data).decode()}" '
            f'alt="{html.escape(alt)}" title="{html.escape(name)}">')


def _continuation_html(c: ContinuationResult | None, images: dict) -> str:
    if c is None:
        return ""
    label = c.path.label
    bifs = _table([(b.kind.replace("_", "–"), b.branch, b.period, f"{b.mu:.12g}",
                    f"{b.mu_error:.1g}", f"{b.multiplier:.6f}") for b in c.bifurcations],
                  ("bifurcation", "branch", "period", label, "± (from the multiplier's error)",
                   "critical multiplier")) if c.bifurcations else "<p>No bifurcation.</p>"
    rows = [(r["branch"], r["period_steps"], f"{r[label]:.8g}", f"{r['max_multiplier']:.6f}",
             "yes" if r["stable"] else "no", f"{r['step_period']:.6g}") for r in c.table()]
    branch = _table(rows, ("branch", "period", label, "max |λ|", "stable", "step period (s)"))
    return (f"<h2>Continuation in {html.escape(label)}</h2><p>{html.escape(c.message)}.</p>"
            + _img(images, "bifurcation_diagram.png", "bifurcation diagram") + bifs
            + f"<details><summary>The branches ({len(rows)} points)</summary>{branch}</details>")


def _html(walker, gait, gait_d, sd, gsn, bas, comparison, ledger, images,
          continuation=None) -> str:
    m = gait_d
    status = html.escape(f"{gait.status}: {gait.message}")
    params = _table([(k, v) for k, v in walker.parameters.items()], ("parameter", "value (SI)"))
    metrics = _table([(k, m.get(k)) for k in ("step_period", "step_length", "speed",
                                              "energy_dissipated_per_step",
                                              "potential_released_per_step", "max_theta",
                                              "max_phi", "cost_of_transport")],
                     ("gait metric", "value (SI)"))
    fp = _table([(k, v) for k, v in (gait.fixed_point or {}).items()],
                ("fixed point (section state)", "value (SI)"))
    mults = _table([(f"{c.real:.8g}", f"{c.imag:+.8g}", f"{abs(c):.8g}")
                    for c in np.asarray(gait.floquet_multipliers, dtype=complex)],
                   ("Re λ", "Im λ", "|λ|"))
    comp = _table([(r["quantity"], r["ours"], r["published"], r["unit"],
                    None if r["deviation"] is None else f"{100 * r['deviation']:+.1f} %", r["source"])
                   for r in comparison], ("quantity", "ours", "published", "unit", "deviation",
                                          "source")) if comparison else ""
    sd_html = ""
    if sd is not None:
        sd_html = (f"<h2>Step-down</h2><p>{html.escape(sd.message)} (recovery within "
                   f"{sd.tol:g} of the fixed point in {sd.n_steps} steps).</p>"
                   + _img(images, "step_down.png", "step-down cases"))
    gsn_html = "" if gsn is None else (
        f"<h2>Gait Sensitivity Norm</h2><p>{html.escape(gsn.message)}; by indicator: "
        + ", ".join(f"{k} {v:.4g}" for k, v in gsn.by_indicator.items()) + " (per m of drop).</p>")
    basin_html = "" if bas is None else (f"<h2>Basin of attraction</h2><p>{html.escape(bas.message)}"
                                         f"</p>" + _img(images, "basin.png", "basin of attraction"))
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(walker.name)} — walker report</title>
<style>{_CSS}</style></head>
<body>
<h1>Walker report: {html.escape(walker.name)}</h1>
<p>{html.escape(getattr(walker, "doc", ""))}</p>
<p><b>Gait:</b> {status}; period {gait.period_steps} step(s); stable: {_fmt(gait.stable)}.
Section: <code>{html.escape(", ".join(walker.section))}</code>.</p>
{("<h2>Compared with the published numbers</h2>" + comp) if comp else ""}
<h2>Gait</h2>{metrics}{fp}
<h2>Floquet multipliers</h2><p>Error bound {_fmt(gait.multiplier_error)} (finite differences,
the step chosen per coordinate).</p>{mults}
{_img(images, "floquet.png", "Floquet multipliers")}
<h2>Walk from the fixed point</h2>
<p>{ledger["steps"]} steps in one simulation; energy dissipated {ledger["energy_dissipated"]:.6g} J,
supplied {ledger["energy_supplied"]:.6g} J, largest ledger residual {ledger["max_abs_residual"]:.3g} J.</p>
{_img(images, "walk.gif", "animation of the first steps")}
{_img(images, "angles.png", "leg angles over time")}
{_img(images, "limit_cycle.png", "limit cycle")}
{_img(images, "energy.png", "energy ledger")}
{_img(images, "energy_per_step.png", "energy per step")}
{sd_html}{gsn_html}{basin_html}{_continuation_html(continuation, images)}
<h2>Parameters</h2>{params}
<p>Results as JSON beside this file: gait.json, step_down.json, gsn.json, report.json.</p>
<script>{_SCRIPT}</script>
</body></html>
"""


def load_summary(out: str | Path) -> dict:
    """The ``report.json`` written by :func:`write_report`."""
    return json.loads((Path(out) / "report.json").read_text())


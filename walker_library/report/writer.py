"""The main job: a self-contained HTML report of a walker's gait (``walker report``).

:func:`write_report` runs the analyses on one walker — the gait (fixed point, Floquet
multipliers, metrics), a recorded walk of a few steps from the fixed point (angles, limit cycle,
energy ledger, the animation), the step-down test, the Gait Sensitivity Norm, optionally the
basin of attraction — compares the numbers with the publication the model comes from
(:mod:`walker_library.comparison`) and writes into ``out``:

* ``report.html`` — one file with every figure, the interactive player and its data embedded,
  readable offline (nothing is fetched from the network), from a phone to a wide screen;
* the figures as PNG files (``angles.png``, ``limit_cycle.png``, ``energy.png``,
  ``energy_per_step.png``, ``floquet.png``, ``step_down.png``, ``basin.png``, and those of
  :data:`EXTRA_FIGURES`) and the animation ``walk.gif`` (every recorded step, looping);
* for a 3D walker (or when asked), the still image ``view3d.png`` of the interactive 3D view;
* the results as JSON (``gait.json``, ``step_down.json``, ``gsn.json``, ``basin.json``,
  ``report.json`` with all of them and the comparison), SI units, named fields.

Every table gives each quantity a readable label (the internal name on hover), its unit and its
meaning (:mod:`walker_library.labels`); a nondimensional model is labelled so. A walker without a
gait (it falls, or no fixed point is found) still gets a report: the status, the message and the
walk until the fall.

The walk is shown by an interactive player: a 2D walker's stick figure on a canvas, a 3D
walker's bodies in an interactive 3D view (:mod:`porthamiltonian.viewer`: orbit, play/pause,
scrub, step through the strides; three.js inline, so the page stays self-contained). ``view3d``
asks for the 3D view of a planar walker too (beside its 2D player, :mod:`.view3d`).

Extra sections: :class:`ExtraFigure` entries in :data:`EXTRA_FIGURES` (or passed as ``extra=``)
add a figure section each — a continuation or bifurcation diagram, say — drawn after the
standard analyses; one that returns None is left out.

Plots use matplotlib (the ``plots`` extra) with the Agg back end; nothing is shown on screen.
"""
from __future__ import annotations

import html
import json
import math
import shlex
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from porthamiltonian import io as ph_io
from porthamiltonian.errors import ModelError
from porthamiltonian.userfiles import make_folder

from ..analyses.continuation import ContinuationResult
from ..analyses.gait import GaitResult, analyze_gait
from ..analyses.results import to_json
from ..analyses.robustness import (
    BasinResult,
    GSNResult,
    StepDownResult,
    basin,
    gait_sensitivity_norm,
    step_down,
)
from ..analyses.series import GaitSeries, walk_series
from ..core.protocol import Walker
from ..core.walker import HybridWalker
from . import page as P
from .animation import Scene, player_data, scene, write_gif
from .comparison import REFERENCES, ComparisonRow, compare, differing_conditions, doc_link
from .figures import (
    fig_angles,
    fig_basin,
    fig_bifurcation,
    fig_energy,
    fig_energy_per_step,
    fig_floquet,
    fig_limit_cycle,
    fig_step_down,
)
from .labels import METRICS, describe, is_nondimensional, parameter, shown_unit
from .view3d import is_3d, walker_scene

if TYPE_CHECKING:
    from porthamiltonian.interfaces.viewer import Scene as Scene3D

__all__ = ["EXTRA_FIGURES", "ExtraFigure", "ReportResult", "load_summary", "write_report"]


@dataclass(frozen=True)
class ExtraFigure:
    """An optional figure section of the report.

    title : the section's heading. filename : the PNG written into the report's directory.
    draw : ``draw(walker, gait, path)`` writes the PNG at ``path`` and returns a caption (one
        or two sentences: what is drawn, units), or None to leave the section out (e.g. when the
        data it needs does not exist).
    """

    title: str
    filename: str
    draw: Callable[[Walker, GaitResult, Path], str | None]


#: extra figure sections every report tries (see :class:`ExtraFigure`)
EXTRA_FIGURES: list[ExtraFigure] = []


@dataclass
class ReportResult:
    """What :func:`write_report` wrote: the directory, the files, the analyses and the time."""

    out: Path
    files: list[str]
    gait: GaitResult
    step_down: StepDownResult | None
    basin: BasinResult | None
    seconds: float


def write_report(walker: HybridWalker, out: str | Path, *, n_steps: int = 6, with_step_down: bool = True,
                 with_basin: bool = False, basin_n: int = 9, step_down_resolution: float | None = None,
                 forces: bool = False, extra: Sequence[ExtraFigure] | None = None,
                 view3d: bool | None = None, continuation: ContinuationResult | None = None,
                 log: Callable[[str], None] | None = None) -> ReportResult:
    """Analyse ``walker`` and write the report into directory ``out`` (module docstring).

    n_steps : steps of the recorded walk (figures, animation). forces : draw the contact-force
    arrows in the GIF (the page's player has a switch for them either way). extra : extra figure
    sections (default :data:`EXTRA_FIGURES`). view3d : the interactive 3D view (default: for a
    3D walker only; True: for a planar walker too, beside its 2D player; False: never).
    continuation : a continuation of the gait (:func:`~.continuation.continue_gait`) whose
    bifurcation diagram, bifurcations and branch table the report includes.
    ``log`` receives progress lines."""
    t0 = time.perf_counter()
    say = log or (lambda msg: None)
    out = make_folder(out)
    nondim = is_nondimensional(walker)
    files: list[str] = []
    images: dict[str, tuple[str, bytes]] = {}

    def put(name: str, data: bytes, mime: str = "image/png") -> None:
        files.append(name)
        images[name] = (mime, data)

    def dump(name: str, obj: Any) -> None:
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
    put("angles.png", fig_angles(series, out / "angles.png", nondim))
    put("limit_cycle.png", fig_limit_cycle(series, out / "limit_cycle.png", nondim))
    put("energy.png", fig_energy(series, out / "energy.png", nondim))
    put("energy_per_step.png", fig_energy_per_step(series, out / "energy_per_step.png", nondim))
    say(f"{walker.name}: animation")
    sc = scene(walker, series)
    put("walk.gif", write_gif(sc, out / "walk.gif", forces=forces, nondimensional=nondim),
        "image/gif")
    three_d = is_3d(walker, series)
    scene3d = None
    if three_d if view3d is None else view3d:
        say(f"{walker.name}: 3D view")
        scene3d = walker_scene(walker, series, sc, step_period=period)
        put("view3d.png", scene3d.to_png(out / "view3d.png").read_bytes())
    sd = bas = gsn = None
    if periodic:
        put("floquet.png", fig_floquet(gait.floquet_multipliers, gait.multiplier_error,
                                       out / "floquet.png"))
        if with_step_down:
            say(f"{walker.name}: step-down test")
            sd = step_down(walker, gait, resolution=step_down_resolution)
            dump("step_down.json", sd)
            put("step_down.png", fig_step_down(sd, out / "step_down.png", nondim))
        say(f"{walker.name}: gait sensitivity norm")
        gsn = gait_sensitivity_norm(walker, gait)
        dump("gsn.json", gsn)
        if with_basin:
            say(f"{walker.name}: basin of attraction ({basin_n}×{basin_n})")
            bas = basin(walker, gait, n=basin_n)
            dump("basin.json", bas)
            put("basin.png", fig_basin(bas, out / "basin.png"))
    extras = []
    for section in EXTRA_FIGURES if extra is None else extra:
        say(f"{walker.name}: {section.title}")
        caption = section.draw(walker, gait, out / section.filename)
        if caption is not None:
            put(section.filename, (out / section.filename).read_bytes())
            extras.append((section, caption))
    if continuation is not None:
        put("bifurcation_diagram.png", fig_bifurcation(continuation, out / "bifurcation_diagram.png"))
        dump("continuation.json", continuation.to_dict())
    comparison = compare(walker, gait, sd)
    ledger = {"max_abs_residual": float(np.max(np.abs(series.residual))),
              "energy_dissipated": float(series.E_diss[-1]), "energy_supplied": float(series.E_in[-1]),
              "steps": len([s for s in series.strides if not s.fell])}
    summary = {"model": walker.name, "units": "nondimensional" if nondim else "SI",
               "gait": gait_d, "step_down": sd, "gsn": gsn, "basin": bas,
               "comparison": [r.__dict__ for r in comparison], "walk_ledger": ledger,
               "continuation": None if continuation is None else continuation.to_dict()}
    dump("report.json", summary)
    body = _body(walker, gait, sd, gsn, bas, comparison, ledger, series, sc, images, extras, out,
                 (scene3d, three_d), continuation)
    (out / "report.html").write_text(P.page(f"{walker.name} — walker report", body,
                                            with_player=not three_d,
                                            with_viewer=scene3d is not None))
    files.append("report.html")
    seconds = time.perf_counter() - t0
    say(f"{walker.name}: report written to {out / 'report.html'} in {seconds:.1f} s")
    return ReportResult(out, files, gait, sd, bas, seconds)


# --- the page's sections -------------------------------------------------------------------------
def _u(unit: str, nondim: bool) -> str:
    return shown_unit(unit, nondim) or "—"


def _header(walker: HybridWalker, gait: GaitResult, sd: StepDownResult | None, nondim: bool) -> str:
    badges = []
    if gait.status == "periodic":
        kind = "stable" if gait.stable else "unstable"
        badges.append((f"{kind} period-{gait.period_steps} gait", "good" if gait.stable else "warn"))
    elif gait.status == "fell":
        badges.append((f"falls during step {gait.fell_at_step}", "warn"))
    else:
        badges.append(("no periodic gait found", "warn"))
    badges.append(("nondimensional model (g = l = 1): values are ratios, not SI" if nondim
                   else "SI units", ""))
    b = "".join(f'<span class="badge {c}">{html.escape(t)}</span>' for t, c in badges)
    m = gait.metrics
    cards = [("speed", m.speed, "speed"), ("step length", m.step_length, "step_length"),
             ("step period", m.step_period, "step_period"),
             ("energy per step", m.energy_dissipated_per_step, "energy_dissipated_per_step"),
             ("cost of transport", m.cost_of_transport, "cost_of_transport")]
    cells = [(k, _with_unit(P.number(v, 4), METRICS[n].unit, nondim))
             for k, v, n in cards if v is not None and math.isfinite(v)]
    if gait.floquet_multipliers:
        cells.append(("largest |λ|", P.number(max(abs(complex(x)) for x in gait.floquet_multipliers), 3)))
    if sd is not None and sd.max_step_down is not None:
        cells.append(("largest step-down survived", _length(sd.max_step_down, nondim)))
    card_html = "".join(f'<div class="card"><div class="k">{html.escape(k)}</div>'
                        f'<div class="v">{html.escape(v)}</div></div>' for k, v in cells)
    return (f"<header><h1>Walker report: {html.escape(walker.name)}</h1>"
            f'<p class="lead">{html.escape(walker.doc)}</p><div class="badges">{b}</div>'
            + ("" if gait.status == "periodic" else
               f"<p>{html.escape(gait.message[:1].upper() + gait.message[1:])}.</p>")
            + f'<div class="cards">{card_html}</div></header>')


def _with_unit(value: str, unit: str, nondim: bool) -> str:
    """``"0.305 m/s"``; a ratio (unit 1) without a unit."""
    return value if unit in ("1", "") else f"{value} {shown_unit(unit, nondim)}"


def _length(value: float, nondim: bool) -> str:
    return f"{value:.3g} (nondim.)" if nondim else f"{value * 1e3:.3g} mm"


def _comparison_html(walker: HybridWalker, rows: list, out: Path) -> str:
    ref = REFERENCES.get(walker.name)
    if ref is None:
        return ""
    head = (f"<h2 id=\"comparison\">Compared with the published numbers</h2>"
            f"<p>Source: {html.escape(ref.publication.citation)}.</p>")
    if not rows:
        differ = differing_conditions(walker)
        what = ", ".join(f"{k} = {ours:g} (published: {theirs:g})"
                         for k, (ours, theirs) in differ.items())
        return head + (f"<p>Not compared: the published numbers hold for other parameter values "
                       f"than this run's: {html.escape(what)}.</p>")
    cells: list[Any] = []
    for k, r in enumerate(rows):
        if r.agrees is None:
            verdict = P.Html("—")
        else:
            verdict = P.Html('<span class="ok">within tolerance</span>' if r.agrees
                             else '<span class="bad">outside tolerance</span>')
        link = doc_link(r.doc, r.heading, out)
        where = f"{r.doc} § {r.heading.split(' (`')[0]}"
        more = (f' <a href="{html.escape(link)}">{html.escape(where)}</a>' if link
                else f" ({html.escape(where)})")
        dev = "—" if r.deviation is None else f"{100 * r.deviation:+.2g}\u00a0%"
        tol = "—" if r.tolerance is None else f"±\u00a0{r.tolerance:.2g}"
        cells.append([P.named(r.label, r.quantity), r.unit, r.printed,
                      P.Html(f'<span class="where">{html.escape(r.where)}</span>'),
                      _to_tolerance(r.ours, r.tolerance), dev, tol, verdict])
        if k + 1 < len(rows) and rows[k + 1].explanation == r.explanation:
            continue                            # one note under rows that share it
        why = r.explanation[:1].upper() + r.explanation[1:]
        cells.append(P.Note(f"{html.escape(why)}.{more}"))
    table = P.table(["quantity", "unit", "published", "where", "ours", "deviation",
                     "tolerance", "verdict"], cells, numeric=(2, 4, 5, 6))
    note = ("<p>Deviation: (ours − published) / |published|. Tolerance: half a unit of the "
            "published value's last printed digit plus the uncertainty that can be stated for "
            "the comparison (our step-down grid, the model limit of the published result, the "
            "published finite-difference accuracy); the integration and Newton tolerances of "
            "ours are far below it.</p>")
    return head + table + note


def _to_tolerance(value: float | None, tolerance: float | None) -> str:
    """Our value with one decimal more than the tolerance's first digit (6 significant digits at
    least), so that a difference within the tolerance shows."""
    if value is None or tolerance is None or not tolerance > 0:
        return P.number(value)
    decimals = max(0, 1 - math.floor(math.log10(tolerance)))
    shown = f"{value:.{decimals}f}"
    return shown if len(shown.strip("-0.")) >= 6 else P.number(value)


def _gait_tables(walker: HybridWalker, gait: GaitResult, nondim: bool) -> str:
    m = gait.metrics.to_dict()
    rows = [[P.named(q.label, k), m[k], _u(q.unit, nondim), q.doc]
            for k, q in METRICS.items() if k in m]
    parts: list[str] = [P.table(["gait metric", "value", "unit", "meaning"], rows, numeric=(1,))]
    fp = gait.fixed_point or {}
    if gait.status == "periodic" and fp:
        thesis = [k for k in walker.thesis_section if k in fp]
        derived = [k for k in ("theta", "phi", "theta_dot", "phi_dot", "hip_speed", "hub_speed")
                   if k in fp and k not in thesis]
        own = [k for k in fp if k not in thesis and k not in derived]
        label = ("Fixed point on the Poincaré section (the state at heel strike that the gait "
                 "returns to every period), in the thesis's coordinates")

        def rows_of(keys: list[str]) -> list[list[Any]]:
            return [[P.named(describe(walker, k).label, k), fp[k],
                     _u(describe(walker, k).unit, nondim), describe(walker, k).doc] for k in keys]
        parts.append(f"<h3>{html.escape(label)}</h3>")
        parts.append(P.table(["coordinate", "value", "unit", "meaning"],
                             rows_of(thesis + derived), numeric=(1,)))
        parts.append("<details><summary>the same state in the model's own coordinates</summary>"
                     + P.table(["coordinate", "value", "unit", "joint"], rows_of(own),
                               numeric=(1,)) + "</details>")
    elif gait.last_iterate:
        parts.append("<h3>Last state reached</h3>" + P.table(
            ["coordinate", "value", "unit"],
            [[P.named(describe(walker, k).label, k), v, _u(describe(walker, k).unit, nondim)]
             for k, v in gait.last_iterate.items()], numeric=(1,)))
    return "".join(parts)


def _floquet_html(gait: GaitResult, images: dict) -> str:
    if not gait.floquet_multipliers:
        return ""
    eps = gait.multiplier_error
    rows, small = P.multiplier_cells(gait.floquet_multipliers, eps)
    n = len(gait.floquet_multipliers)
    text = (f"<p>The {n} eigenvalues of the stride map's Jacobian at the fixed point (finite "
            f"differences, Richardson-extrapolated). Their error estimate ε = {P.number(eps, 2)} "
            "sets the printed decimals; "
            + (f"{small} of them are smaller than ε and shown as “&lt; ε”: their digits are "
               "noise. " if small else "")
            + f"The gait is {'stable' if gait.stable else 'unstable'}: "
            + ("every multiplier lies inside the unit circle.</p>" if gait.stable else
               "some multiplier lies on or outside the unit circle.</p>"))
    table = P.table(["multiplier λ", "|λ|"], rows, numeric=(0, 1), stack=False)
    fig = P.figure(images, "floquet.png", "Floquet multipliers in the complex plane",
                   "The multipliers in the complex plane; the unit circle is the stability limit, "
                   "the shaded disc |λ| < ε the error estimate; ×n counts overlapping points.")
    return (f'<h2 id="floquet">Floquet multipliers</h2>{text}<div class="grid2"><div>{table}'
            f"</div><div>{fig}</div></div>")


def _view3d_html(walker: HybridWalker, scene3d: Scene3D, three_d: bool, images: dict) -> str:
    """The interactive 3D view (its still image inside, for browsers without WebGL)."""
    from porthamiltonian.interfaces.viewer.page import block
    gamma = scene3d.ground.slope if scene3d.ground is not None else 0.0
    what = ("The walker's bodies at their poses" if three_d else
            "The same walk set upright in 3D (the model is planar: its legs share one plane; "
            "they are drawn 0.1 leg lengths apart sideways so that neither hides the other)")
    cap = (f"{what}, on the slope (γ = {gamma:.3g} rad, drawn at its angle); a stride starts at "
           "each heel strike. view3d.png beside this page is a still image of it.")
    return block(scene3d, element_id="view3d", caption=cap, still=images["view3d.png"][1],
                 label=f"3D view of {walker.name} walking")


def _walk_html(walker: HybridWalker, gait: GaitResult, ledger: dict, sc: Scene, images: dict,
               nondim: bool, view: tuple) -> str:
    J = _u("J", nondim)
    tunit = "nondimensional time" if nondim else "s"
    step_period = gait.metrics.step_period
    scale = (1.0 / step_period if nondim and math.isfinite(step_period) and step_period > 0
             else 1.0)
    cap = (f"All {sc.n_steps} recorded step{'' if sc.n_steps == 1 else 's'}, looping; the slope (γ = {sc.slope:.3g} rad) drawn at "
           f"its angle, {'arc feet at their radius' if np.any(sc.radius > 0) else 'point feet'}. "
           "Click the picture or the button to pause; drag the slider to scrub"
           + ("; the contact forces switch on arrows (the weight is drawn 0.35 leg lengths long)"
              if sc.force is not None else "") + ".")
    scene3d, three_d = view
    player: str = P.player(player_data(sc), time_unit=tunit, time_scale=scale, caption=cap)
    if scene3d is not None:
        shown = _view3d_html(walker, scene3d, three_d, images)
        player = shown if three_d else (player + "<h3>In three dimensions</h3>" + shown)
    gif = P.figure(images, "walk.gif", "animation of the walk (GIF)",
                   "The same walk as an animated GIF (walk.gif beside this page), for slides.")
    start = "the fixed point" if gait.status == "periodic" else "the initial guess"
    legged = walker.legged
    steps = ledger["steps"]
    fell = " until it fell" if gait.status == "fell" else ""
    return (f'<h2 id="motion">The walk</h2><p>{steps} step{"" if steps == 1 else "s"} from '
            f"{start}{fell} in one simulation; energy dissipated {ledger['energy_dissipated']:.6g} {J}, supplied "
            f"{ledger['energy_supplied']:.6g} {J}; the ledger residual "
            f"|H − H(0) + E_diss − E_in| stays below {ledger['max_abs_residual']:.2g} {J} "
            "throughout.</p>"
            + player + f"<details><summary>GIF</summary>{gif}</details>"
            + P.figure(images, "angles.png", "leg angles over time",
                       ("θ (stance leg to the slope normal) and φ (between the legs) over time. "
                        "At each heel strike (dotted lines) the legs exchange roles, so θ and φ "
                        "jump: the jump is a reset, drawn dashed." if legged else
                        "θ (the stance leg to the slope normal) over time. At each heel strike "
                        "(dotted lines) the next leg takes over, so θ jumps: the jump is a "
                        "reset, drawn dashed."))
            + P.figure(images, "limit_cycle.png", "limit cycle",
                       "The limit cycle as phase portraits: the flow of each step solid, the "
                       "heel-strike reset dashed, the states just before (open) and just after "
                       "(filled) the heel strike marked.")
            + P.figure(images, "energy.png", "energy ledger",
                       "The energy ledger: potential, kinetic and total energy, the energy "
                       "dissipated and supplied; below, the ledger residual, zero up to "
                       "integration error.")
            + P.figure(images, "energy_per_step.png", "energy per step",
                       "Energy dissipated and potential energy released per step: equal on a "
                       "periodic gait."))


def _robustness_html(walker: HybridWalker, sd: StepDownResult | None, gsn: GSNResult | None,
                     bas: BasinResult | None, images: dict, nondim: bool) -> str:
    parts = []
    if sd is not None and sd.status == "ok":
        grid = _length(sd.resolution, nondim) if math.isfinite(sd.resolution) else "given heights"
        beyond = [iv for iv in sd.survived_intervals
                  if sd.contiguous_limit is None or iv[0] > sd.contiguous_limit]
        verdict = ("no height survived" if not sd.survived_intervals else
                   "every lower height survived too" if sd.contiguous else
                   "survived beyond it: " + ", ".join(
                       f"{_length(a, nondim)} to {_length(b, nondim)}" for a, b in beyond))
        parts.append(
            f'<h2 id="step-down">Step-down</h2><p>The surface drops once, ahead of the stance '
            f"foot, and stays down; a height counts as survived when the walker is back within "
            f"{sd.tol:g} of the fixed point (in the section's coordinates) after {sd.n_steps} "
            f"steps. Heights scanned on a grid of {grid} up to {_length(sd.window, nondim)}, "
            f"each boundary of the survived set bisected to {_length(sd.boundary_tol, nondim)}: "
            f"every drop up to {_length(sd.contiguous_limit or 0.0, nondim)} survived; the "
            f"largest survived is {_length(sd.max_step_down or 0.0, nondim)}; {verdict}.</p>"
            + P.figure(images, "step_down.png", "step-down cases",
                       "Each height tried: survived (converged) or fell."))
    if gsn is not None and gsn.status == "ok":
        unit = {"step_period": "s/m", "step_length": "m/m"}
        rows = [[P.named(describe(walker, k).label, k), P.number(v, 4),
                 "nondim." if nondim else unit.get(k, "1/m"),
                 f"sensitivity of the {describe(walker, k).label} to the step-down height"]
                for k, v in gsn.by_indicator.items()]
        parts.append(
            f'<h2 id="gsn">Gait Sensitivity Norm</h2><p>The 2-norm over the steps after a small '
            f"step-down of the indicators' deviations from the gait, per m of drop (Hobbelen & "
            f"Wisse 2007): GSN = {gsn.gsn:.4g} (error estimate {gsn.error:.2g}).</p>"
            + P.table(["indicator", "norm", "unit", "meaning"], rows, numeric=(1,)))
    if bas is not None:
        parts.append(f'<h2 id="basin">Basin of attraction</h2><p>{html.escape(bas.message)}; '
                     f"the thesis's scaled coordinates θ/{bas.theta_scale:g} rad and "
                     f"θ̇/{bas.theta_dot_scale:g} rad/s.</p>"
                     + P.figure(images, "basin.png", "basin of attraction",
                                "Grid points that converge to the gait (stars) and the others."))
    return "".join(parts)


def _continuation_html(c: ContinuationResult | None, images: dict) -> str:
    if c is None:
        return ""
    label = c.path.label
    bifs = (P.table(["bifurcation", "branch", "period", label, "± (from the multiplier's error)",
                     "critical multiplier", "period-doubled branch"],
                    [[b.kind.replace("_", "–"), b.branch, b.period, f"{b.mu:.12g}",
                      f"{b.mu_error:.1g}", f"{complex(b.multiplier):.6f}",
                      "" if b.child is None else
                      f"{b.child} (joins it: followed already)" if b.joins else b.child]
                     for b in c.bifurcations], numeric=(3, 4))
            if c.bifurcations else "<p>No bifurcation in the range.</p>")
    rows = [[r["branch"], r["period_steps"], f"{r[label]:.8g}", f"{r['max_multiplier']:.6f}",
             "yes" if r["stable"] else "no", f"{r['step_period']:.6g}"] for r in c.table()]
    branch = P.table(["branch", "period", label, "max |λ|", "stable", "step period (s)"], rows,
                     numeric=(2, 3, 5))
    fig = P.figure(images, "bifurcation_diagram.png", "bifurcation diagram",
                   f"Bifurcation diagram in {label}: the largest Floquet multiplier modulus (top) "
                   "and the duration of each step of the orbit (bottom); stable solid, unstable "
                   "dashed, bifurcations marked.")
    return (f'<h2 id="continuation">Continuation in {html.escape(label)}</h2>'
            f"<p>{html.escape(c.message)}.</p>" + fig + bifs
            + f"<details><summary>The branches ({len(rows)} points)</summary>{branch}</details>")


def _parameters_html(walker: HybridWalker, nondim: bool) -> str:
    rows = []
    for k, v in walker.parameters.items():
        q = parameter(walker, k)
        spec = walker.specs.get(k)
        default = v if spec is None else spec.value
        mark = "" if v == default else f" (file: {default:g})"
        rows.append([P.Html(f"<code>{html.escape(k)}</code>"), v, _u(q.unit, nondim),
                     q.doc + mark])
    return ('<h2 id="parameters">Parameters</h2>'
            + P.table(["parameter", "value", "unit", "meaning (from the model file)"], rows,
                      numeric=(1,)))


def _command(walker: HybridWalker) -> str:
    """The command that writes this report again (shell-quoted): the walker by its name when
    that name finds its file, else by the file's path; every parameter that differs from the
    file's value, exactly (repr)."""
    specs = walker.specs
    source = walker.spec.source
    target = walker.name
    if source:
        try:
            by_name = ph_io.model_path(walker.name).resolve() == Path(source).resolve()
        except (ModelError, OSError):
            by_name = False
        target = walker.name if by_name else source
    sets = [f"--set={k}={float(v)!r}" for k, v in walker.parameters.items()
            if k in specs and v != specs[k].value]
    return shlex.join(["walker", "report", target, *sets])


def _body(walker: HybridWalker, gait: GaitResult, sd: StepDownResult | None,
          gsn: GSNResult | None, bas: BasinResult | None, comparison: list[ComparisonRow],
          ledger: dict, series: GaitSeries, sc: Scene, images: dict,
          extras: list[tuple[ExtraFigure, str]], out: Path, view: tuple,
          continuation: ContinuationResult | None = None) -> str:
    nondim = is_nondimensional(walker)
    sections = [_header(walker, gait, sd, nondim)]
    toc = [("comparison", "comparison", walker.name in REFERENCES),
           ("motion", "the walk", True), ("gait", "gait", True),
           ("floquet", "multipliers", bool(gait.floquet_multipliers)),
           ("step-down", "step-down", sd is not None), ("gsn", "GSN", gsn is not None),
           ("basin", "basin", bas is not None),
           ("continuation", "continuation", continuation is not None),
           ("extra", "more figures", bool(extras)),
           ("parameters", "parameters", True)]
    sections.append('<nav class="toc">' + "".join(f'<a href="#{a}">{t}</a>'
                                                  for a, t, on in toc if on) + "</nav>")
    sections.append(_comparison_html(walker, comparison, out))
    sections.append(_walk_html(walker, gait, ledger, sc, images, nondim, view))
    sections.append('<h2 id="gait">Gait</h2>'
                    f"<p>Poincaré section: {html.escape(_section_words(walker))}.</p>"
                    + _gait_tables(walker, gait, nondim))
    sections.append(_floquet_html(gait, images))
    sections.append(_robustness_html(walker, sd, gsn, bas, images, nondim))
    sections.append(_continuation_html(continuation, images))
    if extras:
        sections.append('<h2 id="extra">More figures</h2>' + "".join(
            f"<h3>{html.escape(s.title)}</h3>" + P.figure(images, s.filename, s.title, caption)
            for s, caption in extras))
    sections.append(_parameters_html(walker, nondim))
    made = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    json_files = ", ".join(f for f in ("gait.json", "step_down.json", "gsn.json", "basin.json",
                                       "continuation.json", "report.json")
                           if (out / f).exists())
    sections.append(f"<footer><p>Made {made} by <code>{html.escape(_command(walker))}</code> "
                    f"(back end {html.escape(walker.backend)}). The results "
                    f"as JSON beside this page: {html.escape(json_files)}; the figures as PNG.</p>"
                    "</footer>")
    return "\n".join(s for s in sections if s)


def _section_words(walker: HybridWalker) -> str:
    names = [describe(walker, k).label for k in walker.thesis_section]
    return "the state at every heel strike, by " + ", ".join(names)


def load_summary(out: str | Path) -> dict:
    """The ``report.json`` written by :func:`write_report`."""
    return json.loads((Path(out) / "report.json").read_text())


"""The walker in motion: a :class:`Scene` (the stick figure at evenly spaced times, drawn in the
world frame), its GIF (:func:`write_gif`) and the data of the report's interactive player
(:func:`player_data`).

The scene is drawn as a reader expects: the world frame has x horizontal and z up, so the slope
descends at its real angle γ (the slope frame of the models — x down the slope, z along its
normal — rotated by −γ); the legs run from the hip to the feet; an arc foot (a contact that
reads the surface at ``<point>.z − R``, :func:`~.labels.foot_radius`) is drawn as an arc of
radius R about its centre, touching the ground where it rolls; a point foot as a dot. The
feet keep their colours through the heel strikes of a rigid walker, whose model swaps the roles
(stance, swing) of its legs: each frame's feet are matched to the previous frame's by distance.
Contact forces (the force on each foot from the components bonded to its body: contact and
friction, N) are kept when the model has them, for optional arrows.

Frames are interpolated inside the continuous pieces of the recorded run (never across a reset)
at a fixed rate, so every recorded step is in the loop.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from porthamiltonian import Component
from porthamiltonian.interfaces.viewer.sampling import resample

from ..analyses.series import GaitSeries
from ..core.walker import HybridWalker
from .figures import new_figure, styled
from .labels import foot_radius

__all__ = ["Scene", "arrow_scale", "contact_forces", "player_data", "scene", "write_gif"]

#: colours of the legs (the matplotlib default cycle's first two, also used by the player)
LEG_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728")
#: half-angle (rad) of the drawn arc of an arc foot
ARC_HALF_ANGLE = math.radians(55)


@dataclass
class Scene:
    """The stick figure at F evenly spaced times, in the world frame (x horizontal, z up; m).

    t (F,) s; step (F,) 0-based step index; hip (F, 2); feet (F, K, 2): the feet's points (an
    arc foot's centre); colour (F, K): the physical leg of each foot (for colours); radius (K,):
    arc radius of each foot (0: point foot); force (F, K, 2) N on each foot or None; contact
    (F, K, 2): where the force is drawn (the arc's lowest point on the ground normal);
    slope (rad); ground: two world points of the surface line; bounds (x0, x1, z0, z1) of the
    view; leg_length (m); weight (N); n_steps: strides recorded (a fall's last one included).
    """

    t: np.ndarray
    step: np.ndarray
    hip: np.ndarray
    feet: np.ndarray
    colour: np.ndarray
    radius: np.ndarray
    force: np.ndarray | None
    contact: np.ndarray
    slope: float
    ground: np.ndarray
    bounds: tuple[float, float, float, float]
    leg_length: float
    weight: float
    n_steps: int


def _world(slope: float, xz: np.ndarray) -> np.ndarray:
    """Slope-frame points (..., 2) -> world points: X = x cos γ + z sin γ, Z = −x sin γ + z cos γ."""
    c, s = math.cos(slope), math.sin(slope)
    x, z = xz[..., 0], xz[..., 1]
    return np.stack([x * c + z * s, -x * s + z * c], axis=-1)


def _body_points(walker: HybridWalker) -> dict[str, list[str]]:
    """The multibody's points and world-aligned frames by body (names ``<mb>.<point>``)."""
    mb = walker.multibody
    try:
        comp = walker.spec.model.component(mb)
        if not isinstance(comp, Component):     # a sub-model has no bodies
            return {}
        bodies = comp.value("bodies")
    except (AttributeError, KeyError, ValueError):
        return {}
    return {b: [f"{mb}.{p}" for key in ("points", "world_frames") for p in (d.get(key) or {})]
            for b, d in bodies.items()}


#: the efforts of a port of dimension 2, 3 or 6 that hold the force's x and z
_FORCE_XZ = {2: (0, 1), 3: (1, 2), 6: (3, 5)}


def contact_forces(walker: HybridWalker, traj: Any) -> np.ndarray | None:
    """Force (N, slope frame) on each foot over the points of ``traj``, shape (N, K, 2): the sum
    of the efforts of the components bonded to any point of the foot's body (power flows from
    the walker into them, so the force on the walker is minus their effort); None when no foot
    has such a component (rigid walkers: their impacts are impulses)."""
    bodies = _body_points(walker)
    outputs = {n: i for i, n in enumerate(traj.model.output_names)}
    Y = None
    forces = np.zeros((len(traj.t), len(walker.feet), 2))
    found = False
    bonds = walker.spec.model.freeze().bonds
    for k, point in enumerate(walker.feet):
        body = next((pts for pts in bodies.values() if point in pts), [point])
        for (tc, tp), (hc, hp) in bonds:
            for near, far, sign in (((tc, tp), (hc, hp), -1.0), ((hc, hp), (tc, tp), 1.0)):
                if f"{near[0]}.{near[1]}" not in body:
                    continue
                port = f"{far[0]}.{far[1]}"
                dim = sum(1 for i in range(6) if f"{port}.e{i}" in outputs)
                # the force's x and z among the efforts: a point's (f_x, f_z), a planar screw's
                # (τ_y, f_x, f_z), a screw's (τ, f)
                names = [f"{port}.e{i}" for i in _FORCE_XZ.get(dim, (0, 1))]
                if not all(n in outputs for n in names):
                    continue
                Y = traj.outputs if Y is None else Y
                forces[:, k] += sign * Y[:, [outputs[n] for n in names]]
                found = True
    return forces if found else None


def _identities(feet: np.ndarray) -> np.ndarray:
    """(F, K) index of the physical leg of each foot, keeping each leg's identity from frame to
    frame (the assignment that moves the feet least)."""
    F, K = feet.shape[:2]
    ident = np.zeros((F, K), dtype=int)
    ident[0] = np.arange(K)
    last = feet[0][np.argsort(ident[0])]           # positions by physical leg
    perms = list(itertools.permutations(range(K))) if K <= 4 else [tuple(range(K))]
    for f in range(1, F):
        best = min(perms, key=lambda p: sum(np.hypot(*(feet[f, p[j]] - last[j])) for j in range(K)))
        for leg, foot in enumerate(best):
            ident[f, foot] = leg
        last = feet[f][list(best)]
    return ident


def scene(walker: HybridWalker, s: GaitSeries, *, rate: float = 30.0, max_frames: int = 600) -> Scene:
    """The :class:`Scene` of a recorded walk at ``rate`` frames per second of simulated time
    (fewer when that would exceed ``max_frames``)."""
    duration = float(s.t[-1] - s.t[0])
    n = int(min(max_frames, max(2, round(duration * rate) + 1)))
    times = np.linspace(s.t[0], s.t[-1], n)
    slope = float(walker.parameters.get("slope", 0.0))
    values = {**{k: float(v.value) for k, v in walker.spec.model.parameters.items()},
              **walker.parameters}
    radius = np.array([foot_radius(walker, f, values) for f in walker.spec.feet])
    traj = s.strides[-1].info.get("trajectory") if s.strides else None
    raw_force = contact_forces(walker, traj) if traj is not None else None
    hip = _world(slope, resample(s.t, s.hip, times))
    feet = _world(slope, resample(s.t, s.feet, times))
    normal = np.array([math.sin(slope), math.cos(slope)])     # the slope normal in the world
    contact = feet - radius[None, :, None] * normal
    force = None
    if raw_force is not None:
        force = _world(slope, resample(s.t, raw_force, times))
    step = np.round(resample(s.t, s.step.astype(float), times)).astype(int)
    leg = float(walker.leg_length)
    pts = np.concatenate([hip[:, None, :], feet, contact], axis=1).reshape(-1, 2)
    pad = 0.12 * leg
    x0, x1 = float(pts[:, 0].min() - pad), float(pts[:, 0].max() + pad)
    ground = np.array([[x0, -x0 * math.tan(slope)], [x1, -x1 * math.tan(slope)]])
    z0 = float(min(pts[:, 1].min(), ground[:, 1].min()) - 0.08 * leg)
    z1 = float(pts[:, 1].max() + 0.08 * leg)
    steps = len(s.strides)                       # a fall's last stride included
    return Scene(t=times, step=step, hip=hip, feet=feet, colour=_identities(feet), radius=radius,
                 force=force, contact=contact, slope=slope, ground=ground,
                 bounds=(x0, x1, z0, z1), leg_length=leg,
                 weight=float(walker.weight), n_steps=steps)


def _arc(centre: np.ndarray, towards: np.ndarray, radius: float) -> np.ndarray:
    """Points of the arc of ``radius`` about ``centre`` facing along ``towards`` (unit)."""
    a = math.atan2(towards[1], towards[0])
    u = np.linspace(a - ARC_HALF_ANGLE, a + ARC_HALF_ANGLE, 25)
    return centre + radius * np.stack([np.cos(u), np.sin(u)], axis=1)


def _foot_direction(hip: np.ndarray, foot: np.ndarray) -> np.ndarray:
    d = foot - hip
    n = float(np.hypot(*d))
    return d / n if n > 0 else np.array([0.0, -1.0])


def arrow_scale(sc: Scene) -> float:
    """Metres of arrow per newton: the weight drawn as 0.35 leg lengths."""
    return 0.35 * sc.leg_length / max(sc.weight, 1e-12)


@styled
def write_gif(sc: Scene, path: Path, *, fps: int = 12, max_frames: int = 90,
              forces: bool = False, nondimensional: bool = False) -> bytes:
    """Write the scene as an animated GIF (looping, every recorded step) and return its bytes.
    Real time when the walk fits in ``max_frames`` frames at ``fps``, else faster (said in the
    frame's label). ``forces``: draw the contact-force arrows.

    The still parts (axes, ground, labels) are drawn once and each frame draws only the walker
    over them (blitting, at 90 dpi); the frames share one 255-colour palette (maximum
    coverage, so the flat colours stay exact) made from eight of them, instead of a palette per
    frame: 1 s instead of 6 s for 90 frames, the same picture (mean difference 0.2 of 255)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image

    duration = float(sc.t[-1] - sc.t[0])
    n = int(min(max_frames, max(2, round(duration * fps) + 1)))
    frames = np.unique(np.round(np.linspace(0, len(sc.t) - 1, n)).astype(int))
    speedup = duration / max(len(frames) / fps, 1e-12)
    x0, x1, z0, z1 = sc.bounds
    width = 7.0
    left, right, bottom, top = 0.62, 0.12, 0.48, 0.3
    ax_w = width - left - right
    ax_h = ax_w * (z1 - z0) / (x1 - x0)
    height = ax_h + bottom + top
    fig = new_figure(figsize=(width, height), layout=None)
    ax = fig.add_axes((left / width, bottom / height, ax_w / width, ax_h / height))
    ax.set_xlim(x0, x1)
    ax.set_ylim(z0, z1)
    ax.set_aspect("equal")
    ax.fill_between(sc.ground[:, 0], sc.ground[:, 1], z0, color="0.9", zorder=0)
    ax.plot(sc.ground[:, 0], sc.ground[:, 1], color="0.35", lw=1.2, zorder=1)
    unit = "nondim." if nondimensional else "m"
    ax.set_xlabel(f"horizontal x ({unit})")
    ax.set_ylabel(f"height z ({unit})")
    K = sc.feet.shape[1]
    legs = [ax.plot([], [], lw=2.4, solid_capstyle="round", zorder=3)[0] for _ in range(K)]
    soles = [ax.plot([], [], lw=2.4, zorder=3)[0] for _ in range(K)]
    hip = ax.plot([], [], "o", color="k", ms=9, zorder=4)[0]
    arrows = [ax.plot([], [], color="C3", lw=1.6, zorder=5)[0] for _ in range(K)] if forces else []
    heads = [ax.plot([], [], "^", color="C3", ms=5, zorder=5)[0] for _ in range(K)] if forces else []
    label = ax.text(0.0, 1.02, "", transform=ax.transAxes, fontsize=8, va="bottom")
    slope_text = f"slope γ = {sc.slope:.3g} rad ({math.degrees(sc.slope):.2g}°), to scale"
    ax.text(1.0, 1.02, slope_text, transform=ax.transAxes, fontsize=8, va="bottom", ha="right")
    scale = arrow_scale(sc)
    tunit = "nondim. time" if nondimensional else "s"
    pace = ("" if nondimensional else " · real time" if abs(speedup - 1) < 0.05
            else f" · {speedup:.2g}× real time")

    def draw(k: int) -> list[Any]:
        f = frames[k]
        h = sc.hip[f]
        for j in range(K):
            colour = LEG_COLOURS[sc.colour[f, j] % len(LEG_COLOURS)]
            c = sc.feet[f, j]
            legs[j].set_data([h[0], c[0]], [h[1], c[1]])
            legs[j].set_color(colour)
            if sc.radius[j] > 0:
                arc = _arc(c, _foot_direction(h, c), sc.radius[j])
                soles[j].set_data(arc[:, 0], arc[:, 1])
                soles[j].set_marker("")
            else:
                soles[j].set_data([c[0]], [c[1]])
                soles[j].set_marker("o")
            soles[j].set_color(colour)
            if forces and sc.force is not None:
                p, F = sc.contact[f, j], sc.force[f, j] * scale
                on = float(np.hypot(*F)) > 0.02 * sc.leg_length
                arrows[j].set_data([p[0], p[0] + F[0]] if on else [], [p[1], p[1] + F[1]] if on else [])
                heads[j].set_data([p[0] + F[0]] if on else [], [p[1] + F[1]] if on else [])
        hip.set_data([h[0]], [h[1]])
        label.set_text(f"t = {sc.t[f]:.2f} {tunit} · step {sc.step[f] + 1} of {sc.n_steps}{pace}")
        return [*legs, *soles, hip, *arrows, *heads, label]

    fig.set_dpi(90)
    canvas = FigureCanvasAgg(fig)
    moving = draw(0)
    for artist in moving:
        artist.set_animated(True)          # left out of the still background
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    images = []
    for k in range(len(frames)):
        canvas.restore_region(background)
        for artist in draw(k):
            ax.draw_artist(artist)
        images.append(Image.frombuffer("RGBA", canvas.get_width_height(),
                                       bytes(canvas.buffer_rgba()), "raw", "RGBA", 0, 1)
                      .convert("RGB"))
    samples = images[:: max(1, len(images) // 8)]
    w, h = images[0].size
    strip = Image.new("RGB", (w, h * len(samples)))
    for i, im in enumerate(samples):
        strip.paste(im, (0, i * h))
    palette = strip.quantize(colors=255, method=Image.Quantize.MAXCOVERAGE)
    gif = [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in images]
    gif[0].save(path, format="GIF", save_all=True, append_images=gif[1:],
                duration=int(1000 / fps), loop=0)
    return Path(path).read_bytes()


def player_data(sc: Scene) -> dict:
    """The scene for the report's player (JSON-able; positions rounded to 0.1 mm, forces to
    0.01 N): frame times, steps, hip, feet, colours, radii, forces, the view and the ground."""
    r4 = lambda a: np.round(np.asarray(a, dtype=float), 4).tolist()
    data = {"t": r4(sc.t), "step": sc.step.tolist(), "hip": r4(sc.hip), "feet": r4(sc.feet),
            "colour": sc.colour.tolist(), "radius": r4(sc.radius), "contact": r4(sc.contact),
            "bounds": list(map(float, sc.bounds)), "ground": r4(sc.ground),
            "slope": sc.slope, "legLength": sc.leg_length, "nSteps": sc.n_steps,
            "arcHalfAngle": ARC_HALF_ANGLE, "colours": list(LEG_COLOURS),
            "arrowScale": arrow_scale(sc)}
    if sc.force is not None:
        data["force"] = np.round(sc.force, 2).tolist()
    return data

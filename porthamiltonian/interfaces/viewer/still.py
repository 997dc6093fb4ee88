"""The scene as a still image (PNG, matplotlib 3D): for printed reports, slides and browsers
without WebGL.

The bodies are drawn at a few times (by default the start of each stride, at most five, and the
last frame), the earlier ones faded; a thin line traces each body's origin over the whole run;
the ground lies under the motion; the axes are to scale (equal lengths on all three), in the
world frame with the scene's up axis vertical. Uses the Agg back end (no window, no pyplot state).
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ...escaping import plain_text
from .quaternions import AXES, rotate

if TYPE_CHECKING:
    from .scene import Scene

__all__ = ["still_frames", "write_png"]


def still_frames(scene: Scene, times: Sequence[float] | None = None) -> list[int]:
    """Frame indices drawn for ``times`` (the nearest frames), or by default: the frames at the
    start of each stride (the last five at most) and the last frame; without strides, three
    evenly spaced frames and the last."""
    t = scene.t
    if times is None:
        starts = list(scene.strides[-5:]) if len(scene.strides) else list(
            np.linspace(t[0], t[-1], 4)[:-1])
        times = [*starts, t[-1]]
    idx = {int(np.argmin(np.abs(t - float(x)))) for x in times}
    return sorted(idx)


def write_png(scene: Scene, path: Path, *, times: Sequence[float] | None = None,
              elevation: float = 18.0, azimuth: float = -70.0, dpi: int = 110) -> Path:
    """Draw the still image of ``scene`` into ``path`` (see :meth:`Scene.to_png`); its text (the
    scene's title: a model's name) is plain text, never mathtext."""
    with plain_text():
        return _draw(scene, path, times=times, elevation=elevation, azimuth=azimuth, dpi=dpi)


def _draw(scene: Scene, path: Path, *, times: Sequence[float] | None, elevation: float,
          azimuth: float, dpi: int) -> Path:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    E = np.stack(AXES[scene.up])                 # rows: downhill x, lateral, up
    frames = still_frames(scene, times)
    size = scene.size()
    lo, hi = scene.bounds()
    fig = Figure(figsize=(7.2, 4.8), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="3d")
    plo, phi = (E @ lo, E @ hi)
    plo, phi = np.minimum(plo, phi) - 0.1 * size, np.maximum(plo, phi) + 0.1 * size
    if scene.ground is not None:
        u, w = scene.ground_region(lo, hi, 0.1 * size)
        polys = [q @ E.T for q in scene.ground.quads(scene.up, u, w)]
        ax.add_collection3d(Poly3DCollection(polys, facecolor=scene.ground.colour,
                                             edgecolor="#9aa3ad", linewidth=0.4, alpha=0.9))
        pts = np.concatenate(polys)
        plo, phi = np.minimum(plo, pts.min(axis=0)), np.maximum(phi, pts.max(axis=0))
    for body in scene.bodies:
        tint = body.shapes[0].colour if body.shapes else "#555555"
        path_pts = body.position @ E.T
        ax.plot(path_pts[:, 0], path_pts[:, 1], path_pts[:, 2], color=tint, lw=0.7, alpha=0.6)
    for n, k in enumerate(frames):
        alpha = 1.0 if n == len(frames) - 1 else 0.2 + 0.4 * n / max(1, len(frames) - 1)
        for body in scene.bodies:
            for shape in body.shapes:
                for grid in shape.surfaces(10):
                    local = np.stack(grid, axis=-1)
                    world = body.position[k] + rotate(body.orientation[k], local)
                    X, Y, Z = np.moveaxis(world @ E.T, -1, 0)
                    ax.plot_surface(X, Y, Z, color=shape.colour, alpha=alpha, linewidth=0,
                                    antialiased=False, shade=True)
    span = phi - plo
    ax.set_xlim(plo[0], phi[0])
    ax.set_ylim(plo[1], phi[1])
    ax.set_zlim(plo[2], phi[2])
    ax.set_box_aspect(tuple(np.maximum(span, 1e-3 * span.max())))
    unit = scene.length_unit
    ax.set_xlabel(f"x ({unit})")
    ax.set_ylabel(f"{'y' if scene.up == 'z' else '−z'} ({unit})")
    ax.set_zlabel(f"{scene.up} ({unit})")
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(4))
    ax.view_init(elev=elevation, azim=azimuth)
    shown = ", ".join(f"{scene.t[k]:.3g}" for k in frames)
    ax.set_title(f"{scene.title + ': ' if scene.title else ''}t = {shown} {scene.time_unit}",
                 fontsize=9)
    fig.savefig(path, dpi=dpi)
    return path

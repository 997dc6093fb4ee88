"""The 3D view in a real browser (headless Chromium with software WebGL, tests/browser.py: without
a browser these tests skip with a one-line reason, under CI they fail).

One page holds three views: the closed-form scene (a top in steady precession and a sphere
rolling down a slope with a step, tests/viewer/synthetic.py), an empty scene, and a scene whose
data names an unknown shape. Each view reports on its element (porthamiltonian.interfaces.viewer.page):
``data-viewer`` (ready, no-webgl or the error), ``data-drawn`` (pixels of its first picture that
differ from the background, read back from WebGL) and ``data-probe`` (where three.js put each
body's first shape at frame 0, compared here with the scene's own poses: a wrong quaternion order
or convention moves them). The empty view proves that the pixel count can be zero, the broken one
that an error reaches the console; a screenshot shows the bodies' colours on screen; without
WebGL the still image takes the view's place."""
from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
from browser import console_errors, render, run, screenshot
from synthetic import BALL, ball_slope_frame, top_pose

from porthamiltonian.interfaces.viewer import (
    Arrow,
    Body,
    Box,
    Cylinder,
    Ground,
    Scene,
    Sphere,
    TorusArc,
)
from porthamiltonian.interfaces.viewer.page import assets, block
from porthamiltonian.interfaces.viewer.quaternions import about_axis, multiply, rotate

TOP_RED, BALL_GREEN = "#d62728", "#2ca02c"


def closed_form_scene() -> Scene:
    t = np.linspace(0, 1.0, 61)
    pos, q = top_pose(t)
    top = Body("top", [Cylinder((0, 0, 0.030), (0, 0, 0.036), 0.035, colour=TOP_RED),
                       Cylinder((0, 0, 0), (0, 0, 0.06), 0.003, colour="#444444"),
                       Box((0.025, 0, 0.033), (0.01, 0.004, 0.008), colour="#1f77b4")],
               pos + [0.0, -0.12, 0.0], q)
    centre, qb = ball_slope_frame(t)
    turn = about_axis([0, 1, 0], BALL["slope"])
    ball = Body("ball", [Sphere((0, 0, 0), BALL["r"], colour=BALL_GREEN),
                         TorusArc((0, 0, 0), (0, 1, 0), (0, 0, -1), 1.05 * BALL["r"], 0.004,
                                  math.pi, colour="#ff7f0e")],
                rotate(turn, centre * [0.2, 1, 1]), multiply(turn, qb))
    weight = np.tile([0.0, 0, -0.5 * 9.81], (len(t), 1))
    return Scene(t, [top, ball], ground=Ground(slope=BALL["slope"], step_at=0.1, step_height=0.02),
                 arrows=[Arrow("weight", ball.position, weight, 0.02)], strides=[0.0, 0.4, 0.8],
                 title="closed-form scene")


def _page(path, views: list[str]) -> None:
    path.write_text('<!DOCTYPE html><html><head><meta charset="utf-8"></head><body>'
                    + "\n".join(views) + assets() + "</body></html>", encoding="utf-8")


def _attrs(dom: str, element_id: str) -> dict[str, str]:
    tag = re.search(rf'<figure[^>]*id="{element_id}"[^>]*>', dom)
    assert tag, f"view {element_id} missing"
    return dict(re.findall(r'(data-[a-z]+)="([^"]*)"', tag.group(0)))


@pytest.fixture(scope="module")
def scene() -> Scene:
    return closed_form_scene()


def test_views_draw_report_and_fail_visibly(scene, tmp_path):
    empty = Scene(np.array([0.0, 1.0]), [])
    broken = block(scene, element_id="broken").replace('"kind":"sphere"', '"kind":"cone"')
    page = tmp_path / "views.html"
    _page(page, [block(scene, element_id="good"), block(empty, element_id="empty"), broken])
    dom, console = render(page)
    good = _attrs(dom, "good")
    assert good["data-viewer"] == f"ready:{len(scene.t)}"
    drawn, total = map(int, good["data-drawn"].split("/"))
    assert total > 100_000 and drawn > 0.02 * total     # bodies, grid lines, the step, shadows
    probe = json.loads(good["data-probe"].replace("&quot;", '"'))
    for body, got in zip(scene.bodies, probe, strict=True):
        s = body.shapes[0]
        local = (np.add(s.a, s.b) / 2 if hasattr(s, "a") else np.array(s.center))
        expect = body.position[0] + rotate(body.orientation[0], local)
        assert np.allclose(got, expect, atol=2e-6 * scene.size() + 1e-6), body.name
    empty_view = _attrs(dom, "empty")
    assert empty_view["data-viewer"] == "ready:2" and empty_view["data-drawn"].startswith("0/")
    assert _attrs(dom, "broken")["data-viewer"] == "error: unknown shape cone"
    errors = console_errors(console)
    assert len(errors) == 1 and "unknown shape cone" in errors[0], console
    offline = dom.replace("http://www.w3.org", "")
    assert "http://" not in offline and "https://" not in offline


def test_the_view_is_on_screen_and_falls_back_to_its_still_image(scene, tmp_path):
    page = tmp_path / "view.html"
    still = scene.to_png(tmp_path / "still.png").read_bytes()
    _page(page, [block(scene, element_id="good", still=still)])
    shot = np.asarray(screenshot(page.resolve().as_uri(), 900, 760, tmp_path / "shot.png"),
                      dtype=int)
    r, g, b = shot[..., 0], shot[..., 1], shot[..., 2]
    assert ((g > r + 40) & (g > b + 40)).sum() > 200               # the green ball
    assert ((r > g + 60) & (r > b + 60)).sum() > 50                # the red top
    # without WebGL: the still image in the view's place, a warning, no error
    proc = run(["--disable-webgl", "--disable-3d-apis", "--dump-dom", page.resolve().as_uri()])
    console = [line for line in proc.stderr.splitlines() if ":CONSOLE" in line]
    assert _attrs(proc.stdout, "good")["data-viewer"] == "no-webgl"
    assert re.search(r'<figure class="ph-viewer" id="good"', proc.stdout)   # not "ph-live"
    assert any("no WebGL" in c for c in console), console
    assert not console_errors(console), console

"""The main job's report (walker_library.report, ``walker report``): files, figures, JSON, the
comparison with the publication, and the HTML page rendered by a real headless browser.

The browser (Chromium, tests/browser.py) is found on PATH. Without one these tests skip with a
one-line reason, unless ``CI`` is set: CI installs Chromium (.ci/run), so there a missing browser
fails.

The browser checks read the page's own load handler, which counts the images that decoded
(``data-images-ok="k/n"``) and marks the player ready (``data-player="ready:N"``), and
Chromium's console log (uncaught errors appear as CONSOLE lines); a deliberately broken page
proves the check can fail. The layout test takes screenshots at 1400 px and at a phone's
390 px: with ``?layout-check`` the page paints a square at its top left, green when nothing
overflows horizontally, red when the page is wider than the window (a wide page proves it)."""
from __future__ import annotations

import html
import json
import re
import shutil
from pathlib import Path

import browser
import pytest
from browser import console_errors, render
from PIL import Image

from walker_library.analyses import results
from walker_library.cli import main
from walker_library.report import writer as report_module
from walker_library.report.writer import ExtraFigure

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def screenshot(path: Path, width: int, height: int, out: Path) -> Image.Image:
    """A screenshot of the page at a window of ``width`` × ``height`` CSS px, in layout-check
    mode (see the module docstring)."""
    return browser.screenshot(path.resolve().as_uri() + "?layout-check", width, height, out)


def layout_mark(image: Image.Image) -> str:
    r, g, _ = image.getpixel((6, 6))
    return "ok" if (g > 200 and r < 60) else "overflow" if (r > 200 and g < 60) else "missing"


def _extra_figure(walker, gait, path: Path) -> str:
    """An extra section as another branch would add one (a continuation diagram, say)."""
    from walker_library.report.figures import new_figure, save_figure
    fig = new_figure(figsize=(3, 2))
    fig.subplots().plot([0, 1], [gait.metrics.speed, gait.metrics.speed])
    save_figure(fig, path)
    return f"speed of {walker.name} (a test figure)"


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    extras = [ExtraFigure("A test section", "extra.png", _extra_figure),
              ExtraFigure("Left out", "none.png", lambda walker, gait, path: None)]
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(report_module, "EXTRA_FIGURES", extras)
        # no notebook view registered, as in a fresh `walker` process (conftest: without_views)
        mp.setattr(results, "_VIEWS", {})
        assert main(["report", "simplest_walker", "--out", str(out), "--steps", "4",
                     "--view3d", "--quiet", "--continuation", "slope=0.0145:0.0152"]) == 0
    return out


def test_report_files_and_json(report):
    for name in ("report.html", "report.json", "gait.json", "step_down.json", "gsn.json",
                 "walk.gif", "angles.png", "limit_cycle.png", "energy.png",
                 "energy_per_step.png", "floquet.png", "step_down.png", "view3d.png",
                 "bifurcation_diagram.png", "continuation.json"):
        assert (report / name).is_file(), name
    summary = json.loads((report / "report.json").read_text())
    assert summary["gait"]["status"] == "periodic"
    assert summary["units"] == "nondimensional"
    # the comparison with Garcia et al. 1998 (Table 1): θ* = 0.20031090049483 within 1e-7
    # (β = 1e-9 instead of β -> 0), |λ|max = 0.5883 within Garcia's finite-difference accuracy
    rows = {r["quantity"]: r for r in summary["comparison"]}
    assert abs(rows["theta"]["ours"] - 0.20031090049483) < 1e-7
    assert rows["theta"]["agrees"] and rows["theta_dot"]["agrees"]
    assert rows["max_abs_multiplier"]["agrees"]
    assert abs(rows["max_abs_multiplier"]["ours"] - 0.58828) < 2e-3
    assert summary["walk_ledger"]["max_abs_residual"] < 1e-10
    assert isinstance(summary["step_down"]["max_step_down"], float)
    # --continuation: the flip of Garcia's gait in the range, its diagram and tables
    flips = [b for b in summary["continuation"]["bifurcations"] if b["kind"] == "flip"]
    assert len(flips) == 1 and flips[0]["mu"] == pytest.approx(0.0150884, abs=1e-6)
    assert "Continuation in slope" in (report / "report.html").read_text()


def test_every_figure_is_a_valid_png_and_the_gif_animates_every_step(report):
    pngs = sorted(report.glob("*.png"))
    assert len(pngs) == 9       # 6 figures, the bifurcation diagram, the 3D view's still, the extra
    assert not (report / "none.png").exists()
    for p in pngs:
        assert p.read_bytes()[:8] == PNG_SIGNATURE, p.name
        with Image.open(p) as im:
            im.verify()
        with Image.open(p) as im:
            assert im.format == "PNG" and im.size[0] > 200 and im.size[1] > 150
    with Image.open(report / "walk.gif") as gif:
        assert gif.format == "GIF" and gif.n_frames >= 40
        gif.seek(gif.n_frames - 1)
    page = (report / "report.html").read_text()
    data = json.loads(re.search(r'id="player-data">(.*?)</script>', page, re.DOTALL).group(1))
    assert data["nSteps"] == 4 and max(data["step"]) == 3       # all recorded steps play


def test_the_page_speaks_units_not_python(report):
    page = (report / "report.html").read_text()
    text = html.unescape(re.sub(r"<script.*?</script>|<style.*?</style>|<[^>]+>", " ", page,
                                flags=re.DOTALL))
    for literal in ("True", "False", "None", "nan"):
        assert not re.search(rf"\b{literal}\b", text), literal
    assert "nondimensional model" in text
    assert "The simplest walking model: stability, complexity, and scaling" in text
    # readable labels with the internal name on hover; multipliers below the error as "< ε"
    assert 'title="theta_dot">θ̇ stance-leg rate</span>' in page
    assert re.search(r"1 multiplier\s+< \d×10⁻[⁰¹²³⁴⁵⁶⁷⁸⁹]", text)


def test_report_opens_in_a_headless_browser_without_errors(report):
    dom, console = render(report / "report.html")
    m = re.search(r'data-images-ok="(\d+)/(\d+)"', dom)
    assert m, "the page's load handler did not run"
    ok, total = int(m.group(1)), int(m.group(2))
    assert total == 10 and ok == total          # 6 figures, the bifurcation diagram, the extra
    #                                             one, the GIF, the 3D view's still (hidden while
    #                                             WebGL draws)
    assert "A test section" in dom and "Left out" not in dom
    player = re.search(r'data-player="ready:(\d+)"', dom)
    assert player and int(player.group(1)) > 100, "the player did not start"
    # a planar walker keeps its 2D player; asked for, the 3D view comes beside it and draws
    tag = re.search(r'<figure class="ph-viewer ph-live" id="view3d"[^>]*>', dom)
    assert tag, "the 3D view did not start"
    view = dict(re.findall(r'(data-[a-z]+)="([^"]*)"', tag.group(0)))
    drawn, pixels = map(int, view["data-drawn"].split("/"))
    assert view["data-viewer"] == player.group(0).split('"')[1] and drawn > 0.02 * pixels
    assert not console_errors(console), console
    assert "Walker report: simplest_walker" in dom
    assert "http://" not in dom.replace("http://www.w3.org", "") and "https://" not in dom


def test_the_page_fits_a_wide_screen_and_a_phone(report, tmp_path):
    for width, height in ((1400, 900), (390, 844)):
        shot = screenshot(report / "report.html", width, height, tmp_path / f"report-{width}.png")
        assert shot.size == (width, height)
        assert layout_mark(shot) == "ok", f"horizontal overflow at {width} px"


def test_the_layout_check_catches_an_overflowing_page(report, tmp_path):
    page = (report / "report.html").read_text()
    wide = tmp_path / "wide.html"
    wide.write_text(page.replace("<main>", '<main><div style="width:900px">too wide</div>', 1))
    shot = screenshot(wide, 390, 844, tmp_path / "wide.png")
    assert layout_mark(shot) == "overflow"


def test_the_browser_check_catches_a_broken_page(tmp_path):
    page = tmp_path / "broken.html"
    page.write_text('<html><body><img src="missing.png"><script>throw new Error("boom")</script>'
                    "<script>window.addEventListener('load',function(){var im=document.images,ok=0;"
                    "for(var i=0;i<im.length;i++){if(im[i].naturalWidth>0){ok++;}}"
                    "document.body.setAttribute('data-images-ok',ok+'/'+im.length);});</script>"
                    "</body></html>")
    dom, console = render(page)
    assert 'data-images-ok="0/1"' in dom
    assert any("Uncaught Error: boom" in c for c in console)


def test_no_browser_skips_with_a_reason_but_fails_under_ci(monkeypatch):
    monkeypatch.setattr(shutil, "which", lambda name: None)
    monkeypatch.delenv("CI", raising=False)
    with pytest.raises(pytest.skip.Exception, match="needs a headless browser"):
        browser.chromium()
    monkeypatch.setenv("CI", "1")
    with pytest.raises(pytest.fail.Exception, match="CI installs it"):
        browser.chromium()

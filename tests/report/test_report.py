"""The main job's report (walker_library.report, ``walker report``): files, figures, JSON, and
the HTML page rendered by a real headless browser (Debian's Chromium, installed by .ci/run; the
test fails — never skips — when it is missing, saying how to install it).

The browser check reads the page's own load handler, which counts the images that decoded
(``data-images-ok="k/n"``), and Chromium's console log (uncaught errors appear as CONSOLE lines);
a deliberately broken page proves the check can fail."""
from __future__ import annotations

import json
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest
from PIL import Image

from walker_library.cli import main

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--enable-logging=stderr", "--v=0", "--virtual-time-budget=5000", "--dump-dom"]


def _chromium() -> str:
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.fail("the report test needs a headless browser: install Chromium "
                    "(Debian/Ubuntu: apt-get install -y chromium), as .ci/run does")
    return exe


def render(path: Path) -> tuple[str, list[str]]:
    """(DOM after load, console lines) of a local page in headless Chromium."""
    with tempfile.TemporaryDirectory() as profile:
        proc = subprocess.run([_chromium(), *CHROMIUM_FLAGS, f"--user-data-dir={profile}",
                               path.resolve().as_uri()], capture_output=True, text=True, timeout=120)
    console = [line for line in proc.stderr.splitlines() if ":CONSOLE" in line]
    return proc.stdout, console


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    assert main(["report", "simplest_walker", "--out", str(out), "--steps", "4", "--quiet",
                 "--continuation", "slope=0.0145:0.0152"]) == 0
    return out


def test_report_files_and_json(report):
    for name in ("report.html", "report.json", "gait.json", "step_down.json", "gsn.json",
                 "walk.gif", "angles.png", "limit_cycle.png", "energy.png",
                 "energy_per_step.png", "floquet.png", "step_down.png",
                 "bifurcation_diagram.png", "continuation.json"):
        assert (report / name).is_file(), name
    summary = json.loads((report / "report.json").read_text())
    assert summary["gait"]["status"] == "periodic"
    # the comparison with Garcia et al. 1998 (Table 1) is in the report
    rows = {r["quantity"]: r for r in summary["comparison"]}
    assert abs(rows["theta"]["deviation"]) < 1e-8
    assert summary["walk_ledger"]["max_abs_residual"] < 1e-10
    assert isinstance(summary["step_down"]["max_step_down"], float)
    # --continuation: the flip of Garcia's gait in the range, its diagram and tables
    flips = [b for b in summary["continuation"]["bifurcations"] if b["kind"] == "flip"]
    assert len(flips) == 1 and flips[0]["mu"] == pytest.approx(0.0150884, abs=1e-6)
    assert "Continuation in slope" in (report / "report.html").read_text()


def test_every_figure_is_a_valid_png_and_the_gif_animates(report):
    pngs = sorted(report.glob("*.png"))
    assert len(pngs) == 7
    for p in pngs:
        assert p.read_bytes()[:8] == PNG_SIGNATURE, p.name
        with Image.open(p) as im:
            im.verify()
        with Image.open(p) as im:
            assert im.format == "PNG" and im.size[0] > 200 and im.size[1] > 150
    with Image.open(report / "walk.gif") as gif:
        assert gif.format == "GIF" and gif.n_frames >= 20


def test_report_opens_in_a_headless_browser_without_errors(report):
    dom, console = render(report / "report.html")
    m = re.search(r'data-images-ok="(\d+)/(\d+)"', dom)
    assert m, "the page's load handler did not run"
    ok, total = int(m.group(1)), int(m.group(2))
    assert total == 8 and ok == total                 # 7 figures + the animation, all decoded
    assert not [c for c in console if "Uncaught" in c or "rror" in c], console
    assert "Walker report: simplest_walker" in dom


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

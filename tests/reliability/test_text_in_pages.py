"""Text from a model file in the pages and figures made of it (issue 21; porthamiltonian/
escaping.py): one rule for data embedded in HTML scripts, one for text handed to matplotlib.

Before: a model named ``<!--<script>`` hid most of the report in a browser (1 of 7 figures, 1 of
5 sections shown, the 3D view stuck at "loading", no error: the JSON in its ``<script>`` blocks
escaped ``</`` only); a ``$`` in a model's name or a parameter's unit crashed matplotlib's
mathtext (``porthamiltonian view``, ``walker report --view3d`` / ``--continuation``: a
ParseSyntaxException reported as a bug, no report written).

The escaping rule is checked on its own (every hostile payload round-trips through JSON.parse's
equal, json.loads, and no ``<``, ``>``, ``&``, U+2028/9 is left in the script), the figures with
``$`` in every text a user controls, and the whole chain in a headless browser (tests/browser.py;
under CI the browser must be there): a report and a 3D viewer page built from a hostile name
show every section, figure and script.
"""
from __future__ import annotations

import html
import json
import re
from pathlib import Path

import numpy as np
import pytest
from bounds import MODELS_DIR
from browser import console_errors, render

from porthamiltonian.escaping import PLAIN_TEXT, plain_text, script_json
from porthamiltonian.interfaces import cli
from porthamiltonian.interfaces.viewer import Body, Scene, Sphere
from porthamiltonian.interfaces.viewer.page import block
from walker_library.cli import main as walker_main
from walker_library.report.page import player

#: what a name, a unit or a description can hold that the pages and figures must survive
PAYLOADS = ["<!--<script>", "</script><script>alert(1)</script>", "]]></script>", "a & b &amp;",
            "x\u2028y\u2029z", "<img src=x onerror=alert(1)>", "$^$", "cost $5 and $x_{$",
            "<!-- -->", "\U0001f600 <b>bold</b>", "'\"`", "\\u003c already escaped"]
#: the model name of the browser test: the page's worst case (a name may not hold quotes,
#: backslashes or control characters, io._text_problem)
HOSTILE_NAME = "w <!--<script> </script> & $^$ <b>x</b>"
_UNSAFE = ("<", ">", "&", "\u2028", "\u2029")


@pytest.mark.parametrize("payload", PAYLOADS)
def test_script_json_round_trips_and_leaves_nothing_the_html_parser_reads(payload):
    data = {"name": payload, "list": [payload, {"k": payload}], "n": 1.5}
    for options in ({}, {"ensure_ascii": False}, {"indent": 1}):
        text = script_json(data, **options)
        assert not any(c in text for c in _UNSAFE), text
        assert json.loads(text) == data


@pytest.mark.parametrize("payload", PAYLOADS)
def test_the_player_and_the_viewer_embed_hostile_text_inertly(payload):
    scene = Scene(np.array([0.0, 1.0]), [Body("b", [Sphere((0, 0, 0), 0.1)],
                                              np.zeros((2, 3)), np.tile([1.0, 0, 0, 0], (2, 1)))],
                  title=payload)
    page = block(scene, caption=payload) + player({"t": [0.0, 1.0], "title": payload},
                                                  time_unit=payload, time_scale=1.0,
                                                  caption=payload)
    scripts = re.findall(r"<script[^>]*>(.*?)</script>", page, re.DOTALL)
    assert len(scripts) == 2
    for body in scripts:
        assert not any(c in body for c in _UNSAFE)
        assert payload in _strings(json.loads(body))          # the same text, read back
    assert html.escape(payload) in page                  # the captions, as text


def _strings(value) -> set[str]:
    if isinstance(value, dict):
        return set().union(*map(_strings, value.values())) if value else set()
    if isinstance(value, list):
        return set().union(*map(_strings, value)) if value else set()
    return {value} if isinstance(value, str) else set()


@pytest.mark.parametrize("payload", [p for p in PAYLOADS if "$" in p] + ["$\\frac$", "$$"])
def test_figures_take_dollars_as_text(payload, tmp_path):
    """The still image titled with the payload, a trajectory plot of a model named with it,
    and text made inside plain_text(): no mathtext, so nothing to fail to parse."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from porthamiltonian import compile_model, io

    scene = Scene(np.array([0.0, 1.0]), [Body("b", [Sphere((0, 0, 0), 0.1)], np.zeros((2, 3)),
                                              np.tile([1.0, 0, 0, 0], (2, 1)))], title=payload)
    assert scene.to_png(tmp_path / "still.png").stat().st_size > 1000
    model = io.load("mass_spring_damper")
    model.name = payload
    traj = compile_model(model, backend="python").simulate(0.5, method="Radau")
    ax = traj.plot()
    ax.figure.savefig(tmp_path / "traj.png")
    with plain_text():
        fig = Figure()
        FigureCanvasAgg(fig)
        fig.subplots().set_title(payload)
        fig.savefig(tmp_path / "fig.png")
    assert PLAIN_TEXT == {"text.parse_math": False}


def _hostile_copy(tmp_path: Path, name: str) -> Path:
    """models/<name>.toml with the hostile model name, and '$' and markup in a unit and a doc."""
    text = (MODELS_DIR / f"{name}.toml").read_text()
    text = re.sub(r'(?m)^\[model\]\n(name = "[^"]*"\n)?', "[model]\n", text, count=1)
    assert "[model]\n" in text
    text = text.replace("[model]\n", f'[model]\nname = "{HOSTILE_NAME}"\n', 1)
    text = re.sub(r'unit = "rad", doc = "slope angle gamma"',
                  'unit = "rad $^$", doc = "slope <!--<script> $x$"', text)
    path = tmp_path / f"hostile_{name}.toml"
    path.write_text(text)
    return path


def test_view_of_a_hostile_model_writes_its_page_and_image(tmp_path, capsys):
    path = _hostile_copy(tmp_path, "heavy_top")
    out = tmp_path / "view"
    status = cli.main(["--backend", "python", "view", str(path), "--t-end", "0.2",
                       "--out", str(out)])
    assert status == 0, capsys.readouterr().err
    page = (out / "view.html").read_text()
    assert html.escape(HOSTILE_NAME) in page and HOSTILE_NAME not in page
    assert (out / "view.png").stat().st_size > 1000


@pytest.fixture(scope="module")
def hostile_report(tmp_path_factory):
    """A report (one step: the page's parts are what is checked, with the 3D view and a
    continuation) of simplest_walker under a hostile name, and the viewer page of heavy_top
    under one."""
    tmp = tmp_path_factory.mktemp("hostile")
    walker = _hostile_copy(tmp, "simplest_walker")
    out = tmp / "report"
    assert walker_main(["report", str(walker), "--out", str(out), "--steps", "1", "--view3d",
                        "--quiet", "--no-step-down", "--continuation", "slope=0.0145:0.0147"]) == 0
    view = tmp / "view"
    assert cli.main(["--backend", "python", "view", str(_hostile_copy(tmp, "heavy_top")),
                     "--t-end", "0.3", "--out", str(view)]) == 0
    return walker, out, view


def test_the_report_rerun_command_names_the_file(hostile_report):
    walker, out, _ = hostile_report
    page = (out / "report.html").read_text()
    footer = html.unescape(re.search(r"<footer>.*?<code>(.*?)</code>", page, re.DOTALL).group(1))
    assert footer == f"walker report {walker}"


def test_a_hostile_report_shows_every_section_figure_and_script(hostile_report):
    _, out, _ = hostile_report
    source = (out / "report.html").read_text()
    sections = re.findall(r'<h2 id="([\w-]+)"', source)
    images = len(re.findall(r"<img ", source))
    scripts = len(re.findall(r"<script", source))
    assert {"gait", "floquet", "continuation", "parameters"} <= set(sections)
    dom, console = render(out / "report.html")
    assert re.findall(r'<h2 id="([\w-]+)"', dom) == sections      # every section, in order
    shown = re.search(r'data-images-ok="(\d+)/(\d+)"', dom)
    assert shown and shown.group(1) == shown.group(2) == str(images), shown
    assert len(re.findall(r"<script", dom)) >= scripts
    assert re.search(r'data-player="ready:\d+"', dom), "the 2D player did not start"
    assert re.search(r'<figure class="ph-viewer ph-live" id="view3d"[^>]*data-viewer="ready:\d+"',
                     dom), "the 3D view did not start"
    assert not console_errors(console), console
    assert f"Walker report: {html.escape(HOSTILE_NAME)}" in dom      # the name, as text


def test_a_hostile_viewer_page_draws(hostile_report):
    _, _, view = hostile_report
    dom, console = render(view / "view.html")
    assert re.search(r'data-viewer="ready:\d+"', dom), "the view did not start"
    assert f"<h1>{html.escape(HOSTILE_NAME)}</h1>" in dom
    assert not console_errors(console), console

"""The viewer's scene (porthamiltonian.interfaces.viewer): quaternions, resampling, checks of bad scenes, the
page's data and the still image — against closed forms where there are some (tests/viewer/
synthetic.py: a top in steady precession, a sphere rolling down a slope)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from PIL import Image
from synthetic import BALL, TOP, ball_slope_frame, top_pose, top_precession

from porthamiltonian.errors import SceneError
from porthamiltonian.interfaces.viewer import (
    Arrow,
    Body,
    Box,
    Capsule,
    Cylinder,
    Ground,
    Scene,
    Sphere,
    TorusArc,
)
from porthamiltonian.interfaces.viewer.page import block, document
from porthamiltonian.interfaces.viewer.quaternions import (
    about_axis,
    from_matrix,
    multiply,
    normalise,
    rotate,
    to_matrix,
)
from porthamiltonian.interfaces.viewer.sampling import resample, resample_quaternions
from porthamiltonian.interfaces.viewer.shapes import shape_from_dict
from porthamiltonian.interfaces.viewer.still import still_frames

RNG = np.random.default_rng(7)


def _rodrigues(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix by Rodrigues' formula (an independent derivation)."""
    k = axis / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def test_quaternions_against_rodrigues_and_composition():
    for _ in range(20):
        a1, a2 = RNG.normal(size=3), RNG.normal(size=3)
        t1, t2 = RNG.uniform(-3, 3, size=2)
        q1, q2 = about_axis(a1, t1), about_axis(a2, t2)
        R1, R2 = _rodrigues(a1, t1), _rodrigues(a2, t2)
        assert np.allclose(to_matrix(q1), R1, atol=1e-14)
        assert np.allclose(to_matrix(multiply(q1, q2)), R1 @ R2, atol=1e-14)   # q1 ⊗ q2 = R1 R2
        v = RNG.normal(size=3)
        assert np.allclose(rotate(q1, v), R1 @ v, atol=1e-14)
        q = normalise(multiply(q1, q2))
        back = from_matrix(to_matrix(q))
        assert np.allclose(back, q if q[0] >= 0 else -q, atol=1e-12)


def test_resampling_keeps_events_and_follows_a_rotation():
    # an event at t = 1: two points at the same time; the frame at t = 1 is the state after it
    t = np.array([0.0, 0.5, 1.0, 1.0, 1.5])
    x = np.array([0.0, 1.0, 2.0, 10.0, 11.0])
    assert np.allclose(resample(t, x, np.array([0.25, 0.75, 1.0, 1.25])), [0.5, 1.5, 10.0, 10.5])
    # a uniform rotation stored every h: normalised linear interpolation between neighbours
    # deviates from the exact rotation by at most θ³/32 rad for a step angle θ = ω h (the
    # chord's midpoint, where tan(θ/4) vs θ/4 ... measured: 2.4e-5 rad for θ = 0.2)
    omega, h = 2.0, 0.1
    ts = np.arange(0, 2.0 + h / 2, h)
    q = about_axis([1, 2, 2], omega * ts)
    q[1::2] *= -1                                    # q and −q: the same rotation
    times = np.linspace(0, 2.0, 333)
    got = resample_quaternions(ts, q, times)
    exact = about_axis([1, 2, 2], omega * times)
    angle = 2 * np.arccos(np.clip(np.abs(np.sum(got * exact, axis=1)), 0, 1))
    theta = omega * h
    assert angle.max() < theta ** 3 / 32
    assert angle.max() > theta ** 3 / 400           # the bound is not loose beyond measure


def test_the_top_precesses_at_its_closed_form_rate_in_the_scene():
    # stored at irregular times (steps of 1/300 s ± 30 %: spin angles up to 0.26 rad per step),
    # resampled into frames: the symmetry axis keeps its tilt and turns about the vertical at Ω
    # (Goldstein §5.7); errors of the interpolation only (≤ 0.26³/32 rad)
    ts = np.linspace(0, 2.0, 601)
    ts[1:-1] += RNG.uniform(-0.3, 0.3, 599) / 300
    pos, q = top_pose(ts)
    frames = np.linspace(0, 2.0, 121)
    body = Body("top", [Cylinder((0, 0, 0), (0, 0, 0.06), 0.004)], resample(ts, pos, frames),
                resample_quaternions(ts, q, frames))
    sc = Scene(frames, [body])
    axis = rotate(sc.bodies[0].orientation, np.array([0.0, 0, 1]))
    assert np.max(np.abs(axis[:, 2] - math.cos(TOP["theta"]))) < 0.26 ** 3 / 32
    azimuth = np.unwrap(np.arctan2(axis[:, 1], axis[:, 0]))
    rate = np.polyfit(frames, azimuth, 1)[0]
    assert rate == pytest.approx(top_precession(), rel=1e-3)


def _rolling_scene(n: int = 201) -> Scene:
    t = np.linspace(0, 1.0, n)
    centre, q = ball_slope_frame(t)
    turn = about_axis([0, 1, 0], BALL["slope"])          # slope frame -> level world
    body = Body("ball", [Sphere((0, 0, 0), BALL["r"], colour="#2ca02c"),
                         Box((0, 0, 0.7 * BALL["r"]), (0.02, 0.02, 0.03), colour="#ff7f0e")],
                rotate(turn, centre), multiply(turn, q))
    weight = np.tile([0.0, 0, -9.81], (n, 1))
    return Scene(t, [body], ground=Ground(slope=BALL["slope"]), strides=[0.0, 0.5],
                 arrows=[Arrow("weight", body.position, weight, 0.01)])


def test_the_rolling_sphere_touches_the_slope_and_its_contact_point_rests():
    sc = _rolling_scene()
    ball = sc.bodies[0]
    _, _, n = sc.ground.frame("z")
    assert np.allclose(n, [math.sin(BALL["slope"]), 0, math.cos(BALL["slope"])])
    # the centre stays r above the plane (through the origin, normal n)
    assert np.max(np.abs(ball.position @ n - BALL["r"])) < 1e-12
    # the body point at the bottom at frame k has no velocity there (rolling without slip):
    # central difference over the neighbouring frames (h apart), relative to the centre's
    # speed v = ω r; its truncation error is the point's third derivative, (ω³ + 3 ω α) r,
    # times h²/6 (α = ω̇, the sphere speeds up): (ω² + 3 α) h²/6 relative. A wrong turning
    # sense would give 2.
    for k in (40, 100, 180):
        P = rotate(ball.orientation[k] * [1, -1, -1, -1], -BALL["r"] * n)   # R(q)ᵀ (−r n)
        x = [ball.position[j] + rotate(ball.orientation[j], P) for j in (k - 1, k + 1)]
        dt = sc.t[k + 1] - sc.t[k - 1]
        v_point = (x[1] - x[0]) / dt
        v_centre = (ball.position[k + 1] - ball.position[k - 1]) / dt
        speed = np.linalg.norm(v_centre)
        omega, alpha = speed / BALL["r"], (5 / 7) * 9.81 * math.sin(BALL["slope"]) / BALL["r"]
        bound = (omega ** 2 + 3 * alpha) * (dt / 2) ** 2 / 6
        assert bound / 3 < np.linalg.norm(v_point) / speed < 1.2 * bound
    assert sc.stride_of(0.7) == 1 and sc.stride_of(0.2) == 0


def test_page_data_rounds_and_holds_the_ground():
    sc = _rolling_scene()
    data = sc.to_dict()
    json.dumps(data)                                   # JSON-able
    pose = np.array(data["bodies"][0]["pose"]).reshape(-1, 7)
    size = sc.size()
    assert np.max(np.abs(pose[:, :3] - sc.bodies[0].position)) <= 1e-5 * size
    assert np.max(np.abs(pose[:, 3:] - sc.bodies[0].orientation)) <= 5e-7
    quad = np.array(data["ground"]["quads"][0]).reshape(4, 3)
    n = np.array(data["ground"]["normal"])
    assert np.allclose(quad @ n, 0, atol=1e-5 * size)             # the plane through the origin
    lo, hi = sc.bounds()
    assert quad[:, 0].min() < lo[0] and quad[:, 0].max() > hi[0]   # under the whole run
    assert data["strides"] == [0.0, 0.5] and data["arrows"][0]["vector"][2] == pytest.approx(-0.0981)


def test_a_step_in_the_ground():
    g = Ground(slope=0.1, step_at=0.5, step_height=0.05)
    quads = g.quads("z", (0.0, 1.0), (-0.2, 0.2))
    d, _, n = g.frame("z")
    assert len(quads) == 3
    upper, riser, lower = quads
    assert np.allclose(upper @ n, 0) and np.allclose(lower @ n, -0.05)
    assert np.allclose(riser @ d, 0.5)
    assert len(g.quads("z", (0.6, 1.0), (-0.2, 0.2))) == 1      # beyond the step: one plane
    assert np.allclose(g.quads("z", (0.6, 1.0), (-0.2, 0.2))[0] @ n, -0.05)
    y_up = Ground(slope=0.1).frame("y")
    assert np.allclose(y_up[2], [math.sin(0.1), math.cos(0.1), 0])


@pytest.mark.parametrize("make, message", [
    (lambda t, p, q: Scene(t, [Body("a", [], p, q * 1.01)]), r"body 'a' orientation at t = 0 "),
    (lambda t, p, q: Scene(t, [Body("a", [], p[:-1], q)]), r"body 'a' position: expected shape"),
    (lambda t, p, q: Scene(t[::-1], [Body("a", [], p, q)]), r"must not decrease"),
    (lambda t, p, q: Scene(t, [Body("a", [], p, q), Body("a", [], p, q)]), r"two bodies"),
    (lambda t, p, q: Scene(t, [Body("a", ["ball"], p, q)]), r"shapes must be"),
    (lambda t, p, q: Scene(t, [], strides=[5.0]), r"strides"),
    (lambda t, p, q: Scene(t, [], up="x"), r"up axis"),
    (lambda t, p, q: Scene(t, [], title="x" * 1000), r"title"),
    (lambda t, p, q: Scene(t, [Body("a", [], np.where(t[:, None] > 0.5, np.nan, p), q)]),
     r"frame 6 is not finite"),
    (lambda t, p, q: Sphere((0, 0, 0), 1, colour="red"), r"#rrggbb"),
    (lambda t, p, q: Sphere((0, 0), 1), r"three"),
    (lambda t, p, q: Capsule((0, 0, 0), (0, 0, 1), -1), r"capsule radius: must be positive"),
    (lambda t, p, q: TorusArc((0, 0, 0), (0, 1, 0), (0, 2, 0), 1, 0.1), r"not be parallel"),
    (lambda t, p, q: TorusArc((0, 0, 0), (0, 1, 0), (1, 0, 0), 1, 0.1, 7.0), r"at most 6.28"),
    (lambda t, p, q: Box((0, 0, 0), (1, 1, 1), rotation=(1, 1, 0, 0)), r"unit quaternion"),
    (lambda t, p, q: Ground(slope=2.0), r"ground slope"),
    (lambda t, p, q: shape_from_dict({"kind": "cone"}), r"kind = one of"),
    (lambda t, p, q: shape_from_dict({"kind": "sphere", "center": [0, 0, 0], "radius": 1,
                                      "onload": "x"}), r"unknown field\(s\) onload"),
])
def test_bad_scenes_are_refused_with_the_culprit_named(make, message):
    t = np.linspace(0, 1, 11)
    p, q = np.zeros((11, 3)), np.tile([1.0, 0, 0, 0], (11, 1))
    with pytest.raises(SceneError, match=message):
        make(t, p, q)


def test_hostile_text_cannot_leave_the_data():
    t = np.linspace(0, 1, 3)
    sc = Scene(t, [Body("</script><script>alert(1)</script>", [Sphere((0, 0, 0), 1)],
                        np.zeros((3, 3)), np.tile([1.0, 0, 0, 0], (3, 1)))],
               title='<img src=x onerror="alert(1)">')
    html = block(sc, caption='<b onclick="x">')
    outside, data = html.split('<script type="application/json" class="ph-data">')
    data = data.removesuffix("</script>\n</figure>")
    assert "</" not in data                     # nothing in the data can close its element
    assert json.loads(data)["bodies"][0]["name"] == "</script><script>alert(1)</script>"
    assert "<img" not in outside and "<b onclick" not in outside and "&lt;b onclick" in outside
    page = document(sc, still=False)
    assert "<img src=x" not in page.split('class="ph-data">')[0]


def test_shapes_round_trip_and_bound_themselves():
    shapes = [Sphere((0, 0, 1), 0.5), Capsule((0, 0, 0), (1, 0, 0), 0.1, colour="#AA00FF"),
              Cylinder((0, 0, 0), (0, 1, 0), 0.2), Box((0, 0, 0), (1, 2, 3)),
              TorusArc((0, 0, 0), (0, 1, 0), (0, 0, -1), 0.5, 0.05, math.pi / 2)]
    for s in shapes:
        assert shape_from_dict(json.loads(json.dumps(s.to_dict()))) == s
    lo, hi = shapes[3].extent().min(axis=0), shapes[3].extent().max(axis=0)
    assert np.allclose(lo, [-0.5, -1, -1.5]) and np.allclose(hi, [0.5, 1, 1.5])
    arc = shapes[4].extent()
    # a quarter arc of radius 0.5 centred on −z: from −45° to +45° about the y axis; its tube
    # (radius 0.05) reaches 0.45 to 0.55 from the centre in the arc's plane
    assert arc[:, 2].max() == pytest.approx(-0.45 * math.cos(math.pi / 4), abs=1e-9)
    assert arc[:, 0].max() == pytest.approx(0.55 * math.sin(math.pi / 4), abs=1e-9)
    assert arc[:, 2].min() == pytest.approx(-0.55, abs=1e-9)
    assert np.abs(arc[:, 1]).max() == pytest.approx(0.05, abs=1e-9)
    assert shapes[1].colour == "#aa00ff"


def test_still_image(tmp_path):
    sc = _rolling_scene()
    assert still_frames(sc) == [0, 100, 200]               # the strides' starts and the end
    path = sc.to_png(tmp_path / "still.png")
    with Image.open(path) as im:
        assert im.format == "PNG" and im.size[0] >= 700 and im.size[1] >= 450
        px = np.asarray(im.convert("RGB")).astype(int)
    green = (px[..., 1] > px[..., 0] + 40) & (px[..., 1] > px[..., 2] + 40)
    assert green.sum() > 100                                # the ball is drawn

"""Scenes from simulations (porthamiltonian.interfaces.viewer.from_trajectory) and the walker's 3D scene
(walker_library.report.view3d): the names read, the default shapes, the slope frame turned level.

Most cases use stand-in trajectories whose columns are closed-form motions
(tests/viewer/synthetic.py); a real Multibody (the heavy top, whose pose outputs
``<mb>.<body>.pose.x|y|z|qw|qx|qy|qz`` are validated in tests/validation/test_multibody_poses.py)
and a FreeBody (whose poses are its states) are simulated here."""
from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest
from synthetic import BALL, FakeTrajectory, ball_slope_frame, pose_columns

import porthamiltonian as ph
from porthamiltonian import io
from porthamiltonian.errors import SceneError
from porthamiltonian.interfaces.viewer import (
    Arrow,
    Capsule,
    Ground,
    Sphere,
    TorusArc,
    pose_sources,
    scene_from_trajectory,
)
from porthamiltonian.interfaces.viewer.from_trajectory import body_points
from porthamiltonian.interfaces.viewer.quaternions import about_axis, multiply, normalise, rotate
from walker_library.core.files import read_walker
from walker_library.report.view3d import is_3d, walker_scene


def test_pose_sources_by_name():
    names = ["rig.ball.pose.x", "rig.ball.pose.y", "rig.ball.pose.z", "rig.ball.pose.qw",
             "rig.ball.pose.qx", "rig.ball.pose.qy", "rig.ball.pose.qz",
             "rig.half.pose.qw", "rig.half.pose.x",                    # incomplete: not a body
             "top.r.x", "top.r.y", "top.r.z", "top.q.w", "top.q.x", "top.q.y", "top.q.z"]
    found = pose_sources(names)
    assert list(found) == ["rig.ball", "top"]
    assert found["top"] == ("top.r.x", "top.r.y", "top.r.z", "top.q.w", "top.q.x", "top.q.y",
                            "top.q.z")


def test_a_slope_frame_is_turned_level():
    # the rolling sphere in the slope frame (x down the slope, z its normal) with its weight
    # g (sin γ, 0, −cos γ) there: level, the weight points straight down and the sphere rests
    # on Ground(slope=γ)
    t = np.linspace(0, 1.0, 400)
    centre, q = ball_slope_frame(t)
    traj = FakeTrajectory(t, pose_columns("rig.ball", centre, q))
    g = 9.81 * np.array([math.sin(BALL["slope"]), 0, -math.cos(BALL["slope"])])
    weight = Arrow("weight", centre, np.tile(g, (len(t), 1)), 0.01)
    sc = scene_from_trajectory(traj, ground=Ground(slope=BALL["slope"]), arrows=[weight],
                               shapes={"rig.ball": [Sphere((0, 0, 0), BALL["r"])]},
                               strides=[0.0, 0.5, 3.0], slope_frame=BALL["slope"], rate=60)
    assert len(sc.t) == 61 and list(sc.strides) == [0.0, 0.5]        # 3.0 is past the run
    assert np.allclose(sc.arrows[0].vector, [0, 0, -9.81], atol=1e-12)
    _, _, n = sc.ground.frame("z")
    ball = sc.bodies[0]
    assert np.max(np.abs(ball.position @ n - BALL["r"])) < 1e-12
    s_end, gamma = 0.5 * (5 / 7) * 9.81 * math.sin(BALL["slope"]), BALL["slope"]
    assert np.allclose(ball.position[-1], [s_end * math.cos(gamma) + BALL["r"] * math.sin(gamma),
                                           0, -s_end * math.sin(gamma)
                                           + BALL["r"] * math.cos(gamma)], atol=1e-12)
    # the orientation is the slope's turn after the rolling: R_world = R_turn R_slope-frame
    expect = multiply(about_axis([0, 1, 0], BALL["slope"]),
                      about_axis([0, 1, 0], 0.5 * (5 / 7) * 9.81 * math.sin(BALL["slope"])
                                 / BALL["r"]))
    assert np.allclose(ball.orientation[-1], expect, atol=1e-12)


def _double_pendulum(t: np.ndarray) -> dict[str, np.ndarray]:
    """Closed-form poses and point outputs of models/double_pendulum.toml's bodies for the
    angles θ1 = 0.8 sin t, θ2 = 0.5 cos 2t (revolute joints about y; rod lengths 1 and 0.8)."""
    q1 = about_axis([0, 1, 0], 0.8 * np.sin(t))
    q2 = multiply(q1, about_axis([0, 1, 0], 0.5 * np.cos(2 * t)))
    zero = np.zeros((len(t), 3))
    elbow = rotate(q1, np.array([0, 0, -1.0]))
    tip = elbow + rotate(q2, np.array([0, 0, -0.8]))
    cols = {**pose_columns("arm.rod1", zero, q1), **pose_columns("arm.rod2", elbow, q2)}
    for name, p in (("elbow", elbow), ("tip", tip)):          # plane = "xz": x and z only
        cols[f"arm.{name}.x"], cols[f"arm.{name}.z"] = p[:, 0], p[:, 2]
    return cols


def test_multibody_bodies_are_drawn_to_their_points_and_joints():
    model = io.load("double_pendulum")
    t = np.linspace(0, 2, 50)
    traj = FakeTrajectory(t, _double_pendulum(t), name="double_pendulum")
    pts = body_points(traj, model, "arm.rod1")
    assert set(pts) == {"elbow", "elbow_joint"}           # its point and its child's joint
    assert np.allclose(pts["elbow"], [0, 0, -1]) and np.allclose(pts["elbow_joint"], [0, 0, -1])
    assert np.allclose(body_points(traj, model, "arm.rod2")["tip"], [0, 0, -0.8])
    sc = scene_from_trajectory(traj, model=model)
    rod2 = sc.bodies[1]
    assert [b.name for b in sc.bodies] == ["arm.rod1", "arm.rod2"]
    assert isinstance(rod2.shapes[0], Sphere)
    (link,) = [s for s in rod2.shapes if isinstance(s, Capsule)]
    assert np.allclose(link.b, [0, 0, -0.8], atol=1e-14)
    # the drawn tip follows the model's tip output at every frame
    tip = rod2.position + rotate(rod2.orientation, np.array([0, 0, -0.8]))
    cols = _double_pendulum(sc.t)
    assert np.allclose(tip[:, [0, 2]], np.stack([cols["arm.tip.x"], cols["arm.tip.z"]], 1),
                       atol=2e-3)                         # frames interpolated from 50 points
    assert scene_from_trajectory(traj).bodies[0].shapes[0].kind == "sphere"   # without the model


def test_a_free_body_is_its_inertia_box(compile_named):
    model = compile_named("free_rigid_body")
    traj = model.simulate(3.0, method="DOP853", rtol=1e-10, atol=1e-12)
    sc = scene_from_trajectory(traj, rate=20)
    (body,) = sc.bodies
    assert body.name == "body"
    (box,) = body.shapes
    # I = (1, 2, 3) kg m², m = 1 kg: edges √(6 (I_j + I_k − I_i) / m) = √24, √12, 0 (a lamina,
    # drawn 5 % of the longest edge thick)
    assert np.allclose(box.size, [math.sqrt(24), math.sqrt(12), 0.05 * math.sqrt(24)])
    assert np.allclose(box.center, 0) and np.allclose(box.rotation, [1, 0, 0, 0])
    q = np.stack([traj[f"body.q.{a}"] for a in "wxyz"], axis=1)
    assert np.allclose(body.orientation[0], normalise(q[0]), atol=1e-12)
    assert np.allclose(body.orientation[-1], normalise(q[-1]), atol=1e-12)


def test_a_3d_multibody_is_drawn_from_its_pose_outputs(compile_named):
    """models/heavy_top.toml over 0.2 s: one body, ``top.body``, drawn as a ball at the pivot and
    a capsule to its point cm = (0, 0, l) (body frame); at the first and last frame (the run's
    own points) its orientation is the joint's normalised quaternion and the drawn cm,
    position + R(q) (0, 0, l), is the model's cm output."""
    compiled = compile_named("heavy_top")
    traj = compiled.simulate(0.2, method="DOP853", rtol=1e-10, atol=1e-12)
    sc = scene_from_trajectory(traj, model=io.load("heavy_top"), rate=50)
    (body,) = sc.bodies
    assert body.name == "top.body" and len(sc.t) == 11
    l = compiled.param_defaults[compiled.param_names.index("l")]
    (link,) = [s for s in body.shapes if isinstance(s, Capsule)]
    assert np.allclose(link.b, [0, 0, l], rtol=0, atol=1e-12)
    for frame in (0, -1):
        q = normalise(np.array([traj[f"top.q.tip.{c}"][frame] for c in ("qw", "qx", "qy", "qz")]))
        assert np.allclose(body.orientation[frame], q, rtol=0, atol=1e-12)
        cm = body.position[frame] + rotate(body.orientation[frame], np.array([0, 0, l]))
        assert np.allclose(cm, [traj[f"top.cm.{a}"][frame] for a in "xyz"], rtol=0, atol=1e-12)
    assert np.ptp(body.orientation[:, 3]) > 0.1                 # it turned


def test_models_without_poses_and_wrong_names_are_refused(compile_named):
    traj = compile_named("mass_spring_damper").simulate(0.1)
    with pytest.raises(SceneError, match=r"gives no body poses.*pose\.x\|y\|z\|qw\|qx\|qy\|qz"):
        scene_from_trajectory(traj)
    t = np.linspace(0, 1, 5)
    fake = FakeTrajectory(t, pose_columns("rig.ball", np.zeros((5, 3)),
                                          np.tile([1.0, 0, 0, 0], (5, 1))))
    with pytest.raises(SceneError, match=r"no pose for body 'rig.bal'.*rig\.ball"):
        scene_from_trajectory(fake, bodies=["rig.bal"])
    with pytest.raises(SceneError, match=r"shapes given for top"):
        scene_from_trajectory(fake, shapes={"top": []})


# --- the walker's 3D scene -------------------------------------------------------------------------
def _walker_standin():
    """compass_walker's file with its multibody made 3D (no plane), as a 3D walker's would be
    (its components without their bonds: the file's contacts are planar), and a closed-form
    stride of it: the hip moving down the slope, the legs swinging."""
    spec, _ = read_walker("compass_walker")
    model = ph.Model("compass_walker_3d")
    for name, p in spec.model.parameters.items():
        model.parameter(name, p.value, p.unit)
    for name, comp in spec.model.components():
        if name == "walker":
            comp = type(comp)(**{k: v for k, v in comp.args.items() if k != "plane"})
        model.add(name, comp)
    spec = dataclasses.replace(spec, model=model)
    values = {k: float(p.value) for k, p in spec.model.parameters.items()}
    walker = SimpleNamespace(name="compass_walker", multibody="walker", spec=spec,
                             parameters=values, leg_length=values["l"])
    t = np.linspace(0, 1.0, 101)
    l, R = values["l"], values["R"]
    hip = np.stack([0.3 * t, 0 * t, np.full_like(t, l + R)], axis=1)
    angles = (0.2 - 0.4 * t, -0.2 + 0.4 * t)
    cols = {**pose_columns("walker.hip_body", hip, np.tile([1.0, 0, 0, 0], (len(t), 1)))}
    for k, a in zip((1, 2), angles, strict=True):
        q = about_axis([0, 1, 0], a)
        foot = hip + rotate(q, np.array([0, 0, -l]))
        cols.update(pose_columns(f"walker.leg{k}", hip, q))
        cols.update(pose_columns(f"walker.foot{k}_body", foot, q))
        for point, p in ((f"foot{k}", foot), (f"sole{k}", foot + rotate(q, np.array([0, 0, -R])))):
            cols.update({f"walker.{point}.{a}": p[:, i] for i, a in enumerate("xyz")})
    cols.update({f"walker.hip_centre.{a}": hip[:, i] for i, a in enumerate("xyz")})
    traj = FakeTrajectory(t, cols, name="compass_walker")
    stride = SimpleNamespace(info={"trajectory": traj}, duration=0.5, fell=False)
    series = SimpleNamespace(t=t, strides=[stride, stride], step_times=np.array([0.5, 1.0]))
    return walker, series


def test_a_3d_walker_is_drawn_from_its_poses():
    walker, series = _walker_standin()
    assert is_3d(walker, series)
    sc = walker_scene(walker, series, sc2d=None)
    names = [b.name for b in sc.bodies]
    assert names == ["walker.hip_body", "walker.leg1", "walker.foot1_body", "walker.leg2",
                     "walker.foot2_body"]
    leg = sc.bodies[1]
    (link,) = [s for s in leg.shapes if isinstance(s, Capsule)]
    assert np.allclose(link.b, [0, 0, -0.7], atol=1e-14)                     # to its foot
    foot = sc.bodies[2]
    arcs = [s for s in foot.shapes if isinstance(s, TorusArc)]
    assert len(arcs) == 1 and arcs[0].radius == pytest.approx(0.05)          # R of the file
    assert np.allclose(arcs[0].center, 0, atol=1e-14) and np.allclose(arcs[0].mid, [0, 0, -1])
    assert list(sc.strides) == [0.0, 0.5]
    # turned level: the hip, l + R above the slope, is at height (l + R) cos γ − x sin γ
    gamma = walker.parameters["slope"]
    hip = sc.bodies[0].position
    x = 0.3 * sc.t
    assert np.allclose(hip[:, 2], (0.75 * math.cos(gamma) - x * math.sin(gamma)), atol=1e-12)
    # a planar walker (the file as it is) is not 3D
    planar, _ = read_walker("compass_walker")
    assert not is_3d(SimpleNamespace(multibody="walker", spec=planar), series)


# --- the command line ------------------------------------------------------------------------------
def test_porthamiltonian_view(compile_named, tmp_path, capsys):
    from PIL import Image

    from porthamiltonian.interfaces.cli import main

    compile_named("free_rigid_body")                   # the python back end, compiled once
    out = tmp_path / "view"
    assert main(["view", "free_rigid_body", "--backend", "python", "--t-end", "2", "--rate", "10",
                 "--out", str(out)]) == 0
    assert "1 body, 21 frames over 2 s (finished)" in capsys.readouterr().out
    page = (out / "view.html").read_text()
    assert 'data-viewer="loading"' in page and '"name":"body"' in page
    with Image.open(out / "view.png") as im:
        assert im.format == "PNG"
    assert main(["view", "mass_spring_damper", "--backend", "python", "--out", str(out)]) == 2
    assert "error: model 'mass_spring_damper' gives no body poses" in capsys.readouterr().err
    assert main(["view", "free_rigid_body", "--rate", "0", "--out", str(out)]) == 2
    assert "error: --rate" in capsys.readouterr().err

"""The Multibody's pose outputs ``<mb>.<body>.pose.x|y|z|qw|qx|qy|qz`` (read by the 3D viewer)
against a second derivation: forward kinematics of the joint tables written here with numpy and
scipy's rotations (``Rotation.from_rotvec`` of axis · angle for revolute and universal joints,
``from_quat`` of the normalised quaternion for spherical and free joints, shifts along the axes
for prismatic and translational joints, the joint origins in the parent's frame).

* a spatial tree (translational root, revolute joints about skew axes, a prismatic joint along a
  skew axis, a weld with an offset) and a floating tree (free, universal and spherical joints), at
  random states whose quaternions are not of unit norm: the origin to 1e-12 m, R(q) to 1e-12,
  |q| = 1 to 1e-14; the point outputs equal origin + R(q) · (the point in the body frame);
* the planar double pendulum (models/double_pendulum.toml) in closed form: rod 1 turned by θ1 and
  rod 2 by θ1 + θ2 about y, q = (cos θ/2, 0, sin θ/2, 0) with this sign (continuous in θ), rod 2's
  origin at (−l1 sin θ1, 0, −l1 cos θ1);
* the heavy top (models/heavy_top.toml): its pose quaternion is its joint's, normalised.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp
from multibody_cases import random_states, tree3d_model
from scipy.spatial.transform import Rotation

import porthamiltonian as ph
from porthamiltonian import compile_model

AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def floating_model() -> ph.Model:
    """A base on a free joint from the world; an arm on a universal joint (skew axes, offset)
    and a head on a spherical joint (offset), both on the base; a point on each."""
    body = {"mass": 1.0, "com": [0.05, -0.02, 0.1], "inertia": [0.02, 0.03, 0.04]}
    m = ph.Model("floating_poses")
    m.add("mb", ph.Multibody(
        bodies={"base": {**body, "points": {"b_pt": [0.1, 0.2, -0.3]}},
                "arm": {**body, "points": {"a_pt": [0.0, -0.4, 0.25]}},
                "head": {**body, "points": {"h_pt": [0.3, 0.1, 0.2]}}},
        joints={"float": {"type": "free", "parent": "world", "child": "base",
                          "q0": [0.3, -0.2, 1.1, 0.9, 0.1, -0.3, 0.2]},
                "uni": {"type": "universal", "parent": "base", "child": "arm",
                        "axes": [[0.6, 0.0, 0.8], [0.0, 1.0, 0.0]], "origin": [0.2, 0.1, -0.1],
                        "q0": [0.4, -0.6]},
                "ball": {"type": "spherical", "parent": "base", "child": "head",
                         "origin": [-0.1, 0.3, 0.2], "q0": [0.8, -0.2, 0.4, 0.1]}},
        gravity=[0, 0, -9.81]))
    return m


def _number(value, params: dict) -> float:
    return float(sp.sympify(value).subs(params)) if isinstance(value, str) else float(value)


def _unit(axis) -> np.ndarray:
    a = np.array(AXES[axis] if isinstance(axis, str) else axis, dtype=float)
    return a / np.linalg.norm(a)


def _quaternion(q: list[float]) -> np.ndarray:
    """R of (w, x, y, z) / |q|, by scipy (scalar last there)."""
    w, x, y, z = q
    return Rotation.from_quat([x, y, z, w]).as_matrix()


def reference_poses(multibody, mb: str, values: dict[str, float], params: dict
                    ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Body -> (origin, R) in world coordinates from the joint tables and the coordinates
    ``values`` (state name -> value)."""
    joints = multibody.value("joints")
    poses = {"world": (np.zeros(3), np.eye(3))}
    while len(poses) <= len(joints):
        for name, j in joints.items():
            if j["child"] in poses or j["parent"] not in poses:
                continue
            p, R = poses[j["parent"]]
            p = p + R @ np.array([_number(v, params) for v in j.get("origin", [0, 0, 0])])
            q = lambda label, name=name: values[f"{mb}.q.{name}{label}"]
            kind = j["type"]
            if kind == "revolute":
                R = R @ Rotation.from_rotvec(_unit(j["axis"]) * q("")).as_matrix()
            elif kind == "prismatic":
                p = p + R @ (_unit(j["axis"]) * q(""))
            elif kind == "translational":
                p = p + R @ sum(_unit(ax) * q(f".{ax}") for ax in j["axes"])
            elif kind == "universal":
                labels = [f".{ax}" if isinstance(ax, str) else f".a{i + 1}"
                          for i, ax in enumerate(j["axes"])]
                for ax, label in zip(j["axes"], labels, strict=True):
                    R = R @ Rotation.from_rotvec(_unit(ax) * q(label)).as_matrix()
            elif kind in ("spherical", "free"):
                if kind == "free":
                    p = p + R @ np.array([q(".x"), q(".y"), q(".z")])
                R = R @ _quaternion([q(f".{c}") for c in ("qw", "qx", "qy", "qz")])
            poses[j["child"]] = (p, R)
    return {b: poses[b] for b in multibody.value("bodies")}


def _pose(outputs: dict, name: str) -> tuple[np.ndarray, np.ndarray]:
    return (np.array([outputs[f"{name}.pose.{a}"] for a in "xyz"]),
            np.array([outputs[f"{name}.pose.{a}"] for a in ("qw", "qx", "qy", "qz")]))


@pytest.mark.parametrize("case", ["tree3d", "floating"])
def test_poses_match_forward_kinematics(case, isolated_cache):
    model = tree3d_model() if case == "tree3d" else floating_model()
    mb = "tree" if case == "tree3d" else "mb"
    compiled = compile_model(model, backend="python")
    multibody = model.freeze().components[mb]
    params = {sp.Symbol(n): v for n, v in zip(compiled.param_names, compiled.param_defaults)}
    unnormalised = 0.0
    for x in random_states(compiled, 11, 3):
        values = dict(zip(compiled.state_names, x))
        outputs = dict(zip(compiled.output_names, compiled.outputs(0.0, x, compiled.param_defaults)))
        for body, (p_ref, R_ref) in reference_poses(multibody, mb, values, params).items():
            p, quat = _pose(outputs, f"{mb}.{body}")
            assert abs(np.linalg.norm(quat) - 1) < 1e-14
            assert np.max(np.abs(p - p_ref)) < 1e-12, body
            assert np.max(np.abs(_quaternion(list(quat)) - R_ref)) < 1e-12, body
            for point, local in (multibody.value("bodies")[body].get("points") or {}).items():
                local = np.array([_number(v, params) for v in local])
                world = [outputs[f"{mb}.{point}.{a}"] for a in "xyz"]
                assert np.max(np.abs(p + R_ref @ local - world)) < 1e-12, point
        quats = [n for n in compiled.state_names if n.endswith(".qw")]
        for name in quats:
            i = compiled.state_names.index(name)
            unnormalised = max(unnormalised, abs(np.linalg.norm(x[i:i + 4]) - 1))
    assert case == "tree3d" or unnormalised > 0.01         # |q| ≠ 1 was exercised


def test_double_pendulum_poses_in_closed_form(compile_named):
    model = compile_named("double_pendulum")
    rng = np.random.default_rng(5)
    p = model.param_defaults
    l1 = p[model.param_names.index("l1")]
    names = model.state_names
    for th1, th2 in rng.uniform(-3.0, 3.0, (4, 2)):
        x = model.initial_state().copy()
        x[names.index("arm.q.shoulder")], x[names.index("arm.q.elbow_joint")] = th1, th2
        outputs = dict(zip(model.output_names, model.outputs(0.0, x, p)))
        for body, angle, origin in (
                ("rod1", th1, [0, 0, 0]),
                ("rod2", th1 + th2, [-l1 * math.sin(th1), 0, -l1 * math.cos(th1)])):
            position, quat = _pose(outputs, f"arm.{body}")
            assert np.allclose(position, origin, rtol=0, atol=1e-14)
            assert np.allclose(quat, [math.cos(angle / 2), 0, math.sin(angle / 2), 0],
                               rtol=0, atol=1e-15)


def test_heavy_top_pose_is_its_normalised_joint_quaternion(compile_named):
    model = compile_named("heavy_top")
    x = model.initial_state().copy()
    i = model.state_names.index("top.q.tip.qw")
    x[i:i + 4] = [0.9, 0.3, -0.5, 0.2]
    outputs = dict(zip(model.output_names, model.outputs(0.0, x, model.param_defaults)))
    position, quat = _pose(outputs, "top.body")
    assert np.array_equal(position, [0, 0, 0])
    assert np.allclose(quat, x[i:i + 4] / np.linalg.norm(x[i:i + 4]), rtol=0, atol=1e-15)

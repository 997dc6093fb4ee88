"""The recursive Multibody against an independent derivation with sympy.physics.mechanics.

For random mechanisms (masses U(0.5, 2) kg, link lengths U(0.3, 0.8) m, off-axis centres of
mass, random inertia matrices a body can have, random joint offsets and gravity) the
same tree is written once as a Multibody and once with sympy.physics.mechanics (reference frames
oriented about the joint axes, points located from the joint origins, their velocities by
v2pt/v1pt theory, rigid bodies, the potential −Σ m gᵀ r_c; see mechanics_reference.Reference). From the
latter: M(q) from the bodies' partial velocities (Kane's method: M_jk = Σ m ∂v_c/∂u_j·∂v_c/∂u_k +
∂ω/∂u_j·I·∂ω/∂u_k), H = T + V and Hamilton's ṗ = ∂L/∂q|_q̇ (L = T − V, [Goldstein] §8.1) by
complex-step differentiation. At three random states (q ~ U(−1, 1), q̇ ~ U(−1, 1), p = M q̇)
the compiled model's mass matrix, q̇ (its first n state derivatives), ṗ and H must agree to 1e-10
relative to the largest entry of each.

Mechanisms: planar chains of 3 and 6 links (revolute about y), spatial chains of 3 and 6 links
(revolute joints about x, y, z and skew axes in turn), and a non-planar tree: two branches on
revolute joints about different axes, a prismatic joint along a skew axis and a weld.

[Goldstein] H. Goldstein, C. Poole, J. Safko, *Classical Mechanics*, 3rd ed., 2002.
"""
from __future__ import annotations

import numpy as np
import pytest
from mechanics_reference import Reference

import porthamiltonian as ph


def _body_inertia(A: np.ndarray) -> list:
    """A random inertia that a body can have: tr(S) 1 − S of the second moment S = A Aᵀ +
    0.005·1 of a mass distribution (positive definite, its principal moments obeying the
    triangle inequality; a random symmetric positive definite matrix need not)."""
    S = A @ A.T + 0.005 * np.eye(3)
    return (np.trace(S) * np.eye(3) - S).tolist()

def random_spec(kind: str, seed: int) -> dict:
    """Joints (parents first) of a random mechanism: name -> {type, parent, axis, origin, body}."""
    rng = np.random.default_rng(seed)
    skew = [tuple(a / np.linalg.norm(a)) for a in rng.normal(size=(4, 3))]
    if kind.startswith("planar"):
        axes = ["y"] * int(kind[-1])
    elif kind.startswith("spatial"):
        axes = (["x", "y", "z", skew[0], "y", skew[1]])[: int(kind[-1])]
    else:
        axes = None
    joints: dict[str, dict] = {}

    def body():
        A = rng.normal(size=(3, 3)) * 0.1
        length = float(rng.uniform(0.3, 0.8))
        return {"mass": float(rng.uniform(0.5, 2.0)), "length": length,
                "com": [float(rng.uniform(-0.1, 0.1)), float(rng.uniform(-0.1, 0.1)), -length / 2],
                "inertia": _body_inertia(A)}

    def add(name, jtype, parent, axis):
        origin = [0.0, 0.0, 0.0] if parent == "world" else [
            float(rng.uniform(-0.05, 0.05)), float(rng.uniform(-0.05, 0.05)),
            -joints[parent]["body"]["length"]]
        joints[name] = {"type": jtype, "parent": parent, "axis": axis, "origin": origin,
                        "body": body()}

    if axes is not None:
        for i, axis in enumerate(axes):
            add(f"j{i}", "revolute", "world" if i == 0 else f"j{i - 1}", axis)
    else:                                    # the tree
        add("root", "revolute", "world", "z")
        add("left", "revolute", "root", "x")
        add("left2", "revolute", "left", skew[2])
        add("right", "revolute", "root", skew[3])
        add("slide", "prismatic", "right", skew[0])
        add("tool", "weld", "left2", None)
    return joints


def multibody(spec: dict, gravity) -> ph.Model:
    bodies, joints = {}, {}
    for name, j in spec.items():
        bodies[f"b_{name}"] = {"mass": j["body"]["mass"], "com": j["body"]["com"],
                               "inertia": j["body"]["inertia"]}
        joints[name] = {"type": j["type"], "parent": "world" if j["parent"] == "world"
                        else f"b_{j['parent']}", "child": f"b_{name}", "origin": j["origin"]}
        if j["axis"] is not None:
            joints[name]["axis"] = list(j["axis"]) if isinstance(j["axis"], tuple) else j["axis"]
    model = ph.Model("mechanics_check")
    model.add("mb", ph.Multibody(bodies=bodies, joints=joints, gravity=list(gravity)))
    return model


CASES = ["planar3", "planar6", "spatial3", "spatial6", "tree"]


@pytest.mark.parametrize("kind", CASES)
def test_multibody_matches_sympy_mechanics(kind, isolated_cache):
    seed = CASES.index(kind) + 100
    spec = random_spec(kind, seed)
    rng = np.random.default_rng(seed)
    gravity = [float(rng.uniform(-1, 1)), float(rng.uniform(-1, 1)), -9.81]
    model = ph.compile_model(multibody(spec, gravity), backend="python")
    reference = Reference(spec, gravity)
    n = model.n_states // 2
    q_names = [f"mb.q.{name}" for name, j in spec.items() if j["type"] != "weld"]
    assert model.state_names[:n] == q_names
    for _ in range(3):
        q, v = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
        M, H, pdot = reference.values(q, v)
        x = np.concatenate([q, M @ v])
        M_model = model.matrix("mb.M", 0.0, x, model.param_defaults)
        assert np.max(np.abs(M_model - M)) <= 1e-10 * np.max(np.abs(M))
        xdot = np.asarray(model.functions.rhs(0.0, model.augment(x), model.native_params(
            model.param_defaults)))[: 2 * n]
        assert np.max(np.abs(xdot[:n] - v)) <= 1e-10 * np.max(np.abs(v))
        assert np.max(np.abs(xdot[n:] - pdot)) <= 1e-10 * np.max(np.abs(pdot))
        assert abs(model.energy(0.0, x, model.param_defaults)[0] - H) <= 1e-10 * abs(H)

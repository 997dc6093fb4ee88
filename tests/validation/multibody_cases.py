"""Models and random states shared by the multibody regression tests.

* :func:`shipped_multibody_models`: every model file of ``models/`` that holds a Multibody;
* :func:`tree3d_model`: a spatial tree exercising every joint type and port kind of the
  Multibody (a translational x-y-z root, revolute joints about skew axes, a prismatic joint along
  a skew axis, welds with offsets, full inertia matrices, point and frame ports loaded by linear
  dampers, a joint port), under a skew gravity;
* :func:`chain_model`: the planar N-link pendulum chain of benchmarks/bench_mechanics.py;
* :func:`generic_chain_model`: an N-link chain on revolute joints about random 3D axes;
* :func:`with_formulation`: a model with its Multibody's formulation (kernel, symbolic) set;
* :func:`random_states`: reproducible random states around a model's initial state;
* :func:`close`, :func:`compare_formulations`: the comparisons (to 1e-12 relative, row-scaled)
  of the kernel and regression tests.

Used by record_multibody_reference.py (which wrote data/multibody_reference.json with the
pre-recursive formulation) and test_multibody_regression.py (which compares against it).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

import porthamiltonian as ph
from porthamiltonian import io
from porthamiltonian.mechanics import Multibody

MODELS = Path(__file__).resolve().parents[2] / "models"


def shipped_multibody_models() -> list[str]:
    """Names of the model files in ``models/`` that hold a Multibody component."""
    names = []
    for path in sorted(MODELS.glob("*.toml")):
        model = io.load(path)
        if any(isinstance(c, Multibody) for c in model.flatten().components.values()):
            names.append(path.stem)
    return names


def tree3d_model() -> ph.Model:
    """A spatial tree: base on a translational x-y-z joint from the world; arm1 on a revolute
    joint about x from the base; arm2 on a revolute joint about a skew axis from arm1, with a
    tool welded to it (offset) carrying a frame port; a slider on a prismatic joint along a
    skew axis from arm2; a second branch on a revolute joint about z from the base. Full
    (non-diagonal) inertia matrices, off-axis centres of mass, gravity (0.3, −0.2, −9.81) m/s².
    Ports: the point ``tipA`` (slider) and ``tipB`` (branch) into 3-D linear dampers, the frame
    ``wrist`` (tool) into a 6-D linear damper, the joint ``elbow`` into a rotary damper."""
    m = ph.Model("tree3d")                  # a spatial tree exercising every joint and port kind
    for name, value, unit in (("m1", 1.3, "kg"), ("l1", 0.45, "m"), ("m2", 0.8, "kg"),
                              ("l2", 0.35, "m"), ("g", 9.81, "m/s^2")):
        m.parameter(name, value, unit)
    inertia_a = [[0.05, 0.004, -0.003], [0.004, 0.07, 0.002], [-0.003, 0.002, 0.03]]
    inertia_b = [[0.02, -0.001, 0.0015], [-0.001, 0.018, 0.0], [0.0015, 0.0, 0.011]]
    bodies = {
        "base": {"mass": 2.0, "com": [0.02, -0.01, 0.05], "inertia": [0.1, 0.12, 0.09]},
        "arm1": {"mass": "m1", "com": [0.01, 0.02, "-l1/2"], "inertia": inertia_a},
        "arm2": {"mass": "m2", "com": [0.03, 0, "-l2/2"], "inertia": inertia_b,
                 "points": {"elbow_pt": [0, 0, 0]}},
        "tool": {"mass": 0.3, "com": [0.0, 0.01, -0.02], "inertia": [0.001, 0.002, 0.0015],
                 "frames": {"wrist": [0.02, -0.03, -0.05]}},
        "slider": {"mass": 0.4, "com": [0, 0, 0], "inertia": 0,
                   "points": {"tipA": [0.05, 0, -0.02]}},
        "branch": {"mass": 0.6, "com": [0.2, 0, 0], "inertia": [0.002, 0.01, 0.01],
                   "points": {"tipB": [0.4, 0.0, 0.0]}},
    }
    joints = {
        "root": {"type": "translational", "parent": "world", "child": "base",
                 "axes": ["x", "y", "z"], "origin": [0.1, 0.2, 1.5], "q0": [0.1, -0.2, 0.05],
                 "v0": [0.3, -0.1, 0.2]},
        "shoulder": {"type": "revolute", "parent": "base", "child": "arm1", "axis": "x",
                     "origin": [0, 0.05, -0.1], "q0": 0.4, "v0": -0.5},
        "elbow": {"type": "revolute", "parent": "arm1", "child": "arm2",
                  "axis": [0.6, 0.0, 0.8], "origin": [0, 0, "-l1"], "q0": -0.7, "v0": 0.8},
        "wrist_weld": {"type": "weld", "parent": "arm2", "child": "tool",
                       "origin": [0.01, 0.02, "-l2"]},
        "slide": {"type": "prismatic", "parent": "arm2", "child": "slider",
                  "axis": [0.2, -0.4, 0.9], "origin": [0.05, 0, "-l2/2"], "q0": 0.1, "v0": 0.2},
        "yaw": {"type": "revolute", "parent": "base", "child": "branch", "axis": "z",
                "origin": [0.1, 0, 0], "q0": 0.3, "v0": 1.1},
    }
    m.add("tree", Multibody(bodies=bodies, joints=joints, gravity=[0.3, -0.2, "-g"]))
    m.add("dA", ph.R(domain="translation", dim=3, resistance=0.7))
    m.add("dB", ph.R(domain="translation", dim=3, resistance=1.3))
    m.add("dW", ph.R(domain="screw", dim=6, resistance=0.4))
    m.add("dE", ph.R(domain="rotation", resistance=0.05))
    for port, damper in (("tipA", "dA"), ("tipB", "dB"), ("wrist", "dW"), ("elbow", "dE")):
        m.connect(f"tree.{port}", f"{damper}.p")
    return m


def chain_model(n: int) -> ph.Model:
    """N uniform rods (m_i = 1 + 0.1 i kg, l_i = 0.5 + 0.05 i m) hanging from each other on
    revolute joints about y (relative angles q_i, all 0.3 rad initially), gravity (0, 0, −g)."""
    model = ph.Model(f"chain{n}")                  # n uniform rods on revolute joints
    bodies, joints = {}, {}
    for i in range(1, n + 1):
        model.parameter(f"m{i}", 1.0 + 0.1 * i, "kg")
        model.parameter(f"l{i}", 0.5 + 0.05 * i, "m")
        bodies[f"link{i}"] = {"mass": f"m{i}", "com": [0, 0, f"-l{i}/2"],
                              "inertia": [f"m{i}*l{i}**2/12"] * 3}
        joints[f"q{i}"] = {"type": "revolute", "parent": "world" if i == 1 else f"link{i - 1}",
                           "child": f"link{i}", "axis": "y",
                           "origin": [0, 0, 0] if i == 1 else [0, 0, f"-l{i - 1}"], "q0": 0.3}
    model.parameter("g", 9.81, "m/s^2")
    model.add("chain", Multibody(bodies=bodies, joints=joints, gravity=[0, 0, "-g"], plane="xz"))
    return model


def generic_chain_model(n: int, seed: int = 1) -> ph.Model:
    """N links hanging from each other on revolute joints about random unit axes (3D, seeded),
    each a body of mass U(0.5, 2) kg with an off-axis centre of mass and a random full inertia,
    joint offsets (0.02, −0.01, −l) with l = U(0.3, 0.6) m; gravity (0, 0, −g); all joints at
    0.1 rad. The case whose symbolic build exploded (no zero folds), for the kernel."""
    rng = np.random.default_rng(seed)
    model = ph.Model(f"gchain{n}")
    model.parameter("g", 9.81, "m/s^2")
    bodies, joints, length = {}, {}, 0.0
    for i in range(n):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        A = rng.normal(size=(3, 3)) * 0.1
        second = A @ A.T + 0.01 * np.eye(3)         # a random second moment of mass
        inertia = np.trace(second) * np.eye(3) - second     # the inertia of such a body
        previous, length = length, float(rng.uniform(0.3, 0.6))
        bodies[f"link{i}"] = {"mass": float(rng.uniform(0.5, 2.0)),
                              "com": [float(v) for v in rng.uniform(-0.05, 0.05, 2)] + [-length / 2],
                              "inertia": inertia.tolist()}
        joints[f"q{i}"] = {"type": "revolute", "parent": "world" if i == 0 else f"link{i - 1}",
                           "child": f"link{i}", "axis": axis.tolist(),
                           "origin": [0, 0, 0] if i == 0 else [0.02, -0.01, -previous], "q0": 0.1}
    model.add("chain", Multibody(bodies=bodies, joints=joints, gravity=[0, 0, "-g"]))
    return model


def with_formulation(model: ph.Model, formulation: str) -> ph.Model:
    """The model with its Multibody components' ``formulation`` set (through its tables)."""
    data = io.model_to_dict(model)
    for comp in data["components"].values():
        if comp.get("type") == "Multibody":
            comp["formulation"] = formulation
    data.setdefault("model", {})["name"] = f"{model.name}_{formulation}"
    return io.model_from_dict(data)


def python_cases() -> dict[str, ph.Model]:
    """The models built here, by name."""
    return {"tree3d": tree3d_model(), "chain5": chain_model(5)}


def close(new, old, what: str, rtol: float = 1e-12) -> None:
    """Assert ``new`` equals ``old`` entrywise to ``rtol`` relative to the entry, or to 0.1 of its
    row's largest entry where that is larger (rows of a matrix, or the one row of a vector)."""
    new, old = np.atleast_2d(np.asarray(new, float)), np.atleast_2d(np.asarray(old, float))
    assert new.shape == old.shape, f"{what}: shape {new.shape} != {old.shape}"
    scale = np.max(np.abs(old), axis=1, keepdims=True)
    bound = rtol * np.maximum(np.abs(old), 0.1 * scale) + 1e-300
    worst = np.max(np.abs(new - old) / bound)
    assert worst <= 1.0, f"{what}: deviation {worst:.3g} x tolerance"


def compare_formulations(kernel, symbolic, x: np.ndarray, params: np.ndarray, close,
                          functions: tuple[str, ...], label: str) -> None:
    """The kernel-formulated model against the symbolic one at state ``x`` (parameter vector
    ``params``): each of ``functions`` (``rhs``, ``jac``, ...) and every matrix, through
    ``close(new, old, what)`` (the caller's tolerance)."""
    y = symbolic.augment(x)
    pk, ps = kernel.native_params(params), symbolic.native_params(params)
    for name in functions:
        close(getattr(kernel.functions, name)(0.0, y, pk),
              getattr(symbolic.functions, name)(0.0, y, ps), f"{label} {name}")
    for name in symbolic.matrix_names:
        close(kernel.matrix(name, 0.0, x, params), symbolic.matrix(name, 0.0, x, params),
              f"{label} {name}")


def random_states(compiled, seed: int, count: int) -> np.ndarray:
    """``count`` model states around the initial state: multibody coordinates ``<mb>.q.*``
    shifted by U(−0.4, 0.4), their velocities drawn from U(−2, 2) (m/s or rad/s) and the momenta
    set to p = M(q) v with the multibody's mass matrix ``<mb>.M``, other states shifted by
    U(−0.05, 0.05)."""
    rng = np.random.default_rng(seed)
    x0 = compiled.initial_state()
    names = compiled.state_names
    out = np.empty((count, len(x0)))
    for k in range(count):
        x = x0.copy()
        for i, name in enumerate(names):
            if ".q." in name:
                x[i] += rng.uniform(-0.4, 0.4)
            elif ".p." not in name:
                x[i] += rng.uniform(-0.05, 0.05)
        for matrix in compiled.matrix_names:
            if matrix.endswith(".M"):
                prefix = matrix[:-1] + "p."
                ip = [i for i, n in enumerate(names) if n.startswith(prefix)]
                v = rng.uniform(-2.0, 2.0, len(ip))
                x[ip] = compiled.matrix(matrix, 0.0, x, compiled.param_defaults) @ v
        out[k] = x
    return out

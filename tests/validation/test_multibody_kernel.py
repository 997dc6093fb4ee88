"""The recursive multibody kernel against the symbolic formulation, finite differences and itself.

The kernel (porthamiltonian/mechanics/kernel.c and its Python twin kernel.py) evaluates a
Multibody's dynamics over the tree's numeric tables; the symbolic formulation writes the same
recursion (porthamiltonian/mechanics/tree.py) out as compiler intermediates, and is itself checked
against the entrywise formulation (test_multibody_regression.py) and sympy.physics.mechanics
(test_multibody_sympy_mechanics.py). Here the same models are compiled both ways (``formulation =
"kernel"`` / ``"symbolic"``) and must give the same numbers to round-off at random states: the
state derivative, its Jacobian (the kernel's forward-mode tangents against the symbolic chain
rule), the energy ledger, every output (positions, port flows, poses), every named matrix (M,
the points' Jacobians) and the initial state (the initial momenta M(q0) v0), on the python and C
back ends (the two kernels). Tolerance: |kernel − symbolic| ≤ 1e-12 · max(|symbolic|, 0.1 ·
scale) entry by entry, scale the largest |entry| of the same row.

Models: the spatial tree of multibody_cases (translational root, revolute joints about skew axes,
a prismatic joint along a skew axis, welds, point, frame and joint ports loaded by dampers) and
a floating tree with every other joint type (a free base, a spherical shoulder, a universal wrist
about a skew axis, a prismatic slide, a translational x-z branch; points, frames and world frames
loaded by dampers; skew gravity). And an open model (the cart-pole with its input, a damper of a
parameter and declared outputs): its derivatives by inputs and parameters and its linearization
through the kernel's tangents.
"""
from __future__ import annotations

import numpy as np
import pytest
from multibody_cases import (
    close,
    compare_formulations,
    random_states,
    tree3d_model,
    with_formulation,
)

import porthamiltonian as ph
from porthamiltonian import io
from porthamiltonian.errors import CompilerError, ModelError
from porthamiltonian.mechanics import Multibody


def all_joints_model() -> ph.Model:
    """A floating base (free joint, full inertia), a spherical shoulder, a universal wrist
    (axes x then a skew axis), a prismatic slide along a skew axis with a welded tool, a
    translational x-z branch; points, a frame and world frames into dampers; skew gravity."""
    m = ph.Model("all_joints")
    m.parameter("m_arm", 0.7, "kg")
    m.parameter("l", 0.5, "m")
    bodies = {
        "base": {"mass": 2.0, "com": [0.1, -0.05, 0.2],
                 "inertia": [[0.3, 0.01, -0.02], [0.01, 0.5, 0.03], [-0.02, 0.03, 0.7]]},
        "arm": {"mass": "m_arm", "com": [0, 0.01, "-l/2"], "inertia": [0.03, 0.03, 0.004],
                "points": {"elbow": [0, 0, "-l"]}},
        "hand": {"mass": 0.3, "com": [0.02, 0, -0.05], "inertia": [0.002, 0.001, 0.0015],
                 "world_frames": {"palm": [0.01, 0.02, -0.1]}},
        "slider": {"mass": 0.2, "com": [0, 0, 0], "inertia": 0},
        "tool": {"mass": 0.1, "com": [0.01, 0, 0], "inertia": [1e-4, 2e-4, 1.5e-4],
                 "frames": {"grip": [0.03, -0.01, 0.02]}},
        "side": {"mass": 0.5, "com": [0, 0.05, 0], "inertia": [0.01, 0.01, 0.01],
                 "points": {"side_tip": [0.1, 0.05, 0]}},
    }
    joints = {
        "float": {"type": "free", "parent": "world", "child": "base",
                  "q0": [0.3, -0.2, 1.0, 0.9, 0.1, -0.3, 0.2],
                  "v0": [0.4, -0.7, 1.3, 0.5, 0.2, -0.1]},
        "shoulder": {"type": "spherical", "parent": "base", "child": "arm",
                     "origin": [0.2, -0.1, 0.3], "q0": [0.8, 0.3, 0.5, 0.1], "v0": [2.0, -1.0, 0.5]},
        "wrist": {"type": "universal", "parent": "arm", "child": "hand", "axes": ["x", [0.3, 0.9, 0.1]],
                  "origin": [0, 0, "-l"], "q0": [0.2, -0.4], "v0": [0.5, 0.3]},
        "slide": {"type": "prismatic", "parent": "hand", "child": "slider", "axis": [0.2, -0.4, 0.9],
                  "origin": [0.05, 0, -0.1], "q0": 0.05, "v0": -0.2},
        "tool_weld": {"type": "weld", "parent": "slider", "child": "tool", "origin": [0.01, 0.02, -0.03]},
        "branch": {"type": "translational", "parent": "base", "child": "side", "axes": ["x", "z"],
                   "origin": [-0.1, 0.2, 0], "q0": [0.02, -0.01], "v0": [0.1, 0.2]},
    }
    m.add("mb", Multibody(bodies=bodies, joints=joints, gravity=[0.4, -0.3, -9.81]))
    for port, damper, domain, dim in (("elbow", "dE", "translation", 3), ("palm", "dP", "screw", 6),
                                      ("grip", "dG", "screw", 6), ("side_tip", "dS", "translation", 3)):
        m.add(damper, ph.R(domain=domain, dim=dim, resistance=0.3))
        m.connect(f"mb.{port}", f"{damper}.p")
    return m


CASES = {"tree3d": tree3d_model, "all_joints": all_joints_model}


@pytest.fixture(scope="module")
def pairs(isolated_cache):
    """``pairs(case, backend)`` -> (the kernel formulation on ``backend``, the symbolic
    formulation): the symbolic reference is built once per case, on the python back end (its
    generated program is the C back end's, function by function: test_backends), so each
    back end's kernel is compared with the same numbers."""
    built = {}

    def get(case: str, backend: str):
        if (case, "symbolic") not in built:
            built[case, "symbolic"] = ph.compile_model(with_formulation(CASES[case](), "symbolic"),
                                                       backend="python")
        if (case, backend) not in built:
            built[case, backend] = ph.compile_model(with_formulation(CASES[case](), "kernel"),
                                                    backend=backend)
        return built[case, backend], built[case, "symbolic"]

    return get


@pytest.mark.parametrize("backend", ["python", "c"])
@pytest.mark.parametrize("case", sorted(CASES))
def test_kernel_gives_the_numbers_of_the_symbolic_formulation(pairs, case, backend):
    kernel, symbolic = pairs(case, backend)
    assert kernel.functions.backend == backend
    assert "mb_state(" in kernel.source and "mb_state(" not in symbolic.source
    assert kernel.state_names == symbolic.state_names
    assert kernel.output_names == symbolic.output_names
    assert kernel.matrix_names == symbolic.matrix_names
    params = np.array(symbolic.param_defaults, dtype=float)
    close(kernel.initial_state(params), symbolic.initial_state(params), f"{case} initial")
    for k, x in enumerate(random_states(symbolic, 7, 3)):
        compare_formulations(kernel, symbolic, x, params, close,
                             ("rhs", "jac", "energy", "outputs"), f"{case} #{k}")


def test_kernel_jacobian_matches_central_differences(pairs):
    """Independently of the symbolic chain rule: the kernel model's analytic Jacobian against
    central differences of its right-hand side (step 1e-6 · max(|x_j|, 1)), to 1e-6 of each
    column's scale."""
    kernel, _ = pairs("all_joints", "c")
    params = kernel.native_params(kernel.param_defaults)
    for x in random_states(kernel, 3, 2):
        y = kernel.augment(x)
        J = kernel.functions.jac(0.0, y, params)
        D = np.zeros_like(J)
        for j in range(len(y)):
            h = 1e-6 * max(abs(y[j]), 1.0)
            up, down = y.copy(), y.copy()
            up[j] += h
            down[j] -= h
            D[:, j] = (kernel.functions.rhs(0.0, up, params)
                       - kernel.functions.rhs(0.0, down, params)) / (2 * h)
        scale = np.maximum(np.max(np.abs(D), axis=0), 1.0)
        assert np.max(np.abs(J - D) / scale) < 1e-6


def test_energy_is_conserved_by_a_kernel_simulation(isolated_cache):
    """The floating tree without its dampers, kernel formulation on the C back end: over 2 s
    (Rodas5P, rtol 1e-10) H stays constant to 1e-8 of the ledger's scale."""
    model = all_joints_model()
    bare = ph.Model("all_joints_bare")
    for name, p in model.freeze().parameters.items():
        bare.parameter(name, p.value, p.unit)
    bare.add("mb", model.freeze().components["mb"])
    compiled = ph.compile_model(with_formulation(bare, "kernel"), backend="c")
    traj = compiled.simulate(2.0, rtol=1e-10, atol=1e-12)
    assert traj.status == "finished"
    assert np.ptp(traj["H"]) < 1e-8 * traj.energy_scale


def chain(n: int, axis) -> ph.Model:
    model = ph.Model(f"chain{n}")
    bodies = {f"b{i}": {"mass": 1.0, "com": [0, 0, -0.25], "inertia": [0.01, 0.01, 0.01]}
              for i in range(n)}
    joints = {f"j{i}": {"type": "revolute", "parent": "world" if i == 0 else f"b{i - 1}",
                        "child": f"b{i}", "axis": axis, "origin": [0, 0, 0 if i == 0 else -0.5]}
              for i in range(n)}
    model.add("mb", Multibody(bodies=bodies, joints=joints))
    return model


@pytest.mark.parametrize(("n", "axis", "kernel"), [(3, "y", False), (9, "y", False),
                                                   (3, [0, 0, -1], False), (10, "y", True),
                                                   (2, [0.6, 0, 0.8], True)])
def test_auto_formulation_writes_out_small_trees_on_coordinate_axes_only(n, axis, kernel):
    """``formulation = "auto"``: the kernel for an axis off the coordinate axes or more than 9
    links, the symbolic recursion otherwise (where it folds to little code)."""
    sym = ph.compiler.symbolic(chain(n, axis))
    assert bool(sym.calls) == kernel


def test_kernel_formulation_needs_tables_of_parameters():
    """A mass that varies in time cannot be a kernel table entry: "kernel" refuses it naming
    the field; "auto" writes that tree out symbolically."""
    model = ph.Model("timed")
    bodies = {"b": {"mass": "1 + 0.1*t", "com": [0, 0, -0.2], "inertia": [0.01, 0.01, 0.01]}}
    joints = {"j": {"type": "revolute", "parent": "world", "child": "b", "axis": [0.6, 0, 0.8]}}
    model.add("mb", Multibody(bodies=bodies, joints=joints, formulation="kernel"))
    with pytest.raises(ModelError, match="parameters only"):
        ph.compiler.symbolic(model)
    auto = ph.Model("timed_auto")
    auto.add("mb", Multibody(bodies=bodies, joints=joints))
    assert not ph.compiler.symbolic(auto).calls


def test_formulation_is_checked():
    with pytest.raises(ModelError, match="formulation must be one of"):
        Multibody(bodies={"b": {"mass": 1}}, joints={"j": {"type": "revolute", "parent": "world",
                                                           "child": "b", "axis": "y"}},
                  formulation="fast")


def open_cart_pole(formulation: str, pose: bool = False) -> ph.Model:
    """models/cart_pole.toml (the input force F on the cart) with a semi-active damper at the
    rod's top (a 2-D point port, a kernel site): resistance c (1 + d), c a parameter outside the
    kernel's tables and d a second input, so that both reach the kernel's load entry through
    the point's force; declared outputs x, θ, the top's height (a kernel site) and the pivot's
    velocity; ``pose``: also the rod's orientation (a kernel output without tangents)."""
    data = io.model_to_dict(io.load("cart_pole"))
    data["parameters"]["c"] = {"value": 0.3, "unit": "N*s/m", "doc": "damping at the top"}
    data["inputs"]["d"] = {"unit": "", "doc": "the damper's command"}
    data["components"]["damper"] = {"type": "R", "domain": "translation", "dim": 2,
                                    "resistance": "c*(1 + d)"}
    data["bonds"].append("cart_pole.top -> damper.p")
    data["outputs"].update({"top_z": "cart_pole.top.z", "omega": "cart_pole.v.pivot"})
    if pose:
        data["outputs"]["rod_qw"] = "cart_pole.rod.pose.qw"
    data["components"]["cart_pole"]["formulation"] = formulation
    data["model"]["name"] = f"open_cart_pole_{formulation}{'_pose' if pose else ''}"
    return io.model_from_dict(data)


@pytest.fixture(scope="module")
def open_pair(isolated_cache):
    """The open cart-pole's kernel formulation on the C back end and its symbolic reference on
    the python back end (see ``pairs``)."""
    return (ph.compile_model(open_cart_pole("kernel"), backend="c", jac_p=["c"]),
            ph.compile_model(open_cart_pole("symbolic"), backend="python", jac_p=["c"]))


def test_derivatives_of_an_open_kernel_model_are_those_of_the_symbolic_formulation(open_pair):
    """Through the kernel's tangents (d and c reach its load entry by the damper's force, the
    outputs read its site and its velocities): ∂ẋ/∂u, ∂ẋ/∂c, the linearization (A, B, C, D)
    and the exact accelerations equal the symbolic formulation's to 1e-12; ∂ẋ/∂d and ∂ẋ/∂c
    are not zero (they do pass through the kernel)."""
    kernel, symbolic = open_pair
    assert kernel.meta.kernels == ("multibody",) and symbolic.meta.kernels == ()
    for k, x in enumerate(random_states(symbolic, 5, 3)):
        u = [0.7 - 0.4 * k, 0.2 * k]
        B = kernel.input_jacobian(x=x, u=u)
        P = kernel.parameter_jacobian(["c"], x=x, u=u)
        assert np.max(np.abs(B[:, 1])) > 1e-3 and np.max(np.abs(P)) > 1e-3
        close(B, symbolic.input_jacobian(x=x, u=u), f"jac_u #{k}")
        close(P, symbolic.parameter_jacobian(["c"], x=x, u=u), f"jac_p #{k}")
        lin_k, lin_s = kernel.linearize(x=x, u=u), symbolic.linearize(x=x, u=u)
        for name in "ABCD":
            close(getattr(lin_k, name), getattr(lin_s, name), f"{name} #{k}")
        acc_k, acc_s = kernel.accelerations(x=x, u=u), symbolic.accelerations(x=x, u=u)
        assert acc_k.keys() == acc_s.keys() == {"cart_pole.a.slider", "cart_pole.a.pivot"}
        close(list(acc_k.values()), list(acc_s.values()), f"accelerations #{k}")


def test_a_derivative_by_a_kernel_table_entry_is_refused_naming_it(open_pair):
    """The kernel's tangents are by its inputs, not its tables: ∂ẋ/∂l (a length in the rod's
    table) is refused naming l and the way out; the symbolic formulation has it."""
    kernel, symbolic = open_pair
    with pytest.raises(CompilerError, match=r"by l is not available.*formulation = 'symbolic'"):
        kernel.parameter_jacobian(["l"], u=[0.0, 0.0])
    assert np.all(np.isfinite(symbolic.parameter_jacobian(["l"], u=[0.0, 0.0])))


def test_a_declared_pose_of_a_kernel_model_simulates_but_does_not_linearize(isolated_cache):
    """A body's pose comes from a kernel entry without tangents: the model compiles and runs,
    its linearization says which output has no derivative (the symbolic formulation's does)."""
    kernel = ph.compile_model(open_cart_pole("kernel", pose=True), backend="python")
    assert "out_jac" in kernel.meta.unavailable
    traj = kernel.simulate(0.2, inputs={"F": 0.5, "d": 0.0})
    assert traj.status == "finished" and np.all(np.abs(traj["rod_qw"]) <= 1.0)
    with pytest.raises(ModelError, match="'rod_qw'.*formulation = 'symbolic'"):
        kernel.linearize(u=[0.0, 0.0])
    symbolic = ph.compile_model(open_cart_pole("symbolic", pose=True), backend="python")
    assert symbolic.linearize(u=[0.0, 0.0]).C.shape == (5, 4)

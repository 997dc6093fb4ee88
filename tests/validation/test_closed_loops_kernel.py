"""Closed loops and constraints on the compiled kernel against the symbolic formulation.

With ``formulation = "kernel"`` a multibody with ``loops`` or ``constraints`` keeps the tree in
the recursive kernel (porthamiltonian/mechanics/kernel.py and its C twin kernel.c) and solves the
constrained equations there: the saddle-point systems of docs/closed-loops.md by a Schur
complement on the kernel's factorisation of M, Ṁ v by a Newton–Euler pass, the Jacobian by
implicit differentiation of the saddle-point systems; only the rows' φ, G and Ġ v are written out.
The symbolic formulation writes everything out and solves the saddle-point matrix in the
generated code (its numbers are pinned against published references in test_closed_loops.py and
test_whipple_bicycle.py). Here every shipped loop model (and a ladder of parallel chains) is
compiled both ways and must give the same state derivative, Jacobian and outputs — the constraint
forces among them — to 1e-10 of the largest entry (measured ≤ 5e-13, the ladder's Jacobian), at
the initial state and at random states off the constraints (so the stabilisation's position
correction and its Jacobian are exercised), with the constraint switches on and off (the kneed
walker's knee lock).
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from multibody_cases import compare_formulations, random_states, with_formulation

import porthamiltonian as ph
from porthamiltonian import errors, io

RTOL = 1e-10


def ladder_text(n: int, formulation: str = "auto") -> str:
    """Two planar chains of n links (1 m apart, links 0.3 m) and n rungs, rung k hanging on the
    left chain's k-th link and closed onto the right chain's by a loop revolute (3n joints, 2n
    rows: n degrees of freedom)."""
    link = '{mass = 1.0, com = [0, 0, -0.15], inertia = [0.0075, 0.0075, 0.0075]}'
    rung = '{mass = 0.5, com = [0.5, 0, 0], inertia = [0.04, 0.04, 0.04]}'
    lines = ["[model]", f'name = "ladder{n}"', "[components]", 'mb.type = "Multibody"',
             'mb.plane = "xz"', f'mb.formulation = "{formulation}"']
    for k in range(1, n + 1):
        lines += [f"mb.bodies.L{k} = {link}", f"mb.bodies.R{k} = {link}", f"mb.bodies.K{k} = {rung}"]
        for side, x in (("L", 0.0), ("R", 1.0)):
            parent = "world" if k == 1 else f"{side}{k - 1}"
            origin = f"[{x}, 0, 0]" if k == 1 else "[0, 0, -0.3]"
            lines.append(f'mb.joints.{side}{k} = {{type = "revolute", parent = "{parent}", '
                         f'child = "{side}{k}", axis = "y", origin = {origin}, '
                         f'q0 = {0.1 if k == 1 else 0}}}')
        lines.append(f'mb.joints.K{k} = {{type = "revolute", parent = "L{k}", child = "K{k}", '
                     f'axis = "y", origin = [0, 0, -0.3], q0 = -0.1}}')
        lines.append(f'mb.loops.C{k} = {{type = "revolute", parent = "K{k}", child = "R{k}", '
                     f'axis = "y", origin = [1, 0, 0], child_origin = [0, 0, -0.3]}}')
    return "\n".join(lines) + "\n"


def models() -> dict:
    """name -> (model, parameter sets to compare at): the shipped files as they are
    (``formulation = "auto"``, symbolic for these), the ladder with ``formulation =
    "symbolic"`` (``"auto"`` would choose the kernel for its 12 bodies)."""
    out = {name: (io.load(name), [{}]) for name in
           ("four_bar", "andrews_squeezer", "spatial_slider_crank", "rolling_disc")}
    out["kneed_walker"] = (io.load("kneed_walker"), [{"knee_locked": 0.0},
                                                     {"knee_locked": 1.0}])
    out["ladder4"] = (io.loads(ladder_text(4, "symbolic"), "ladder4.toml"), [{}])
    return out


CASES = models()


def close(new: np.ndarray, old: np.ndarray, what: str) -> float:
    new, old = np.asarray(new, dtype=float), np.asarray(old, dtype=float)
    scale = max(1.0, float(np.max(np.abs(old))))
    error = float(np.max(np.abs(new - old))) / scale
    assert error <= RTOL, f"{what}: {error:.2e} of the largest entry"
    return error


@pytest.fixture(scope="module")
def pairs(isolated_cache):
    """``pairs(case, backend)`` -> (the kernel formulation, the symbolic one) on ``backend``.
    The symbolic one is the model as written (:func:`models`; symbolic, which the tests
    assert), so that a shipped model's build is the one the other tests of the shipped models
    make, read from the cache (one symbolic build, not two that differ only in the model's
    name)."""
    built: dict = {}

    def get(case: str, backend: str = "python"):
        if (case, backend) not in built:
            model = CASES[case][0]
            built[case, backend] = (
                ph.compile_model(with_formulation(model, "kernel"), backend=backend),
                ph.compile_model(model, backend=backend))
        return built[case, backend]

    return get


@pytest.mark.parametrize("case", sorted(CASES))
def test_kernel_with_loops_gives_the_numbers_of_the_symbolic_formulation(pairs, case):
    kernel, symbolic = pairs(case)
    assert "mb_constrained(" in kernel.source and "mb_constrained(" not in symbolic.source
    assert kernel.meta.kernels == ("multibody",) and symbolic.meta.kernels == ()
    assert kernel.state_names == symbolic.state_names
    assert kernel.output_names == symbolic.output_names
    assert kernel.matrix_names == symbolic.matrix_names
    for values in CASES[case][1]:
        params = symbolic.params(values)
        states = [symbolic.initial_state(params), *random_states(symbolic, 11, 3)]
        for k, x in enumerate(states):
            compare_formulations(kernel, symbolic, x, params, close, ("rhs", "jac", "outputs"),
                                 f"{case} #{k} {values}")


def test_the_c_kernel_is_the_python_kernel(pairs):
    """The C twin of the constrained entry against the Python one (ladder, four loops), rhs and
    Jacobian at random states off the constraints, to 1e-12."""
    kernel_c, _ = pairs("ladder4", "c")
    kernel_py, _ = pairs("ladder4")
    params = kernel_py.params()
    pc, pp = kernel_c.native_params(params), kernel_py.native_params(params)
    for x in random_states(kernel_py, 5, 3):
        y = kernel_py.augment(x)
        for name in ("rhs", "jac"):
            a = np.asarray(getattr(kernel_c.functions, name)(0.0, y, pc))
            b = np.asarray(getattr(kernel_py.functions, name)(0.0, y, pp))
            assert np.max(np.abs(a - b)) <= 1e-12 * max(1.0, float(np.max(np.abs(b)))), name


def test_a_kernel_ladder_keeps_its_constraints_and_its_energy(pairs):
    """The ladder in the kernel formulation swinging 1 s under gravity (C, Rodas5P, rtol 1e-8):
    the energy ledger closes (the constraint forces do no work; ≤ 1e-7 relative) and the loops
    stay closed (|φ| ≤ 1e-7 m); its run equals the symbolic formulation's to 1e-7 (the two
    differ by round-off only, amplified by the integrator's step choices)."""
    kernel, symbolic = pairs("ladder4", "c")
    runs = [m.simulate(1.0, method="Rodas5P", rtol=1e-8, atol=1e-10) for m in (kernel, symbolic)]
    traj = runs[0]
    assert traj.relative_residual < 1e-7
    phi = [o for o in kernel.output_names if ".phi." in o]
    assert len(phi) == 8
    assert max(float(np.max(np.abs(traj[o]))) for o in phi) < 1e-7
    assert runs[0].x[-1] == pytest.approx(runs[1].x[-1], rel=1e-7, abs=1e-9)
    assert max(abs(traj[o][-1]) for o in kernel.output_names if ".reaction." in o) > 1.0


def test_dependent_rows_on_the_kernel_are_refused_with_the_rank(isolated_cache):
    """The same refusal as the symbolic formulation's (tests/unit/test_multibody_errors.py): two
    identical loops (4 rows on 4 velocities, rank 2), refused before anything solves with the
    rows (no division by the singular Schur complement's zero pivot: no RuntimeWarning)."""
    text = ladder_text(2, "kernel").replace(
        "mb.loops.C2 = {", 'mb.loops.C3 = {type = "revolute", parent = "K1", child = "R1", '
        'axis = "y", origin = [1, 0, 0], child_origin = [0, 0, -0.3]}\nmb.loops.C2 = {')
    text = text.replace('mb.loops.C2 = {type = "revolute", parent = "K2", child = "R2", '
                        'axis = "y", origin = [1, 0, 0], child_origin = [0, 0, -0.3]}', "")
    compiled = ph.compile_model(io.loads(text, "redundant.toml"), backend="python")
    assert "mb_constrained(" in compiled.source
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(errors.ModelError) as info:
            compiled.simulate(0.1)
    msg = str(info.value)
    assert "rank 2" in msg and "C1, C3" in msg and "redundant" in msg

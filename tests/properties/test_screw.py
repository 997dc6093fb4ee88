"""Property tests of porthamiltonian.mechanics.screw (screw theory on SE(3)).

Independent references: scipy.linalg.expm for exponentials, scipy's Rotation for random poses,
numpy's cross product and the centre-of-mass velocity for kinetic energy.
"""
from __future__ import annotations

import functools

import numpy as np
import pytest
import scipy.linalg
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from porthamiltonian.mechanics.screw import (
    Ad,
    Pose,
    Twist,
    Wrench,
    ad,
    ad_star,
    exp_se3,
    exp_so3,
    hat3,
    hat6,
    kinetic_energy,
    log_se3,
    log_so3,
    planar_pose,
    pose_inverse,
    pose_matrix,
    spatial_inertia,
    vee3,
    vee6,
)

# All generated quantities are O(1-10); a few chained 4x4/6x6 products or an expm in double
# precision stay within ~1e-12, so 1e-9 leaves a wide margin without hiding formula errors
# (which show up at O(1)).
ATOL = 1e-9
RTOL = 1e-9
# exp/log round trips lose a few digits near the rotation angle π (the log is ill-conditioned
# there: dθ ~ dR / sin θ with sin θ ≥ sin 0.1 in the round-trip test).
ROUNDTRIP_ATOL = 1e-7

SETTINGS = settings(max_examples=50, deadline=None)

coordinate = st.floats(-2.0, 2.0)
vec3 = arrays(np.float64, 3, elements=coordinate)
vec6 = arrays(np.float64, 6, elements=coordinate)
# Scales the angular part so that the small-angle (Taylor) branches and ω = 0 are exercised.
omega_scale = st.sampled_from([1.0, 1.0, 1.0, 1e-3, 1e-6, 1e-9, 0.0])
twists = st.builds(lambda w, s, v: np.concatenate([s * w, v]), vec3, omega_scale, vec3)
unit_axes = vec3.filter(lambda a: np.linalg.norm(a) > 1e-2).map(lambda a: a / np.linalg.norm(a))
frame_pairs = st.lists(
    st.sampled_from(["world", "base", "link", "tool", "camera"]), min_size=2, max_size=2,
    unique=True,
)


@st.composite
def poses(draw: st.DrawFn) -> np.ndarray:
    """Random pose built with scipy (independent of the module under test)."""
    H = np.eye(4)
    rotation_vector = draw(arrays(np.float64, 3, elements=st.floats(-3.0, 3.0)))
    H[:3, :3] = Rotation.from_rotvec(rotation_vector).as_matrix()
    H[:3, 3] = draw(vec3)
    return H


@st.composite
def rotational_inertias(draw: st.DrawFn) -> np.ndarray:
    """Random symmetric positive definite 3x3 inertia [kg·m²]: R diag(J) Rᵀ."""
    J = draw(arrays(np.float64, 3, elements=st.floats(0.01, 5.0)))
    R = Rotation.from_rotvec(draw(vec3)).as_matrix()
    return R @ np.diag(J) @ R.T


masses = st.floats(0.01, 10.0)


def assert_close(actual, expected, atol: float = ATOL) -> None:
    np.testing.assert_allclose(np.asarray(actual, dtype=float), expected, rtol=RTOL, atol=atol)


# ------------------------------------------------------------------------------------------
# hat / vee
# ------------------------------------------------------------------------------------------


@SETTINGS
@given(vec3, vec3)
def test_hat3_is_the_cross_product_and_vee3_inverts_it(w, u):
    assert_close(hat3(w) @ u, np.cross(w, u))
    assert_close(vee3(hat3(w)), w)


@SETTINGS
@given(vec6)
def test_vee6_inverts_hat6(T):
    assert_close(vee6(hat6(T)), T)


# ------------------------------------------------------------------------------------------
# Adjoint
# ------------------------------------------------------------------------------------------


@SETTINGS
@given(poses(), poses())
def test_Ad_is_a_group_homomorphism(H1, H2):
    assert_close(Ad(H1 @ H2), Ad(H1) @ Ad(H2))


@SETTINGS
@given(poses())
def test_Ad_of_inverse_pose_is_inverse_Ad(H):
    assert_close(pose_inverse(H), np.linalg.inv(H))
    assert_close(Ad(pose_inverse(H)), np.linalg.inv(Ad(H)))


@SETTINGS
@given(poses(), vec6)
def test_Ad_is_conjugation_of_hat6(H, T):
    assert_close(hat6(Ad(H) @ T), H @ hat6(T) @ np.linalg.inv(H))


@SETTINGS
@given(twists)
def test_Ad_of_exp_is_expm_of_ad(T):
    assert_close(Ad(exp_se3(T)), scipy.linalg.expm(ad(T)))


# ------------------------------------------------------------------------------------------
# Lie bracket
# ------------------------------------------------------------------------------------------


@SETTINGS
@given(vec6, vec6)
def test_ad_is_the_matrix_commutator_of_hat6(T1, T2):
    X1, X2 = hat6(T1), hat6(T2)
    assert_close(hat6(ad(T1) @ T2), X1 @ X2 - X2 @ X1)


@SETTINGS
@given(vec6, vec6)
def test_bracket_is_antisymmetric(T1, T2):
    assert_close(ad(T1) @ T2, -(ad(T2) @ T1))


@SETTINGS
@given(vec6, vec6, vec6)
def test_bracket_satisfies_jacobi_identity(T1, T2, T3):
    jacobi = ad(T1) @ ad(T2) @ T3 + ad(T2) @ ad(T3) @ T1 + ad(T3) @ ad(T1) @ T2
    assert_close(jacobi, np.zeros(6))


# ------------------------------------------------------------------------------------------
# Exponential and logarithm
# ------------------------------------------------------------------------------------------


@SETTINGS
@given(twists, st.floats(-2.0, 2.0))
def test_exp_se3_equals_expm_of_hat6(T, theta):
    assert_close(exp_se3(T, theta), scipy.linalg.expm(theta * hat6(T)))


@SETTINGS
@given(vec3, omega_scale, st.floats(-2.0, 2.0))
def test_exp_so3_equals_expm_of_hat3(w, scale, theta):
    assert_close(exp_so3(scale * w, theta), scipy.linalg.expm(theta * scale * hat3(w)))


@SETTINGS
@given(vec3)
def test_exp_se3_of_pure_translation_is_exact(v):
    H = exp_se3(np.concatenate([np.zeros(3), v]), 0.5)
    assert np.array_equal(H, pose_matrix(np.eye(3), 0.5 * v))


@SETTINGS
@given(unit_axes, st.floats(0.0, np.pi - 0.1), st.sampled_from([1.0, 1e-4, 1e-8, 0.0]), vec3)
def test_log_se3_inverts_exp_se3_below_pi(axis, angle, angle_scale, v):
    T = np.concatenate([angle * angle_scale * axis, v])
    assert_close(log_se3(exp_se3(T)), T, atol=ROUNDTRIP_ATOL)


@SETTINGS
@given(poses())
def test_exp_se3_inverts_log_se3(H):
    assert_close(exp_se3(log_se3(H)), H)


@SETTINGS
@given(unit_axes, vec3)
def test_log_se3_at_rotation_angle_pi_is_a_valid_logarithm(axis, p):
    H = pose_matrix(Rotation.from_rotvec(np.pi * axis).as_matrix(), p)
    T = log_se3(H)
    assert np.linalg.norm(T[:3]) == pytest.approx(np.pi)
    assert_close(exp_se3(T), H)


def test_log_rejects_non_rotations_and_symbolic_input():
    with pytest.raises(ValueError, match="not a rotation matrix"):
        log_so3(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(TypeError, match="numeric"):
        log_se3(sp.eye(4))


# ------------------------------------------------------------------------------------------
# Twists, wrenches and change of frame
# ------------------------------------------------------------------------------------------


@SETTINGS
@given(poses(), vec6, vec6, frame_pairs)
def test_power_is_invariant_under_change_of_frame(H, t, w, frames):
    parent, child = frames
    pose = Pose(H, parent=parent, child=child)
    T, W = Twist(t, frame=child), Wrench(w, frame=child)
    T_parent, W_parent = pose.act(T), pose.act(W)
    assert (T_parent.frame, W_parent.frame) == (parent, parent)
    assert W_parent.power(T_parent) == pytest.approx(W.power(T), rel=RTOL, abs=ATOL)
    assert T_parent.power(W_parent) == pytest.approx(t @ w, rel=RTOL, abs=ATOL)


@SETTINGS
@given(poses(), poses(), vec6, st.lists(st.sampled_from(["a", "b", "c"]), min_size=3, max_size=3,
                                        unique=True))
def test_pose_composition_and_inverse_act_consistently(H1, H2, t, frames):
    a, b, c = frames
    H_ab, H_bc = Pose(H1, parent=a, child=b), Pose(H2, parent=b, child=c)
    H_ac = H_ab @ H_bc
    assert (H_ac.parent, H_ac.child) == (a, c)
    T_c = Twist(t, frame=c)
    assert_close(H_ac.act(T_c).vector, H_ab.act(H_bc.act(T_c)).vector)
    assert_close(H_ac.act_inv(H_ac.act(T_c)).vector, t)
    assert (H_ac.inverse().parent, H_ac.inverse().child) == (c, a)


@SETTINGS
@given(vec6, vec6, st.floats(-3.0, 3.0), frame_pairs)
def test_twists_and_wrenches_add_and_scale_within_their_type(a, b, k, frames):
    for kind in (Twist, Wrench):
        x, y = kind(a, frame=frames[0]), kind(b, frame=frames[0])
        assert isinstance(x + y, kind) and (x + y).frame == frames[0]
        assert_close((x + y).vector, a + b)
        assert_close((x - y).vector, a - b)
        assert_close((k * x).vector, k * a)
        assert_close((x * np.float64(k)).vector, k * a)


@SETTINGS
@given(vec6, vec6, frame_pairs)
def test_twist_and_wrench_are_not_interchangeable(t, w, frames):
    here = frames[0]
    T, W = Twist(t, frame=here), Wrench(w, frame=here)
    with pytest.raises(TypeError):
        T + W
    with pytest.raises(TypeError):
        W + T
    with pytest.raises(TypeError):
        W - T
    with pytest.raises(TypeError, match="expects a Wrench"):
        T.power(Twist(t, frame=here))
    with pytest.raises(TypeError, match="expects a Twist"):
        W.power(W)
    with pytest.raises(TypeError):
        T.power(w)  # a bare array is not a wrench either


@SETTINGS
@given(vec6, vec6, frame_pairs, poses())
def test_frame_mismatches_are_value_errors_naming_both_frames(t, w, frames, H):
    here, there = frames
    T, W = Twist(t, frame=here), Wrench(w, frame=there)
    with pytest.raises(ValueError, match=f"{here}.*{there}"):
        T.power(W)
    with pytest.raises(ValueError, match=f"{here}.*{there}"):
        T + Twist(t, frame=there)
    with pytest.raises(ValueError, match=f"'{here}'.*'{there}'"):
        Pose(H, parent=there, child=here).act(W)
    with pytest.raises(ValueError, match="inner frames"):
        Pose(H, parent=here, child=there) @ Pose(H, parent=here, child=there)


def test_pose_rejects_non_poses_and_wrong_operands():
    with pytest.raises(ValueError, match="rotation"):
        Pose(np.diag([2.0, 1.0, 1.0, 1.0]), parent="world", child="body")
    with pytest.raises(TypeError, match="Twist or a Wrench"):
        Pose(np.eye(4), parent="world", child="body").act(np.zeros(6))


# ------------------------------------------------------------------------------------------
# Spatial inertia
# ------------------------------------------------------------------------------------------


@SETTINGS
@given(masses, vec3, rotational_inertias(), vec3, vec3)
def test_spatial_inertia_kinetic_energy_equals_com_formula(m, c, I_c, w, v):
    v_com = v + np.cross(w, c)
    expected = 0.5 * m * v_com @ v_com + 0.5 * w @ I_c @ w
    energy = kinetic_energy(spatial_inertia(m, c, I_c), np.concatenate([w, v]))
    assert energy == pytest.approx(expected, rel=RTOL, abs=ATOL)


@SETTINGS
@given(masses, vec3, rotational_inertias())
def test_spatial_inertia_is_symmetric_positive_definite(m, c, I_c):
    M = spatial_inertia(m, c, I_c)
    assert_close(M, M.T)
    assert np.linalg.eigvalsh(M).min() > 0


@SETTINGS
@given(masses, vec3, rotational_inertias())
def test_spatial_inertia_off_com_is_the_frame_change_of_the_com_inertia(m, c, I_c):
    # Frame C at the centre of mass, parallel to the body frame O: H_C_O = [[1, -c], [0, 1]];
    # kinetic energy is frame independent, so I_O = Ad(H_C_O)ᵀ I_C Ad(H_C_O).
    A = Ad(pose_matrix(np.eye(3), -c))
    assert_close(spatial_inertia(m, c, I_c), A.T @ spatial_inertia(m, np.zeros(3), I_c) @ A)


@SETTINGS
@given(st.floats(-10.0, 0.0), vec3)
def test_spatial_inertia_rejects_non_positive_mass(m, c):
    with pytest.raises(ValueError, match="mass must be positive"):
        spatial_inertia(m, c, np.eye(3))


@SETTINGS
@given(masses, arrays(np.float64, 3, elements=st.floats(-5.0, 0.0)))
def test_spatial_inertia_rejects_non_positive_definite_rotational_inertia(m, J):
    with pytest.raises(ValueError, match="symmetric positive definite, got eigenvalues"):
        spatial_inertia(m, np.zeros(3), np.diag(J))
    with pytest.raises(ValueError, match="symmetric positive definite"):
        spatial_inertia(m, np.zeros(3), np.eye(3) + np.triu(np.ones((3, 3)), 1))


# ------------------------------------------------------------------------------------------
# Lie–Poisson sign
# ------------------------------------------------------------------------------------------


@SETTINGS
@given(masses, arrays(np.float64, 3, elements=st.floats(0.01, 5.0)), vec3)
def test_ad_star_gives_euler_equations_for_pure_rotation(m, J, w):
    T = np.concatenate([w, np.zeros(3)])
    P = spatial_inertia(m, np.zeros(3), np.diag(J)) @ T
    dP = ad_star(T) @ P
    assert_close(dP[:3], np.cross(J * w, w))  # I ω̇ = (I ω) × ω
    assert_close(dP[3:], np.zeros(3))


@SETTINGS
@given(vec6, vec6)
def test_ad_star_matches_component_form_of_lie_poisson_equations(T, P):
    w, v, L, p = T[:3], T[3:], P[:3], P[3:]
    expected = np.concatenate([np.cross(L, w) + np.cross(p, v), np.cross(p, w)])
    assert_close(ad_star(T) @ P, expected)


# ------------------------------------------------------------------------------------------
# Symbolic path agrees with the numeric path
# ------------------------------------------------------------------------------------------

OMEGA = sp.symbols("w1:4", real=True)
VEL = sp.symbols("v1:4", real=True)
THETA = sp.Symbol("theta", real=True)
MASS = sp.Symbol("m", positive=True)
COM = sp.symbols("c1:4", real=True)
SYMBOLS = (*OMEGA, *VEL, THETA)


@functools.cache
def symbolic_exp_and_Ad():
    """Numeric functions lambdified from the symbolic exp_se3 and Ad(exp_se3)."""
    H = exp_se3([*OMEGA, *VEL], THETA)
    assert isinstance(H, sp.Matrix)
    return sp.lambdify(SYMBOLS, H, "numpy"), sp.lambdify(SYMBOLS, Ad(H), "numpy")


# The symbolic formulas divide by |ω|; keep it away from zero (ω = 0 is tested exactly below).
nonzero_omegas = vec3.filter(lambda w: np.linalg.norm(w) > 0.1)


@SETTINGS
@given(nonzero_omegas, vec3, st.floats(-2.0, 2.0))
def test_symbolic_exp_se3_and_Ad_match_numeric(w, v, theta):
    exp_fn, Ad_fn = symbolic_exp_and_Ad()
    H = exp_se3(np.concatenate([w, v]), theta)
    assert_close(exp_fn(*w, *v, theta), H)
    assert_close(Ad_fn(*w, *v, theta), Ad(H))


INERTIA_ENTRIES = J11, J12, J13, J22, J23, J33 = sp.symbols("J11 J12 J13 J22 J23 J33", real=True)
INERTIA = sp.Matrix([[J11, J12, J13], [J12, J22, J23], [J13, J23, J33]])
UPPER = np.triu_indices(3)  # row-major upper triangle: the order of INERTIA_ENTRIES


@functools.cache
def symbolic_ad_and_inertia():
    """Numeric functions lambdified from the symbolic ad and spatial_inertia."""
    inertia_symbols = (MASS, *COM, *INERTIA_ENTRIES)
    return (
        sp.lambdify((*OMEGA, *VEL), ad([*OMEGA, *VEL]), "numpy"),
        sp.lambdify(inertia_symbols, spatial_inertia(MASS, COM, INERTIA), "numpy"),
    )


@SETTINGS
@given(vec6, masses, vec3, rotational_inertias())
def test_symbolic_ad_and_spatial_inertia_match_numeric(T, m, c, I_c):
    ad_fn, inertia_fn = symbolic_ad_and_inertia()
    assert_close(ad_fn(*T), ad(T))
    assert_close(inertia_fn(m, *c, *I_c[UPPER]), spatial_inertia(m, c, I_c))


def test_symbolic_pure_translation_and_planar_pose_are_exact():
    assert exp_se3([0, 0, 0, *VEL], THETA) == pose_matrix(sp.eye(3), [THETA * v for v in VEL])
    x, y = sp.symbols("x y", real=True)
    c, s = sp.cos(THETA), sp.sin(THETA)
    expected = sp.Matrix([[c, -s, 0, x], [s, c, 0, y], [0, 0, 1, 0], [0, 0, 0, 1]])
    assert sp.simplify(planar_pose(x, y, THETA) - expected) == sp.zeros(4, 4)
    assert_close(planar_pose(1.0, 2.0, 0.3), np.array(expected.subs({x: 1.0, y: 2.0, THETA: 0.3}),
                                                       dtype=float))

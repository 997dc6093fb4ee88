"""Screw theory on SE(3): poses, twists, wrenches, exponential coordinates and spatial inertia.

The notation follows Stramigioli & Bruyninckx, *Geometry and Screw Theory for Robotics* (2001),
and the 20-sim 3D Mechanics Toolbox; the formulas are those of Murray, Li & Sastry, *A
Mathematical Introduction to Robotic Manipulation* (1994), with the halves of the 6-vectors swapped.

Ordering and units
------------------
* A **twist** is ``T = (ω, v)``: angular velocity first [rad/s], then linear velocity [m/s].
* A **wrench** is ``W = (τ, f)``: torque first [N·m], then force [N].
* The **power pairing** of a wrench and a twist is ``⟨W, T⟩ = τ·ω + f·v`` [W].

(Murray, Li & Sastry order twists as ``(v, ω)``; every 6x6 matrix here is for ``(ω, v)``.)

Frames (monogram notation, as in Drake)
---------------------------------------
* ``H_A_B`` is the **pose of frame B relative to frame A**: the 4x4 homogeneous matrix
  ``[[R_A_B, p_A_B], [0, 1]]`` mapping homogeneous coordinates expressed in B to coordinates
  expressed in A, ``x_A = H_A_B @ x_B``. The columns of ``R_A_B`` are B's axes expressed in A and
  ``p_A_B`` is B's origin expressed in A. Poses compose as ``H_A_C = H_A_B @ H_B_C``.
  :class:`Pose` carries the two frame names as ``parent`` (A) and ``child`` (B).
* A :class:`Twist` or :class:`Wrench` carries the name of the frame it is **expressed in**
  (``frame``): the frame whose axes and origin are used for its coordinates. Which relative motion a
  twist describes (of which body, relative to what) is up to the caller.
* Change of frame, B → A (:meth:`Pose.act` of ``H_A_B``)::

      T_A = Ad(H_A_B) T_B
      W_A = Ad(H_B_A)ᵀ W_B = (Ad(H_A_B)⁻¹)ᵀ W_B

  so that power is frame independent: ``⟨W_A, T_A⟩ = ⟨W_B, T_B⟩``.

Utilities, not port types
-------------------------
:class:`Pose`, :class:`Twist` and :class:`Wrench` are utilities for computing with poses and
screws (building a component's laws, post-processing a trajectory: ``Pose.act`` to see a frame's
twist in world coordinates); the power ports of the screw domain do not carry them. This is a
choice, for three reasons:

* the power pairing is already fixed by the domain: every ``"screw"`` port has dimension 6, its
  effort is a wrench ``(τ, f)`` and its flow a twist ``(ω, v)`` in the ordering above, so a
  bond's ``e·f`` is ``⟨W, T⟩`` by construction, and ``connect`` checks domain and dimension;
* the frame is the frame of the one body port of the bond: a multibody's frame port and a free
  body's port are expressed in their own frames, the elements that act on them (sources,
  dampers, springs, junctions) have no frame of their own and take their bond's, and no
  component changes frames (there is no adjoint transformer yet), so there is no pair of frames
  a connect-time check could compare;
* what a check would reject is rejected already: two body ports bonded directly both impose
  their twist, and the compiler refuses the pair as structurally singular, naming both
  components (tests/unit/test_multibody_frames.py).

When a component that maps screws between frames is added (an ``Ad`` transformer, a joint
between two bodies' frame ports), ports should carry their (component-qualified) frame and
``check_bond`` should compare frames: then these classes become the ports' types.

Numeric and symbolic use
------------------------
The module-level functions accept numpy arrays (or nested sequences) of floats and sympy
expressions or matrices alike. If any argument contains a sympy object the result is a
``sympy.Matrix`` (vectors as columns) computed with exact sympy functions; otherwise it is a float
numpy array (vectors one-dimensional). :func:`log_so3` and :func:`log_se3` are numeric only.
"""
from __future__ import annotations

import numbers
from collections.abc import Sequence
from typing import Any, ClassVar, TypeAlias

import numpy as np
import sympy as sp

from ..errors import FrameError, OptionError, ParameterValueError
from ..modeling.expressions import as_expr

__all__ = [
    "Ad",
    "Pose",
    "Twist",
    "Wrench",
    "ad",
    "ad_star",
    "exp_se3",
    "exp_so3",
    "hat3",
    "hat6",
    "kinetic_energy",
    "log_se3",
    "log_so3",
    "planar_pose",
    "pose_inverse",
    "pose_matrix",
    "spatial_inertia",
    "vee3",
    "vee6",
]

#: Inputs: numpy arrays, nested sequences of numbers, or sympy matrices/expressions.
ArrayLike: TypeAlias = np.ndarray | sp.MatrixBase | Sequence[Any]
#: Outputs: a float numpy array or a ``sympy.Matrix``.
Array: TypeAlias = np.ndarray | sp.Matrix
#: A scalar: a float or a sympy expression.
Scalar: TypeAlias = float | sp.Expr

#: Below this rotation angle [rad] the Rodrigues coefficients are evaluated by their Taylor
#: series (relative truncation error at most 2e-16); above it the cancellation error of the closed
#: forms stays below 1e-11 relative and is multiplied by a power of the angle in the result.
_TAYLOR_ANGLE = 1e-2
#: Largest entry of ``RᵀR - 1`` (and of the bottom row of a pose minus ``[0, 0, 0, 1]``) accepted
#: for a numeric rotation/pose.
_ROTATION_TOL = 1e-8
#: Largest ``|I - Iᵀ|`` entry, relative to the largest ``|I|`` entry, accepted as symmetric.
_SYMMETRY_RTOL = 1e-9


# --------------------------------------------------------------------------------------------
# Backends: the same formulas evaluated with numpy floats or with sympy
# --------------------------------------------------------------------------------------------


class _NumpyBackend:
    """Float arithmetic with numpy; vectors are one-dimensional arrays."""

    sin = staticmethod(np.sin)
    cos = staticmethod(np.cos)
    sqrt = staticmethod(np.sqrt)

    @staticmethod
    def scalar(x: Any) -> float:
        return float(x)

    @staticmethod
    def vector(x: Any, n: int) -> np.ndarray:
        a = np.array(x, dtype=float)
        if a.shape not in ((n,), (n, 1), (1, n)):
            raise OptionError(f"expected a {n}-vector, got an array of shape {a.shape}")
        return a.reshape(n)

    @staticmethod
    def matrix(x: Any, n: int, m: int) -> np.ndarray:
        a = np.array(x, dtype=float)
        if a.shape != (n, m):
            raise OptionError(f"expected a {n}x{m} matrix, got an array of shape {a.shape}")
        return a

    @staticmethod
    def from_rows(rows: list[list[Any]]) -> np.ndarray:
        return np.array(rows, dtype=float)

    @staticmethod
    def column(v: np.ndarray) -> np.ndarray:
        return v.reshape(-1, 1)

    @staticmethod
    def block(rows: list[list[np.ndarray]]) -> np.ndarray:
        return np.block(rows)

    @staticmethod
    def zeros(n: int, m: int) -> np.ndarray:
        return np.zeros((n, m))

    @staticmethod
    def eye(n: int) -> np.ndarray:
        return np.eye(n)

    @staticmethod
    def dot(a: np.ndarray, b: np.ndarray) -> float:
        return float(a @ b)


def _no_text(x: Any) -> Any:
    """``x`` unchanged, after checking that no entry is text (``sp.Matrix`` would sympify it,
    i.e. run it as Python); expressions from text go through porthamiltonian.modeling.expressions."""
    stack = [x]
    while stack:
        item = stack.pop()
        if isinstance(item, str):
            raise TypeError(f"expected numbers or sympy expressions, got the text {item!r}")
        if isinstance(item, (list, tuple)):
            stack += item
    return x


class _SympyBackend:
    """Exact arithmetic with sympy; vectors are column matrices."""

    sin = staticmethod(sp.sin)
    cos = staticmethod(sp.cos)
    sqrt = staticmethod(sp.sqrt)

    @staticmethod
    def scalar(x: Any) -> sp.Expr:
        return as_expr(x)

    @staticmethod
    def vector(x: Any, n: int) -> sp.Matrix:
        m = sp.Matrix(_no_text(x))
        if m.shape not in ((n, 1), (1, n)):
            raise OptionError(f"expected a {n}-vector, got a matrix of shape {m.shape}")
        return m.reshape(n, 1)

    @staticmethod
    def matrix(x: Any, n: int, m: int) -> sp.Matrix:
        a = sp.Matrix(_no_text(x))
        if a.shape != (n, m):
            raise OptionError(f"expected a {n}x{m} matrix, got a matrix of shape {a.shape}")
        return a

    @staticmethod
    def from_rows(rows: list[list[Any]]) -> sp.Matrix:
        return sp.Matrix(_no_text(rows))

    @staticmethod
    def column(v: sp.Matrix) -> sp.Matrix:
        return v

    @staticmethod
    def block(rows: list[list[sp.Matrix]]) -> sp.Matrix:
        return sp.Matrix.vstack(*(sp.Matrix.hstack(*row) for row in rows))

    @staticmethod
    def zeros(n: int, m: int) -> sp.Matrix:
        return sp.zeros(n, m)

    @staticmethod
    def eye(n: int) -> sp.Matrix:
        return sp.eye(n)

    @staticmethod
    def dot(a: sp.Matrix, b: sp.Matrix) -> sp.Expr:
        return (a.T @ b)[0]


_NUMPY = _NumpyBackend()
_SYMPY = _SympyBackend()
_Backend = _NumpyBackend | _SympyBackend


def _contains_sympy(x: Any) -> bool:
    if isinstance(x, (sp.Basic, sp.MatrixBase)):
        return True
    if isinstance(x, np.ndarray):
        return x.dtype == object and any(_contains_sympy(e) for e in x.flat)
    if isinstance(x, (list, tuple)):
        return any(_contains_sympy(e) for e in x)
    return False


def _backend(*xs: Any) -> _Backend:
    """Sympy if any argument contains a sympy object, numpy otherwise."""
    return _SYMPY if any(_contains_sympy(x) for x in xs) else _NUMPY


def _matmul(a: Any, b: Any) -> Array:
    """``a @ b`` in the common backend of ``a`` and ``b`` (a matrix times a matrix or vector)."""
    if _backend(a, b) is _SYMPY:
        return sp.Matrix(a) @ sp.Matrix(b)
    return np.asarray(a, dtype=float) @ np.asarray(b, dtype=float)


def _split6(ns: _Backend, x: ArrayLike) -> tuple[Array, Array]:
    """The two 3-vector halves of a 6-vector."""
    entries = list(ns.vector(x, 6))
    return ns.vector(entries[:3], 3), ns.vector(entries[3:], 3)


def _split_pose(ns: _Backend, H: ArrayLike) -> tuple[Array, Array]:
    """Rotation and translation of a 4x4 pose."""
    H = ns.matrix(H, 4, 4)
    return H[:3, :3], ns.vector(list(H[:3, 3]), 3)


def _require_numeric(x: Any, name: str) -> None:
    if _backend(x) is _SYMPY:
        raise TypeError(f"{name} is only implemented for numeric input, got a sympy object")


def _check_rotation(R: np.ndarray) -> None:
    error = np.abs(R.T @ R - np.eye(3)).max()
    if not (error <= _ROTATION_TOL and np.linalg.det(R) > 0):
        raise FrameError(
            f"not a rotation matrix (max |RᵀR - 1| = {error:.3g}, det R = {np.linalg.det(R):.6g}): "
            f"{R.tolist()}"
        )


def _check_pose(H: np.ndarray) -> None:
    if np.abs(H[3] - [0.0, 0.0, 0.0, 1.0]).max() > _ROTATION_TOL:
        raise FrameError(f"the bottom row of a pose must be [0, 0, 0, 1], got {H[3].tolist()}")
    _check_rotation(H[:3, :3])


def _check_frame(name: Any) -> str:
    if not isinstance(name, str) or not name:
        raise TypeError(f"a frame name must be a non-empty string, got {name!r}")
    return name


# --------------------------------------------------------------------------------------------
# so(3) and se(3)
# --------------------------------------------------------------------------------------------


def hat3(w: ArrayLike) -> Array:
    """Skew-symmetric matrix of a 3-vector.

    Parameters
    ----------
    w : array_like, shape (3,)
        Any 3-vector, e.g. an angular velocity [rad/s].

    Returns
    -------
    ndarray or sympy.Matrix, shape (3, 3)
        ``w̃`` such that ``w̃ @ u = w × u`` for every 3-vector ``u``.
    """
    ns = _backend(w)
    x, y, z = ns.vector(w, 3)
    return ns.from_rows([[0, -z, y], [z, 0, -x], [-y, x, 0]])


def vee3(S: ArrayLike) -> Array:
    """Inverse of :func:`hat3`: the vector ``(S[2,1], S[0,2], S[1,0])`` of a skew 3x3 matrix."""
    ns = _backend(S)
    S = ns.matrix(S, 3, 3)
    return ns.vector([S[2, 1], S[0, 2], S[1, 0]], 3)


def hat6(T: ArrayLike) -> Array:
    """The 4x4 se(3) matrix ``[[ω̃, v], [0, 0]]`` of a twist ``T = (ω, v)`` [rad/s, m/s].

    For the twist ``T_A`` of frame B relative to A expressed in A,
    ``dH_A_B/dt = hat6(T_A) @ H_A_B``; for the body twist ``T_B``,
    ``dH_A_B/dt = H_A_B @ hat6(T_B)``.
    """
    ns = _backend(T)
    w, v = _split6(ns, T)
    return ns.block([[hat3(w), ns.column(v)], [ns.zeros(1, 3), ns.zeros(1, 1)]])


def vee6(X: ArrayLike) -> Array:
    """Inverse of :func:`hat6`: the twist ``(ω, v)`` of a 4x4 se(3) matrix ``[[ω̃, v], [0, 0]]``."""
    ns = _backend(X)
    X = ns.matrix(X, 4, 4)
    return ns.vector(list(vee3(X[:3, :3])) + list(X[:3, 3]), 6)


def pose_matrix(R: ArrayLike, p: ArrayLike) -> Array:
    """The 4x4 pose ``[[R, p], [0, 1]]`` (``R`` 3x3 rotation, ``p`` translation [m])."""
    ns = _backend(R, p)
    return ns.block(
        [[ns.matrix(R, 3, 3), ns.column(ns.vector(p, 3))], [ns.zeros(1, 3), ns.eye(1)]]
    )


def pose_inverse(H: ArrayLike) -> Array:
    """Inverse of a pose, ``H_B_A = H_A_B⁻¹ = [[Rᵀ, -Rᵀ p], [0, 1]]``."""
    ns = _backend(H)
    R, p = _split_pose(ns, H)
    return pose_matrix(R.T, -(R.T @ p))


def Ad(H: ArrayLike) -> Array:
    """Adjoint matrix of a pose, in the ``(ω, v)`` ordering.

    Parameters
    ----------
    H : array_like, shape (4, 4)
        Pose ``H_A_B = [[R, p], [0, 1]]``.

    Returns
    -------
    ndarray or sympy.Matrix, shape (6, 6)
        ``[[R, 0], [p̃ R, R]]``, mapping a twist expressed in B to the same twist expressed in A:
        ``T_A = Ad(H_A_B) T_B``, i.e. ``hat6(T_A) = H_A_B hat6(T_B) H_A_B⁻¹``. Wrenches change frame
        with the transpose of the adjoint of the inverse pose, ``W_A = Ad(H_B_A)ᵀ W_B``.
    """
    ns = _backend(H)
    R, p = _split_pose(ns, H)
    return ns.block([[R, ns.zeros(3, 3)], [hat3(p) @ R, R]])


def ad(T: ArrayLike) -> Array:
    """The 6x6 matrix ``[[ω̃, 0], [ṽ, ω̃]]`` of the Lie bracket with a twist ``T = (ω, v)``
    [rad/s, m/s] (the adjoint of se(3)), in the ``(ω, v)`` ordering.

    ``ad(T1) @ T2 = [T1, T2]`` with ``hat6([T1, T2]) = hat6(T1) hat6(T2) - hat6(T2) hat6(T1)``.
    """
    ns = _backend(T)
    w, v = _split6(ns, T)
    W = hat3(w)
    return ns.block([[W, ns.zeros(3, 3)], [hat3(v), W]])


def ad_star(T: ArrayLike) -> Array:
    """Coadjoint matrix ``ad(T)ᵀ`` acting on momenta and wrenches, in the ``(τ, f)`` ordering.

    With this sign the Lie–Poisson (Euler–Kirchhoff) equations of a rigid body with body twist
    ``T = (ω, v)``, body momentum ``P = (L, p) = I T`` and applied body wrench ``W = (τ, f)`` read
    ``dP/dt = ad_star(T) @ P + W``, in components::

        dL/dt = L × ω + p × v + τ
        dp/dt = p × ω + f

    For a pure rotation about the centre of mass this is Euler's ``I ω̇ = (I ω) × ω + τ``.
    The matrix (6x6) is ``[[-ω̃, -ṽ], [0, -ω̃]]``.
    """
    return ad(T).T


# --------------------------------------------------------------------------------------------
# Exponential and logarithm
# --------------------------------------------------------------------------------------------


def _rodrigues_coefficients(ns: _Backend, phi: Scalar) -> tuple[Scalar, Scalar, Scalar]:
    """``A = sin φ / φ``, ``B = (1 - cos φ) / φ²``, ``C = (φ - sin φ) / φ³`` (even in φ)."""
    if ns is _NUMPY and abs(phi) < _TAYLOR_ANGLE:
        q = phi * phi
        return 1 - q / 6 + q * q / 120, 1 / 2 - q / 24 + q * q / 720, 1 / 6 - q / 120 + q * q / 5040
    if ns is _SYMPY and isinstance(phi, sp.Expr) and phi.is_zero:  # a zero rotation (ω = 0)
        return sp.Integer(1), sp.Rational(1, 2), sp.Rational(1, 6)
    return ns.sin(phi) / phi, (1 - ns.cos(phi)) / phi**2, (phi - ns.sin(phi)) / phi**3


def _rodrigues(ns: _Backend, w: ArrayLike, theta: Scalar) -> tuple[Array, Array]:
    """``R = exp(θ ω̃)`` and ``Θ = ∫₀^θ exp(s ω̃) ds``: ``exp_se3((ω, v), θ) = [[R, Θ v], [0, 1]]``.

    Each power of θ is multiplied into its coefficient so that sympy cancels θ exactly.
    """
    w = ns.vector(w, 3)
    phi = theta * ns.sqrt(ns.dot(w, w))
    A, B, C = _rodrigues_coefficients(ns, phi)
    W = hat3(w)
    W2 = W @ W
    identity = ns.eye(3)
    R = identity + (theta * A) * W + (theta**2 * B) * W2
    return R, theta * identity + (theta**2 * B) * W + (theta**3 * C) * W2


def exp_so3(w: ArrayLike, theta: Scalar = 1) -> Array:
    """Rotation matrix ``exp(θ ω̃)`` (Rodrigues' formula).

    Parameters
    ----------
    w : array_like, shape (3,)
        Angular velocity [rad/s], or a rotation axis (unit vector) when ``theta`` is an angle.
    theta : float or sympy expression, optional
        Time [s] (or angle [rad] for a unit axis) the rotation runs for; default 1.

    Returns
    -------
    ndarray or sympy.Matrix, shape (3, 3)
        The rotation by the angle ``θ |ω|`` about ``ω``. In the symbolic path a symbolic ``ω`` is
        assumed non-zero (the formula divides by ``|ω|``); an identically zero ``ω`` gives exactly
        the identity.
    """
    ns = _backend(w, theta)
    R, _ = _rodrigues(ns, w, ns.scalar(theta))
    return R


def exp_se3(T: ArrayLike, theta: Scalar = 1) -> Array:
    """Pose ``exp(θ hat6(T))`` reached by following a constant twist (closed-form, Rodrigues-based).

    Parameters
    ----------
    T : array_like, shape (6,)
        Twist ``(ω, v)`` [rad/s, m/s].
    theta : float or sympy expression, optional
        Time [s] the twist is followed for; default 1.

    Returns
    -------
    ndarray or sympy.Matrix, shape (4, 4)
        ``[[R, Θ v], [0, 1]]`` with ``R = exp_so3(ω, θ)``, ``φ = θ |ω|`` and
        ``Θ = θ 1 + (1 - cos φ)/|ω|² ω̃ + (φ - sin φ)/|ω|³ ω̃²``. ``ω = 0`` gives the
        pure translation ``[[1, θ v], [0, 1]]`` exactly; in the numeric path small ``φ`` use Taylor
        series. In the symbolic path a symbolic ``ω`` is assumed non-zero. If ``T_B`` is the
        constant body twist of B relative to A, ``H_A_B(t) = H_A_B(0) @ exp_se3(T_B, t)``.
    """
    ns = _backend(T, theta)
    theta = ns.scalar(theta)
    w, v = _split6(ns, T)
    R, Theta = _rodrigues(ns, w, theta)
    return pose_matrix(R, Theta @ v)


def log_so3(R: ArrayLike) -> np.ndarray:
    """Rotation vector ``θ a`` (angle times unit axis) with ``exp_so3(θ a) = R`` (numeric only).

    Parameters
    ----------
    R : array_like, shape (3, 3)
        Rotation matrix.

    Returns
    -------
    ndarray, shape (3,)
        Rotation vector with angle ``θ = |θ a|`` in ``[0, π]`` [rad]. At exactly ``θ = π`` both
        ``±π a`` are logarithms; the one whose axis has a non-negative component along the
        (round-off sized) antisymmetric part of ``R`` is returned.

    Raises
    ------
    TypeError
        For sympy input.
    ValueError
        If ``R`` is not a rotation matrix.
    """
    _require_numeric(R, "log_so3")
    R = _NUMPY.matrix(R, 3, 3)
    _check_rotation(R)
    s = vee3(R - R.T) / 2  # sin θ · a
    c = (np.trace(R) - 1) / 2  # cos θ
    angle = np.arctan2(np.linalg.norm(s), c)
    if c > 0:  # θ < π/2: the antisymmetric part determines the axis well
        A, _, _ = _rodrigues_coefficients(_NUMPY, angle)
        return s / A
    # θ ≥ π/2: use the symmetric part, (R + Rᵀ)/2 - cos θ · 1 = (1 - cos θ) a aᵀ
    aa = ((R + R.T) / 2 - c * np.eye(3)) / (1 - c)
    k = int(np.argmax(np.diag(aa)))
    a = aa[:, k] / np.sqrt(aa[k, k])
    return angle * (a if a @ s >= 0 else -a)


def log_se3(H: ArrayLike) -> np.ndarray:
    """Twist ``T`` with ``exp_se3(T) = H`` (numeric only).

    Parameters
    ----------
    H : array_like, shape (4, 4)
        Pose.

    Returns
    -------
    ndarray, shape (6,)
        ``(ω, v)`` with ``ω = log_so3(R)`` (rotation angle in ``[0, π]``, see :func:`log_so3` for
        the choice at exactly π) and ``v = Θ⁻¹ p``, ``Θ`` as in :func:`exp_se3` with ``θ = 1``.

    Raises
    ------
    TypeError
        For sympy input.
    ValueError
        If ``H`` is not a pose.
    """
    _require_numeric(H, "log_se3")
    H = _NUMPY.matrix(H, 4, 4)
    _check_pose(H)
    w = log_so3(H[:3, :3])
    _, Theta = _rodrigues(_NUMPY, w, 1.0)
    return np.concatenate([w, np.linalg.solve(Theta, H[:3, 3])])


def planar_pose(x: Scalar, y: Scalar, angle: Scalar) -> Array:
    """Pose of a planar (SE(2)) motion embedded in SE(3): in the x-y plane, rotation about z.

    Parameters
    ----------
    x, y : float or sympy expression
        Origin of the child frame expressed in the parent frame [m].
    angle : float or sympy expression
        Rotation of the child frame about the common z axis [rad], counter-clockwise seen from +z.

    Returns
    -------
    ndarray or sympy.Matrix, shape (4, 4)
        ``[[cos, -sin, 0, x], [sin, cos, 0, y], [0, 0, 1, 0], [0, 0, 0, 1]]``.
    """
    return pose_matrix(exp_so3([0, 0, 1], angle), [x, y, 0])


# --------------------------------------------------------------------------------------------
# Inertia
# --------------------------------------------------------------------------------------------


def _as_float_array(x: Any) -> np.ndarray | None:
    """``x`` as a float array, or None if it has symbolic entries."""
    try:
        return np.array(x, dtype=float)
    except TypeError:
        return None


def _check_inertia(mass: Scalar, I_com: Array) -> None:
    """Validate mass and rotational inertia where they are numeric (symbolic ones pass)."""
    m, I_c = _as_float_array(mass), _as_float_array(I_com)
    if m is not None and not m > 0:
        raise ParameterValueError(f"mass must be positive, got {mass}")
    if I_c is None:
        return
    message = "rotational inertia must be symmetric positive definite, got"
    if np.abs(I_c - I_c.T).max() > _SYMMETRY_RTOL * np.abs(I_c).max():
        raise ParameterValueError(f"{message} the non-symmetric matrix {I_c.tolist()}")
    eigenvalues = np.linalg.eigvalsh(I_c)
    if not eigenvalues.min() > 0:
        raise ParameterValueError(f"{message} eigenvalues {eigenvalues.tolist()}")


def spatial_inertia(mass: Scalar, com: ArrayLike, I_com: ArrayLike) -> Array:
    """6x6 spatial inertia of a rigid body in a body frame whose origin may differ from its CoM.

    Parameters
    ----------
    mass : float or sympy expression
        Mass ``m`` [kg], positive.
    com : array_like, shape (3,)
        Position ``c`` of the centre of mass expressed in the body frame [m].
    I_com : array_like, shape (3, 3)
        Rotational inertia ``I_c`` about the centre of mass, axes parallel to the body frame
        [kg·m²], symmetric positive definite.

    Returns
    -------
    ndarray or sympy.Matrix, shape (6, 6)
        In the ``(ω, v)`` ordering::

            I_o = [[I_c + m c̃ c̃ᵀ, m c̃ ],
                   [m c̃ᵀ,         m 1 ]]

        so that for the body twist ``T = (ω, v)`` of the body frame (``v`` the velocity of its
        origin), the momentum is ``P = I_o T`` and the kinetic energy
        ``½ Tᵀ I_o T = ½ m |v + ω × c|² + ½ ωᵀ I_c ω``.

    Raises
    ------
    ValueError
        If ``mass <= 0`` or ``I_com`` is not symmetric positive definite (checked for numeric
        values, also inside sympy objects; symbolic values are not checked).
    """
    ns = _backend(mass, com, I_com)
    m = ns.scalar(mass)
    I_c = ns.matrix(I_com, 3, 3)
    _check_inertia(m, I_c)
    C = hat3(ns.vector(com, 3))
    return ns.block([[I_c + m * C @ C.T, m * C], [m * C.T, m * ns.eye(3)]])


def kinetic_energy(I_spatial: ArrayLike, T: ArrayLike) -> Scalar:
    """Kinetic energy ``½ Tᵀ I T`` [J] of a body with spatial inertia ``I`` and twist ``T``.

    ``I`` (6x6, see :func:`spatial_inertia`) and ``T = (ω, v)`` [rad/s, m/s] must be expressed in
    the same frame.
    """
    ns = _backend(I_spatial, T)
    T = ns.vector(T, 6)
    return ns.dot(T, ns.matrix(I_spatial, 6, 6) @ T) / 2


# --------------------------------------------------------------------------------------------
# Frame-tagged objects
# --------------------------------------------------------------------------------------------


class Pose:
    """Pose ``H_parent_child`` of frame ``child`` relative to frame ``parent``.

    Parameters
    ----------
    matrix : array_like, shape (4, 4)
        ``[[R, p], [0, 1]]`` mapping homogeneous coordinates expressed in ``child`` to coordinates
        expressed in ``parent`` (``p`` [m] is the child origin in the parent frame). Numeric
        matrices are checked to be poses (``ValueError`` otherwise).
    parent, child : str
        Frame names (A and B of ``H_A_B``).

    Examples
    --------
    >>> H_world_link = Pose(planar_pose(1.0, 0.0, 0.0), parent="world", child="link")
    >>> T_link = Twist.from_parts([0, 0, 1], [0, 0, 0], frame="link")
    >>> H_world_link.act(T_link).linear.tolist()   # spinning about z at x = 1
    [0.0, -1.0, 0.0]
    """

    def __init__(self, matrix: ArrayLike, parent: str = "A", child: str = "B") -> None:
        ns = _backend(matrix)
        self._matrix = ns.matrix(matrix, 4, 4)
        if ns is _NUMPY:
            _check_pose(self._matrix)
        self._parent = _check_frame(parent)
        self._child = _check_frame(child)

    @property
    def matrix(self) -> Array:
        """The 4x4 homogeneous matrix."""
        return self._matrix

    @property
    def parent(self) -> str:
        """Name of the frame the pose is relative to (A of ``H_A_B``)."""
        return self._parent

    @property
    def child(self) -> str:
        """Name of the frame whose pose this is (B of ``H_A_B``)."""
        return self._child

    @property
    def rotation(self) -> Array:
        """``R_parent_child`` (3x3)."""
        return self._matrix[:3, :3]

    @property
    def translation(self) -> Array:
        """``p_parent_child``: the child origin expressed in the parent frame [m]."""
        return _split_pose(_backend(self._matrix), self._matrix)[1]

    def adjoint(self) -> Array:
        """``Ad(H_parent_child)`` (6x6), see :func:`Ad`."""
        return Ad(self._matrix)

    def inverse(self) -> Pose:
        """``H_child_parent``."""
        return Pose(pose_inverse(self._matrix), parent=self._child, child=self._parent)

    def __matmul__(self, other: Pose) -> Pose:
        """Composition ``H_A_B @ H_B_C = H_A_C``; the inner frames must match (``ValueError``)."""
        if not isinstance(other, Pose):
            return NotImplemented
        if self._child != other._parent:
            raise FrameError(
                f"cannot compose {self!r} @ {other!r}: inner frames {self._child!r} and "
                f"{other._parent!r} differ"
            )
        return Pose(_matmul(self._matrix, other._matrix), parent=self._parent, child=other._child)

    def act(self, x: Twist | Wrench) -> Twist | Wrench:
        """Express a twist or wrench given in ``child`` in ``parent``.

        ``T_parent = Ad(H) T_child`` and ``W_parent = Ad(H⁻¹)ᵀ W_child``, so power is preserved.

        Raises
        ------
        TypeError
            If ``x`` is neither a :class:`Twist` nor a :class:`Wrench`.
        ValueError
            If ``x`` is not expressed in ``child``.
        """
        if not isinstance(x, _Screw):
            raise TypeError(f"a Pose acts on a Twist or a Wrench, got {type(x).__name__}")
        if x.frame != self._child:
            raise FrameError(
                f"{self!r} acts on twists/wrenches expressed in frame {self._child!r}, got a "
                f"{type(x).__name__} expressed in frame {x.frame!r}"
            )
        M = self.adjoint() if isinstance(x, Twist) else self.inverse().adjoint().T
        return type(x)(_matmul(M, x.vector), frame=self._parent)

    def act_inv(self, x: Twist | Wrench) -> Twist | Wrench:
        """Express a twist or wrench given in ``parent`` in ``child``: ``self.inverse().act(x)``."""
        return self.inverse().act(x)

    def __repr__(self) -> str:
        return f"Pose(H_{self._parent}_{self._child}, {self._matrix.tolist()})"


class _Screw:
    """A 6-vector tagged with the frame it is expressed in (shared by Twist and Wrench)."""

    __array_ufunc__ = None  # make numpy scalars defer to __rmul__
    _dual: ClassVar[type[_Screw]]

    def __init__(self, vector: ArrayLike, frame: str) -> None:
        self._vector = _backend(vector).vector(vector, 6)
        self._frame = _check_frame(frame)

    @classmethod
    def _from_halves(cls, first: ArrayLike, second: ArrayLike, frame: str) -> Any:
        ns = _backend(first, second)
        return cls(list(ns.vector(first, 3)) + list(ns.vector(second, 3)), frame)

    @property
    def vector(self) -> Array:
        """The 6 components (a float array of shape (6,) or a 6x1 sympy.Matrix)."""
        return self._vector

    @property
    def frame(self) -> str:
        """Name of the frame the components are expressed in."""
        return self._frame

    def _half(self, i: int) -> Array:
        return _split6(_backend(self._vector), self._vector)[i]

    def _check_compatible(self, other: _Screw, verb: str) -> None:
        if type(other) is not type(self):
            raise TypeError(
                f"cannot {verb} a {type(self).__name__} and a {type(other).__name__}: twists and "
                "wrenches are dual quantities; pair them with power()"
            )
        if other._frame != self._frame:
            raise FrameError(
                f"cannot {verb} a {type(self).__name__} expressed in frame {self._frame!r} and one "
                f"expressed in frame {other._frame!r}; change frame first with Pose.act"
            )

    def __add__(self, other: Any) -> Any:
        if not isinstance(other, _Screw):
            return NotImplemented
        self._check_compatible(other, "add")
        ns = _backend(self._vector, other._vector)
        return type(self)(ns.vector(self._vector, 6) + ns.vector(other._vector, 6), self._frame)

    def __sub__(self, other: Any) -> Any:
        if not isinstance(other, _Screw):
            return NotImplemented
        self._check_compatible(other, "subtract")
        return self + (-other)

    def __neg__(self) -> Any:
        return -1 * self

    def __mul__(self, k: Any) -> Any:
        if not isinstance(k, (numbers.Real, sp.Expr)):
            return NotImplemented
        return type(self)(k * self._vector, self._frame)

    __rmul__ = __mul__

    def power(self, other: _Screw) -> Scalar:
        """Power ``⟨W, T⟩ = τ·ω + f·v`` [W] of this and a dual quantity expressed in the same frame.

        Raises
        ------
        TypeError
            If ``other`` is not of the dual type (a Wrench for a Twist, a Twist for a Wrench).
        ValueError
            If ``other`` is expressed in a different frame.
        """
        if not isinstance(other, self._dual):
            raise TypeError(
                f"{type(self).__name__}.power expects a {self._dual.__name__}, "
                f"got {type(other).__name__}"
            )
        if other._frame != self._frame:
            raise FrameError(
                f"cannot pair a {type(self).__name__} expressed in frame {self._frame!r} with a "
                f"{type(other).__name__} expressed in frame {other._frame!r}; change frame first "
                "with Pose.act"
            )
        ns = _backend(self._vector, other._vector)
        return ns.dot(ns.vector(self._vector, 6), ns.vector(other._vector, 6))

    def __repr__(self) -> str:
        components = self._vector.reshape(1, 6).tolist()[0]
        return f"{type(self).__name__}({components}, frame={self._frame!r})"


def _half(k: int, doc: str) -> property:
    """The read-only property of half ``k`` (0: first three components, 1: last three)."""
    def get(self: _Screw) -> Array:
        return self._half(k)
    get.__doc__ = doc
    return property(get)


class Twist(_Screw):
    """Twist ``(ω, v)`` [rad/s, m/s] expressed in frame ``frame``.

    Twists in the same frame add and scale by scalars; they pair with a :class:`Wrench` in the
    same frame through :meth:`power`. Adding a wrench is a ``TypeError``, adding a twist expressed
    in another frame a ``ValueError``.
    """

    angular = _half(0, "Angular velocity ω [rad/s].")
    linear = _half(1, "Linear velocity v [m/s] of the point at the frame origin.")

    @classmethod
    def from_parts(cls, angular: ArrayLike, linear: ArrayLike, frame: str) -> Twist:
        """Twist from its angular [rad/s] and linear [m/s] velocity 3-vectors."""
        return cls._from_halves(angular, linear, frame)


class Wrench(_Screw):
    """Wrench ``(τ, f)`` [N·m, N] expressed in frame ``frame``: it pairs with a :class:`Twist` in
    the same frame through :meth:`power`, and otherwise behaves as a twist does (same-frame sums,
    scaling; a ``TypeError`` for a twist, a ``ValueError`` for another frame)."""

    torque = _half(0, "Torque τ [N·m] about the frame origin.")
    force = _half(1, "Force f [N].")

    @classmethod
    def from_parts(cls, torque: ArrayLike, force: ArrayLike, frame: str) -> Wrench:
        """Wrench from its torque [N·m] (about the frame origin) and force [N] 3-vectors."""
        return cls._from_halves(torque, force, frame)


Twist._dual = Wrench
Wrench._dual = Twist

"""The free-floating rigid body in Lie–Poisson (Euler–Kirchhoff) form: the FreeBody component.

One component, :class:`FreeBody`: a rigid body in 3D, free of any joint, with its momentum in
the body frame and its pose (position and unit quaternion) as states. It compiles to

    𝕀 T = P                        (the body twist T, solved numerically, never 𝕀⁻¹),
    Ṗ = ad_Tᵀ P + W_g + s·W_port   (Lie–Poisson; L̇ = L × ω + p × v + τ, ṗ = p × ω + f),
    ṙ = R(q) v,   q̇ = ½ q ⊗ (0, ω),
    H = ½ Pᵀ T − m gᵀ (r + R(q) c).

Why the energy ledger closes: Tᵀ ad_Tᵀ P = (ad_T T)ᵀ P = [T, T]ᵀ P = 0, so the Lie–Poisson term
does no work; the gravity wrench W_g is minus the gradient of the potential along the body
twist (dV/dt = −⟨W_g, T⟩ identically, see :class:`FreeBody`), so dH/dt = s ⟨W_port, T⟩: exactly
the power entering through the port. Note that energy and |L| are conserved whichever sign the
Lie–Poisson term is written with; only a comparison with Euler's equations catches a sign error
(tests/validation/test_free_body.py does that).

Design choices (and why)
------------------------
* Orientation as a quaternion, not Euler angles: no singularity, polynomial kinematics.
* R(q) is the rotation of the *normalized* quaternion, ``R(q) = R_quad(q) / |q|²``. The exact flow
  keeps |q| constant (qᵀ q̇ = 0 identically), but the integrator lets it drift by its tolerance;
  with the normalized form R(q) stays a rotation matrix whatever the drift, the potential and the
  kinematics stay exact functions of the attitude, and the power balance holds pointwise for any
  q ≠ 0. No stabilization term is added (it would make the model stiff); |q| is an output, to be
  watched.
* Momentum about the body-frame origin, which may differ from the centre of mass: 𝕀 is
  :func:`~porthamiltonian.mechanics.screw.spatial_inertia` (constant in the body frame), so the
  implicit block has a constant matrix and its solve is cheap.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import sympy as sp

from ..errors import ModelError
from ..modeling.component import Arg, Builder, Component, register
from ..modeling.ports import Port
from .inertia import numeric_problem, require_consistent
from .kinematics import written_out
from .screw import ad_star, spatial_inertia
from .tree import quaternion_rate, quaternion_rotation

_XYZ = ("x", "y", "z")
_WXYZ = ("w", "x", "y", "z")


def _vector(value: Any, n: int, where: str, default: list) -> list:
    """``value`` as a list of ``n`` entries (numbers or expressions), ``default`` when None."""
    if value is None:
        return list(default)
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise ModelError(f"FreeBody {where}: expected a list of {n} numbers or expressions, "
                         f"got {value!r}")
    return list(value)


def _inertia_rows(value: Any) -> list[list]:
    """Three principal values or a 3x3 matrix, as a 3x3 nested list; numeric values validated."""
    if isinstance(value, (list, tuple)) and len(value) == 3 and not any(
            isinstance(r, (list, tuple)) for r in value):
        value = [[value[0], 0, 0], [0, value[1], 0], [0, 0, value[2]]]
    if not (isinstance(value, (list, tuple)) and len(value) == 3
            and all(isinstance(r, (list, tuple)) and len(r) == 3 for r in value)):
        raise ModelError("FreeBody inertia: expected three principal moments [I1, I2, I3] or a 3x3 "
                         f"matrix (kg m^2, about the centre of mass, body axes), got {value!r}")
    try:
        numeric = np.array(value, dtype=float)
    except (TypeError, ValueError):
        return [list(r) for r in value]          # symbolic entries: bound at run time, unchecked
    problem = numeric_problem(numeric, definite=True)
    if problem is not None:
        raise ModelError(f"FreeBody {problem}")
    return [list(r) for r in value]


@register
class FreeBody(Component):
    """Free-floating rigid body in Lie–Poisson form, with its pose and gravity.

    The body momentum ``P = (L, p) = 𝕀 T`` lives in se*(3), expressed in the body frame B; the
    body twist ``T = (ω, v)`` (ω the angular velocity of B, v the velocity of B's origin, both in
    B's axes) is solved from ``𝕀 T = P`` numerically at every evaluation (never a symbolic
    inverse). The pose is the position ``r`` of B's origin in the world frame W and the unit
    quaternion ``q`` of B's orientation.

    Parameters
    ----------
    mass : float or expression
        Mass m [kg], positive.
    inertia : list
        Rotational inertia I_c about the centre of mass, in the body axes [kg m²]: three principal
        moments ``[I1, I2, I3]`` (body axes = principal axes) or a symmetric positive definite 3x3
        matrix. Entries are numbers or expressions in the model's parameters.
    com : list, optional
        Centre of mass c in the body frame [m]; default ``[0, 0, 0]`` (B's origin at the centre of
        mass). When c ≠ 0 the spatial inertia about B's origin is
        ``𝕀 = [[I_c + m c̃ c̃ᵀ, m c̃], [m c̃ᵀ, m 1]]`` (:func:`~.screw.spatial_inertia`).
    gravity : list, optional
        Acceleration of gravity g in world coordinates [m/s²]; default ``[0, 0, "-9.81"]``; may be
        ``[0, 0, 0]``. Entries may depend on parameters (and on ``t``: the compiler then books the
        power of the modulation as supplied).
    position0 : list, optional
        Initial position r(0) of B's origin in world coordinates [m]; default ``[0, 0, 0]``.
    quaternion0 : list, optional
        Initial orientation q(0) = (w, x, y, z) (Hamilton, body to world); default
        ``[1, 0, 0, 0]`` (B aligned with W). It is normalized by the component, so
        ``[cos(a/2), sin(a/2) n_x, sin(a/2) n_y, sin(a/2) n_z]`` (a rotation by ``a`` about the unit
        axis ``n``) and any non-zero multiple of it are accepted.
    omega0 : list, optional
        Initial body angular velocity ω(0), in B's axes [rad/s]; default ``[0, 0, 0]``.
    v0 : list, optional
        Initial velocity of B's origin, in B's axes [m/s]; default ``[0, 0, 0]``. With
        ``T0 = (ω0, v0)`` the initial momentum is ``P0 = 𝕀 T0``.

    Notes
    -----
    **States** (13), named ``<body>.<state>``:

    * ``L.x, L.y, L.z`` — angular momentum about B's origin, B's axes [N m s];
    * ``p.x, p.y, p.z`` — linear momentum, B's axes [N s];
    * ``r.x, r.y, r.z`` — position of B's origin in W [m];
    * ``q.w, q.x, q.y, q.z`` — orientation quaternion [1], Hamilton convention, ``R(q)`` maps B
      coordinates to W coordinates: ``x_W = r + R(q) x_B``.

    **Equations** (twist T from the implicit block ``𝕀 T = P``, symbols ``<body>.T0..T5``)::

        L̇ = L × ω + p × v + τ_g + s τ        ṗ = p × ω + f_g + s f
        ṙ = R(q) v                            q̇ = ½ q ⊗ (0, ω)

    i.e. ``Ṗ = ad_Tᵀ P + W_g + s W`` with ``ad_T = [[ω̃, 0], [ṽ, ω̃]]`` (``screw.ad_star``;
    Stramigioli & Bruyninckx write ad*_T). For a pure rotation about the centre of mass this is
    Euler's ``I ω̇ = (I ω) × ω + τ``.

    **Gravity** enters as the body wrench ``W_g = (c × f_g, f_g)``, ``f_g = R(q)ᵀ m g``: the
    weight acting at the centre of mass, expressed in B about B's origin. It is the wrench of the
    potential ``V = −m gᵀ (r + R(q) c)``: along the kinematics, ``dV/dt = −⟨W_g, T⟩``
    identically, so gravity exchanges energy with the kinetic part and nothing leaks.

    **Energy**: ``H = ½ Pᵀ T + V`` [J] (kinetic ½ Pᵀ 𝕀⁻¹ P plus gravity potential), a function of
    the states only; no dissipation.

    **Port** ``body`` (domain "screw", dimension 6, frame "body" = B, optional, orientation set by
    the bond): effort = wrench ``W = (τ, f)`` [N m, N], torque about B's origin and force, in B's
    axes; flow = body twist ``T = (ω, v)`` [rad/s, m/s]; power ⟨W, T⟩ = τ·ω + f·v. With the bond
    pointing into the body (head, ``s = +1``) the effort is the wrench applied *to* the body; with
    the bond pointing out (tail, ``s = −1``) it is the wrench the body exerts on the element at the
    other end (so ``connect("body.body", "damper.p")`` gives the body the wrench −W). Unconnected,
    it carries no wrench.

    **Outputs** (``<body>.<name>``):

    * ``omega.x|y|z`` — body angular velocity ω [rad/s] (B's axes);
    * ``v.x|y|z`` — velocity of B's origin [m/s] (B's axes);
    * ``com.x|y|z`` — position of the centre of mass in W [m];
    * ``L_norm`` — |L_c| [N m s], the norm of the angular momentum about the centre of mass,
      ``L_c = L − c × p`` (the same in B and in W; equal to |L| when c = 0); conserved when no
      torque acts about the centre of mass (torque-free, or uniform gravity);
    * ``T`` — kinetic energy ½ Pᵀ T [J]; ``V`` — potential energy [J] (names as in Multibody);
    * ``q_norm`` — |q| [1], 1 for the exact flow (a measure of integration drift).

    **Matrix** ``<body>.inertia``: the 6x6 spatial inertia 𝕀 about B's origin, in B.

    References
    ----------
    S. Stramigioli, H. Bruyninckx, *Geometry and Screw Theory for Robotics*, tutorial, IEEE ICRA
    2001 (twists, wrenches, ad*, the Lie–Poisson body momentum equation; 20-sim 3D Mechanics).
    J. E. Marsden, T. S. Ratiu, *Introduction to Mechanics and Symmetry*, 2nd ed., Springer 1999,
    ch. 13 and 15 (Lie–Poisson reduction; the free rigid body, its Casimir |L| and the stability
    of rotation about the major and minor axes).
    J. B. Kuipers, *Quaternions and Rotation Sequences*, Princeton 1999 (quaternion kinematics).
    """

    kind = "FreeBody"
    arguments = {
        "mass": Arg("mass m", "kg", rule=">"),
        "inertia": Arg("inertia about the centre of mass, body axes: [I1, I2, I3] or 3x3",
                       "kg*m^2", symbolic=False),
        "com": Arg("centre of mass in the body frame", "m", symbolic=False, default=None),
        "gravity": Arg("gravity acceleration in world coordinates", "m/s^2", symbolic=False,
                       default=None),
        "position0": Arg("initial position of the body-frame origin in world coordinates", "m",
                         symbolic=False, default=None),
        "quaternion0": Arg("initial orientation quaternion (w, x, y, z), body to world", "1",
                           symbolic=False, default=None),
        "omega0": Arg("initial body angular velocity (body axes)", "rad/s", symbolic=False,
                      default=None),
        "v0": Arg("initial velocity of the body-frame origin (body axes)", "m/s", symbolic=False,
                  default=None),
    }

    vector_arguments = ("inertia", "com", "gravity", "position0", "quaternion0", "omega0", "v0")

    def __init__(self, **args: Any):
        super().__init__(**args)
        mass = self.value("mass")
        if isinstance(mass, (int, float)) and not mass > 0:
            raise ModelError(f"FreeBody mass must be positive, got {mass}")
        _inertia_rows(self.value("inertia"))
        for name, n in (("com", 3), ("gravity", 3), ("position0", 3), ("quaternion0", 4),
                        ("omega0", 3), ("v0", 3)):
            _vector(self.value(name), n, name, [0] * n)
        quat = self.value("quaternion0")
        if quat is not None and all(isinstance(v, (int, float)) for v in quat) and not any(quat):
            raise ModelError("FreeBody quaternion0 must not be zero (identity: [1, 0, 0, 0])")

    def ports(self) -> list[Port]:
        return [Port("body", "screw", 6, None, "body",
                     "wrench (torque, force) on the body / body twist (omega, v), body frame",
                     optional=True)]

    def build(self, b: Builder, mass: sp.Expr, inertia: list, com: list | None,
              gravity: list | None, position0: list | None, quaternion0: list | None,
              omega0: list | None, v0: list | None) -> None:
        def vec(value: Any, n: int, what: str, default: Any) -> sp.Matrix:
            return sp.Matrix([b.parse(v, f"argument {what!r}")
                              for v in _vector(value, n, what, default)])

        I_c = sp.Matrix([[b.parse(v, "argument 'inertia'") for v in row]
                         for row in _inertia_rows(inertia)])
        require_consistent(b, I_c.tolist(), "argument 'inertia'", definite=True)
        c = vec(com, 3, "com", [0, 0, 0])
        g = vec(gravity, 3, "gravity", [0, 0, "-9.81"])
        r0 = vec(position0, 3, "position0", [0, 0, 0])
        q0 = vec(quaternion0, 4, "quaternion0", [1, 0, 0, 0])
        T0 = sp.Matrix.vstack(vec(omega0, 3, "omega0", [0, 0, 0]), vec(v0, 3, "v0", [0, 0, 0]))
        inertia6 = sp.Matrix(spatial_inertia(mass, c, I_c))         # 𝕀 about B's origin, in B

        P0 = inertia6 * T0                                          # a product, no inversion
        b.require((q0.T * q0)[0, 0], ">", "argument 'quaternion0' (its squared norm; identity: "
                  "[1, 0, 0, 0])")
        q0 = q0 / sp.sqrt((q0.T * q0)[0, 0])
        L = [b.state(f"L.{a}", "N*m*s", P0[i]) for i, a in enumerate(_XYZ)]
        p = [b.state(f"p.{a}", "N*s", P0[3 + i]) for i, a in enumerate(_XYZ)]
        r = sp.Matrix([b.state(f"r.{a}", "m", r0[i]) for i, a in enumerate(_XYZ)])
        q = sp.Matrix([b.state(f"q.{a}", "1", q0[i]) for i, a in enumerate(_WXYZ)])

        P = sp.Matrix(L + p)
        if b.ph is None:
            T = sp.Matrix(b.implicit("T", inertia6, P))            # 𝕀 T = P, solved numerically
        else:                       # the pH form's cut build: T = ∂H/∂P
            T = sp.Matrix([b.ph.eta(state) for state in L + p])
        omega, v = T[:3, :], T[3:, :]
        R = sp.Matrix(quaternion_rotation(q, written_out, "R").rows)  # R_W_B, of q/|q|

        f_g = R.T * (mass * g)                                      # weight, B's axes
        W_g = sp.Matrix.vstack(c.cross(f_g), f_g)                   # at the CoM, about B's origin
        if b.ph is not None:        # −Kᵀ ∂H/∂(r, q): ṙ = R v and q̇ = ½ q ⊗ (0, ω) transposed
            K = sp.Matrix([*(R * v), *quaternion_rate(q, omega)]).jacobian(T)
            W_g = -K.T * sp.Matrix([b.ph.eta(state) for state in [*r, *q]])
        port = b.port("body")
        s = b.sign("body")
        b.equation(port.f, T, "port flow = body twist")
        Pdot = ad_star(T) * P + W_g + s * port.e
        for state, rate in zip(L + p, Pdot):
            b.equation(b.der(state), rate, "dP/dt = ad_T' P + W_g + s W (Lie-Poisson)")
        for state, rate in zip(r, R * v):
            b.equation(b.der(state), rate, "dr/dt = R(q) v")
        for state, rate in zip(q, quaternion_rate(q, omega)):
            b.equation(b.der(state), rate, "dq/dt = 1/2 q (x) (0, omega)")

        com_world = r + R * c
        kinetic = (P.T * T)[0, 0] / 2
        potential = -mass * (g.T * com_world)[0, 0]
        b.energy(kinetic + potential)

        L_c = sp.Matrix(L) - c.cross(sp.Matrix(p))                  # about the centre of mass
        for i, a in enumerate(_XYZ):
            b.output(f"omega.{a}", omega[i])
            b.output(f"v.{a}", v[i])
            b.output(f"com.{a}", com_world[i])
        b.output("L_norm", sp.sqrt((L_c.T * L_c)[0, 0]))
        b.output("T", kinetic)
        b.output("V", potential)
        b.output("q_norm", sp.sqrt((q.T * q)[0, 0]))
        b.matrix("inertia", inertia6)


__all__ = ["FreeBody"]

# Template: appended by porthamiltonian.compiler.printers to the generated Python module of every
# model with a kernel-formulated Multibody (where ``np``, ``math`` and ``_jit`` are defined: numba's
# njit or the identity); importable on its own as well (then ``_jit`` is the identity), which the
# tests use. kernel.c is the same algorithm in C, line by line: a change here is made there too
# (tests/validation/test_multibody_kernel.py runs both). Numeric code only, no sympy. The entries
# without tangents (mb_mass, mb_jacobians, mb_poses, mb_momenta) follow it, generated for both
# templates from one table (porthamiltonian/mechanics/sources.py).
"""The recursive multibody kernel: one code for every tree, driven by numeric tables.

The dynamics of :mod:`porthamiltonian.mechanics.tree` (the recursive joint-space Hamiltonian in
the links' own frames, twists (ω, v) and wrenches (τ, f)) evaluated numerically: the links'
relative poses ``(R_k, p_k)`` (x_parent = R_k x_k + p_k) and world poses, the composite (subtree)
mass, first moment and rotational inertia, the mass matrix by the composite-rigid-body recursion
and its L^T D L factorisation without fill-in outside the ancestors (Featherstone, *Rigid Body
Dynamics Algorithms*, 2008, §6.2, §6.5), the velocities v = M⁻¹ p, the body twists (root to tip)
and subtree momenta Π_k = (L, P) (tip to root), the momentum rates
``Π_kᵀ ad_{T_k} S + Sᵀ (hᶜ_k × g_k, mᶜ_k g_k)`` of every unit twist S, the potential
``V = −g · (first moment)`` and the kinematics of sites (points and frames fixed to links).

Tangents (forward mode). Every entry takes tangent directions of its inputs ``din`` (r × K) and
returns ``dout = ∂out/∂in · din`` (m × K): each quantity is held as 1 + K numbers, its value then
its K derivatives, and every operation applies the product rule (``K = 0``: values only). The
velocities are differentiated implicitly, ``dv = M⁻¹ (dp − d(M v)|_v)``, where ``d(M v)|_v`` is
the tangent of the momenta ``Sᵀ Π`` at fixed v; the Jacobian of a model through the kernel is
therefore exact (no differences) and costs about K evaluations of the recursion.

Tables. ``s`` (integers): ``[nl, nv, nq, ns]``, then per link ``parent`` (−1: the world),
``kind`` (0 revolute, 1 prismatic, 2 spherical, 3 free), its first velocity and first coordinate
(links are ordered parents first), then per site its link and ``kind``. ``c`` (numbers, the
tree's run-time parameters): per link (16 numbers) its unit axis (revolute, prismatic), the joint's
origin in the parent's frame (m), mass (kg), first moment Σ m c (kg m) and rotational inertia
about the link origin (kg m²: xx, yy, zz, xy, xz, yz), all in the link's frame; then gravity
(world, m/s²), the first moment of the bodies welded to the world (kg m), and per site its
position in its link's frame (m). A spherical link's coordinates are a quaternion (w, x, y, z),
its velocities the relative angular velocity in its axes; a free link's are the position (parent
axes) and a quaternion, its velocities the relative twist (ω, v) in its axes.

Entries (``in``, ``out``): ``mb_state`` — in (q, p); out (v, the momentum rates without port loads,
V, then per site: kind 0 (point) world position and velocity (6), kind 1 (frame) its twist
(ω, v) in its link's axes (6), kind 2 (world frame) world position, angular velocity and
velocity in world axes (9)). ``mb_load`` — in (q, per site a wrench (τ, f) about the site, in world
axes, or the link's axes for kind 1); out the generalized forces Sᵀ W (nv). ``mb_constrained``
(no sites; the table ends with m, the count of Ga's structural nonzeros and their (row, column)
pairs) — in (q, v, f the momentum rates with the ports' loads, Ga = S G (its structural
nonzeros, in the table's order), C = 1 − S (m), r = −S (Ġ v + γ G v) (m), h = S φ (m)); out
(ṗ = f − Gaᵀ ν, λ = −ν, Δv) of the saddle-point systems [M Gaᵀ; Ga C] [a; ν] = [f − Ṁ v; r]
and [M Gaᵀ; Ga C] [Δv; μ] = [0; −h] (porthamiltonian/mechanics/constrained.py), solved by the
Schur complement Ga M⁻¹ Gaᵀ − C on the factors of M, with Ṁ v = Πᵀ ad_T S + C(q, v) from a
Newton–Euler pass; the tangents by implicit differentiation of the two systems. Without tangents:
``mb_mass`` (in q; out M, nv × nv row-major), ``mb_jacobians`` (in q; per site the world Jacobian of
its velocity, 3 × nv), ``mb_poses`` (in q; per site its world position and the unit quaternion of
its link's axes, 7), ``mb_momenta`` (in (q, v); out M(q) v).
"""
try:
    _jit  # noqa: B018 - defined by the generated module's header
except NameError:
    def _jit(f):
        return f

import math

import numpy as np

_MB_ROT, _MB_TRANS, _MB_SPH, _MB_FREE = 0, 1, 2, 3
_MB_LINK = 16


@_jit
def _mb_dofs(kind):
    return 3 if kind == _MB_SPH else (6 if kind == _MB_FREE else 1)


@_jit
def _mb_screw(s, c, k, r, a, u):
    """The unit twist (a, u) of velocity r of link k, in the link's frame."""
    kind = s[4 + 4 * k + 1]
    base = _MB_LINK * k
    for i in range(3):
        a[i] = 0.0
        u[i] = 0.0
    if kind == _MB_ROT:
        for i in range(3):
            a[i] = c[base + i]
    elif kind == _MB_TRANS:
        for i in range(3):
            u[i] = c[base + i]
    elif r < 3:
        a[r] = 1.0
    else:
        u[r - 3] = 1.0


# --- duals: a value and D - 1 derivatives at x[i:i + D] -------------------------------------------
@_jit
def _mb_set(D, x, i, value):
    x[i] = value
    for j in range(1, D):
        x[i + j] = 0.0


@_jit
def _mb_axpy(D, alpha, x, ix, out, io):
    """out += alpha x (alpha a number)."""
    for j in range(D):
        out[io + j] += alpha * x[ix + j]


@_jit
def _mb_fma(D, a, ia, b, ib, out, io):
    """out += a b."""
    a0, b0 = a[ia], b[ib]
    for j in range(1, D):
        out[io + j] += a0 * b[ib + j] + a[ia + j] * b0
    out[io] += a0 * b0


@_jit
def _mb_fms(D, a, ia, b, ib, out, io):
    """out -= a b."""
    a0, b0 = a[ia], b[ib]
    for j in range(1, D):
        out[io + j] -= a0 * b[ib + j] + a[ia + j] * b0
    out[io] -= a0 * b0


@_jit
def _mb_div(D, a, ia, b, ib, out, io):
    """out = a / b."""
    r, inv = a[ia] / b[ib], 1.0 / b[ib]
    for j in range(1, D):
        out[io + j] = (a[ia + j] - r * b[ib + j]) * inv
    out[io] = r


@_jit
def _mb_zero(x, i, n):
    for j in range(n):
        x[i + j] = 0.0


@_jit
def _mb_copy(x, i, y, iy, n):
    for j in range(n):
        x[i + j] = y[iy + j]


@_jit
def _mb_rot(D, R, iR, v, iv, out, io):
    """out += R v (3x3 and 3-vectors of duals)."""
    for i in range(3):
        for k in range(3):
            _mb_fma(D, R, iR + (3 * i + k) * D, v, iv + k * D, out, io + i * D)


@_jit
def _mb_rot_t(D, R, iR, v, iv, out, io):
    """out += Rᵀ v."""
    for i in range(3):
        for k in range(3):
            _mb_fma(D, R, iR + (3 * k + i) * D, v, iv + k * D, out, io + i * D)


@_jit
def _mb_rot_c(D, R, iR, v, iv, out, io):
    """out += R v for a constant v (numbers at v[iv:iv + 3])."""
    for i in range(3):
        for k in range(3):
            _mb_axpy(D, v[iv + k], R, iR + (3 * i + k) * D, out, io + i * D)


@_jit
def _mb_rot_t_c(D, R, iR, v, iv, out, io):
    """out += Rᵀ v for a constant v."""
    for i in range(3):
        for k in range(3):
            _mb_axpy(D, v[iv + k], R, iR + (3 * k + i) * D, out, io + i * D)


@_jit
def _mb_cross(D, a, ia, b, ib, out, io):
    """out += a × b."""
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        _mb_fma(D, a, ia + i1 * D, b, ib + i2 * D, out, io + i * D)
        _mb_fms(D, a, ia + i2 * D, b, ib + i1 * D, out, io + i * D)


@_jit
def _mb_cross_c(D, a, ia, sign, b, ib, out, io):
    """out += sign (a × b) for a constant a (numbers at a[ia:ia + 3])."""
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        _mb_axpy(D, sign * a[ia + i1], b, ib + i2 * D, out, io + i * D)
        _mb_axpy(D, -sign * a[ia + i2], b, ib + i1 * D, out, io + i * D)


@_jit
def _mb_dot_c(D, a, ia, b, ib, out, io):
    """out += a · b for a constant a."""
    for i in range(3):
        _mb_axpy(D, a[ia + i], b, ib + i * D, out, io)


@_jit
def _mb_mat_mul(D, A, iA, B, iB, out, io):
    """out = A B (3x3 duals)."""
    _mb_zero(out, io, 9 * D)
    for i in range(3):
        for k in range(3):
            for m in range(3):
                _mb_fma(D, A, iA + (3 * i + m) * D, B, iB + (3 * m + k) * D, out, io + (3 * i + k) * D)


# --- positions ------------------------------------------------------------------------------------
@_jit
def _mb_quaternion(D, q, iq, R, iR):
    """The rotation of q / |q| (Hamilton, w x y z; duals at q[iq:]) into R."""
    n2 = np.zeros(D)
    e = np.zeros(D)
    for m in range(4):
        _mb_fma(D, q, iq + m * D, q, iq + m * D, n2, 0)
    w = iq
    for i in range(3):               # diagonal: w² + a_i² − the other two squared
        _mb_set(D, e, 0, 0.0)
        _mb_fma(D, q, w, q, w, e, 0)
        for a in range(3):
            if a == i:
                _mb_fma(D, q, iq + (a + 1) * D, q, iq + (a + 1) * D, e, 0)
            else:
                _mb_fms(D, q, iq + (a + 1) * D, q, iq + (a + 1) * D, e, 0)
        _mb_div(D, e, 0, n2, 0, R, iR + 4 * i * D)
    for i in range(3):               # off-diagonal: 2 (a_i a_j ∓ w a_k), minus when j follows i
        for j in range(3):
            if i == j:
                continue
            k = 3 - i - j
            _mb_set(D, e, 0, 0.0)
            _mb_fma(D, q, iq + (i + 1) * D, q, iq + (j + 1) * D, e, 0)
            if (j - i + 3) % 3 == 1:
                _mb_fms(D, q, w, q, iq + (k + 1) * D, e, 0)
            else:
                _mb_fma(D, q, w, q, iq + (k + 1) * D, e, 0)
            for m in range(D):
                e[m] *= 2.0
            _mb_div(D, e, 0, n2, 0, R, iR + (3 * i + j) * D)


@_jit
def _mb_positions(D, s, c, q, R, p, R0, p0):
    """Relative poses (R, p) and world poses (R0, p0) of the links, root to tip; q: the
    coordinates as duals (nq x D)."""
    nl = s[0]
    cs = np.zeros(D)
    sn = np.zeros(D)
    for k in range(nl):
        parent, kind, co = s[4 + 4 * k], s[4 + 4 * k + 1], s[4 + 4 * k + 3]
        base = _MB_LINK * k
        iR, ip = 9 * D * k, 3 * D * k
        for i in range(3):
            _mb_set(D, p, ip + i * D, c[base + 3 + i])
        if kind == _MB_ROT:
            iq = co * D
            c0, s0 = math.cos(q[iq]), math.sin(q[iq])
            cs[0], sn[0] = c0, s0
            for j in range(1, D):
                cs[j] = -s0 * q[iq + j]
                sn[j] = c0 * q[iq + j]
            ax, ay, az = c[base], c[base + 1], c[base + 2]
            skew = (0.0, -az, ay, az, 0.0, -ax, -ay, ax, 0.0)
            for i in range(3):
                for m in range(3):
                    e = iR + (3 * i + m) * D
                    aa = c[base + i] * c[base + m]
                    diag = (1.0 if i == m else 0.0) - aa
                    for j in range(D):
                        R[e + j] = diag * cs[j] + skew[3 * i + m] * sn[j]
                    R[e] += aa
        elif kind == _MB_TRANS:
            for i in range(9):
                _mb_set(D, R, iR + i * D, 1.0 if i % 4 == 0 else 0.0)
            for i in range(3):
                _mb_axpy(D, c[base + i], q, co * D, p, ip + i * D)
        elif kind == _MB_SPH:
            _mb_quaternion(D, q, co * D, R, iR)
        else:
            _mb_quaternion(D, q, (co + 3) * D, R, iR)
            for i in range(3):
                _mb_axpy(D, 1.0, q, (co + i) * D, p, ip + i * D)
        if parent < 0:
            _mb_copy(R0, iR, R, iR, 9 * D)
            _mb_copy(p0, ip, p, ip, 3 * D)
        else:
            _mb_mat_mul(D, R0, 9 * D * parent, R, iR, R0, iR)
            _mb_copy(p0, ip, p0, 3 * D * parent, 3 * D)
            _mb_rot(D, R0, 9 * D * parent, p, ip, p0, ip)


@_jit
def _mb_composites(D, s, c, R, p, mc, hc, Jc):
    """Composite mass mc, first moment hc (duals) and rotational inertia Jc (values, 3x3, about
    the link origin) of every link's subtree, tip to root."""
    nl = s[0]
    Rh = np.zeros(3 * D)
    for k in range(nl):
        base = _MB_LINK * k
        mc[k] = c[base + 6]
        for i in range(3):
            _mb_set(D, hc, 3 * D * k + i * D, c[base + 7 + i])
        J = base + 10
        Jc[9 * k], Jc[9 * k + 4], Jc[9 * k + 8] = c[J], c[J + 1], c[J + 2]
        Jc[9 * k + 1] = Jc[9 * k + 3] = c[J + 3]
        Jc[9 * k + 2] = Jc[9 * k + 6] = c[J + 4]
        Jc[9 * k + 5] = Jc[9 * k + 7] = c[J + 5]
    RJ = np.zeros(9)
    P = np.zeros(3)
    H = np.zeros(3)
    for k in range(nl - 1, -1, -1):
        parent = s[4 + 4 * k]
        if parent < 0:
            continue
        iR, ip, m = 9 * D * k, 3 * D * k, mc[k]
        _mb_zero(Rh, 0, 3 * D)
        _mb_rot(D, R, iR, hc, 3 * D * k, Rh, 0)
        mc[parent] += m
        for i in range(3):
            _mb_axpy(D, 1.0, Rh, i * D, hc, 3 * D * parent + i * D)
            _mb_axpy(D, m, p, ip + i * D, hc, 3 * D * parent + i * D)
        # R J Rᵀ + m (|p|² 1 − p pᵀ) + 2 (p · Rh) 1 − p Rhᵀ − Rh pᵀ (values)
        for i in range(3):
            P[i] = p[ip + i * D]
            H[i] = Rh[i * D]
        for i in range(3):
            for a in range(3):
                acc = 0.0
                for b in range(3):
                    acc += R[iR + (3 * i + b) * D] * Jc[9 * k + 3 * b + a]
                RJ[3 * i + a] = acc
        p2 = P[0] * P[0] + P[1] * P[1] + P[2] * P[2]
        ph = 2.0 * (P[0] * H[0] + P[1] * H[1] + P[2] * H[2])
        for i in range(3):
            for a in range(3):
                acc = 0.0
                for b in range(3):
                    acc += RJ[3 * i + b] * R[iR + (3 * a + b) * D]
                eye = 1.0 if i == a else 0.0
                Jc[9 * parent + 3 * i + a] += (acc + m * (eye * p2 - P[i] * P[a]) + eye * ph
                                              - P[i] * H[a] - H[i] * P[a])


@_jit
def _mb_lambda(s):
    """The dof-level parent of every velocity (the previous velocity of a multi-velocity joint,
    else the last velocity of the parent link; −1 at the root) and the first of the contiguous
    ancestors of each (run[i] = j: lam[m] = m − 1 for j < m ≤ i): (lam, run)."""
    nl, nv = s[0], s[1]
    lam = np.empty(nv, dtype=np.int64)
    run = np.empty(nv, dtype=np.int64)
    for k in range(nl):
        parent, i0, n = s[4 + 4 * k], s[4 + 4 * k + 2], _mb_dofs(s[4 + 4 * k + 1])
        lam[i0] = -1 if parent < 0 else s[4 + 4 * parent + 2] + _mb_dofs(s[4 + 4 * parent + 1]) - 1
        for r in range(1, n):
            lam[i0 + r] = i0 + r - 1
    for i in range(nv):
        run[i] = run[i - 1] if (i > 0 and lam[i] == i - 1) else i
    return lam, run


@_jit
def _mb_mass(D, s, c, R0, p0, mc, hc, Jc, M):
    """M (nv x nv, row-major) by the composite-rigid-body recursion, from the values of the dual
    arrays R0, p0, hc: within a joint M = Sᵀ Iᶜ S in its link's frame; for an ancestor's unit
    twist (a, u) at its origin o, a⁰ · (τ⁰ + (p⁰_k − o) × f⁰) + u⁰ · f⁰ with the wrench F = Iᶜ S
    (torque about p⁰_k) and the twist in world axes."""
    nl, nv = s[0], s[1]
    a, u, b, w = np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3)
    tau, f, tw, fw, h, pk, d, cc = (np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3),
                                    np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))
    S0 = np.zeros(6 * nv)
    for i in range(nv * nv):                     # zero where two velocities share no path
        M[i] = 0.0
    for k in range(nl):                          # the unit twists in world axes (a0, u0)
        i0, iR = s[4 + 4 * k + 2], 9 * D * k
        for r in range(_mb_dofs(s[4 + 4 * k + 1])):
            _mb_screw(s, c, k, r, a, u)
            for i in range(3):
                S0[6 * (i0 + r) + i] = (R0[iR + 3 * i * D] * a[0] + R0[iR + (3 * i + 1) * D] * a[1]
                                        + R0[iR + (3 * i + 2) * D] * a[2])
                S0[6 * (i0 + r) + 3 + i] = (R0[iR + 3 * i * D] * u[0] + R0[iR + (3 * i + 1) * D] * u[1]
                                            + R0[iR + (3 * i + 2) * D] * u[2])
    for k in range(nl):
        kind, i0 = s[4 + 4 * k + 1], s[4 + 4 * k + 2]
        J, m, iR = 9 * k, mc[k], 9 * D * k
        for i in range(3):
            h[i] = hc[3 * D * k + i * D]
            pk[i] = p0[3 * D * k + i * D]
        for r in range(_mb_dofs(kind)):
            _mb_screw(s, c, k, r, a, u)
            for i in range(3):
                i1, i2 = (i + 1) % 3, (i + 2) % 3
                tau[i] = (Jc[J + 3 * i] * a[0] + Jc[J + 3 * i + 1] * a[1] + Jc[J + 3 * i + 2] * a[2]
                          + h[i1] * u[i2] - h[i2] * u[i1])
                f[i] = m * u[i] + a[i1] * h[i2] - a[i2] * h[i1]
            for t in range(r + 1):
                _mb_screw(s, c, k, t, b, w)
                e = (b[0] * tau[0] + b[1] * tau[1] + b[2] * tau[2]
                     + w[0] * f[0] + w[1] * f[1] + w[2] * f[2])
                M[(i0 + t) * nv + i0 + r] = e
                M[(i0 + r) * nv + i0 + t] = e
            if s[4 + 4 * k] < 0:
                continue
            for i in range(3):
                tw[i] = (R0[iR + 3 * i * D] * tau[0] + R0[iR + (3 * i + 1) * D] * tau[1]
                         + R0[iR + (3 * i + 2) * D] * tau[2])
                fw[i] = (R0[iR + 3 * i * D] * f[0] + R0[iR + (3 * i + 1) * D] * f[1]
                         + R0[iR + (3 * i + 2) * D] * f[2])
            j = s[4 + 4 * k]
            while j >= 0:
                j0 = s[4 + 4 * j + 2]
                for i in range(3):
                    d[i] = pk[i] - p0[3 * D * j + i * D]
                for i in range(3):
                    i1, i2 = (i + 1) % 3, (i + 2) % 3
                    cc[i] = tw[i] + d[i1] * fw[i2] - d[i2] * fw[i1]
                for t in range(_mb_dofs(s[4 + 4 * j + 1])):
                    S = 6 * (j0 + t)
                    e = (S0[S] * cc[0] + S0[S + 1] * cc[1] + S0[S + 2] * cc[2]
                         + S0[S + 3] * fw[0] + S0[S + 4] * fw[1] + S0[S + 5] * fw[2])
                    M[(j0 + t) * nv + i0 + r] = e
                    M[(i0 + r) * nv + j0 + t] = e
                j = s[4 + 4 * j]


@_jit
def _mb_ltdl(n, lam, run, H):
    """M = Lᵀ D L in place (Featherstone's LTDL: no fill-in outside the ancestors)."""
    for k in range(n - 1, -1, -1):
        i = lam[k]
        while i >= 0:
            a = H[k * n + i] / H[k * n + k]
            j = i
            while j >= 0:
                for m in range(j, run[j] - 1, -1):
                    H[i * n + m] -= a * H[k * n + m]
                j = lam[run[j]]
            H[k * n + i] = a
            i = lam[i]


@_jit
def _mb_sweep(D, j0, n, lam, run, H, x, transposed):
    """One triangular sweep over the columns j0 .. D − 1 of x (n x D) with the unit factor L of
    _mb_ltdl: Lᵀ y = x (``transposed``, tip to root: x_m −= L_im x_i) or L y = x (root to tip:
    x_i −= L_im x_m), over the ancestors m of every i."""
    for step in range(n):
        i = n - 1 - step if transposed else step
        j = lam[i]
        while j >= 0:
            for m in range(j, run[j] - 1, -1):
                a = H[i * n + m]
                src, dst = (i, m) if transposed else (m, i)
                for col in range(j0, D):
                    x[dst * D + col] -= a * x[src * D + col]
            j = lam[run[j]]


@_jit
def _mb_solve(D, j0, n, lam, run, H, x):
    """x = M⁻¹ x for the columns j0 .. D − 1 of x (n x D) with the factors of _mb_ltdl."""
    _mb_sweep(D, j0, n, lam, run, H, x, True)           # Lᵀ y = x
    for i in range(n):                                  # D z = y, then L x = z
        r = 1.0 / H[i * n + i]
        for col in range(j0, D):
            x[i * D + col] *= r
    _mb_sweep(D, j0, n, lam, run, H, x, False)


# --- velocities -----------------------------------------------------------------------------------
@_jit
def _mb_carry(D, R, p, k, T, it, tp, F, jf, fp, tmp):
    """Link k's wrench (torque T at it about its origin, force F at jf; its frame) added to its
    parent's (at tp, fp): T_λ += R T + p × (R F), F_λ += R F; tmp: 3 duals of work space."""
    _mb_zero(tmp, 0, 3 * D)
    _mb_rot(D, R, 9 * D * k, F, jf, tmp, 0)
    _mb_rot(D, R, 9 * D * k, T, it, T, tp)
    _mb_cross(D, p, 3 * D * k, tmp, 0, T, tp)
    for i in range(3 * D):
        F[fp + i] += tmp[i]


@_jit
def _mb_inertia(D, c, k, Jm, x, ix, y, iy, L, il, P, ip):
    """(L, P) = 𝕀_k (x, y): link k's own spatial inertia (about its origin, its frame) times the
    twist (x, y): L = J x + h × y, P = m y − h × x (duals at the offsets given). Jm: 9 numbers
    of work space."""
    base = _MB_LINK * k
    J, m = base + 10, c[base + 6]
    Jm[0], Jm[4], Jm[8] = c[J], c[J + 1], c[J + 2]
    Jm[1] = Jm[3] = c[J + 3]
    Jm[2] = Jm[6] = c[J + 4]
    Jm[5] = Jm[7] = c[J + 5]
    _mb_zero(L, il, 3 * D)
    _mb_zero(P, ip, 3 * D)
    for i in range(3):
        for b in range(3):
            _mb_axpy(D, Jm[3 * i + b], x, ix + b * D, L, il + i * D)
    _mb_cross_c(D, c, base + 7, 1.0, y, iy, L, il)            # h × y
    for i in range(3):
        _mb_axpy(D, m, y, iy + i * D, P, ip + i * D)
    _mb_cross_c(D, c, base + 7, -1.0, x, ix, P, ip)           # x × h = −h × x


@_jit
def _mb_velocities(D, s, c, R, p, v, w, lin, L, P):
    """Body twists (w, lin) root to tip and subtree momenta (L, P) tip to root from the
    velocities v (duals, nv x D)."""
    nl = s[0]
    a, u = np.zeros(3), np.zeros(3)
    tmp = np.zeros(3 * D)
    Jm = np.zeros(9)
    for k in range(nl):
        parent, kind, i0 = s[4 + 4 * k], s[4 + 4 * k + 1], s[4 + 4 * k + 2]
        iw = 3 * D * k
        _mb_zero(w, iw, 3 * D)
        _mb_zero(lin, iw, 3 * D)
        if parent >= 0:
            _mb_copy(tmp, 0, lin, 3 * D * parent, 3 * D)
            _mb_cross(D, w, 3 * D * parent, p, iw, tmp, 0)
            _mb_rot_t(D, R, 9 * D * k, w, 3 * D * parent, w, iw)
            _mb_rot_t(D, R, 9 * D * k, tmp, 0, lin, iw)
        for r in range(_mb_dofs(kind)):
            _mb_screw(s, c, k, r, a, u)
            for i in range(3):
                _mb_axpy(D, a[i], v, (i0 + r) * D, w, iw + i * D)
                _mb_axpy(D, u[i], v, (i0 + r) * D, lin, iw + i * D)
    for k in range(nl):                                 # each link's own momentum
        iw = 3 * D * k
        _mb_inertia(D, c, k, Jm, w, iw, lin, iw, L, iw, P, iw)
    RP = np.zeros(3 * D)
    for k in range(nl - 1, -1, -1):                     # carried to the parents
        parent = s[4 + 4 * k]
        if parent < 0:
            continue
        iw = 3 * D * k
        _mb_carry(D, R, p, k, L, iw, 3 * D * parent, P, iw, 3 * D * parent, RP)


@_jit
def _mb_ad_t(D, w, lin, L, P, iw, tau, it, f, jf):
    """τ += L × w + P × lin, f += P × w (at it, jf): the wrench ad_Tᵀ Π of the link at iw with
    twist T = (w, lin) and subtree momentum Π = (L, P), so that Sᵀ (ad_Tᵀ Π) = Πᵀ ad_T S =
    L · (w × a) + P · (w × u + lin × a) for each unit twist S = (a, u) (the triple product)."""
    _mb_cross(D, L, iw, w, iw, tau, it)
    _mb_cross(D, P, iw, lin, iw, tau, it)
    _mb_cross(D, P, iw, w, iw, f, jf)


@_jit
def _mb_project(D, s, c, k, a, u, tau, it, f, jf, e, ie):
    """e = S_kᵀ W (the link's n velocities' duals from ie): e_r = a · τ + u · f for each unit twist
    S_r = (a, u) of link k and the wrench W = (τ at it, f at jf; 3 duals each, the link's frame);
    a, u: 3 numbers of work space each."""
    for r in range(_mb_dofs(s[4 + 4 * k + 1])):
        _mb_screw(s, c, k, r, a, u)
        _mb_set(D, e, ie + r * D, 0.0)
        _mb_dot_c(D, a, 0, tau, it, e, ie + r * D)
        _mb_dot_c(D, u, 0, f, jf, e, ie + r * D)


@_jit
def _mb_generalized(D, s, c, L, P, e):
    """e = Sᵀ Π (nv duals) from the subtree momenta: M v for the velocities behind (L, P)."""
    a, u = np.zeros(3), np.zeros(3)
    for k in range(s[0]):
        _mb_project(D, s, c, k, a, u, L, 3 * D * k, P, 3 * D * k, e, s[4 + 4 * k + 2] * D)


@_jit
def _mb_times_m(D, s, c, R, p, xv, w, lin, L, P, e):
    """e = M(q) x as duals for the numbers xv (nv): its value and, at fixed x, its tangents
    d(M x)|_x through the positions' tangents."""
    nv = s[1]
    y = np.zeros(nv * D)
    for i in range(nv):
        y[i * D] = xv[i]
    _mb_velocities(D, s, c, R, p, y, w, lin, L, P)
    _mb_generalized(D, s, c, L, P, e)


@_jit
def _mb_implicit(D, s, c, R, p, lam, run, H, x, w, lin, L, P):
    """x = M⁻¹ y in place for the duals y in x (nv x D), H the factors of M: the values by the
    factors, the tangents implicitly, dx = M⁻¹ (dy − d(M x)|_x)."""
    nv = s[1]
    xv = np.zeros(nv)
    for i in range(nv):
        xv[i] = x[i * D]
    _mb_solve(1, 0, nv, lam, run, H, xv)
    if D > 1:
        e = np.zeros(nv * D)
        _mb_times_m(D, s, c, R, p, xv, w, lin, L, P, e)
        for i in range(nv * D):
            x[i] -= e[i]
        _mb_solve(D, 1, nv, lam, run, H, x)
    for i in range(nv):
        x[i * D] = xv[i]


@_jit
def _mb_bias(D, s, c, R, p, v, acc, w, lin, A, F):
    """F = the subtree wrenches of Newton–Euler's inverse dynamics without gravity (Featherstone
    2008, §5.3; tree.Tree.velocity_products), Sᵀ F = M(q) acc + C(q, v), at the joint
    accelerations acc (numbers), from the velocities v and the body twists (w, lin) (duals). Root
    to tip the spatial accelerations A_k = X_kᵀ A_λ + S acc + T_k × S v (angular at A[0:3], linear
    at A[3:6] of each link's 6 duals), tip to root the wrenches F_k = 𝕀_k A_k + T_k ×* 𝕀_k T_k
    plus the children's (torque at F[0:3], force at F[3:6])."""
    nl = s[0]
    a, u = np.zeros(3), np.zeros(3)
    Jm = np.zeros(9)
    tmp = np.zeros(3 * D)
    Lo, Po = np.zeros(3 * D), np.zeros(3 * D)
    tf = np.zeros(6 * D)
    for k in range(nl):
        parent, kind, i0 = s[4 + 4 * k], s[4 + 4 * k + 1], s[4 + 4 * k + 2]
        ia, iw = 6 * D * k, 3 * D * k
        _mb_zero(A, ia, 6 * D)
        if parent >= 0:                 # Rᵀ α_λ, Rᵀ (c_λ + α_λ × p)
            ip = 6 * D * parent
            _mb_copy(tmp, 0, A, ip + 3 * D, 3 * D)
            _mb_cross(D, A, ip, p, iw, tmp, 0)
            _mb_rot_t(D, R, 9 * D * k, A, ip, A, ia)
            _mb_rot_t(D, R, 9 * D * k, tmp, 0, A, ia + 3 * D)
        for r in range(_mb_dofs(kind)):
            _mb_screw(s, c, k, r, a, u)
            for i in range(3):
                A[ia + i * D] += acc[i0 + r] * a[i]
                A[ia + 3 * D + i * D] += acc[i0 + r] * u[i]
            _mb_zero(tmp, 0, 3 * D)
            _mb_cross_c(D, a, 0, -1.0, w, iw, tmp, 0)             # w × a
            for i in range(3):
                _mb_fma(D, v, (i0 + r) * D, tmp, i * D, A, ia + i * D)
            _mb_zero(tmp, 0, 3 * D)
            _mb_cross_c(D, u, 0, -1.0, w, iw, tmp, 0)             # w × u
            _mb_cross_c(D, a, 0, -1.0, lin, iw, tmp, 0)           # lin × a
            for i in range(3):
                _mb_fma(D, v, (i0 + r) * D, tmp, i * D, A, ia + 3 * D + i * D)
    _mb_zero(F, 0, 6 * D * nl)
    for k in range(nl - 1, -1, -1):
        parent, ia, iw = s[4 + 4 * k], 6 * D * k, 3 * D * k
        _mb_inertia(D, c, k, Jm, A, ia, A, ia + 3 * D, tf, 0, tf, 3 * D)
        _mb_inertia(D, c, k, Jm, w, iw, lin, iw, Lo, 0, Po, 0)
        _mb_cross(D, w, iw, Lo, 0, tf, 0)
        _mb_cross(D, lin, iw, Po, 0, tf, 0)
        _mb_cross(D, w, iw, Po, 0, tf, 3 * D)
        for i in range(6 * D):
            F[ia + i] += tf[i]
        if parent < 0:
            continue
        ip = 6 * D * parent
        _mb_carry(D, R, p, k, F, ia, ip, F, ia + 3 * D, ip + 3 * D, tmp)


# --- entry points ---------------------------------------------------------------------------------
@_jit
def _mb_seed(D, n, values, din, x):
    """The duals x (n x D) from values[:n] and tangents din (n x K)."""
    for i in range(n):
        x[i * D] = values[i]
        for j in range(1, D):
            x[i * D + j] = din[i, j - 1]


@_jit
def _mb_emit(D, x, ix, out, dout, i):
    out[i] = x[ix]
    for j in range(1, D):
        dout[i, j - 1] = x[ix + j]


@_jit
def _mb_tree(D, s, c, x, R, p, R0, p0, mc, hc, Jc, M):
    """The tree at the duals x = (q, …): poses, composites and M factored in place (values):
    (lam, run) of _mb_lambda."""
    _mb_positions(D, s, c, x, R, p, R0, p0)
    _mb_composites(D, s, c, R, p, mc, hc, Jc)
    _mb_mass(D, s, c, R0, p0, mc, hc, Jc, M)
    lam, run = _mb_lambda(s)
    _mb_ltdl(s[1], lam, run, M)
    return lam, run


@_jit
def _mb_state_outputs(s):
    nv, ns = s[1], s[3]
    count = 2 * nv + 1
    for i in range(ns):
        count += 9 if s[4 + 4 * s[0] + 2 * i + 1] == 2 else 6
    return count


@_jit
def _mb_work_size(s, D):
    """The length of a state entry's work (:func:`_mb_work`) at D = 1 + K."""
    nl, nv, nq = s[0], s[1], s[2]
    return 1 + (nq + 2 * nv + 39 * nl) * D + 10 * nl + nv * nv


@_jit
def _mb_work(s, D, work):
    """The state entry's work, kept for the constrained entry (mb_state_keep,
    mb_constrained_reuse): work[0] = D, then views of the duals x (q, p), v, R, p, R0, p0, hc,
    w, lin, L, P and of the values mc, Jc, M (factored)."""
    nl, nv, nq = s[0], s[1], s[2]
    o = np.zeros(15, dtype=np.int64)
    sizes = ((nq + nv) * D, nv * D, 9 * D * nl, 3 * D * nl, 9 * D * nl, 3 * D * nl, 3 * D * nl,
             3 * D * nl, 3 * D * nl, 3 * D * nl, 3 * D * nl, nl, 9 * nl, nv * nv)
    o[0] = 1
    for i in range(14):
        o[i + 1] = o[i] + sizes[i]
    return (work[o[0]:o[1]], work[o[1]:o[2]], work[o[2]:o[3]], work[o[3]:o[4]], work[o[4]:o[5]],
            work[o[5]:o[6]], work[o[6]:o[7]], work[o[7]:o[8]], work[o[8]:o[9]], work[o[9]:o[10]],
            work[o[10]:o[11]], work[o[11]:o[12]], work[o[12]:o[13]], work[o[13]:o[14]])


@_jit
def _mb_kept(s, D, work, x):
    """Whether work is a state entry's at the duals of (q, v) that begin x (values and tangents
    equal): then the constrained entry reuses its tree, twists and subtree momenta."""
    nv, nq = s[1], s[2]
    if work.shape[0] != _mb_work_size(s, D) or work[0] != D:
        return False
    for i in range(nq * D):
        if work[1 + i] != x[i]:
            return False
    iv = 1 + (nq + nv) * D
    for i in range(nv * D):
        if work[iv + i] != x[nq * D + i]:
            return False
    return True


@_jit
def mb_state(s, c, values, din):
    """The state entry (see the module docstring): (out, dout)."""
    out, dout, _ = mb_state_keep(s, c, values, din)
    return out, dout


@_jit
def mb_state_keep(s, c, values, din):
    """The state entry and its work (:func:`_mb_work`): (out, dout, work)."""
    nl, nv, nq, ns = s[0], s[1], s[2], s[3]
    K = din.shape[1]
    D = 1 + K
    out = np.zeros(_mb_state_outputs(s))
    dout = np.zeros((out.shape[0], K))
    work = np.zeros(_mb_work_size(s, D))
    work[0] = D
    x, v, R, p, R0, p0, hc, w, lin, L, P, mc, Jc, M = _mb_work(s, D, work)
    g = np.zeros(3 * D * nl)
    a, u = np.zeros(3), np.zeros(3)
    e = np.zeros(6 * D)
    _mb_seed(D, nq + nv, values, din, x)
    lam, run = _mb_tree(D, s, c, x, R, p, R0, p0, mc, hc, Jc, M)
    _mb_copy(v, 0, x, nq * D, nv * D)
    _mb_implicit(D, s, c, R, p, lam, run, M, v, w, lin, L, P)
    _mb_velocities(D, s, c, R, p, v, w, lin, L, P)
    G = _MB_LINK * nl
    for k in range(nl):                                 # gravity in each link's frame
        parent = s[4 + 4 * k]
        _mb_zero(g, 3 * D * k, 3 * D)
        if parent < 0:
            _mb_rot_t_c(D, R, 9 * D * k, c, G, g, 3 * D * k)
        else:
            _mb_rot_t(D, R, 9 * D * k, g, 3 * D * parent, g, 3 * D * k)
    for i in range(nv):
        _mb_emit(D, v, i * D, out, dout, i)
    o = nv
    tau, f = np.zeros(3 * D), np.zeros(3 * D)
    for k in range(nl):                  # Sᵀ (ad_Tᵀ Π + (hc × g, mc g))
        i0, iw = s[4 + 4 * k + 2], 3 * D * k
        _mb_zero(tau, 0, 3 * D)
        _mb_cross(D, hc, iw, g, iw, tau, 0)
        for j in range(3 * D):
            f[j] = mc[k] * g[iw + j]
        _mb_ad_t(D, w, lin, L, P, iw, tau, 0, f, 0)
        _mb_project(D, s, c, k, a, u, tau, 0, f, 0, e, 0)
        for r in range(_mb_dofs(s[4 + 4 * k + 1])):
            _mb_emit(D, e, r * D, out, dout, o + i0 + r)
    o += nv
    # V = −g · (first moment of the bodies welded to the world + of every root's subtree)
    SF = G + 3
    V = np.zeros(D)
    V[0] = -(c[G] * c[SF] + c[G + 1] * c[SF + 1] + c[G + 2] * c[SF + 2])
    first = np.zeros(3 * D)
    for k in range(nl):
        if s[4 + 4 * k] >= 0:
            continue
        _mb_zero(first, 0, 3 * D)
        _mb_rot(D, R0, 9 * D * k, hc, 3 * D * k, first, 0)
        for i in range(3):
            _mb_axpy(D, mc[k], p0, 3 * D * k + i * D, first, i * D)
        for i in range(3):
            _mb_axpy(D, -c[G + i], first, i * D, V, 0)
    _mb_emit(D, V, 0, out, dout, o)
    o += 1
    vel = np.zeros(3 * D)
    buf = np.zeros(9 * D)
    for i in range(ns):                                 # sites
        k, kind = s[4 + 4 * nl + 2 * i], s[4 + 4 * nl + 2 * i + 1]
        r, iR, iw = G + 6 + 3 * i, 9 * D * k, 3 * D * k
        _mb_copy(vel, 0, lin, iw, 3 * D)
        _mb_cross_c(D, c, r, -1.0, w, iw, vel, 0)         # lin + w × r
        m = 6
        if kind != 1:                                   # world position
            _mb_copy(buf, 0, p0, iw, 3 * D)
            _mb_rot_c(D, R0, iR, c, r, buf, 0)
        if kind == 0:                                   # point: velocity, world axes
            _mb_zero(buf, 3 * D, 3 * D)
            _mb_rot(D, R0, iR, vel, 0, buf, 3 * D)
        elif kind == 1:                                 # frame: (w, v), link axes
            _mb_copy(buf, 0, w, iw, 3 * D)
            _mb_copy(buf, 3 * D, vel, 0, 3 * D)
        else:                                           # world frame: (w, v), world axes
            _mb_zero(buf, 3 * D, 6 * D)
            _mb_rot(D, R0, iR, w, iw, buf, 3 * D)
            _mb_rot(D, R0, iR, vel, 0, buf, 6 * D)
            m = 9
        for j in range(m):
            _mb_emit(D, buf, j * D, out, dout, o + j)
        o += m
    return out, dout, work


@_jit
def mb_load(s, c, values, din):
    """The load entry (see the module docstring): (out, dout)."""
    nl, nv, nq, ns = s[0], s[1], s[2], s[3]
    K = din.shape[1]
    D = 1 + K
    out = np.zeros(nv)
    dout = np.zeros((nv, K))
    R, p = np.zeros(9 * D * nl), np.zeros(3 * D * nl)
    R0, p0 = np.zeros(9 * D * nl), np.zeros(3 * D * nl)
    tau, f = np.zeros(3 * D * nl), np.zeros(3 * D * nl)
    x = np.zeros((nq + 6 * ns) * D)
    _mb_seed(D, nq + 6 * ns, values, din, x)
    _mb_positions(D, s, c, x, R, p, R0, p0)
    G = _MB_LINK * nl
    tl, fl = np.zeros(3 * D), np.zeros(3 * D)
    for i in range(ns):          # each site's wrench in its link's frame, about the origin
        k, kind = s[4 + 4 * nl + 2 * i], s[4 + 4 * nl + 2 * i + 1]
        it = (nq + 6 * i) * D
        if kind == 1:
            _mb_copy(tl, 0, x, it, 3 * D)
            _mb_copy(fl, 0, x, it + 3 * D, 3 * D)
        else:
            _mb_zero(tl, 0, 3 * D)
            _mb_zero(fl, 0, 3 * D)
            _mb_rot_t(D, R0, 9 * D * k, x, it, tl, 0)
            _mb_rot_t(D, R0, 9 * D * k, x, it + 3 * D, fl, 0)
        _mb_cross_c(D, c, G + 6 + 3 * i, 1.0, fl, 0, tl, 0)
        for j in range(3 * D):
            tau[3 * D * k + j] += tl[j]
            f[3 * D * k + j] += fl[j]
    a, u = np.zeros(3), np.zeros(3)
    e = np.zeros(6 * D)
    Rf = np.zeros(3 * D)
    for k in range(nl - 1, -1, -1):
        parent, i0, iw = s[4 + 4 * k], s[4 + 4 * k + 2], 3 * D * k
        _mb_project(D, s, c, k, a, u, tau, iw, f, iw, e, 0)
        for r in range(_mb_dofs(s[4 + 4 * k + 1])):
            _mb_emit(D, e, r * D, out, dout, i0 + r)
        if parent < 0:
            continue
        _mb_carry(D, R, p, k, tau, iw, 3 * D * parent, f, iw, 3 * D * parent, Rf)
    return out, dout


@_jit
def _mb_products(D, s, c, R, p, v, acc, w, lin, L, P, A, F, kept, e):
    """e = Sᵀ (ad_Tᵀ Π + F) = Πᵀ ad_T S + M(q) acc + C(q, v) (nv duals; with acc = 0 the
    velocity products Ṁ v) from the velocities v: the twists and subtree momenta (w, lin, L, P)
    formed here (given: ``kept``, the state entry's work) and the Newton–Euler wrenches F."""
    a, u = np.zeros(3), np.zeros(3)
    if not kept:
        _mb_velocities(D, s, c, R, p, v, w, lin, L, P)
    _mb_bias(D, s, c, R, p, v, acc, w, lin, A, F)
    for k in range(s[0]):
        iw, ia = 3 * D * k, 6 * D * k
        _mb_ad_t(D, w, lin, L, P, iw, F, ia, F, ia + 3 * D)
        _mb_project(D, s, c, k, a, u, F, ia, F, ia + 3 * D, e, s[4 + 4 * k + 2] * D)


@_jit
def _mb_values(x, D, n):
    """The values of the n duals x (n x D)."""
    out = np.zeros(n)
    for i in range(n):
        out[i] = x[i * D]
    return out


@_jit
def _mb_lu(m, A, piv):
    """A = P L U in place (m x m, row-major; partial pivoting, row swaps in piv)."""
    for k in range(m):
        best = k
        for i in range(k + 1, m):
            if abs(A[i * m + k]) > abs(A[best * m + k]):
                best = i
        piv[k] = best
        if best != k:
            for j in range(m):
                A[k * m + j], A[best * m + j] = A[best * m + j], A[k * m + j]
        for i in range(k + 1, m):
            f = A[i * m + k] / A[k * m + k]
            A[i * m + k] = f
            for j in range(k + 1, m):
                A[i * m + j] -= f * A[k * m + j]


@_jit
def _mb_lu_solve(m, A, piv, D, j0, x):
    """x = A⁻¹ x for the columns j0 .. D − 1 of x (m x D) with the factors of _mb_lu."""
    for k in range(m):
        t = piv[k]
        for col in range(j0, D):
            x[k * D + col], x[t * D + col] = x[t * D + col], x[k * D + col]
    for i in range(m):
        for j in range(i):
            a = A[i * m + j]
            for col in range(j0, D):
                x[i * D + col] -= a * x[j * D + col]
    for i in range(m - 1, -1, -1):
        for j in range(i + 1, m):
            a = A[i * m + j]
            for col in range(j0, D):
                x[i * D + col] -= a * x[j * D + col]
        for col in range(j0, D):
            x[i * D + col] /= A[i * m + i]


@_jit
def _mb_pattern(s):
    """The structural nonzeros (i, k) of Ga (m x nv) from the constrained entry's table: (rows,
    columns, count); Ga's inputs are their values in this order."""
    at = 4 + 4 * s[0] + 2 * s[3] + 1
    nnz = s[at]
    rows, cols = np.zeros(nnz, dtype=np.int64), np.zeros(nnz, dtype=np.int64)
    for e in range(nnz):
        rows[e], cols[e] = s[at + 1 + 2 * e], s[at + 2 + 2 * e]
    return rows, cols, nnz


@_jit
def _mb_saddle(D, j0, n, m, lam, run, H, Ga, nz_i, nz_k, nnz, Y, Sc, piv, X, Z, full):
    """The saddle-point system [M Gaᵀ; Ga C] [a; ν] = [X; Z] solved in place (X ← a, Z ← ν)
    for the columns j0 .. D − 1 of X (n x D) and Z (m x D) by the Schur complement: with the
    factors H of M, Y = M⁻¹ Gaᵀ (n x m) and Sc = Ga Y − C (m x m, factored by _mb_lu),
    a' = M⁻¹ X, ν = Sc⁻¹ (Ga a' − Z), a = a' − Y ν (Ga's nonzeros: nz_i, nz_k, nnz; not
    ``full``: ν only, X left at a')."""
    _mb_solve(D, j0, n, lam, run, H, X)
    for i in range(m):
        for col in range(j0, D):
            Z[i * D + col] = -Z[i * D + col]
    for e in range(nnz):
        i, k = nz_i[e], nz_k[e]
        g = Ga[i * n + k]
        for col in range(j0, D):
            Z[i * D + col] += g * X[k * D + col]
    _mb_lu_solve(m, Sc, piv, D, j0, Z)
    if not full:
        return
    for k in range(n):
        for i in range(m):
            y = Y[k * m + i]
            for col in range(j0, D):
                X[k * D + col] -= y * Z[i * D + col]


@_jit
def _mb_saddle_tangents(D, n, m, x, iG, iC, nz_i, nz_k, nnz, a, nu, dm, T, Z):
    """The right-hand sides of a saddle solution's tangents (columns 1 .. D − 1): T −= d(M a)|_a
    (the tangents of dm) + dGaᵀ ν, Z −= dGa a + dC ν, for the solution (a, ν) (numbers) and the
    duals of Ga's nonzeros (nz_i, nz_k, nnz) at x[iG:] and of C's diagonal at x[iC:]."""
    for k in range(n):
        for j in range(1, D):
            T[k * D + j] -= dm[k * D + j]
    for i in range(m):
        for j in range(1, D):
            Z[i * D + j] -= x[iC + i * D + j] * nu[i]
    for e in range(nnz):
        i, k = nz_i[e], nz_k[e]
        g = iG + e * D
        for j in range(1, D):
            T[k * D + j] -= x[g + j] * nu[i]
            Z[i * D + j] -= x[g + j] * a[k]


@_jit
def mb_constrained(s, c, values, din):
    """The constrained entry (see the module docstring): (out, dout)."""
    return mb_constrained_reuse(s, c, values, din, np.zeros(1))


@_jit
def mb_constrained_reuse(s, c, values, din, work):
    """The constrained entry reusing the work of the state entry at the same (q, v) (its tree,
    M's factors, twists and subtree momenta; :func:`_mb_kept`), else computing them: (out,
    dout)."""
    nl, nv, nq, ns = s[0], s[1], s[2], s[3]
    m = s[4 + 4 * nl + 2 * ns]
    nz_i, nz_k, nnz = _mb_pattern(s)
    K = din.shape[1]
    D = 1 + K
    n_in = nq + 2 * nv + nnz + 3 * m
    iF, iG = (nq + nv) * D, (nq + 2 * nv) * D
    iC = iG + nnz * D
    iB, iH = iC + m * D, iC + 2 * m * D
    out = np.zeros(2 * nv + m)
    dout = np.zeros((2 * nv + m, K))
    A, F = np.zeros(6 * D * nl), np.zeros(6 * D * nl)
    x = np.zeros(n_in * D)
    _mb_seed(D, n_in, values, din, x)
    kept = _mb_kept(s, D, work, x)
    if not kept:
        work = np.zeros(_mb_work_size(s, D))
    _, v, R, p, R0, p0, hc, w, lin, L, P, mc, Jc, M = _mb_work(s, D, work)
    if kept:
        lam, run = _mb_lambda(s)
    else:
        lam, run = _mb_tree(D, s, c, x, R, p, R0, p0, mc, hc, Jc, M)
        _mb_copy(v, 0, x, nq * D, nv * D)          # the velocities (and tangents) are inputs
    # values: b = f − Ṁ v for the accelerations' right-hand side
    Rv, pv, vv = _mb_values(R, D, 9 * nl), _mb_values(p, D, 3 * nl), _mb_values(v, D, nv)
    acc_a, nu = np.zeros(nv), np.zeros(m)            # the accelerations and ν = −λ
    _mb_products(1, s, c, Rv, pv, vv, np.zeros(nv), _mb_values(w, D, 3 * nl),
                 _mb_values(lin, D, 3 * nl), _mb_values(L, D, 3 * nl), _mb_values(P, D, 3 * nl),
                 np.zeros(6 * nl), np.zeros(6 * nl), kept, acc_a)
    for k in range(nv):
        acc_a[k] = x[iF + k * D] - acc_a[k]
    Ga, Y, Sc = np.zeros(m * nv), np.zeros(nv * m), np.zeros(m * m)
    piv = np.zeros(m, dtype=np.int64)
    for e in range(nnz):
        i, k = nz_i[e], nz_k[e]
        Ga[i * nv + k] = x[iG + e * D]
        Y[k * m + i] = Ga[i * nv + k]
    _mb_solve(m, 0, nv, lam, run, M, Y)
    for i in range(m):
        Sc[i * m + i] = -x[iC + i * D]
    for e in range(nnz):                # Sc = Ga Y − C
        i, k = nz_i[e], nz_k[e]
        for j in range(m):
            Sc[i * m + j] += Ga[i * nv + k] * Y[k * m + j]
    _mb_lu(m, Sc, piv)
    shift, mu = np.zeros(nv), np.zeros(m)            # the position correction Δv
    for i in range(m):
        nu[i] = x[iB + i * D]
        mu[i] = -x[iH + i * D]
    _mb_saddle(1, 0, nv, m, lam, run, M, Ga, nz_i, nz_k, nnz, Y, Sc, piv, acc_a, nu, True)
    _mb_saddle(1, 0, nv, m, lam, run, M, Ga, nz_i, nz_k, nnz, Y, Sc, piv, shift, mu, True)
    T, Z = np.zeros(nv * D), np.zeros(m * D)
    Tc, Zc = np.zeros(nv * D), np.zeros(m * D)
    if K > 0:           # the saddle system differentiated: the same matrix, new right-hand sides
        dm = np.zeros(nv * D)           # Πᵀ ad_T S + M a + C(q, v): its tangents at fixed a
        _mb_products(D, s, c, R, p, v, acc_a, w, lin, L, P, A, F, kept, dm)
        _mb_copy(T, 0, x, iF, nv * D)
        _mb_copy(Z, 0, x, iB, m * D)
        _mb_saddle_tangents(D, nv, m, x, iG, iC, nz_i, nz_k, nnz, acc_a, nu, dm, T, Z)
        _mb_saddle(D, 1, nv, m, lam, run, M, Ga, nz_i, nz_k, nnz, Y, Sc, piv, T, Z, False)
        w, lin, L, P = (np.zeros(3 * D * nl), np.zeros(3 * D * nl), np.zeros(3 * D * nl),
                        np.zeros(3 * D * nl))       # (the kept work stays as it is)
        _mb_times_m(D, s, c, R, p, shift, w, lin, L, P, dm)
        for i in range(m * D):
            Zc[i] = -x[iH + i]
        _mb_saddle_tangents(D, nv, m, x, iG, iC, nz_i, nz_k, nnz, shift, mu, dm, Tc, Zc)
        _mb_saddle(D, 1, nv, m, lam, run, M, Ga, nz_i, nz_k, nnz, Y, Sc, piv, Tc, Zc, True)
    for k in range(nv):             # ṗ = f − Gaᵀ ν, λ = −ν, Δv
        out[k] = x[iF + k * D]
        out[nv + m + k] = shift[k]
        for j in range(K):
            dout[k, j] = x[iF + k * D + 1 + j]
            dout[nv + m + k, j] = Tc[k * D + 1 + j]
    for e in range(nnz):
        i, k = nz_i[e], nz_k[e]
        g = iG + e * D
        out[k] -= Ga[i * nv + k] * nu[i]
        for j in range(K):
            dout[k, j] -= x[g + 1 + j] * nu[i] + Ga[i * nv + k] * Z[i * D + 1 + j]
    for i in range(m):
        out[nv + i] = -nu[i]
        for j in range(K):
            dout[nv + i, j] = -Z[i * D + 1 + j]
    return out, dout


@_jit
def _mb_position_values(what, s, c, values):
    """The entries without tangents: what = 0 mass, 1 jacobians, 2 poses, 3 momenta."""
    nl, nv, nq, ns = s[0], s[1], s[2], s[3]
    R, p = np.zeros(9 * nl), np.zeros(3 * nl)
    R0, p0 = np.zeros(9 * nl), np.zeros(3 * nl)
    mc, hc, Jc = np.zeros(nl), np.zeros(3 * nl), np.zeros(9 * nl)
    q = np.zeros(nq)
    for i in range(nq):
        q[i] = values[i]
    _mb_positions(1, s, c, q, R, p, R0, p0)
    G = _MB_LINK * nl
    if what == 0 or what == 3:
        M = np.zeros(nv * nv)
        _mb_composites(1, s, c, R, p, mc, hc, Jc)
        _mb_mass(1, s, c, R0, p0, mc, hc, Jc, M)
        if what == 0:
            return M
        out = np.zeros(nv)
        for i in range(nv):
            acc = 0.0
            for j in range(nv):
                acc += M[i * nv + j] * values[nq + j]
            out[i] = acc
        return out
    if what == 1:
        out = np.zeros(3 * nv * ns)
        a, u, A, U, x = np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3)
        for i in range(ns):
            k0, r = s[4 + 4 * nl + 2 * i], G + 6 + 3 * i
            for e in range(3):
                x[e] = (p0[3 * k0 + e] + R0[9 * k0 + 3 * e] * c[r] + R0[9 * k0 + 3 * e + 1] * c[r + 1]
                        + R0[9 * k0 + 3 * e + 2] * c[r + 2])
            k = k0
            while k >= 0:
                i0 = s[4 + 4 * k + 2]
                for sv in range(_mb_dofs(s[4 + 4 * k + 1])):
                    _mb_screw(s, c, k, sv, a, u)
                    for e in range(3):
                        A[e] = R0[9 * k + 3 * e] * a[0] + R0[9 * k + 3 * e + 1] * a[1] + R0[9 * k + 3 * e + 2] * a[2]
                        U[e] = R0[9 * k + 3 * e] * u[0] + R0[9 * k + 3 * e + 1] * u[1] + R0[9 * k + 3 * e + 2] * u[2]
                    for e in range(3):
                        e1, e2 = (e + 1) % 3, (e + 2) % 3
                        out[(3 * i + e) * nv + i0 + sv] = (U[e] + A[e1] * (x[e2] - p0[3 * k + e2])
                                                           - A[e2] * (x[e1] - p0[3 * k + e1]))
                k = s[4 + 4 * k]
        return out
    qw = np.zeros(4 * nl)        # the world quaternion: the parent's times the joint's
    step, par = np.zeros(4), np.zeros(4)
    for k in range(nl):
        parent, kind, co = s[4 + 4 * k], s[4 + 4 * k + 1], s[4 + 4 * k + 3]
        base = _MB_LINK * k
        step[0], step[1], step[2], step[3] = 1.0, 0.0, 0.0, 0.0
        if kind == _MB_ROT:
            h = 0.5 * values[co]
            sh = math.sin(h)
            step[0], step[1], step[2], step[3] = math.cos(h), sh * c[base], sh * c[base + 1], sh * c[base + 2]
        elif kind == _MB_SPH or kind == _MB_FREE:
            iq = co + (3 if kind == _MB_FREE else 0)
            nrm = math.sqrt(values[iq] ** 2 + values[iq + 1] ** 2 + values[iq + 2] ** 2
                            + values[iq + 3] ** 2)
            for e in range(4):
                step[e] = values[iq + e] / nrm
        if parent < 0:
            par[0], par[1], par[2], par[3] = 1.0, 0.0, 0.0, 0.0
        else:
            for e in range(4):
                par[e] = qw[4 * parent + e]
        qw[4 * k] = par[0] * step[0] - par[1] * step[1] - par[2] * step[2] - par[3] * step[3]
        qw[4 * k + 1] = par[0] * step[1] + step[0] * par[1] + par[2] * step[3] - par[3] * step[2]
        qw[4 * k + 2] = par[0] * step[2] + step[0] * par[2] + par[3] * step[1] - par[1] * step[3]
        qw[4 * k + 3] = par[0] * step[3] + step[0] * par[3] + par[1] * step[2] - par[2] * step[1]
    out = np.zeros(7 * ns)
    for i in range(ns):
        k, r = s[4 + 4 * nl + 2 * i], G + 6 + 3 * i
        for e in range(3):
            out[7 * i + e] = (p0[3 * k + e] + R0[9 * k + 3 * e] * c[r] + R0[9 * k + 3 * e + 1] * c[r + 1]
                              + R0[9 * k + 3 * e + 2] * c[r + 2])
        for e in range(4):
            out[7 * i + 3 + e] = qw[4 * k + e]
    return out

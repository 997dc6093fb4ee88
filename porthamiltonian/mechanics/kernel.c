/* Template: compiled once as its own translation unit (porthamiltonian.mechanics.sources.
 * c_object_source: MB_ENTRY defined, the entries external and hidden), cached, and linked into
 * every model library whose generated functions call it (they declare the entries,
 * sources.c_declarations); without MB_ENTRY the entries are static, for inclusion in one unit.
 * kernel.py is the same algorithm in Python (the python and numba back ends) and documents it; a
 * change here is made there too (tests/validation/test_multibody_kernel.py runs both). The
 * entries without tangents (ph_mb_mass, ph_mb_jacobians, ph_mb_poses, ph_mb_momenta) follow it,
 * generated for both templates from one table (porthamiltonian/mechanics/sources.py).
 *
 * The recursive dynamics of a tree of rigid bodies driven by numeric tables (one compiled code for
 * every tree): the links' relative and world poses, composite inertias, the mass matrix by the
 * composite-rigid-body recursion and its sparse L^T D L factorisation (Featherstone, Rigid Body
 * Dynamics Algorithms, 2008, sections 6.2 and 6.5), the velocities v = M^-1 p, the body twists and
 * subtree momenta, the momentum rates Pi_k^T ad_{T_k} S + gravity, and the kinematics of sites
 * (points and frames fixed to links); with closed loops and constraints (ph_mb_constrained) the
 * velocity products by a Newton-Euler pass and the constrained equations by a Schur complement on
 * the factors of M. Every entry point can also propagate K tangent directions
 * (forward mode, the chain rule through the recursion): each quantity is stored as 1 + K doubles,
 * its value then its K derivatives, so that one code serves the value (K = 0, compiled as its own
 * copy with the tangent loops removed) and the Jacobian. The tangent of v is solved implicitly,
 * dv = M^-1 (dp - d(M v)|_v), where d(M v)|_v is the tangent of the momenta at fixed v.
 *
 * Tables (see kernel.py for their layout): s (integers: sizes, per link parent / kind / first
 * velocity / first coordinate, per site link / kind) and c (numbers, the run-time parameters of
 * the tree: per link axis, joint offset, mass, first moment, inertia about the link origin;
 * gravity; the first moment of bodies welded to the world; per site its position in the link).
 */
#if defined(__GNUC__)
#define MB_FLATTEN __attribute__((flatten))
#else
#define MB_FLATTEN
#endif
#ifndef MB_ENTRY
#if defined(__GNUC__)
#define MB_ENTRY static __attribute__((unused))
#else
#define MB_ENTRY static
#endif
#endif
#define MB_INLINE static inline
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC push_options
#pragma GCC optimize ("O2")
#endif

enum { MB_ROT = 0, MB_TRANS = 1, MB_SPH = 2, MB_FREE = 3 };
enum { MB_LINK = 16, MB_STACK = 16384, MB_HEAD = 8 };

typedef struct {
    int nl, nv, nq, ns;
    const int *link;            /* per link: parent (-1: the world), kind, first velocity, first coordinate */
    const int *site;            /* per site: link, kind */
    const double *c;
} mb_tab;

static void mb_read(const int *s, const double *c, mb_tab *t)
{
    t->nl = s[0]; t->nv = s[1]; t->nq = s[2]; t->ns = s[3];
    t->link = s + 4; t->site = s + 4 + 4 * s[0]; t->c = c;
}

static int mb_dofs(int kind) { return kind == MB_SPH ? 3 : kind == MB_FREE ? 6 : 1; }

/* the unit twist (a, u) of velocity s of link k, in the link's frame */
MB_INLINE void mb_screw(const mb_tab *t, int k, int s, double *a, double *u)
{
    const int kind = t->link[4 * k + 1];
    const double *axis = t->c + MB_LINK * k;
    a[0] = a[1] = a[2] = u[0] = u[1] = u[2] = 0.0;
    if (kind == MB_ROT) { a[0] = axis[0]; a[1] = axis[1]; a[2] = axis[2]; }
    else if (kind == MB_TRANS) { u[0] = axis[0]; u[1] = axis[1]; u[2] = axis[2]; }
    else if (s < 3) a[s] = 1.0;
    else u[s - 3] = 1.0;
}

/* --- duals: a value and D - 1 derivatives, contiguous ----------------------------------------- */
MB_INLINE void d_set(int D, double *x, double value)
{
    x[0] = value;
    for (int j = 1; j < D; ++j) x[j] = 0.0;
}
/* x = y */
MB_INLINE void d_copy(int D, double *x, const double *y) { for (int j = 0; j < D; ++j) x[j] = y[j]; }
/* out += alpha x (alpha a number) */
MB_INLINE void d_axpy(int D, double alpha, const double *x, double *out)
{
    for (int j = 0; j < D; ++j) out[j] += alpha * x[j];
}
/* out += a b */
MB_INLINE void d_fma(int D, const double *a, const double *b, double *out)
{
    const double a0 = a[0], b0 = b[0];
    for (int j = 1; j < D; ++j) out[j] += a0 * b[j] + a[j] * b0;
    out[0] += a0 * b0;
}
/* out -= a b */
MB_INLINE void d_fms(int D, const double *a, const double *b, double *out)
{
    const double a0 = a[0], b0 = b[0];
    for (int j = 1; j < D; ++j) out[j] -= a0 * b[j] + a[j] * b0;
    out[0] -= a0 * b0;
}
/* out = a / b */
MB_INLINE void d_div(int D, const double *a, const double *b, double *out)
{
    const double r = a[0] / b[0], inv = 1.0 / b[0];
    for (int j = 1; j < D; ++j) out[j] = (a[j] - r * b[j]) * inv;
    out[0] = r;
}
/* 3-vectors of duals: component i at [i * D] */
MB_INLINE void v_zero(int D, double *x) { for (int j = 0; j < 3 * D; ++j) x[j] = 0.0; }
MB_INLINE void v_const(int D, double *x, const double *v)
{
    for (int i = 0; i < 3; ++i) d_set(D, x + i * D, v[i]);
}
/* out += R v (R: 3x3 duals, row-major) */
MB_INLINE void v_rot(int D, const double *R, const double *v, double *out)
{
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) d_fma(D, R + (3 * i + k) * D, v + k * D, out + i * D);
}
/* out += R^T v */
MB_INLINE void v_rot_t(int D, const double *R, const double *v, double *out)
{
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) d_fma(D, R + (3 * k + i) * D, v + k * D, out + i * D);
}
/* out += R v for a constant v (numbers) */
MB_INLINE void v_rot_c(int D, const double *R, const double *v, double *out)
{
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) d_axpy(D, v[k], R + (3 * i + k) * D, out + i * D);
}
/* out += R^T v for a constant v */
MB_INLINE void v_rot_t_c(int D, const double *R, const double *v, double *out)
{
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) d_axpy(D, v[k], R + (3 * k + i) * D, out + i * D);
}
/* out += a x b */
MB_INLINE void v_cross(int D, const double *a, const double *b, double *out)
{
    for (int i = 0; i < 3; ++i) {
        const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
        d_fma(D, a + i1 * D, b + i2 * D, out + i * D);
        d_fms(D, a + i2 * D, b + i1 * D, out + i * D);
    }
}
/* out += a x b for a constant a (numbers) */
MB_INLINE void v_cross_c(int D, const double *a, const double *b, double *out)
{
    for (int i = 0; i < 3; ++i) {
        const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
        d_axpy(D, a[i1], b + i2 * D, out + i * D);
        d_axpy(D, -a[i2], b + i1 * D, out + i * D);
    }
}
/* out += a . b for a constant a */
MB_INLINE void v_dot_c(int D, const double *a, const double *b, double *out)
{
    for (int i = 0; i < 3; ++i) d_axpy(D, a[i], b + i * D, out);
}
/* out = A B (3x3 duals) */
MB_INLINE void m_mul(int D, const double *A, const double *B, double *out)
{
    for (int j = 0; j < 9 * D; ++j) out[j] = 0.0;
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k)
            for (int l = 0; l < 3; ++l) d_fma(D, A + (3 * i + l) * D, B + (3 * l + k) * D, out + (3 * i + k) * D);
}

/* --- positions ----------------------------------------------------------------------------------- */
/* the rotation of the quaternion q / |q| (Hamilton, w x y z; duals) into R (3x3 duals) */
MB_INLINE void mb_quaternion(int D, const double *q, double *R)
{
    const double *w = q, *x = q + D, *y = q + 2 * D, *z = q + 3 * D;
    double n2[D], e[D];
    d_set(D, n2, 0.0);
    d_fma(D, w, w, n2); d_fma(D, x, x, n2); d_fma(D, y, y, n2); d_fma(D, z, z, n2);
    /* diagonal: w^2 + a^2 - b^2 - c^2 with a the entry's own axis */
    const double *own[3] = {x, y, z};
    for (int i = 0; i < 3; ++i) {
        d_set(D, e, 0.0);
        d_fma(D, w, w, e);
        for (int a = 0; a < 3; ++a)
            if (a == i) d_fma(D, own[a], own[a], e);
            else d_fms(D, own[a], own[a], e);
        d_div(D, e, n2, R + 4 * i * D);
    }
    /* off-diagonal (i, j), k the third axis: 2 (a_i a_j - w a_k) when j follows i cyclically,
     * else 2 (a_i a_j + w a_k): R01 = 2 (xy - wz), R10 = 2 (xy + wz) */
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            if (i == j) continue;
            const int k = 3 - i - j;
            d_set(D, e, 0.0);
            d_fma(D, own[i], own[j], e);
            if ((j - i + 3) % 3 == 1) d_fms(D, w, own[k], e);
            else d_fma(D, w, own[k], e);
            for (int l = 0; l < D; ++l) e[l] *= 2.0;
            d_div(D, e, n2, R + (3 * i + j) * D);
        }
}

/* relative pose (R, p) of every link and its world pose (R0, p0), root to tip; q: the
 * coordinates as duals (nq x D) */
MB_INLINE void mb_positions(int D, const mb_tab *t, const double *q, double *R, double *p,
                            double *R0, double *p0)
{
    for (int k = 0; k < t->nl; ++k) {
        const int parent = t->link[4 * k], kind = t->link[4 * k + 1], c = t->link[4 * k + 3];
        const double *axis = t->c + MB_LINK * k, *origin = axis + 3;
        double *Rk = R + 9 * D * k, *pk = p + 3 * D * k;
        v_const(D, pk, origin);
        if (kind == MB_ROT) {
            const double *qk = q + c * D;
            double cs[D], sn[D];
            const double c0 = cos(qk[0]), s0 = sin(qk[0]);
            cs[0] = c0; sn[0] = s0;
            for (int j = 1; j < D; ++j) { cs[j] = -s0 * qk[j]; sn[j] = c0 * qk[j]; }
            const double skew[9] = {0, -axis[2], axis[1], axis[2], 0, -axis[0], -axis[1], axis[0], 0};
            for (int i = 0; i < 3; ++i)
                for (int l = 0; l < 3; ++l) {
                    double *e = Rk + (3 * i + l) * D;
                    const double aa = axis[i] * axis[l];
                    for (int j = 0; j < D; ++j) e[j] = ((i == l) - aa) * cs[j] + skew[3 * i + l] * sn[j];
                    e[0] += aa;
                }
        } else if (kind == MB_TRANS) {
            for (int i = 0; i < 9; ++i) d_set(D, Rk + i * D, (i % 4) == 0);
            for (int i = 0; i < 3; ++i) d_axpy(D, axis[i], q + c * D, pk + i * D);
        } else if (kind == MB_SPH) {
            mb_quaternion(D, q + c * D, Rk);
        } else {
            mb_quaternion(D, q + (c + 3) * D, Rk);
            for (int i = 0; i < 3; ++i) d_axpy(D, 1.0, q + (c + i) * D, pk + i * D);
        }
        double *R0k = R0 + 9 * D * k, *p0k = p0 + 3 * D * k;
        if (parent < 0) {
            d_copy(9 * D, R0k, Rk);
            d_copy(3 * D, p0k, pk);
        } else {
            m_mul(D, R0 + 9 * D * parent, Rk, R0k);
            d_copy(3 * D, p0k, p0 + 3 * D * parent);
            v_rot(D, R0 + 9 * D * parent, pk, p0k);
        }
    }
}

/* composite mass mc, first moment hc (duals) and rotational inertia Jc (about the link origin,
 * values, 3x3) of every link's subtree, tip to root; Jc only when it is not NULL */
MB_INLINE void mb_composites(int D, const mb_tab *t, const double *R, const double *p, double *mc,
                             double *hc, double *Jc)
{
    for (int k = 0; k < t->nl; ++k) {
        const double *l = t->c + MB_LINK * k;
        mc[k] = l[6];
        v_const(D, hc + 3 * D * k, l + 7);
        if (Jc) {
            const double *J = l + 10;
            double *Jk = Jc + 9 * k;
            Jk[0] = J[0]; Jk[4] = J[1]; Jk[8] = J[2];
            Jk[1] = Jk[3] = J[3]; Jk[2] = Jk[6] = J[4]; Jk[5] = Jk[7] = J[5];
        }
    }
    for (int k = t->nl - 1; k >= 0; --k) {
        const int parent = t->link[4 * k];
        if (parent < 0) continue;
        const double *Rk = R + 9 * D * k, *pk = p + 3 * D * k, m = mc[k];
        double Rh[3 * D];
        v_zero(D, Rh);
        v_rot(D, Rk, hc + 3 * D * k, Rh);
        mc[parent] += m;
        double *hp = hc + 3 * D * parent;
        for (int i = 0; i < 3; ++i) {
            d_axpy(D, 1.0, Rh + i * D, hp + i * D);
            d_axpy(D, m, pk + i * D, hp + i * D);
        }
        if (Jc) {     /* R J R^T + m (|p|^2 1 - p p^T) + 2 (p . Rh) 1 - p Rh^T - Rh p^T (values) */
            const double *J = Jc + 9 * k;
            double RJ[9], P[3], H[3];
            for (int i = 0; i < 3; ++i) { P[i] = pk[i * D]; H[i] = Rh[i * D]; }
            for (int i = 0; i < 3; ++i)
                for (int a = 0; a < 3; ++a) {
                    double s = 0.0;
                    for (int b = 0; b < 3; ++b) s += Rk[(3 * i + b) * D] * J[3 * b + a];
                    RJ[3 * i + a] = s;
                }
            const double p2 = P[0] * P[0] + P[1] * P[1] + P[2] * P[2];
            const double ph = 2.0 * (P[0] * H[0] + P[1] * H[1] + P[2] * H[2]);
            double *Jp = Jc + 9 * parent;
            for (int i = 0; i < 3; ++i)
                for (int a = 0; a < 3; ++a) {
                    double s = 0.0;
                    for (int b = 0; b < 3; ++b) s += RJ[3 * i + b] * Rk[(3 * a + b) * D];
                    Jp[3 * i + a] += s + m * ((i == a) * p2 - P[i] * P[a]) + (i == a) * ph
                                     - P[i] * H[a] - H[i] * P[a];
                }
        }
    }
}

/* the dof-level parent of every velocity (the previous velocity of a multi-velocity joint, else
 * the last velocity of the parent link; -1 at the root) into lam, and into run the first of the
 * contiguous ancestors of each (run[i] = j: lam[m] = m - 1 for j < m <= i), so that the loops over
 * ancestors run along contiguous rows (a chain is one run) */
static void mb_lambda(const mb_tab *t, int *lam, int *run)
{
    for (int k = 0; k < t->nl; ++k) {
        const int parent = t->link[4 * k], i0 = t->link[4 * k + 2], n = mb_dofs(t->link[4 * k + 1]);
        lam[i0] = parent < 0 ? -1 : t->link[4 * parent + 2] + mb_dofs(t->link[4 * parent + 1]) - 1;
        for (int s = 1; s < n; ++s) lam[i0 + s] = i0 + s - 1;
    }
    for (int i = 0; i < t->nv; ++i) run[i] = (lam[i] == i - 1 && i > 0) ? run[i - 1] : i;
}

/* M (nv x nv, row-major, values) by the composite-rigid-body recursion, from the values of the
 * dual arrays R0, p0, hc (stride D): within a joint M = S^T Ic S in its link's frame; for an
 * ancestor's unit twist (a, u) at its origin o the entry is a0 . (tau0 + (p0_k - o) x f0) + u0 . f0
 * with the wrench F = Ic S (torque about p0_k) and the twists (a0, u0) in world axes (S0, nv x 6,
 * a scratch array) */
static void mb_mass(int D, const mb_tab *t, const double *R0, const double *p0, const double *mc,
                    const double *hc, const double *Jc, double *S0, double *M)
{
    const int nv = t->nv;
    memset(M, 0, sizeof(double) * (size_t)nv * nv);   /* zero where two velocities share no path */
    for (int k = 0; k < t->nl; ++k) {          /* the unit twists in world axes (a0, u0) */
        const int i0 = t->link[4 * k + 2], n = mb_dofs(t->link[4 * k + 1]);
        const double *Rk = R0 + 9 * D * k;
        for (int s = 0; s < n; ++s) {
            double a[3], u[3];
            mb_screw(t, k, s, a, u);
            for (int i = 0; i < 3; ++i) {
                S0[6 * (i0 + s) + i] = Rk[3 * i * D] * a[0] + Rk[(3 * i + 1) * D] * a[1] + Rk[(3 * i + 2) * D] * a[2];
                S0[6 * (i0 + s) + 3 + i] = Rk[3 * i * D] * u[0] + Rk[(3 * i + 1) * D] * u[1] + Rk[(3 * i + 2) * D] * u[2];
            }
        }
    }
    for (int k = 0; k < t->nl; ++k) {
        const int kind = t->link[4 * k + 1], i0 = t->link[4 * k + 2], n = mb_dofs(kind);
        const double *J = Jc + 9 * k, m = mc[k], *Rk = R0 + 9 * D * k;
        const double h[3] = {hc[3 * D * k], hc[3 * D * k + D], hc[3 * D * k + 2 * D]};
        const double pk[3] = {p0[3 * D * k], p0[3 * D * k + D], p0[3 * D * k + 2 * D]};
        for (int s = 0; s < n; ++s) {
            double a[3], u[3], tau[3], f[3], tw[3], fw[3];
            mb_screw(t, k, s, a, u);
            for (int i = 0; i < 3; ++i) {
                const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
                tau[i] = J[3 * i] * a[0] + J[3 * i + 1] * a[1] + J[3 * i + 2] * a[2]
                         + h[i1] * u[i2] - h[i2] * u[i1];
                f[i] = m * u[i] + a[i1] * h[i2] - a[i2] * h[i1];
            }
            for (int r = 0; r <= s; ++r) {
                double b[3], w[3];
                mb_screw(t, k, r, b, w);
                const double e = b[0] * tau[0] + b[1] * tau[1] + b[2] * tau[2]
                                 + w[0] * f[0] + w[1] * f[1] + w[2] * f[2];
                M[(i0 + r) * nv + i0 + s] = M[(i0 + s) * nv + i0 + r] = e;
            }
            if (t->link[4 * k] < 0) continue;
            for (int i = 0; i < 3; ++i) {
                tw[i] = Rk[3 * i * D] * tau[0] + Rk[(3 * i + 1) * D] * tau[1] + Rk[(3 * i + 2) * D] * tau[2];
                fw[i] = Rk[3 * i * D] * f[0] + Rk[(3 * i + 1) * D] * f[1] + Rk[(3 * i + 2) * D] * f[2];
            }
            for (int j = t->link[4 * k]; j >= 0; j = t->link[4 * j]) {
                const int j0 = t->link[4 * j + 2], nj = mb_dofs(t->link[4 * j + 1]);
                const double *oj = p0 + 3 * D * j;
                const double d[3] = {pk[0] - oj[0], pk[1] - oj[D], pk[2] - oj[2 * D]};
                double c[3];
                for (int i = 0; i < 3; ++i) {
                    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
                    c[i] = tw[i] + d[i1] * fw[i2] - d[i2] * fw[i1];
                }
                for (int r = 0; r < nj; ++r) {
                    const double *S = S0 + 6 * (j0 + r);
                    const double e = S[0] * c[0] + S[1] * c[1] + S[2] * c[2]
                                     + S[3] * fw[0] + S[4] * fw[1] + S[5] * fw[2];
                    M[(j0 + r) * nv + i0 + s] = M[(i0 + s) * nv + j0 + r] = e;
                }
            }
        }
    }
}

/* M = L^T D L in place (Featherstone's LTDL: no fill-in outside the ancestors) */
static void mb_ltdl(int n, const int *lam, const int *run, double *H)
{
    for (int k = n - 1; k >= 0; --k) {
        double *Hk = H + k * n;
        for (int i = lam[k]; i >= 0; i = lam[i]) {
            const double a = Hk[i] / Hk[k];
            double *Hi = H + i * n;
            for (int j = i; j >= 0; j = lam[run[j]])
                for (int m = j; m >= run[j]; --m) Hi[m] -= a * Hk[m];
            Hk[i] = a;
        }
    }
}

/* x = M^-1 x for the columns j0 .. D - 1 of x (n x D) with the factors of mb_ltdl */
MB_INLINE void mb_solve(int D, int j0, int n, const int *lam, const int *run, const double *H,
                        double *x)
{
    for (int i = n - 1; i >= 0; --i) {                 /* L^T y = x */
        const double *Hi = H + i * n, *xi = x + i * D;
        for (int j = lam[i]; j >= 0; j = lam[run[j]])
            for (int m = j; m >= run[j]; --m)
                for (int c = j0; c < D; ++c) x[m * D + c] -= Hi[m] * xi[c];
    }
    for (int i = 0; i < n; ++i) {                      /* D z = y, then L x = z */
        const double r = 1.0 / H[i * n + i];
        for (int c = j0; c < D; ++c) x[i * D + c] *= r;
    }
    for (int i = 0; i < n; ++i) {
        const double *Hi = H + i * n;
        double *xi = x + i * D;
        for (int j = lam[i]; j >= 0; j = lam[run[j]])
            for (int m = j; m >= run[j]; --m)
                for (int c = j0; c < D; ++c) xi[c] -= Hi[m] * x[m * D + c];
    }
}

/* --- velocities ---------------------------------------------------------------------------------- */
/* a link's wrench (torque T about its origin, force F; its frame; relative pose Rk, pk) added to
 * its parent's: Tp += R T + p x (R F), Fp += R F */
MB_INLINE void mb_carry(int D, const double *Rk, const double *pk, const double *T, const double *F,
                        double *Tp, double *Fp)
{
    double RF[3 * D];
    v_zero(D, RF);
    v_rot(D, Rk, F, RF);
    v_rot(D, Rk, T, Tp);
    v_cross(D, pk, RF, Tp);
    for (int i = 0; i < 3 * D; ++i) Fp[i] += RF[i];
}

/* (L, P) = I_k (x, y): link k's own spatial inertia (about its origin, its frame) times the twist
 * (x, y): L = J x + h x y, P = m y - h x x */
MB_INLINE void mb_inertia(int D, const mb_tab *t, int k, const double *x, const double *y,
                          double *L, double *P)
{
    const double *l = t->c + MB_LINK * k, *J = l + 10, m = l[6];
    const double Jm[9] = {J[0], J[3], J[4], J[3], J[1], J[5], J[4], J[5], J[2]};
    v_zero(D, L);
    v_zero(D, P);
    for (int i = 0; i < 3; ++i)
        for (int a = 0; a < 3; ++a) d_axpy(D, Jm[3 * i + a], x + a * D, L + i * D);
    v_cross_c(D, l + 7, y, L);                           /* h x y */
    for (int i = 0; i < 3; ++i) d_axpy(D, m, y + i * D, P + i * D);
    const double mh[3] = {-l[7], -l[8], -l[9]};          /* x x h = -h x x */
    v_cross_c(D, mh, x, P);
}

/* body twists (w, lin) root to tip and subtree momenta (L, P) tip to root from the velocities v
 * (duals, nv x D) */
MB_INLINE void mb_velocities(int D, const mb_tab *t, const double *R, const double *p,
                             const double *v, double *w, double *lin, double *L, double *P)
{
    for (int k = 0; k < t->nl; ++k) {
        const int parent = t->link[4 * k], kind = t->link[4 * k + 1], i0 = t->link[4 * k + 2];
        double *wk = w + 3 * D * k, *lk = lin + 3 * D * k;
        v_zero(D, wk);
        v_zero(D, lk);
        if (parent >= 0) {
            const double *Rk = R + 9 * D * k, *wp = w + 3 * D * parent;
            double tmp[3 * D];
            d_copy(3 * D, tmp, lin + 3 * D * parent);
            v_cross(D, wp, p + 3 * D * k, tmp);
            v_rot_t(D, Rk, wp, wk);
            v_rot_t(D, Rk, tmp, lk);
        }
        for (int s = 0; s < mb_dofs(kind); ++s) {
            double a[3], u[3];
            mb_screw(t, k, s, a, u);
            for (int i = 0; i < 3; ++i) {
                d_axpy(D, a[i], v + (i0 + s) * D, wk + i * D);
                d_axpy(D, u[i], v + (i0 + s) * D, lk + i * D);
            }
        }
    }
    for (int k = 0; k < t->nl; ++k)                     /* each link's own momentum */
        mb_inertia(D, t, k, w + 3 * D * k, lin + 3 * D * k, L + 3 * D * k, P + 3 * D * k);
    for (int k = t->nl - 1; k >= 0; --k) {              /* carried to the parents */
        const int parent = t->link[4 * k];
        if (parent < 0) continue;
        mb_carry(D, R + 9 * D * k, p + 3 * D * k, L + 3 * D * k, P + 3 * D * k, L + 3 * D * parent,
                 P + 3 * D * parent);
    }
}

/* tau += L x w + P x lin, f += P x w: the wrench ad_T^T Pi of a link with twist T = (w, lin) and
 * subtree momentum Pi = (L, P), so that S^T (ad_T^T Pi) = Pi^T ad_T S = L . (w x a) + P . (w x u +
 * lin x a) for each unit twist S = (a, u) (the triple product) */
MB_INLINE void mb_ad_t(int D, const double *w, const double *lin, const double *L, const double *P,
                       double *tau, double *f)
{
    v_cross(D, L, w, tau);
    v_cross(D, P, lin, tau);
    v_cross(D, P, w, f);
}

/* e = S_k^T W (n duals at e, n the link's velocities): e_r = a . tau + u . f for each unit twist
 * S_r = (a, u) of link k and the wrench W = (tau, f) (3 duals each, the link's frame) */
MB_INLINE void mb_project(int D, const mb_tab *t, int k, const double *tau, const double *f,
                          double *e)
{
    for (int r = 0; r < mb_dofs(t->link[4 * k + 1]); ++r) {
        double a[3], u[3];
        mb_screw(t, k, r, a, u);
        d_set(D, e + r * D, 0.0);
        v_dot_c(D, a, tau, e + r * D);
        v_dot_c(D, u, f, e + r * D);
    }
}

/* e = S^T Pi (nv duals) from the subtree momenta: M v for the velocities behind (L, P) */
MB_INLINE void mb_generalized(int D, const mb_tab *t, const double *L, const double *P, double *e)
{
    for (int k = 0; k < t->nl; ++k)
        mb_project(D, t, k, L + 3 * D * k, P + 3 * D * k, e + t->link[4 * k + 2] * D);
}

/* e = M(q) x as duals for the numbers xv (nv): its value and, at fixed x, its tangents
 * d(M x)|_x through the positions' tangents; y: nv x D of work space */
static void mb_times_m(int D, const mb_tab *t, const double *R, const double *p, const double *xv,
                       double *w, double *lin, double *L, double *P, double *y, double *e)
{
    for (int i = 0; i < t->nv; ++i) d_set(D, y + i * D, xv[i]);
    mb_velocities(D, t, R, p, y, w, lin, L, P);
    mb_generalized(D, t, L, P, e);
}

/* x = M^-1 y in place for the duals y in x (nv x D), H the factors of M: the values by the
 * factors, the tangents implicitly, dx = M^-1 (dy - d(M x)|_x); work: xv (nv), y and e (nv x D) */
static void mb_implicit(int D, const mb_tab *t, const double *R, const double *p, const int *lam,
                        const double *H, double *x, double *w, double *lin, double *L, double *P,
                        double *xv, double *y, double *e)
{
    const int nv = t->nv;
    for (int i = 0; i < nv; ++i) xv[i] = x[i * D];
    mb_solve(1, 0, nv, lam, lam + nv, H, xv);
    if (D > 1) {
        mb_times_m(D, t, R, p, xv, w, lin, L, P, y, e);
        for (int i = 0; i < nv * D; ++i) x[i] -= e[i];
        mb_solve(D, 1, nv, lam, lam + nv, H, x);
    }
    for (int i = 0; i < nv; ++i) x[i * D] = xv[i];
}

/* F = the subtree wrenches of Newton-Euler's inverse dynamics without gravity (Featherstone 2008,
 * section 5.3), S^T F = M(q) acc + C(q, v), at the joint accelerations acc (numbers), from the
 * velocities v and the body twists (w, lin) (duals). Root to tip the spatial accelerations
 * A_k = X_k^T A_parent + S acc + T_k x S v (6 duals per link: angular, then linear), tip to root
 * the wrenches F_k = I_k A_k + T_k x* I_k T_k plus the children's (6 duals per link: torque, then
 * force). */
static void mb_bias(int D, const mb_tab *t, const double *R, const double *p, const double *v,
                    const double *acc, const double *w, const double *lin, double *A, double *F)
{
    const int nl = t->nl;
    for (int k = 0; k < nl; ++k) {
        const int parent = t->link[4 * k], kind = t->link[4 * k + 1], i0 = t->link[4 * k + 2];
        double *Ak = A + 6 * D * k, tmp[3 * D];
        const double *wk = w + 3 * D * k, *lk = lin + 3 * D * k;
        for (int i = 0; i < 6 * D; ++i) Ak[i] = 0.0;
        if (parent >= 0) {            /* R^T alpha_parent, R^T (c_parent + alpha_parent x p) */
            const double *Ap = A + 6 * D * parent;
            d_copy(3 * D, tmp, Ap + 3 * D);
            v_cross(D, Ap, p + 3 * D * k, tmp);
            v_rot_t(D, R + 9 * D * k, Ap, Ak);
            v_rot_t(D, R + 9 * D * k, tmp, Ak + 3 * D);
        }
        for (int s = 0; s < mb_dofs(kind); ++s) {
            double a[3], u[3], ma[3];
            mb_screw(t, k, s, a, u);
            for (int i = 0; i < 3; ++i) {
                Ak[i * D] += acc[i0 + s] * a[i];
                Ak[3 * D + i * D] += acc[i0 + s] * u[i];
            }
            for (int i = 0; i < 3; ++i) ma[i] = -a[i];
            v_zero(D, tmp);
            v_cross_c(D, ma, wk, tmp);                   /* w x a */
            for (int i = 0; i < 3; ++i) d_fma(D, v + (i0 + s) * D, tmp + i * D, Ak + i * D);
            v_zero(D, tmp);
            for (int i = 0; i < 3; ++i) ma[i] = -u[i];
            v_cross_c(D, ma, wk, tmp);                   /* w x u */
            for (int i = 0; i < 3; ++i) ma[i] = -a[i];
            v_cross_c(D, ma, lk, tmp);                   /* lin x a */
            for (int i = 0; i < 3; ++i) d_fma(D, v + (i0 + s) * D, tmp + i * D, Ak + 3 * D + i * D);
        }
    }
    for (int i = 0; i < 6 * D * nl; ++i) F[i] = 0.0;
    for (int k = nl - 1; k >= 0; --k) {
        const int parent = t->link[4 * k];
        const double *wk = w + 3 * D * k, *lk = lin + 3 * D * k;
        double *Fk = F + 6 * D * k, tf[6 * D], Lo[3 * D], Po[3 * D];
        mb_inertia(D, t, k, A + 6 * D * k, A + 6 * D * k + 3 * D, tf, tf + 3 * D);
        mb_inertia(D, t, k, wk, lk, Lo, Po);
        v_cross(D, wk, Lo, tf);
        v_cross(D, lk, Po, tf);
        v_cross(D, wk, Po, tf + 3 * D);
        for (int i = 0; i < 6 * D; ++i) Fk[i] += tf[i];
        if (parent < 0) continue;
        double *Fp = F + 6 * D * parent;
        mb_carry(D, R + 9 * D * k, p + 3 * D * k, Fk, Fk + 3 * D, Fp, Fp + 3 * D);
    }
}

/* e = S^T (ad_T^T Pi + F) = Pi^T ad_T S + M(q) acc + C(q, v) (nv duals; with acc = 0 the velocity
 * products Mdot v) from the velocities v: the twists and subtree momenta (w, lin, L, P) formed
 * here (given: kept, the state entry's work) and the Newton-Euler wrenches F */
static void mb_products(int D, const mb_tab *t, const double *R, const double *p, const double *v,
                        const double *acc, double *w, double *lin, double *L, double *P, double *A,
                        double *F, int kept, double *e)
{
    if (!kept) mb_velocities(D, t, R, p, v, w, lin, L, P);
    mb_bias(D, t, R, p, v, acc, w, lin, A, F);
    for (int k = 0; k < t->nl; ++k) {
        const int i = 3 * D * k;
        double *Fk = F + 6 * D * k;
        mb_ad_t(D, w + i, lin + i, L + i, P + i, Fk, Fk + 3 * D);
        mb_project(D, t, k, Fk, Fk + 3 * D, e + t->link[4 * k + 2] * D);
    }
}

/* out = the values of the n duals x (n x D) */
MB_INLINE void mb_values(int D, int n, const double *x, double *out)
{
    for (int i = 0; i < n; ++i) out[i] = x[i * D];
}

/* A = P L U in place (m x m, row-major; partial pivoting, row swaps in piv) */
static void mb_lu(int m, double *A, int *piv)
{
    for (int k = 0; k < m; ++k) {
        int best = k;
        for (int i = k + 1; i < m; ++i)
            if (fabs(A[i * m + k]) > fabs(A[best * m + k])) best = i;
        piv[k] = best;
        if (best != k)
            for (int j = 0; j < m; ++j) {
                const double tmp = A[k * m + j];
                A[k * m + j] = A[best * m + j];
                A[best * m + j] = tmp;
            }
        for (int i = k + 1; i < m; ++i) {
            const double f = A[i * m + k] / A[k * m + k];
            A[i * m + k] = f;
            for (int j = k + 1; j < m; ++j) A[i * m + j] -= f * A[k * m + j];
        }
    }
}

/* x = A^-1 x for the columns j0 .. D - 1 of x (m x D) with the factors of mb_lu */
static void mb_lu_solve(int m, const double *A, const int *piv, int D, int j0, double *x)
{
    for (int k = 0; k < m; ++k)
        for (int col = j0; col < D; ++col) {
            const double tmp = x[k * D + col];
            x[k * D + col] = x[piv[k] * D + col];
            x[piv[k] * D + col] = tmp;
        }
    for (int i = 0; i < m; ++i)
        for (int j = 0; j < i; ++j) {
            const double a = A[i * m + j];
            for (int col = j0; col < D; ++col) x[i * D + col] -= a * x[j * D + col];
        }
    for (int i = m - 1; i >= 0; --i) {
        for (int j = i + 1; j < m; ++j) {
            const double a = A[i * m + j];
            for (int col = j0; col < D; ++col) x[i * D + col] -= a * x[j * D + col];
        }
        for (int col = j0; col < D; ++col) x[i * D + col] /= A[i * m + i];
    }
}

/* The saddle-point system [M Ga^T; Ga C] [a; nu] = [X; Z] solved in place (X <- a, Z <- nu) for the
 * columns j0 .. D - 1 of X (n x D) and Z (m x D) by the Schur complement: with the factors H of M,
 * Y = M^-1 Ga^T (n x m) and Sc = Ga Y - C (m x m, factored by mb_lu), a' = M^-1 X,
 * nu = Sc^-1 (Ga a' - Z), a = a' - Y nu (Ga's structural nonzeros: the nnz (row, column) pairs nz;
 * not full: nu only, X left at a') */
static void mb_saddle(int D, int j0, int n, int m, const int *lam, const double *H,
                      const double *Ga, const int *nz, int nnz, const double *Y, const double *Sc,
                      const int *piv, double *X, double *Z, int full)
{
    mb_solve(D, j0, n, lam, lam + n, H, X);
    for (int i = 0; i < m; ++i)
        for (int col = j0; col < D; ++col) Z[i * D + col] = -Z[i * D + col];
    for (int e = 0; e < nnz; ++e) {
        const int i = nz[2 * e], k = nz[2 * e + 1];
        const double g = Ga[i * n + k];
        for (int col = j0; col < D; ++col) Z[i * D + col] += g * X[k * D + col];
    }
    mb_lu_solve(m, Sc, piv, D, j0, Z);
    if (!full) return;
    for (int k = 0; k < n; ++k)
        for (int i = 0; i < m; ++i) {
            const double y = Y[k * m + i];
            for (int col = j0; col < D; ++col) X[k * D + col] -= y * Z[i * D + col];
        }
}

/* The right-hand sides of a saddle solution's tangents (columns 1 .. D - 1): T -= d(M a)|_a (the
 * tangents of dm) + dGa^T nu, Z -= dGa a + dC nu, for the solution (a, nu) (numbers) and the duals
 * of Ga's nonzeros (xG, in the order of the pairs nz) and of C's diagonal (xC) */
static void mb_saddle_tangents(int D, int n, int m, const double *xG, const double *xC,
                               const int *nz, int nnz, const double *a, const double *nu,
                               const double *dm, double *T, double *Z)
{
    for (int k = 0; k < n; ++k)
        for (int j = 1; j < D; ++j) T[k * D + j] -= dm[k * D + j];
    for (int i = 0; i < m; ++i)
        for (int j = 1; j < D; ++j) Z[i * D + j] -= xC[i * D + j] * nu[i];
    for (int e = 0; e < nnz; ++e) {
        const int i = nz[2 * e], k = nz[2 * e + 1];
        const double *g = xG + e * D;
        for (int j = 1; j < D; ++j) {
            T[k * D + j] -= g[j] * nu[i];
            Z[i * D + j] -= g[j] * a[k];
        }
    }
}

/* The tree at the duals x = (q, ...): poses, composites and M factored in place (values; lam: the
 * parents and runs of mb_lambda; S0: 6 nv of work space) */
static void mb_tree(int D, const mb_tab *t, const double *x, double *R, double *p, double *R0,
                    double *p0, double *mc, double *hc, double *Jc, double *S0, double *M, int *lam)
{
    mb_positions(D, t, x, R, p, R0, p0);
    mb_composites(D, t, R, p, mc, hc, Jc);
    mb_mass(D, t, R0, p0, mc, hc, Jc, S0, M);           /* values only */
    mb_lambda(t, lam, lam + t->nv);
    mb_ltdl(t->nv, lam, lam + t->nv, M);
}

/* --- entry points -------------------------------------------------------------------------------- */
/* a dual array x (n x D) from values in[0..n) and tangents din (n x K, row-major; NULL: none) */
MB_INLINE void mb_seed(int D, int n, const double *in, const double *din, double *x)
{
    for (int i = 0; i < n; ++i) {
        x[i * D] = in[i];
        for (int j = 1; j < D; ++j) x[i * D + j] = din[i * (D - 1) + j - 1];
    }
}

/* out[i] and dout[i, :] (m x K) from the dual x */
MB_INLINE void mb_emit(int D, const double *x, double *out, double *dout)
{
    out[0] = x[0];
    for (int j = 1; j < D; ++j) dout[j - 1] = x[j];
}

/* The state entry's work, kept for the constrained entry (ph_mb_state_keep,
 * ph_mb_constrained_reuse): ws[0] = D (the header: 8 doubles, so that the arrays keep the
 * buffer's alignment), then the duals R, p, R0, p0, g (gravity in the links' frames), hc, w,
 * lin, L, P, the values mc, Jc, M (factored) and the duals x (q, p) and v */
typedef struct { double *R, *p, *R0, *p0, *g, *hc, *w, *lin, *L, *P, *mc, *Jc, *M, *x, *v; } mb_work;

static size_t mb_work_size(const mb_tab *t, int D)
{
    return MB_HEAD + (size_t)D * (size_t)(t->nq + 2 * t->nv + 42 * t->nl) + 10 * (size_t)t->nl
           + (size_t)t->nv * (size_t)t->nv;
}

static void mb_work_views(const mb_tab *t, int D, double *ws, mb_work *k)
{
    const int nl = t->nl, nv = t->nv;
    k->R = ws + MB_HEAD; k->p = k->R + 9 * D * nl; k->R0 = k->p + 3 * D * nl;
    k->p0 = k->R0 + 9 * D * nl; k->g = k->p0 + 3 * D * nl; k->hc = k->g + 3 * D * nl;
    k->w = k->hc + 3 * D * nl; k->lin = k->w + 3 * D * nl; k->L = k->lin + 3 * D * nl;
    k->P = k->L + 3 * D * nl; k->mc = k->P + 3 * D * nl; k->Jc = k->mc + nl; k->M = k->Jc + 9 * nl;
    k->x = k->M + nv * nv; k->v = k->x + (t->nq + nv) * D;
}

/* whether ws is a state entry's work at the duals of (q, v) that begin x (values and tangents
 * equal): then the constrained entry reuses its tree, twists and subtree momenta */
static int mb_kept(const mb_tab *t, int D, const double *ws, const double *x)
{
    const int nq = t->nq, nv = t->nv;
    if (ws == NULL || ws[0] != D) return 0;
    mb_work kw;
    mb_work_views(t, D, (double *)ws, &kw);
    for (int i = 0; i < nq * D; ++i)
        if (kw.x[i] != x[i]) return 0;
    for (int i = 0; i < nv * D; ++i)
        if (kw.v[i] != x[nq * D + i]) return 0;
    return 1;
}

static size_t mb_state_size(const mb_tab *t, int D)
{
    return mb_work_size(t, D) + (size_t)D + 7 * (size_t)t->nv + 2 * (size_t)t->nv * D;
}

/* the state entry (ph_mb_state) in ws (mb_state_size: its work, mb_work, first) */
MB_INLINE void mb_state_run(int D, const mb_tab *t, const double *in, const double *din,
                            double *out, double *dout, double *ws, int *lam)
{
    const int nl = t->nl, nv = t->nv, nq = t->nq, K = D - 1;
    mb_work kw;
    mb_work_views(t, D, ws, &kw);
    ws[0] = D;
    double *R = kw.R, *p = kw.p, *R0 = kw.R0, *p0 = kw.p0, *g = kw.g, *hc = kw.hc, *w = kw.w;
    double *lin = kw.lin, *L = kw.L, *P = kw.P, *mc = kw.mc, *Jc = kw.Jc, *M = kw.M, *x = kw.x;
    double *v = kw.v;
    double *V = ws + mb_work_size(t, D), *S0 = V + D, *xv = S0 + 6 * nv, *y = xv + nv;
    double *ev = y + nv * D;
    mb_seed(D, nq + nv, in, din, x);
    mb_tree(D, t, x, R, p, R0, p0, mc, hc, Jc, S0, M, lam);
    d_copy(nv * D, v, x + nq * D);
    mb_implicit(D, t, R, p, lam, M, v, w, lin, L, P, xv, y, ev);
    mb_velocities(D, t, R, p, v, w, lin, L, P);
    const double *G = t->c + MB_LINK * nl;
    for (int k = 0; k < nl; ++k) {                      /* gravity in each link's frame */
        const int parent = t->link[4 * k];
        double *gk = g + 3 * D * k;
        v_zero(D, gk);
        if (parent < 0) v_rot_t_c(D, R + 9 * D * k, G, gk);
        else v_rot_t(D, R + 9 * D * k, g + 3 * D * parent, gk);
    }
    int o = 0;
    for (int i = 0; i < nv; ++i) mb_emit(D, v + i * D, out + o + i, dout + (o + i) * K);
    o += nv;
    for (int k = 0; k < nl; ++k) {        /* S^T (ad_T^T Pi + (hc x g, mc g)) */
        const int i0 = t->link[4 * k + 2], n = mb_dofs(t->link[4 * k + 1]), i = 3 * D * k;
        double tau[3 * D], f[3 * D], e[6 * D];
        v_zero(D, tau);
        v_cross(D, hc + i, g + i, tau);
        for (int j = 0; j < 3 * D; ++j) f[j] = mc[k] * g[i + j];
        mb_ad_t(D, w + i, lin + i, L + i, P + i, tau, f);
        mb_project(D, t, k, tau, f, e);
        for (int r = 0; r < n; ++r) mb_emit(D, e + r * D, out + o + i0 + r, dout + (o + i0 + r) * K);
    }
    o += nv;
    /* V = -g . (first moment of the bodies welded to the world + of every root's subtree) */
    const double *SF = G + 3;
    d_set(D, V, -(G[0] * SF[0] + G[1] * SF[1] + G[2] * SF[2]));
    for (int k = 0; k < nl; ++k) {
        if (t->link[4 * k] >= 0) continue;
        double first[3 * D];
        v_zero(D, first);
        v_rot(D, R0 + 9 * D * k, hc + 3 * D * k, first);
        for (int i = 0; i < 3; ++i) d_axpy(D, mc[k], p0 + 3 * D * k + i * D, first + i * D);
        for (int i = 0; i < 3; ++i) d_axpy(D, -G[i], first + i * D, V);
    }
    mb_emit(D, V, out + o, dout + o * K);
    o += 1;
    for (int i = 0; i < t->ns; ++i) {                   /* sites */
        const int k = t->site[2 * i], kind = t->site[2 * i + 1];
        const double *r = G + 6 + 3 * i, *R0k = R0 + 9 * D * k;
        const double *wk = w + 3 * D * k, *lk = lin + 3 * D * k;
        double vel[3 * D], buf[9 * D];
        d_copy(3 * D, vel, lk);
        double mr[3] = {-r[0], -r[1], -r[2]};
        v_cross_c(D, mr, wk, vel);                      /* lin + w x r */
        int m = 0;
        if (kind != 1) {                                /* world position */
            d_copy(3 * D, buf, p0 + 3 * D * k);
            v_rot_c(D, R0k, r, buf);
            m = 3;
        }
        if (kind == 0) {                                /* point: velocity, world axes */
            v_zero(D, buf + 3 * D);
            v_rot(D, R0k, vel, buf + 3 * D);
            m = 6;
        } else if (kind == 1) {                         /* frame: (w, v), link axes */
            d_copy(3 * D, buf, wk);
            d_copy(3 * D, buf + 3 * D, vel);
            m = 6;
        } else {                                        /* world frame: (w, v), world axes */
            v_zero(D, buf + 3 * D);
            v_rot(D, R0k, wk, buf + 3 * D);
            v_zero(D, buf + 6 * D);
            v_rot(D, R0k, vel, buf + 6 * D);
            m = 9;
        }
        for (int e = 0; e < m; ++e) mb_emit(D, buf + e * D, out + o + e, dout + (o + e) * K);
        o += m;
    }
}

static MB_FLATTEN void mb_state_value(const mb_tab *t, const double *in, double *out, double *ws,
                                     int *lam)
{
    mb_state_run(1, t, in, NULL, out, NULL, ws, lam);
}

static void mb_state_tangent(int D, const mb_tab *t, const double *in, const double *din,
                             double *out, double *dout, double *ws, int *lam)
{
    mb_state_run(D, t, in, din, out, dout, ws, lam);
}

/* The state entry: in = (q, p); out = (v, the momentum rates without port loads, V, then per
 * site: a point's world position and velocity (6), a frame's twist (w, v) in its link's axes (6),
 * a world frame's position, angular velocity and velocity in world axes (9)); with K > 0 also
 * dout = d out / d in . din (m x K) for din (nq + nv) x K. */
MB_ENTRY void ph_mb_state(const int *s, const double *c, const double *in, double *out, int K,
                        const double *din, double *dout)
{
    mb_tab t;
    mb_read(s, c, &t);
    int lam[t.nv > 0 ? 2 * t.nv : 1];      /* the parents and the runs of mb_lambda */
    const size_t size = mb_state_size(&t, 1 + K);
    if (K == 0 && size <= MB_STACK) {
        double ws[size];
        mb_state_value(&t, in, out, ws, lam);
        return;
    }
    double *ws = malloc(sizeof(double) * size);
    if (ws == NULL) abort();
    if (K == 0) mb_state_value(&t, in, out, ws, lam);
    else mb_state_tangent(1 + K, &t, in, din, out, dout, ws, lam);
    free(ws);
}

/* ph_mb_state, its work (mb_work) kept in *work for ph_mb_constrained_reuse: the caller frees it */
MB_ENTRY void ph_mb_state_keep(const int *s, const double *c, const double *in, double *out, int K,
                             const double *din, double *dout, double **work)
{
    mb_tab t;
    mb_read(s, c, &t);
    int lam[t.nv > 0 ? 2 * t.nv : 1];
    double *ws = malloc(sizeof(double) * mb_state_size(&t, 1 + K));
    if (ws == NULL) abort();
    if (K == 0) mb_state_value(&t, in, out, ws, lam);
    else mb_state_tangent(1 + K, &t, in, din, out, dout, ws, lam);
    *work = ws;
}

MB_INLINE void mb_load_run(int D, const mb_tab *t, const double *in, const double *din,
                           double *out, double *dout, double *ws)
{
    const int nl = t->nl, nq = t->nq, K = D - 1;
    double *R = ws, *p = R + 9 * D * nl, *R0 = p + 3 * D * nl, *p0 = R0 + 9 * D * nl;
    double *tau = p0 + 3 * D * nl, *f = tau + 3 * D * nl, *x = f + 3 * D * nl;
    const int n_in = nq + 6 * t->ns;
    mb_seed(D, n_in, in, din, x);
    mb_positions(D, t, x, R, p, R0, p0);
    for (int i = 0; i < 3 * D * nl; ++i) tau[i] = f[i] = 0.0;
    const double *r0 = t->c + MB_LINK * nl + 6;
    for (int i = 0; i < t->ns; ++i) {    /* each site's wrench in its link's frame, about the origin */
        const int k = t->site[2 * i], kind = t->site[2 * i + 1];
        const double *tw = x + (nq + 6 * i) * D, *fw = tw + 3 * D, *r = r0 + 3 * i;
        double tl[3 * D], fl[3 * D];
        if (kind == 1) { d_copy(3 * D, tl, tw); d_copy(3 * D, fl, fw); }
        else {
            v_zero(D, tl); v_zero(D, fl);
            v_rot_t(D, R0 + 9 * D * k, tw, tl);
            v_rot_t(D, R0 + 9 * D * k, fw, fl);
        }
        v_cross_c(D, r, fl, tl);
        for (int e = 0; e < 3 * D; ++e) { tau[3 * D * k + e] += tl[e]; f[3 * D * k + e] += fl[e]; }
    }
    for (int k = nl - 1; k >= 0; --k) {
        const int parent = t->link[4 * k], i0 = t->link[4 * k + 2], n = mb_dofs(t->link[4 * k + 1]);
        const double *tk = tau + 3 * D * k, *fk = f + 3 * D * k;
        double e[6 * D];
        mb_project(D, t, k, tk, fk, e);
        for (int r = 0; r < n; ++r) mb_emit(D, e + r * D, out + i0 + r, dout + (i0 + r) * K);
        if (parent < 0) continue;
        mb_carry(D, R + 9 * D * k, p + 3 * D * k, tk, fk, tau + 3 * D * parent, f + 3 * D * parent);
    }
}

static MB_FLATTEN void mb_load_value(const mb_tab *t, const double *in, double *out, double *ws)
{
    mb_load_run(1, t, in, NULL, out, NULL, ws);
}

static void mb_load_tangent(int D, const mb_tab *t, const double *in, const double *din,
                            double *out, double *dout, double *ws)
{
    mb_load_run(D, t, in, din, out, dout, ws);
}

/* The load entry: in = (q, per site its wrench (torque, force) about the site: world axes, or
 * the link's axes for a frame (site kind 1)); out = the generalized forces (nv); with K > 0
 * dout as for ph_mb_state. */
MB_ENTRY void ph_mb_load(const int *s, const double *c, const double *in, double *out, int K,
                       const double *din, double *dout)
{
    mb_tab t;
    mb_read(s, c, &t);
    const int D = 1 + K;
    const size_t size = (size_t)t.nl * 30 * D + (size_t)(t.nq + 6 * t.ns) * D;
    if (K == 0 && size <= MB_STACK) {
        double ws[size];
        mb_load_value(&t, in, out, ws);
        return;
    }
    double *ws = malloc(sizeof(double) * size);
    if (ws == NULL) abort();
    if (K == 0) mb_load_value(&t, in, out, ws);
    else mb_load_tangent(D, &t, in, din, out, dout, ws);
    free(ws);
}

/* The constrained entry: in = (q, v, f (the momentum rates with the ports' loads), Ga = S G (its
 * structural nonzeros), C = 1 - S (m), r = -S (Gdot v + gamma G v) (m), h = S phi (m)); the table
 * ends with m, the count nnz of Ga's structural nonzeros and their (row, column) pairs; out = (pdot = f - Ga^T nu, lambda = -nu, the position correction dv) of
 * the saddle-point systems [M Ga^T; Ga C] [a; nu] = [f - Mdot v; r] and [M Ga^T; Ga C] [dv; mu] =
 * [0; -h], solved by the Schur complement on the factors of M; their tangents by implicit
 * differentiation (the same systems with the differentiated right-hand sides). */
MB_INLINE void mb_constrained_run(int D, const int *s, const double *c, const double *in,
                                  double *out, const double *din, double *dout, const double *kept)
{
    mb_tab t;
    mb_read(s, c, &t);
    const int nl = t.nl, nv = t.nv, nq = t.nq, m = s[4 + 4 * nl + 2 * t.ns], K = D - 1;
    const int nnz = s[5 + 4 * nl + 2 * t.ns], *nz = s + 6 + 4 * nl + 2 * t.ns;
    const int n_in = nq + 2 * nv + nnz + 3 * m;
    const size_t size = (size_t)nl * 24 * D + (size_t)nl * 36 + (size_t)nv * 10 + (size_t)n_in * D
                        + (size_t)nv * 4 * D + (size_t)m * (2 * nv + m + 2) + (size_t)m * 2 * D;
    double *ws = malloc(sizeof(double) * size), *own = NULL;
    int *iw = malloc(sizeof(int) * (size_t)(2 * nv + m + 1));
    if (ws == NULL || iw == NULL) abort();
    double *A = ws, *F = A + 6 * D * nl, *w2 = F + 6 * D * nl, *lin2 = w2 + 3 * D * nl;
    double *L2 = lin2 + 3 * D * nl, *P2 = L2 + 3 * D * nl, *S0 = P2 + 3 * D * nl, *x = S0 + 6 * nv;
    double *y = x + n_in * D, *T = y + nv * D, *Tc = T + nv * D, *dm = Tc + nv * D;
    double *acc = dm + nv * D, *shift = acc + nv, *zero = shift + nv, *vv = zero + nv;
    double *Rv = vv + nv, *pv = Rv + 9 * nl, *wv = pv + 3 * nl, *lv = wv + 3 * nl, *Lv = lv + 3 * nl;
    double *Pv = Lv + 3 * nl, *Av = Pv + 3 * nl, *Fv = Av + 6 * nl;
    double *Ga = Fv + 6 * nl, *Y = Ga + m * nv, *Sc = Y + nv * m, *nu = Sc + m * m, *mu = nu + m;
    double *Z = mu + m, *Zc = Z + m * D;
    int *lam = iw, *piv = iw + 2 * nv;
    const double *xF = x + (nq + nv) * D, *xG = x + (nq + 2 * nv) * D, *xC = xG + nnz * D;
    const double *xB = xC + m * D, *xH = xC + 2 * m * D;
    mb_seed(D, n_in, in, din, x);
    const int reuse = mb_kept(&t, D, kept, x);
    mb_work kw;
    if (reuse) {
        mb_work_views(&t, D, (double *)kept, &kw);       /* read only */
        mb_lambda(&t, lam, lam + nv);
    } else {
        own = malloc(sizeof(double) * mb_work_size(&t, D));
        if (own == NULL) abort();
        mb_work_views(&t, D, own, &kw);
        mb_tree(D, &t, x, kw.R, kw.p, kw.R0, kw.p0, kw.mc, kw.hc, kw.Jc, S0, kw.M, lam);
        d_copy(nv * D, kw.v, x + nq * D);      /* the velocities (and tangents) are inputs */
    }
    const double *R = kw.R, *p = kw.p, *v = kw.v, *M = kw.M;
    /* values: b = f - Mdot v for the accelerations' right-hand side */
    mb_values(D, 9 * nl, R, Rv);
    mb_values(D, 3 * nl, p, pv);
    mb_values(D, nv, v, vv);
    mb_values(D, 3 * nl, kw.w, wv);
    mb_values(D, 3 * nl, kw.lin, lv);
    mb_values(D, 3 * nl, kw.L, Lv);
    mb_values(D, 3 * nl, kw.P, Pv);
    for (int k = 0; k < nv; ++k) zero[k] = 0.0;
    mb_products(1, &t, Rv, pv, vv, zero, wv, lv, Lv, Pv, Av, Fv, reuse, acc);
    for (int k = 0; k < nv; ++k) acc[k] = xF[k * D] - acc[k];
    for (int i = 0; i < m * nv; ++i) Y[i] = Ga[i] = 0.0;
    for (int z = 0; z < nnz; ++z) {
        const int i = nz[2 * z], k = nz[2 * z + 1];
        Y[k * m + i] = Ga[i * nv + k] = xG[z * D];
    }
    mb_solve(m, 0, nv, lam, lam + nv, M, Y);
    for (int i = 0; i < m; ++i)
        for (int j = 0; j < m; ++j) Sc[i * m + j] = i == j ? -xC[i * D] : 0.0;
    for (int z = 0; z < nnz; ++z) {       /* Sc = Ga Y - C */
        const int i = nz[2 * z], k = nz[2 * z + 1];
        for (int j = 0; j < m; ++j) Sc[i * m + j] += Ga[i * nv + k] * Y[k * m + j];
    }
    mb_lu(m, Sc, piv);
    for (int k = 0; k < nv; ++k) shift[k] = 0.0;
    for (int i = 0; i < m; ++i) { nu[i] = xB[i * D]; mu[i] = -xH[i * D]; }
    mb_saddle(1, 0, nv, m, lam, M, Ga, nz, nnz, Y, Sc, piv, acc, nu, 1);
    mb_saddle(1, 0, nv, m, lam, M, Ga, nz, nnz, Y, Sc, piv, shift, mu, 1);
    if (K > 0) {        /* the saddle systems differentiated: the same matrix, new right-hand sides */
        mb_products(D, &t, R, p, v, acc, kw.w, kw.lin, kw.L, kw.P, A, F, reuse, dm);
        d_copy(nv * D, T, xF);
        d_copy(m * D, Z, xB);
        mb_saddle_tangents(D, nv, m, xG, xC, nz, nnz, acc, nu, dm, T, Z);
        mb_saddle(D, 1, nv, m, lam, M, Ga, nz, nnz, Y, Sc, piv, T, Z, 0);
        mb_times_m(D, &t, R, p, shift, w2, lin2, L2, P2, y, dm);   /* (the kept work stays) */
        for (int i = 0; i < nv * D; ++i) Tc[i] = 0.0;
        for (int i = 0; i < m * D; ++i) Zc[i] = -xH[i];
        mb_saddle_tangents(D, nv, m, xG, xC, nz, nnz, shift, mu, dm, Tc, Zc);
        mb_saddle(D, 1, nv, m, lam, M, Ga, nz, nnz, Y, Sc, piv, Tc, Zc, 1);
    }
    for (int k = 0; k < nv; ++k) {        /* pdot = f - Ga^T nu, lambda = -nu, dv */
        out[k] = xF[k * D];
        out[nv + m + k] = shift[k];
        for (int j = 0; j < K; ++j) {
            dout[k * K + j] = xF[k * D + 1 + j];
            dout[(nv + m + k) * K + j] = Tc[k * D + 1 + j];
        }
    }
    for (int z = 0; z < nnz; ++z) {
        const int i = nz[2 * z], k = nz[2 * z + 1];
        const double *g = xG + z * D;
        out[k] -= Ga[i * nv + k] * nu[i];
        for (int j = 0; j < K; ++j) dout[k * K + j] -= g[1 + j] * nu[i] + Ga[i * nv + k] * Z[i * D + 1 + j];
    }
    for (int i = 0; i < m; ++i) {
        out[nv + i] = -nu[i];
        for (int j = 0; j < K; ++j) dout[(nv + i) * K + j] = -Z[i * D + 1 + j];
    }
    free(iw);
    free(own);
    free(ws);
}

static void mb_constrained_value(const int *s, const double *c, const double *in, double *out,
                                 const double *kept)
{
    mb_constrained_run(1, s, c, in, out, NULL, NULL, kept);
}

static void mb_constrained_tangent(int D, const int *s, const double *c, const double *in,
                                   double *out, const double *din, double *dout, const double *kept)
{
    mb_constrained_run(D, s, c, in, out, din, dout, kept);
}

MB_ENTRY void ph_mb_constrained(const int *s, const double *c, const double *in, double *out,
                                int K, const double *din, double *dout)
{
    if (K == 0) mb_constrained_value(s, c, in, out, NULL);
    else mb_constrained_tangent(1 + K, s, c, in, out, din, dout, NULL);
}

/* ph_mb_constrained reusing the work of ph_mb_state_keep at the same (q, v) (mb_kept; else
 * computing it) */
MB_ENTRY void ph_mb_constrained_reuse(const int *s, const double *c, const double *in, double *out,
                                      int K, const double *din, double *dout, const double *work)
{
    if (K == 0) mb_constrained_value(s, c, in, out, work);
    else mb_constrained_tangent(1 + K, s, c, in, out, din, dout, work);
}

/* Position-level values (no tangents): what = 0: the mass matrix M(q) (nv x nv, row-major);
 * 1: per site the world Jacobian of its velocity (3 x nv, row-major); 2: per site its world
 * position and the unit quaternion (w, x, y, z) of its link's axes (7); 3: M(q) v for
 * in = (q, v) (nv). */
static void mb_positions_entry(int what, const int *s, const double *c, const double *in,
                               double *out)
{
    mb_tab t;
    mb_read(s, c, &t);
    const int nl = t.nl, nv = t.nv;
    double *ws = malloc(sizeof(double) * ((size_t)nl * 40 + (size_t)nv * (nv + 6) + t.nq + 1));
    if (ws == NULL) abort();
    double *R = ws, *p = R + 9 * nl, *R0 = p + 3 * nl, *p0 = R0 + 9 * nl, *hc = p0 + 3 * nl;
    double *mc = hc + 3 * nl, *Jc = mc + nl, *M = Jc + 9 * nl, *S0 = M + nv * nv;
    mb_positions(1, &t, in, R, p, R0, p0);
    if (what == 0 || what == 3) {
        mb_composites(1, &t, R, p, mc, hc, Jc);
        mb_mass(1, &t, R0, p0, mc, hc, Jc, S0, what == 0 ? out : M);
        if (what == 3)
            for (int i = 0; i < nv; ++i) {
                double e = 0.0;
                for (int j = 0; j < nv; ++j) e += M[i * nv + j] * in[t.nq + j];
                out[i] = e;
            }
    } else if (what == 1) {
        memset(out, 0, sizeof(double) * 3 * nv * t.ns);
        for (int i = 0; i < t.ns; ++i) {
            const int k0 = t.site[2 * i];
            const double *r = t.c + MB_LINK * nl + 6 + 3 * i;
            double x[3] = {p0[3 * k0], p0[3 * k0 + 1], p0[3 * k0 + 2]};
            for (int a = 0; a < 3; ++a) for (int b = 0; b < 3; ++b) x[a] += R0[9 * k0 + 3 * a + b] * r[b];
            for (int k = k0; k >= 0; k = t.link[4 * k]) {
                const int i0 = t.link[4 * k + 2], n = mb_dofs(t.link[4 * k + 1]);
                for (int sv = 0; sv < n; ++sv) {
                    double a[3], u[3], A[3], U[3];
                    mb_screw(&t, k, sv, a, u);
                    for (int e = 0; e < 3; ++e) {
                        A[e] = R0[9 * k + 3 * e] * a[0] + R0[9 * k + 3 * e + 1] * a[1] + R0[9 * k + 3 * e + 2] * a[2];
                        U[e] = R0[9 * k + 3 * e] * u[0] + R0[9 * k + 3 * e + 1] * u[1] + R0[9 * k + 3 * e + 2] * u[2];
                    }
                    const double d[3] = {x[0] - p0[3 * k], x[1] - p0[3 * k + 1], x[2] - p0[3 * k + 2]};
                    for (int e = 0; e < 3; ++e) {
                        const int e1 = (e + 1) % 3, e2 = (e + 2) % 3;
                        out[(3 * i + e) * nv + i0 + sv] = U[e] + A[e1] * d[e2] - A[e2] * d[e1];
                    }
                }
            }
        }
    } else {
        double *qw = malloc(sizeof(double) * 4 * (size_t)(nl > 0 ? nl : 1));
        if (qw == NULL) abort();
        for (int k = 0; k < nl; ++k) {     /* the world quaternion: the parent's times the joint's */
            const int parent = t.link[4 * k], kind = t.link[4 * k + 1], c0 = t.link[4 * k + 3];
            const double *axis = t.c + MB_LINK * k;
            double step[4] = {1.0, 0.0, 0.0, 0.0};
            if (kind == MB_ROT) {
                const double h = 0.5 * in[c0], sh = sin(h);
                step[0] = cos(h); step[1] = sh * axis[0]; step[2] = sh * axis[1]; step[3] = sh * axis[2];
            } else if (kind == MB_SPH || kind == MB_FREE) {
                const double *q = in + c0 + (kind == MB_FREE ? 3 : 0);
                const double nrm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
                for (int e = 0; e < 4; ++e) step[e] = q[e] / nrm;
            }
            const double par[4] = {parent < 0 ? 1.0 : qw[4 * parent], parent < 0 ? 0.0 : qw[4 * parent + 1],
                                   parent < 0 ? 0.0 : qw[4 * parent + 2], parent < 0 ? 0.0 : qw[4 * parent + 3]};
            double *o = qw + 4 * k;
            o[0] = par[0] * step[0] - par[1] * step[1] - par[2] * step[2] - par[3] * step[3];
            o[1] = par[0] * step[1] + step[0] * par[1] + par[2] * step[3] - par[3] * step[2];
            o[2] = par[0] * step[2] + step[0] * par[2] + par[3] * step[1] - par[1] * step[3];
            o[3] = par[0] * step[3] + step[0] * par[3] + par[1] * step[2] - par[2] * step[1];
        }
        for (int i = 0; i < t.ns; ++i) {
            const int k = t.site[2 * i];
            const double *r = t.c + MB_LINK * nl + 6 + 3 * i;
            for (int a = 0; a < 3; ++a)
                out[7 * i + a] = p0[3 * k + a] + R0[9 * k + 3 * a] * r[0] + R0[9 * k + 3 * a + 1] * r[1]
                                 + R0[9 * k + 3 * a + 2] * r[2];
            for (int e = 0; e < 4; ++e) out[7 * i + 3 + e] = qw[4 * k + e];
        }
        free(qw);
    }
    free(ws);
}

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC pop_options
#endif

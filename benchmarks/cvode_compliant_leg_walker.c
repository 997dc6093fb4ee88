/* The compliant-leg walker (the thesis's §3.1; models/compliant_leg_walker.toml) written by hand
 * in C — right-hand side and its exact Jacobian — under SUNDIALS CVODE (BDF, Newton, dense LU)
 * with its root finding for the mode switches: the limit baseline of benchmarks/bench_walkers.py
 * for this walker, as cvode_compass_walker.c is for the compass walker.
 *
 * The equations, contact and friction laws, scuffing rule and start of a stride are those of
 * tests/validation/handwritten_walkers.py (CompliantLegWalkerHand, see its docstring): point
 * masses (hip M; per leg m_leg at l/2 and the foot m_foot at r_k = l + s_k) plus each leg's moment
 * of inertia I_leg, q = (x, z, a1, a2, s1, s2), y = (q, q'),
 *     M(q) = sum_i m_i J_i^T J_i + I_leg on the angles,
 *     M q'' = sum_i J_i^T m_i (g - c_i) + Q(leg springs and dampers, contact, friction),
 * q'' by Gaussian elimination of the 6 x 6 system. The Jacobian is exact: the same equations in
 * forward-mode dual numbers (value and the 12 partial derivatives), so that it needs no second
 * derivation by hand; --check compares it with central differences of the right-hand side.
 * The CVODE side (callbacks, the walk with its mode switches, --check, the timed repeats) is
 * cvode_walk.h's, shared with cvode_compass_walker.c.
 * Benchmarks only: SUNDIALS is no dependency of porthamiltonian.
 *
 * Build (Debian's SUNDIALS 6: apt-get install -y libsundials-dev), as bench_walkers.py does:
 *   cc -O2 cvode_compliant_leg_walker.c -o cvode_compliant_leg_walker -lsundials_cvode \
 *      -lsundials_nvecserial -lsundials_sunmatrixdense -lsundials_sunlinsoldense \
 *      -lsundials_generic -lm
 * Run:
 *   cvode_compliant_leg_walker N_STEPS RTOL ATOL MAX_STEP REPEATS y_1 ... y_12
 *     (y: the state at the leading foot's (foot 1's) touchdown, in the order above)
 *     -> one JSON line: wall seconds of each repeat, the state at the last heel strike and the
 *        leading foot then (0 or 1), steps, right-hand-side and Jacobian evaluations, events,
 *        strides walked
 *   cvode_compliant_leg_walker --rhs y_1 ... y_12
 *     -> the right-hand side at y with both contacts on (one JSON line), to check the equations
 *   cvode_compliant_leg_walker --check
 *     -> the largest relative difference between the exact Jacobian and central differences at a
 *        few states in contact (one JSON line) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#define NY 12
#define NQ 6

/* parameters: handwritten_walkers.COMPASS_DEFAULTS and CompliantLegWalkerHand's defaults */
static const double SLOPE = 0.009, MH = 3.0, M_LEG = 0.01, M_FOOT = 0.1, L = 0.7, R = 0.05,
                    G = 9.81, K = 1.0e6, LAM = 3.16e7, MU_ST = 0.5, MU_C = 0.25, MU_V = 0.025,
                    S_FRIC = 500.0, V_ST = 0.02, LIFTOFF_MARGIN = 1e-6, FRONT_MARGIN = 0.01,
                    I_LEG = 0.01 * 0.7 * 0.7 / 12.0, /* a rod's: m_leg l^2 / 12 */
                    FALL_FRACTION = 0.5, MAX_STEP_TIME = 3.0, K_LEG = 6000.0, ALPHA = 0.15,
                    PRELOAD = 0.0;
static double D_LEG;    /* 2 alpha sqrt((M + m_foot) K_leg), set in main */

typedef struct {
    int c[2];           /* contact flags */
    int masked;         /* guard held on its new side at t_mask (-1: none) */
    double t_mask;
} Walker;

/* both feet in contact, no guard masked */
static Walker new_walker(void)
{
    Walker w = {{1, 1}, -1, 0.0};
    return w;
}

/* --- the equations in doubles ----------------------------------------------------------------- */
static double mu(double v)
{
    if (v == 0.0)
        return 0.0;
    const double sgn = v > 0 ? 1.0 : -1.0, E = exp(-(v / V_ST) * (v / V_ST));
    return (MU_C + (MU_ST * fabs(tanh(S_FRIC * v)) - MU_C) * E) * sgn + MU_V * v;
}

static void solve(double A[NQ][NQ], double *b)
{
    for (int k = 0; k < NQ; ++k) {
        int p = k;
        for (int i = k + 1; i < NQ; ++i)
            if (fabs(A[i][k]) > fabs(A[p][k]))
                p = i;
        if (p != k) {
            for (int j = 0; j < NQ; ++j) {
                double t = A[k][j]; A[k][j] = A[p][j]; A[p][j] = t;
            }
            double t = b[k]; b[k] = b[p]; b[p] = t;
        }
        for (int i = k + 1; i < NQ; ++i) {
            const double f = A[i][k] / A[k][k];
            for (int j = k; j < NQ; ++j)
                A[i][j] -= f * A[k][j];
            b[i] -= f * b[k];
        }
    }
    for (int i = NQ - 1; i >= 0; --i) {
        double s = b[i];
        for (int j = i + 1; j < NQ; ++j)
            s -= A[i][j] * b[j];
        b[i] = s / A[i][i];
    }
}

/* adds m J^T J to M and J^T m (g - c) to b for a point mass whose velocity is J q' (J: 2 x 6,
 * given by its nonzero entries in columns 2 + k and 4 + k besides the unit x, z columns) */
static void add_point(double M[NQ][NQ], double *b, double m, int k, double jx_a, double jz_a,
                      double jx_s, double jz_s, double cx, double cz)
{
    double J[2][NQ] = {{1.0, 0.0, 0.0, 0.0, 0.0, 0.0}, {0.0, 1.0, 0.0, 0.0, 0.0, 0.0}};
    J[0][2 + k] = jx_a;
    J[1][2 + k] = jz_a;
    J[0][4 + k] = jx_s;
    J[1][4 + k] = jz_s;
    const double gx = G * sin(SLOPE), gz = -G * cos(SLOPE);
    for (int i = 0; i < NQ; ++i) {
        for (int j = 0; j < NQ; ++j)
            M[i][j] += m * (J[0][i] * J[0][j] + J[1][i] * J[1][j]);
        b[i] += m * (J[0][i] * (gx - cx) + J[1][i] * (gz - cz));
    }
}

static void rhs_values(const Walker *w, const double *y, double *ydot)
{
    double M[NQ][NQ] = {{0}}, b[NQ] = {0};
    M[2][2] = M[3][3] = I_LEG;
    add_point(M, b, MH, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (int k = 0; k < 2; ++k) {
        const double a = y[2 + k], wk = y[8 + k], s = y[4 + k], sd = y[10 + k];
        const double sa = sin(a), ca = cos(a), h = L / 2, r = L + s;
        add_point(M, b, M_LEG, k, -h * ca, h * sa, 0.0, 0.0, h * wk * wk * sa, h * wk * wk * ca);
        add_point(M, b, M_FOOT, k, -r * ca, r * sa, -sa, -ca,
                  -2.0 * sd * wk * ca + r * wk * wk * sa, 2.0 * sd * wk * sa + r * wk * wk * ca);
        b[4 + k] -= K_LEG * s - PRELOAD + D_LEG * sd;
        if (!w->c[k])
            continue;
        const double d = R - y[1] + r * ca;
        if (d <= 0.0)
            continue;
        const double dd = -(y[7] - sd * ca + r * sa * wk), law = K + LAM * dd;
        if (law <= 0.0)
            continue;
        const double F = d * law, lever = r * ca + R, Ft = -F * mu(y[6] - sd * sa - lever * wk);
        b[0] += Ft;
        b[1] += F;
        b[2 + k] += F * r * sa - lever * Ft;
        b[4 + k] += -F * ca - sa * Ft;
    }
    solve(M, b);
    for (int i = 0; i < NQ; ++i) {
        ydot[i] = y[NQ + i];
        ydot[NQ + i] = b[i];
    }
}

/* --- the same equations in dual numbers: value and the NY partial derivatives ----------------- */
typedef struct {
    double v, d[NY];
} dual;

static dual dc(double v)
{
    dual r;
    r.v = v;
    memset(r.d, 0, sizeof(r.d));
    return r;
}
static dual dadd(dual a, dual b)
{
    for (int i = 0; i < NY; ++i)
        a.d[i] += b.d[i];
    a.v += b.v;
    return a;
}
static dual dsub(dual a, dual b)
{
    for (int i = 0; i < NY; ++i)
        a.d[i] -= b.d[i];
    a.v -= b.v;
    return a;
}
static dual dmul(dual a, dual b)
{
    dual r;
    r.v = a.v * b.v;
    for (int i = 0; i < NY; ++i)
        r.d[i] = a.d[i] * b.v + a.v * b.d[i];
    return r;
}
static dual ddiv(dual a, dual b)
{
    dual r;
    r.v = a.v / b.v;
    for (int i = 0; i < NY; ++i)
        r.d[i] = (a.d[i] - r.v * b.d[i]) / b.v;
    return r;
}
static dual dscale(double s, dual a)
{
    a.v *= s;
    for (int i = 0; i < NY; ++i)
        a.d[i] *= s;
    return a;
}
/* f(a) with f(a.v) = v, f'(a.v) = dv */
static dual dchain(dual a, double v, double dv)
{
    a.v = v;
    for (int i = 0; i < NY; ++i)
        a.d[i] *= dv;
    return a;
}
static dual dsin(dual a) { return dchain(a, sin(a.v), cos(a.v)); }
static dual dcos(dual a) { return dchain(a, cos(a.v), -sin(a.v)); }
static dual dexp(dual a) { return dchain(a, exp(a.v), exp(a.v)); }
static dual dtanh(dual a)
{
    const double t = tanh(a.v);
    return dchain(a, t, 1.0 - t * t);
}

static dual mu_dual(dual v)
{
    if (v.v == 0.0)
        return dc(0.0);
    const double sgn = v.v > 0 ? 1.0 : -1.0;
    const dual x = dscale(1.0 / V_ST, v), E = dexp(dscale(-1.0, dmul(x, x)));
    const dual a = dsub(dscale(MU_ST * sgn, dtanh(dscale(S_FRIC, v))), dc(MU_C));  /* |tanh| */
    return dadd(dscale(sgn, dadd(dc(MU_C), dmul(a, E))), dscale(MU_V, v));
}

static void solve_dual(dual A[NQ][NQ], dual *b)
{
    for (int k = 0; k < NQ; ++k) {
        int p = k;
        for (int i = k + 1; i < NQ; ++i)
            if (fabs(A[i][k].v) > fabs(A[p][k].v))
                p = i;
        if (p != k) {
            for (int j = 0; j < NQ; ++j) {
                dual t = A[k][j]; A[k][j] = A[p][j]; A[p][j] = t;
            }
            dual t = b[k]; b[k] = b[p]; b[p] = t;
        }
        for (int i = k + 1; i < NQ; ++i) {
            const dual f = ddiv(A[i][k], A[k][k]);
            for (int j = k; j < NQ; ++j)
                A[i][j] = dsub(A[i][j], dmul(f, A[k][j]));
            b[i] = dsub(b[i], dmul(f, b[k]));
        }
    }
    for (int i = NQ - 1; i >= 0; --i) {
        dual s = b[i];
        for (int j = i + 1; j < NQ; ++j)
            s = dsub(s, dmul(A[i][j], b[j]));
        b[i] = ddiv(s, A[i][i]);
    }
}

static void add_point_dual(dual M[NQ][NQ], dual *b, double m, int k, dual jx_a, dual jz_a,
                           dual jx_s, dual jz_s, dual cx, dual cz)
{
    dual J[2][NQ];
    for (int i = 0; i < NQ; ++i)
        J[0][i] = J[1][i] = dc(0.0);
    J[0][0] = J[1][1] = dc(1.0);
    J[0][2 + k] = jx_a;
    J[1][2 + k] = jz_a;
    J[0][4 + k] = jx_s;
    J[1][4 + k] = jz_s;
    const dual gx = dsub(dc(G * sin(SLOPE)), cx), gz = dsub(dc(-G * cos(SLOPE)), cz);
    for (int i = 0; i < NQ; ++i) {
        for (int j = 0; j < NQ; ++j)
            M[i][j] = dadd(M[i][j], dscale(m, dadd(dmul(J[0][i], J[0][j]),
                                                   dmul(J[1][i], J[1][j]))));
        b[i] = dadd(b[i], dscale(m, dadd(dmul(J[0][i], gx), dmul(J[1][i], gz))));
    }
}

static void jac_values(const Walker *w, const double *yv, double Jac[NY][NY])
{
    dual y[NY], M[NQ][NQ], b[NQ];
    for (int i = 0; i < NY; ++i) {
        y[i] = dc(yv[i]);
        y[i].d[i] = 1.0;
    }
    for (int i = 0; i < NQ; ++i) {
        b[i] = dc(0.0);
        for (int j = 0; j < NQ; ++j)
            M[i][j] = dc(0.0);
    }
    M[2][2] = M[3][3] = dc(I_LEG);
    const dual zero = dc(0.0);
    add_point_dual(M, b, MH, 0, zero, zero, zero, zero, zero, zero);
    for (int k = 0; k < 2; ++k) {
        const dual a = y[2 + k], wk = y[8 + k], s = y[4 + k], sd = y[10 + k];
        const dual sa = dsin(a), ca = dcos(a), r = dadd(dc(L), s), w2 = dmul(wk, wk);
        const double h = L / 2;
        add_point_dual(M, b, M_LEG, k, dscale(-h, ca), dscale(h, sa), zero, zero,
                       dscale(h, dmul(w2, sa)), dscale(h, dmul(w2, ca)));
        const dual sdw = dmul(sd, wk);
        add_point_dual(M, b, M_FOOT, k, dscale(-1.0, dmul(r, ca)), dmul(r, sa),
                       dscale(-1.0, sa), dscale(-1.0, ca),
                       dadd(dscale(-2.0, dmul(sdw, ca)), dmul(r, dmul(w2, sa))),
                       dadd(dscale(2.0, dmul(sdw, sa)), dmul(r, dmul(w2, ca))));
        b[4 + k] = dsub(b[4 + k], dadd(dsub(dscale(K_LEG, s), dc(PRELOAD)), dscale(D_LEG, sd)));
        if (!w->c[k])
            continue;
        const dual d = dadd(dsub(dc(R), y[1]), dmul(r, ca));
        if (d.v <= 0.0)
            continue;
        const dual dd = dscale(-1.0, dadd(dsub(y[7], dmul(sd, ca)), dmul(r, dmul(sa, wk))));
        const dual law = dadd(dc(K), dscale(LAM, dd));
        if (law.v <= 0.0)
            continue;
        const dual F = dmul(d, law), lever = dadd(dmul(r, ca), dc(R));
        const dual slip = dsub(dsub(y[6], dmul(sd, sa)), dmul(lever, wk));
        const dual Ft = dscale(-1.0, dmul(F, mu_dual(slip)));
        b[0] = dadd(b[0], Ft);
        b[1] = dadd(b[1], F);
        b[2 + k] = dadd(b[2 + k], dsub(dmul(F, dmul(r, sa)), dmul(lever, Ft)));
        b[4 + k] = dsub(b[4 + k], dadd(dmul(F, ca), dmul(sa, Ft)));
    }
    solve_dual(M, b);
    memset(Jac, 0, sizeof(double) * NY * NY);
    for (int i = 0; i < NQ; ++i) {
        Jac[i][NQ + i] = 1.0;
        for (int j = 0; j < NY; ++j)
            Jac[NQ + i][j] = b[i].d[j];
    }
}

static double penetration(const double *y, int k)
{
    return R - y[1] + (L + y[4 + k]) * cos(y[2 + k]);
}
static double foot_x(const double *y, int k) { return y[0] - (L + y[4 + k]) * sin(y[2 + k]); }

#include "cvode_walk.h"

int main(int argc, char **argv)
{
    D_LEG = 2.0 * ALPHA * sqrt((MH + M_FOOT) * K_LEG);
    if (argc == 2 && strcmp(argv[1], "--check") == 0) {
        const double states[3][NY] = {
            {0.01, 0.7 * cos(0.2) + R - 1e-5, -0.2, 0.21, 1e-4, -2e-4,
             0.6, -0.1, 0.8, 0.83, 0.01, -0.02},
            {0.02, 0.7 * cos(0.1) + R - 3e-5, 0.1, -0.15, -3e-4, 1e-4,
             0.55, 0.02, -0.7, 0.9, -0.03, 0.01},
            {0.0, 0.7 * cos(0.25) + R - 2e-6, 0.25, -0.25, 2e-4, 2e-4,
             0.5, -0.05, 0.3, -0.2, 0.0, 0.02}};
        return check(states, 3);
    }
    if (argc == 2 + NY && strcmp(argv[1], "--rhs") == 0) {
        Walker w = new_walker();
        double y[NY], f[NY];
        for (int i = 0; i < NY; ++i)
            y[i] = atof(argv[2 + i]);
        rhs_values(&w, y, f);
        printf("{\"rhs\": [");
        for (int i = 0; i < NY; ++i)
            printf("%s%.17g", i ? ", " : "", f[i]);
        printf("]}\n");
        return 0;
    }
    if (argc != 6 + NY) {
        fprintf(stderr, "usage: %s N_STEPS RTOL ATOL MAX_STEP REPEATS y_1 ... y_12 | --rhs y_1 "
                        "... y_12 | --check\n", argv[0]);
        return 2;
    }
    const int n_steps = atoi(argv[1]), repeats = atoi(argv[5]);
    const double rtol = atof(argv[2]), atol = atof(argv[3]), max_step = atof(argv[4]);
    double y0[NY];
    for (int i = 0; i < NY; ++i)
        y0[i] = atof(argv[6 + i]);
    const WalkResult res = timed_walks(y0, n_steps, rtol, atol, max_step, repeats);
    printf("], \"y\": [");
    for (int i = 0; i < NY; ++i)
        printf("%s%.17g", i ? ", " : "", res.y[i]);
    printf("], \"lead\": %d, \"strides\": %d, \"steps\": %ld, \"nfev\": %ld, \"njev\": %ld, "
           "\"events\": %ld, \"end\": \"%s\"}\n", res.lead, res.strides, res.steps, res.nfev,
           res.njev, res.events, res.end);
    return 0;
}

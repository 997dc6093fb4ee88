/* The nominal compliant-contact walker (the thesis's ch. 2; models/compass_walker.toml) written by
 * hand in C — right-hand side and analytic Jacobian — under SUNDIALS CVODE (BDF, Newton, dense
 * LU) with its root finding for the mode switches: the limit baseline of
 * benchmarks/bench_walkers.py ("what a hand-written C + CVODE program does").
 *
 * The equations, contact and friction laws, scuffing rule, start of a stride and section are
 * those of tests/validation/handwritten_walkers.py (CompassWalkerHand, see its docstring):
 * y = (x, z, a1, a2, vx, vz, w1, w2), M(q) v' = b(q, v) + Q(contact), v' by Gaussian elimination
 * of the 4 x 4 system; the Jacobian is [[0, I], [M^-1 (db/dq - dM/dq v'), M^-1 db/dv]].
 * The CVODE side (callbacks, the walk with its mode switches, --check, the timed repeats) is
 * cvode_walk.h's, shared with cvode_compliant_leg_walker.c.
 * Benchmarks only: SUNDIALS is no dependency of porthamiltonian.
 *
 * Build (Debian's SUNDIALS 6: apt-get install -y libsundials-dev), as bench_walkers.py does:
 *   cc -O2 cvode_compass_walker.c -o cvode_compass_walker -lsundials_cvode \
 *      -lsundials_nvecserial -lsundials_sunmatrixdense -lsundials_sunlinsoldense \
 *      -lsundials_generic -lm
 * Run:
 *   cvode_compass_walker N_STEPS RTOL ATOL MAX_STEP REPEATS a_lead a_trail vx vz w_lead w_trail
 *     -> one JSON line: wall seconds of each repeat, the section state after the walk, steps,
 *        right-hand-side and Jacobian evaluations, events, strides walked
 *   cvode_compass_walker --check
 *     -> the largest relative difference between the analytic Jacobian and central differences
 *        at a few states in contact (one JSON line) */
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

#define NY 8        /* y = (x, z, a1, a2, vx, vz, w1, w2) */

/* parameters: handwritten_walkers.COMPASS_DEFAULTS */
static const double SLOPE = 0.009, MH = 3.0, M_LEG = 0.01, M_FOOT = 0.1, L = 0.7, R = 0.05,
                    G = 9.81, K = 1.0e6, LAM = 3.16e7, MU_ST = 0.5, MU_C = 0.25, MU_V = 0.025,
                    S_FRIC = 500.0, V_ST = 0.02, LIFTOFF_MARGIN = 1e-6, FRONT_MARGIN = 0.01,
                    I_LEG = 0.01 * 0.7 * 0.7 / 12.0, /* a rod's: m_leg l^2 / 12 */
                    FALL_FRACTION = 0.5, MAX_STEP_TIME = 3.0, START_PENETRATION = 1e-9;

typedef struct {
    int c[2];           /* contact flags */
    int masked;         /* guard held on its new side at t_mask (-1: none) */
    double t_mask;
    double S, I, mt;
} Walker;

/* both feet in contact, no guard masked; S, I, m_t of handwritten_walkers.CompassWalkerHand */
static Walker new_walker(void)
{
    Walker w = {{1, 1}, -1, 0.0, M_LEG * L / 2 + M_FOOT * L,
                M_LEG * L * L / 4 + I_LEG + M_FOOT * L * L, MH + 2 * (M_LEG + M_FOOT)};
    return w;
}

static double mu(double v, double *dmu)
{
    if (v == 0.0) {
        *dmu = 0.0;     /* (a measure-zero point; the hand-written Python returns 0 too) */
        return 0.0;
    }
    const double sgn = v > 0 ? 1.0 : -1.0, th = tanh(S_FRIC * v), E = exp(-(v / V_ST) * (v / V_ST));
    const double a = MU_ST * fabs(th) - MU_C;
    *dmu = MU_ST * S_FRIC * (1.0 - th * th) * E - sgn * a * 2.0 * v / (V_ST * V_ST) * E + MU_V;
    return (MU_C + a * E) * sgn + MU_V * v;
}

static void solve4(double A[4][4], double *b)
{
    for (int k = 0; k < 4; ++k) {
        int p = k;
        for (int i = k + 1; i < 4; ++i)
            if (fabs(A[i][k]) > fabs(A[p][k]))
                p = i;
        if (p != k) {
            for (int j = 0; j < 4; ++j) {
                double t = A[k][j]; A[k][j] = A[p][j]; A[p][j] = t;
            }
            double t = b[k]; b[k] = b[p]; b[p] = t;
        }
        for (int i = k + 1; i < 4; ++i) {
            double f = A[i][k] / A[k][k];
            for (int j = k; j < 4; ++j)
                A[i][j] -= f * A[k][j];
            b[i] -= f * b[k];
        }
    }
    for (int i = 3; i >= 0; --i) {
        double s = b[i];
        for (int j = i + 1; j < 4; ++j)
            s -= A[i][j] * b[j];
        b[i] = s / A[i][i];
    }
}

static void mass_matrix(const Walker *w, const double *y, double M[4][4])
{
    const double c1 = cos(y[2]), s1 = sin(y[2]), c2 = cos(y[3]), s2 = sin(y[3]);
    double m[4][4] = {{w->mt, 0.0, -w->S * c1, -w->S * c2}, {0.0, w->mt, w->S * s1, w->S * s2},
                      {-w->S * c1, w->S * s1, w->I, 0.0}, {-w->S * c2, w->S * s2, 0.0, w->I}};
    memcpy(M, m, sizeof(m));
}

/* b(q, v) + Q and, when db is not NULL, its partial derivatives db[i][j] = d b_i / d y_j */
static void forces(const Walker *w, const double *y, double *b, double db[4][8])
{
    const double S = w->S, mt = w->mt;
    const double a[2] = {y[2], y[3]}, om[2] = {y[6], y[7]};
    if (db)
        memset(db, 0, sizeof(double) * 32);
    b[0] = mt * G * sin(SLOPE);
    b[1] = -mt * G * cos(SLOPE);
    for (int k = 0; k < 2; ++k) {
        const double s = sin(a[k]), c = cos(a[k]), wk = om[k];
        b[0] -= S * s * wk * wk;
        b[1] -= S * c * wk * wk;
        b[2 + k] = -G * S * sin(a[k] + SLOPE);
        if (db) {
            db[0][2 + k] = -S * c * wk * wk;
            db[0][6 + k] = -2.0 * S * s * wk;
            db[1][2 + k] = S * s * wk * wk;
            db[1][6 + k] = -2.0 * S * c * wk;
            db[2 + k][2 + k] = -G * S * cos(a[k] + SLOPE);
        }
    }
    for (int k = 0; k < 2; ++k) {
        if (!w->c[k])
            continue;
        const double s = sin(a[k]), c = cos(a[k]), wk = om[k];
        const double d = R - y[1] + L * c;
        if (!(d > 0.0))
            continue;
        const double dd = -(y[5] + L * s * wk), law = K + LAM * dd;
        if (!(law > 0.0))
            continue;
        /* friction at the rolling arc's material contact point, R below the foot centre: its
         * x velocity is vx - (L cos a + R) w (the lever of Ft about the leg's angle) */
        const double lever = L * c + R, F = d * law, vs = y[4] - lever * wk;
        double dmu;
        const double m = mu(vs, &dmu), Ft = -F * m;
        b[0] += Ft;
        b[1] += F;
        b[2 + k] += F * L * s - lever * Ft;
        if (!db)
            continue;
        /* dF and dFt with respect to (z, a_k, vx, vz, w_k) */
        const int iz = 1, ia = 2 + k, ivx = 4, ivz = 5, iw = 6 + k;
        double dF[8] = {0}, dvs[8] = {0}, dFt[8];
        dF[iz] = -law;
        dF[ia] = law * (-L * s) + d * LAM * (-L * c * wk);
        dF[ivz] = -d * LAM;
        dF[iw] = -d * LAM * L * s;
        dvs[ia] = L * s * wk;
        dvs[ivx] = 1.0;
        dvs[iw] = -lever;
        for (int j = 0; j < 8; ++j) {
            dFt[j] = -m * dF[j] - F * dmu * dvs[j];
            db[0][j] += dFt[j];
            db[1][j] += dF[j];
            db[2 + k][j] += dF[j] * L * s - lever * dFt[j];
        }
        db[2 + k][ia] += F * L * c + L * s * Ft;
    }
}

static void rhs_values(const Walker *w, const double *y, double *ydot)
{
    double M[4][4], b[4];
    forces(w, y, b, NULL);
    mass_matrix(w, y, M);
    solve4(M, b);
    for (int i = 0; i < 4; ++i) {
        ydot[i] = y[4 + i];
        ydot[4 + i] = b[i];
    }
}

static void jac_values(const Walker *w, const double *y, double J[NY][NY])
{
    double M[4][4], Mc[4][4], b[4], db[4][8], acc[4];
    forces(w, y, b, db);
    mass_matrix(w, y, M);
    memcpy(acc, b, sizeof(acc));
    memcpy(Mc, M, sizeof(Mc));
    solve4(Mc, acc);                                       /* v' (solve4 destroys its matrix) */
    const double S = w->S, s1 = sin(y[2]), c1 = cos(y[2]), s2 = sin(y[3]), c2 = cos(y[3]);
    memset(J, 0, sizeof(double) * 64);
    for (int i = 0; i < 4; ++i)
        J[i][4 + i] = 1.0;
    for (int j = 0; j < 8; ++j) {
        double col[4] = {db[0][j], db[1][j], db[2][j], db[3][j]};
        if (j == 2) {               /* - dM/da1 v' */
            col[0] -= S * s1 * acc[2];
            col[1] -= S * c1 * acc[2];
            col[2] -= S * s1 * acc[0] + S * c1 * acc[1];
        } else if (j == 3) {        /* - dM/da2 v' */
            col[0] -= S * s2 * acc[3];
            col[1] -= S * c2 * acc[3];
            col[3] -= S * s2 * acc[0] + S * c2 * acc[1];
        }
        memcpy(Mc, M, sizeof(Mc));
        solve4(Mc, col);
        for (int i = 0; i < 4; ++i)
            J[4 + i][j] = col[i];
    }
}

static double penetration(const double *y, int k) { return R - y[1] + L * cos(y[2 + k]); }
static double foot_x(const double *y, int k) { return y[0] - L * sin(y[2 + k]); }

#include "cvode_walk.h"

int main(int argc, char **argv)
{
    if (argc == 2 && strcmp(argv[1], "--check") == 0) {
        const double states[3][NY] = {
            {0.01, 0.7 * cos(0.2) + R - 1e-5, -0.2, 0.21, 0.6, -0.1, 0.8, 0.83},
            {0.02, 0.7 * cos(0.1) + R - 3e-5, 0.1, -0.15, 0.55, 0.02, -0.7, 0.9},
            {0.0, 0.7 * cos(0.25) + R - 2e-6, 0.25, -0.25, 0.5, -0.05, 0.3, -0.2}};
        return check(states, 3);
    }
    if (argc != 12) {
        fprintf(stderr, "usage: %s N_STEPS RTOL ATOL MAX_STEP REPEATS a_lead a_trail vx vz "
                        "w_lead w_trail | --check\n", argv[0]);
        return 2;
    }
    const int n_steps = atoi(argv[1]), repeats = atoi(argv[5]);
    const double rtol = atof(argv[2]), atol = atof(argv[3]), max_step = atof(argv[4]);
    double z0[6];
    for (int i = 0; i < 6; ++i)
        z0[i] = atof(argv[6 + i]);
    /* the start of a stride: the section state, the hip at x = 0 and at the height that puts
     * the leading foot START_PENETRATION into the surface */
    const double y0[NY] = {0.0, L * cos(z0[0]) + R - START_PENETRATION, z0[0], z0[1], z0[2],
                           z0[3], z0[4], z0[5]};
    const WalkResult res = timed_walks(y0, n_steps, rtol, atol, max_step, repeats);
    /* the section state at the last heel strike: the leading foot's angle first */
    const int i = 2 + res.lead, j = 3 - res.lead;
    const double *y = res.y;
    printf("], \"z\": [%.17g, %.17g, %.17g, %.17g, %.17g, %.17g], \"strides\": %d, "
           "\"steps\": %ld, \"nfev\": %ld, \"njev\": %ld, \"events\": %ld, \"end\": \"%s\"}\n",
           y[i], y[j], y[4], y[5], y[4 + i], y[4 + j], res.strides, res.steps, res.nfev,
           res.njev, res.events, res.end);
    return 0;
}

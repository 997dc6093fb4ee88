/* Template, not compiled alone: appended by porthamiltonian.backends to each model's generated
 * C functions (rhs, jac, guards; PH_N states, PH_NG guard slots: the model's constants in one
 * translation unit with it, e.g. an FMU's, or the sizes its unit exports, ph_n and ph_ng, read
 * at run time by the loops' object that every model links), followed by the tables and
 * exported entry point ph_integrate_<method> of each method (porthamiltonian/integrators/
 * tableaus.py). It is rosenbrock_loop.py in C, step for step (same stages, error norm, step-size
 * rule, dense output, guard samples, Illinois iteration and statuses): a change there is made
 * here too.
 *
 * Entry points: int ph_integrate_<method>(PH_LOOP_PARAMS) returns the status (0 reached t_end,
 * 1 terminal event, 2 step-size underflow or singular W, 3 divergence, 4 max_steps, 5 store
 * buffers full) and writes out_th = {t, h}, out_y = y (PH_N values), counts = {n_store, nfev,
 * njev, nsteps, event_index, n_ev, nlu}, the accepted steps into ts (store_cap) / ys
 * (store_cap x PH_N, row-major) and the non-terminal events into ev_t / ev_k (store_cap).
 * int ph_integrate_<method>_variational(PH_LOOP_PARAMS, PH_PHI_PARAMS) does the same and
 * integrates the sensitivities Phi from phi0 (PH_N x m, row-major; column c the initial
 * perturbation of direction c) as rosenbrock_loop.py does (see its header): Phi at the end into
 * phi_out (PH_N x m), at the stored points into phis (store_cap x PH_N x m), the largest relative
 * error estimate of Phi over its accepted sub-steps into phi_error[0]. With parameter
 * sensitivities (n_gain > 0: the gain G, n_gain x m row-major, of the header of
 * rosenbrock_loop.py) Phi' = A Phi + jac_p G, jac_p the model's generated dxdot/dp (N x n_gain;
 * a model compiled without it has a stub and is called with n_gain = 0). */

typedef struct {
    int s;              /* stages */
    int m;              /* rows of the dense-output table */
    double gamma;
    double expo;        /* step-size exponent 1/(q + 1), q the embedded order */
    const double *a;    /* s x s: U_i = y + sum_j a_ij K_j */
    const double *c;    /* s x s: + (sum_j c_ij K_j) / h */
    const double *nodes;
    const double *d;
    const double *h;    /* m x s dense-output table */
} ph_tableau;

#define PH_SAMPLES 3    /* interior guard samples per step */
#define PH_MAX_STAGES 16    /* stages of a tableau at most (tableaus.py checks its tables) */

/* ph: the entry points' parameters */
#define PH_LOOP_PARAMS double t0, const double *y0, double t_end, const double *p, double rtol, \
    const double *atol, double h0, double hmax, const int64_t *directions, \
    const uint8_t *terminal, int64_t g_count, int64_t mask_index, double mask_sign, \
    int64_t n_model, double bound, int64_t max_steps, int64_t store_cap, double tgrad_step, \
    double *ts, double *ys, double *ev_t, int64_t *ev_k, double *out_th, double *out_y, \
    int64_t *counts
#define PH_LOOP_ARGS t0, y0, t_end, p, rtol, atol, h0, hmax, directions, terminal, g_count, \
    mask_index, mask_sign, n_model, bound, max_steps, store_cap, tgrad_step, ts, ys, ev_t, ev_k, \
    out_th, out_y, counts
#define PH_PHI_PARAMS int64_t m, const double *phi0, int64_t n_gain, const double *gain, \
    double *phis, double *phi_out, double *phi_error
#define PH_PHI_ARGS m, phi0, n_gain, gain, phis, phi_out, phi_error
/* ph: end of the entry points' parameters */
#define PH_CBRT_EPS 6.0554544523933395e-06   /* the relative step of the central differences */

/* The leading nf x nf block of the PH_N x PH_N row-major A: PA = LU in place (partial pivoting,
 * row swaps in piv): L below the diagonal (unit diagonal), U above it, and on the diagonal
 * 1/U[k, k], so that solves multiply (a division's latency is on the critical path of a small
 * solve); 0 when the block is singular (_lu_factor of rosenbrock_loop.py) */
static int ph_lu_factor(double *A, int *piv, int nf)
{
    const int n = PH_N;
    for (int k = 0; k < nf; ++k) {
        int m = k;
        double big = fabs(A[k * n + k]);
        for (int i = k + 1; i < nf; ++i) {
            if (fabs(A[i * n + k]) > big) {
                big = fabs(A[i * n + k]);
                m = i;
            }
        }
        piv[k] = m;
        if (big == 0.0)
            return 0;
        if (m != k) {
            for (int j = 0; j < n; ++j) {
                double tmp = A[k * n + j];
                A[k * n + j] = A[m * n + j];
                A[m * n + j] = tmp;
            }
        }
        const double r = 1.0 / A[k * n + k];
        A[k * n + k] = r;
        for (int i = k + 1; i < nf; ++i) {
            A[i * n + k] *= r;
            double f = A[i * n + k];
            if (f != 0.0)
                for (int j = k + 1; j < nf; ++j)
                    A[i * n + j] -= f * A[k * n + j];
        }
    }
    return 1;
}

/* W = I/(h gamma) - J (hgam = h gamma), factored in place (_w_factor of rosenbrock_loop.py).
 * The ledger quadratures (states n_model..PH_N-1) are read by no right-hand side: when J's
 * columns of them are zero, W is block lower-triangular and only its model block is factored
 * (a ledger row is then solved by substitution: its diagonal holds h gamma); otherwise all of
 * W. Returns the size of the factored block, 0 when it is singular. */
static int ph_w_factor(const double *J, double hgam, int64_t n_model, double *W, int *piv)
{
    const int n = PH_N;
    const double inv = 1.0 / hgam;
    int nf = (int)n_model;
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j)
            W[i * n + j] = -J[i * n + j];
        W[i * n + i] += inv;
        for (int j = (int)n_model; j < n; ++j)
            if (J[i * n + j] != 0.0)
                nf = n;
    }
    if (!ph_lu_factor(W, piv, nf))
        return 0;
    for (int i = nf; i < n; ++i)
        W[i * n + i] = hgam;
    return nf;
}

/* Solve W x = b in place (W: from ph_w_factor, its block of nf factored), the block by columns
 * (each step updates the remaining components independently of one another), then the rows
 * below it by substitution */
static void ph_lu_solve(const double *A, const int *piv, int nf, double *b)
{
    const int n = PH_N;
    for (int k = 0; k < nf; ++k) {
        int m = piv[k];
        if (m != k) {
            double tmp = b[k];
            b[k] = b[m];
            b[m] = tmp;
        }
    }
    for (int k = 0; k < nf; ++k) {
        const double bk = b[k];
        for (int i = k + 1; i < nf; ++i)
            b[i] -= A[i * n + k] * bk;
    }
    for (int k = nf - 1; k >= 0; --k) {
        const double bk = b[k] * A[k * n + k];
        b[k] = bk;
        for (int i = 0; i < k; ++i)
            b[i] -= A[i * n + k] * bk;
    }
    for (int i = nf; i < n; ++i) {
        double acc = b[i];
        for (int j = 0; j < nf; ++j)
            acc -= A[i * n + j] * b[j];
        b[i] = acc * A[i * n + i];
    }
}

/* y(theta) = (1 - theta) y0 + theta (y1 + (1 - theta)(E_0 + theta (E_1 + theta (...)))) for
 * vectors of len values (E: m x len) */
static void ph_dense(int m, int64_t len, double theta, const double *y0, const double *y1,
                     const double *E, double *out)
{
    for (int64_t i = 0; i < len; ++i) {
        double acc = E[(m - 1) * len + i];
        for (int r = m - 2; r >= 0; --r)
            acc = E[r * len + i] + theta * acc;
        out[i] = (1.0 - theta) * y0[i] + theta * (y1[i] + (1.0 - theta) * acc);
    }
}

/* The step of the differences along (1, f) (_rate_step of rosenbrock_loop.py) */
static double ph_rate_step(double h, const double *f, const double *sc, int64_t n_model)
{
    double nu = 1.0 / h;
    for (int64_t i = 0; i < n_model; ++i)
        nu = fmax(nu, fabs(f[i]) / sc[i]);
    return PH_CBRT_EPS / nu;
}

/* The variational equation's helpers (to ph_phi_substep) with GCC's loop vectorizer (its cheap
 * cost model, on -O2): their loops over Phi's entries (the stage sums, the products with A, the
 * solves) vectorized, the same numbers (no reassociation); a stride of the compliant-leg walker
 * with its sensitivities ~15 % faster, as at -O3, for 0.04 s more of GCC (-O3: 0.1 s; on the
 * whole object: twice its compilation, and no gain in the plain step). */
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC push_options
#pragma GCC optimize ("O2", "tree-loop-vectorize", "vect-cost-model=cheap")
#endif

/* out += A[:, :cols] B for the PH_N rows of A (row-major, lda per row) and B (cols x m,
 * row-major; out PH_N x m), skipping A's zeros (_add_product of rosenbrock_loop.py) */
static void ph_add_product(const double *A, int64_t lda, int64_t cols, const double *B, int64_t m,
                           double *out)
{
    for (int i = 0; i < PH_N; ++i)
        for (int64_t j = 0; j < cols; ++j) {
            const double a = A[i * lda + j];
            if (a != 0.0)
                for (int64_t c = 0; c < m; ++c)
                    out[i * m + c] += a * B[j * m + c];
        }
}

/* out = jac_p(t, y, p) G (N x m row-major; G = gain, n_gain x m): the forcing of the parameter
 * sensitivities (_forcing of rosenbrock_loop.py); Fp: work (N x n_gain) */
static void ph_forcing(double t, const double *y, const double *p, int64_t n_gain,
                       const double *gain, int64_t m, double *Fp, double *out)
{
    jac_p(t, y, p, Fp);
    memset(out, 0, sizeof(double) * PH_N * m);
    ph_add_product(Fp, n_gain, n_gain, gain, m, out);
}

/* out = dX/dt from X at (t, y) and Xp, Xm at t +- eps along (1, f), len values each: central,
 * or the one-sided difference without a kink of X (_difference_rate of rosenbrock_loop.py) */
static void ph_difference_rate(const double *Xp, const double *X, const double *Xm, int64_t len,
                               double eps, double *out)
{
    double up = 0.0, down = 0.0, second = 0.0, central = 0.0;
    /* the largest of each: a > m ? a : m is fmax(m, a) while m is a number (it starts at 0 and
     * a NaN a is passed over, as fmax does), but an instruction GCC vectorizes, not a call */
    for (int64_t k = 0; k < len; ++k) {
        const double a = fabs(Xp[k] - X[k]), b = fabs(X[k] - Xm[k]);
        const double c = fabs(Xp[k] - 2.0 * X[k] + Xm[k]), d = fabs(Xp[k] - Xm[k]);
        up = a > up ? a : up;
        down = b > down ? b : down;
        second = c > second ? c : second;
        central = d > central ? d : central;
    }
    const int kink = second > 0.5 * central && second > 1e-12 * (up + down + 1e-300);
    for (int64_t k = 0; k < len; ++k) {
        if (!kink)
            out[k] = (Xp[k] - Xm[k]) / (2.0 * eps);
        else if (up <= down)
            out[k] = (Xp[k] - X[k]) / eps;
        else
            out[k] = (X[k] - Xm[k]) / eps;
    }
}

/* yp, ym = y +- eps f: the states at t +- eps along (1, f) (_shifted of rosenbrock_loop.py) */
static void ph_shifted(const double *y, const double *f, double eps, double *yp, double *ym)
{
    for (int i = 0; i < PH_N; ++i) {
        yp[i] = y[i] + eps * f[i];
        ym[i] = y[i] - eps * f[i];
    }
}

/* DF = d/dt F(t, x(t)) of the forcing F (its value at (t, y)) by the differences of ph_jac_rate
 * (_forcing_rate of rosenbrock_loop.py); work: 2 N m + 2 N + N n_gain. Returns the jac_p
 * evaluations made (2). */
static int ph_forcing_rate(double t, double h, const double *y, const double *p, int64_t n_gain,
                           const double *gain, int64_t m, const double *F, const double *f,
                           const double *sc, int64_t n_model, double *DF, double *work)
{
    const int N = PH_N;
    const int64_t nm = N * m;
    const double eps = ph_rate_step(h, f, sc, n_model);
    double *Fp = work, *Fm = Fp + nm, *yp = Fm + nm, *ym = yp + N, *Jp = ym + N;
    ph_shifted(y, f, eps, yp, ym);
    ph_forcing(t + eps, yp, p, n_gain, gain, m, Jp, Fp);
    ph_forcing(t - eps, ym, p, n_gain, gain, m, Jp, Fm);
    ph_difference_rate(Fp, F, Fm, nm, eps, DF);
    return 2;
}

/* D = d/dt J(t, x(t)) = d_x J[f] + d_t J by differences along (1, f) (_jac_rate of
 * rosenbrock_loop.py: central, or the one-sided difference without a kink of J); work: 2 N x N +
 * 2 N. Returns the jac evaluations made (2). */
static int ph_jac_rate(double t, double h, const double *y, const double *p, const double *J,
                       const double *f, const double *sc, int64_t n_model, double *D,
                       double *work)
{
    const int N = PH_N;
    const double eps = ph_rate_step(h, f, sc, n_model);
    double *Jp = work, *Jm = Jp + N * N, *yp = Jm + N * N, *ym = yp + N;
    ph_shifted(y, f, eps, yp, ym);
    jac(t + eps, yp, p, Jp);
    jac(t - eps, ym, p, Jm);
    ph_difference_rate(Jp, J, Jm, N * N, eps, D);
    return 2;
}

/* Row i of the N x m matrix B (row-major) solved from rows j0..j1-1: B_i = (B_i - sum_j
 * A_ij B_j) A_ii (A_ii holds the inverse of the pivot) */
static void ph_row_solved(const double *A, double *B, int64_t m, int i, int j0, int j1)
{
    const int n = PH_N;
    for (int j = j0; j < j1; ++j) {
        const double a = A[i * n + j];
        if (a != 0.0)
            for (int64_t c = 0; c < m; ++c)
                B[i * m + c] -= a * B[j * m + c];
    }
    const double d = A[i * n + i];
    for (int64_t c = 0; c < m; ++c)
        B[i * m + c] *= d;
}

/* Solve W X = B in place for the N x m matrix B (row-major; W: from ph_w_factor, its block of
 * nf factored) */
static void ph_lu_solve_rows(const double *A, const int *piv, int nf, double *B, int64_t m)
{
    const int n = PH_N;
    for (int k = 0; k < nf; ++k) {
        int r = piv[k];
        if (r != k)
            for (int64_t c = 0; c < m; ++c) {
                double tmp = B[k * m + c];
                B[k * m + c] = B[r * m + c];
                B[r * m + c] = tmp;
            }
    }
    for (int i = 0; i < nf; ++i)
        for (int j = 0; j < i; ++j) {
            const double a = A[i * n + j];
            if (a != 0.0)
                for (int64_t c = 0; c < m; ++c)
                    B[i * m + c] -= a * B[j * m + c];
        }
    for (int i = nf - 1; i >= 0; --i)          /* U, its diagonal stored inverted */
        ph_row_solved(A, B, m, i, i + 1, nf);
    for (int i = nf; i < n; ++i)                /* the ledger rows: their diagonal is h gamma */
        ph_row_solved(A, B, m, i, 0, nf);
}

/* One sub-step of Phi from t + th_a h to t + th_b h (_phi_substep of rosenbrock_loop.py): KP
 * (s x N m) and P1 from P, with the LU of W = I/(eta gamma) - Ja and D = A'; A at t + th_b h
 * into A_end; the step's dense output y, y1, E (nd rows); with parameters (n_gain > 0) the
 * forcing Fa at the start, its rate DF, F at the end into F_end (Fp: N x n_gain work). work:
 * N x N + 2 m N + N. Returns the jac and jac_p evaluations made. */
static int ph_phi_substep(const ph_tableau *tab, double th_a, double th_b, double t, double h,
                          const double *y, const double *y1, const double *p, int nd,
                          const double *E,
                          const double *Ja, const double *D, const double *W, const int *piv,
                          int nf, int64_t n_model, int64_t m, const double *P, double *KP,
                          double *P1,
                          double *A_end, double *work, int64_t n_gain, const double *gain,
                          const double *Fa, const double *DF, double *F_end, double *Fp)
{
    const int N = PH_N;
    const int s = tab->s;
    const int64_t nm = m * N;
    const double ds = th_b - th_a, eta = ds * h;
    double *Js = work, *UP = Js + N * N, *DP = UP + nm, *xi = DP + nm;
    const int forced = n_gain > 0;
    int nj = 0;
    memset(DP, 0, sizeof(double) * nm);
    ph_add_product(D, N, n_model, P, m, DP);       /* DP = A' Phi0 (+ F') */
    if (forced)
        for (int64_t q = 0; q < nm; ++q)
            DP[q] += DF[q];
    const double *F = Fa;
    const double *A = Ja;
    for (int st = 0; st < s; ++st) {
        double *KPs = KP + st * nm;
        /* the stage sums term by term over Phi's entries, each entry adding its terms in the
         * order j = 0, 1, ... (the numbers of a sum per entry; the inner loops vectorize) */
        memcpy(UP, P, sizeof(double) * nm);
        for (int j = 0; j < st; ++j) {
            const double a = tab->a[st * s + j];
            const double *KPj = KP + j * nm;
            for (int64_t q = 0; q < nm; ++q)
                UP[q] += a * KPj[q];
        }
        if (st > 0 && tab->nodes[st] != tab->nodes[st - 1]) {
            const double th = tab->nodes[st] == 1.0 ? th_b : th_a + tab->nodes[st] * ds;
            double *out = tab->nodes[st] == 1.0 ? A_end : Js;
            if (th == 1.0) {
                jac(t + h, y1, p, out);
                if (forced)
                    ph_forcing(t + h, y1, p, n_gain, gain, m, Fp, F_end);
            } else {
                ph_dense(nd, N, th, y, y1, E, xi);
                jac(t + th * h, xi, p, out);
                if (forced)
                    ph_forcing(t + th * h, xi, p, n_gain, gain, m, Fp, F_end);
            }
            A = out;
            F = F_end;
            nj += forced ? 2 : 1;
        }
        const double hd = eta * tab->d[st];
        double ce[PH_MAX_STAGES];      /* c_ij / eta: a division per stage, not per term */
        for (int j = 0; j < st; ++j)
            ce[j] = tab->c[st * s + j] / eta;
        for (int64_t q = 0; q < nm; ++q)
            KPs[q] = hd * DP[q];
        for (int j = 0; j < st; ++j) {
            const double *KPj = KP + j * nm;
            for (int64_t q = 0; q < nm; ++q)
                KPs[q] += ce[j] * KPj[q];
        }
        if (forced)
            for (int64_t q = 0; q < nm; ++q)
                KPs[q] += F[q];
        ph_add_product(A, N, n_model, UP, m, KPs);
        ph_lu_solve_rows(W, piv, nf, KPs, m);
    }
    if (A != A_end)
        memcpy(A_end, A, sizeof(double) * N * N);
    for (int64_t q = 0; q < nm; ++q)
        P1[q] = UP[q] + KP[(s - 1) * nm + q];
    return nj;
}

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC pop_options
#endif

#define PH_SUBSTEPS 400     /* at most this many sub-steps of Phi per step */
#define PH_THETA_MIN 1e-9   /* the smallest sub-step, in parts of the step */
#define PH_PHI_TOLERANCE 10.0   /* a sub-step's error estimate may be this many rtol (see
                                 * _PHI_TOLERANCE in rosenbrock_loop.py) */

/* Carry Phi (P, in place) over the accepted step from t to t + th_end h in sub-steps of its own
 * error control, the first *eta long (_variational_step of rosenbrock_loop.py: with the step's LU
 * W, piv for a whole step when nf > 0; nf = 0: none given); the step's dense output y, y1, E (nd
 * rows); A at the end into J_end (the next step's J when th_end = 1), the evaluations into
 * counts[0] (jac), counts[1] (rhs), counts[2] (LU), the largest error estimate accepted into
 * *worst, the next sub-step's length into *eta; n_gain, gain: the forcing of parameter columns
 * (jac_p evaluations counted with jac's). work: (s + 3) m N + 7 N x N + 6 N + PH_FORCING_WORK. */
#define PH_FORCING_WORK(nm, n_gain) (5 * (nm) + 2 * PH_N + PH_N * (n_gain))
static void ph_variational_step(const ph_tableau *tab, double t, double h, double th_end,
                                const double *y, const double *y1, const double *p,
                                const double *J, const double *f0, const double *W,
                                const int *piv, int nf, int nd, const double *E, double rtol,
                                const double *atol,
                                int64_t n_model, double expo, int64_t m, double *P,
                                double *J_end, int64_t *counts, double *worst, double *eta,
                                double *work, int64_t n_gain, const double *gain)
{
    const int N = PH_N;
    const int s = tab->s;
    const int64_t nm = m * N;
    double *KP = work, *P1 = KP + s * nm, *D = P1 + nm, *Ws = D + N * N, *Ja = Ws + N * N;
    double *Jb = Ja + N * N, *sc = Jb + N * N, *xa = sc + N, *fa = xa + N, *sub = fa + N;
    double *rate_work = sub + N * N + 2 * nm + N;
    /* the forcing: at the sub-step's start and end, its rate, work of ph_forcing_rate (whose
     * last N x n_gain serve ph_phi_substep's jac_p too) */
    double *Fa = rate_work + 2 * N * N + 2 * N, *Fb = Fa + nm, *DF = Fb + nm, *fwork = DF + nm;
    double *Fp = fwork + 2 * nm + 2 * N;
    const int forced = n_gain > 0;
    int pivs[PH_N];
    for (int i = 0; i < N; ++i)
        sc[i] = fmax(fabs(y[i]), atol[i] / rtol);
    memcpy(xa, y, sizeof(double) * N);
    memcpy(fa, f0, sizeof(double) * N);
    memcpy(Ja, J, sizeof(double) * N * N);
    double th_a = 0.0, ds = fmin(th_end, fmax(*eta / h, PH_THETA_MIN));
    int count = 0;
    *worst = 0.0;
    if (forced) {
        ph_forcing(t, y, p, n_gain, gain, m, Fp, Fa);
        counts[0] += 1;
    }
    while (th_a < th_end) {
        const int last = ds >= th_end - th_a;
        const double th_b = last ? th_end : th_a + ds, eta = (th_b - th_a) * h;
        counts[0] += ph_jac_rate(t + th_a * h, eta, xa, p, Ja, fa, sc, n_model, D, rate_work);
        if (forced)
            counts[0] += ph_forcing_rate(t + th_a * h, eta, xa, p, n_gain, gain, m, Fa, fa, sc,
                                         n_model, DF, fwork);
        const double *Wu = W;
        const int *pu = piv;
        int nfu = nf;
        if (!(th_a == 0.0 && th_b == 1.0 && nf > 0)) {
            nfu = ph_w_factor(Ja, eta * tab->gamma, n_model, Ws, pivs);
            counts[2] += 1;
            if (!nfu) {
                ds = 0.5 * (th_b - th_a);
                continue;
            }
            Wu = Ws;
            pu = pivs;
        }
        counts[0] += ph_phi_substep(tab, th_a, th_b, t, h, y, y1, p, nd, E, Ja, D, Wu, pu, nfu,
                                    n_model, m, P, KP, P1, Jb, sub, n_gain, gain, Fa, DF, Fb,
                                    Fp);
        double num = 0.0, den = 0.0;
        for (int64_t i = 0; i < n_model; ++i)
            for (int64_t c = 0; c < m; ++c) {
                const double e = KP[(s - 1) * nm + i * m + c] / sc[i], v = P1[i * m + c] / sc[i];
                num += e * e;
                den += v * v;
            }
        const double err = den > 0.0 ? sqrt(num / den) : 0.0, tol = PH_PHI_TOLERANCE * rtol;
        count += 1;
        if (err <= tol || th_b - th_a <= PH_THETA_MIN || count >= PH_SUBSTEPS) {
            memcpy(P, P1, sizeof(double) * nm);
            *worst = fmax(*worst, err);
            double *tmp = Ja;       /* A at the end of the sub-step: the next one's start */
            Ja = Jb;
            Jb = tmp;
            tmp = Fa;               /* the forcing too */
            Fa = Fb;
            Fb = tmp;
            th_a = th_b;
            if (th_a < th_end) {
                ph_dense(nd, N, th_a, y, y1, E, xa);
                rhs(t + th_a * h, xa, p, fa);
                counts[1] += 1;
            }
            const double fac = err == 0.0 ? 6.0 : fmin(6.0, fmax(0.2, 0.9 * pow(tol / err, expo)));
            ds = fmax(ds * fac, PH_THETA_MIN);
        } else {
            ds = fmax((th_b - th_a) * fmax(0.2, 0.9 * pow(tol / err, expo)), PH_THETA_MIN);
        }
    }
    memcpy(J_end, Ja, sizeof(double) * N * N);
    *eta = ds * h;
}

/* Events on (t, t + h] of the step from y to y1 with the dense output E (nd rows): the guards
 * at the step's end (into g_new) and at PH_SAMPLES interior points (g_old: at the step's start),
 * a sign change in a guard's direction located by the Illinois method on the dense output
 * (_locate_events of rosenbrock_loop.py). Non-terminal events are appended to ev_t / ev_k (*n_ev
 * of them so far, at most store_cap - 1). Returns the earliest terminal event's index or -1, its
 * time into *t_hit (t + h when none); yi: work (PH_N). */
static int64_t ph_locate_events(int nd, double t, double h, const double *y, const double *y1,
                                const double *E, const double *p, const double *g_old,
                                double *g_new, const int64_t *directions, const uint8_t *terminal,
                                int64_t g_count, int64_t store_cap, double *ev_t, int64_t *ev_k,
                                int64_t *n_ev, double *t_hit, double *yi)
{
    const int N = PH_N, NG = PH_NG;
    double g_a[PH_NG], g_b[PH_NG];
    int64_t hit = -1;
    const double t_new = t + h;
    *t_hit = t_new;
    guards(t_new, y1, p, g_new);
    memcpy(g_a, g_old, sizeof(double) * NG);
    double th_a = 0.0;
    for (int s_i = 1; s_i <= PH_SAMPLES + 1; ++s_i) {
        const double th_b = s_i / (PH_SAMPLES + 1.0);
        if (s_i <= PH_SAMPLES) {
            ph_dense(nd, N, th_b, y, y1, E, yi);
            guards(t + th_b * h, yi, p, g_b);
        } else {
            memcpy(g_b, g_new, sizeof(double) * NG);
        }
        for (int64_t k = 0; k < g_count; ++k) {
            const double a = g_a[k], b = g_b[k];
            const int up = a <= 0.0 && b >= 0.0, down = a >= 0.0 && b <= 0.0;
            const int64_t dk = directions[k];
            if (a == b || !((up && dk > 0) || (down && dk < 0) || ((up || down) && dk == 0)))
                continue;
            /* Illinois on theta in [th_a, th_b] */
            double lo = th_a, hi = th_b, glo = a, ghi = b, th = hi, gk[PH_NG];
            int side = 0;
            for (int it = 0; it < 100; ++it) {
                th = (lo * ghi - hi * glo) / (ghi - glo);
                ph_dense(nd, N, th, y, y1, E, yi);
                guards(t + th * h, yi, p, gk);
                const double gm = gk[k];
                if (gm == 0.0 || (hi - lo) * h < 4e-16 * fmax(fabs(t), 1.0))
                    break;
                if ((gm > 0.0) == (ghi > 0.0)) {
                    hi = th;
                    ghi = gm;
                    if (side == 1)
                        glo *= 0.5;
                    side = 1;
                } else {
                    lo = th;
                    glo = gm;
                    if (side == -1)
                        ghi *= 0.5;
                    side = -1;
                }
            }
            const double t_root = t + th * h;
            if (terminal[k]) {
                if (hit < 0 || t_root < *t_hit) {
                    hit = k;
                    *t_hit = t_root;
                }
            } else if (*n_ev < store_cap - 1) {
                ev_t[*n_ev] = t_root;
                ev_k[*n_ev] = k;
                *n_ev += 1;
            }
        }
        if (hit >= 0)
            break;
        memcpy(g_a, g_b, sizeof(double) * NG);
        th_a = th_b;
    }
    return hit;
}

static int rosenbrock(const ph_tableau *tab, PH_LOOP_PARAMS, PH_PHI_PARAMS)
{
    const int N = PH_N, NG = PH_NG;
    const int s = tab->s, nd = tab->m;
    const double gam = tab->gamma, expo = tab->expo;
    int64_t n_ev = 0, n_store = 0, nfev = 0, njev = 0, nlu = 0, nsteps = 0, hit = -1;
    int status = 0, nf = 0, piv[PH_N];
    double t = t0, h = h0, err = 0.0;
    double g_old[PH_NG];
    /* the work arrays, on the heap (large models would overflow a thread's stack) */
    double *work = malloc(sizeof(double) * (size_t)N * (2 * N + 2 * s + nd + 7));
    if (work == NULL)
        return 2;
    double *W = work, *J = W + N * N, *K = J + N * N, *U = K + s * N, *E = U + s * N;
    double *y = E + nd * N, *dT = y + N, *y1 = dT + N, *yi = y1 + N, *f0 = yi + N;
    double *f = f0 + N, *fT = f + N;
    /* the sensitivities' work arrays (m > 0); J_next: A at the end of the last step, made for
     * its Phi: the next step's J */
    const int64_t nm = m * N;
    double *P = NULL, *J_next = NULL, *vwork = NULL;
    int have_next = 0;
    int64_t vcounts[3] = {0, 0, 0};
    double eta_phi = 1e300;     /* the length of Phi's next sub-step (s): the whole step */
    if (m > 0 && (P = ph_phi_start(m, phi0, s, 0, n_gain, phi_error, work, &J_next,
                                   &vwork)) == NULL)
        return 2;
    memcpy(y, y0, sizeof(double) * N);
    memset(dT, 0, sizeof(double) * N);
    ph_start_guards(t, y, p, mask_index, mask_sign, g_old);
    rhs(t, y, p, f0);
    nfev += 1;
    if (h <= 0.0) {
        /* initial step from the scaled derivative (Hairer-Wanner II, p. 169, simplified) */
        double d0n = 0.0, d1n = 0.0;
        for (int64_t i = 0; i < n_model; ++i) {
            double sc = atol[i] + rtol * fabs(y[i]);
            d0n += (y[i] / sc) * (y[i] / sc);
            d1n += (f0[i] / sc) * (f0[i] / sc);
        }
        d0n = sqrt(d0n / (double)n_model);
        d1n = sqrt(d1n / (double)n_model);
        h = (d0n < 1e-5 || d1n < 1e-5) ? 1e-6 : 0.01 * d0n / d1n;
        if (hmax < h)
            h = hmax;
        if (t_end - t < h)
            h = t_end - t;
    }
    for (;;) {
        status = ph_stop_status(t, t_end, nsteps, max_steps, n_store, n_ev, store_cap);
        if (status >= 0)
            break;
        if (have_next) {
            memcpy(J, J_next, sizeof(double) * N * N);   /* jac(t, y, p) */
            have_next = 0;
        } else {
            jac(t, y, p, J);
            njev += 1;
        }
        if (tgrad_step > 0.0) {
            rhs(t + tgrad_step, y, p, fT);
            nfev += 1;
            for (int i = 0; i < N; ++i)
                dT[i] = (fT[i] - f0[i]) / tgrad_step;
        }
        int rejected = 0, underflow = 0;
        for (;;) {
            /* too small a step, unless it is the whole of what is left (t_end - t tiny) */
            if (!(h >= 1e-14 * fmax(fabs(t), 1.0)) && !(h >= t_end - t)) {   /* a NaN h too */
                underflow = 1;
                break;
            }
            if (t + h > t_end)
                h = t_end - t;
            nf = ph_w_factor(J, h * gam, n_model, W, piv);
            nlu += 1;
            if (!nf) {
                h *= 0.5;
                continue;
            }
            /* stages: U_i = y + sum_j a_ij K_j; W K_i = f(t + c_i h, U_i) + h d_i dT
             * + (sum_j C_ij K_j) / h */
            for (int st = 0; st < s; ++st) {
                const double *fs = f0;
                double *Ui = U + st * N, *Ki = K + st * N;
                if (st == 0) {
                    memcpy(Ui, y, sizeof(double) * N);
                } else {
                    for (int i = 0; i < N; ++i) {
                        double acc = y[i];
                        for (int j = 0; j < st; ++j)
                            acc += tab->a[st * s + j] * K[j * N + i];
                        Ui[i] = acc;
                    }
                    rhs(t + tab->nodes[st] * h, Ui, p, f);
                    nfev += 1;
                    fs = f;
                }
                for (int i = 0; i < N; ++i) {
                    double acc = 0.0;
                    for (int j = 0; j < st; ++j)
                        acc += tab->c[st * s + j] * K[j * N + i];
                    Ki[i] = fs[i] + h * tab->d[st] * dT[i] + acc / h;
                }
                ph_lu_solve(W, piv, nf, Ki);
            }
            /* error norm over all states, the ledger quadratures included; atol per state */
            const double *Us = U + (s - 1) * N, *Ks = K + (s - 1) * N;
            int finite = 1;
            err = 0.0;
            for (int i = 0; i < N; ++i) {
                y1[i] = Us[i] + Ks[i];
                if (!isfinite(y1[i]))
                    finite = 0;
                double sc = atol[i] + rtol * fmax(fabs(y[i]), fabs(y1[i]));
                err += (Ks[i] / sc) * (Ks[i] / sc);
            }
            err = finite ? sqrt(err / N) : 1e300;
            if (err <= 1.0)
                break;
            rejected = 1;
            h *= fmax(0.2, 0.9 * pow(err, -expo));
        }
        if (underflow) {
            status = 2;
            break;
        }
        /* accepted step t -> t + h */
        nsteps += 1;
        /* a step that ends within the smallest step size of t_end ends at t_end exactly (a
         * breakpoint: a sampling instant, an input sample; else the remainder would fail) */
        const double t_new = (t_end - (t + h) < 1e-14 * fmax(fabs(t_end), 1.0)) ? t_end : t + h;
        for (int r = 0; r < nd; ++r)
            for (int i = 0; i < N; ++i) {
                double acc = 0.0;
                for (int j = 0; j < s; ++j)
                    acc += tab->h[r * s + j] * K[j * N + i];
                E[r * N + i] = acc;
            }
        double big = 0.0;
        for (int64_t i = 0; i < n_model; ++i)
            big = fmax(big, fabs(y1[i]));
        if (!(big <= bound)) {
            status = 3;
            break;
        }
        /* events on (t, t_new], Phi over the step (its last A is the next step's J), the point */
        hit = ph_finish_step(t, h, t_new, y, y1, nd, E, tab, J, f0, W, piv, nf, J_next,
                             PH_FINISH_ARGS);
        if (hit >= 0) {
            status = 1;
            break;
        }
        have_next = m > 0;
        rhs(t, y, p, f0);
        nfev += 1;
        double fac = err > 0.0 ? fmin(6.0, fmax(0.2, 0.9 * pow(err, -expo))) : 6.0;
        if (rejected)
            fac = fmin(fac, 1.0);
        h = fmin(h * fac, hmax);
    }
    return ph_loop_end(status, t, h, y, n_store, nfev, njev, nsteps, hit, n_ev, nlu, vcounts, m,
                       P, out_th, out_y, counts, phi_out, P, work);
}

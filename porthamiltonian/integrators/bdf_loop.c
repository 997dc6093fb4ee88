/* Template, not compiled alone: appended by porthamiltonian.backends after rosenbrock_loop.c
 * (whose ph_w_factor, ph_lu_solve and ph_dense it calls), common_loop.c (the start, the checks,
 * the end of a step and the results shared with the Rosenbrock loop) and the methods' tables; the exported entry points ph_integrate_qbdf and
 * ph_integrate_qbdf_variational follow it (porthamiltonian/integrators/bdf.py). It is
 * bdf_loop.py in C, step for step (same history, Newton iteration, reuse rules, error test,
 * order and step-size choice, dense output and statuses): a change there is made here too; the
 * method and its rules are described in bdf_loop.py's header. Arguments and results as the
 * Rosenbrock entry points' (rosenbrock_loop.c); tgrad_step is not used. */

#define PH_BDF_MAX_ORDER 5
#define PH_NEWTON_ITERS 3
#define PH_NEWTON_COEF 0.1
#define PH_DIVERGE 2.0
#define PH_RATE_DOWN 0.3
#define PH_GAMMA_CHANGE 0.3
#define PH_LU_AGE_MAX 20
#define PH_JAC_AGE_MAX 50
#define PH_GROW_MIN 1.5
#define PH_GROW_MAX 10.0
#define PH_SHRINK_MIN 0.2
#define PH_SAFETY 0.9

/* Change the step size of the history D (rows 0..order, PH_N columns) by factor
 * (_bdf_rescale of bdf_loop.py: D <- (R U)^T D) */
static void ph_bdf_rescale(double *D, int order, double factor)
{
    const int N = PH_N;
    enum { Q = PH_BDF_MAX_ORDER + 1 };
    const int q1 = order + 1;
    double R[Q][Q], U[Q][Q], RU[Q][Q], old[Q * PH_N];
    for (int j = 0; j < q1; ++j) {
        R[0][j] = 1.0;
        U[0][j] = 1.0;
    }
    for (int i = 1; i < q1; ++i) {
        R[i][0] = 0.0;
        U[i][0] = 0.0;
        for (int j = 1; j < q1; ++j) {
            R[i][j] = R[i - 1][j] * (i - 1 - factor * j) / i;
            U[i][j] = U[i - 1][j] * (i - 1 - j) / i;
        }
    }
    for (int i = 0; i < q1; ++i)
        for (int j = 0; j < q1; ++j) {
            double acc = 0.0;
            for (int k = 0; k < q1; ++k)
                acc += R[i][k] * U[k][j];
            RU[i][j] = acc;
        }
    memcpy(old, D, sizeof(double) * q1 * N);
    for (int j = 0; j < q1; ++j)
        for (int i = 0; i < N; ++i) {
            double acc = 0.0;
            for (int k = 0; k < q1; ++k)
                acc += RU[k][j] * old[k * N + i];
            D[j * N + i] = acc;
        }
}

/* The step's dense output from D after the step, as ph_dense reads it (_bdf_dense of
 * bdf_loop.py); E: nd rows, those past order - 2 zero */
static void ph_bdf_dense(const double *D, int order, int nd, double *E)
{
    const int N = PH_N;
    enum { Q = PH_BDF_MAX_ORDER + 1 };
    double B[Q][Q];
    memset(B, 0, sizeof(B));
    B[0][0] = 1.0;
    for (int j = 1; j <= order; ++j)
        for (int k = 0; k <= j; ++k) {
            double acc = (j - 2.0) * B[j - 1][k];
            if (k > 0)
                acc += B[j - 1][k - 1];
            B[j][k] = acc / j;
        }
    for (int i = 0; i < N; ++i) {
        double acc = 0.0;               /* sum of c_k' over k' >= k, k from the top down */
        for (int k = order; k > 1; --k) {
            double ck = 0.0;
            for (int j = k; j <= order; ++j)
                ck += B[j][k] * D[j * N + i];
            acc += ck;
            E[(k - 2) * N + i] = -acc;
        }
        for (int r = order > 1 ? order - 1 : 0; r < nd; ++r)
            E[r * N + i] = 0.0;
    }
}

/* The RMS norm of v_i / w_i over i < n */
static double ph_rms(const double *v, const double *w, int n)
{
    double acc = 0.0;
    for (int i = 0; i < n; ++i)
        acc += (v[i] / w[i]) * (v[i] / w[i]);
    return sqrt(acc / n);
}

/* The first step of order 1 (_bdf_first_step of bdf_loop.py); one rhs evaluation; work: 3 PH_N */
static double ph_bdf_first_step(double t, const double *y, const double *f0, const double *p,
                                double rtol, const double *atol, double h0, double hmax,
                                double t_end, double *work)
{
    const int N = PH_N;
    double *sc = work, *y1 = sc + N, *f1 = y1 + N;
    for (int i = 0; i < N; ++i)
        sc[i] = atol[i] + rtol * fabs(y[i]);
    const double d0 = ph_rms(y, sc, N), d1 = ph_rms(f0, sc, N);
    double h = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    h = fmin(h, fmin(hmax, t_end - t));
    for (int i = 0; i < N; ++i)
        y1[i] = y[i] + h * f0[i];
    rhs(t + h, y1, p, f1);
    for (int i = 0; i < N; ++i)
        y1[i] = f1[i] - f0[i];
    const double d2 = ph_rms(y1, sc, N) / h, big = fmax(d1, d2);
    const double h1 = big <= 1e-15 ? fmax(1e-6, h * 1e-3) : sqrt(0.01 / big);
    h = fmin(fmin(100.0 * h, h1), fmin(hmax, t_end - t));
    if (h0 > 0.0)
        h = fmin(h, h0);
    return h;
}

static int bdf(const ph_tableau *phi_tab, PH_LOOP_PARAMS, PH_PHI_PARAMS)
{
    const int N = PH_N, NG = PH_NG;
    enum { QR = PH_BDF_MAX_ORDER + 3, ND = PH_BDF_MAX_ORDER - 1 };
    (void)tgrad_step;
    int64_t n_ev = 0, n_store = 0, nfev = 0, njev = 0, nlu = 0, nsteps = 0, hit = -1;
    int status = 0, nb = 0, piv[PH_N];
    double t = t0, g_old[PH_NG], gsum[PH_BDF_MAX_ORDER + 1];
    double *work = malloc(sizeof(double) * (size_t)N * (QR + ND + 2 * N + 13));
    if (work == NULL)
        return 2;
    double *D = work, *E = D + QR * N, *W = E + ND * N, *J = W + N * N, *y = J + N * N;
    double *sc = y + N, *yp = sc + N, *psi = yp + N, *d = psi + N, *dy = d + N, *yk = dy + N;
    double *yi = yk + N, *f = yi + N, *f0 = f + N, *fwork = f0 + N;   /* fwork: 3 N */
    /* the sensitivities' work arrays (m > 0): J_phi, A at the start of the step (the last Phi
     * step's end), f_phi = rhs there */
    const int64_t nm = m * N;
    double *P = NULL, *J_phi = NULL, *f_phi = NULL, *vwork = NULL;
    int have_phi_jac = 0;
    int64_t vcounts[3] = {0, 0, 0};
    double eta_phi = 1e300;
    if (m > 0) {
        P = ph_phi_start(m, phi0, phi_tab->s, N, n_gain, phi_error, work, &J_phi, &vwork);
        if (P == NULL)
            return 2;
        f_phi = J_phi + N * N;      /* the loop's own N */
    }
    gsum[0] = 0.0;
    for (int q = 1; q <= PH_BDF_MAX_ORDER; ++q)
        gsum[q] = gsum[q - 1] + 1.0 / q;
    memcpy(y, y0, sizeof(double) * N);
    memset(D, 0, sizeof(double) * QR * N);
    ph_start_guards(t, y, p, mask_index, mask_sign, g_old);
    rhs(t, y, p, f0);
    nfev += 1;
    double h = ph_bdf_first_step(t, y, f0, p, rtol, atol, h0, hmax, t_end, fwork);
    nfev += 1;
    for (int i = 0; i < N; ++i) {
        D[i] = y[i];
        D[N + i] = h * f0[i];
    }
    int order = 1, n_equal = 0, jac_age = 0, lu_age = 0;
    jac(t, y, p, J);
    njev += 1;
    double c_lu = 0.0, rate = 1.0, err = 0.0, t_new = t;
    for (;;) {
        status = ph_stop_status(t, t_end, nsteps, max_steps, n_store, n_ev, store_cap);
        if (status >= 0)
            break;
        int last = t + h >= t_end;
        if (last && t + h != t_end) {
            ph_bdf_rescale(D, order, (t_end - t) / h);
            h = t_end - t;
            n_equal = 0;
        }
        for (int i = 0; i < N; ++i)
            sc[i] = atol[i] + rtol * fabs(y[i]);
        int underflow = 0;
        for (;;) {
            if (!(h >= 1e-14 * fmax(fabs(t), 1.0)) && !(h >= t_end - t)) {   /* unless it is all that is
                                                                          * left; a NaN h too */
                underflow = 1;
                break;
            }
            t_new = last ? t_end : t + h;
            const double c = h / gsum[order];
            for (int i = 0; i < N; ++i) {
                double acc = 0.0, acc_psi = 0.0;
                for (int j = order; j > 0; --j) {
                    acc += D[j * N + i];
                    acc_psi += gsum[j] * D[j * N + i];
                }
                yp[i] = acc + D[i];
                psi[i] = acc_psi / gsum[order];
            }
            if (c_lu == 0.0 || fabs(c / c_lu - 1.0) > PH_GAMMA_CHANGE || lu_age >= PH_LU_AGE_MAX) {
                if (jac_age >= PH_JAC_AGE_MAX) {
                    jac(t_new, yp, p, J);
                    njev += 1;
                    jac_age = 0;
                }
                nb = ph_w_factor(J, c, n_model, W, piv);       /* I/c - J */
                nlu += 1;
                lu_age = 0;
                rate = 1.0;
                if (!nb) {
                    c_lu = 0.0;
                    ph_bdf_rescale(D, order, 0.25);
                    h *= 0.25;
                    n_equal = 0;
                    last = 0;
                    continue;
                }
                c_lu = c;
            }
            /* the modified Newton iteration on d */
            int converged = 0;
            double del_old = 0.0;
            for (int i = 0; i < N; ++i) {
                d[i] = 0.0;
                yk[i] = yp[i];
            }
            for (int it = 0; it < PH_NEWTON_ITERS; ++it) {
                rhs(t_new, yk, p, f);
                nfev += 1;
                for (int i = 0; i < N; ++i)
                    dy[i] = (c * f[i] - psi[i] - d[i]) / c_lu;
                ph_lu_solve(W, piv, nb, dy);
                if (c != c_lu) {
                    const double scale = 2.0 / (1.0 + c / c_lu);
                    for (int i = 0; i < N; ++i)
                        dy[i] *= scale;
                }
                const double dl = ph_rms(dy, sc, N);
                if (!isfinite(dl))
                    break;
                for (int i = 0; i < N; ++i) {
                    yk[i] += dy[i];
                    d[i] += dy[i];
                }
                if (it > 0) {
                    rate = fmax(PH_RATE_DOWN * rate, dl / del_old);
                    if (dl > PH_DIVERGE * del_old)
                        break;
                }
                if (dl * fmin(1.0, rate) / (order + 1.0) <= PH_NEWTON_COEF) {
                    converged = 1;
                    break;
                }
                del_old = dl;
            }
            if (!converged) {
                if (jac_age > 0) {      /* a stale J: the same step with a new one */
                    jac(t_new, yp, p, J);
                    njev += 1;
                    jac_age = 0;
                    c_lu = 0.0;
                    continue;
                }
                ph_bdf_rescale(D, order, 0.25);
                h *= 0.25;
                n_equal = 0;
                c_lu = 0.0;
                last = 0;
                continue;
            }
            err = ph_rms(d, sc, N) / (order + 1.0);
            if (err > 1.0) {
                const double fac = fmax(PH_SHRINK_MIN, PH_SAFETY * pow(err, -1.0 / (order + 1.0)));
                ph_bdf_rescale(D, order, fac);
                h *= fac;
                n_equal = 0;
                c_lu = 0.0;
                last = 0;
                continue;
            }
            break;
        }
        if (underflow) {
            status = 2;
            break;
        }
        /* accepted step t -> t_new */
        nsteps += 1;
        n_equal += 1;
        jac_age += 1;
        lu_age += 1;
        for (int i = 0; i < N; ++i) {
            D[(order + 2) * N + i] = d[i] - D[(order + 1) * N + i];
            D[(order + 1) * N + i] = d[i];
        }
        for (int j = order; j >= 0; --j)
            for (int i = 0; i < N; ++i)
                D[j * N + i] += D[(j + 1) * N + i];
        ph_bdf_dense(D, order, ND, E);
        int finite = 1;
        double big = 0.0;
        for (int i = 0; i < N; ++i)
            if (!isfinite(yk[i]))
                finite = 0;
        for (int64_t i = 0; i < n_model; ++i)
            big = fmax(big, fabs(yk[i]));
        if (!(finite && big <= bound)) {
            status = 3;
            break;
        }
        const double hh = t_new - t;
        if (m > 0) {
            if (!have_phi_jac) {
                jac(t, y, p, J_phi);
                njev += 1;
            }
            rhs(t, y, p, f_phi);
            nfev += 1;
        }
        /* events on (t, t_new], Phi over the step (its last A is J at the next step's start), the point */
        hit = ph_finish_step(t, hh, t_new, y, yk, ND, E, phi_tab, J_phi, f_phi, W, piv, 0, J_phi,
                             PH_FINISH_ARGS);
        if (hit >= 0) {
            status = 1;
            break;
        }
        have_phi_jac = m > 0;
        /* the next step's order and size */
        if (n_equal < order + 1)
            continue;
        for (int i = 0; i < N; ++i)
            sc[i] = atol[i] + rtol * fabs(y[i]);
        double best = err > 0.0 ? PH_SAFETY * pow(err, -1.0 / (order + 1.0)) : PH_GROW_MAX;
        int change = 0;
        if (order > 1) {
            const double e_down = ph_rms(D + order * N, sc, N) / order;
            const double fac = e_down > 0.0 ? PH_SAFETY * pow(e_down, -1.0 / order) : PH_GROW_MAX;
            if (fac > best) {
                best = fac;
                change = -1;
            }
        }
        if (order < PH_BDF_MAX_ORDER) {
            const double e_up = ph_rms(D + (order + 2) * N, sc, N) / (order + 2.0);
            const double fac = e_up > 0.0 ? PH_SAFETY * pow(e_up, -1.0 / (order + 2.0))
                                          : PH_GROW_MAX;
            if (fac > best) {
                best = fac;
                change = 1;
            }
        }
        n_equal = 0;
        if (change == 0 && best < PH_GROW_MIN)
            continue;
        order += change;
        const double fac = fmin(best, fmin(PH_GROW_MAX, hmax / h));
        ph_bdf_rescale(D, order, fac);
        h *= fac;
    }
    return ph_loop_end(status, t, h, y, n_store, nfev, njev, nsteps, hit, n_ev, nlu, vcounts, m,
                       P, out_th, out_y, counts, phi_out, P, work);
}

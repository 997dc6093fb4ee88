/* Template, not compiled alone: inserted by porthamiltonian.backends into rosenbrock_loop.c
 * after its helpers (ph_dense, ph_locate_events and ph_variational_step, which it calls) and
 * before its loop rosenbrock; the entry points and bdf_loop.c follow. The pieces every step
 * loop shares (rosenbrock and bdf): the guards at the start, the checks before each step, the
 * end of an accepted step (events, Phi, the stored point) and the results. It is
 * common_loop.py in C: a change there is made here too. */

/* The guards at the start (t, y) into g_old, the one of mask_index (>= 0: an event just handled
 * there) given the sign mask_sign, so that it does not fire again at once (_loop_start of
 * common_loop.py) */
static void ph_start_guards(double t, const double *y, const double *p, int64_t mask_index,
                            double mask_sign, double *g_old)
{
    guards(t, y, p, g_old);
    if (mask_index >= 0) {
        double g = fabs(g_old[mask_index]);
        g_old[mask_index] = mask_sign * (g > 1e-300 ? g : 1e-300);
    }
}

/* The sensitivities' work of a loop with m > 0 columns, one block (returned; NULL, and the loop's
 * `work` freed, when out of memory): P (PH_N x m, a copy of phi0), A at the end of Phi's last
 * step (*J_end, PH_N x PH_N), `extra` doubles of the loop's own, then ph_variational_step's work
 * (*vwork) for Phi's method of s stages; phi_error[0] reset */
static double *ph_phi_start(int64_t m, const double *phi0, int s, int extra, int64_t n_gain,
                            double *phi_error, double *work, double **J_end, double **vwork)
{
    const int N = PH_N;
    const int64_t nm = m * N;
    double *P = malloc(sizeof(double) * (size_t)(nm * (s + 4) + 8 * N * N + 6 * N + extra
                                                 + PH_FORCING_WORK(nm, n_gain)));
    if (P == NULL) {
        free(work);
        return NULL;
    }
    *J_end = P + nm;
    *vwork = *J_end + N * N + extra;
    memcpy(P, phi0, sizeof(double) * nm);
    phi_error[0] = 0.0;
    return P;
}

/* The status that ends a loop before its next step from t: 0 t_end reached, 4 max_steps steps
 * taken, 5 a buffer full; -1: go on (_stop_status of common_loop.py) */
static int ph_stop_status(double t, double t_end, int64_t nsteps, int64_t max_steps,
                          int64_t n_store, int64_t n_ev, int64_t store_cap)
{
    if (t >= t_end)
        return 0;
    if (nsteps >= max_steps)
        return 4;
    if (n_store >= store_cap - 1 || n_ev >= store_cap - 1)
        return 5;
    return -1;
}

/* ph_finish_step's arguments from p on: the loop's state, under the same names in both loops
 * (their parameters PH_LOOP_PARAMS, PH_PHI_PARAMS and their own variables) */
#define PH_FINISH_ARGS p, g_old, directions, terminal, g_count, store_cap, ev_t, ev_k, &n_ev, yi, \
    rtol, atol, n_model, m, P, vcounts, &eta_phi, vwork, n_gain, gain, phi_error, ts, ys, phis, \
    &n_store, &t

/* The end of the accepted step of length h from (t, y) to (t_new, y1), E its dense output (nd
 * rows): its events located (ph_locate_events; g_old moves to the step's end unless a terminal
 * one is hit), then, with m > 0, Phi (P) carried to the earliest terminal event or to the
 * step's end by the method tab (ph_variational_step from A = J and f0 at t, with the step's LU
 * W, piv of nb rows, 0: none; A at its end into J_end, its evaluations added to vcounts, its
 * largest error estimate to phi_error[0]), and the point there stored at *n_store (then
 * counted) of ts, ys, phis and copied into y (_finish_step of common_loop.py). Returns the
 * terminal event's index or -1; the point's time into *t_out; yi: work (PH_N). The loops pass
 * the arguments from p on as PH_FINISH_ARGS. */
static int64_t ph_finish_step(double t, double h, double t_new, double *y, const double *y1,
                              int nd, const double *E, const ph_tableau *tab, const double *J,
                              const double *f0, const double *W, const int *piv, int nb,
                              double *J_end, const double *p, double *g_old,
                              const int64_t *directions, const uint8_t *terminal,
                              int64_t g_count, int64_t store_cap, double *ev_t, int64_t *ev_k,
                              int64_t *n_ev, double *yi, double rtol, const double *atol,
                              int64_t n_model, int64_t m, double *P, int64_t *vcounts,
                              double *eta_phi, double *vwork, int64_t n_gain, const double *gain,
                              double *phi_error, double *ts, double *ys, double *phis,
                              int64_t *n_store, double *t_out)
{
    const int N = PH_N, NG = PH_NG;
    double g_new[PH_NG], t_hit = t_new, th_end = 1.0;
    const double *y_end = y1;
    int64_t hit = -1;
    if (g_count > 0) {
        hit = ph_locate_events(nd, t, h, y, y1, E, p, g_old, g_new, directions, terminal,
                               g_count, store_cap, ev_t, ev_k, n_ev, &t_hit, yi);
        if (hit >= 0) {
            th_end = (t_hit - t) / h;
            ph_dense(nd, N, th_end, y, y1, E, yi);
            y_end = yi;
        } else {
            memcpy(g_old, g_new, sizeof(double) * NG);
        }
    }
    if (m > 0) {
        double worst = 0.0;
        ph_variational_step(tab, t, h, th_end, y, y1, p, J, f0, W, piv, nb, nd, E, rtol, atol,
                            n_model, tab->expo, m, P, J_end, vcounts, &worst, eta_phi, vwork,
                            n_gain, gain);
        phi_error[0] = fmax(phi_error[0], worst);
        memcpy(phis + *n_store * N * m, P, sizeof(double) * N * m);
    }
    ts[*n_store] = t_hit;
    memcpy(ys + *n_store * N, y_end, sizeof(double) * N);
    *n_store += 1;
    memcpy(y, y_end, sizeof(double) * N);
    *t_out = t_hit;
    return hit;
}

/* A loop's results at its end (t, h, y; the counters, Phi's own added; hit: the terminal
 * event's index) into out_th, out_y, counts and phi_out, its work arrays (P's block: pwork)
 * freed; returns status */
static int ph_loop_end(int status, double t, double h, const double *y, int64_t n_store,
                       int64_t nfev, int64_t njev, int64_t nsteps, int64_t hit, int64_t n_ev,
                       int64_t nlu, const int64_t *vcounts, int64_t m, const double *P,
                       double *out_th, double *out_y, int64_t *counts, double *phi_out,
                       double *pwork, double *work)
{
    out_th[0] = t;
    out_th[1] = h;
    memcpy(out_y, y, sizeof(double) * PH_N);
    counts[0] = n_store;
    counts[1] = nfev + vcounts[1];
    counts[2] = njev + vcounts[0];
    counts[3] = nsteps;
    counts[4] = status == 1 ? hit : -1;
    counts[5] = n_ev;
    counts[6] = nlu + vcounts[2];
    if (m > 0)
        memcpy(phi_out, P, sizeof(double) * PH_N * m);
    free(pwork);
    free(work);
    return status;
}

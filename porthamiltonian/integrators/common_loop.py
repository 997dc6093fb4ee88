# Template, not imported: appended by porthamiltonian.backends to the loop modules (see
# rosenbrock_loop.py's header: ``fn``, the model's functions) after rosenbrock_loop.py (whose _dense, _locate_events and _variational_step it calls) and before
# the methods' entry points and bdf_loop.py. The pieces every step loop shares (the Rosenbrock
# loop _rosenbrock and the BDF loop _bdf): the result buffers and the guards at the start, the
# checks before each step, and the end of an accepted step (events, Φ, the stored point).
# common_loop.c is the same in C: a change here is made there too.
#
# _finish_step must stay the last function: porthamiltonian/integrators/__init__.py copies it as
# _finish_step_plain (Φ's step replaced by _no_variational) for the loops' copies without Φ.


@_jit
def _loop_start(fn, t, y0, p, n_guards, mask_index, mask_sign, store_cap, phi0):
    """A loop's state, buffers and guards at the start (t, y0): returns (y: a copy of y0; ts,
    ys, ev_t, ev_k: the stored points and the non-terminal events, store_cap of each; P: Φ
    flattened by rows, a copy of phi0 (n x m); phis: Φ at the stored points; g_old: the n_guards
    guards at (t, y0), the one of mask_index (>= 0: an event just handled there) given the sign
    mask_sign, so that it does not fire again at once)."""
    y = y0.copy()
    n = y.shape[0]
    nm = n * phi0.shape[1]
    guards = fn[2]
    g_old = guards(t, y, p)[:n_guards].copy()
    if mask_index >= 0:
        g_old[mask_index] = mask_sign * max(abs(g_old[mask_index]), 1e-300)
    return (y, np.empty(store_cap), np.empty((store_cap, n)), np.empty(store_cap),
            np.empty(store_cap, dtype=np.int64), phi0.copy().reshape(nm),
            np.empty((store_cap, nm)), g_old)


@_jit
def _stop_status(t, t_end, nsteps, max_steps, n_store, n_ev, store_cap):
    """The status that ends a loop before its next step from t: 0 t_end reached, 4 max_steps
    steps taken, 5 a buffer full (n_store points or n_ev events of store_cap - 1); -1: go on."""
    if t >= t_end:
        return 0
    if nsteps >= max_steps:
        return 4
    if n_store >= store_cap - 1 or n_ev >= store_cap - 1:
        return 5
    return -1


@_jit
def _finish_step(fn, t, h, t_new, y, y1, E, p, g_old, directions, terminal, ev_t, ev_k, n_ev, yi, J,
                 f0, W, piv, nb, TA, TC, TN, TD, gam, expo, rtol, atol, n_model, P, eta_phi, gain,
                 ts, ys, phis, n_store, njev, nfev, nlu, phi_err):
    """The end of the accepted step of length h from (t, y) to (t_new, y1), E its dense output
    (_dense): its events located (_locate_events; non-terminal ones appended to ev_t, ev_k),
    then Φ (P, when it has columns) carried to the earliest terminal event or to the step's end
    by the Rosenbrock method TA..TD, gam, expo (_variational_step, from A = J and f0 at t, with
    the step's LU W, piv of nb rows; nb = 0: none), and the point there stored at n_store of ts,
    ys, phis and copied into y (yi: work space). Returns (the terminal event's index or -1, the
    point's time, n_ev, n_store + 1, the guards at t_new, the counters njev, nfev, nlu with Φ's
    jac, rhs evaluations and LU factorizations added, A at the end of Φ's step, phi_err or Φ's
    largest error estimate when larger, the length of Φ's next sub-step)."""
    hit = -1
    t_hit = t_new
    g_new = g_old
    if directions.shape[0] > 0:
        hit, t_hit, n_ev, g_new = _locate_events(fn, t, h, y, y1, E, p, g_old, directions, terminal,
                                                 ev_t, ev_k, n_ev, yi)
    th_end = 1.0
    y_end = y1
    if hit >= 0:
        th_end = (t_hit - t) / h
        _dense(th_end, y, y1, E, yi)
        y_end = yi
    nj = 0
    nf = 0
    nl = 0
    worst = 0.0
    J_end = J
    if P.shape[0] > 0:
        nj, nf, nl, J_end, worst, eta_phi = _variational_step(
            fn, t, h, th_end, y, y1, p, J, f0, W, piv, nb, E, TA, TC, TN, TD, gam, expo, rtol, atol,
            n_model, P, eta_phi, gain)
    ts[n_store] = t_hit
    ys[n_store, :] = y_end
    phis[n_store, :] = P
    y[:] = y_end
    return (hit, t_hit, n_ev, n_store + 1, g_new, njev + nj, nfev + nf, nlu + nl, J_end,
            max(phi_err, worst), eta_phi)

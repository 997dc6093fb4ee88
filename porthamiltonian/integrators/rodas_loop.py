# Template, not imported: appended by porthamiltonian.compiler.codegen to each generated model
# module, where ``rhs``, ``jac``, ``guards``, ``np``, ``math`` and ``_jit`` are defined.
#
# Rodas4: a 6-stage, order-4, L-stable, stiffly accurate Rosenbrock method with an embedded
# order-3 error estimate and an order-3 dense output (Hairer & Wanner, Solving ODEs II, 2nd ed.,
# §IV.7, and their RODAS code; coefficients of the "Rodas4" set, γ = 1/4). Each step forms
# W = I/(hγ) − J once, factors it (LU with partial pivoting) and solves six linear systems.
# Events: after each accepted step the guards are evaluated; a sign change in the wanted
# direction is located on the dense output by the Illinois (regula falsi) method.

_R_GAMMA = 0.25
_R_SAMPLES = 3  # interior guard samples per step
_R_A = (1.544, 0.9466785280815826, 0.2557011698983284, 3.314825187068521, 2.896124015972201,
        0.9986419139977817, 1.221224509226641, 6.019134481288629, 12.53708332932087,
        -0.687886036105895)
_R_C = (-5.6688, -2.430093356833875, -0.2063599157091915, -0.1073529058151375, -9.594562251023355,
        -20.47028614809616, 7.496443313967647, -10.24680431464352, -33.99990352819905,
        11.7089089320616, 8.083246795921522, -7.981132988064893, -31.52159432874371,
        16.31930543123136, -6.058818238834054)
_R_CT = (0.386, 0.21, 0.63)
_R_D = (0.25, -0.1043, 0.1035, -0.0362)
_R_H = (10.12623508344586, -7.487995877610167, -34.80091861555747, -7.992771707568823,
        1.025137723295662, -0.6762803392801253, 6.087714651680015, 16.43084320892478,
        24.76722511418386, -6.594389125716872)


@_jit
def _lu_factor(A, piv):
    n = A.shape[0]
    for k in range(n):
        m = k
        big = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                m = i
        piv[k] = m
        if big == 0.0:
            return False
        if m != k:
            for j in range(n):
                tmp = A[k, j]
                A[k, j] = A[m, j]
                A[m, j] = tmp
        for i in range(k + 1, n):
            A[i, k] /= A[k, k]
            f = A[i, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= f * A[k, j]
    return True


@_jit
def _lu_solve(A, piv, b):
    n = A.shape[0]
    for k in range(n):
        m = piv[k]
        if m != k:
            tmp = b[k]
            b[k] = b[m]
            b[m] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= A[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= A[i, j] * b[j]
        b[i] = s / A[i, i]


@_jit
def _dense(theta, y0, y1, d1, d2, out):
    for i in range(y0.shape[0]):
        out[i] = (1.0 - theta) * y0[i] + theta * (y1[i] + (1.0 - theta) * (d1[i] + theta * d2[i]))


@_jit
def rodas_integrate(t0, y0, t_end, p, rtol, atol, h0, hmax, directions, terminal, mask_index,
                    mask_sign, n_model, bound, max_steps, store_cap, tgrad_step):
    """Integrate from (t0, y0) to t_end or the first terminal event.

    Returns (status, t, y, ts, ys, n_store, nfev, njev, nsteps, event_index, ev_t, ev_k, n_ev, h):
    status 0 reached t_end, 1 terminal event ``event_index``, 2 step-size underflow or singular
    W, 3 divergence (max|x| > bound or non-finite), 4 max_steps, 5 store buffer full (call again
    from the returned t, y with the returned h). ``ts``/``ys`` hold the accepted steps,
    ``ev_t``/``ev_k`` the non-terminal events found.
    """
    n = y0.shape[0]
    g_count = directions.shape[0]
    A = _R_A
    C = _R_C
    CT = _R_CT
    D = _R_D
    H = _R_H
    gam = _R_GAMMA
    ts = np.empty(store_cap)
    ys = np.empty((store_cap, n))
    ev_t = np.empty(store_cap)
    ev_k = np.empty(store_cap, dtype=np.int64)
    n_ev = 0
    n_store = 0
    nfev = 0
    njev = 0
    nsteps = 0
    t = t0
    y = y0.copy()
    W = np.empty((n, n))
    piv = np.empty(n, dtype=np.int64)
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    k5 = np.empty(n)
    k6 = np.empty(n)
    ut = np.empty(n)
    dT = np.zeros(n)
    y1 = np.empty(n)
    d1 = np.empty(n)
    d2 = np.empty(n)
    yi = np.empty(n)
    g_old = guards(t, y, p)[:g_count].copy()
    if mask_index >= 0:
        g_old[mask_index] = mask_sign * max(abs(g_old[mask_index]), 1e-300)
    h = h0
    f0 = rhs(t, y, p)
    nfev += 1
    if h <= 0.0:
        # initial step from the scaled derivative (Hairer-Wanner II, p. 169, simplified)
        d0n = 0.0
        d1n = 0.0
        for i in range(n_model):
            sc = atol[i] + rtol * abs(y[i])
            d0n += (y[i] / sc) ** 2
            d1n += (f0[i] / sc) ** 2
        d0n = math.sqrt(d0n / n_model)
        d1n = math.sqrt(d1n / n_model)
        h = 1e-6 if (d0n < 1e-5 or d1n < 1e-5) else 0.01 * d0n / d1n
        h = min(h, hmax, t_end - t)
    while True:
        if t >= t_end:
            return 0, t, y, ts, ys, n_store, nfev, njev, nsteps, -1, ev_t, ev_k, n_ev, h
        if nsteps >= max_steps:
            return 4, t, y, ts, ys, n_store, nfev, njev, nsteps, -1, ev_t, ev_k, n_ev, h
        if n_store >= store_cap - 1 or n_ev >= store_cap - 1:
            return 5, t, y, ts, ys, n_store, nfev, njev, nsteps, -1, ev_t, ev_k, n_ev, h
        J = jac(t, y, p)
        njev += 1
        if tgrad_step > 0.0:
            fT = rhs(t + tgrad_step, y, p)
            nfev += 1
            for i in range(n):
                dT[i] = (fT[i] - f0[i]) / tgrad_step
        rejected = False
        while True:
            if h < 1e-14 * max(abs(t), 1.0):
                return 2, t, y, ts, ys, n_store, nfev, njev, nsteps, -1, ev_t, ev_k, n_ev, h
            if t + h > t_end:
                h = t_end - t
            inv = 1.0 / (h * gam)
            for i in range(n):
                for j in range(n):
                    W[i, j] = -J[i, j]
                W[i, i] += inv
            if not _lu_factor(W, piv):
                h *= 0.5
                continue
            # stage 1
            for i in range(n):
                k1[i] = f0[i] + h * D[0] * dT[i]
            _lu_solve(W, piv, k1)
            for i in range(n):
                ut[i] = y[i] + A[0] * k1[i]
            f = rhs(t + CT[0] * h, ut, p)
            for i in range(n):
                k2[i] = f[i] + h * D[1] * dT[i] + (C[0] / h) * k1[i]
            _lu_solve(W, piv, k2)
            for i in range(n):
                ut[i] = y[i] + A[1] * k1[i] + A[2] * k2[i]
            f = rhs(t + CT[1] * h, ut, p)
            for i in range(n):
                k3[i] = f[i] + h * D[2] * dT[i] + (C[1] * k1[i] + C[2] * k2[i]) / h
            _lu_solve(W, piv, k3)
            for i in range(n):
                ut[i] = y[i] + A[3] * k1[i] + A[4] * k2[i] + A[5] * k3[i]
            f = rhs(t + CT[2] * h, ut, p)
            for i in range(n):
                k4[i] = f[i] + h * D[3] * dT[i] + (C[3] * k1[i] + C[4] * k2[i] + C[5] * k3[i]) / h
            _lu_solve(W, piv, k4)
            for i in range(n):
                ut[i] = y[i] + A[6] * k1[i] + A[7] * k2[i] + A[8] * k3[i] + A[9] * k4[i]
            f = rhs(t + h, ut, p)
            for i in range(n):
                k5[i] = f[i] + (C[6] * k1[i] + C[7] * k2[i] + C[8] * k3[i] + C[9] * k4[i]) / h
            _lu_solve(W, piv, k5)
            for i in range(n):
                ut[i] += k5[i]
            f = rhs(t + h, ut, p)
            for i in range(n):
                k6[i] = f[i] + (C[10] * k1[i] + C[11] * k2[i] + C[12] * k3[i] + C[13] * k4[i]
                                + C[14] * k5[i]) / h
            _lu_solve(W, piv, k6)
            nfev += 5
            # error norm over all states, the ledger quadratures included (their accuracy is the
            # accuracy of the energy balance); atol per state
            err = 0.0
            finite = True
            for i in range(n):
                y1[i] = ut[i] + k6[i]
                if not math.isfinite(y1[i]):
                    finite = False
                sc = atol[i] + rtol * max(abs(y[i]), abs(y1[i]))
                err += (k6[i] / sc) ** 2
            err = math.sqrt(err / n) if finite else 1e300
            if err <= 1.0:
                break
            rejected = True
            h *= max(0.2, 0.9 * err ** -0.25)
        # accepted step t -> t + h
        nsteps += 1
        t_new = t + h
        for i in range(n):
            d1[i] = H[0] * k1[i] + H[1] * k2[i] + H[2] * k3[i] + H[3] * k4[i] + H[4] * k5[i]
            d2[i] = H[5] * k1[i] + H[6] * k2[i] + H[7] * k3[i] + H[8] * k4[i] + H[9] * k5[i]
        big = 0.0
        for i in range(n_model):
            big = max(big, abs(y1[i]))
        if not (big <= bound):
            return 3, t, y, ts, ys, n_store, nfev, njev, nsteps, -1, ev_t, ev_k, n_ev, h
        # events on (t, t_new]: guards at the step ends and at _R_SAMPLES interior points of the
        # dense output, so that a guard crossing twice within one step (e.g. a ball's whole
        # flight) is not missed
        hit = -1
        t_hit = t_new
        if g_count > 0:
            g_new = guards(t_new, y1, p)[:g_count].copy()
            g_a = g_old.copy()
            th_a = 0.0
            for s_i in range(1, _R_SAMPLES + 2):
                th_b = s_i / (_R_SAMPLES + 1.0)
                if s_i <= _R_SAMPLES:
                    _dense(th_b, y, y1, d1, d2, yi)
                    g_b = guards(t + th_b * h, yi, p)[:g_count].copy()
                else:
                    g_b = g_new
                for k in range(g_count):
                    a = g_a[k]
                    b = g_b[k]
                    up = a <= 0.0 and b >= 0.0
                    down = a >= 0.0 and b <= 0.0
                    dk = directions[k]
                    if a == b or not ((up and dk > 0) or (down and dk < 0)
                                      or ((up or down) and dk == 0)):
                        continue
                    # Illinois on theta in [th_a, th_b]
                    lo = th_a
                    hi = th_b
                    glo = a
                    ghi = b
                    side = 0
                    th = hi
                    for _ in range(100):
                        th = (lo * ghi - hi * glo) / (ghi - glo)
                        _dense(th, y, y1, d1, d2, yi)
                        gm = guards(t + th * h, yi, p)[k]
                        if gm == 0.0 or (hi - lo) * h < 4e-16 * max(abs(t), 1.0):
                            break
                        if (gm > 0.0) == (ghi > 0.0):
                            hi = th
                            ghi = gm
                            if side == 1:
                                glo *= 0.5
                            side = 1
                        else:
                            lo = th
                            glo = gm
                            if side == -1:
                                ghi *= 0.5
                            side = -1
                    t_root = t + th * h
                    if terminal[k]:
                        if hit < 0 or t_root < t_hit:
                            hit = k
                            t_hit = t_root
                    elif n_ev < store_cap - 1:
                        ev_t[n_ev] = t_root
                        ev_k[n_ev] = k
                        n_ev += 1
                if hit >= 0:
                    break
                g_a = g_b
                th_a = th_b
            if hit >= 0:
                _dense((t_hit - t) / h, y, y1, d1, d2, yi)
                ts[n_store] = t_hit
                ys[n_store, :] = yi
                n_store += 1
                return 1, t_hit, yi.copy(), ts, ys, n_store, nfev, njev, nsteps, hit, ev_t, ev_k, n_ev, h
            g_old = g_new
        t = t_new
        for i in range(n):
            y[i] = y1[i]
        ts[n_store] = t
        ys[n_store, :] = y
        n_store += 1
        f0 = rhs(t, y, p)
        nfev += 1
        fac = min(6.0, max(0.2, 0.9 * err ** -0.25)) if err > 0.0 else 6.0
        if rejected:
            fac = min(fac, 1.0)
        h = min(h * fac, hmax)

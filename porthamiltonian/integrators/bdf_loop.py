# Template, not imported: appended by porthamiltonian.backends to the loop modules (see
# rosenbrock_loop.py's header: ``fn``, the model's functions) after rosenbrock_loop.py (whose _w_factor, _lu_solve and _dense it calls), common_loop.py (_loop_start,
# _stop_status, _finish_step: the events, Φ and the stored point at the end of a step) and the
# methods' tables; the entry points integrate_qbdf, integrate_qbdf_variational follow it
# (porthamiltonian/integrators/bdf.py). bdf_loop.c is the same loop in C: a change here is made
# there too (tests/validation/test_qbdf.py runs both on the same problems).
#
# QBDF: the backward differentiation formulas of orders 1-5 with variable order and a
# quasi-constant step size (Shampine & Reichelt, "The MATLAB ODE Suite", SIAM J. Sci. Comput. 18,
# 1997, §2.1-2.3, with their κ = 0: the BDFs themselves), solved by a modified Newton iteration
# that reuses the Jacobian and the LU of its iteration matrix over many steps (the rules of
# SUNDIALS CVODE: Hindmarsh et al., ACM TOMS 31, 2005, and the CVODE user guide, §2.1).
#
# History: D (rows 0..q+2) holds y_n and its backward differences scaled to the current step h
# on the grid t_n, t_n - h, t_n - 2h, ...: D_0 = y_n, D_j = ∇^j y_n. A step to t_n+1 = t_n + h
# predicts y⁰ = Σ_{j≤q} D_j and solves
#     d − c f(t_n+1, y⁰ + d) + ψ = 0,   c = h / γ_q,   ψ = Σ_{1≤j≤q} γ_j D_j / γ_q,  γ_j = Σ_{i≤j} 1/i,
# for the correction d (y_n+1 = y⁰ + d), by Newton with the matrix I − c̄ J (c̄, J: those of the
# last factorization; the increment scaled by 2 / (1 + c/c̄) when c ≠ c̄, as CVODE does). The
# local error estimate is d / (q + 1); the step is accepted when its RMS norm, weighted by
# 1 / (atol_i + rtol |y_n,i|) over all states (the ledger quadratures included), is at most 1.
# A change of step size by a factor r rescales D (the interpolating polynomial evaluated on the
# new grid; Shampine & Reichelt eq. (2.3)). After q + 1 steps of the same size the orders q − 1,
# q, q + 1 are compared by their error estimates (from D_q and from ∇^{q+2} y) and the one that
# allows the largest step is taken, unless it would grow the step by less than _GROW_MIN (then
# step and order stay, and are looked at again after q + 1 more steps).
#
# Reuse of the Jacobian and of the LU (the documented rule, CVODE's):
# * J is evaluated at the start of each call (a segment: after an event the right-hand side may
#   have jumped), again when the Newton iteration fails with a J older than the current step
#   (the same step is retried with the new J), and when a new LU is needed and J is
#   _JAC_AGE_MAX or more steps old;
# * I − c J is factored anew when c differs from that of the last factorization by more than
#   _GAMMA_CHANGE (relative; a change of step size or of order), when the last factorization is
#   _LU_AGE_MAX steps old, and after any failed step (error test or Newton);
# * the Newton iteration takes at most _NEWTON_ITERS iterations; it has converged when the
#   increment times the convergence rate (min(1, rate), the rate estimated over the iterations
#   and carried from step to step, reset to 1 at a new factorization) times the error
#   constant 1/(q + 1) is at most _NEWTON_COEF: the error left by the iteration is a tenth of
#   the error allowed; it has failed when an increment is more than _DIVERGE times the one
#   before, or after _NEWTON_ITERS iterations. A failure with a current J divides the step by 4.
#
# Dense output: the polynomial of degree q through D (the last q + 1 points of the grid),
# written over the step as _dense reads it: y(θ) = (1 − θ) y_n + θ (y_n+1 + (1 − θ) Σ_r E_r θ^r)
# (_bdf_dense), so that event location (_locate_events) and the sensitivities
# (_variational_step) work on it as on a Rosenbrock step's.
#
# Sensitivities (phi0 with m > 0 columns): staggered as for the Rosenbrock loops and by the same
# code: after each accepted step, Φ' = A(t) Φ is carried over it by _variational_step with the
# Rosenbrock method of the tables TA..TD (Rodas5P) in sub-steps of its own error control, A = J
# at the step's dense output. The Newton J of the BDF is never replaced by Φ's: the trajectory is
# bit for bit the same with and without Φ.

_BDF_MAX_ORDER = 5
_NEWTON_ITERS = 3       # CVODE's maxcor
_NEWTON_COEF = 0.1      # CVODE's nlscoef: the iteration's error, in parts of the error allowed
_DIVERGE = 2.0          # CVODE's RDIV
_RATE_DOWN = 0.3        # CVODE's CRDOWN: the rate estimate decays by at most this factor
_GAMMA_CHANGE = 0.3     # CVODE's DGMAX
_LU_AGE_MAX = 20        # CVODE's MSBP
_JAC_AGE_MAX = 50       # CVODE's MSBJ
_GROW_MIN = 1.5         # CVODE's THRESH: a smaller growth keeps step and order
_GROW_MAX = 10.0
_SHRINK_MIN = 0.2
_SAFETY = 0.9


@_jit
def _product_t(A, B, out):
    """out = Aᵀ B (out[i, j] = Σ_k A[k, i] B[k, j], k from 0 up)."""
    for i in range(out.shape[0]):
        for j in range(out.shape[1]):
            acc = 0.0
            for k in range(A.shape[0]):
                acc += A[k, i] * B[k, j]
            out[i, j] = acc


@_jit
def _bdf_rescale(D, order, factor):
    """Change the step size of the history D (rows 0..order) by ``factor``: D ← (R U)ᵀ D with
    R_ij = Π_{1≤r≤i} (r − 1 − factor j) / r and U the same at factor 1 (Shampine & Reichelt,
    eq. (2.3): the interpolating polynomial on the new grid); R is built transposed (Rt)."""
    q1 = order + 1
    Rt = np.zeros((q1, q1))
    U = np.zeros((q1, q1))
    for j in range(q1):
        Rt[j, 0] = 1.0
        U[0, j] = 1.0
    for i in range(1, q1):
        for j in range(1, q1):
            Rt[j, i] = Rt[j, i - 1] * (i - 1 - factor * j) / i
            U[i, j] = U[i - 1, j] * (i - 1 - j) / i
    RU = np.zeros((q1, q1))
    _product_t(Rt, U, RU)
    _product_t(RU, D[:q1].copy(), D[:q1])


@_jit
def _bdf_dense(D, order, E):
    """The step's dense output from D after the step (rows 0..order): the interpolating
    polynomial y(θ) = D_0 + Σ_j D_j Π_{0≤m<j} (θ − 1 + m) / (m + 1) (θ = 0 at the step's start,
    1 at its end) written as _dense reads it, E_r = −Σ_{k≥r+2} c_k with c_k its coefficients of
    θ^k; rows of E past order − 2 are zero."""
    n = D.shape[1]
    B = np.zeros((order + 1, order + 1))      # B[j, k]: coefficient of θ^k of the j-th product
    B[0, 0] = 1.0
    for j in range(1, order + 1):
        for k in range(j + 1):
            acc = (j - 2.0) * B[j - 1, k]
            if k > 0:
                acc += B[j - 1, k - 1]
            B[j, k] = acc / j
    for i in range(n):
        acc = 0.0                             # Σ_{k' ≥ k} c_k', k from the top down
        for k in range(order, 1, -1):
            ck = 0.0
            for j in range(k, order + 1):
                ck += B[j, k] * D[j, i]
            acc += ck
            E[k - 2, i] = -acc
        for r in range(max(order - 1, 0), E.shape[0]):
            E[r, i] = 0.0


@_jit
def _rms(v, w, n):
    """The RMS norm of v_i / w_i over i < n."""
    acc = 0.0
    for i in range(n):
        acc += (v[i] / w[i]) ** 2
    return math.sqrt(acc / n)


@_jit
def _bdf_first_step(fn, t, y, f0, p, rtol, atol, h0, hmax, t_end):
    """The first step of order 1 (Hairer, Nørsett & Wanner, Solving ODEs I, 2nd ed., §II.4: from
    the scaled norms of y, f and of a difference estimate of f'), at most h0 when h0 > 0, hmax
    and the span. Returns (h, rhs evaluations made)."""
    n = y.shape[0]
    sc = np.empty(n)
    for i in range(n):
        sc[i] = atol[i] + rtol * abs(y[i])
    d0 = _rms(y, sc, n)
    d1 = _rms(f0, sc, n)
    h = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h = min(h, hmax, t_end - t)
    y1 = np.empty(n)
    for i in range(n):
        y1[i] = y[i] + h * f0[i]
    rhs = fn[0]
    f1 = rhs(t + h, y1, p)
    for i in range(n):
        y1[i] = f1[i] - f0[i]
    # h = 0 when f0 lies beyond the float64 range (d1 = inf): C's division gives inf or NaN
    # there and the same h = 0 below; Python's and numba's raise
    d2 = _rms(y1, sc, n) / h if h > 0.0 else math.inf
    big = max(d1, d2)
    h1 = max(1e-6, h * 1e-3) if big <= 1e-15 else math.sqrt(0.01 / big)
    h = min(100.0 * h, h1, hmax, t_end - t)
    if h0 > 0.0:
        h = min(h, h0)
    return h, 1


@_jit
def _bdf(fn, TA, TC, TN, TD, gam, expo, t0, y0, t_end, p, rtol, atol, h0, hmax, directions,
         terminal, mask_index, mask_sign, n_model, bound, max_steps, store_cap, tgrad_step, phi0,
         gain):
    """Integrate from (t0, y0) to t_end or the first terminal event with QBDF (see the header);
    TA, TC, TN, TD, gam, expo: the Rosenbrock method that carries the sensitivities.

    Arguments (``gain``: the forcing of parameter columns) and results as _rosenbrock's (``tgrad_step`` is not used: the BDFs need no ∂f/∂t):
    (status, t, y, ts, ys, n_store, nfev, njev, nsteps, event_index, ev_t, ev_k, n_ev, h, nlu,
    phi, phis, phi_err); ``h`` is the step size in force at the end (the next call starts at
    order 1 with at most it), ``nlu`` counts the factorizations of I − c J (and of Φ's
    sub-steps)."""
    n, m = phi0.shape       # Φ0: n x m (m = 0: no sensitivities)
    t = t0
    rhs, jac = fn[0], fn[1]
    y, ts, ys, ev_t, ev_k, P, phis, g_old = _loop_start(fn, t, y0, p, directions.shape[0],
                                                        mask_index, mask_sign, store_cap, phi0)
    nfev = njev = nlu = nsteps = n_store = n_ev = 0
    D = np.zeros((_BDF_MAX_ORDER + 3, n))
    E = np.zeros((_BDF_MAX_ORDER - 1, n))
    W = np.empty((n, n))
    piv = np.empty(n, dtype=np.int64)
    nb = 0
    J = np.empty((n, n))
    sc = np.empty(n)
    yp = np.empty(n)
    psi = np.empty(n)
    d = np.empty(n)
    dy = np.empty(n)
    yk = np.empty(n)
    yi = np.empty(n)
    gsum = np.zeros(_BDF_MAX_ORDER + 1)       # γ_q = Σ_{i≤q} 1/i
    for q in range(1, _BDF_MAX_ORDER + 1):
        gsum[q] = gsum[q - 1] + 1.0 / q
    J_phi = np.empty((n, n))
    have_phi_jac = False
    phi_err = 0.0
    eta_phi = 1e300
    f0 = rhs(t, y, p)
    nfev += 1
    h, nf = _bdf_first_step(fn, t, y, f0, p, rtol, atol, h0, hmax, t_end)
    nfev += nf
    for i in range(n):
        D[0, i] = y[i]
        D[1, i] = h * f0[i]
    order = 1
    n_equal = 0
    J[:, :] = jac(t, y, p)
    njev += 1
    jac_age = 0             # accepted steps since J was evaluated
    lu_age = 0              # accepted steps since the last factorization
    c_lu = 0.0              # c of the last factorization (0: none valid)
    rate = 1.0
    status = 0
    hit = -1
    err = 0.0
    t_new = t
    f_phi = f0
    while True:
        status = _stop_status(t, t_end, nsteps, max_steps, n_store, n_ev, store_cap)
        if status >= 0:
            break
        last = t + h >= t_end
        if last and t + h != t_end:
            _bdf_rescale(D, order, (t_end - t) / h)
            h = t_end - t
            n_equal = 0
        for i in range(n):
            sc[i] = atol[i] + rtol * abs(y[i])
        underflow = False
        while True:
            if not h >= 1e-14 * max(abs(t), 1.0) and not h >= t_end - t:  # unless all that is left; NaN
                underflow = True
                break
            t_new = t_end if last else t + h
            c = h / gsum[order]
            for i in range(n):
                acc = 0.0
                acc_psi = 0.0
                for j in range(order, 0, -1):
                    acc += D[j, i]
                    acc_psi += gsum[j] * D[j, i]
                yp[i] = acc + D[0, i]
                psi[i] = acc_psi / gsum[order]
            if c_lu == 0.0 or abs(c / c_lu - 1.0) > _GAMMA_CHANGE or lu_age >= _LU_AGE_MAX:
                if jac_age >= _JAC_AGE_MAX:
                    J[:, :] = jac(t_new, yp, p)
                    njev += 1
                    jac_age = 0
                nb = _w_factor(J, c, n_model, W, piv)     # I/c − J
                nlu += 1
                lu_age = 0
                rate = 1.0
                if nb == 0:
                    c_lu = 0.0
                    _bdf_rescale(D, order, 0.25)
                    h *= 0.25
                    n_equal = 0
                    last = False
                    continue
                c_lu = c
            # the modified Newton iteration on d
            converged = False
            del_old = 0.0
            for i in range(n):
                d[i] = 0.0
                yk[i] = yp[i]
            for it in range(_NEWTON_ITERS):
                f = rhs(t_new, yk, p)
                nfev += 1
                for i in range(n):
                    dy[i] = (c * f[i] - psi[i] - d[i]) / c_lu
                _lu_solve(W, piv, nb, dy)
                if c != c_lu:
                    scale = 2.0 / (1.0 + c / c_lu)
                    for i in range(n):
                        dy[i] *= scale
                dl = _rms(dy, sc, n)
                if not math.isfinite(dl):
                    break
                for i in range(n):
                    yk[i] += dy[i]
                    d[i] += dy[i]
                if it > 0:
                    rate = max(_RATE_DOWN * rate, dl / del_old)
                    if dl > _DIVERGE * del_old:
                        break
                if dl * min(1.0, rate) / (order + 1.0) <= _NEWTON_COEF:
                    converged = True
                    break
                del_old = dl
            if not converged:
                if jac_age > 0:             # a stale J: the same step with a new one
                    J[:, :] = jac(t_new, yp, p)
                    njev += 1
                    jac_age = 0
                    c_lu = 0.0
                    continue
                _bdf_rescale(D, order, 0.25)
                h *= 0.25
                n_equal = 0
                c_lu = 0.0
                last = False
                continue
            err = _rms(d, sc, n) / (order + 1.0)
            if err > 1.0:
                fac = max(_SHRINK_MIN, _SAFETY * err ** (-1.0 / (order + 1.0)))
                _bdf_rescale(D, order, fac)
                h *= fac
                n_equal = 0
                c_lu = 0.0
                last = False
                continue
            break
        if underflow:
            status = 2
            break
        # accepted step t -> t_new
        nsteps += 1
        n_equal += 1
        jac_age += 1
        lu_age += 1
        for i in range(n):
            D[order + 2, i] = d[i] - D[order + 1, i]
            D[order + 1, i] = d[i]
        for j in range(order, -1, -1):
            for i in range(n):
                D[j, i] += D[j + 1, i]
        _bdf_dense(D, order, E)
        big = 0.0
        finite = True
        for i in range(n):
            if not math.isfinite(yk[i]):
                finite = False
        for i in range(n_model):
            big = max(big, abs(yk[i]))
        if not (finite and big <= bound):
            status = 3
            break
        hh = t_new - t
        if m > 0 and not have_phi_jac:
            J_phi = jac(t, y, p)
            njev += 1
        if m > 0:
            f_phi = rhs(t, y, p)
            nfev += 1
        # events on (t, t_new], Φ over the step (its last A is J at the next step's start), the
        # point
        hit, t, n_ev, n_store, g_old, njev, nfev, nlu, J_phi, phi_err, eta_phi = _finish_step(
            fn, t, hh, t_new, y, yk, E, p, g_old, directions, terminal, ev_t, ev_k, n_ev, yi, J_phi,
            f_phi, W, piv, 0, TA, TC, TN, TD, gam, expo, rtol, atol, n_model, P, eta_phi, gain,
            ts, ys, phis, n_store, njev, nfev, nlu, phi_err)
        if hit >= 0:
            status = 1
            break
        have_phi_jac = m > 0
        # the next step's order and size
        if n_equal < order + 1:
            continue
        for i in range(n):
            sc[i] = atol[i] + rtol * abs(y[i])
        best = _SAFETY * err ** (-1.0 / (order + 1.0)) if err > 0.0 else _GROW_MAX
        change = 0
        if order > 1:
            e_down = _rms(D[order], sc, n) / order
            fac = _SAFETY * e_down ** (-1.0 / order) if e_down > 0.0 else _GROW_MAX
            if fac > best:
                best = fac
                change = -1
        if order < _BDF_MAX_ORDER:
            e_up = _rms(D[order + 2], sc, n) / (order + 2.0)
            fac = _SAFETY * e_up ** (-1.0 / (order + 2.0)) if e_up > 0.0 else _GROW_MAX
            if fac > best:
                best = fac
                change = 1
        n_equal = 0
        if change == 0 and best < _GROW_MIN:
            continue
        order += change
        fac = min(best, _GROW_MAX, hmax / h)
        _bdf_rescale(D, order, fac)
        h *= fac
    return (status, t, y, ts, ys, n_store, nfev, njev, nsteps, hit if status == 1 else -1, ev_t,
            ev_k, n_ev, h, nlu, P.reshape(n, m), phis.reshape(store_cap, n, m), phi_err)

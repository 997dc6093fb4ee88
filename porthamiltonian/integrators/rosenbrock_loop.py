# Template, not imported: appended by porthamiltonian.backends to each generated model module of
# the python back end, after the model's functions, and to the numba back end's one loop module
# for all models, where ``np``, ``math`` and ``_jit`` are defined. The model's functions come as
# the argument ``fn`` = (rhs, jac, guards, jac_p), each (t, x, p) -> array, of every function
# that calls them (under numba a tuple of first-class functions: one compiled loop serves every
# model, porthamiltonian/backends/numba_loops.py). This file comes before common_loop.py (its _loop_start, _stop_status and _finish_step, which the
# loop calls, are shared with the BDF loop); the tables of each method and its entry point ``integrate_<method>`` follow it
# (porthamiltonian/integrators/tableaus.py). rosenbrock_loop.c is the same loop in C: a change
# here is made there too (tests/validation/test_rodas.py runs both on the same problems).
#
# The step loop of the stiffly accurate Rosenbrock methods of tableaus.py (Rodas4, Rodas5P;
# Hairer & Wanner, Solving ODEs II, 2nd ed., §IV.7). Each step forms W = I/(hγ) − J once, factors
# it (LU with partial pivoting) and solves one linear system per stage; the last stage's
# increment is the error estimate. Events: after each accepted step the guards are evaluated at
# the step's end and at _SAMPLES interior points of the dense output; a sign change in the wanted
# direction is located on the dense output by the Illinois (regula falsi) method.
#
# Sensitivities (given directions ``phi0``; none when it has no columns): the variational equation
# Φ' = A(t) Φ, A(t) = J(t, x(t)), is integrated beside x, staggered: each step's x-stages are
# computed, the step accepted and its events located exactly as without Φ (the trajectory is bit
# for bit the same); then Φ is carried over the accepted step (to its end, or to the terminal
# event) by the same method on the linear non-autonomous system Φ' = A(t) Φ, x taken from the
# step's dense output, in sub-steps of its own error control (_variational_step):
#     W KΦ_i = A(τ + c_i η) UΦ_i + η d_i A'(τ) Φ0 + (Σ_j C_ij KΦ_j) / η,   W = I/(ηγ) − A(τ),
#     UΦ_i = Φ0 + Σ_j a_ij KΦ_j,   Φ1 = UΦ_s + KΦ_s,   error estimate KΦ_s,
# for a sub-step τ -> τ + η. A at the nodes is J at the dense output (one jac per distinct node;
# the node c = 1 of the step's end is y1, whose J the next step reuses); A'(τ) = ∂_x J[f] + ∂_t J
# a central difference of J along (1, f) (_jac_rate). The first try is the whole step with the
# step's own LU: where it meets the tolerance (the usual case) Φ costs no more; where it does
# not — the steps chosen for x do not resolve Φ, e.g. from an equilibrium where x does not move,
# or across a kink of J (a Piecewise law switching inside the step) — the step is divided. With A
# and A' exact each sub-step is the method of order p on Φ; the dense output's error (of the
# order of the local error) enters A. Φ (n x m) is held flattened, P[i * m + c] = Φ[i, c], so that
# products and solves run along rows of m independent values; J's last two columns (the ledger
# states, which no rate depends on) are zero and skipped.
#
# Parameter sensitivities (columns of Φ seeded with ∂x₀/∂p; ``gain`` G, L x m, not empty): the
# variational equation has the forcing term F(t) = jac_p(t, x(t), p) G (jac_p: the model's
# generated ∂ẋ/∂p over its L parameters, G = ∂p/∂(seed) of each column: a unit column for
# ∂x/∂p_l, zero for a state direction), Φ' = A Φ + F, whose sub-steps are
#     W KΦ_i = A(τ + c_i η) UΦ_i + F(τ + c_i η) + η d_i (A'(τ) Φ0 + F'(τ)) + (Σ_j C_ij KΦ_j) / η,
# F at the same nodes as A (one jac_p per distinct node), F'(τ) by the same difference along
# (1, f) as A' (_rate_step, _forcing_rate). Without parameters (L = 0 rows of G) nothing of it
# runs.

_SAMPLES = 3  # interior guard samples per step
_CBRT_EPS = 6.0554544523933395e-06  # ε^(1/3): the relative step of the central differences
_SUBSTEPS = 400     # at most this many sub-steps of Φ per step
_THETA_MIN = 1e-9   # the smallest sub-step, in parts of the step
# a sub-step's error estimate (of the embedded solution, an order below the one propagated) may
# be this many rtol: measured against closed forms, Φ's error then stays within a few rtol, and
# the steps chosen for x are rarely divided (at 1 rtol: most of them, twice the cost)
_PHI_TOLERANCE = 10.0


@_jit
def _lu_factor(A, piv, nb):
    """The leading nb x nb block of A: PA = LU in place (partial pivoting, row swaps in
    ``piv``): L below the diagonal (unit diagonal), U above it, and on the diagonal 1/U[k, k],
    so that solves multiply (a division's latency is on the critical path of a small solve);
    False when the block is singular."""
    n = A.shape[0]
    for k in range(nb):
        m = k
        big = abs(A[k, k])
        for i in range(k + 1, nb):
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
        r = 1.0 / A[k, k]
        A[k, k] = r
        for i in range(k + 1, nb):
            A[i, k] *= r
            f = A[i, k]
            if f != 0.0:
                for j in range(k + 1, nb):
                    A[i, j] -= f * A[k, j]
    return True


@_jit
def _w_factor(J, hgam, n_model, W, piv):
    """W = I/(hγ) − J (hgam = hγ), factored in place. The ledger quadratures (states n_model..)
    are read by no right-hand side: when J's columns of them are zero, W is block
    lower-triangular and only its model block is factored (a ledger row is then solved by
    substitution: its diagonal holds hγ); otherwise all of W. Returns the size of the factored
    block, 0 when it is singular."""
    n = J.shape[0]
    inv = 1.0 / hgam
    nb = n_model
    for i in range(n):
        for j in range(n):
            W[i, j] = -J[i, j]
        W[i, i] += inv
        for j in range(n_model, n):
            if J[i, j] != 0.0:
                nb = n
    if not _lu_factor(W, piv, nb):
        return 0
    for i in range(nb, n):
        W[i, i] = hgam
    return nb


@_jit
def _lu_solve(A, piv, nb, b):
    """Solve W x = b in place (W: from _w_factor, its block of nb factored), the block by
    columns (each step updates the remaining components independently of one another), then
    the rows below it by substitution."""
    n = A.shape[0]
    for k in range(nb):
        m = piv[k]
        if m != k:
            tmp = b[k]
            b[k] = b[m]
            b[m] = tmp
    for k in range(nb):
        bk = b[k]
        for i in range(k + 1, nb):
            b[i] -= A[i, k] * bk
    for k in range(nb - 1, -1, -1):
        bk = b[k] * A[k, k]
        b[k] = bk
        for i in range(k):
            b[i] -= A[i, k] * bk
    for i in range(nb, n):
        acc = b[i]
        for j in range(nb):
            acc -= A[i, j] * b[j]
        b[i] = acc * A[i, i]


@_jit
def _dense(theta, y0, y1, E, out):
    """y(θ) = (1 − θ) y0 + θ (y1 + (1 − θ)(E[0] + θ (E[1] + θ (...))))."""
    m = E.shape[0]
    for i in range(y0.shape[0]):
        acc = E[m - 1, i]
        for r in range(m - 2, -1, -1):
            acc = E[r, i] + theta * acc
        out[i] = (1.0 - theta) * y0[i] + theta * (y1[i] + (1.0 - theta) * acc)


@_jit
def _rate_step(h, f, sc, n_model):
    """The step ε = ε_mach^(1/3) / ν, ν = max(max_i |f_i| / sc_i, 1 / h), of the differences
    along (1, f) (_jac_rate, _forcing_rate)."""
    nu = 1.0 / h
    for i in range(n_model):
        nu = max(nu, abs(f[i]) / sc[i])
    return _CBRT_EPS / nu


@_jit
def _add_product(A, cols, B, out):
    """out += A[:, :cols] B (out: rows of A x columns of B), skipping A's zeros."""
    for i in range(A.shape[0]):
        for j in range(cols):
            a = A[i, j]
            if a != 0.0:
                for c in range(B.shape[1]):
                    out[i, c] += a * B[j, c]


@_jit
def _forcing(fn, t, y, p, gain, out):
    """out = jac_p(t, y, p) G (n x m, flattened by rows; G = ``gain``, L x m): the forcing of
    the parameter sensitivities (see the header)."""
    n = y.shape[0]
    m = gain.shape[1]
    for q in range(n * m):
        out[q] = 0.0
    jac_p = fn[3]
    _add_product(jac_p(t, y, p), gain.shape[0], gain, out.reshape(n, m))


@_jit
def _shifted(y, f, eps):
    """y ± ε f: the states at t ± ε along (1, f) (_jac_rate, _forcing_rate)."""
    yp = y.copy()
    ym = y.copy()
    for i in range(y.shape[0]):
        yp[i] += eps * f[i]
        ym[i] -= eps * f[i]
    return yp, ym


@_jit
def _difference_rate(Xp, X, Xm, eps, out):
    """out = dX/dt from X at (t, y) and Xp, Xm at t ± ε along (1, f) (rows x columns alike):
    central, (Xp − Xm) / 2ε, unless X has a kink in between (a Piecewise law, e.g. a contact's
    max(z, 0)): then the two one-sided differences disagree by O(1) instead of O(ε), and the
    smaller one, from the side without the kink, is used."""
    up = 0.0
    down = 0.0
    second = 0.0
    central = 0.0
    for i in range(X.shape[0]):
        for j in range(X.shape[1]):
            up = max(up, abs(Xp[i, j] - X[i, j]))
            down = max(down, abs(X[i, j] - Xm[i, j]))
            second = max(second, abs(Xp[i, j] - 2.0 * X[i, j] + Xm[i, j]))
            central = max(central, abs(Xp[i, j] - Xm[i, j]))
    kink = second > 0.5 * central and second > 1e-12 * (up + down + 1e-300)
    for i in range(X.shape[0]):
        for j in range(X.shape[1]):
            if not kink:
                out[i, j] = (Xp[i, j] - Xm[i, j]) / (2.0 * eps)
            elif up <= down:
                out[i, j] = (Xp[i, j] - X[i, j]) / eps
            else:
                out[i, j] = (X[i, j] - Xm[i, j]) / eps


@_jit
def _forcing_rate(fn, t, h, y, p, gain, F, f, sc, n_model, DF):
    """DF = d/dt F(t, x(t)) of the forcing F = jac_p G at (t, y) (F: its value there), by the
    differences of _jac_rate (the same step, the same choice between the central and the
    one-sided differences). Returns the jac_p evaluations made (2)."""
    n = y.shape[0]
    nm = F.shape[0]
    eps = _rate_step(h, f, sc, n_model)
    yp, ym = _shifted(y, f, eps)
    Fp = np.empty(nm)
    Fm = np.empty(nm)
    _forcing(fn, t + eps, yp, p, gain, Fp)
    _forcing(fn, t - eps, ym, p, gain, Fm)
    m = nm // n
    _difference_rate(Fp.reshape(n, m), F.reshape(n, m), Fm.reshape(n, m), eps, DF.reshape(n, m))
    return 2


@_jit
def _jac_rate(fn, t, h, y, p, J, f, sc, n_model, D):
    """D = d/dt J(t, x(t)) = ∂_x J[f] + ∂_t J at (t, y), f = ẋ, by a difference of J along
    (1, f) with the step ε of _rate_step (model states i: every state moves by at most
    ε_mach^(1/3) of its scale sc_i, the time by at most that part of the step), central unless
    J has a kink in between (_difference_rate). Returns the jac evaluations made (2)."""
    eps = _rate_step(h, f, sc, n_model)
    yp, ym = _shifted(y, f, eps)
    jac = fn[1]
    _difference_rate(jac(t + eps, yp, p), J, jac(t - eps, ym, p), eps, D)
    return 2


@_jit
def _row_solved(A, B, m, i, j0, j1):
    """Row i of the n x m matrix B (flattened row by row) solved from rows j0..j1-1:
    B_i = (B_i − Σ_j A[i, j] B_j) A[i, i] (A[i, i] holds the inverse of the pivot)."""
    for j in range(j0, j1):
        a = A[i, j]
        if a != 0.0:
            for c in range(m):
                B[i * m + c] -= a * B[j * m + c]
    d = A[i, i]
    for c in range(m):
        B[i * m + c] *= d


@_jit
def _lu_solve_rows(A, piv, nb, B, m):
    """Solve W X = B in place for the n x m matrix B, flattened row by row (W: from _w_factor,
    its block of nb factored)."""
    n = A.shape[0]
    for k in range(nb):
        r = piv[k]
        if r != k:
            for c in range(m):
                tmp = B[k * m + c]
                B[k * m + c] = B[r * m + c]
                B[r * m + c] = tmp
    for i in range(nb):
        for j in range(i):
            a = A[i, j]
            if a != 0.0:
                for c in range(m):
                    B[i * m + c] -= a * B[j * m + c]
    for i in range(nb - 1, -1, -1):             # U, its diagonal stored inverted
        _row_solved(A, B, m, i, i + 1, nb)
    for i in range(nb, n):                      # the ledger rows: their diagonal is hγ
        _row_solved(A, B, m, i, 0, nb)


@_jit
def _phi_substep(fn, th_a, th_b, t, h, y, y1, p, E, Ja, D, W, piv, nb, TA, TC, TN, TD, n_model, P,
                 KP, P1, xi, gain, Fa, DF, F_end):
    """One sub-step of Φ from τ = t + th_a h to t + th_b h (η = (th_b − th_a) h; see the header):
    KP and P1 from P, with the LU of W = I/(ηγ) − Ja and D = A'(τ); with parameters (``gain``
    not empty) the forcing Fa at τ, its rate DF, and F at t + th_b h into F_end. Returns (jac
    and jac_p evaluations made, A at t + th_b h)."""
    n = y.shape[0]
    s = TN.shape[0]
    nm = P.shape[0]
    m = nm // n
    jac = fn[1]
    forced = gain.shape[0] > 0
    ds = th_b - th_a
    eta = ds * h
    UP = np.empty(nm)
    DP = np.zeros(nm)
    _add_product(D, n_model, P.reshape(n, m), DP.reshape(n, m))     # DP = A'(τ) Φ0 (+ F'(τ))
    F = Fa
    if forced:
        for q in range(nm):
            DP[q] += DF[q]
    nj = 0
    A = Ja
    for st in range(s):
        # the stage sums term by term over Φ's entries, each entry adding its terms in the order
        # j = 0, 1, … (the C loop's order: its inner loops run over the entries, vectorized)
        for q in range(nm):
            UP[q] = P[q]
        for j in range(st):
            a = TA[st, j]
            for q in range(nm):
                UP[q] += a * KP[j, q]
        if st > 0 and TN[st] != TN[st - 1]:
            th = th_b if TN[st] == 1.0 else th_a + TN[st] * ds
            if th == 1.0:
                A = jac(t + h, y1, p)
                if forced:
                    F = F_end
                    _forcing(fn, t + h, y1, p, gain, F)
            else:
                _dense(th, y, y1, E, xi)
                A = jac(t + th * h, xi, p)
                if forced:
                    F = F_end
                    _forcing(fn, t + th * h, xi, p, gain, F)
            nj += 2 if forced else 1
        hd = eta * TD[st]
        ce = TC[st] / eta                   # c_ij / η: a division per stage, not per term
        for q in range(nm):
            KP[st, q] = hd * DP[q]
        for j in range(st):
            for q in range(nm):
                KP[st, q] += ce[j] * KP[j, q]
        if forced:
            for q in range(nm):
                KP[st, q] += F[q]
        _add_product(A, n_model, UP.reshape(n, m), KP[st].reshape(n, m))
        _lu_solve_rows(W, piv, nb, KP[st], m)
    for q in range(nm):
        P1[q] = UP[q] + KP[s - 1, q]
    return nj, A


@_jit
def _locate_events(fn, t, h, y, y1, E, p, g_old, directions, terminal, ev_t, ev_k, n_ev, yi):
    """Events on (t, t + h] of the step from y to y1 with the dense output E (_dense): the
    guards at the step's end and at _SAMPLES interior points (so that a guard crossing twice
    within one step, e.g. a ball's whole flight, is not missed; g_old: at the step's start); a
    sign change in a guard's direction is located by the Illinois (regula falsi) method on the
    dense output. Non-terminal events are appended to ev_t, ev_k (n_ev of them so far, at most
    their length - 1); yi is work space. Returns (the earliest terminal event's index or -1, its
    time (t + h when none), n_ev, the guards at the step's end)."""
    g_count = directions.shape[0]
    store_cap = ev_t.shape[0]
    t_new = t + h
    hit = -1
    t_hit = t_new
    guards = fn[2]
    g_new = guards(t_new, y1, p)[:g_count].copy()
    g_a = g_old.copy()
    th_a = 0.0
    for s_i in range(1, _SAMPLES + 2):
        th_b = s_i / (_SAMPLES + 1.0)
        if s_i <= _SAMPLES:
            _dense(th_b, y, y1, E, yi)
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
                _dense(th, y, y1, E, yi)
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
    return hit, t_hit, n_ev, g_new


@_jit
def _variational_step(fn, t, h, th_end, y, y1, p, J, f0, W, piv, nb, E, TA, TC, TN, TD, gam, expo,
                      rtol, atol, n_model, P, eta0, gain):
    """Carry Φ (P, in place) over the accepted step from t to t + th_end h in sub-steps of its own
    error control (see the header), the first eta0 long (s; the whole step when eta0 >= th_end h,
    with the step's LU W, piv when th_end = 1 and nb > 0; nb = 0: no LU of the step is given, as
    for a multistep method's step); ``E`` and ``y``, ``y1``: the step's dense output (_dense),
    from which A is taken at the nodes; a sub-step is accepted when its error estimate
    ‖KΦ_s‖ / ‖Φ1‖ (norm weighted by 1/sc, sc_i = max(|y_i|, atol_i / rtol), over the model
    states) is at most _PHI_TOLERANCE rtol, or when it is _THETA_MIN of the step, or the
    _SUBSTEPS-th; ``gain`` (L x m): the forcing of the parameter columns (none when L = 0; see
    the header; its jac_p evaluations are counted with jac's). Returns (jac evaluations, rhs evaluations, LU factorizations, A at the end (the
    next step's J when th_end = 1), the largest error estimate accepted, the next sub-step's length
    proposed)."""
    rhs = fn[0]
    n = y.shape[0]
    s = TN.shape[0]
    nm = P.shape[0]
    m = nm // n
    KP = np.empty((s, nm))
    P1 = np.empty(nm)
    D = np.empty((n, n))
    Ws = np.empty((n, n))
    pivs = np.empty(n, dtype=np.int64)
    sc = np.empty(n)
    for i in range(n):
        sc[i] = max(abs(y[i]), atol[i] / rtol)
    xa = y.copy()
    xi = np.empty(n)
    fa = f0
    Ja = J
    th_a = 0.0
    ds = min(th_end, max(eta0 / h, _THETA_MIN))
    nj = 0
    nf = 0
    nlu = 0
    worst = 0.0
    count = 0
    forced = gain.shape[0] > 0
    Fa = np.zeros(nm)
    Fb = np.zeros(nm)
    DF = np.zeros(nm)
    if forced:
        _forcing(fn, t, y, p, gain, Fa)
        nj += 1
    while th_a < th_end:
        last = ds >= th_end - th_a
        th_b = th_end if last else th_a + ds
        eta = (th_b - th_a) * h
        nj += _jac_rate(fn, t + th_a * h, eta, xa, p, Ja, fa, sc, n_model, D)
        if forced:
            nj += _forcing_rate(fn, t + th_a * h, eta, xa, p, gain, Fa, fa, sc, n_model, DF)
        if th_a == 0.0 and th_b == 1.0 and nb > 0:
            Wu = W
            pu = piv
            nbu = nb
        else:
            nbu = _w_factor(Ja, eta * gam, n_model, Ws, pivs)
            nlu += 1
            if nbu == 0:
                ds = 0.5 * (th_b - th_a)
                continue
            Wu = Ws
            pu = pivs
        nj_s, A_end = _phi_substep(fn, th_a, th_b, t, h, y, y1, p, E, Ja, D, Wu, pu, nbu, TA, TC,
                                   TN, TD, n_model, P, KP, P1, xi, gain, Fa, DF, Fb)
        nj += nj_s
        num = 0.0
        den = 0.0
        for i in range(n_model):
            for c in range(m):
                num += (KP[s - 1, i * m + c] / sc[i]) ** 2
                den += (P1[i * m + c] / sc[i]) ** 2
        err = math.sqrt(num / den) if den > 0.0 else 0.0
        count += 1
        tol = _PHI_TOLERANCE * rtol
        if err <= tol or th_b - th_a <= _THETA_MIN or count >= _SUBSTEPS:
            P[:] = P1
            worst = max(worst, err)
            Ja = A_end
            if forced:
                Fa, Fb = Fb, Fa
            th_a = th_b
            if th_a < th_end:
                _dense(th_a, y, y1, E, xa)
                fa = rhs(t + th_a * h, xa, p)
                nf += 1
            fac = 6.0 if err == 0.0 else min(6.0, max(0.2, 0.9 * (tol / err) ** expo))
            ds = max(ds * fac, _THETA_MIN)
        else:
            ds = max((th_b - th_a) * max(0.2, 0.9 * (tol / err) ** expo), _THETA_MIN)
    return nj, nf, nlu, Ja, worst, ds * h


@_jit
def _no_variational(fn, t, h, th_end, y, y1, p, J, f0, W, piv, nb, E, TA, TC, TN, TD, gam, expo,
                    rtol, atol, n_model, P, eta0, gain):
    """_variational_step in the copy of _rosenbrock for runs without sensitivities (never
    called there: m = 0; see porthamiltonian/integrators/__init__.py)."""
    return 0, 0, 0, J, 0.0, eta0


@_jit
def _rosenbrock(fn, TA, TC, TN, TD, TH, gam, expo, t0, y0, t_end, p, rtol, atol, h0, hmax,
                directions, terminal, mask_index, mask_sign, n_model, bound, max_steps, store_cap,
                tgrad_step, phi0, gain):
    """Integrate from (t0, y0) to t_end or the first terminal event with the method of the
    tables TA, TC, TN, TD, TH, γ = gam, step-size exponent expo (see tableaus.py).

    Returns (status, t, y, ts, ys, n_store, nfev, njev, nsteps, event_index, ev_t, ev_k, n_ev, h,
    nlu, phi, phis, phi_err): status 0 reached t_end, 1 terminal event ``event_index``, 2 step-size
    underflow or singular W, 3 divergence (max|x| > bound or non-finite), 4 max_steps, 5 store
    buffer full (call again from the returned t, y with the returned h). ``ts``/``ys`` hold the accepted
    steps, ``ev_t``/``ev_k`` the non-terminal events found, ``nlu`` counts the LU factorizations
    (of W, one per attempted step, and of Φ's sub-steps). ``phi0`` (n x m, column c the
    initial perturbation of direction c; m = 0: no sensitivities) gives the sensitivities Φ (see
    the header; ``gain``, L x m: the forcing of parameter columns, see there): ``phi`` (n x m)
    at the returned t, ``phis`` (store_cap x n x m) at the stored
    points, ``phi_err`` the largest relative error estimate of Φ over its accepted sub-steps
    (_variational_step; at most _PHI_TOLERANCE rtol unless a sub-step limit was reached).
    """
    n, m = phi0.shape       # Φ0: n x m (m = 0: no sensitivities)
    s = TN.shape[0]
    t = t0
    rhs, jac = fn[0], fn[1]
    y, ts, ys, ev_t, ev_k, P, phis, g_old = _loop_start(fn, t, y0, p, directions.shape[0],
                                                        mask_index, mask_sign, store_cap, phi0)
    nfev = njev = nlu = nsteps = n_store = n_ev = 0
    W = np.empty((n, n))
    piv = np.empty(n, dtype=np.int64)
    nb = 0          # the size of W's factored block (_w_factor)
    K = np.empty((s, n))
    U = np.empty((s, n))
    E = np.empty((TH.shape[0], n))
    dT = np.zeros(n)
    y1 = np.empty(n)
    yi = np.empty(n)
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
    err = 0.0
    status = 0
    hit = -1
    have_next = False
    J_next = np.empty((n, n))
    phi_err = 0.0
    eta_phi = 1e300         # the length of Φ's next sub-step (s): the whole step
    while True:
        status = _stop_status(t, t_end, nsteps, max_steps, n_store, n_ev, store_cap)
        if status >= 0:
            break
        if have_next:
            J = J_next          # jac(t, y, p), made for the last step's Φ
            have_next = False
        else:
            J = jac(t, y, p)
            njev += 1
        if tgrad_step > 0.0:
            fT = rhs(t + tgrad_step, y, p)
            nfev += 1
            for i in range(n):
                dT[i] = (fT[i] - f0[i]) / tgrad_step
        rejected = False
        underflow = False
        while True:
            # too small a step, unless it is the whole of what is left (t_end - t itself tiny)
            if not h >= 1e-14 * max(abs(t), 1.0) and not h >= t_end - t:   # a NaN h too
                underflow = True
                break
            if t + h > t_end:
                h = t_end - t
            nb = _w_factor(J, h * gam, n_model, W, piv)
            nlu += 1
            if nb == 0:
                h *= 0.5
                continue
            # stages: U[i] = y + Σ_j TA[i, j] K[j];  W K[i] = f(t + TN[i] h, U[i]) + h TD[i] dT
            # + (Σ_j TC[i, j] K[j]) / h
            for st in range(s):
                if st == 0:
                    for i in range(n):
                        U[0, i] = y[i]
                    f = f0
                else:
                    for i in range(n):
                        acc = y[i]
                        for j in range(st):
                            acc += TA[st, j] * K[j, i]
                        U[st, i] = acc
                    f = rhs(t + TN[st] * h, U[st], p)
                    nfev += 1
                for i in range(n):
                    acc = 0.0
                    for j in range(st):
                        acc += TC[st, j] * K[j, i]
                    K[st, i] = f[i] + h * TD[st] * dT[i] + acc / h
                _lu_solve(W, piv, nb, K[st])
            # error norm over all states, the ledger quadratures included (their accuracy is the
            # accuracy of the energy balance); atol per state
            err = 0.0
            finite = True
            for i in range(n):
                y1[i] = U[s - 1, i] + K[s - 1, i]
                if not math.isfinite(y1[i]):
                    finite = False
                sc = atol[i] + rtol * max(abs(y[i]), abs(y1[i]))
                err += (K[s - 1, i] / sc) ** 2
            err = math.sqrt(err / n) if finite else 1e300
            if err <= 1.0:
                break
            rejected = True
            h *= max(0.2, 0.9 * err ** -expo)
        if underflow:
            status = 2
            break
        # accepted step t -> t + h
        nsteps += 1
        # a step that ends within the smallest step size of t_end ends at t_end exactly (a
        # breakpoint: a sampling instant, an input sample; else the remainder would fail)
        t_new = t_end if t_end - (t + h) < 1e-14 * max(abs(t_end), 1.0) else t + h
        for r in range(TH.shape[0]):
            for i in range(n):
                acc = 0.0
                for j in range(s):
                    acc += TH[r, j] * K[j, i]
                E[r, i] = acc
        big = 0.0
        for i in range(n_model):
            big = max(big, abs(y1[i]))
        if not (big <= bound):
            status = 3
            break
        # events on (t, t_new], Φ over the step (its last A is the next step's J), the point
        hit, t, n_ev, n_store, g_old, njev, nfev, nlu, J_next, phi_err, eta_phi = _finish_step(
            fn, t, h, t_new, y, y1, E, p, g_old, directions, terminal, ev_t, ev_k, n_ev, yi, J, f0,
            W, piv, nb, TA, TC, TN, TD, gam, expo, rtol, atol, n_model, P, eta_phi, gain, ts, ys,
            phis, n_store, njev, nfev, nlu, phi_err)
        if hit >= 0:
            status = 1
            break
        have_next = m > 0
        f0 = rhs(t, y, p)
        nfev += 1
        fac = min(6.0, max(0.2, 0.9 * err ** -expo)) if err > 0.0 else 6.0
        if rejected:
            fac = min(fac, 1.0)
        h = min(h * fac, hmax)
    return (status, t, y, ts, ys, n_store, nfev, njev, nsteps, hit if status == 1 else -1, ev_t,
            ev_k, n_ev, h, nlu, P.reshape(n, m), phis.reshape(store_cap, n, m), phi_err)

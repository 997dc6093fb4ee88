/* The CVODE driver of the hand-written C walkers (cvode_compass_walker.c and
 * cvode_compliant_leg_walker.c include it after their equations): the CVODE callbacks, the walk
 * with the mode switches of tests/validation/handwritten_walkers.py (lift-off, a bounce of the
 * leading foot, heel strike, scuffing: the guard held on its new side at the restart, the fall),
 * the check of the Jacobian against central differences, and the timed repeats of a walk.
 *
 * The including file defines: NY, the state's size; the type Walker (its first members the
 * contact flags int c[2], int masked, double t_mask) and new_walker() (both feet in contact,
 * no guard masked); rhs_values and jac_values (the right-hand side and its Jacobian at y in the
 * walker's contact modes); penetration and foot_x (foot k's penetration and its position along
 * the slope); the parameters L, LIFTOFF_MARGIN, FRONT_MARGIN, FALL_FRACTION and MAX_STEP_TIME.
 * It includes the C and SUNDIALS headers this file uses. Benchmarks only. */

/* --- CVODE callbacks -------------------------------------------------------------------------- */
static long n_rhs_calls = 0, n_jac_calls = 0;

static int rhs_cb(sunrealtype t, N_Vector y, N_Vector ydot, void *data)
{
    (void)t;
    n_rhs_calls += 1;
    rhs_values((const Walker *)data, N_VGetArrayPointer(y), N_VGetArrayPointer(ydot));
    return 0;
}

static int jac_cb(sunrealtype t, N_Vector y, N_Vector fy, SUNMatrix Jm, void *data, N_Vector t1,
                  N_Vector t2, N_Vector t3)
{
    (void)t; (void)fy; (void)t1; (void)t2; (void)t3;
    double J[NY][NY];
    n_jac_calls += 1;
    jac_values((const Walker *)data, N_VGetArrayPointer(y), J);
    for (int i = 0; i < NY; ++i)
        for (int j = 0; j < NY; ++j)
            SM_ELEMENT_D(Jm, i, j) = J[i][j];
    return 0;
}

static int roots_cb(sunrealtype t, N_Vector yv, sunrealtype *g, void *data)
{
    const Walker *w = (const Walker *)data;
    const double *y = N_VGetArrayPointer(yv);
    for (int k = 0; k < 2; ++k) {
        const double v = w->c[k] ? penetration(y, k) + LIFTOFF_MARGIN : penetration(y, k);
        const double dir = w->c[k] ? -1.0 : 1.0;
        g[k] = (w->masked == k && t == w->t_mask) ? dir * fmax(fabs(v), 1e-300) : v;
    }
    g[2] = y[1] - FALL_FRACTION * L;
    return 0;
}

/* --- the walk ----------------------------------------------------------------------------------- */
/* a walk's end: the state at the last heel strike and its leading foot (zeros and 0 before one),
 * CVODE's steps, the evaluations, the events and strides, why it ended */
typedef struct {
    int strides, lead;
    double y[NY];
    long steps, nfev, njev, events;
    const char *end;
} WalkResult;

/* n_steps strides from the state y0 (foot 1 leading, foot 2 in contact unless it is above the
 * surface by the lift-off margin), at most MAX_STEP_TIME s each */
static WalkResult walk(const double *y0, int n_steps, double rtol, double atol, double max_step)
{
    WalkResult out = {0};
    Walker w = new_walker();
    SUNContext ctx;
    SUNContext_Create(NULL, &ctx);
    N_Vector y = N_VNew_Serial(NY, ctx);
    double *yd = N_VGetArrayPointer(y);
    memcpy(yd, y0, sizeof(double) * NY);
    if (!(penetration(yd, 1) + LIFTOFF_MARGIN > 0))
        w.c[1] = 0;
    void *mem = CVodeCreate(CV_BDF, ctx);
    SUNMatrix A = SUNDenseMatrix(NY, NY, ctx);
    SUNLinearSolver LS = SUNLinSol_Dense(y, A, ctx);
    CVodeInit(mem, rhs_cb, 0.0, y);
    CVodeSStolerances(mem, rtol, atol);
    CVodeSetUserData(mem, &w);
    CVodeSetLinearSolver(mem, LS, A);
    CVodeSetJacFn(mem, jac_cb);
    CVodeSetMaxStep(mem, max_step);
    CVodeSetMaxNumSteps(mem, 10000000);
    CVodeRootInit(mem, 3, roots_cb);
    int dirs[3];
    int lead = 0;
    double t = 0.0;
    const double t_end = MAX_STEP_TIME * n_steps;
    n_rhs_calls = n_jac_calls = 0;
    out.end = "time_limit";
    for (;;) {
        for (int k = 0; k < 2; ++k)
            dirs[k] = w.c[k] ? -1 : 1;
        dirs[2] = -1;
        CVodeSetRootDirection(mem, dirs);
        int flag = CVode(mem, t_end, y, &t, CV_NORMAL);
        long nst = 0;
        CVodeGetNumSteps(mem, &nst);
        out.steps += nst;
        if (flag != CV_ROOT_RETURN) {
            out.end = flag == CV_SUCCESS ? "time_limit" : "cvode_failure";
            break;
        }
        out.events += 1;
        int found[3];
        CVodeGetRootInfo(mem, found);
        w.masked = -1;
        if (found[2]) {
            out.end = "fall";
            break;
        }
        int k = found[0] ? 0 : 1;
        if (w.c[k]) {
            w.c[k] = 0;                                         /* lift-off */
        } else {
            const int other = 1 - k;
            if (k == lead) {
                w.c[k] = 1;                                     /* a bounce of the leading foot */
            } else if (foot_x(yd, k) - foot_x(yd, other) > FRONT_MARGIN) {
                w.c[k] = 1;                                     /* heel strike: a new step */
                lead = k;
                out.strides += 1;
                out.lead = k;
                memcpy(out.y, yd, sizeof(double) * NY);
                if (out.strides >= n_steps) {
                    out.end = "done";
                    break;
                }
            } else {
                w.masked = k;                                   /* scuffing: held at restart */
                w.t_mask = t;
            }
        }
        CVodeReInit(mem, t, y);
    }
    out.nfev = n_rhs_calls;
    out.njev = n_jac_calls;
    CVodeFree(&mem);
    SUNLinSolFree(LS);
    SUNMatDestroy(A);
    N_VDestroy(y);
    SUNContext_Free(&ctx);
    return out;
}

/* `repeats` walks from y0, their wall seconds printed as the start of the JSON line
 * ({"seconds": [...]); the last walk's result */
static WalkResult timed_walks(const double *y0, int n_steps, double rtol, double atol,
                              double max_step, int repeats)
{
    WalkResult res = {0};
    printf("{\"seconds\": [");
    for (int r = 0; r < repeats; ++r) {
        struct timespec a, b;
        clock_gettime(CLOCK_MONOTONIC, &a);
        res = walk(y0, n_steps, rtol, atol, max_step);
        clock_gettime(CLOCK_MONOTONIC, &b);
        printf("%s%.9f", r ? ", " : "", (b.tv_sec - a.tv_sec) + 1e-9 * (b.tv_nsec - a.tv_nsec));
    }
    return res;
}

/* --check: the largest difference between the Jacobian and central differences of the
 * right-hand side at the n states given (both feet in contact), relative to the Jacobian's
 * largest entry, as one JSON line */
static int check(const double (*states)[NY], int n)
{
    Walker w = new_walker();
    double worst = 0.0;
    for (int s = 0; s < n; ++s) {
        double J[NY][NY], f1[NY], f2[NY], y[NY], scale = 0.0;
        jac_values(&w, states[s], J);
        for (int i = 0; i < NY; ++i)
            for (int j = 0; j < NY; ++j)
                scale = fmax(scale, fabs(J[i][j]));
        for (int j = 0; j < NY; ++j) {
            const double h = 1e-7 * fmax(1.0, fabs(states[s][j]));
            memcpy(y, states[s], sizeof(y));
            y[j] += h;
            rhs_values(&w, y, f1);
            y[j] -= 2 * h;
            rhs_values(&w, y, f2);
            for (int i = 0; i < NY; ++i)
                worst = fmax(worst, fabs((f1[i] - f2[i]) / (2 * h) - J[i][j]) / scale);
        }
    }
    printf("{\"jacobian_vs_central_differences\": %.3e}\n", worst);
    return 0;
}

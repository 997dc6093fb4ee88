/* The runtime of an FMU exported by porthamiltonian (docs/fmu.md), shared by FMI 2.0 and 3.0:
 * the instance and its values, variables by value reference, events and their rules, the
 * directional derivatives, the FMU state, and the co-simulation step.
 *
 * Model exchange. The continuous states are the model's states followed by the energy ledger's
 * E_diss and E_in (dE_diss/dt = P_diss, dE_in/dt = P_in); the event indicators are the model's
 * event guards. An event fires when its guard has crossed zero in the event's direction since the
 * last event (the sign it had then is kept, ph_values.g_prev). At an event of a terminal event
 * with rules, the first rule whose conditions hold sets its mode parameters and books the jump of
 * H in the ledger (as porthamiltonian.simulate does for an action's Reset); a terminal event
 * without rules, or a rule with stop, ends the simulation (terminateSimulation).
 *
 * Co-simulation. The instance integrates with the compiled Rosenbrock loop of model.c, one
 * accepted step per call, as porthamiltonian.simulate's compiled segments do: the steps do not
 * depend on the communication points, so the trajectory (and every event time) is the one the
 * framework computes with the same method, tolerances, maximum step and stop time. The values at
 * a communication point inside a step come from an integration of their own from the step's
 * start (same loop, error-controlled, guards off); the events found in that step count from
 * their own times. A tunable parameter set between steps restarts the integration from the
 * communication point.
 *
 * Inputs. Input k reads the two slots p[PH_NP + k] + p[PH_NP + PH_NU + k] t of the parameter
 * vector (the compiled model's input slots): the runtime writes them from the value the importer
 * sets, held, or (FMI 2.0 co-simulation, fmi2SetRealInputDerivatives) extrapolated linearly from
 * the time it was set. In co-simulation an input that changed restarts the integration at the
 * communication point, as the framework's run stops at a sample time of its inputs.
 *
 * Discrete-time blocks are sampled at t_k = t_start + k T (computed, never accumulated): each
 * block's generated update gives its new discrete states from the state just before t_k (with
 * the inputs set for the time from t_k on). Model exchange: time events (nextEventTime), the
 * samples taken in the event update. Co-simulation: the integration stops exactly on t_k and
 * samples when it goes on from there (a sampling instant on a communication point is taken in
 * the doStep that starts there, after the importer set its inputs). */

#define PH_STORE 64                 /* stored points and events of one loop call */
#define PH_SIDE_STEPS 100000        /* the steps of one integration to a communication point */

typedef struct {
    double t;
    double y[PH_N];                 /* model states, E_diss, E_in */
    double p[PH_NS1];               /* parameters, then the inputs' slots (a: PH_NU, b: PH_NU) */
    int64_t sample_k[PH_ND1];       /* the next sample of each discrete-time block */
    int64_t ev_count[PH_NE1];
    double ev_time[PH_NE1];
    int64_t ctr_count[PH_NC1];
    double ctr_time[PH_NC1];
    int stop;                       /* the run ends here (a terminal event) */
} ph_point;

enum { PH_INSTANTIATED, PH_INIT, PH_EVENT_MODE, PH_CONTINUOUS, PH_STEP_MODE, PH_TERMINATED,
       PH_FAILED };

/* everything an FMU state holds (get/set/serialize copy it whole) */
typedef struct {
    int mode;
    ph_point now;                   /* the values at the current time */
    double h_start;                 /* H at the end of initialization (the residual's origin) */
    int state_set[PH_N];            /* a state's start value was set (not from the parameters) */
    double g_prev[PH_NE1];          /* model exchange: guards after the last event */
    double solver[3];               /* rtol, atol, max_step */
    double t_start, t_stop;
    int stop_defined;
    /* inputs as the importer set them: the value u at time u_time, the derivative du */
    double u[PH_NU1], u_time[PH_NU1], du[PH_NU1];
    double period[PH_ND1];          /* the discrete blocks' sample periods (read at init) */
    /* co-simulation */
    ph_point main, prev;            /* the integration's point; the point before its last step */
    ph_point cross;                 /* the first point of this doStep whose next step would
                                       cross the communication point (porthamiltonian.simulate
                                       would shorten that step to end on it: a breakpoint) */
    double cross_h;                 /* the step size proposed there */
    int have_prev, restart, have_cross;
    double h_next, t_segment;
    double h_now;                   /* the step size to go on with from v.now (a restart) */
    int64_t mask_index;
    double mask_sign;
    int n_last;                     /* the non-terminal events of the last step */
    double last_t[PH_STORE];
    int64_t last_k[PH_STORE];
    double last_successful;
} ph_values;

typedef struct ph_instance_s ph_instance;
typedef void (*ph_callback)(void);      /* the standard's logger, whichever version's */
typedef void (*ph_log_fn)(ph_instance *, int status, const char *category, const char *message);

struct ph_instance_s {
    int cosimulation;
    char *name;
    void *environment;
    ph_callback logger;             /* the standard's callback (FMI 2 or 3) */
    ph_log_fn log;
    int logging, log_events;
    ph_values v;
    /* values at v.now, computed when asked for (valid flags cleared by every change) */
    int have_rates, have_outputs, have_energy, have_guards;
    double rates[PH_N], out[PH_NO1], energy[3], g[PH_NG];
    /* buffers of the loop */
    double ts[PH_STORE], ys[PH_STORE * PH_N], ev_t[PH_STORE], th[2], y_out[PH_N], atol[PH_N];
    int64_t ev_k[PH_STORE], counts[7];   /* the loops' counters (rosenbrock_loop.c) */
};

enum { PH_OK, PH_WARNING, PH_DISCARD, PH_ERROR };

static void ph_logf(ph_instance *c, int status, const char *category, const char *fmt, ...)
{
    char message[512];
    va_list args;
    if (c == NULL || c->logger == NULL)
        return;
    if (status == PH_OK && !(c->logging && c->log_events))
        return;
    va_start(args, fmt);
    vsnprintf(message, sizeof message, fmt, args);
    va_end(args);
    c->log(c, status, category, message);
}

#define PH_FAIL(c, ...) (ph_logf((c), PH_ERROR, "logStatusError", __VA_ARGS__), PH_ERROR)

static void ph_changed(ph_instance *c)
{
    c->have_rates = c->have_outputs = c->have_energy = c->have_guards = 0;
}

/* the input slots of pt: u_k(t) = u_k + du_k (t - u_time_k), as the importer set them */
static void ph_input_slots(const ph_values *v, ph_point *pt)
{
    for (int k = 0; k < PH_NU; ++k) {
        pt->p[PH_NP + k] = v->u[k] - v->du[k] * v->u_time[k];
        pt->p[PH_NP + PH_NU + k] = v->du[k];
    }
}

/* tgrad of the compiled loop (the step of its difference in t): 0 for a model autonomous with
 * inputs that are constant on the step, as porthamiltonian.simulate takes it */
static double ph_tgrad(const ph_values *v, const double *p)
{
    int moving = 0;
    for (int k = 0; k < PH_NU; ++k)
        moving |= p[PH_NP + PH_NU + k] != 0.0;
    return (PH_AUTONOMOUS && !moving) ? 0.0 : 1e-7 * fmax(1.0, fabs(v->t_segment));
}

/* the current rates, outputs, energy and guards: each computed once per state and time */
#define PH_NOW(what, fn, flag, buf)                              \
    static const double *ph_now_##what(ph_instance *c)           \
    {                                                            \
        if (!c->flag) {                                          \
            fn(c->v.now.t, c->v.now.y, c->v.now.p, c->buf);      \
            c->flag = 1;                                         \
        }                                                        \
        return c->buf;                                           \
    }
PH_NOW(rates, rhs, have_rates, rates)
PH_NOW(outputs, outputs, have_outputs, out)
PH_NOW(energy, energy, have_energy, energy)
PH_NOW(guards, guards, have_guards, g)
#undef PH_NOW

static const double *ph_now_states(ph_instance *c)
{
    return c->v.now.y;
}

/* The `want` values of `values` at v.now copied into `to` (FMI's get derivatives, event
 * indicators and continuous states); n: how many the caller asked for, an error naming `what`
 * unless it is `want` */
static int ph_values_out(ph_instance *c, double *to, size_t n, int want, const char *what,
                         const double *(*values)(ph_instance *))
{
    if (n != (size_t)want)
        return PH_FAIL(c, "%s: %zu %s asked for, the FMU has %d", c->name, n, what, want);
    if (n > 0)
        memcpy(to, values(c), sizeof(double) * n);
    return PH_OK;
}

/* --- instance --------------------------------------------------------------------------------- */
static void ph_defaults(ph_instance *c)
{
    ph_values *v = &c->v;
    memset(v, 0, sizeof *v);
    v->mode = PH_INSTANTIATED;
    memcpy(v->now.p, ph_param_start, sizeof v->now.p);
    memcpy(v->now.y, ph_state_start, sizeof v->now.y);
    memcpy(v->solver, ph_solver_defaults, sizeof v->solver);
    for (int k = 0; k < PH_NU; ++k)
        v->u[k] = ph_param_start[PH_NP + k];
    v->mask_index = -1;
    ph_changed(c);
}

static ph_instance *ph_instantiate(const char *name, int cosimulation, void *environment,
                                   ph_callback logger, ph_log_fn log, int logging)
{
    ph_instance *c = calloc(1, sizeof(ph_instance));
    if (c == NULL)
        return NULL;
    size_t len = strlen(name ? name : "");
    c->name = malloc(len + 1);
    if (c->name == NULL) {
        free(c);
        return NULL;
    }
    memcpy(c->name, name ? name : "", len + 1);
    c->cosimulation = cosimulation;
    c->environment = environment;
    c->logger = logger;
    c->log = log;
    c->logging = logging;
    c->log_events = 1;
    ph_defaults(c);
    return c;
}

static void ph_free(ph_instance *c)
{
    if (c != NULL) {
        free(c->name);
        free(c);
    }
}

static void ph_set_debug_logging(ph_instance *c, int on, size_t n, const char *const *categories)
{
    c->logging = on;
    if (n == 0 || categories == NULL) {
        c->log_events = 1;
        return;
    }
    c->log_events = 0;
    for (size_t i = 0; i < n; ++i)
        if (categories[i] != NULL && strcmp(categories[i], "logEvents") == 0)
            c->log_events = 1;
}

/* --- variables -------------------------------------------------------------------------------- */
static const ph_variable *ph_find(ph_instance *c, unsigned int vr, int integer)
{
    if (vr >= PH_NVARS || ph_variables[vr].integer != integer) {
        ph_logf(c, PH_ERROR, "logStatusError", "%s: no %s variable has value reference %u",
                c->name, integer ? "Integer" : "Real", vr);
        return NULL;
    }
    return &ph_variables[vr];
}

static int ph_get_real(ph_instance *c, unsigned int vr, double *value)
{
    const ph_variable *var = ph_find(c, vr, 0);
    if (var == NULL)
        return PH_ERROR;
    const ph_point *now = &c->v.now;
    const int i = var->index;
    switch (var->kind) {
    case PH_TIME: *value = now->t; break;
    case PH_PARAM: *value = now->p[i]; break;
    case PH_STATE: *value = now->y[i]; break;
    case PH_RATE: *value = ph_now_rates(c)[i]; break;
    case PH_OUTPUT: *value = ph_now_outputs(c)[i]; break;
    case PH_ENERGY: *value = ph_now_energy(c)[i]; break;
    case PH_RESIDUAL:
        *value = ph_now_energy(c)[0] - c->v.h_start + now->y[PH_NX] - now->y[PH_NX + 1];
        break;
    case PH_INDICATOR: *value = ph_now_guards(c)[i]; break;
    case PH_EVENT_TIME: *value = now->ev_time[i]; break;
    case PH_COUNTER_TIME: *value = now->ctr_time[i]; break;
    case PH_SOLVER: *value = c->v.solver[i]; break;
    case PH_INPUT: *value = c->v.u[i]; break;
    default: return PH_FAIL(c, "%s: value reference %u is not a Real", c->name, vr);
    }
    return PH_OK;
}

static int ph_get_integer(ph_instance *c, unsigned int vr, int64_t *value)
{
    const ph_variable *var = ph_find(c, vr, 1);
    if (var == NULL)
        return PH_ERROR;
    if (var->kind == PH_EVENT_COUNT)
        *value = c->v.now.ev_count[var->index];
    else
        *value = c->v.now.ctr_count[var->index];
    return PH_OK;
}

static int ph_set_real(ph_instance *c, unsigned int vr, double value)
{
    const ph_variable *var = ph_find(c, vr, 0);
    if (var == NULL)
        return PH_ERROR;
    const int before = c->v.mode == PH_INSTANTIATED || c->v.mode == PH_INIT;
    if (var->access == PH_READ_ONLY || (var->access == PH_BEFORE_INIT && !before))
        return PH_FAIL(c, "%s: variable %u cannot be set %s", c->name, vr,
                       var->access == PH_READ_ONLY ? "(it is computed)"
                                                   : "after initialization (it is not tunable)");
    if (!isfinite(value))
        return PH_FAIL(c, "%s: variable %u must be finite, got %g", c->name, vr, value);
    switch (var->kind) {
    case PH_PARAM:
        if (c->v.now.p[var->index] != value && !before)
            c->v.restart = 1;
        c->v.now.p[var->index] = value;
        break;
    case PH_STATE:
        c->v.now.y[var->index] = value;
        c->v.state_set[var->index] = 1;
        break;
    case PH_INPUT:
        c->v.u[var->index] = value;
        c->v.u_time[var->index] = c->v.now.t;
        ph_input_slots(&c->v, &c->v.now);
        break;
    case PH_SOLVER:
        if (!(value > 0.0))
            return PH_FAIL(c, "%s: the solver's settings (rtol, atol, max_step) must be positive, "
                           "got %g", c->name, value);
        c->v.solver[var->index] = value;
        break;
    default:
        return PH_FAIL(c, "%s: variable %u cannot be set", c->name, vr);
    }
    ph_changed(c);
    return PH_OK;
}

/* FMI's Get/Set of Real (FMI 3: Float64) and Integer (FMI 3: Int32) values, one value reference
 * at a time; the first that fails ends the call (an FMI 3 Int32 is an int here, as a value
 * reference is an unsigned int: ph_fmu.h's types on the platforms the FMU is built for) */
static int ph_get_reals(ph_instance *c, const unsigned int *vr, size_t n, double *values)
{
    for (size_t i = 0; i < n; ++i)
        if (ph_get_real(c, vr[i], &values[i]) != PH_OK)
            return PH_ERROR;
    return PH_OK;
}

static int ph_get_integers(ph_instance *c, const unsigned int *vr, size_t n, int *values)
{
    for (size_t i = 0; i < n; ++i) {
        int64_t v;
        if (ph_get_integer(c, vr[i], &v) != PH_OK)
            return PH_ERROR;
        values[i] = (int)v;
    }
    return PH_OK;
}

static int ph_set_reals(ph_instance *c, const unsigned int *vr, size_t n, const double *values)
{
    for (size_t i = 0; i < n; ++i)
        if (ph_set_real(c, vr[i], values[i]) != PH_OK)
            return PH_ERROR;
    return PH_OK;
}

/* --- events and rules ------------------------------------------------------------------------- */
static int ph_holds(const ph_condition *cond, const double *out)
{
    const double a = out[cond->output];
    switch (cond->op) {
    case PH_LT: return a < 0.0;
    case PH_LE: return a <= 0.0;
    case PH_GT: return a > 0.0;
    case PH_GE: return a >= 0.0;
    case PH_EQ: return a == 0.0;
    default: return a != 0.0;
    }
}

/* the first rule of event k (-1: the start) whose conditions hold for the outputs out, or -1 */
static int ph_first_rule(int k, const double *out)
{
    for (int r = 0; r < PH_NR; ++r) {
        if (ph_rules[r].event != k)
            continue;
        int ok = 1;
        for (int j = 0; j < ph_rules[r].n_conditions && ok; ++j)
            ok = ph_holds(&ph_conditions[ph_rules[r].first_condition + j], out);
        if (ok)
            return r;
    }
    return -1;
}

/* rule r's changes applied to the parameters of pt (out: the outputs before the event) */
static void ph_change_modes(int r, ph_point *pt, const double *out)
{
    for (int j = 0; j < ph_rules[r].n_changes; ++j) {
        const ph_change *ch = &ph_changes[ph_rules[r].first_change + j];
        pt->p[ch->param] = ch->output >= 0 ? out[ch->output] : ch->constant;
    }
}

/* Event k fired at pt: counted; a terminal event runs its first rule that applies (its modes,
 * the jump of H booked in the ledger, its counter, its stop), or ends the run without rules.
 * out: PH_NO1 doubles of work. */
static void ph_fire(ph_instance *c, ph_point *pt, int k, double *out)
{
    pt->ev_count[k] += 1;
    pt->ev_time[k] = pt->t;
    ph_logf(c, PH_OK, "logEvents", "%s: event %s at t = %.17g", c->name, ph_event_names[k], pt->t);
    if (!ph_event_terminal[k])
        return;
    if (!ph_event_action[k]) {
        pt->stop = 1;
        ph_logf(c, PH_OK, "logEvents", "%s: terminal event %s ends the run", c->name,
                ph_event_names[k]);
        return;
    }
    outputs(pt->t, pt->y, pt->p, out);
    const int r = ph_first_rule(k, out);
    if (r < 0)
        return;
    double e[3];
    energy(pt->t, pt->y, pt->p, e);
    const double h_before = e[0];
    ph_change_modes(r, pt, out);
    energy(pt->t, pt->y, pt->p, e);
    const double jump = e[0] - h_before;
    if (ph_rules[r].supplied)
        pt->y[PH_NX + 1] += jump;
    else
        pt->y[PH_NX] -= jump;
    if (ph_rules[r].counter >= 0) {
        pt->ctr_count[ph_rules[r].counter] += 1;
        pt->ctr_time[ph_rules[r].counter] = pt->t;
    }
    if (ph_rules[r].stop)
        pt->stop = 1;
    ph_logf(c, PH_OK, "logEvents", "%s: rule %d of event %s at t = %.17g%s", c->name, r + 1,
            ph_event_names[k], pt->t, ph_rules[r].stop ? ": the run ends" : "");
}

/* a guard's crossing from a to b in direction d (the compiled loop's test) */
static int ph_crossed(double a, double b, int64_t d)
{
    const int up = a <= 0.0 && b >= 0.0, down = a >= 0.0 && b <= 0.0;
    return a != b && ((up && d > 0) || (down && d < 0) || ((up || down) && d == 0));
}

/* --- discrete-time blocks ---------------------------------------------------------------------- */
/* the next sampling instant of pt (t_start + k T over the blocks), INFINITY without blocks */
static double ph_next_sample(const ph_values *v, const ph_point *pt)
{
    double next = INFINITY;
    for (int j = 0; j < PH_ND; ++j)
        next = fmin(next, v->t_start + (double)pt->sample_k[j] * v->period[j]);
    return next;
}

/* The samples due at pt->t (instants up to pt->t + tol): each block due takes its new discrete
 * states from its update at the state before the instant (all from the same state, in the order
 * of the blocks); a block's instants up to pt->t + tol are passed. PH_ERROR for a non-finite
 * result. */
static int ph_sample(ph_instance *c, ph_point *pt, double tol)
{
    const ph_values *v = &c->v;
    double before[PH_N], out[PH_NX1];
    memcpy(before, pt->y, sizeof before);
    for (int j = 0; j < PH_ND; ++j) {
        if (v->t_start + (double)pt->sample_k[j] * v->period[j] > pt->t + tol)
            continue;
        ph_block_update[j](pt->t, before, pt->p, out);
        for (int i = 0; i < ph_block_count[j]; ++i) {
            if (!isfinite(out[i]))
                return PH_FAIL(c, "%s: the sampling of discrete block %s at t = %.17g gave a "
                               "non-finite state", c->name, ph_block_names[j], pt->t);
            pt->y[ph_block_states[ph_block_first[j] + i]] = out[i];
        }
        while (v->t_start + (double)pt->sample_k[j] * v->period[j] <= pt->t + tol)
            pt->sample_k[j] += 1;
    }
    return PH_OK;
}

/* --- initialization --------------------------------------------------------------------------- */
static int ph_enter_initialization(ph_instance *c, int tol_defined, double tol, double t_start,
                                   int stop_defined, double t_stop)
{
    if (c->v.mode != PH_INSTANTIATED)
        return PH_FAIL(c, "%s: enter initialization mode only after instantiation", c->name);
    if (tol_defined && c->cosimulation) {
        if (!(tol > 0.0 && tol < 1.0))
            return PH_FAIL(c, "%s: the tolerance must be in (0, 1), got %g", c->name, tol);
        c->v.solver[0] = tol;
    }
    c->v.t_start = t_start;
    c->v.now.t = t_start;
    c->v.stop_defined = stop_defined;
    c->v.t_stop = stop_defined ? t_stop : INFINITY;
    if (stop_defined && !(t_stop >= t_start))
        return PH_FAIL(c, "%s: stop time %g before start time %g", c->name, t_stop, t_start);
    c->v.mode = PH_INIT;
    ph_changed(c);
    return PH_OK;
}

static int ph_exit_initialization(ph_instance *c)
{
    ph_values *v = &c->v;
    if (v->mode != PH_INIT)
        return PH_FAIL(c, "%s: exit initialization mode only after entering it", c->name);
    if (PH_STATES_FROM_PARAMETERS) {
        double x0[PH_NX1];
        initial(v->now.p, x0);
        for (int i = 0; i < PH_NX; ++i)
            if (!v->state_set[i])
                v->now.y[i] = x0[i];
    }
    for (int i = 0; i < PH_N; ++i)
        if (!isfinite(v->now.y[i]))
            return PH_FAIL(c, "%s: the initial state is not finite (state %d)", c->name, i);
    double out[PH_NO1];
    outputs(v->now.t, v->now.y, v->now.p, out);
    const int r = ph_first_rule(-1, out);
    if (r >= 0)
        ph_change_modes(r, &v->now, out);
    ph_changed(c);
    if (PH_ND > 0) {            /* the sample periods, read at the start (outputs <block>.T) */
        const double *o = ph_now_outputs(c);
        for (int j = 0; j < PH_ND; ++j) {
            v->period[j] = o[ph_block_period[j]];
            v->now.sample_k[j] = 0;
            if (!(isfinite(v->period[j]) && v->period[j] > 0.0))
                return PH_FAIL(c, "%s: discrete block %s: its sample period must be a finite "
                               "number > 0, got %g", c->name, ph_block_names[j], v->period[j]);
        }
    }
    v->h_start = ph_now_energy(c)[0];
    memcpy(v->g_prev, ph_now_guards(c), sizeof(double) * PH_NE);
    for (int i = 0; i < PH_N; ++i)
        c->atol[i] = v->solver[1];
    v->main = v->now;
    v->h_next = 0.0;
    v->h_now = 0.0;
    v->t_segment = v->now.t;
    v->mask_index = -1;
    v->last_successful = v->now.t;
    v->mode = c->cosimulation ? PH_STEP_MODE : PH_EVENT_MODE;
    return PH_OK;
}

/* --- model exchange --------------------------------------------------------------------------- */
/* the event update of model exchange: every guard that crossed in its direction since the last
 * event fires (in the order of the events), then the discrete blocks due sample (a time event);
 * *terminate when the run ends, *moved when states changed (the ledger's, the blocks'),
 * *next_time the next sampling instant (*next_defined: there is one) */
static int ph_update_discrete(ph_instance *c, int *terminate, int *moved, int *next_defined,
                              double *next_time)
{
    ph_values *v = &c->v;
    double g_old[PH_NE1], out[PH_NO1], before[PH_N];
    memcpy(g_old, ph_now_guards(c), sizeof(double) * PH_NE);
    memcpy(before, v->now.y, sizeof before);
    int fired[PH_NE1];
    for (int k = 0; k < PH_NE; ++k) {
        fired[k] = ph_crossed(v->g_prev[k], g_old[k], ph_event_directions[k]);
        if (fired[k])
            ph_fire(c, &v->now, k, out);
    }
    *next_defined = 0;
    *next_time = 0.0;
    if (PH_ND > 0) {
        const double t_k = ph_next_sample(v, &v->now);
        const double tol = 1e-10 * fmax(1.0, fabs(t_k));
        if (v->now.t >= t_k - tol && ph_sample(c, &v->now, tol) != PH_OK)
            return PH_ERROR;
        *next_time = ph_next_sample(v, &v->now);
        *next_defined = isfinite(*next_time) &&
                        !(v->stop_defined && *next_time >= v->t_stop);
        if (!*next_defined)
            *next_time = 0.0;
    }
    ph_changed(c);
    const double *g = ph_now_guards(c);
    for (int k = 0; k < PH_NE; ++k) {
        const double a = v->g_prev[k], b = g_old[k];
        if (ph_crossed(a, b, 0)) {      /* keep a crossed guard on the side it crossed to */
            const double side = (a <= 0.0 && b >= 0.0) ? 1.0 : -1.0;
            v->g_prev[k] = side * fmax(fabs(g[k]), 1e-300);
        } else {
            v->g_prev[k] = g[k];
        }
    }
    *moved = memcmp(before, v->now.y, sizeof before) != 0;
    *terminate = v->now.stop;
    if (v->now.stop)
        v->mode = PH_TERMINATED;
    return PH_OK;
}

/* completed integrator step: a guard that crossed in its direction asks for an event */
static int ph_step_event(ph_instance *c)
{
    const double *g = ph_now_guards(c);
    for (int k = 0; k < PH_NE; ++k)
        if (ph_crossed(c->v.g_prev[k], g[k], ph_event_directions[k]))
            return 1;
    return 0;
}

/* --- directional derivatives ------------------------------------------------------------------ */
/* the value of variable vr at (t, y, p) (uncached: for differences) */
static double ph_value_at(ph_instance *c, unsigned int vr, const double *y, const double *p)
{
    ph_values saved = c->v;
    memcpy(c->v.now.y, y, sizeof c->v.now.y);
    memcpy(c->v.now.p, p, sizeof c->v.now.p);
    ph_changed(c);
    double value = NAN;
    ph_get_real(c, vr, &value);
    c->v = saved;
    ph_changed(c);
    return value;
}

/* sensitivity = d(unknowns)/d(knowns) . seed. The state derivatives by the states and inputs:
 * the compiled Jacobians (jac, jac_u: exact); any other pair (outputs, H, guards; parameters as
 * knowns): central differences along the seed (an input moves its slot a: u + eps at any t). */
static int ph_directional(ph_instance *c, const unsigned int *unknowns, size_t n_unknowns,
                          const unsigned int *knowns, size_t n_knowns, const double *seed,
                          double *sensitivity)
{
    double dy[PH_N], dp[PH_NS1], du[PH_NU1];
    int exact = 1, by_inputs = 0;
    memset(dy, 0, sizeof dy);
    memset(dp, 0, sizeof dp);
    memset(du, 0, sizeof du);
    for (size_t j = 0; j < n_knowns; ++j) {
        const ph_variable *var = ph_find(c, knowns[j], 0);
        if (var == NULL)
            return PH_ERROR;
        if (var->kind == PH_STATE) {
            dy[var->index] += seed[j];
        } else if (var->kind == PH_PARAM) {
            dp[var->index] += seed[j];
            exact = 0;
        } else if (var->kind == PH_INPUT) {
            dp[PH_NP + var->index] += seed[j];
            du[var->index] += seed[j];
            by_inputs = 1;
        } else {
            return PH_FAIL(c, "%s: directional derivatives by variable %u: only states, inputs "
                           "and parameters are knowns", c->name, knowns[j]);
        }
    }
    double *J = NULL;
    double yp[PH_N], ym[PH_N], pp[PH_NS1], pm[PH_NS1];
    double scale = 0.0, size = 0.0;
    for (int i = 0; i < PH_N; ++i) {
        scale = fmax(scale, fabs(c->v.now.y[i]));
        size = fmax(size, fabs(dy[i]));
    }
    for (int i = 0; i < PH_NP + PH_NU; ++i) {
        scale = fmax(scale, fabs(c->v.now.p[i]));
        size = fmax(size, fabs(dp[i]));
    }
    const double eps = size > 0.0 ? 6.0554544523933395e-06 * fmax(scale, 1.0) / size : 0.0;
    for (int i = 0; i < PH_N; ++i) {
        yp[i] = c->v.now.y[i] + eps * dy[i];
        ym[i] = c->v.now.y[i] - eps * dy[i];
    }
    for (int i = 0; i < PH_NS1; ++i) {
        pp[i] = c->v.now.p[i] + eps * dp[i];
        pm[i] = c->v.now.p[i] - eps * dp[i];
    }
    for (size_t u = 0; u < n_unknowns; ++u) {
        const ph_variable *var = ph_find(c, unknowns[u], 0);
        if (var == NULL) {
            free(J);
            return PH_ERROR;
        }
        if (var->kind == PH_RATE && exact) {
            if (J == NULL) {
                J = malloc(sizeof(double) * PH_N * (PH_N + PH_NU));
                if (J == NULL)
                    return PH_FAIL(c, "%s: out of memory", c->name);
                jac(c->v.now.t, c->v.now.y, c->v.now.p, J);
#if PH_NU > 0
                if (by_inputs)
                    jac_u(c->v.now.t, c->v.now.y, c->v.now.p, J + PH_N * PH_N);
#endif
            }
            double acc = 0.0;
            for (int j = 0; j < PH_N; ++j)
                acc += J[var->index * PH_N + j] * dy[j];
            for (int k = 0; k < PH_NU && by_inputs; ++k)
                acc += J[PH_N * PH_N + var->index * PH_NU + k] * du[k];
            sensitivity[u] = acc;
        } else if (eps == 0.0) {
            sensitivity[u] = 0.0;
        } else {
            sensitivity[u] = (ph_value_at(c, unknowns[u], yp, pp) -
                              ph_value_at(c, unknowns[u], ym, pm)) / (2.0 * eps);
        }
    }
    free(J);
    return PH_OK;
}

/* --- FMU state -------------------------------------------------------------------------------- */
#define PH_STATE_MAGIC 0x70684655u        /* "phFU" */

typedef struct {
    uint32_t magic;
    uint32_t size;
    char token[sizeof PH_TOKEN];
    ph_values values;
} ph_saved;

static int ph_get_state(ph_instance *c, void **state)
{
    ph_saved *s = *state != NULL ? (ph_saved *)*state : malloc(sizeof(ph_saved));
    if (s == NULL)
        return PH_FAIL(c, "%s: out of memory", c->name);
    s->magic = PH_STATE_MAGIC;
    s->size = (uint32_t)sizeof(ph_saved);
    memcpy(s->token, PH_TOKEN, sizeof PH_TOKEN);
    s->values = c->v;
    *state = s;
    return PH_OK;
}

static int ph_check_state(ph_instance *c, const ph_saved *s)
{
    if (s == NULL || s->magic != PH_STATE_MAGIC || s->size != sizeof(ph_saved) ||
        memcmp(s->token, PH_TOKEN, sizeof PH_TOKEN) != 0)
        return PH_FAIL(c, "%s: not an FMU state of this FMU", c->name);
    return PH_OK;
}

static int ph_set_state(ph_instance *c, const void *state)
{
    const ph_saved *s = (const ph_saved *)state;
    if (ph_check_state(c, s) != PH_OK)
        return PH_ERROR;
    c->v = s->values;
    ph_changed(c);
    return PH_OK;
}

/* Free a state of ph_get_state or ph_deserialize (FMI's FreeFMUState); *state becomes NULL */
static void ph_free_state(void **state)
{
    if (state != NULL) {
        free(*state);
        *state = NULL;
    }
}

/* The state's bytes (FMI's SerializeFMUState) into bytes, size long: sizeof(ph_saved) needed */
static int ph_serialize(ph_instance *c, const void *state, void *bytes, size_t size)
{
    if (ph_check_state(c, (const ph_saved *)state) != PH_OK)
        return PH_ERROR;
    if (size < sizeof(ph_saved))
        return PH_FAIL(c, "%s: %zu bytes for a serialized FMU state of %zu", c->name, size,
                       sizeof(ph_saved));
    memcpy(bytes, state, sizeof(ph_saved));
    return PH_OK;
}

static int ph_deserialize(ph_instance *c, const void *bytes, size_t size, void **state)
{
    if (size != sizeof(ph_saved))
        return PH_FAIL(c, "%s: a serialized FMU state of %zu bytes (expected %zu)", c->name, size,
                       sizeof(ph_saved));
    ph_saved *s = *state != NULL ? (ph_saved *)*state : malloc(sizeof(ph_saved));
    if (s == NULL)
        return PH_FAIL(c, "%s: out of memory", c->name);
    memcpy(s, bytes, sizeof(ph_saved));
    if (ph_check_state(c, s) != PH_OK) {
        if (*state == NULL)
            free(s);
        return PH_ERROR;
    }
    *state = s;
    return PH_OK;
}

/* FMI's six FMU-state functions, each one call into the functions above, for FMI 2 and FMI 3
 * (expanded once by fmi2.c and once by fmi3.c) in the standard's names and types: V the version
 * (2, 3), INSTANCE its instance type (fmi2Component, fmi3Instance), STATE its spelling of
 * "FMUState" in the names and the state's type (FMI 2: FMUstate), DESERIALIZE its spelling of
 * the verb (FMI 2: DeSerialize). E.g. V 2: fmi2GetFMUstate(fmi2Component, fmi2FMUstate *). */
#define PH_STATE_RETURN(V, call)                                                              \
    do {                                                                                      \
        if (instance == NULL)                                                                 \
            return fmi##V##Error;                                                             \
        return ph_fmi##V##_status[call];                                                      \
    } while (0)
#define PH_FMU_STATE_FUNCTIONS(V, INSTANCE, STATE, DESERIALIZE)                               \
    PH_FMI_EXPORT fmi##V##Status PH_FMI##V(fmi##V##Get##STATE)(INSTANCE instance,             \
                                                               fmi##V##STATE *state)          \
    {                                                                                         \
        PH_STATE_RETURN(V, ph_get_state(instance, state));                                    \
    }                                                                                         \
    PH_FMI_EXPORT fmi##V##Status PH_FMI##V(fmi##V##Set##STATE)(INSTANCE instance,             \
                                                               fmi##V##STATE state)           \
    {                                                                                         \
        PH_STATE_RETURN(V, ph_set_state(instance, state));                                    \
    }                                                                                         \
    PH_FMI_EXPORT fmi##V##Status PH_FMI##V(fmi##V##Free##STATE)(INSTANCE instance,            \
                                                                fmi##V##STATE *state)         \
    {                                                                                         \
        (void)instance;                                                                       \
        ph_free_state(state);                                                                 \
        return fmi##V##OK;                                                                    \
    }                                                                                         \
    PH_FMI_EXPORT fmi##V##Status PH_FMI##V(fmi##V##Serialized##STATE##Size)(                  \
        INSTANCE instance, fmi##V##STATE state, size_t *size)                                 \
    {                                                                                         \
        if (instance == NULL)                                                                 \
            return fmi##V##Error;                                                             \
        (void)state;                                                                          \
        *size = sizeof(ph_saved);                                                             \
        return fmi##V##OK;                                                                    \
    }                                                                                         \
    PH_FMI_EXPORT fmi##V##Status PH_FMI##V(fmi##V##Serialize##STATE)(                         \
        INSTANCE instance, fmi##V##STATE state, fmi##V##Byte serializedState[], size_t size)  \
    {                                                                                         \
        PH_STATE_RETURN(V, ph_serialize(instance, state, serializedState, size));             \
    }                                                                                         \
    PH_FMI_EXPORT fmi##V##Status PH_FMI##V(fmi##V##DESERIALIZE##STATE)(                       \
        INSTANCE instance, const fmi##V##Byte serializedState[], size_t size,                 \
        fmi##V##STATE *state)                                                                 \
    {                                                                                         \
        PH_STATE_RETURN(V, ph_deserialize(instance, serializedState, size, state));           \
    }

/* --- co-simulation ---------------------------------------------------------------------------- */
/* One accepted step of v->main (the loop returns after it: max_steps = 1), with its events and
 * rules; the point before it in v->prev. The discrete blocks due at v->main sample first; the
 * step ends on the next sampling instant at the latest. The first point whose step would cross
 * the communication point `target` is kept (v->cross). 0 on success (also at the stop time or
 * a terminal event), else the loop's failure status (-1: a sampling failed). */
static int ph_main_step(ph_instance *c, double target)
{
    ph_values *v = &c->v;
    ph_point *m = &v->main;
    double t_end = v->stop_defined ? v->t_stop : 1e300;
    const double hmax = isfinite(v->solver[2]) ? v->solver[2] : 1e300;
    if (PH_ND > 0) {
        if (ph_next_sample(v, m) <= m->t) {     /* a breakpoint, as in porthamiltonian.simulate */
            if (ph_sample(c, m, 0.0) != PH_OK)
                return -1;
            v->mask_index = -1;
            v->t_segment = m->t;
        }
        t_end = fmin(t_end, ph_next_sample(v, m));
    }
    const double tgrad = ph_tgrad(v, m->p);
    if (!v->have_cross && v->h_next > 0.0 && m->t < target && target < t_end &&
        m->t + v->h_next > target) {
        v->cross = *m;
        v->cross_h = v->h_next;
        v->have_cross = 1;
    }
    v->prev = *m;
    v->have_prev = 1;
    const int status = PH_INTEGRATE(m->t, m->y, t_end, m->p, v->solver[0], c->atol, v->h_next,
                                    hmax, ph_event_directions, ph_event_terminal, PH_NE,
                                    v->mask_index, v->mask_sign, PH_NX, PH_DIVERGENCE_BOUND, 1,
                                    PH_STORE, tgrad, c->ts, c->ys, c->ev_t, c->ev_k, c->th,
                                    c->y_out, c->counts);
    v->mask_index = -1;
    if (status == 2 || status == 3)
        return status;
    m->t = c->th[0];
    memcpy(m->y, c->y_out, sizeof m->y);
    v->h_next = c->th[1];
    v->n_last = (int)c->counts[5];
    double out[PH_NO1];
    for (int j = 0; j < v->n_last; ++j) {
        v->last_t[j] = c->ev_t[j];
        v->last_k[j] = c->ev_k[j];
        const double t = m->t;
        m->t = c->ev_t[j];
        ph_fire(c, m, (int)c->ev_k[j], out);   /* non-terminal: counted at its time */
        m->t = t;
    }
    if (status == 1) {
        const int k = (int)c->counts[4];
        if (c->th[0] <= target)     /* the integration goes on from the event */
            v->have_cross = 0;
        const double t_restart = v->t_segment;
        ph_fire(c, m, k, out);
        /* as porthamiltonian.simulate: a guard that fired after some integration (its state
         * not moved by the rules) is kept on its new side at the restart */
        if (m->t != t_restart) {
            v->mask_index = k;
            v->mask_sign = ph_event_directions[k] ? (double)ph_event_directions[k] : -1.0;
        }
        v->t_segment = m->t;
    }
    return 0;
}

/* y at time t (prev.t < t < main.t) by an integration of its own (guards off) from v->cross, the
 * point where porthamiltonian.simulate with a breakpoint at t would shorten its step (else from
 * v->prev): the steps it takes from there; *h_out the step size it goes on with */
static int ph_values_at(ph_instance *c, double t, double *y, double *h_out)
{
    ph_values *v = &c->v;
    const ph_point *a = v->have_cross ? &v->cross : &v->prev;
    const double hmax = isfinite(v->solver[2]) ? v->solver[2] : 1e300;
    const double tgrad = ph_tgrad(v, a->p);
    *h_out = v->h_next;
    if (t - a->t <= 1e-13 * fmax(1.0, fabs(t))) {
        memcpy(y, a->y, sizeof(double) * PH_N);
        return 0;
    }
    double tt = a->t, h = v->have_cross ? v->cross_h : t - a->t, yy[PH_N];
    memcpy(yy, a->y, sizeof yy);
    for (;;) {
        const int status = PH_INTEGRATE(tt, yy, t, a->p, v->solver[0], c->atol, h, hmax,
                                        ph_event_directions, ph_event_terminal, 0, -1, 0.0, PH_NX,
                                        PH_DIVERGENCE_BOUND, PH_SIDE_STEPS, PH_STORE, tgrad,
                                        c->ts, c->ys, c->ev_t, c->ev_k, c->th, c->y_out,
                                        c->counts);
        tt = c->th[0];
        h = c->th[1];
        memcpy(yy, c->y_out, sizeof yy);
        if (status == 0)
            break;
        if (status != 5)
            return status;
    }
    memcpy(y, yy, sizeof(double) * PH_N);
    *h_out = h;
    return 0;
}

static const char *ph_loop_failure(int status)
{
    return status == 2 ? "the step size became too small (or the iteration matrix singular)"
         : status == 3 ? "the state diverged (max |x| above the divergence bound, or not finite)"
                       : "too many steps";
}

/* fmi*DoStep: advance to t_c + h. *terminated when the run ended (a terminal event) at or before
 * it: the values are those at the end (v.last_successful). */
static int ph_do_step(ph_instance *c, double t_c, double h, int *terminated)
{
    ph_values *v = &c->v;
    *terminated = 0;
    if (v->mode != PH_STEP_MODE)
        return PH_FAIL(c, "%s: doStep %s", c->name, v->mode == PH_TERMINATED
                       ? "after the run ended (a terminal event)" : "before initialization");
    if (!(h >= 0.0) || !isfinite(t_c))
        return PH_FAIL(c, "%s: doStep from t = %g by %g: the step must be >= 0", c->name, t_c, h);
    if (fabs(t_c - v->now.t) > 1e-9 * fmax(1.0, fabs(t_c)))
        return PH_FAIL(c, "%s: doStep from t = %.17g but the FMU is at t = %.17g", c->name, t_c,
                       v->now.t);
    const double target = t_c + h;     /* the importer's clock (t_c + (t_next - t_c) = t_next) */
    v->have_cross = 0;
    int inputs_changed = 0;
    for (int i = PH_NP; i < PH_NS; ++i)
        inputs_changed |= v->now.p[i] != v->main.p[i];
    if (v->restart || inputs_changed) {  /* a tunable parameter or an input changed: restart */
        v->main = v->now;
        v->have_prev = 0;
        v->mask_index = -1;
        v->t_segment = v->now.t;
        v->h_next = v->h_now;
        v->restart = 0;
    }
    while (!v->main.stop && v->main.t < target) {
        if (v->stop_defined && v->main.t >= v->t_stop) {
            if (target - v->t_stop > 1e-9 * fmax(1.0, fabs(v->t_stop)))
                return PH_FAIL(c, "%s: doStep to t = %.17g beyond the stop time %.17g",
                               c->name, target, v->t_stop);
            break;
        }
        const int status = ph_main_step(c, target);
        if (status < 0) {
            v->mode = PH_FAILED;
            return PH_ERROR;
        }
        if (status != 0) {
            v->mode = PH_FAILED;
            return PH_FAIL(c, "%s: the integration failed at t = %.17g: %s", c->name, v->main.t,
                           ph_loop_failure(status));
        }
    }
    if (v->main.stop && v->main.t <= target) {
        v->now = v->main;
        v->last_successful = v->main.t;
        v->mode = PH_TERMINATED;
        *terminated = 1;
    } else if (v->main.t <= target || !v->have_prev) {
        v->now = v->main;
        v->now.t = target;
        v->h_now = v->h_next;
    } else {                        /* inside the last step: from the point before it */
        double y[PH_N];
        const int status = ph_values_at(c, target, y, &v->h_now);
        if (status != 0) {
            v->mode = PH_FAILED;
            return PH_FAIL(c, "%s: the integration to the communication point t = %.17g "
                           "failed: %s", c->name, target, ph_loop_failure(status));
        }
        v->now = v->prev;
        v->now.t = target;
        memcpy(v->now.y, y, sizeof y);
        double out[PH_NO1];
        for (int j = 0; j < v->n_last; ++j)
            if (v->last_t[j] <= target) {
                v->now.t = v->last_t[j];
                ph_fire(c, &v->now, (int)v->last_k[j], out);
            }
        v->now.t = target;
    }
    if (!*terminated)
        v->last_successful = target;
    ph_changed(c);
    return PH_OK;
}

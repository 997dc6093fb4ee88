/* The FMI 2.0 functions of an FMU exported by porthamiltonian (model exchange and
 * co-simulation), on the runtime of runtime.c. */

static const fmi2Status ph_fmi2_status[] = {fmi2OK, fmi2Warning, fmi2Discard, fmi2Error};

static void ph_fmi2_log(ph_instance *c, int status, const char *category, const char *message)
{
    fmi2CallbackLogger logger = (fmi2CallbackLogger)c->logger;
    logger(c->environment, c->name, ph_fmi2_status[status], category, "%s", message);
}

#define PH_C ((ph_instance *)c)
#define PH_CHECK(c) do { if ((c) == NULL) return fmi2Error; } while (0)
#define PH_RETURN(expr) return ph_fmi2_status[(expr)]
/* fmi2Get<Type> / fmi2Set<Type> of a type no variable has: only an empty request succeeds */
#define PH_NO_VARIABLES(fn, type, what) \
    PH_FMI_EXPORT fmi2Status PH_FMI2(fn)(fmi2Component c, const fmi2ValueReference vr[], \
                                           size_t nvr, type value[]) \
    { \
        PH_CHECK(c); \
        (void)value; \
        PH_RETURN(nvr == 0 ? PH_OK : PH_FAIL(PH_C, "%s: no " what " variable has value " \
                                             "reference %u", PH_C->name, vr[0])); \
    }

PH_FMI_EXPORT const char *PH_FMI2(fmi2GetTypesPlatform)(void) { return "default"; }

PH_FMI_EXPORT const char *PH_FMI2(fmi2GetVersion)(void) { return "2.0"; }

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2SetDebugLogging)(fmi2Component c, fmi2Boolean loggingOn,
                                                      size_t nCategories,
                                                      const fmi2String categories[])
{
    PH_CHECK(c);
    ph_set_debug_logging(PH_C, loggingOn, nCategories, categories);
    return fmi2OK;
}

PH_FMI_EXPORT fmi2Component PH_FMI2(fmi2Instantiate)(fmi2String instanceName, fmi2Type fmuType,
                                                     fmi2String fmuGUID,
                                                     fmi2String fmuResourceLocation,
                                                     const fmi2CallbackFunctions *functions,
                                                     fmi2Boolean visible,
                                                     fmi2Boolean loggingOn)
{
    (void)fmuResourceLocation;
    (void)visible;
    fmi2CallbackLogger logger = functions != NULL ? functions->logger : NULL;
    void *environment = functions != NULL ? functions->componentEnvironment : NULL;
    if (fmuType != fmi2ModelExchange && fmuType != fmi2CoSimulation)
        return NULL;
    if ((fmuType == fmi2ModelExchange && !PH_HAS_ME) ||
        (fmuType == fmi2CoSimulation && !PH_HAS_CS)) {
        if (logger != NULL)
            logger(environment, instanceName, fmi2Error, "logStatusError",
                   "this FMU was exported without %s",
                   fmuType == fmi2ModelExchange ? "model exchange" : "co-simulation");
        return NULL;
    }
    if (fmuGUID == NULL || strcmp(fmuGUID, PH_TOKEN) != 0) {
        if (logger != NULL)
            logger(environment, instanceName, fmi2Error, "logStatusError",
                   "the GUID %s is not this FMU's (%s): a modelDescription.xml of another "
                   "FMU?", fmuGUID ? fmuGUID : "(null)", PH_TOKEN);
        return NULL;
    }
    ph_instance *inst = ph_instantiate(instanceName, fmuType == fmi2CoSimulation, environment,
                                       (ph_callback)logger, ph_fmi2_log, loggingOn);
    return inst;
}

PH_FMI_EXPORT void PH_FMI2(fmi2FreeInstance)(fmi2Component c) { ph_free(PH_C); }

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2SetupExperiment)(fmi2Component c,
                                                      fmi2Boolean toleranceDefined,
                                                      fmi2Real tolerance, fmi2Real startTime,
                                                      fmi2Boolean stopTimeDefined,
                                                      fmi2Real stopTime)
{
    PH_CHECK(c);
    ph_values *v = &PH_C->v;
    if (v->mode != PH_INSTANTIATED)
        PH_RETURN(PH_FAIL(PH_C, "%s: fmi2SetupExperiment only after instantiation", PH_C->name));
    if (toleranceDefined && PH_C->cosimulation) {
        if (!(tolerance > 0.0 && tolerance < 1.0))
            PH_RETURN(PH_FAIL(PH_C, "%s: the tolerance must be in (0, 1), got %g", PH_C->name,
                              tolerance));
        v->solver[0] = tolerance;
    }
    v->t_start = startTime;
    v->now.t = startTime;
    v->stop_defined = stopTimeDefined;
    v->t_stop = stopTimeDefined ? stopTime : INFINITY;
    return fmi2OK;
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2EnterInitializationMode)(fmi2Component c)
{
    PH_CHECK(c);
    ph_values *v = &PH_C->v;
    PH_RETURN(ph_enter_initialization(PH_C, 0, 0.0, v->now.t, v->stop_defined, v->t_stop));
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2ExitInitializationMode)(fmi2Component c)
{
    PH_CHECK(c);
    PH_RETURN(ph_exit_initialization(PH_C));
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2Terminate)(fmi2Component c)
{
    PH_CHECK(c);
    PH_C->v.mode = PH_TERMINATED;
    return fmi2OK;
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2Reset)(fmi2Component c)
{
    PH_CHECK(c);
    ph_defaults(PH_C);
    return fmi2OK;
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2GetReal)(fmi2Component c, const fmi2ValueReference vr[],
                                              size_t nvr, fmi2Real value[])
{
    PH_CHECK(c);
    PH_RETURN(ph_get_reals(PH_C, vr, nvr, value));
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2GetInteger)(fmi2Component c, const fmi2ValueReference vr[],
                                                 size_t nvr, fmi2Integer value[])
{
    PH_CHECK(c);
    PH_RETURN(ph_get_integers(PH_C, vr, nvr, value));
}

PH_NO_VARIABLES(fmi2GetBoolean, fmi2Boolean, "Boolean")
PH_NO_VARIABLES(fmi2GetString, fmi2String, "String")

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2SetReal)(fmi2Component c, const fmi2ValueReference vr[],
                                              size_t nvr, const fmi2Real value[])
{
    PH_CHECK(c);
    PH_RETURN(ph_set_reals(PH_C, vr, nvr, value));
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2SetInteger)(fmi2Component c, const fmi2ValueReference vr[],
                                                 size_t nvr, const fmi2Integer value[])
{
    PH_CHECK(c);
    (void)value;
    if (nvr == 0)
        return fmi2OK;
    PH_RETURN(PH_FAIL(PH_C, "%s: Integer variable %u is computed and cannot be set",
                      PH_C->name, vr[0]));
}

PH_NO_VARIABLES(fmi2SetBoolean, const fmi2Boolean, "Boolean")
PH_NO_VARIABLES(fmi2SetString, const fmi2String, "String")

/* fmi2GetFMUstate, fmi2SetFMUstate, fmi2FreeFMUstate, fmi2SerializedFMUstateSize,
 * fmi2SerializeFMUstate, fmi2DeSerializeFMUstate (runtime.c) */
PH_FMU_STATE_FUNCTIONS(2, fmi2Component, FMUstate, DeSerialize)

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2GetDirectionalDerivative)(
    fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
    const fmi2ValueReference vKnown_ref[], size_t nKnown, const fmi2Real dvKnown[],
    fmi2Real dvUnknown[])
{
    PH_CHECK(c);
    PH_RETURN(ph_directional(PH_C, vUnknown_ref, nUnknown, vKnown_ref, nKnown, dvKnown,
                             dvUnknown));
}

/* --- model exchange --------------------------------------------------------------------------- */
PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2EnterEventMode)(fmi2Component c)
{
    PH_CHECK(c);
    PH_C->v.mode = PH_EVENT_MODE;
    return fmi2OK;
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2NewDiscreteStates)(fmi2Component c, fmi2EventInfo *info)
{
    PH_CHECK(c);
    int terminate = 0, moved = 0, next_defined = 0;
    double next_time = 0.0;
    const int status = ph_update_discrete(PH_C, &terminate, &moved, &next_defined, &next_time);
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = terminate;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = moved;
    info->nextEventTimeDefined = next_defined;
    info->nextEventTime = next_time;
    PH_RETURN(status);
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2EnterContinuousTimeMode)(fmi2Component c)
{
    PH_CHECK(c);
    PH_C->v.mode = PH_CONTINUOUS;
    return fmi2OK;
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2CompletedIntegratorStep)(
    fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint, fmi2Boolean *enterEventMode,
    fmi2Boolean *terminateSimulation)
{
    PH_CHECK(c);
    (void)noSetFMUStatePriorToCurrentPoint;
    *enterEventMode = ph_step_event(PH_C);
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2SetTime)(fmi2Component c, fmi2Real time)
{
    PH_CHECK(c);
    PH_C->v.now.t = time;
    ph_changed(PH_C);
    return fmi2OK;
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2SetContinuousStates)(fmi2Component c, const fmi2Real x[],
                                                          size_t nx)
{
    PH_CHECK(c);
    if (nx != PH_N)
        PH_RETURN(PH_FAIL(PH_C, "%s: %zu continuous states given, the FMU has %d", PH_C->name, nx,
                          PH_N));
    memcpy(PH_C->v.now.y, x, sizeof(double) * PH_N);
    ph_changed(PH_C);
    return fmi2OK;
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2GetDerivatives)(fmi2Component c, fmi2Real derivatives[],
                                                     size_t nx)
{
    PH_CHECK(c);
    PH_RETURN(ph_values_out(PH_C, derivatives, nx, PH_N, "derivatives", ph_now_rates));
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2GetEventIndicators)(fmi2Component c,
                                                         fmi2Real eventIndicators[], size_t ni)
{
    PH_CHECK(c);
    PH_RETURN(ph_values_out(PH_C, eventIndicators, ni, PH_NE, "event indicators",
                            ph_now_guards));
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2GetContinuousStates)(fmi2Component c, fmi2Real x[],
                                                          size_t nx)
{
    PH_CHECK(c);
    PH_RETURN(ph_values_out(PH_C, x, nx, PH_N, "continuous states", ph_now_states));
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2GetNominalsOfContinuousStates)(fmi2Component c,
                                                                    fmi2Real x_nominal[],
                                                                    size_t nx)
{
    PH_CHECK(c);
    for (size_t i = 0; i < nx; ++i)
        x_nominal[i] = 1.0;
    return fmi2OK;
}

/* fmi2SetRealInputDerivatives (co-simulation): the derivative of order `order` of input vr, set
 * at the current communication point; the first derivative extrapolates the input linearly over
 * the steps that follow (until it is set again), higher ones are ignored (a warning) */
static int ph_set_input_derivative(ph_instance *c, unsigned int vr, int order, double value)
{
    const ph_variable *var = ph_find(c, vr, 0);
    if (var == NULL)
        return PH_ERROR;
    if (!c->cosimulation)
        return PH_FAIL(c, "%s: input derivatives are for co-simulation", c->name);
    if (var->kind != PH_INPUT)
        return PH_FAIL(c, "%s: variable %u is not an input", c->name, vr);
    if (order < 1 || !isfinite(value))
        return PH_FAIL(c, "%s: input derivative of order %d = %g: the order must be >= 1 and the "
                       "value finite", c->name, order, value);
    if (order > 1) {
        ph_logf(c, PH_WARNING, "logStatusError", "%s: input derivatives of order %d are ignored: "
                "the FMU extrapolates its inputs linearly", c->name, order);
        return PH_WARNING;
    }
    /* the line keeps its value at the current time */
    const int k = var->index;
    c->v.u[k] += c->v.du[k] * (c->v.now.t - c->v.u_time[k]);
    c->v.u_time[k] = c->v.now.t;
    c->v.du[k] = value;
    ph_input_slots(&c->v, &c->v.now);
    ph_changed(c);
    return PH_OK;
}

/* --- co-simulation ---------------------------------------------------------------------------- */
PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2SetRealInputDerivatives)(fmi2Component c,
                                                              const fmi2ValueReference vr[],
                                                              size_t nvr,
                                                              const fmi2Integer order[],
                                                              const fmi2Real value[])
{
    PH_CHECK(c);
    int worst = PH_OK;
    for (size_t i = 0; i < nvr; ++i) {
        const int status = ph_set_input_derivative(PH_C, vr[i], order[i], value[i]);
        if (status == PH_ERROR)
            return fmi2Error;
        worst = status > worst ? status : worst;
    }
    PH_RETURN(worst);
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2GetRealOutputDerivatives)(fmi2Component c,
                                                               const fmi2ValueReference vr[],
                                                               size_t nvr,
                                                               const fmi2Integer order[],
                                                               fmi2Real value[])
{
    PH_CHECK(c);
    (void)vr; (void)order; (void)value;
    if (nvr == 0)
        return fmi2OK;
    PH_RETURN(PH_FAIL(PH_C, "%s: the FMU gives no output derivatives (maxOutputDerivativeOrder "
                      "0)", PH_C->name));
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2DoStep)(fmi2Component c, fmi2Real currentCommunicationPoint,
                                             fmi2Real communicationStepSize,
                                             fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    PH_CHECK(c);
    (void)noSetFMUStatePriorToCurrentPoint;
    int terminated = 0;
    const int status = ph_do_step(PH_C, currentCommunicationPoint, communicationStepSize,
                                  &terminated);
    if (status != PH_OK)
        PH_RETURN(status);
    return terminated ? fmi2Discard : fmi2OK;
}

PH_FMI_EXPORT fmi2Status PH_FMI2(fmi2CancelStep)(fmi2Component c)
{
    PH_CHECK(c);
    PH_RETURN(PH_FAIL(PH_C, "%s: fmi2CancelStep: doStep never runs asynchronously here",
                      PH_C->name));
}

/* fmi2Get<Type>Status: the one status kind of the type reported (kind) is expr, any other is
 * fmi2Discard; PH_NO_STATUS: a type of no status kind */
#define PH_STATUS(fn, type, kind, expr) \
    PH_FMI_EXPORT fmi2Status PH_FMI2(fn)(fmi2Component c, const fmi2StatusKind s, type *value) \
    { \
        PH_CHECK(c); \
        if (s != (kind)) \
            return fmi2Discard; \
        *value = (expr); \
        return fmi2OK; \
    }
#define PH_NO_STATUS(fn, type) \
    PH_FMI_EXPORT fmi2Status PH_FMI2(fn)(fmi2Component c, const fmi2StatusKind s, type *value) \
    { \
        PH_CHECK(c); \
        (void)s; (void)value; \
        return fmi2Discard; \
    }

PH_STATUS(fmi2GetStatus, fmi2Status, fmi2DoStepStatus,
          PH_C->v.mode == PH_FAILED ? fmi2Error : fmi2OK)
PH_STATUS(fmi2GetRealStatus, fmi2Real, fmi2LastSuccessfulTime, PH_C->v.last_successful)
PH_NO_STATUS(fmi2GetIntegerStatus, fmi2Integer)
PH_STATUS(fmi2GetBooleanStatus, fmi2Boolean, fmi2Terminated, PH_C->v.mode == PH_TERMINATED)
PH_NO_STATUS(fmi2GetStringStatus, fmi2String)

/* The FMI 3.0 functions of an FMU exported by porthamiltonian (model exchange and
 * co-simulation; no scheduled execution), on the runtime of runtime.c. */

static const fmi3Status ph_fmi3_status[] = {fmi3OK, fmi3Warning, fmi3Discard, fmi3Error};

static void ph_fmi3_log(ph_instance *c, int status, const char *category, const char *message)
{
    fmi3LogMessageCallback logger = (fmi3LogMessageCallback)c->logger;
    logger(c->environment, ph_fmi3_status[status], category, message);
}

#define PH_I ((ph_instance *)instance)
#define PH_CHECK3 do { if (instance == NULL) return fmi3Error; } while (0)
#define PH_RETURN3(expr) return ph_fmi3_status[(expr)]
#define PH_NO_TYPE(type) PH_RETURN3(nValueReferences == 0 ? PH_OK : PH_FAIL(PH_I, \
    "%s: no " type " variable has value reference %u", PH_I->name, valueReferences[0]))

PH_FMI_EXPORT const char *PH_FMI3(fmi3GetVersion)(void) { return "3.0"; }

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3SetDebugLogging)(fmi3Instance instance,
                                                      fmi3Boolean loggingOn,
                                                      size_t nCategories,
                                                      const fmi3String categories[])
{
    PH_CHECK3;
    ph_set_debug_logging(PH_I, loggingOn, nCategories, categories);
    return fmi3OK;
}

static fmi3Instance ph_fmi3_instantiate(fmi3String instanceName, fmi3String token,
                                        int cosimulation, int available, fmi3Boolean loggingOn,
                                        fmi3InstanceEnvironment environment,
                                        fmi3LogMessageCallback logMessage)
{
    if (!available) {
        if (logMessage != NULL)
            logMessage(environment, fmi3Error, "logStatusError", cosimulation
                       ? "this FMU was exported without co-simulation"
                       : "this FMU was exported without model exchange");
        return NULL;
    }
    if (token == NULL || strcmp(token, PH_TOKEN) != 0) {
        if (logMessage != NULL)
            logMessage(environment, fmi3Error, "logStatusError",
                       "the instantiation token is not this FMU's: a modelDescription.xml of "
                       "another FMU?");
        return NULL;
    }
    return ph_instantiate(instanceName, cosimulation, environment, (ph_callback)logMessage,
                          ph_fmi3_log, loggingOn);
}

PH_FMI_EXPORT fmi3Instance PH_FMI3(fmi3InstantiateModelExchange)(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage)
{
    (void)resourcePath;
    (void)visible;
    return ph_fmi3_instantiate(instanceName, instantiationToken, 0, PH_HAS_ME, loggingOn,
                               instanceEnvironment, logMessage);
}

PH_FMI_EXPORT fmi3Instance PH_FMI3(fmi3InstantiateCoSimulation)(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate)
{
    (void)resourcePath; (void)visible; (void)earlyReturnAllowed;
    (void)requiredIntermediateVariables; (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate;
    if (eventModeUsed) {
        if (logMessage != NULL)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "this FMU handles its events inside doStep (hasEventMode=\"false\")");
        return NULL;
    }
    return ph_fmi3_instantiate(instanceName, instantiationToken, 1, PH_HAS_CS, loggingOn,
                               instanceEnvironment, logMessage);
}

PH_FMI_EXPORT fmi3Instance PH_FMI3(fmi3InstantiateScheduledExecution)(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible;
    (void)loggingOn; (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    if (logMessage != NULL)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "this FMU has no scheduled execution");
    return NULL;
}

PH_FMI_EXPORT void PH_FMI3(fmi3FreeInstance)(fmi3Instance instance) { ph_free(PH_I); }

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3EnterInitializationMode)(fmi3Instance instance,
                                                              fmi3Boolean toleranceDefined,
                                                              fmi3Float64 tolerance,
                                                              fmi3Float64 startTime,
                                                              fmi3Boolean stopTimeDefined,
                                                              fmi3Float64 stopTime)
{
    PH_CHECK3;
    PH_RETURN3(ph_enter_initialization(PH_I, toleranceDefined, tolerance, startTime,
                                       stopTimeDefined, stopTime));
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3ExitInitializationMode)(fmi3Instance instance)
{
    PH_CHECK3;
    PH_RETURN3(ph_exit_initialization(PH_I));
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3EnterEventMode)(fmi3Instance instance)
{
    PH_CHECK3;
    if (PH_I->cosimulation)
        PH_RETURN3(PH_FAIL(PH_I, "%s: this FMU has no event mode in co-simulation", PH_I->name));
    PH_I->v.mode = PH_EVENT_MODE;
    return fmi3OK;
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3Terminate)(fmi3Instance instance)
{
    PH_CHECK3;
    PH_I->v.mode = PH_TERMINATED;
    return fmi3OK;
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3Reset)(fmi3Instance instance)
{
    PH_CHECK3;
    ph_defaults(PH_I);
    return fmi3OK;
}

/* --- getting and setting values ---------------------------------------------------------------- */
/* fmi3Get<Type> / fmi3Set<Type> (ctype: the type's C type) around `body` */
#define PH_GET3(Type, ctype, body) \
    PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3Get##Type)(fmi3Instance instance, \
        const fmi3ValueReference valueReferences[], size_t nValueReferences, ctype values[], \
        size_t nValues) \
    { PH_CHECK3; body; }
#define PH_SET3(Type, ctype, body) \
    PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3Set##Type)(fmi3Instance instance, \
        const fmi3ValueReference valueReferences[], size_t nValueReferences, \
        const ctype values[], size_t nValues) \
    { PH_CHECK3; body; }

/* the types with variables: every variable is a scalar (as many values as value references),
 * got and set by the runtime's loops; the Int32 variables (event counts) are computed */
#define PH_SCALARS3(call) \
    if (nValues != nValueReferences) \
        PH_RETURN3(PH_FAIL(PH_I, "%s: %zu values for %zu value references (all scalars)", \
                           PH_I->name, nValues, nValueReferences)); \
    PH_RETURN3(call)
PH_GET3(Float64, fmi3Float64,
        PH_SCALARS3(ph_get_reals(PH_I, valueReferences, nValueReferences, values)))
PH_SET3(Float64, fmi3Float64,
        PH_SCALARS3(ph_set_reals(PH_I, valueReferences, nValueReferences, values)))
PH_GET3(Int32, fmi3Int32,
        PH_SCALARS3(ph_get_integers(PH_I, valueReferences, nValueReferences, values)))
PH_SET3(Int32, fmi3Int32,
        (void)values; (void)nValues;
        PH_RETURN3(nValueReferences == 0 ? PH_OK : PH_FAIL(PH_I, "%s: Int32 variable %u is "
                   "computed and cannot be set", PH_I->name, valueReferences[0])))

/* the types this FMU has no variables of */
#define PH_NO_GET(Type, ctype) PH_GET3(Type, ctype, (void)values; (void)nValues; PH_NO_TYPE(#Type))
#define PH_NO_SET(Type, ctype) PH_SET3(Type, ctype, (void)values; (void)nValues; PH_NO_TYPE(#Type))

PH_NO_GET(Float32, fmi3Float32)
PH_NO_GET(Int8, fmi3Int8)
PH_NO_GET(UInt8, fmi3UInt8)
PH_NO_GET(Int16, fmi3Int16)
PH_NO_GET(UInt16, fmi3UInt16)
PH_NO_GET(UInt32, fmi3UInt32)
PH_NO_GET(Int64, fmi3Int64)
PH_NO_GET(UInt64, fmi3UInt64)
PH_NO_GET(Boolean, fmi3Boolean)
PH_NO_GET(String, fmi3String)
PH_NO_SET(Float32, fmi3Float32)
PH_NO_SET(Int8, fmi3Int8)
PH_NO_SET(UInt8, fmi3UInt8)
PH_NO_SET(Int16, fmi3Int16)
PH_NO_SET(UInt16, fmi3UInt16)
PH_NO_SET(UInt32, fmi3UInt32)
PH_NO_SET(Int64, fmi3Int64)
PH_NO_SET(UInt64, fmi3UInt64)
PH_NO_SET(Boolean, fmi3Boolean)
PH_NO_SET(String, fmi3String)

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3GetBinary)(fmi3Instance instance,
                                                const fmi3ValueReference valueReferences[],
                                                size_t nValueReferences, size_t valueSizes[],
                                                fmi3Binary values[], size_t nValues)
{
    PH_CHECK3;
    (void)valueSizes; (void)values; (void)nValues;
    PH_NO_TYPE("Binary");
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3SetBinary)(fmi3Instance instance,
                                                const fmi3ValueReference valueReferences[],
                                                size_t nValueReferences,
                                                const size_t valueSizes[],
                                                const fmi3Binary values[], size_t nValues)
{
    PH_CHECK3;
    (void)valueSizes; (void)values; (void)nValues;
    PH_NO_TYPE("Binary");
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3GetClock)(fmi3Instance instance,
                                               const fmi3ValueReference valueReferences[],
                                               size_t nValueReferences, fmi3Clock values[])
{
    PH_CHECK3;
    (void)values;
    PH_NO_TYPE("Clock");
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3SetClock)(fmi3Instance instance,
                                               const fmi3ValueReference valueReferences[],
                                               size_t nValueReferences,
                                               const fmi3Clock values[])
{
    PH_CHECK3;
    (void)values;
    PH_NO_TYPE("Clock");
}

/* --- dependencies, FMU state, derivatives -------------------------------------------------------- */
PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3GetNumberOfVariableDependencies)(
    fmi3Instance instance, fmi3ValueReference valueReference, size_t *nDependencies)
{
    PH_CHECK3;
    (void)valueReference; (void)nDependencies;
    PH_RETURN3(PH_FAIL(PH_I, "%s: the variables' dependencies are not listed (the "
                       "modelDescription declares none: all depend on all)", PH_I->name));
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3GetVariableDependencies)(
    fmi3Instance instance, fmi3ValueReference dependent, size_t elementIndicesOfDependent[],
    fmi3ValueReference independents[], size_t elementIndicesOfIndependents[],
    fmi3DependencyKind dependencyKinds[], size_t nDependencies)
{
    PH_CHECK3;
    (void)dependent; (void)elementIndicesOfDependent; (void)independents;
    (void)elementIndicesOfIndependents; (void)dependencyKinds; (void)nDependencies;
    PH_RETURN3(PH_FAIL(PH_I, "%s: the variables' dependencies are not listed", PH_I->name));
}

/* fmi3GetFMUState, fmi3SetFMUState, fmi3FreeFMUState, fmi3SerializedFMUStateSize,
 * fmi3SerializeFMUState, fmi3DeserializeFMUState (runtime.c) */
PH_FMU_STATE_FUNCTIONS(3, fmi3Instance, FMUState, Deserialize)

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3GetDirectionalDerivative)(
    fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
    fmi3Float64 sensitivity[], size_t nSensitivity)
{
    PH_CHECK3;
    if (nSeed != nKnowns || nSensitivity != nUnknowns)
        PH_RETURN3(PH_FAIL(PH_I, "%s: directional derivative: %zu seeds for %zu knowns, %zu "
                           "sensitivities for %zu unknowns", PH_I->name, nSeed, nKnowns,
                           nSensitivity, nUnknowns));
    PH_RETURN3(ph_directional(PH_I, unknowns, nUnknowns, knowns, nKnowns, seed, sensitivity));
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3GetAdjointDerivative)(
    fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
    fmi3Float64 sensitivity[], size_t nSensitivity)
{
    PH_CHECK3;
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed;
    (void)sensitivity; (void)nSensitivity;
    PH_RETURN3(PH_FAIL(PH_I, "%s: no adjoint derivatives (providesAdjointDerivatives is false)",
                       PH_I->name));
}

/* --- configuration, clocks: none ----------------------------------------------------------------- */
PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3EnterConfigurationMode)(fmi3Instance instance)
{
    PH_CHECK3;
    PH_RETURN3(PH_FAIL(PH_I, "%s: no structural parameters", PH_I->name));
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3ExitConfigurationMode)(fmi3Instance instance)
{
    PH_CHECK3;
    PH_RETURN3(PH_FAIL(PH_I, "%s: no structural parameters", PH_I->name));
}

/* the clock functions: this FMU has no clocks, each refuses with the same message (the value
 * arrays after nValueReferences differ: their declarations, then their casts to void) */
#define PH_UNPAREN(...) __VA_ARGS__
#define PH_NO_CLOCK(fn, values, unused)                                                     \
    PH_FMI_EXPORT fmi3Status PH_FMI3(fn)(fmi3Instance instance,                             \
        const fmi3ValueReference valueReferences[], size_t nValueReferences,                \
        PH_UNPAREN values)                                                                  \
    {                                                                                       \
        (void)valueReferences; (void)nValueReferences; unused;                              \
        PH_CHECK3;                                                                          \
        PH_RETURN3(PH_FAIL(PH_I, "%s: this FMU has no clocks", PH_I->name));                \
    }
PH_NO_CLOCK(fmi3GetIntervalDecimal, (fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]),
            (void)intervals; (void)qualifiers)
PH_NO_CLOCK(fmi3GetIntervalFraction,
            (fmi3UInt64 counters[], fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]),
            (void)counters; (void)resolutions; (void)qualifiers)
PH_NO_CLOCK(fmi3GetShiftDecimal, (fmi3Float64 shifts[]),
            (void)shifts)
PH_NO_CLOCK(fmi3GetShiftFraction, (fmi3UInt64 counters[], fmi3UInt64 resolutions[]),
            (void)counters; (void)resolutions)
PH_NO_CLOCK(fmi3SetIntervalDecimal, (const fmi3Float64 intervals[]),
            (void)intervals)
PH_NO_CLOCK(fmi3SetIntervalFraction,
            (const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]),
            (void)counters; (void)resolutions)
PH_NO_CLOCK(fmi3SetShiftDecimal, (const fmi3Float64 shifts[]),
            (void)shifts)
PH_NO_CLOCK(fmi3SetShiftFraction,
            (const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]),
            (void)counters; (void)resolutions)
#undef PH_NO_CLOCK
#undef PH_UNPAREN

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3EvaluateDiscreteStates)(fmi3Instance instance)
{
    PH_CHECK3;
    return fmi3OK;
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3UpdateDiscreteStates)(
    fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
    fmi3Float64 *nextEventTime)
{
    PH_CHECK3;
    int terminate = 0, moved = 0, next_defined = 0;
    double next_time = 0.0;
    const int status = ph_update_discrete(PH_I, &terminate, &moved, &next_defined, &next_time);
    *discreteStatesNeedUpdate = 0;
    *terminateSimulation = terminate;
    *nominalsOfContinuousStatesChanged = 0;
    *valuesOfContinuousStatesChanged = moved;
    *nextEventTimeDefined = next_defined;
    *nextEventTime = next_time;
    PH_RETURN3(status);
}

/* --- model exchange ------------------------------------------------------------------------------ */
PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3EnterContinuousTimeMode)(fmi3Instance instance)
{
    PH_CHECK3;
    PH_I->v.mode = PH_CONTINUOUS;
    return fmi3OK;
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3CompletedIntegratorStep)(
    fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
    fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation)
{
    PH_CHECK3;
    (void)noSetFMUStatePriorToCurrentPoint;
    *enterEventMode = ph_step_event(PH_I);
    *terminateSimulation = 0;
    return fmi3OK;
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3SetTime)(fmi3Instance instance, fmi3Float64 time)
{
    PH_CHECK3;
    PH_I->v.now.t = time;
    ph_changed(PH_I);
    return fmi3OK;
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3SetContinuousStates)(fmi3Instance instance,
                                                          const fmi3Float64 continuousStates[],
                                                          size_t nContinuousStates)
{
    PH_CHECK3;
    if (nContinuousStates != PH_N)
        PH_RETURN3(PH_FAIL(PH_I, "%s: %zu continuous states given, the FMU has %d", PH_I->name,
                           nContinuousStates, PH_N));
    memcpy(PH_I->v.now.y, continuousStates, sizeof(double) * PH_N);
    ph_changed(PH_I);
    return fmi3OK;
}

/* the getters of the current values (FMI 3: derivatives, event indicators, states), checked
 * for the caller's count */
#define PH_VALUES_OUT3(fn, n_have, what, now)                                             \
    PH_FMI_EXPORT fmi3Status PH_FMI3(fn)(fmi3Instance instance, fmi3Float64 values[],     \
                                         size_t n)                                        \
    {                                                                                     \
        PH_CHECK3;                                                                        \
        PH_RETURN3(ph_values_out(PH_I, values, n, n_have, what, now));                    \
    }
PH_VALUES_OUT3(fmi3GetContinuousStateDerivatives, PH_N, "derivatives", ph_now_rates)
PH_VALUES_OUT3(fmi3GetEventIndicators, PH_NE, "event indicators", ph_now_guards)
PH_VALUES_OUT3(fmi3GetContinuousStates, PH_N, "continuous states", ph_now_states)
#undef PH_VALUES_OUT3

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3GetNominalsOfContinuousStates)(fmi3Instance instance,
                                                                    fmi3Float64 nominals[],
                                                                    size_t nContinuousStates)
{
    PH_CHECK3;
    for (size_t i = 0; i < nContinuousStates; ++i)
        nominals[i] = 1.0;
    return fmi3OK;
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3GetNumberOfEventIndicators)(fmi3Instance instance,
                                                                 size_t *nEventIndicators)
{
    PH_CHECK3;
    *nEventIndicators = PH_NE;
    return fmi3OK;
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3GetNumberOfContinuousStates)(fmi3Instance instance,
                                                                  size_t *nContinuousStates)
{
    PH_CHECK3;
    *nContinuousStates = PH_N;
    return fmi3OK;
}

/* --- co-simulation ------------------------------------------------------------------------------- */
PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3EnterStepMode)(fmi3Instance instance)
{
    PH_CHECK3;
    PH_RETURN3(PH_FAIL(PH_I, "%s: no event mode in co-simulation: the FMU is in step mode after "
                       "initialization", PH_I->name));
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3GetOutputDerivatives)(fmi3Instance instance,
    const fmi3ValueReference valueReferences[], size_t nValueReferences,
    const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues)
{
    PH_CHECK3;
    (void)valueReferences; (void)orders; (void)values; (void)nValues;
    PH_RETURN3(nValueReferences == 0 ? PH_OK : PH_FAIL(PH_I, "%s: no output derivatives "
               "(maxOutputDerivativeOrder 0)", PH_I->name));
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3DoStep)(fmi3Instance instance,
                                             fmi3Float64 currentCommunicationPoint,
                                             fmi3Float64 communicationStepSize,
                                             fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                             fmi3Boolean *eventHandlingNeeded,
                                             fmi3Boolean *terminateSimulation,
                                             fmi3Boolean *earlyReturn,
                                             fmi3Float64 *lastSuccessfulTime)
{
    PH_CHECK3;
    (void)noSetFMUStatePriorToCurrentPoint;
    int terminated = 0;
    const int status = ph_do_step(PH_I, currentCommunicationPoint, communicationStepSize,
                                  &terminated);
    *eventHandlingNeeded = 0;
    *terminateSimulation = terminated;
    *earlyReturn = 0;
    *lastSuccessfulTime = PH_I->v.last_successful;
    PH_RETURN3(status);
}

PH_FMI_EXPORT fmi3Status PH_FMI3(fmi3ActivateModelPartition)(fmi3Instance instance,
                                                             fmi3ValueReference clockReference,
                                                             fmi3Float64 activationTime)
{
    PH_CHECK3;
    (void)clockReference; (void)activationTime;
    PH_RETURN3(PH_FAIL(PH_I, "%s: this FMU has no scheduled execution", PH_I->name));
}

/* Declarations of an FMU exported by porthamiltonian (docs/fmu.md): the FMI types this FMU uses
 * (FMI 2.0 and 3.0, written from the standards' documents: the C types, enumerations and
 * structures of their function interfaces) and the types of the runtime (runtime.c).
 *
 * The FMU is one translation unit, fmu.c: this header, then model.c (generated: the model's
 * functions, the integration loop, the tables of variables, events and rules), runtime.c (the
 * FMU's state, events, co-simulation steps) and fmi2.c or fmi3.c (the standard's functions).
 * Only the FMI functions are exported; everything else is static. Define FMI2_FUNCTION_PREFIX /
 * FMI3_FUNCTION_PREFIX (as the standard describes for source-code FMUs) to prefix their names. */
#ifndef PH_FMU_H
#define PH_FMU_H

#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if defined(_WIN32)
#define PH_FMI_EXPORT __declspec(dllexport)
#else
#define PH_FMI_EXPORT __attribute__((visibility("default")))
#endif

#define PH_CAT_(a, b) a##b
#define PH_CAT(a, b) PH_CAT_(a, b)

/* --- FMI 2.0 -------------------------------------------------------------------------------- */
typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef void *fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef char fmi2Char;
typedef const fmi2Char *fmi2String;
typedef char fmi2Byte;
#define fmi2True 1
#define fmi2False 0

typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;
typedef enum {
    fmi2DoStepStatus, fmi2PendingStatus, fmi2LastSuccessfulTime, fmi2Terminated
} fmi2StatusKind;

typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String,
                                   fmi2String, ...);
typedef void *(*fmi2CallbackAllocateMemory)(size_t, size_t);
typedef void (*fmi2CallbackFreeMemory)(void *);
typedef void (*fmi2StepFinished)(fmi2ComponentEnvironment, fmi2Status);

typedef struct {
    const fmi2CallbackLogger logger;
    const fmi2CallbackAllocateMemory allocateMemory;
    const fmi2CallbackFreeMemory freeMemory;
    const fmi2StepFinished stepFinished;
    const fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

typedef struct {
    fmi2Boolean newDiscreteStatesNeeded;
    fmi2Boolean terminateSimulation;
    fmi2Boolean nominalsOfContinuousStatesChanged;
    fmi2Boolean valuesOfContinuousStatesChanged;
    fmi2Boolean nextEventTimeDefined;
    fmi2Real nextEventTime;
} fmi2EventInfo;

#ifdef FMI2_FUNCTION_PREFIX
#define PH_FMI2(name) PH_CAT(FMI2_FUNCTION_PREFIX, name)
#else
#define PH_FMI2(name) name
#endif

/* --- FMI 3.0 -------------------------------------------------------------------------------- */
typedef void *fmi3Instance;
typedef void *fmi3InstanceEnvironment;
typedef void *fmi3FMUState;
typedef uint32_t fmi3ValueReference;
typedef float fmi3Float32;
typedef double fmi3Float64;
typedef int8_t fmi3Int8;
typedef uint8_t fmi3UInt8;
typedef int16_t fmi3Int16;
typedef uint16_t fmi3UInt16;
typedef int32_t fmi3Int32;
typedef uint32_t fmi3UInt32;
typedef int64_t fmi3Int64;
typedef uint64_t fmi3UInt64;
typedef _Bool fmi3Boolean;
typedef char fmi3Char;
typedef const fmi3Char *fmi3String;
typedef uint8_t fmi3Byte;
typedef const fmi3Byte *fmi3Binary;
typedef _Bool fmi3Clock;

typedef enum { fmi3OK, fmi3Warning, fmi3Discard, fmi3Error, fmi3Fatal } fmi3Status;
typedef enum {
    fmi3Independent, fmi3Constant, fmi3Fixed, fmi3Tunable, fmi3Discrete, fmi3Dependent
} fmi3DependencyKind;
typedef enum {
    fmi3IntervalNotYetKnown, fmi3IntervalUnchanged, fmi3IntervalChanged
} fmi3IntervalQualifier;

typedef void (*fmi3LogMessageCallback)(fmi3InstanceEnvironment, fmi3Status, fmi3String,
                                       fmi3String);
typedef void (*fmi3ClockUpdateCallback)(fmi3InstanceEnvironment);
typedef void (*fmi3IntermediateUpdateCallback)(fmi3InstanceEnvironment, fmi3Float64, fmi3Boolean,
                                               fmi3Boolean, fmi3Boolean, fmi3Boolean,
                                               fmi3Boolean *, fmi3Float64 *);
typedef void (*fmi3LockPreemptionCallback)(void);
typedef void (*fmi3UnlockPreemptionCallback)(void);

#ifdef FMI3_FUNCTION_PREFIX
#define PH_FMI3(name) PH_CAT(FMI3_FUNCTION_PREFIX, name)
#else
#define PH_FMI3(name) name
#endif

/* --- the runtime's types -------------------------------------------------------------------- */
/* what a value reference designates (ph_variable.kind) */
enum {
    PH_TIME,            /* the independent variable */
    PH_PARAM,           /* p[index] */
    PH_STATE,           /* y[index]: the model states, then the ledger's E_diss and E_in */
    PH_RATE,            /* dy/dt[index] */
    PH_OUTPUT,          /* the model's named output [index] */
    PH_ENERGY,          /* [H, P_diss, P_in][index] */
    PH_RESIDUAL,        /* H(t) - H(t0) + E_diss - E_in */
    PH_INDICATOR,       /* guard [index] */
    PH_EVENT_TIME,      /* the time event [index] last fired */
    PH_EVENT_COUNT,     /* how often event [index] fired */
    PH_COUNTER_TIME,    /* the time a rule counting under counter [index] last fired */
    PH_COUNTER_COUNT,   /* how often such rules fired */
    PH_SOLVER,          /* co-simulation settings: [rtol, atol, max_step][index] */
    PH_INPUT            /* model input [index]: the slots p[PH_NP + index] + p[PH_NP + PH_NU +
                           index] t */
};

/* who may set a variable (ph_variable.access) */
enum { PH_READ_ONLY, PH_BEFORE_INIT, PH_TUNABLE };

typedef struct {
    int kind;
    int index;
    int integer;        /* 1: an Integer (Int32) variable, 0: a Real (Float64) */
    int access;
} ph_variable;

/* a discrete-time block's generated update: its new discrete states from (t, y, p) */
typedef void (*ph_update_fn)(double t, const double *y, const double *p, double *out);

/* a rule's condition: output [output] compared with 0 by op */
enum { PH_LT, PH_LE, PH_GT, PH_GE, PH_EQ, PH_NE };
typedef struct {
    int output;
    int op;
} ph_condition;

/* a rule's change: p[param] = output [output] (before the event), or constant when output < 0 */
typedef struct {
    int param;
    int output;
    double constant;
} ph_change;

/* what an event does: the first rule of the event whose conditions hold (event -1: at the start) */
typedef struct {
    int event;
    int first_condition, n_conditions;
    int first_change, n_changes;
    int supplied;       /* a jump of H is booked as supplied energy (else dissipated) */
    int stop;           /* the run ends after the rule */
    int counter;        /* counter the rule counts under, -1 none */
} ph_rule;

#endif

/* FMI 3.0 functions of Trebuchet (co-simulation and model exchange), over treb_model.c, laid
 * out as fmi2.c. Reals are Float64, the phase Int32, the choices Enumerations (Int64), the
 * release command Boolean; the event indicators are the local Float64 variables after the
 * interface's (value references TREB_NV ... TREB_NV + 2), then the independent time. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "treb_model.h"

typedef enum { S_INSTANTIATED, S_INIT, S_STEP, S_EVENT, S_CONTINUOUS, S_TERMINATED,
               S_ERROR } State;

typedef struct {
    fmi3LogMessageCallback logger;
    fmi3InstanceEnvironment env;
    fmi3Boolean logging;
    int cosim;
    State state;
    TrebModel m;
} Instance;

static void log3(Instance *c, fmi3Status status, const char *category, const char *fmt, ...)
{
    char text[TREB_MSG + 64];
    va_list ap;
    if (!c || !c->logger) return;
    if (status == fmi3OK && !c->logging) return;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    c->logger(c->env, status, category, text);
}

static fmi3Status fail(Instance *c, const char *msg)
{
    log3(c, fmi3Error, "logStatusError", "%s", msg);
    return fmi3Error;
}

static fmi3Status result(Instance *c, int r, const char *msg)
{
    if (r < 0) return fail(c, msg);
    if (r > 0) {
        log3(c, fmi3Warning, "logStatusWarning", "%s", msg);
        return fmi3Warning;
    }
    return fmi3OK;
}

static int check(Instance *c, const char *fn, int allowed)
{
    if (!c) return 0;
    if (!(allowed & (1 << c->state))) {
        log3(c, fmi3Error, "logStatusError", "%s may not be called in this state", fn);
        return 0;
    }
    return 1;
}

#define ANY 0x7F
#define RUNNING ((1 << S_STEP) | (1 << S_EVENT) | (1 << S_CONTINUOUS))
#define CHECK(fn, allowed) do { if (!check(c, fn, allowed)) return fmi3Error; } while (0)

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t n,
                               const fmi3String categories[])
{
    Instance *c = instance;
    (void)n; (void)categories;
    CHECK("fmi3SetDebugLogging", ANY);
    c->logging = loggingOn;
    return fmi3OK;
}

static Instance *instantiate(fmi3String token, fmi3Boolean loggingOn,
                             fmi3InstanceEnvironment env, fmi3LogMessageCallback logger,
                             int cosim)
{
    if (!token || strcmp(token, TREB_GUID) != 0) {
        if (logger) logger(env, fmi3Error, "logStatusError",
                           "instantiation token does not match this FMU's");
        return NULL;
    }
    Instance *c = calloc(1, sizeof *c);
    if (!c) return NULL;
    c->logger = logger;
    c->env = env;
    c->logging = loggingOn;
    c->cosim = cosim;
    c->state = S_INSTANTIATED;
    treb_model_new(&c->m, cosim);
    return c;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String token,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment env,
                                          fmi3LogMessageCallback logMessage)
{
    (void)instanceName; (void)resourcePath; (void)visible;
    return instantiate(token, loggingOn, env, logMessage, 0);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String token,
                                         fmi3String resourcePath, fmi3Boolean visible,
                                         fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
                                         fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference required[], size_t nRequired,
                                         fmi3InstanceEnvironment env,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    (void)instanceName; (void)resourcePath; (void)visible; (void)earlyReturnAllowed;
    (void)required; (void)nRequired; (void)intermediateUpdate;
    if (eventModeUsed) {
        if (logMessage) logMessage(env, fmi3Error, "logStatusError",
                                   "event mode in co-simulation is not supported");
        return NULL;
    }
    return instantiate(token, loggingOn, env, logMessage, 1);
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String token,
                                               fmi3String resourcePath, fmi3Boolean visible,
                                               fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment env,
                                               fmi3LogMessageCallback logMessage,
                                               fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lock,
                                               fmi3UnlockPreemptionCallback unlock)
{
    (void)instanceName; (void)token; (void)resourcePath; (void)visible; (void)loggingOn;
    (void)clockUpdate; (void)lock; (void)unlock;
    if (logMessage) logMessage(env, fmi3Error, "logStatusError",
                               "scheduled execution is not supported");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance)
{
    Instance *c = instance;
    if (!c) return;
    treb_model_free(&c->m);
    free(c);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    Instance *c = instance;
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    CHECK("fmi3EnterInitializationMode", 1 << S_INSTANTIATED);
    c->m.time = startTime;
    c->state = S_INIT;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    Instance *c = instance;
    char msg[TREB_MSG];
    CHECK("fmi3ExitInitializationMode", 1 << S_INIT);
    if (treb_model_exit_init(&c->m, c->m.time, msg)) {
        c->state = S_ERROR;
        return fail(c, msg);
    }
    c->state = c->cosim ? S_STEP : S_EVENT;
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance)
{
    Instance *c = instance;
    CHECK("fmi3EnterEventMode", (1 << S_EVENT) | (1 << S_CONTINUOUS));
    c->state = S_EVENT;
    return fmi3OK;
}

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    Instance *c = instance;
    CHECK("fmi3Terminate", RUNNING | (1 << S_ERROR));
    c->state = S_TERMINATED;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    Instance *c = instance;
    CHECK("fmi3Reset", ANY);
    treb_model_reset(&c->m);
    c->state = S_INSTANTIATED;
    return fmi3OK;
}

/* ------------------------------------------------------------------ values */

static int valid_vr(Instance *c, fmi3ValueReference vr, int type)
{
    if (vr >= TREB_NV || TREB_VAR_TYPE[vr] != type) {
        log3(c, fmi3Error, "logStatusError", "value reference %u is not a variable of this "
             "type", (unsigned)vr);
        return 0;
    }
    return 1;
}

static fmi3Status get(Instance *c, const fmi3ValueReference vr[], size_t nvr, int type,
                      double *out)
{
    char msg[TREB_MSG];
    if (c->m.initialized && treb_model_outputs(&c->m, msg)) return fail(c, msg);
    for (size_t i = 0; i < nvr; i++) {
        if (type == TREB_REAL && vr[i] >= TREB_NV && vr[i] < TREB_NV + TREB_NZ) {
            double z[TREB_NZ];
            treb_model_indicators(&c->m, z);
            out[i] = z[vr[i] - TREB_NV];
            continue;
        }
        if (type == TREB_REAL && vr[i] == TREB_NV + TREB_NZ) {  /* the independent variable */
            out[i] = c->m.time;
            continue;
        }
        if (!valid_vr(c, vr[i], type)) return fmi3Error;
        out[i] = c->m.values[vr[i]];
    }
    return fmi3OK;
}

static fmi3Status set(Instance *c, const fmi3ValueReference vr[], size_t nvr, int type,
                      const double *in)
{
    for (size_t i = 0; i < nvr; i++) {
        if (!valid_vr(c, vr[i], type)) return fmi3Error;
        int causality = TREB_VAR_CAUSALITY[vr[i]];
        int ok = causality == TREB_INPUT
                 || (causality == TREB_PARAMETER
                     && (c->state == S_INSTANTIATED || c->state == S_INIT));
        if (!ok) {
            log3(c, fmi3Error, "logStatusError", "%s cannot be set %s", TREB_VAR_NAME[vr[i]],
                 causality == TREB_OUTPUT ? "(an output)" : "after initialisation (fixed)");
            return fmi3Error;
        }
        c->m.values[vr[i]] = in[i];
    }
    return fmi3OK;
}

#define GETTER(Name, T, kind)                                                                 \
    fmi3Status fmi3Get##Name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                             T values[], size_t nValues)                                      \
    {                                                                                         \
        Instance *c = instance;                                                               \
        double v[TREB_NV + TREB_NZ + 1];                                                          \
        CHECK("fmi3Get" #Name, ANY & ~(1 << S_INSTANTIATED));                                 \
        if (nvr > TREB_NV + TREB_NZ + 1 || nValues < nvr) return fail(c, "too many values");     \
        fmi3Status s = get(c, vr, nvr, kind, v);                                              \
        for (size_t i = 0; i < nvr && s == fmi3OK; i++) values[i] = (T)v[i];                 \
        return s;                                                                             \
    }
#define SETTER(Name, T, kind)                                                                 \
    fmi3Status fmi3Set##Name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                             const T values[], size_t nValues)                                \
    {                                                                                         \
        Instance *c = instance;                                                               \
        double v[TREB_NV];                                                                    \
        CHECK("fmi3Set" #Name, ANY);                                                          \
        if (nvr > TREB_NV || nValues < nvr) return fail(c, "too many values");               \
        for (size_t i = 0; i < nvr; i++) v[i] = (double)values[i];                            \
        return set(c, vr, nvr, kind, v);                                                      \
    }
#define NO_VARIABLES(Name, T)                                                                 \
    fmi3Status fmi3Get##Name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                             T values[], size_t nValues)                                      \
    {                                                                                         \
        (void)vr; (void)values; (void)nValues;                                                \
        return nvr ? fail(instance, "the FMU has no variables of type " #Name) : fmi3OK;      \
    }                                                                                         \
    fmi3Status fmi3Set##Name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                             const T values[], size_t nValues)                                \
    {                                                                                         \
        (void)vr; (void)values; (void)nValues;                                                \
        return nvr ? fail(instance, "the FMU has no variables of type " #Name) : fmi3OK;      \
    }

GETTER(Float64, fmi3Float64, TREB_REAL)
SETTER(Float64, fmi3Float64, TREB_REAL)
GETTER(Int32, fmi3Int32, TREB_INTEGER)
SETTER(Int32, fmi3Int32, TREB_INTEGER)
GETTER(Int64, fmi3Int64, TREB_ENUMERATION)
SETTER(Int64, fmi3Int64, TREB_ENUMERATION)
GETTER(Boolean, fmi3Boolean, TREB_BOOLEAN)
SETTER(Boolean, fmi3Boolean, TREB_BOOLEAN)
NO_VARIABLES(Float32, fmi3Float32)
NO_VARIABLES(Int8, fmi3Int8)
NO_VARIABLES(UInt8, fmi3UInt8)
NO_VARIABLES(Int16, fmi3Int16)
NO_VARIABLES(UInt16, fmi3UInt16)
NO_VARIABLES(UInt32, fmi3UInt32)
NO_VARIABLES(UInt64, fmi3UInt64)
NO_VARIABLES(String, fmi3String)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues)
{
    (void)vr; (void)valueSizes; (void)values; (void)nValues;
    return nvr ? fail(instance, "the FMU has no Binary variables") : fmi3OK;
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues)
{
    (void)vr; (void)valueSizes; (void)values; (void)nValues;
    return nvr ? fail(instance, "the FMU has no Binary variables") : fmi3OK;
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                        fmi3Clock values[])
{
    (void)vr; (void)values;
    return nvr ? fail(instance, "the FMU has no clocks") : fmi3OK;
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                        const fmi3Clock values[])
{
    (void)vr; (void)values;
    return nvr ? fail(instance, "the FMU has no clocks") : fmi3OK;
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference vr,
                                               size_t *n)
{
    (void)vr; (void)n;
    return fail(instance, "variable dependencies are not provided");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[],
                                       fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[],
                                       fmi3DependencyKind dependencyKinds[], size_t n)
{
    (void)dependent; (void)elementIndicesOfDependent; (void)independents;
    (void)elementIndicesOfIndependents; (void)dependencyKinds; (void)n;
    return fail(instance, "variable dependencies are not provided");
}

/* ------------------------------------------------------------------ FMU state */

typedef struct {
    State state;
    TrebModel m;
} Saved;

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    Instance *c = instance;
    CHECK("fmi3GetFMUState", ANY);
    Saved *s = *FMUState ? (Saved *)*FMUState : calloc(1, sizeof *s);
    if (!s) return fail(c, "out of memory");
    if (*FMUState) treb_model_free(&s->m);
    if (treb_model_copy(&s->m, &c->m)) {
        if (!*FMUState) free(s);
        return fail(c, "out of memory");
    }
    s->state = c->state;
    *FMUState = s;
    return fmi3OK;
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    Instance *c = instance;
    TrebModel copy;
    CHECK("fmi3SetFMUState", ANY);
    if (!FMUState) return fail(c, "fmi3SetFMUState: no state");
    const Saved *s = FMUState;
    if (s->m.cosim != c->m.cosim) return fail(c, "fmi3SetFMUState: a state of another type");
    if (treb_model_copy(&copy, &s->m)) return fail(c, "out of memory");
    treb_model_free(&c->m);
    c->m = copy;
    c->state = s->state;
    return fmi3OK;
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    Instance *c = instance;
    CHECK("fmi3FreeFMUState", ANY);
    if (FMUState && *FMUState) {
        Saved *s = *FMUState;
        treb_model_free(&s->m);
        free(s);
        *FMUState = NULL;
    }
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState,
                                      size_t *size)
{
    Instance *c = instance;
    CHECK("fmi3SerializedFMUStateSize", ANY);
    *size = sizeof(int) + treb_model_serialized_size(&((const Saved *)FMUState)->m);
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                 fmi3Byte serializedState[], size_t size)
{
    Instance *c = instance;
    CHECK("fmi3SerializeFMUState", ANY);
    const Saved *s = FMUState;
    if (size < sizeof(int) + treb_model_serialized_size(&s->m))
        return fail(c, "fmi3SerializeFMUState: buffer too small");
    int state = (int)s->state;
    memcpy(serializedState, &state, sizeof state);
    treb_model_serialize(&s->m, serializedState + sizeof state);
    return fmi3OK;
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[],
                                   size_t size, fmi3FMUState *FMUState)
{
    Instance *c = instance;
    CHECK("fmi3DeserializeFMUState", ANY);
    if (size < sizeof(int)) return fail(c, "fmi3DeserializeFMUState: not a serialised state");
    Saved *s = calloc(1, sizeof *s);
    if (!s) return fail(c, "out of memory");
    treb_model_new(&s->m, c->m.cosim);
    int state;
    memcpy(&state, serializedState, sizeof state);
    s->state = (State)state;
    if (treb_model_deserialize(&s->m, serializedState + sizeof state, size - sizeof state)) {
        free(s);
        return fail(c, "fmi3DeserializeFMUState: not a serialised state of this FMU");
    }
    if (*FMUState) fmi3FreeFMUState(instance, FMUState);
    *FMUState = s;
    return fmi3OK;
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference u[],
                                        size_t nu, const fmi3ValueReference k[], size_t nk,
                                        const fmi3Float64 seed[], size_t ns,
                                        fmi3Float64 sensitivity[], size_t nsens)
{
    Instance *c = instance;
    char msg[TREB_MSG];
    CHECK("fmi3GetDirectionalDerivative", (1 << S_INIT) | RUNNING | (1 << S_TERMINATED));
    if (ns != nk || nsens != nu) return fail(c, "fmi3GetDirectionalDerivative: sizes differ");
    if (treb_model_directional(&c->m, u, nu, k, nk, seed, sensitivity, msg))
        return fail(c, msg);
    return fmi3OK;
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference u[],
                                    size_t nu, const fmi3ValueReference k[], size_t nk,
                                    const fmi3Float64 seed[], size_t ns,
                                    fmi3Float64 sensitivity[], size_t nsens)
{
    (void)u; (void)nu; (void)k; (void)nk; (void)seed; (void)ns; (void)sensitivity; (void)nsens;
    return fail(instance, "adjoint derivatives are not provided");
}

/* ------------------------------------------------------------------ clocks (none) */

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance)
{
    return fail(instance, "the FMU has no structural parameters");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance)
{
    return fail(instance, "the FMU has no structural parameters");
}

#define NO_CLOCKS(Name, ...)                                                                  \
    fmi3Status fmi3##Name(fmi3Instance instance, __VA_ARGS__)                                 \
    {                                                                                         \
        return fail(instance, "the FMU has no clocks");                                       \
    }

NO_CLOCKS(GetIntervalDecimal, const fmi3ValueReference vr[], size_t n, fmi3Float64 i[],
          fmi3IntervalQualifier q[])
NO_CLOCKS(GetIntervalFraction, const fmi3ValueReference vr[], size_t n, fmi3UInt64 c[],
          fmi3UInt64 r[], fmi3IntervalQualifier q[])
NO_CLOCKS(GetShiftDecimal, const fmi3ValueReference vr[], size_t n, fmi3Float64 s[])
NO_CLOCKS(GetShiftFraction, const fmi3ValueReference vr[], size_t n, fmi3UInt64 c[],
          fmi3UInt64 r[])
NO_CLOCKS(SetIntervalDecimal, const fmi3ValueReference vr[], size_t n, const fmi3Float64 i[])
NO_CLOCKS(SetIntervalFraction, const fmi3ValueReference vr[], size_t n, const fmi3UInt64 c[],
          const fmi3UInt64 r[])
NO_CLOCKS(SetShiftDecimal, const fmi3ValueReference vr[], size_t n, const fmi3Float64 s[])
NO_CLOCKS(SetShiftFraction, const fmi3ValueReference vr[], size_t n, const fmi3UInt64 c[],
          const fmi3UInt64 r[])
NO_CLOCKS(ActivateModelPartition, fmi3ValueReference clock, fmi3Float64 t)

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance)
{
    (void)instance;
    return fmi3OK;
}

/* ------------------------------------------------------------------ events, model exchange */

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *needUpdate,
                                    fmi3Boolean *terminate, fmi3Boolean *nominalsChanged,
                                    fmi3Boolean *valuesChanged, fmi3Boolean *timeDefined,
                                    fmi3Float64 *nextTime)
{
    Instance *c = instance;
    char msg[TREB_MSG];
    int changed = 0, defined = 0;
    double next = 0.0;
    CHECK("fmi3UpdateDiscreteStates", 1 << S_EVENT);
    int r = treb_model_event(&c->m, &changed, &defined, &next, msg);
    *needUpdate = fmi3False;
    *terminate = r < 0;
    *nominalsChanged = fmi3False;
    *valuesChanged = changed != 0;
    *timeDefined = defined != 0;
    *nextTime = next;
    if (r < 0) c->state = S_ERROR;
    return result(c, r, msg);
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance)
{
    Instance *c = instance;
    CHECK("fmi3EnterContinuousTimeMode", 1 << S_EVENT);
    c->state = S_CONTINUOUS;
    return fmi3OK;
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetPrior,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminate)
{
    Instance *c = instance;
    (void)noSetPrior;
    CHECK("fmi3CompletedIntegratorStep", 1 << S_CONTINUOUS);
    *enterEventMode = fmi3False;
    *terminate = fmi3False;
    return fmi3OK;
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    Instance *c = instance;
    CHECK("fmi3SetTime", RUNNING);
    c->m.time = time;
    c->m.outputs_valid = 0;
    return fmi3OK;
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 x[], size_t nx)
{
    Instance *c = instance;
    CHECK("fmi3SetContinuousStates", (1 << S_CONTINUOUS) | (1 << S_EVENT));
    if (nx != TREB_NX_STATES) return fail(c, "fmi3SetContinuousStates: wrong number of states");
    memcpy(c->m.x, x, sizeof c->m.x);
    c->m.outputs_valid = 0;
    return fmi3OK;
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 dx[],
                                             size_t nx)
{
    Instance *c = instance;
    CHECK("fmi3GetContinuousStateDerivatives", (1 << S_INIT) | RUNNING | (1 << S_TERMINATED));
    if (nx != TREB_NX_STATES) return fail(c, "wrong number of states");
    treb_model_derivatives(&c->m, dx);
    return fmi3OK;
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 z[], size_t nz)
{
    Instance *c = instance;
    CHECK("fmi3GetEventIndicators", (1 << S_INIT) | RUNNING | (1 << S_TERMINATED));
    if (nz != TREB_NZ) return fail(c, "wrong number of event indicators");
    treb_model_indicators(&c->m, z);
    return fmi3OK;
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 x[], size_t nx)
{
    Instance *c = instance;
    CHECK("fmi3GetContinuousStates", (1 << S_INIT) | RUNNING | (1 << S_TERMINATED));
    if (nx != TREB_NX_STATES) return fail(c, "wrong number of states");
    memcpy(x, c->m.x, sizeof c->m.x);
    return fmi3OK;
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nx)
{
    (void)instance;
    for (size_t i = 0; i < nx; i++) nominals[i] = 1.0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *n)
{
    (void)instance;
    *n = TREB_NZ;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *n)
{
    (void)instance;
    *n = TREB_NX_STATES;
    return fmi3OK;
}

/* ------------------------------------------------------------------ co-simulation */

fmi3Status fmi3EnterStepMode(fmi3Instance instance)
{
    return fail(instance, "event mode in co-simulation is not supported");
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[],
                                    size_t nvr, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues)
{
    (void)vr; (void)nvr; (void)orders; (void)values; (void)nValues;
    return fail(instance, "output derivatives are not provided");
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 t, fmi3Float64 h,
                      fmi3Boolean noSetPrior, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminate, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime)
{
    Instance *c = instance;
    char msg[TREB_MSG];
    (void)noSetPrior;
    CHECK("fmi3DoStep", 1 << S_STEP);
    *eventHandlingNeeded = fmi3False;
    *terminate = fmi3False;
    *earlyReturn = fmi3False;
    if (h < 0.0) return fail(c, "fmi3DoStep: negative step size");
    int r = treb_model_step(&c->m, t, h, msg);
    *lastSuccessfulTime = r < 0 ? t : t + h;
    if (r < 0) c->state = S_ERROR;
    return result(c, r, msg);
}

/* FMI 3.0 functions of Trebuchet (co-simulation and model exchange), over treb_model.c and
 * treb_state.c, laid out as fmi2.c (the same checks of the instance, its state and every
 * pointer; the same error state). Reals are Float64, the phase Int32, the choices
 * Enumerations (Int64), the release command Boolean; the event indicators are the local
 * Float64 variables after the interface's (value references TREB_NV ... TREB_NV + 2), then
 * the independent time. A step that reaches the FMU's horizon returns fmi3Discard with
 * terminateSimulation true and lastSuccessfulTime at the horizon. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "treb_state.h"

typedef struct {
    fmi3LogMessageCallback logger;
    fmi3InstanceEnvironment env;
    fmi3Boolean logging;
    int cosim;
    TrebCore k;
} Instance;

static void log3(Instance *c, fmi3Status status, const char *category, const char *fmt, ...)
{
    char text[TREB_MSG + 128];
    va_list ap;
    if (!c || !c->logger) return;
    if (status == fmi3OK && !c->logging) return;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    c->logger(c->env, status, category, text);
}

/* An error: logged, and the instance is in the error state from now on. */
static fmi3Status fail(Instance *c, const char *msg)
{
    if (!c) return fmi3Error;
    log3(c, fmi3Error, "logStatusError", "%s", msg);
    c->k.state = TREB_S_ERROR;
    c->k.broken = 1;
    return fmi3Error;
}

static fmi3Status failf(Instance *c, const char *fmt, ...)
{
    char text[TREB_MSG + 64];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    return fail(c, text);
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

/* The horizon reached: no further step; reads, fmiTerminate and fmiReset only. */
static void stop_here(Instance *c)
{
    c->k.state = TREB_S_STOPPED;
    c->k.stopped = 1;
}

static int check(Instance *c, const char *fn, int allowed)
{
    if (!c) return 0;
    if (c->k.state < 0 || c->k.state >= TREB_NSTATES || !(allowed & (1 << c->k.state))) {
        failf(c, "%s may not be called in this state (%s)", fn, treb_state_name(c->k.state));
        return 0;
    }
    return 1;
}

#define BIT(s) (1 << (s))
#define ANY ((1 << TREB_NSTATES) - 1)
#define RUNNING (BIT(TREB_S_STEP) | BIT(TREB_S_EVENT) | BIT(TREB_S_CONTINUOUS))
#define AFTER_INIT (BIT(TREB_S_INIT) | RUNNING | BIT(TREB_S_TERMINATED) | BIT(TREB_S_ERROR) \
                    | BIT(TREB_S_STOPPED))
#define SETTABLE (BIT(TREB_S_INSTANTIATED) | BIT(TREB_S_INIT) | RUNNING)
#define CHECK(fn, allowed) do { if (!check(c, fn, allowed)) return fmi3Error; } while (0)
#define NEED(p, fn, what) \
    do { if (!(p)) return failf(c, "%s: %s is NULL", fn, what); } while (0)
#define ME_ONLY(fn) \
    do { if (c->cosim) \
             return failf(c, "%s: a co-simulation instance has no continuous states", fn); \
    } while (0)

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t n,
                               const fmi3String categories[])
{
    Instance *c = instance;
    CHECK("fmi3SetDebugLogging", ANY);
    if (n > 0) NEED(categories, "fmi3SetDebugLogging", "categories");
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
    treb_core_new(&c->k, cosim);
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
    treb_core_free(&c->k);
    free(c);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    Instance *c = instance;
    char msg[TREB_MSG];
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    CHECK("fmi3EnterInitializationMode", BIT(TREB_S_INSTANTIATED));
    if (treb_model_check_start(startTime, msg)) return fail(c, msg);
    c->k.start_time = startTime;
    c->k.state = TREB_S_INIT;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    Instance *c = instance;
    char msg[TREB_MSG];
    CHECK("fmi3ExitInitializationMode", BIT(TREB_S_INIT));
    if (treb_model_exit_init(&c->k.m, c->k.start_time, msg)) return fail(c, msg);
    c->k.state = c->cosim ? TREB_S_STEP : TREB_S_EVENT;
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance)
{
    Instance *c = instance;
    CHECK("fmi3EnterEventMode", BIT(TREB_S_EVENT) | BIT(TREB_S_CONTINUOUS));
    c->k.state = TREB_S_EVENT;
    return fmi3OK;
}

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    Instance *c = instance;
    CHECK("fmi3Terminate", RUNNING | BIT(TREB_S_ERROR) | BIT(TREB_S_STOPPED));
    c->k.state = TREB_S_TERMINATED;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    Instance *c = instance;
    CHECK("fmi3Reset", ANY);
    treb_core_reset(&c->k);
    return fmi3OK;
}

/* ------------------------------------------------------------------ values */

static int valid_vr(Instance *c, fmi3ValueReference vr, int type)
{
    if (vr >= TREB_NV || TREB_VAR_TYPE[vr] != type) {
        failf(c, "value reference %u is not a variable of this type", (unsigned)vr);
        return 0;
    }
    return 1;
}

/* One value: a variable, an event indicator (model exchange) or the time. */
static int value_of(Instance *c, fmi3ValueReference vr, int type, double *out)
{
    char msg[TREB_MSG];
    if (type == TREB_REAL && vr >= TREB_NV && vr < TREB_NV + TREB_NZ) {
        double z[TREB_NZ];
        if (treb_model_event_indicators(&c->k.m, z, msg)) return fail(c, msg), 0;
        *out = z[vr - TREB_NV];
        return 1;
    }
    if (type == TREB_REAL && vr == TREB_NV + TREB_NZ) {  /* the independent variable */
        *out = c->k.m.time;
        return 1;
    }
    if (!valid_vr(c, vr, type)) return 0;
    *out = c->k.m.values[vr];
    return 1;
}

static fmi3Status get(Instance *c, const char *fn, const fmi3ValueReference vr[], size_t nvr,
                      int type, void *out, size_t nValues, void (*put)(void *, size_t, double))
{
    char msg[TREB_MSG];
    CHECK(fn, AFTER_INIT);
    if (nvr == 0) return fmi3OK;
    NEED(vr, fn, "the value references");
    NEED(out, fn, "the values");
    if (nValues < nvr) return failf(c, "%s: %lu values for %lu references", fn,
                                     (unsigned long)nValues, (unsigned long)nvr);
    if (c->k.m.initialized && !c->k.broken && treb_model_outputs(&c->k.m, msg))
        return fail(c, msg);
    for (size_t i = 0; i < nvr; i++) {
        double v;
        if (!value_of(c, vr[i], type, &v)) return fmi3Error;
        put(out, i, v);
    }
    return fmi3OK;
}

static fmi3Status set(Instance *c, const char *fn, const fmi3ValueReference vr[], size_t nvr,
                      int type, const void *in, size_t nValues,
                      double (*take)(const void *, size_t))
{
    char msg[TREB_MSG];
    CHECK(fn, SETTABLE);
    if (nvr == 0) return fmi3OK;
    NEED(vr, fn, "the value references");
    NEED(in, fn, "the values");
    if (nValues < nvr) return failf(c, "%s: %lu values for %lu references", fn,
                                     (unsigned long)nValues, (unsigned long)nvr);
    for (size_t i = 0; i < nvr; i++) {
        if (!valid_vr(c, vr[i], type)) return fmi3Error;
        int causality = TREB_VAR_CAUSALITY[vr[i]];
        int ok = causality == TREB_INPUT
                 || (causality == TREB_PARAMETER
                     && (c->k.state == TREB_S_INSTANTIATED || c->k.state == TREB_S_INIT));
        if (!ok)
            return failf(c, "%s cannot be set %s", TREB_VAR_NAME[vr[i]],
                         causality == TREB_OUTPUT ? "(an output)" : "after initialisation (fixed)");
        if (treb_model_set_value(&c->k.m, (int)vr[i], take(in, i), msg)) return fail(c, msg);
    }
    return fmi3OK;
}

#define VALUES(Name, T, kind)                                                                 \
    static void put_##Name(void *out, size_t i, double v) { ((T *)out)[i] = (T)v; }           \
    static double take_##Name(const void *in, size_t i) { return (double)((const T *)in)[i]; } \
    fmi3Status fmi3Get##Name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                             T values[], size_t nValues)                                      \
    {                                                                                         \
        return get(instance, "fmi3Get" #Name, vr, nvr, kind, values, nValues, put_##Name);    \
    }                                                                                         \
    fmi3Status fmi3Set##Name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                             const T values[], size_t nValues)                                \
    {                                                                                         \
        return set(instance, "fmi3Set" #Name, vr, nvr, kind, values, nValues, take_##Name);   \
    }
#define NO_VARIABLES(Name, T)                                                                 \
    fmi3Status fmi3Get##Name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                             T values[], size_t nValues)                                      \
    {                                                                                         \
        Instance *c = instance;                                                               \
        (void)vr; (void)values; (void)nValues;                                                \
        CHECK("fmi3Get" #Name, ANY);                                                          \
        return nvr ? fail(c, "the FMU has no variables of type " #Name) : fmi3OK;             \
    }                                                                                         \
    fmi3Status fmi3Set##Name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                             const T values[], size_t nValues)                                \
    {                                                                                         \
        Instance *c = instance;                                                               \
        (void)vr; (void)values; (void)nValues;                                                \
        CHECK("fmi3Set" #Name, ANY);                                                          \
        return nvr ? fail(c, "the FMU has no variables of type " #Name) : fmi3OK;             \
    }

static double boolean_value(double v) { return v != 0.0; }

VALUES(Float64, fmi3Float64, TREB_REAL)
VALUES(Int32, fmi3Int32, TREB_INTEGER)
VALUES(Int64, fmi3Int64, TREB_ENUMERATION)
NO_VARIABLES(Float32, fmi3Float32)
NO_VARIABLES(Int8, fmi3Int8)
NO_VARIABLES(UInt8, fmi3UInt8)
NO_VARIABLES(Int16, fmi3Int16)
NO_VARIABLES(UInt16, fmi3UInt16)
NO_VARIABLES(UInt32, fmi3UInt32)
NO_VARIABLES(UInt64, fmi3UInt64)
NO_VARIABLES(String, fmi3String)

static void put_Boolean(void *out, size_t i, double v) { ((fmi3Boolean *)out)[i] = v != 0.0; }
static double take_Boolean(const void *in, size_t i)
{
    return boolean_value(((const fmi3Boolean *)in)[i]);
}

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                          fmi3Boolean values[], size_t nValues)
{
    return get(instance, "fmi3GetBoolean", vr, nvr, TREB_BOOLEAN, values, nValues, put_Boolean);
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                          const fmi3Boolean values[], size_t nValues)
{
    return set(instance, "fmi3SetBoolean", vr, nvr, TREB_BOOLEAN, values, nValues,
               take_Boolean);
}

/* The functions of what the FMU does not have: checked, then refused when asked for any. */
#define NOTHING(fn, count, what) \
    do { CHECK(fn, ANY); return (count) ? fail(c, what) : fmi3OK; } while (0)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues)
{
    Instance *c = instance;
    (void)vr; (void)valueSizes; (void)values; (void)nValues;
    NOTHING("fmi3GetBinary", nvr, "the FMU has no Binary variables");
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues)
{
    Instance *c = instance;
    (void)vr; (void)valueSizes; (void)values; (void)nValues;
    NOTHING("fmi3SetBinary", nvr, "the FMU has no Binary variables");
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                        fmi3Clock values[])
{
    Instance *c = instance;
    (void)vr; (void)values;
    NOTHING("fmi3GetClock", nvr, "the FMU has no clocks");
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                        const fmi3Clock values[])
{
    Instance *c = instance;
    (void)vr; (void)values;
    NOTHING("fmi3SetClock", nvr, "the FMU has no clocks");
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference vr,
                                               size_t *n)
{
    Instance *c = instance;
    (void)vr; (void)n;
    NOTHING("fmi3GetNumberOfVariableDependencies", 1, "variable dependencies are not provided");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[],
                                       fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[],
                                       fmi3DependencyKind dependencyKinds[], size_t n)
{
    Instance *c = instance;
    (void)dependent; (void)elementIndicesOfDependent; (void)independents;
    (void)elementIndicesOfIndependents; (void)dependencyKinds; (void)n;
    NOTHING("fmi3GetVariableDependencies", 1, "variable dependencies are not provided");
}

/* ------------------------------------------------------------------ FMU state */

#define STATE_CALL(fn, expr) \
    do { char msg_[TREB_MSG]; CHECK(fn, ANY); \
         return (expr) ? fail(c, msg_) : fmi3OK; } while (0)

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    Instance *c = instance;
    STATE_CALL("fmi3GetFMUState", treb_core_get_state(&c->k, FMUState, msg_));
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    Instance *c = instance;
    STATE_CALL("fmi3SetFMUState", treb_core_set_state(&c->k, FMUState, msg_));
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    Instance *c = instance;
    STATE_CALL("fmi3FreeFMUState", treb_core_free_state(&c->k, FMUState, msg_));
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState,
                                      size_t *size)
{
    Instance *c = instance;
    STATE_CALL("fmi3SerializedFMUStateSize", treb_core_state_size(&c->k, FMUState, size, msg_));
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                 fmi3Byte serializedState[], size_t size)
{
    Instance *c = instance;
    STATE_CALL("fmi3SerializeFMUState",
               treb_core_serialize(&c->k, FMUState, 3, serializedState, size, msg_));
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[],
                                   size_t size, fmi3FMUState *FMUState)
{
    Instance *c = instance;
    STATE_CALL("fmi3DeserializeFMUState",
               treb_core_deserialize(&c->k, 3, serializedState, size, FMUState, msg_));
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference u[],
                                        size_t nu, const fmi3ValueReference k[], size_t nk,
                                        const fmi3Float64 seed[], size_t ns,
                                        fmi3Float64 sensitivity[], size_t nsens)
{
    Instance *c = instance;
    const char *fn = "fmi3GetDirectionalDerivative";
    char msg[TREB_MSG];
    CHECK(fn, RUNNING | BIT(TREB_S_TERMINATED));
    if (ns != nk || nsens != nu) return fail(c, "fmi3GetDirectionalDerivative: sizes differ");
    if (nu) { NEED(u, fn, "unknowns"); NEED(sensitivity, fn, "sensitivity"); }
    if (nk) { NEED(k, fn, "knowns"); NEED(seed, fn, "seed"); }
    for (size_t i = 0; i < nk; i++)
        if (!isfinite(seed[i])) return failf(c, "%s: seed[%lu] = %g: must be finite", fn,
                                             (unsigned long)i, seed[i]);
    if (treb_model_directional(&c->k.m, u, nu, k, nk, seed, sensitivity, msg))
        return fail(c, msg);
    return fmi3OK;
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference u[],
                                    size_t nu, const fmi3ValueReference k[], size_t nk,
                                    const fmi3Float64 seed[], size_t ns,
                                    fmi3Float64 sensitivity[], size_t nsens)
{
    Instance *c = instance;
    (void)u; (void)nu; (void)k; (void)nk; (void)seed; (void)ns; (void)sensitivity; (void)nsens;
    NOTHING("fmi3GetAdjointDerivative", 1, "adjoint derivatives are not provided");
}

/* ------------------------------------------------------------------ clocks (none) */

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance)
{
    Instance *c = instance;
    NOTHING("fmi3EnterConfigurationMode", 1, "the FMU has no structural parameters");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance)
{
    Instance *c = instance;
    NOTHING("fmi3ExitConfigurationMode", 1, "the FMU has no structural parameters");
}

#define NO_CLOCKS(Name, ...)                                                                  \
    fmi3Status fmi3##Name(fmi3Instance instance, __VA_ARGS__)                                 \
    {                                                                                         \
        Instance *c = instance;                                                               \
        NOTHING("fmi3" #Name, 1, "the FMU has no clocks");                                    \
    }

NO_CLOCKS(GetIntervalDecimal, const fmi3ValueReference vr[], size_t n, fmi3Float64 i[],
          fmi3IntervalQualifier q[])
NO_CLOCKS(GetIntervalFraction, const fmi3ValueReference vr[], size_t n, fmi3UInt64 cnt[],
          fmi3UInt64 r[], fmi3IntervalQualifier q[])
NO_CLOCKS(GetShiftDecimal, const fmi3ValueReference vr[], size_t n, fmi3Float64 s[])
NO_CLOCKS(GetShiftFraction, const fmi3ValueReference vr[], size_t n, fmi3UInt64 cnt[],
          fmi3UInt64 r[])
NO_CLOCKS(SetIntervalDecimal, const fmi3ValueReference vr[], size_t n, const fmi3Float64 i[])
NO_CLOCKS(SetIntervalFraction, const fmi3ValueReference vr[], size_t n, const fmi3UInt64 cnt[],
          const fmi3UInt64 r[])
NO_CLOCKS(SetShiftDecimal, const fmi3ValueReference vr[], size_t n, const fmi3Float64 s[])
NO_CLOCKS(SetShiftFraction, const fmi3ValueReference vr[], size_t n, const fmi3UInt64 cnt[],
          const fmi3UInt64 r[])
NO_CLOCKS(ActivateModelPartition, fmi3ValueReference clock, fmi3Float64 t)

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance)
{
    Instance *c = instance;
    CHECK("fmi3EvaluateDiscreteStates", BIT(TREB_S_EVENT));
    return fmi3OK;
}

/* ------------------------------------------------------------------ events, model exchange */

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *needUpdate,
                                    fmi3Boolean *terminate, fmi3Boolean *nominalsChanged,
                                    fmi3Boolean *valuesChanged, fmi3Boolean *timeDefined,
                                    fmi3Float64 *nextTime)
{
    Instance *c = instance;
    const char *fn = "fmi3UpdateDiscreteStates";
    char msg[TREB_MSG];
    int changed = 0, defined = 0;
    double next = 0.0;
    CHECK(fn, BIT(TREB_S_EVENT));
    NEED(needUpdate, fn, "discreteStatesNeedUpdate");
    NEED(terminate, fn, "terminateSimulation");
    NEED(nominalsChanged, fn, "nominalsOfContinuousStatesChanged");
    NEED(valuesChanged, fn, "valuesOfContinuousStatesChanged");
    NEED(timeDefined, fn, "nextEventTimeDefined");
    NEED(nextTime, fn, "nextEventTime");
    int r = treb_model_event(&c->k.m, &changed, &defined, &next, msg);
    int stop = r >= 0 && treb_model_past_horizon(&c->k.m, msg);
    *needUpdate = fmi3False;
    *terminate = r < 0 || stop;
    *nominalsChanged = fmi3False;
    *valuesChanged = changed != 0;
    *timeDefined = defined != 0;
    *nextTime = next;
    if (stop) stop_here(c);
    return result(c, stop ? 1 : r, msg);
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance)
{
    Instance *c = instance;
    CHECK("fmi3EnterContinuousTimeMode", BIT(TREB_S_EVENT));
    c->k.state = TREB_S_CONTINUOUS;
    return fmi3OK;
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetPrior,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminate)
{
    Instance *c = instance;
    char msg[TREB_MSG];
    (void)noSetPrior;
    CHECK("fmi3CompletedIntegratorStep", BIT(TREB_S_CONTINUOUS));
    NEED(enterEventMode, "fmi3CompletedIntegratorStep", "enterEventMode");
    NEED(terminate, "fmi3CompletedIntegratorStep", "terminateSimulation");
    int stop = treb_model_past_horizon(&c->k.m, msg);
    if (stop) stop_here(c);
    *enterEventMode = fmi3False;
    *terminate = stop != 0;
    return result(c, stop, msg);
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    Instance *c = instance;
    char msg[TREB_MSG];
    CHECK("fmi3SetTime", BIT(TREB_S_EVENT) | BIT(TREB_S_CONTINUOUS));
    ME_ONLY("fmi3SetTime");
    return treb_model_set_time(&c->k.m, time, msg) ? fail(c, msg) : fmi3OK;
}

#define ME_ARRAY(fn, p, n, want) \
    do { ME_ONLY(fn); NEED(p, fn, "the array"); \
         if ((n) != (want)) return failf(c, "%s: %lu values, the FMU has %d", fn, \
                                         (unsigned long)(n), (int)(want)); } while (0)
#define EVALUATED (RUNNING | BIT(TREB_S_TERMINATED))

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 x[], size_t nx)
{
    Instance *c = instance;
    char msg[TREB_MSG];
    CHECK("fmi3SetContinuousStates", BIT(TREB_S_CONTINUOUS) | BIT(TREB_S_EVENT));
    ME_ARRAY("fmi3SetContinuousStates", x, nx, TREB_NX_STATES);
    return treb_model_set_states(&c->k.m, x, msg) ? fail(c, msg) : fmi3OK;
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 dx[],
                                             size_t nx)
{
    Instance *c = instance;
    char msg[TREB_MSG];
    CHECK("fmi3GetContinuousStateDerivatives", EVALUATED);
    ME_ARRAY("fmi3GetContinuousStateDerivatives", dx, nx, TREB_NX_STATES);
    return treb_model_derivatives(&c->k.m, dx, msg) ? fail(c, msg) : fmi3OK;
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 z[], size_t nz)
{
    Instance *c = instance;
    char msg[TREB_MSG];
    CHECK("fmi3GetEventIndicators", EVALUATED);
    ME_ARRAY("fmi3GetEventIndicators", z, nz, TREB_NZ);
    return treb_model_event_indicators(&c->k.m, z, msg) ? fail(c, msg) : fmi3OK;
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 x[], size_t nx)
{
    Instance *c = instance;
    CHECK("fmi3GetContinuousStates", EVALUATED);
    ME_ARRAY("fmi3GetContinuousStates", x, nx, TREB_NX_STATES);
    memcpy(x, c->k.m.x, sizeof c->k.m.x);
    return fmi3OK;
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nx)
{
    Instance *c = instance;
    CHECK("fmi3GetNominalsOfContinuousStates", ANY);
    ME_ARRAY("fmi3GetNominalsOfContinuousStates", nominals, nx, TREB_NX_STATES);
    for (size_t i = 0; i < nx; i++) nominals[i] = 1.0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *n)
{
    Instance *c = instance;
    CHECK("fmi3GetNumberOfEventIndicators", ANY);
    NEED(n, "fmi3GetNumberOfEventIndicators", "the count");
    *n = TREB_NZ;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *n)
{
    Instance *c = instance;
    CHECK("fmi3GetNumberOfContinuousStates", ANY);
    NEED(n, "fmi3GetNumberOfContinuousStates", "the count");
    *n = TREB_NX_STATES;
    return fmi3OK;
}

/* ------------------------------------------------------------------ co-simulation */

fmi3Status fmi3EnterStepMode(fmi3Instance instance)
{
    Instance *c = instance;
    NOTHING("fmi3EnterStepMode", 1, "event mode in co-simulation is not supported");
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[],
                                    size_t nvr, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues)
{
    Instance *c = instance;
    (void)vr; (void)nvr; (void)orders; (void)values; (void)nValues;
    NOTHING("fmi3GetOutputDerivatives", 1, "output derivatives are not provided");
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 t, fmi3Float64 h,
                      fmi3Boolean noSetPrior, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminate, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime)
{
    Instance *c = instance;
    const char *fn = "fmi3DoStep";
    char msg[TREB_MSG];
    (void)noSetPrior;
    CHECK(fn, BIT(TREB_S_STEP));
    NEED(eventHandlingNeeded, fn, "eventHandlingNeeded");
    NEED(terminate, fn, "terminateSimulation");
    NEED(earlyReturn, fn, "earlyReturn");
    NEED(lastSuccessfulTime, fn, "lastSuccessfulTime");
    *eventHandlingNeeded = fmi3False;
    *terminate = fmi3False;
    *earlyReturn = fmi3False;
    *lastSuccessfulTime = c->k.m.time;
    int r = treb_model_step(&c->k.m, t, h, msg);
    if (r == 2) {  /* the horizon: the step is done up to there, and no further step */
        stop_here(c);
        *terminate = fmi3True;
        *lastSuccessfulTime = c->k.m.time;
        log3(c, fmi3Discard, "logStatusDiscard", "%s", msg);
        return fmi3Discard;
    }
    if (r >= 0) *lastSuccessfulTime = c->k.m.time;
    return result(c, r, msg);
}

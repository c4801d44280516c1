/* FMI 2.0 functions of Trebuchet (co-simulation and model exchange), over treb_model.c and
 * treb_state.c. Laid out as the Reference FMUs are: an instance holds the callbacks and a
 * TrebCore; every function checks the instance, its state and every pointer it is given,
 * calls the model and logs what fails. An error puts the instance in the error state, where
 * only reads (their values for diagnosis), the FMU state functions, fmi2Terminate,
 * fmi2Reset and fmi2FreeInstance are allowed; a step that reaches the FMU's horizon returns
 * fmi2Discard with fmi2Terminated true, after which no step is allowed. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "treb_state.h"

#ifndef TREB_GUID
#define TREB_GUID "{trebuchet}"
#endif

typedef struct {
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment env;
    char *name;
    fmi2Boolean logging;
    fmi2Type type;
    TrebCore k;
} Instance;

static void logf2(Instance *c, fmi2Status status, const char *category, const char *fmt, ...)
{
    char text[TREB_MSG + 128];
    va_list ap;
    if (!c || !c->logger) return;
    if (status == fmi2OK && !c->logging) return;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    c->logger(c->env, c->name, status, category, text);  /* formatted, as the Reference FMUs */
}

/* An error: logged, and the instance is in the error state from now on. */
static fmi2Status fail(Instance *c, const char *msg)
{
    if (!c) return fmi2Error;
    logf2(c, fmi2Error, "logStatusError", "%s", msg);
    c->k.state = TREB_S_ERROR;
    c->k.broken = 1;
    return fmi2Error;
}

static fmi2Status failf(Instance *c, const char *fmt, ...)
{
    char text[TREB_MSG + 64];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    return fail(c, text);
}

/* The model's result as a status: warnings and errors logged. */
static fmi2Status result(Instance *c, int r, const char *msg)
{
    if (r < 0) return fail(c, msg);
    if (r > 0) {
        logf2(c, fmi2Warning, "logStatusWarning", "%s", msg);
        return fmi2Warning;
    }
    return fmi2OK;
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
#define CHECK(fn, allowed) do { if (!check(c, fn, allowed)) return fmi2Error; } while (0)
/* A pointer argument the call needs. */
#define NEED(p, fn, what) \
    do { if (!(p)) return failf(c, "%s: %s is NULL", fn, what); } while (0)
#define ME_ONLY(fn) \
    do { if (c->type != fmi2ModelExchange) \
             return failf(c, "%s: a co-simulation instance has no continuous states", fn); \
    } while (0)

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn)
{
    (void)fmuResourceLocation;
    (void)visible;
    if (!functions || !functions->logger) return NULL;
    const char *name = instanceName ? instanceName : "Trebuchet";
    if (!fmuGUID || strcmp(fmuGUID, TREB_GUID) != 0) {
        functions->logger(functions->componentEnvironment, name, fmi2Error, "logStatusError",
                          "GUID %s does not match this FMU's %s", fmuGUID ? fmuGUID : "(null)",
                          TREB_GUID);
        return NULL;
    }
    if (fmuType != fmi2ModelExchange && fmuType != fmi2CoSimulation) {
        functions->logger(functions->componentEnvironment, name, fmi2Error, "logStatusError",
                          "fmuType = %d: must be fmi2ModelExchange (0) or fmi2CoSimulation (1)",
                          (int)fmuType);
        return NULL;
    }
    Instance *c = calloc(1, sizeof *c);
    if (!c) return NULL;
    c->name = malloc(strlen(name) + 1);
    if (!c->name) { free(c); return NULL; }
    strcpy(c->name, name);
    c->logger = functions->logger;
    c->env = functions->componentEnvironment;
    c->logging = loggingOn;
    c->type = fmuType;
    treb_core_new(&c->k, fmuType == fmi2CoSimulation);
    return c;
}

void fmi2FreeInstance(fmi2Component comp)
{
    Instance *c = comp;
    if (!c) return;
    treb_core_free(&c->k);
    free(c->name);
    free(c);
}

fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn, size_t n,
                               const fmi2String categories[])
{
    Instance *c = comp;
    CHECK("fmi2SetDebugLogging", ANY);
    if (n > 0) NEED(categories, "fmi2SetDebugLogging", "categories");
    c->logging = loggingOn;
    return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    Instance *c = comp;
    char msg[TREB_MSG];
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    CHECK("fmi2SetupExperiment", BIT(TREB_S_INSTANTIATED));
    if (treb_model_check_start(startTime, msg)) return fail(c, msg);
    c->k.start_time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component comp)
{
    Instance *c = comp;
    CHECK("fmi2EnterInitializationMode", BIT(TREB_S_INSTANTIATED));
    c->k.state = TREB_S_INIT;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component comp)
{
    Instance *c = comp;
    char msg[TREB_MSG];
    CHECK("fmi2ExitInitializationMode", BIT(TREB_S_INIT));
    if (treb_model_exit_init(&c->k.m, c->k.start_time, msg)) return fail(c, msg);
    c->k.state = c->type == fmi2CoSimulation ? TREB_S_STEP : TREB_S_EVENT;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component comp)
{
    Instance *c = comp;
    CHECK("fmi2Terminate", RUNNING | BIT(TREB_S_ERROR) | BIT(TREB_S_STOPPED));
    c->k.state = TREB_S_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component comp)
{
    Instance *c = comp;
    CHECK("fmi2Reset", ANY);
    treb_core_reset(&c->k);
    return fmi2OK;
}

/* ------------------------------------------------------------------ values */

static int valid_vr(Instance *c, fmi2ValueReference vr, int type)
{
    int have = vr < TREB_NV ? TREB_VAR_TYPE[vr] : -1;
    if (have == TREB_ENUMERATION) have = TREB_INTEGER;  /* FMI 2: Enumerations are Integers */
    if (have != type) {
        failf(c, "value reference %u is not a variable of this type", (unsigned)vr);
        return 0;
    }
    return 1;
}

/* The outputs brought up to the instance's time (not after an error: then the last values
 * stand, for diagnosis only). */
static fmi2Status refresh(Instance *c)
{
    char msg[TREB_MSG];
    if (!c->k.m.initialized || c->k.broken) return fmi2OK;
    return treb_model_outputs(&c->k.m, msg) ? fail(c, msg) : fmi2OK;
}

/* Read nvr values of type into out (one at a time: any nvr). */
static fmi2Status get(Instance *c, const char *fn, const fmi2ValueReference vr[], size_t nvr,
                      int type, void *out)
{
    CHECK(fn, AFTER_INIT);
    if (nvr == 0) return fmi2OK;
    NEED(vr, fn, "the value references");
    NEED(out, fn, "the values");
    if (refresh(c) != fmi2OK) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        if (!valid_vr(c, vr[i], type)) return fmi2Error;
        double v = c->k.m.values[vr[i]];
        if (type == TREB_REAL) ((fmi2Real *)out)[i] = v;
        else if (type == TREB_INTEGER) ((fmi2Integer *)out)[i] = (fmi2Integer)v;
        else ((fmi2Boolean *)out)[i] = v != 0.0;
    }
    return fmi2OK;
}

/* Set nvr values of type (read via take); parameters before initialisation only, finite. */
static fmi2Status set(Instance *c, const char *fn, const fmi2ValueReference vr[], size_t nvr,
                      int type, const void *in, double (*take)(const void *, size_t))
{
    char msg[TREB_MSG];
    CHECK(fn, BIT(TREB_S_INSTANTIATED) | BIT(TREB_S_INIT) | RUNNING);
    if (nvr == 0) return fmi2OK;
    NEED(vr, fn, "the value references");
    NEED(in, fn, "the values");
    for (size_t i = 0; i < nvr; i++) {
        if (!valid_vr(c, vr[i], type)) return fmi2Error;
        int causality = TREB_VAR_CAUSALITY[vr[i]];
        int ok = causality == TREB_INPUT
                 || (causality == TREB_PARAMETER
                     && (c->k.state == TREB_S_INSTANTIATED || c->k.state == TREB_S_INIT));
        if (!ok)
            return failf(c, "%s cannot be set %s", TREB_VAR_NAME[vr[i]],
                         causality == TREB_OUTPUT ? "(an output)" : "after initialisation (fixed)");
        if (treb_model_set_value(&c->k.m, (int)vr[i], take(in, i), msg)) return fail(c, msg);
    }
    return fmi2OK;
}

static double take_real(const void *in, size_t i) { return ((const fmi2Real *)in)[i]; }
static double take_integer(const void *in, size_t i) { return ((const fmi2Integer *)in)[i]; }
static double take_boolean(const void *in, size_t i)
{
    return ((const fmi2Boolean *)in)[i] ? 1.0 : 0.0;
}

fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[])
{
    return get(comp, "fmi2GetReal", vr, nvr, TREB_REAL, value);
}

fmi2Status fmi2GetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[])
{
    return get(comp, "fmi2GetInteger", vr, nvr, TREB_INTEGER, value);
}

fmi2Status fmi2GetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[])
{
    return get(comp, "fmi2GetBoolean", vr, nvr, TREB_BOOLEAN, value);
}

fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[])
{
    Instance *c = comp;
    (void)vr; (void)value;
    CHECK("fmi2GetString", AFTER_INIT);
    return nvr ? fail(c, "the FMU has no String variables") : fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[])
{
    return set(comp, "fmi2SetReal", vr, nvr, TREB_REAL, value, take_real);
}

fmi2Status fmi2SetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[])
{
    return set(comp, "fmi2SetInteger", vr, nvr, TREB_INTEGER, value, take_integer);
}

fmi2Status fmi2SetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[])
{
    return set(comp, "fmi2SetBoolean", vr, nvr, TREB_BOOLEAN, value, take_boolean);
}

fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[])
{
    Instance *c = comp;
    (void)vr; (void)value;
    CHECK("fmi2SetString", BIT(TREB_S_INSTANTIATED) | BIT(TREB_S_INIT) | RUNNING);
    return nvr ? fail(c, "the FMU has no String variables") : fmi2OK;
}

/* ------------------------------------------------------------------ FMU state */

/* An FMU state function's result: its message logged as an error. */
#define STATE_CALL(fn, expr) \
    do { char msg_[TREB_MSG]; CHECK(fn, ANY); \
         return (expr) ? fail(c, msg_) : fmi2OK; } while (0)

fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate *FMUstate)
{
    Instance *c = comp;
    STATE_CALL("fmi2GetFMUstate", treb_core_get_state(&c->k, FMUstate, msg_));
}

fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate FMUstate)
{
    Instance *c = comp;
    STATE_CALL("fmi2SetFMUstate", treb_core_set_state(&c->k, FMUstate, msg_));
}

fmi2Status fmi2FreeFMUstate(fmi2Component comp, fmi2FMUstate *FMUstate)
{
    Instance *c = comp;
    STATE_CALL("fmi2FreeFMUstate", treb_core_free_state(&c->k, FMUstate, msg_));
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate FMUstate, size_t *size)
{
    Instance *c = comp;
    STATE_CALL("fmi2SerializedFMUstateSize", treb_core_state_size(&c->k, FMUstate, size, msg_));
}

fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate FMUstate,
                                 fmi2Byte serializedState[], size_t size)
{
    Instance *c = comp;
    STATE_CALL("fmi2SerializeFMUstate",
               treb_core_serialize(&c->k, FMUstate, 2, (unsigned char *)serializedState, size,
                                   msg_));
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp, const fmi2Byte serializedState[],
                                   size_t size, fmi2FMUstate *FMUstate)
{
    Instance *c = comp;
    STATE_CALL("fmi2DeSerializeFMUstate",
               treb_core_deserialize(&c->k, 2, (const unsigned char *)serializedState, size,
                                     FMUstate, msg_));
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp, const fmi2ValueReference vUnknown[],
                                        size_t nUnknown, const fmi2ValueReference vKnown[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[])
{
    Instance *c = comp;
    const char *fn = "fmi2GetDirectionalDerivative";
    char msg[TREB_MSG];
    CHECK(fn, RUNNING | BIT(TREB_S_TERMINATED));
    if (nUnknown) { NEED(vUnknown, fn, "vUnknown"); NEED(dvUnknown, fn, "dvUnknown"); }
    if (nKnown) { NEED(vKnown, fn, "vKnown"); NEED(dvKnown, fn, "dvKnown"); }
    for (size_t k = 0; k < nKnown; k++)
        if (!isfinite(dvKnown[k])) return failf(c, "%s: dvKnown[%lu] = %g: must be finite", fn,
                                                (unsigned long)k, dvKnown[k]);
    if (treb_model_directional(&c->k.m, vUnknown, nUnknown, vKnown, nKnown, dvKnown, dvUnknown,
                               msg))
        return fail(c, msg);
    return fmi2OK;
}

/* ------------------------------------------------------------------ co-simulation */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[])
{
    Instance *c = comp;
    (void)vr; (void)nvr; (void)order; (void)value;
    CHECK("fmi2SetRealInputDerivatives", ANY);
    return fail(c, "the FMU has no Real inputs");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[],
                                        fmi2Real value[])
{
    Instance *c = comp;
    (void)vr; (void)nvr; (void)order; (void)value;
    CHECK("fmi2GetRealOutputDerivatives", ANY);
    return fail(c, "output derivatives are not provided");
}

fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrent)
{
    Instance *c = comp;
    char msg[TREB_MSG];
    (void)noSetFMUStatePriorToCurrent;
    CHECK("fmi2DoStep", BIT(TREB_S_STEP));
    int r = treb_model_step(&c->k.m, currentCommunicationPoint, communicationStepSize, msg);
    if (r == 2) {  /* the horizon: the step is done up to there, and no further step */
        stop_here(c);
        logf2(c, fmi2Discard, "logStatusDiscard", "%s", msg);
        return fmi2Discard;
    }
    return result(c, r, msg);
}

fmi2Status fmi2CancelStep(fmi2Component comp)
{
    Instance *c = comp;
    CHECK("fmi2CancelStep", ANY);
    return fail(c, "fmi2DoStep never runs asynchronously: nothing to cancel");
}

/* fmi2LastSuccessfulTime (the instance's time) and fmi2Terminated (the horizon reached) are
 * known; every other status is fmi2Discard, as fmi2DoStep never returns fmi2Pending. */
#define STATUS(fn) \
    CHECK(fn, AFTER_INIT); \
    NEED(value, fn, "value")

fmi2Status fmi2GetStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Status *value)
{
    Instance *c = comp;
    (void)s;
    STATUS("fmi2GetStatus");
    return fmi2Discard;
}

fmi2Status fmi2GetRealStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Real *value)
{
    Instance *c = comp;
    STATUS("fmi2GetRealStatus");
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *value = c->k.m.time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Integer *value)
{
    Instance *c = comp;
    (void)s;
    STATUS("fmi2GetIntegerStatus");
    return fmi2Discard;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component comp, const fmi2StatusKind s,
                                fmi2Boolean *value)
{
    Instance *c = comp;
    STATUS("fmi2GetBooleanStatus");
    if (s != fmi2Terminated) return fmi2Discard;
    *value = c->k.stopped ? fmi2True : fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component comp, const fmi2StatusKind s, fmi2String *value)
{
    Instance *c = comp;
    (void)s;
    STATUS("fmi2GetStringStatus");
    return fmi2Discard;
}

/* ------------------------------------------------------------------ model exchange */

fmi2Status fmi2EnterEventMode(fmi2Component comp)
{
    Instance *c = comp;
    CHECK("fmi2EnterEventMode", BIT(TREB_S_EVENT) | BIT(TREB_S_CONTINUOUS));
    c->k.state = TREB_S_EVENT;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component comp, fmi2EventInfo *info)
{
    Instance *c = comp;
    char msg[TREB_MSG];
    int changed = 0, time_defined = 0;
    double next = 0.0;
    CHECK("fmi2NewDiscreteStates", BIT(TREB_S_EVENT));
    NEED(info, "fmi2NewDiscreteStates", "eventInfo");
    int r = treb_model_event(&c->k.m, &changed, &time_defined, &next, msg);
    int stop = r >= 0 && treb_model_past_horizon(&c->k.m, msg);
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = r < 0 || stop;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = changed ? fmi2True : fmi2False;
    info->nextEventTimeDefined = time_defined ? fmi2True : fmi2False;
    info->nextEventTime = next;
    if (stop) stop_here(c);
    return result(c, stop ? 1 : r, msg);
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component comp)
{
    Instance *c = comp;
    CHECK("fmi2EnterContinuousTimeMode", BIT(TREB_S_EVENT));
    c->k.state = TREB_S_CONTINUOUS;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component comp,
                                       fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminate)
{
    Instance *c = comp;
    char msg[TREB_MSG];
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK("fmi2CompletedIntegratorStep", BIT(TREB_S_CONTINUOUS));
    NEED(enterEventMode, "fmi2CompletedIntegratorStep", "enterEventMode");
    NEED(terminate, "fmi2CompletedIntegratorStep", "terminateSimulation");
    int stop = treb_model_past_horizon(&c->k.m, msg);
    if (stop) stop_here(c);
    *enterEventMode = fmi2False;
    *terminate = stop ? fmi2True : fmi2False;
    return result(c, stop, msg);
}

fmi2Status fmi2SetTime(fmi2Component comp, fmi2Real time)
{
    Instance *c = comp;
    char msg[TREB_MSG];
    CHECK("fmi2SetTime", BIT(TREB_S_INSTANTIATED) | BIT(TREB_S_INIT) | BIT(TREB_S_EVENT)
          | BIT(TREB_S_CONTINUOUS));
    ME_ONLY("fmi2SetTime");
    return treb_model_set_time(&c->k.m, time, msg) ? fail(c, msg) : fmi2OK;
}

/* The model exchange's arrays: the instance's type, the array and its length. */
#define ME_ARRAY(fn, p, n, want) \
    do { ME_ONLY(fn); NEED(p, fn, "the array"); \
         if ((n) != (want)) return failf(c, "%s: %lu values, the FMU has %d", fn, \
                                         (unsigned long)(n), (int)(want)); } while (0)

fmi2Status fmi2SetContinuousStates(fmi2Component comp, const fmi2Real x[], size_t nx)
{
    Instance *c = comp;
    char msg[TREB_MSG];
    CHECK("fmi2SetContinuousStates", BIT(TREB_S_CONTINUOUS) | BIT(TREB_S_EVENT));
    ME_ARRAY("fmi2SetContinuousStates", x, nx, TREB_NX_STATES);
    return treb_model_set_states(&c->k.m, x, msg) ? fail(c, msg) : fmi2OK;
}

#define EVALUATED (RUNNING | BIT(TREB_S_TERMINATED))

fmi2Status fmi2GetDerivatives(fmi2Component comp, fmi2Real derivatives[], size_t nx)
{
    Instance *c = comp;
    char msg[TREB_MSG];
    CHECK("fmi2GetDerivatives", EVALUATED);
    ME_ARRAY("fmi2GetDerivatives", derivatives, nx, TREB_NX_STATES);
    return treb_model_derivatives(&c->k.m, derivatives, msg) ? fail(c, msg) : fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component comp, fmi2Real eventIndicators[], size_t ni)
{
    Instance *c = comp;
    char msg[TREB_MSG];
    CHECK("fmi2GetEventIndicators", EVALUATED);
    ME_ARRAY("fmi2GetEventIndicators", eventIndicators, ni, TREB_NZ);
    return treb_model_event_indicators(&c->k.m, eventIndicators, msg) ? fail(c, msg) : fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component comp, fmi2Real x[], size_t nx)
{
    Instance *c = comp;
    CHECK("fmi2GetContinuousStates", EVALUATED);
    ME_ARRAY("fmi2GetContinuousStates", x, nx, TREB_NX_STATES);
    memcpy(x, c->k.m.x, sizeof c->k.m.x);
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component comp, fmi2Real x_nominal[],
                                             size_t nx)
{
    Instance *c = comp;
    CHECK("fmi2GetNominalsOfContinuousStates", ANY);
    ME_ARRAY("fmi2GetNominalsOfContinuousStates", x_nominal, nx, TREB_NX_STATES);
    for (size_t i = 0; i < nx; i++) x_nominal[i] = 1.0;
    return fmi2OK;
}

/* FMI 2.0 functions of Trebuchet (co-simulation and model exchange), over treb_model.c.
 * Laid out as the Reference FMUs are: an instance holds the callbacks and a TrebModel; every
 * function checks the instance's state, calls the model and logs what fails. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "treb_model.h"

#ifndef TREB_GUID
#define TREB_GUID "{trebuchet}"
#endif

typedef enum { S_INSTANTIATED, S_INIT, S_STEP, S_EVENT, S_CONTINUOUS, S_TERMINATED,
               S_ERROR } State;

typedef struct {
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment env;
    char *name;
    fmi2Boolean logging;
    fmi2Type type;
    State state;
    double start_time;
    TrebModel m;
} Instance;

static void logf2(Instance *c, fmi2Status status, const char *category, const char *fmt, ...)
{
    char text[TREB_MSG + 64];
    va_list ap;
    if (!c || !c->logger) return;
    if (status == fmi2OK && !c->logging) return;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    c->logger(c->env, c->name, status, category, text);  /* formatted, as the Reference FMUs */
}

static fmi2Status fail(Instance *c, const char *msg)
{
    logf2(c, fmi2Error, "logStatusError", "%s", msg);
    return fmi2Error;
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

static int check(Instance *c, const char *fn, int allowed)
{
    if (!c) return 0;
    if (!(allowed & (1 << c->state))) {
        logf2(c, fmi2Error, "logStatusError", "%s may not be called in this state", fn);
        return 0;
    }
    return 1;
}

#define ANY ((1 << S_INSTANTIATED) | (1 << S_INIT) | (1 << S_STEP) | (1 << S_EVENT) \
             | (1 << S_CONTINUOUS) | (1 << S_TERMINATED) | (1 << S_ERROR))
#define RUNNING ((1 << S_STEP) | (1 << S_EVENT) | (1 << S_CONTINUOUS))
#define CHECK(fn, allowed) do { if (!check(c, fn, allowed)) return fmi2Error; } while (0)

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
    if (!fmuGUID || strcmp(fmuGUID, TREB_GUID) != 0) {
        functions->logger(functions->componentEnvironment, instanceName, fmi2Error,
                          "logStatusError", "GUID %s does not match this FMU's %s",
                          fmuGUID ? fmuGUID : "(null)", TREB_GUID);
        return NULL;
    }
    Instance *c = calloc(1, sizeof *c);
    if (!c) return NULL;
    const char *name = instanceName ? instanceName : "Trebuchet";
    c->name = malloc(strlen(name) + 1);
    if (!c->name) { free(c); return NULL; }
    strcpy(c->name, name);
    c->logger = functions->logger;
    c->env = functions->componentEnvironment;
    c->logging = loggingOn;
    c->type = fmuType;
    c->state = S_INSTANTIATED;
    treb_model_new(&c->m, fmuType == fmi2CoSimulation);
    return c;
}

void fmi2FreeInstance(fmi2Component comp)
{
    Instance *c = comp;
    if (!c) return;
    treb_model_free(&c->m);
    free(c->name);
    free(c);
}

fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn, size_t n,
                               const fmi2String categories[])
{
    Instance *c = comp;
    (void)n;
    (void)categories;
    CHECK("fmi2SetDebugLogging", ANY);
    c->logging = loggingOn;
    return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    Instance *c = comp;
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    CHECK("fmi2SetupExperiment", 1 << S_INSTANTIATED);
    c->start_time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component comp)
{
    Instance *c = comp;
    CHECK("fmi2EnterInitializationMode", 1 << S_INSTANTIATED);
    c->state = S_INIT;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component comp)
{
    Instance *c = comp;
    char msg[TREB_MSG];
    CHECK("fmi2ExitInitializationMode", 1 << S_INIT);
    if (treb_model_exit_init(&c->m, c->start_time, msg)) {
        c->state = S_ERROR;
        return fail(c, msg);
    }
    c->state = c->type == fmi2CoSimulation ? S_STEP : S_EVENT;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component comp)
{
    Instance *c = comp;
    CHECK("fmi2Terminate", RUNNING | (1 << S_ERROR));
    c->state = S_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component comp)
{
    Instance *c = comp;
    CHECK("fmi2Reset", ANY);
    treb_model_reset(&c->m);
    c->state = S_INSTANTIATED;
    return fmi2OK;
}

/* ------------------------------------------------------------------ values */

static int valid_vr(Instance *c, fmi2ValueReference vr, int type)
{
    int have = vr < TREB_NV ? TREB_VAR_TYPE[vr] : -1;
    if (have == TREB_ENUMERATION) have = TREB_INTEGER;  /* FMI 2: Enumerations are Integers */
    if (have != type) {
        logf2(c, fmi2Error, "logStatusError", "value reference %u is not a variable of this "
              "type", (unsigned)vr);
        return 0;
    }
    return 1;
}

static fmi2Status refresh(Instance *c)
{
    char msg[TREB_MSG];
    if (!c->m.initialized) return fmi2OK;
    return treb_model_outputs(&c->m, msg) ? fail(c, msg) : fmi2OK;
}

static fmi2Status get(Instance *c, const fmi2ValueReference vr[], size_t nvr, int type,
                      double *out)
{
    if (refresh(c) != fmi2OK) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        if (!valid_vr(c, vr[i], type)) return fmi2Error;
        out[i] = c->m.values[vr[i]];
    }
    return fmi2OK;
}

static fmi2Status set(Instance *c, const fmi2ValueReference vr[], size_t nvr, int type,
                      const double *in)
{
    for (size_t i = 0; i < nvr; i++) {
        if (!valid_vr(c, vr[i], type)) return fmi2Error;
        int causality = TREB_VAR_CAUSALITY[vr[i]];
        int ok = causality == TREB_INPUT
                 || (causality == TREB_PARAMETER
                     && (c->state == S_INSTANTIATED || c->state == S_INIT));
        if (!ok) {
            logf2(c, fmi2Error, "logStatusError", "%s cannot be set %s", TREB_VAR_NAME[vr[i]],
                  causality == TREB_OUTPUT ? "(an output)" : "after initialisation (fixed)");
            return fmi2Error;
        }
        c->m.values[vr[i]] = in[i];
    }
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[])
{
    Instance *c = comp;
    CHECK("fmi2GetReal", ANY & ~(1 << S_INSTANTIATED));
    return get(c, vr, nvr, TREB_REAL, value);
}

fmi2Status fmi2GetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[])
{
    Instance *c = comp;
    double v[TREB_NV];
    CHECK("fmi2GetInteger", ANY & ~(1 << S_INSTANTIATED));
    if (nvr > TREB_NV) return fmi2Error;
    fmi2Status s = get(c, vr, nvr, TREB_INTEGER, v);
    for (size_t i = 0; i < nvr && s == fmi2OK; i++) value[i] = (fmi2Integer)v[i];
    return s;
}

fmi2Status fmi2GetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[])
{
    Instance *c = comp;
    double v[TREB_NV];
    CHECK("fmi2GetBoolean", ANY & ~(1 << S_INSTANTIATED));
    if (nvr > TREB_NV) return fmi2Error;
    fmi2Status s = get(c, vr, nvr, TREB_BOOLEAN, v);
    for (size_t i = 0; i < nvr && s == fmi2OK; i++) value[i] = v[i] != 0.0;
    return s;
}

fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[])
{
    Instance *c = comp;
    (void)vr; (void)value;
    CHECK("fmi2GetString", ANY);
    return nvr ? fail(c, "the FMU has no String variables") : fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[])
{
    Instance *c = comp;
    CHECK("fmi2SetReal", ANY);
    return set(c, vr, nvr, TREB_REAL, value);
}

fmi2Status fmi2SetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[])
{
    Instance *c = comp;
    double v[TREB_NV];
    CHECK("fmi2SetInteger", ANY);
    if (nvr > TREB_NV) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) v[i] = value[i];
    return set(c, vr, nvr, TREB_INTEGER, v);
}

fmi2Status fmi2SetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[])
{
    Instance *c = comp;
    double v[TREB_NV];
    CHECK("fmi2SetBoolean", ANY);
    if (nvr > TREB_NV) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) v[i] = value[i] ? 1.0 : 0.0;
    return set(c, vr, nvr, TREB_BOOLEAN, v);
}

fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[])
{
    Instance *c = comp;
    (void)vr; (void)value;
    CHECK("fmi2SetString", ANY);
    return nvr ? fail(c, "the FMU has no String variables") : fmi2OK;
}

/* ------------------------------------------------------------------ FMU state */

typedef struct {
    State state;
    double start_time;
    TrebModel m;
} Saved;

fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate *FMUstate)
{
    Instance *c = comp;
    CHECK("fmi2GetFMUstate", ANY);
    Saved *s = *FMUstate ? (Saved *)*FMUstate : calloc(1, sizeof *s);
    if (!s) return fail(c, "out of memory");
    if (*FMUstate) treb_model_free(&s->m);
    if (treb_model_copy(&s->m, &c->m)) {
        if (!*FMUstate) free(s);
        return fail(c, "out of memory");
    }
    s->state = c->state;
    s->start_time = c->start_time;
    *FMUstate = s;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate FMUstate)
{
    Instance *c = comp;
    TrebModel copy;
    CHECK("fmi2SetFMUstate", ANY);
    if (!FMUstate) return fail(c, "fmi2SetFMUstate: no state");
    const Saved *s = FMUstate;
    if (s->m.cosim != c->m.cosim) return fail(c, "fmi2SetFMUstate: a state of another type");
    if (treb_model_copy(&copy, &s->m)) return fail(c, "out of memory");
    treb_model_free(&c->m);
    c->m = copy;
    c->state = s->state;
    c->start_time = s->start_time;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component comp, fmi2FMUstate *FMUstate)
{
    Instance *c = comp;
    CHECK("fmi2FreeFMUstate", ANY);
    if (FMUstate && *FMUstate) {
        Saved *s = *FMUstate;
        treb_model_free(&s->m);
        free(s);
        *FMUstate = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate FMUstate, size_t *size)
{
    Instance *c = comp;
    CHECK("fmi2SerializedFMUstateSize", ANY);
    const Saved *s = FMUstate;
    *size = sizeof(int) + sizeof(double) + treb_model_serialized_size(&s->m);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate FMUstate,
                                 fmi2Byte serializedState[], size_t size)
{
    Instance *c = comp;
    CHECK("fmi2SerializeFMUstate", ANY);
    const Saved *s = FMUstate;
    size_t need = sizeof(int) + sizeof(double) + treb_model_serialized_size(&s->m);
    if (size < need) return fail(c, "fmi2SerializeFMUstate: buffer too small");
    int state = (int)s->state;
    unsigned char *buf = (unsigned char *)serializedState;
    memcpy(buf, &state, sizeof state);
    memcpy(buf + sizeof state, &s->start_time, sizeof s->start_time);
    treb_model_serialize(&s->m, buf + sizeof state + sizeof s->start_time);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp, const fmi2Byte serializedState[],
                                   size_t size, fmi2FMUstate *FMUstate)
{
    Instance *c = comp;
    CHECK("fmi2DeSerializeFMUstate", ANY);
    const unsigned char *buf = (const unsigned char *)serializedState;
    size_t head = sizeof(int) + sizeof(double);
    if (size < head) return fail(c, "fmi2DeSerializeFMUstate: not a serialised state");
    Saved *s = calloc(1, sizeof *s);
    if (!s) return fail(c, "out of memory");
    treb_model_new(&s->m, c->m.cosim);
    int state;
    memcpy(&state, buf, sizeof state);
    memcpy(&s->start_time, buf + sizeof state, sizeof s->start_time);
    s->state = (State)state;
    if (treb_model_deserialize(&s->m, buf + head, size - head)) {
        free(s);
        return fail(c, "fmi2DeSerializeFMUstate: not a serialised state of this FMU");
    }
    if (*FMUstate) fmi2FreeFMUstate(comp, FMUstate);
    *FMUstate = s;
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp, const fmi2ValueReference vUnknown[],
                                        size_t nUnknown, const fmi2ValueReference vKnown[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[])
{
    Instance *c = comp;
    char msg[TREB_MSG];
    CHECK("fmi2GetDirectionalDerivative", (1 << S_INIT) | RUNNING | (1 << S_TERMINATED));
    if (treb_model_directional(&c->m, vUnknown, nUnknown, vKnown, nKnown, dvKnown, dvUnknown,
                               msg))
        return fail(c, msg);
    return fmi2OK;
}

/* ------------------------------------------------------------------ co-simulation */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[])
{
    (void)vr; (void)nvr; (void)order; (void)value;
    return fail(comp, "the FMU has no Real inputs");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[],
                                        fmi2Real value[])
{
    (void)vr; (void)nvr; (void)order; (void)value;
    return fail(comp, "output derivatives are not provided");
}

fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrent)
{
    Instance *c = comp;
    char msg[TREB_MSG];
    (void)noSetFMUStatePriorToCurrent;
    CHECK("fmi2DoStep", 1 << S_STEP);
    if (communicationStepSize < 0.0) return fail(c, "fmi2DoStep: negative step size");
    int r = treb_model_step(&c->m, currentCommunicationPoint, communicationStepSize, msg);
    if (r < 0) c->state = S_ERROR;
    return result(c, r, msg);
}

fmi2Status fmi2CancelStep(fmi2Component comp)
{
    return fail(comp, "fmi2DoStep never runs asynchronously: nothing to cancel");
}

fmi2Status fmi2GetStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Status *value)
{
    (void)comp; (void)s;
    *value = fmi2OK;
    return fmi2Discard;
}

fmi2Status fmi2GetRealStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Real *value)
{
    Instance *c = comp;
    if (s == fmi2LastSuccessfulTime) {
        *value = c->m.time;
        return fmi2OK;
    }
    return fmi2Discard;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Integer *value)
{
    (void)comp; (void)s; (void)value;
    return fmi2Discard;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component comp, const fmi2StatusKind s,
                                fmi2Boolean *value)
{
    (void)comp; (void)s;
    *value = fmi2False;
    return fmi2Discard;
}

fmi2Status fmi2GetStringStatus(fmi2Component comp, const fmi2StatusKind s, fmi2String *value)
{
    (void)comp; (void)s; (void)value;
    return fmi2Discard;
}

/* ------------------------------------------------------------------ model exchange */

fmi2Status fmi2EnterEventMode(fmi2Component comp)
{
    Instance *c = comp;
    CHECK("fmi2EnterEventMode", (1 << S_EVENT) | (1 << S_CONTINUOUS));
    c->state = S_EVENT;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component comp, fmi2EventInfo *info)
{
    Instance *c = comp;
    char msg[TREB_MSG];
    int changed = 0, time_defined = 0;
    double next = 0.0;
    CHECK("fmi2NewDiscreteStates", 1 << S_EVENT);
    int r = treb_model_event(&c->m, &changed, &time_defined, &next, msg);
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = r < 0;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = changed ? fmi2True : fmi2False;
    info->nextEventTimeDefined = time_defined ? fmi2True : fmi2False;
    info->nextEventTime = next;
    if (r < 0) c->state = S_ERROR;
    return result(c, r, msg);
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component comp)
{
    Instance *c = comp;
    CHECK("fmi2EnterContinuousTimeMode", 1 << S_EVENT);
    c->state = S_CONTINUOUS;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component comp,
                                       fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminate)
{
    Instance *c = comp;
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK("fmi2CompletedIntegratorStep", 1 << S_CONTINUOUS);
    *enterEventMode = fmi2False;
    *terminate = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component comp, fmi2Real time)
{
    Instance *c = comp;
    CHECK("fmi2SetTime", (1 << S_INSTANTIATED) | (1 << S_INIT) | RUNNING);
    c->m.time = time;
    c->m.outputs_valid = 0;
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component comp, const fmi2Real x[], size_t nx)
{
    Instance *c = comp;
    CHECK("fmi2SetContinuousStates", (1 << S_CONTINUOUS) | (1 << S_EVENT));
    if (nx != TREB_NX_STATES) return fail(c, "fmi2SetContinuousStates: wrong number of states");
    memcpy(c->m.x, x, sizeof c->m.x);
    c->m.outputs_valid = 0;
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component comp, fmi2Real derivatives[], size_t nx)
{
    Instance *c = comp;
    CHECK("fmi2GetDerivatives", (1 << S_INIT) | RUNNING | (1 << S_TERMINATED));
    if (nx != TREB_NX_STATES) return fail(c, "fmi2GetDerivatives: wrong number of states");
    treb_model_derivatives(&c->m, derivatives);
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component comp, fmi2Real eventIndicators[], size_t ni)
{
    Instance *c = comp;
    CHECK("fmi2GetEventIndicators", (1 << S_INIT) | RUNNING | (1 << S_TERMINATED));
    if (ni != TREB_NZ) return fail(c, "fmi2GetEventIndicators: wrong number of indicators");
    treb_model_indicators(&c->m, eventIndicators);
    return fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component comp, fmi2Real x[], size_t nx)
{
    Instance *c = comp;
    CHECK("fmi2GetContinuousStates", (1 << S_INIT) | RUNNING | (1 << S_TERMINATED));
    if (nx != TREB_NX_STATES) return fail(c, "fmi2GetContinuousStates: wrong number of states");
    memcpy(x, c->m.x, sizeof c->m.x);
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component comp, fmi2Real x_nominal[],
                                             size_t nx)
{
    Instance *c = comp;
    CHECK("fmi2GetNominalsOfContinuousStates", ANY);
    for (size_t i = 0; i < nx; i++) x_nominal[i] = 1.0;
    return fmi2OK;
}

/* The FMU abuse host: drives the FMU's FMI 2.0 and FMI 3.0 libraries (co-simulation and model
 * exchange) through hostile call sequences read from a corpus, each case in a child process,
 * and counts what went wrong. Used by tests/test_fmu_abuse.py (a small sample) and
 * bench/fmu_abuse.py (the whole corpus, built with -fsanitize=address,undefined); the corpus is
 * written by trebuchet.fmu.abuse_corpus.
 *
 *   fmu_abuse LIB2.so LIB3.so TOKEN CORPUS TIMEOUT_S
 *
 * CORPUS holds cases, each a line "case NAME" and then one call (or host action) a line:
 *
 *   fmi 2|3                    the library the case drives (default 2)
 *   reals VR...                the Real value references that "getr" reads (once, any case)
 *   dry VR VALUE VR...         while the Enumeration VR is VALUE, the Reals VR... are NaN by
 *                              definition (a dry fire has no projectile): not counted
 *   inst KIND [guid=bad|null|empty] [cb=null] [log=null] [name=null]   instantiate; KIND cs, me,
 *                              a number (FMI 2 fmuType), se (FMI 3 scheduled), csev (event mode)
 *   use 0|1                    which of two instances the calls go to
 *   setr VR X / seti VR N / setb VR B        set a Real, Integer/Enumeration (FMI 3: Int64),
 *                              Boolean
 *   getr | geti VR | getb VR   read (getr: every Real of "reals")
 *   setup T0                   FMI 2 fmi2SetupExperiment; FMI 3: the start time of "init"
 *   init | exit | term | reset | free         the instance's life cycle
 *   step T H                   DoStep at T ("cur": the host's time) by H, then getr
 *   run N H                    N steps of H from the host's time, each followed by getr
 *   time T | setx X0..X5 [N] | getx | der | ind | event | disc | cont | done   model exchange
 *   merun N H                  N explicit Euler steps of model exchange with event handling
 *   dir KNOWN FIRST N          directional derivative of outputs FIRST..FIRST+N-1 by KNOWN
 *   status                     every fmi2Get*Status (FMI 2)
 *   gst S | sst S | fst S      get / set / free the FMU state in slot S (0-3)
 *   sstwild | sstself          set a state that is no state: garbage memory, the instance
 *   ser S B | des B S          serialise slot S into buffer B (0-3), deserialise B into S
 *   mut B OP ...               corrupt buffer B: flip AT BIT, set AT BYTE, trunc AT,
 *                              grow N, rand AT LEN SEED, fill BYTE, f64 AT X, i32 AT N,
 *                              u64 AT N, fix (recompute the checksum), fixsize (size field
 *                              and checksum), copy B2 (B becomes a copy of B2); AT is a
 *                              fraction of the buffer's length, or @BYTES from its start
 *   null FN MASK               call FN with the pointer arguments of MASK's bits set to NULL
 *   nullc FN                   call FN with a NULL instance
 *
 * Numbers go through strtod ("nan", "inf", "1e308", "5e-324" included). For each case the
 * host prints one line:
 *
 *   CASE NAME result=ok|crash|hang|sanitizer calls=N nan_ok=N after_error=N silent_error=N ms=T
 *
 * nan_ok counts calls that returned OK or Warning with a non-finite value; after_error the
 * calls that returned OK where FMI requires the instance to refuse (after an error, or after
 * a step that stopped the simulation); silent_error the errors returned without a logged
 * message. A crash is a fatal signal (or AddressSanitizer's SEGV), a hang a case still
 * running after TIMEOUT_S, a sanitizer report any other AddressSanitizer, LeakSanitizer or
 * UndefinedBehaviorSanitizer report. The last line sums every case ("TOTAL ..."). Exit 0 once
 * the corpus ran (whatever it found), 2 on a usage or loading problem. With ABUSE_VERBOSE
 * set in the environment, every message the FMU logs is printed too ("  LOG status text"). */
#define _POSIX_C_SOURCE 200809L
#define _DEFAULT_SOURCE
#include <dlfcn.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "fmi2Functions.h"
#include "fmi3Functions.h"

#define NX 8  /* the FMU's continuous states: theta, psi, phi, their rates, the two lost
                energies of friction (fmu/model_description.py STATES) */

#define NSLOT 4
#define MAXARG 16
#define MAXREAL 256

/* ------------------------------------------------------------------ the libraries */

#define F2_LIST(X) X(Instantiate) X(FreeInstance) X(SetupExperiment) \
    X(EnterInitializationMode) X(ExitInitializationMode) X(Terminate) X(Reset) X(SetDebugLogging) \
    X(GetReal) X(GetInteger) X(GetBoolean) X(GetString) X(SetReal) X(SetInteger) X(SetBoolean) \
    X(SetString) X(GetFMUstate) X(SetFMUstate) X(FreeFMUstate) X(SerializedFMUstateSize) \
    X(SerializeFMUstate) X(DeSerializeFMUstate) X(GetDirectionalDerivative) \
    X(SetRealInputDerivatives) X(GetRealOutputDerivatives) X(DoStep) X(CancelStep) \
    X(GetStatus) X(GetRealStatus) X(GetIntegerStatus) X(GetBooleanStatus) X(GetStringStatus) \
    X(EnterEventMode) X(NewDiscreteStates) X(EnterContinuousTimeMode) \
    X(CompletedIntegratorStep) X(SetTime) X(SetContinuousStates) X(GetDerivatives) \
    X(GetEventIndicators) X(GetContinuousStates) X(GetNominalsOfContinuousStates)
#define F3_LIST(X) X(InstantiateModelExchange) X(InstantiateCoSimulation) \
    X(InstantiateScheduledExecution) X(FreeInstance) X(EnterInitializationMode) \
    X(ExitInitializationMode) X(EnterEventMode) X(Terminate) X(Reset) X(SetDebugLogging) \
    X(GetFloat64) X(GetInt32) X(GetInt64) X(GetBoolean) X(SetFloat64) X(SetInt64) \
    X(SetBoolean) X(GetBinary) X(GetFMUState) X(SetFMUState) X(FreeFMUState) \
    X(SerializedFMUStateSize) X(SerializeFMUState) X(DeserializeFMUState) \
    X(GetDirectionalDerivative) X(UpdateDiscreteStates) X(EnterContinuousTimeMode) \
    X(CompletedIntegratorStep) X(SetTime) X(SetContinuousStates) \
    X(GetContinuousStateDerivatives) X(GetEventIndicators) X(GetContinuousStates) \
    X(GetNominalsOfContinuousStates) X(GetNumberOfEventIndicators) \
    X(GetNumberOfContinuousStates) X(DoStep) X(EnterStepMode) X(GetOutputDerivatives)

#define F2_MEMBER(n) fmi2##n##TYPE *n;
#define F3_MEMBER(n) fmi3##n##TYPE *n;
static struct { F2_LIST(F2_MEMBER) } F2;
static struct { F3_LIST(F3_MEMBER) } F3;

static int load(const char *path, int fmi)
{
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "dlopen %s: %s\n", path, dlerror());
        return -1;
    }
#define F2_LOAD(n) if (!(*(void **)&F2.n = dlsym(lib, "fmi2" #n))) goto missing;
#define F3_LOAD(n) if (!(*(void **)&F3.n = dlsym(lib, "fmi3" #n))) goto missing;
    if (fmi == 2) { F2_LIST(F2_LOAD) } else { F3_LIST(F3_LOAD) }
    return 0;
missing:
    fprintf(stderr, "%s: a function of FMI %d is missing\n", path, fmi);
    return -1;
}

/* ------------------------------------------------------------------ what a case found */

typedef struct {
    long calls, nan_ok, after_error, silent_error;
    char last[64];
} Counters;

static Counters *K;  /* shared with the parent: counts survive a crash */
static long n_logs;
static int verbose;  /* ABUSE_VERBOSE set: every message the FMU logs, on stdout */

static void logger2(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                    fmi2String category, fmi2String message, ...)
{
    (void)env; (void)name; (void)category;
    n_logs++;
    if (verbose && message) {
        va_list ap;
        va_start(ap, message);
        printf("  LOG %d ", (int)status);
        vprintf(message, ap);
        printf("\n");
        va_end(ap);
    }
}

static void logger3(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                    fmi3String message)
{
    (void)env; (void)category;
    n_logs++;
    if (verbose && message) printf("  LOG %d %s\n", (int)status, message);
}

static fmi2CallbackFunctions CB = {logger2, calloc, free, NULL, NULL};
static fmi2CallbackFunctions CB_NOLOG = {NULL, calloc, free, NULL, NULL};

/* ------------------------------------------------------------------ a case's world */

typedef struct {
    int fmi;
    void *c[2];
    int cur;
    int logged[2];          /* the instance has a logger */
    int refused[2];         /* an error (or a stop) happened: progress must be refused */
    int cosim[2];
    void *slot[NSLOT];
    int slot_of[NSLOT];     /* the instance that made the state */
    unsigned char *buf[NSLOT];
    size_t len[NSLOT];
    double t, t0;           /* the host's time, the start time */
    double x[NX];
    double z[3];
} World;

static fmi2ValueReference REALS[MAXREAL];
static size_t N_REALS;
static const char *TOKEN;
/* "dry VR VALUE VR...": while the Enumeration VR is VALUE (a dry fire), the Reals VR... are
 * NaN by definition (no projectile): not counted as NaN with OK. */
static fmi2ValueReference DRY_VR, DRY_NAN[16];
static long DRY_VALUE = -1;
static size_t N_DRY_NAN;

static int finite_all(const double *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i])) return 0;
    return 1;
}

/* Count a call: its status, whether it failed silently, whether it returned a non-finite
 * value with OK, whether it went on where it had to refuse. */
static int note(World *w, const char *name, int status, long logs_before, const double *v,
                size_t nv, int progress)
{
    int i = w->cur;
    K->calls++;
    snprintf(K->last, sizeof K->last, "%s", name);
    if (status >= 3 && w->c[i] && w->logged[i] && n_logs == logs_before) K->silent_error++;
    if (status <= 1 && v && !finite_all(v, nv)) K->nan_ok++;
    if (status <= 1 && progress && w->refused[i]) K->after_error++;
    if (status >= 3 && w->c[i]) w->refused[i] = 1;
    return status;
}

#define CALL(w, name, v, nv, progress, expr) \
    do { long lb_ = n_logs; int s_ = (int)(expr); st = note(w, name, s_, lb_, v, nv, progress); \
         (void)st; } while (0)

static double num(const char *s) { return strtod(s, NULL); }

/* ------------------------------------------------------------------ life cycle */

static void op_inst(World *w, int argc, char **argv)
{
    const char *guid = TOKEN, *name = "abuse";
    int cb_null = 0, log_null = 0, i = w->cur;
    for (int a = 2; a < argc; a++) {
        if (!strcmp(argv[a], "guid=bad")) guid = "{00000000-0000-0000-0000-000000000000}";
        else if (!strcmp(argv[a], "guid=null")) guid = NULL;
        else if (!strcmp(argv[a], "guid=empty")) guid = "";
        else if (!strcmp(argv[a], "cb=null")) cb_null = 1;
        else if (!strcmp(argv[a], "log=null")) log_null = 1;
        else if (!strcmp(argv[a], "name=null")) name = NULL;
    }
    const char *kind = argc > 1 ? argv[1] : "cs";
    void *c = NULL;
    long lb = n_logs;
    if (w->fmi == 2) {
        int type = !strcmp(kind, "cs") ? fmi2CoSimulation : !strcmp(kind, "me")
                   ? fmi2ModelExchange : atoi(kind);
        c = F2.Instantiate(name, (fmi2Type)type, guid, "file:///nowhere", cb_null ? NULL
                           : log_null ? &CB_NOLOG : &CB, fmi2False, fmi2True);
        w->cosim[i] = type == fmi2CoSimulation;
    } else if (!strcmp(kind, "me")) {
        c = F3.InstantiateModelExchange(name, guid, NULL, fmi3False, fmi3True, NULL,
                                        log_null ? NULL : logger3);
    } else if (!strcmp(kind, "se")) {
        c = F3.InstantiateScheduledExecution(name, guid, NULL, fmi3False, fmi3True, NULL,
                                             log_null ? NULL : logger3, NULL, NULL, NULL);
    } else {
        c = F3.InstantiateCoSimulation(name, guid, NULL, fmi3False, fmi3True,
                                       !strcmp(kind, "csev"), fmi3False, NULL, 0, NULL,
                                       log_null ? NULL : logger3, NULL);
        w->cosim[i] = 1;
    }
    K->calls++;
    snprintf(K->last, sizeof K->last, "instantiate");
    if (!c && !cb_null && !log_null && n_logs == lb) K->silent_error++;
    if (w->c[i]) {  /* the old instance is freed first */
        if (w->fmi == 2) F2.FreeInstance(w->c[i]);
        else F3.FreeInstance(w->c[i]);
    }
    w->c[i] = c;
    w->logged[i] = !cb_null && !log_null;
    w->refused[i] = 0;
    w->t = w->t0 = 0.0;
}

static void free_instance(World *w, int i)
{
    if (!w->c[i]) return;
    for (int s = 0; s < NSLOT; s++) {  /* the host frees its states before the instance */
        if (w->slot[s] && w->slot_of[s] == i) {
            if (w->fmi == 2) F2.FreeFMUstate(w->c[i], &w->slot[s]);
            else F3.FreeFMUState(w->c[i], &w->slot[s]);
            w->slot[s] = NULL;
        }
    }
    if (w->fmi == 2) F2.FreeInstance(w->c[i]);
    else F3.FreeInstance(w->c[i]);
    K->calls++;
    w->c[i] = NULL;
}

static void op_cycle(World *w, const char *op, int argc, char **argv)
{
    void *c = w->c[w->cur];
    int st = 0, f2 = w->fmi == 2;
    if (!strcmp(op, "setup")) {
        w->t0 = argc > 1 ? num(argv[1]) : 0.0;
        if (f2) CALL(w, "setup", NULL, 0, 1,
                     F2.SetupExperiment(c, fmi2False, 0.0, w->t0, fmi2False, 0.0));
    } else if (!strcmp(op, "init")) {
        if (f2) CALL(w, "init", NULL, 0, 1, F2.EnterInitializationMode(c));
        else CALL(w, "init", NULL, 0, 1,
                  F3.EnterInitializationMode(c, fmi3False, 0.0, w->t0, fmi3False, 0.0));
    } else if (!strcmp(op, "exit")) {
        if (f2) CALL(w, "exit", NULL, 0, 1, F2.ExitInitializationMode(c));
        else CALL(w, "exit", NULL, 0, 1, F3.ExitInitializationMode(c));
        w->t = w->t0;
    } else if (!strcmp(op, "term")) {
        if (f2) CALL(w, "term", NULL, 0, 0, F2.Terminate(c));
        else CALL(w, "term", NULL, 0, 0, F3.Terminate(c));
    } else if (!strcmp(op, "reset")) {
        if (f2) CALL(w, "reset", NULL, 0, 0, F2.Reset(c));
        else CALL(w, "reset", NULL, 0, 0, F3.Reset(c));
        if (st <= 1) w->refused[w->cur] = 0;
    } else if (!strcmp(op, "free")) {
        free_instance(w, w->cur);
    }
}

/* ------------------------------------------------------------------ values */

/* The FMU's own value of the dry-fire Enumeration says whether the dry outputs may be NaN. */
static int dry_fire(World *w)
{
    void *c = w->c[w->cur];
    if (DRY_VALUE < 0) return 0;
    if (w->fmi == 2) {
        fmi2Integer v = 0;
        return F2.GetInteger(c, &DRY_VR, 1, &v) <= fmi2Warning && v == DRY_VALUE;
    }
    fmi3Int64 v = 0;
    return F3.GetInt64(c, &DRY_VR, 1, &v, 1) <= fmi3Warning && v == DRY_VALUE;
}

static void op_getr(World *w)
{
    double v[MAXREAL];
    int st;
    long before = K->nan_ok;
    if (w->fmi == 2) CALL(w, "getr", v, N_REALS, 0, F2.GetReal(w->c[w->cur], REALS, N_REALS, v));
    else CALL(w, "getr", v, N_REALS, 0,
              F3.GetFloat64(w->c[w->cur], REALS, N_REALS, v, N_REALS));
    if (K->nan_ok > before && dry_fire(w)) {  /* NaN allowed where there is no projectile */
        for (size_t i = 0; i < N_REALS; i++)
            for (size_t j = 0; j < N_DRY_NAN; j++)
                if (REALS[i] == DRY_NAN[j]) v[i] = 0.0;
        if (finite_all(v, N_REALS)) K->nan_ok = before;
    }
}

static void op_values(World *w, const char *op, int argc, char **argv)
{
    void *c = w->c[w->cur];
    int st;
    fmi2ValueReference vr = argc > 1 ? (fmi2ValueReference)strtoul(argv[1], NULL, 10) : 0;
    const char *arg = argc > 2 ? argv[2] : "0";
    if (!strcmp(op, "setr")) {
        double x = num(arg);
        if (w->fmi == 2) CALL(w, "setr", NULL, 0, 1, F2.SetReal(c, &vr, 1, &x));
        else CALL(w, "setr", NULL, 0, 1, F3.SetFloat64(c, &vr, 1, &x, 1));
    } else if (!strcmp(op, "seti")) {
        long long n = strtoll(arg, NULL, 10);
        fmi2Integer i2 = (fmi2Integer)n;
        fmi3Int64 i3 = n;
        if (w->fmi == 2) CALL(w, "seti", NULL, 0, 1, F2.SetInteger(c, &vr, 1, &i2));
        else CALL(w, "seti", NULL, 0, 1, F3.SetInt64(c, &vr, 1, &i3, 1));
    } else if (!strcmp(op, "setb")) {
        int b = atoi(arg);
        fmi2Boolean b2 = b;
        fmi3Boolean b3 = b != 0;
        if (w->fmi == 2) CALL(w, "setb", NULL, 0, 1, F2.SetBoolean(c, &vr, 1, &b2));
        else CALL(w, "setb", NULL, 0, 1, F3.SetBoolean(c, &vr, 1, &b3, 1));
    } else if (!strcmp(op, "geti")) {
        fmi2Integer i2 = 0;
        fmi3Int32 i3 = 0;
        if (w->fmi == 2) CALL(w, "geti", NULL, 0, 0, F2.GetInteger(c, &vr, 1, &i2));
        else CALL(w, "geti", NULL, 0, 0, F3.GetInt32(c, &vr, 1, &i3, 1));
    } else if (!strcmp(op, "getb")) {
        fmi2Boolean b2 = 0;
        fmi3Boolean b3 = 0;
        if (w->fmi == 2) CALL(w, "getb", NULL, 0, 0, F2.GetBoolean(c, &vr, 1, &b2));
        else CALL(w, "getb", NULL, 0, 0, F3.GetBoolean(c, &vr, 1, &b3, 1));
    } else {
        op_getr(w);
    }
}

/* ------------------------------------------------------------------ co-simulation */

static int do_step(World *w, double t, double h)
{
    void *c = w->c[w->cur];
    int st;
    if (w->fmi == 2) {
        CALL(w, "step", NULL, 0, 1, F2.DoStep(c, t, h, fmi2True));
        if (st == fmi2Discard) w->refused[w->cur] = 1;  /* stopped: no further step */
    } else {
        fmi3Boolean event = 0, terminate = 0, early = 0;
        double last = NAN;
        CALL(w, "step", &last, 1, 1,
             F3.DoStep(c, t, h, fmi3True, &event, &terminate, &early, &last));
        if (terminate || st == fmi3Discard) w->refused[w->cur] = 1;
    }
    if (st <= 1) w->t = t + h;
    op_getr(w);
    return st;
}

static void op_step(World *w, int argc, char **argv)
{
    double t = argc > 1 && strcmp(argv[1], "cur") ? num(argv[1]) : w->t;
    do_step(w, t, argc > 2 ? num(argv[2]) : 1e-3);
}

static void op_run(World *w, int argc, char **argv)
{
    long n = argc > 1 ? atol(argv[1]) : 10;
    double h = argc > 2 ? num(argv[2]) : 1e-3;
    for (long k = 0; k < n; k++)
        if (do_step(w, w->t, h) > 1) break;
}

static void op_status(World *w)
{
    void *c = w->c[w->cur];
    int st;
    fmi2Status s;
    fmi2Real r = 0.0;
    fmi2Integer i;
    fmi2Boolean b;
    fmi2String str;
    if (w->fmi != 2) return;
    CALL(w, "status", NULL, 0, 0, F2.GetStatus(c, fmi2DoStepStatus, &s));
    CALL(w, "rstatus", &r, 1, 0, F2.GetRealStatus(c, fmi2LastSuccessfulTime, &r));
    CALL(w, "istatus", NULL, 0, 0, F2.GetIntegerStatus(c, fmi2LastSuccessfulTime, &i));
    CALL(w, "bstatus", NULL, 0, 0, F2.GetBooleanStatus(c, fmi2Terminated, &b));
    CALL(w, "sstatus", NULL, 0, 0, F2.GetStringStatus(c, fmi2PendingStatus, &str));
}

/* ------------------------------------------------------------------ model exchange */

static int me_call(World *w, const char *op, int argc, char **argv)
{
    void *c = w->c[w->cur];
    int st = 0, f2 = w->fmi == 2;
    double v[NX];
    if (!strcmp(op, "time")) {
        double t = argc > 1 ? num(argv[1]) : w->t;
        if (f2) CALL(w, "time", NULL, 0, 1, F2.SetTime(c, t));
        else CALL(w, "time", NULL, 0, 1, F3.SetTime(c, t));
        if (st <= 1) w->t = t;
    } else if (!strcmp(op, "setx")) {
        size_t n = NX;
        for (int k = 0; k < 6; k++)  /* the corpus gives the angles and rates, then a count */
            w->x[k] = argc > 1 + k ? num(argv[1 + k]) : w->x[k];
        if (argc > 7) n = (size_t)atol(argv[7]);
        double x[64] = {0};
        memcpy(x, w->x, sizeof w->x);
        if (n > 64) n = 64;
        if (f2) CALL(w, "setx", NULL, 0, 1, F2.SetContinuousStates(c, x, n));
        else CALL(w, "setx", NULL, 0, 1, F3.SetContinuousStates(c, x, n));
    } else if (!strcmp(op, "getx")) {
        if (f2) CALL(w, "getx", v, NX, 0, F2.GetContinuousStates(c, v, NX));
        else CALL(w, "getx", v, NX, 0, F3.GetContinuousStates(c, v, NX));
        if (st <= 1) memcpy(w->x, v, sizeof v);
    } else if (!strcmp(op, "der")) {
        if (f2) CALL(w, "der", v, NX, 0, F2.GetDerivatives(c, v, NX));
        else CALL(w, "der", v, NX, 0, F3.GetContinuousStateDerivatives(c, v, NX));
    } else if (!strcmp(op, "ind")) {
        if (f2) CALL(w, "ind", v, 3, 0, F2.GetEventIndicators(c, v, 3));
        else CALL(w, "ind", v, 3, 0, F3.GetEventIndicators(c, v, 3));
    } else if (!strcmp(op, "event")) {
        if (f2) CALL(w, "event", NULL, 0, 1, F2.EnterEventMode(c));
        else CALL(w, "event", NULL, 0, 1, F3.EnterEventMode(c));
    } else if (!strcmp(op, "disc")) {
        if (f2) {
            fmi2EventInfo info;
            CALL(w, "disc", NULL, 0, 1, F2.NewDiscreteStates(c, &info));
            if (st <= 1 && info.terminateSimulation) w->refused[w->cur] = 1;
        } else {
            fmi3Boolean a, term, b, d, e;
            double next;
            CALL(w, "disc", NULL, 0, 1, F3.UpdateDiscreteStates(c, &a, &term, &b, &d, &e, &next));
            if (st <= 1 && term) w->refused[w->cur] = 1;
        }
    } else if (!strcmp(op, "cont")) {
        if (f2) CALL(w, "cont", NULL, 0, 1, F2.EnterContinuousTimeMode(c));
        else CALL(w, "cont", NULL, 0, 1, F3.EnterContinuousTimeMode(c));
    } else if (!strcmp(op, "done")) {
        if (f2) {
            fmi2Boolean enter = 0, term = 0;
            CALL(w, "done", NULL, 0, 1, F2.CompletedIntegratorStep(c, fmi2True, &enter, &term));
            if (st <= 1 && term) w->refused[w->cur] = 1;
        } else {
            fmi3Boolean enter = 0, term = 0;
            CALL(w, "done", NULL, 0, 1, F3.CompletedIntegratorStep(c, fmi3True, &enter, &term));
            if (st <= 1 && term) w->refused[w->cur] = 1;
        }
    } else if (!strcmp(op, "dir")) {  /* dir KNOWN FIRST N: d(outputs FIRST..)/d(KNOWN) */
        fmi2ValueReference known = argc > 1 ? (fmi2ValueReference)atol(argv[1]) : 0;
        fmi2ValueReference first = argc > 2 ? (fmi2ValueReference)atol(argv[2]) : 0;
        size_t n = argc > 3 ? (size_t)atol(argv[3]) : 1;
        fmi2ValueReference unknown[MAXREAL];
        double seed = 1.0, sens[MAXREAL];
        if (n > MAXREAL) n = MAXREAL;
        for (size_t k = 0; k < n; k++) unknown[k] = first + (fmi2ValueReference)k;
        if (f2) CALL(w, "dir", sens, n, 0,
                     F2.GetDirectionalDerivative(c, unknown, n, &known, 1, &seed, sens));
        else CALL(w, "dir", sens, n, 0,
                  F3.GetDirectionalDerivative(c, unknown, n, &known, 1, &seed, 1, sens, n));
    }
    return st;
}

/* N explicit Euler steps of h, the host handling state events as FMI says. */
static void op_merun(World *w, int argc, char **argv)
{
    long n = argc > 1 ? atol(argv[1]) : 10;
    double h = argc > 2 ? num(argv[2]) : 1e-3;
    char *none[1] = {NULL};
    double dx[NX], z[3];
    if (me_call(w, "cont", 0, none) > 1) return;
    if (me_call(w, "getx", 0, none) > 1) return;
    for (long k = 0; k < n; k++) {
        void *c = w->c[w->cur];
        int st;
        if (w->fmi == 2) CALL(w, "der", dx, NX, 0, F2.GetDerivatives(c, dx, NX));
        else CALL(w, "der", dx, NX, 0, F3.GetContinuousStateDerivatives(c, dx, NX));
        if (st > 1) return;
        char tb[64];
        snprintf(tb, sizeof tb, "%.17g", w->t + h);
        char *targs[2] = {"time", tb};
        if (me_call(w, "time", 2, targs) > 1) return;
        for (int i = 0; i < NX; i++) w->x[i] += h * dx[i];
        char *xargs[1] = {"setx"};
        if (me_call(w, "setx", 1, xargs) > 1) return;
        if (me_call(w, "done", 0, none) > 1) return;
        if (w->fmi == 2) CALL(w, "ind", z, 3, 0, F2.GetEventIndicators(c, z, 3));
        else CALL(w, "ind", z, 3, 0, F3.GetEventIndicators(c, z, 3));
        if (st > 1) return;
        int crossed = 0;
        for (int i = 0; i < 3; i++) crossed |= (z[i] > 0) != (w->z[i] > 0);
        memcpy(w->z, z, sizeof z);
        if (crossed) {
            if (me_call(w, "event", 0, none) > 1 || me_call(w, "disc", 0, none) > 1
                || me_call(w, "cont", 0, none) > 1 || me_call(w, "getx", 0, none) > 1)
                return;
        }
        op_getr(w);
    }
}

/* ------------------------------------------------------------------ FMU states */

static int slot_arg(int argc, char **argv, int a)
{
    int s = argc > a ? atoi(argv[a]) : 0;
    return s < 0 || s >= NSLOT ? 0 : s;
}

static void op_state(World *w, const char *op, int argc, char **argv)
{
    void *c = w->c[w->cur];
    int st, f2 = w->fmi == 2, s = slot_arg(argc, argv, 1);
    if (!strcmp(op, "gst")) {
        if (f2) CALL(w, "gst", NULL, 0, 0, F2.GetFMUstate(c, &w->slot[s]));
        else CALL(w, "gst", NULL, 0, 0, F3.GetFMUState(c, &w->slot[s]));
        w->slot_of[s] = w->cur;
    } else if (!strcmp(op, "sst")) {
        if (f2) CALL(w, "sst", NULL, 0, 0, F2.SetFMUstate(c, w->slot[s]));
        else CALL(w, "sst", NULL, 0, 0, F3.SetFMUState(c, w->slot[s]));
        if (st <= 1) w->refused[w->cur] = 0;
    } else if (!strcmp(op, "fst")) {
        if (f2) CALL(w, "fst", NULL, 0, 0, F2.FreeFMUstate(c, &w->slot[s]));
        else CALL(w, "fst", NULL, 0, 0, F3.FreeFMUState(c, &w->slot[s]));
    } else if (!strcmp(op, "sstwild") || !strcmp(op, "sstself")) {
        static unsigned char junk[4096];
        for (size_t k = 0; k < sizeof junk; k++) junk[k] = (unsigned char)(k * 37 + 11);
        void *p = !strcmp(op, "sstwild") ? (void *)junk : c;
        if (f2) CALL(w, op, NULL, 0, 1, F2.SetFMUstate(c, p));
        else CALL(w, op, NULL, 0, 1, F3.SetFMUState(c, p));
    } else if (!strcmp(op, "ser")) {
        int b = slot_arg(argc, argv, 2);
        size_t size = 0;
        if (f2) CALL(w, "sersize", NULL, 0, 0, F2.SerializedFMUstateSize(c, w->slot[s], &size));
        else CALL(w, "sersize", NULL, 0, 0, F3.SerializedFMUStateSize(c, w->slot[s], &size));
        if (st > 1 || size == 0 || size > ((size_t)1 << 31)) return;
        free(w->buf[b]);
        w->buf[b] = malloc(size);
        w->len[b] = size;
        if (!w->buf[b]) return;
        if (f2) CALL(w, "ser", NULL, 0, 0,
                     F2.SerializeFMUstate(c, w->slot[s], (fmi2Byte *)w->buf[b], size));
        else CALL(w, "ser", NULL, 0, 0, F3.SerializeFMUState(c, w->slot[s], w->buf[b], size));
    } else if (!strcmp(op, "des")) {
        int b = slot_arg(argc, argv, 1), into = slot_arg(argc, argv, 2);
        if (!w->buf[b]) return;
        if (w->slot[into] && w->slot_of[into] != w->cur) return;  /* another's state */
        if (f2) CALL(w, "des", NULL, 0, 0, F2.DeSerializeFMUstate(
                         c, (const fmi2Byte *)w->buf[b], w->len[b], &w->slot[into]));
        else CALL(w, "des", NULL, 0, 0,
                  F3.DeserializeFMUState(c, w->buf[b], w->len[b], &w->slot[into]));
        w->slot_of[into] = w->cur;
    }
}

/* ------------------------------------------------------------------ corrupted bytes */

static uint64_t rng_state;
static uint64_t rng(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return rng_state;
}

static uint64_t fnv1a(const unsigned char *p, size_t n, size_t skip_at)
{
    uint64_t h = 1469598103934665603ULL;
    for (size_t i = 0; i < n; i++) {
        unsigned char b = (i >= skip_at && i < skip_at + 8) ? 0 : p[i];
        h = (h ^ b) * 1099511628211ULL;
    }
    return h;
}

/* The state format's size field (at 32) and checksum (at 40): see treb_model.h. */
#define SIZE_AT 32
#define SUM_AT 40

static void resize(World *w, int b, size_t n)
{
    unsigned char *p = malloc(n ? n : 1);
    if (!p) return;
    size_t keep = n < w->len[b] ? n : w->len[b];
    memcpy(p, w->buf[b], keep);
    for (size_t i = keep; i < n; i++) p[i] = (unsigned char)rng();
    free(w->buf[b]);
    w->buf[b] = p;
    w->len[b] = n;
}

static void op_mut(World *w, int argc, char **argv)
{
    int b = slot_arg(argc, argv, 1);
    const char *what = argc > 2 ? argv[2] : "";
    if (!strcmp(what, "copy")) {
        int from = slot_arg(argc, argv, 3);
        if (!w->buf[from] || from == b) return;
        free(w->buf[b]);
        w->buf[b] = malloc(w->len[from]);
        if (w->buf[b]) memcpy(w->buf[b], w->buf[from], w->len[from]);
        w->len[b] = w->buf[b] ? w->len[from] : 0;
        return;
    }
    if (!w->buf[b] || w->len[b] == 0) return;
    size_t n = w->len[b], at;
    if (argc > 3 && argv[3][0] == '@') {  /* an absolute offset */
        at = (size_t)strtoul(argv[3] + 1, NULL, 10);
        if (at > n - 1) at = n - 1;
    } else {
        double frac = argc > 3 ? num(argv[3]) : 0.0;
        at = (size_t)(fmin(fmax(frac, 0.0), 1.0) * (double)(n - 1));
    }
    unsigned char *p = w->buf[b];
    if (!strcmp(what, "flip")) {
        p[at] ^= (unsigned char)(1u << (atoi(argc > 4 ? argv[4] : "0") & 7));
    } else if (!strcmp(what, "set")) {
        p[at] = (unsigned char)atoi(argc > 4 ? argv[4] : "0");
    } else if (!strcmp(what, "fill")) {
        memset(p, atoi(argc > 3 ? argv[3] : "0"), n);
    } else if (!strcmp(what, "trunc")) {
        resize(w, b, at);
    } else if (!strcmp(what, "grow")) {
        resize(w, b, n + (size_t)atol(argc > 3 ? argv[3] : "8"));
    } else if (!strcmp(what, "rand")) {
        size_t len = (size_t)atol(argc > 4 ? argv[4] : "8");
        rng_state = (uint64_t)strtoull(argc > 5 ? argv[5] : "1", NULL, 10) | 1u;
        for (size_t i = at; i < n && i < at + len; i++) p[i] = (unsigned char)rng();
    } else if (!strcmp(what, "f64") || !strcmp(what, "i32") || !strcmp(what, "u64")) {
        size_t width = what[0] == 'i' ? 4 : 8;
        at -= at % width;
        if (at + width > n) return;
        if (what[0] == 'f') { double x = num(argc > 4 ? argv[4] : "0"); memcpy(p + at, &x, 8); }
        else if (what[0] == 'i') { int32_t x = (int32_t)strtol(argc > 4 ? argv[4] : "0", NULL, 10);
                                   memcpy(p + at, &x, 4); }
        else { uint64_t x = strtoull(argc > 4 ? argv[4] : "0", NULL, 10); memcpy(p + at, &x, 8); }
    } else if (!strcmp(what, "fix") || !strcmp(what, "fixsize")) {
        if (n < SUM_AT + 8) return;
        if (what[3] == 's') { uint64_t len = n; memcpy(p + SIZE_AT, &len, 8); }
        uint64_t sum = fnv1a(p, n, SUM_AT);
        memcpy(p + SUM_AT, &sum, 8);
    }
}

/* ------------------------------------------------------------------ NULL pointers */

#define NP(k, p) (((mask >> (k)) & 1u) ? NULL : (p))

static void null2(World *w, const char *fn, unsigned mask, void *c)
{
    fmi2ValueReference vr[1] = {0};
    double r[8] = {0};
    fmi2Integer i[8] = {0};
    fmi2Boolean b[8] = {0};
    fmi2String s[1] = {"x"};
    size_t size = 0;
    fmi2EventInfo info;
    int st = 0;
    void *state = w->slot[0] && w->slot_of[0] == w->cur ? w->slot[0] : NULL;
    if (!strcmp(fn, "getr")) CALL(w, fn, NULL, 0, 0, F2.GetReal(c, NP(0, vr), 1, NP(1, r)));
    else if (!strcmp(fn, "geti")) CALL(w, fn, NULL, 0, 0, F2.GetInteger(c, NP(0, vr), 1, NP(1, i)));
    else if (!strcmp(fn, "getb")) CALL(w, fn, NULL, 0, 0, F2.GetBoolean(c, NP(0, vr), 1, NP(1, b)));
    else if (!strcmp(fn, "gets")) CALL(w, fn, NULL, 0, 0, F2.GetString(c, NP(0, vr), 1, NP(1, s)));
    else if (!strcmp(fn, "setr")) CALL(w, fn, NULL, 0, 1, F2.SetReal(c, NP(0, vr), 1, NP(1, r)));
    else if (!strcmp(fn, "seti")) CALL(w, fn, NULL, 0, 1, F2.SetInteger(c, NP(0, vr), 1, NP(1, i)));
    else if (!strcmp(fn, "setb")) CALL(w, fn, NULL, 0, 1, F2.SetBoolean(c, NP(0, vr), 1, NP(1, b)));
    else if (!strcmp(fn, "sets")) CALL(w, fn, NULL, 0, 1, F2.SetString(c, NP(0, vr), 1, NP(1, s)));
    else if (!strcmp(fn, "gst")) CALL(w, fn, NULL, 0, 0, F2.GetFMUstate(c, NULL));
    else if (!strcmp(fn, "fst")) CALL(w, fn, NULL, 0, 0, F2.FreeFMUstate(c, NULL));
    else if (!strcmp(fn, "sst")) CALL(w, fn, NULL, 0, 1, F2.SetFMUstate(c, NULL));
    else if (!strcmp(fn, "sersize"))
        CALL(w, fn, NULL, 0, 0, F2.SerializedFMUstateSize(c, NP(0, state), NP(1, &size)));
    else if (!strcmp(fn, "ser"))
        CALL(w, fn, NULL, 0, 0, F2.SerializeFMUstate(c, NP(0, state), NP(1, (fmi2Byte *)r), 64));
    else if (!strcmp(fn, "des")) {
        void *out = NULL;
        CALL(w, fn, NULL, 0, 0, F2.DeSerializeFMUstate(c, NP(0, (fmi2Byte *)r), 64, NP(1, &out)));
        if (out) F2.FreeFMUstate(c, &out);
    } else if (!strcmp(fn, "dir"))
        CALL(w, fn, NULL, 0, 0, F2.GetDirectionalDerivative(c, NP(0, vr), 1, NP(1, vr), 1,
                                                            NP(2, r), NP(3, r + 1)));
    else if (!strcmp(fn, "inder"))
        CALL(w, fn, NULL, 0, 1, F2.SetRealInputDerivatives(c, NP(0, vr), 1, NP(1, i), NP(2, r)));
    else if (!strcmp(fn, "outder"))
        CALL(w, fn, NULL, 0, 0, F2.GetRealOutputDerivatives(c, NP(0, vr), 1, NP(1, i), NP(2, r)));
    else if (!strcmp(fn, "status")) CALL(w, fn, NULL, 0, 0,
                                         F2.GetStatus(c, fmi2DoStepStatus, NULL));
    else if (!strcmp(fn, "rstatus"))
        CALL(w, fn, NULL, 0, 0, F2.GetRealStatus(c, fmi2LastSuccessfulTime, NULL));
    else if (!strcmp(fn, "istatus")) CALL(w, fn, NULL, 0, 0, F2.GetIntegerStatus(c, 0, NULL));
    else if (!strcmp(fn, "bstatus")) CALL(w, fn, NULL, 0, 0,
                                          F2.GetBooleanStatus(c, fmi2Terminated, NULL));
    else if (!strcmp(fn, "sstatus")) CALL(w, fn, NULL, 0, 0,
                                          F2.GetStringStatus(c, fmi2PendingStatus, NULL));
    else if (!strcmp(fn, "disc")) CALL(w, fn, NULL, 0, 1, F2.NewDiscreteStates(c, NP(0, &info)));
    else if (!strcmp(fn, "done"))
        CALL(w, fn, NULL, 0, 1, F2.CompletedIntegratorStep(c, fmi2True, NP(0, b), NP(1, b + 1)));
    else if (!strcmp(fn, "setx")) CALL(w, fn, NULL, 0, 1, F2.SetContinuousStates(c, NULL, NX));
    else if (!strcmp(fn, "getx")) CALL(w, fn, NULL, 0, 0, F2.GetContinuousStates(c, NULL, NX));
    else if (!strcmp(fn, "der")) CALL(w, fn, NULL, 0, 0, F2.GetDerivatives(c, NULL, NX));
    else if (!strcmp(fn, "ind")) CALL(w, fn, NULL, 0, 0, F2.GetEventIndicators(c, NULL, 3));
    else if (!strcmp(fn, "nominal")) CALL(w, fn, NULL, 0, 0,
                                          F2.GetNominalsOfContinuousStates(c, NULL, NX));
    else if (!strcmp(fn, "debug")) CALL(w, fn, NULL, 0, 0,
                                        F2.SetDebugLogging(c, fmi2True, 3, NULL));
    else if (!strcmp(fn, "step")) CALL(w, fn, NULL, 0, 1, F2.DoStep(c, w->t, 1e-3, fmi2True));
    else if (!strcmp(fn, "setup")) CALL(w, fn, NULL, 0, 1, F2.SetupExperiment(c, 0, 0, 0, 0, 0));
    else if (!strcmp(fn, "init")) CALL(w, fn, NULL, 0, 1, F2.EnterInitializationMode(c));
    else if (!strcmp(fn, "exit")) CALL(w, fn, NULL, 0, 1, F2.ExitInitializationMode(c));
    else if (!strcmp(fn, "term")) CALL(w, fn, NULL, 0, 0, F2.Terminate(c));
    else if (!strcmp(fn, "reset")) CALL(w, fn, NULL, 0, 0, F2.Reset(c));
    else if (!strcmp(fn, "time")) CALL(w, fn, NULL, 0, 1, F2.SetTime(c, 0.1));
    else if (!strcmp(fn, "event")) CALL(w, fn, NULL, 0, 1, F2.EnterEventMode(c));
    else if (!strcmp(fn, "cont")) CALL(w, fn, NULL, 0, 1, F2.EnterContinuousTimeMode(c));
    else if (!strcmp(fn, "cancel")) CALL(w, fn, NULL, 0, 0, F2.CancelStep(c));
    else if (!strcmp(fn, "free")) { F2.FreeInstance(c); K->calls++; }
    (void)st;
}

static void null3(World *w, const char *fn, unsigned mask, void *c)
{
    fmi3ValueReference vr[1] = {0};
    double r[8] = {0};
    fmi3Int64 i[8] = {0};
    fmi3Int32 i32[8] = {0};
    fmi3Boolean b[8] = {0};
    size_t size = 0, sizes[1] = {1};
    fmi3Binary bin[1] = {NULL};
    int st = 0;
    void *state = w->slot[0] && w->slot_of[0] == w->cur ? w->slot[0] : NULL;
    if (!strcmp(fn, "getr")) CALL(w, fn, NULL, 0, 0, F3.GetFloat64(c, NP(0, vr), 1, NP(1, r), 1));
    else if (!strcmp(fn, "geti")) CALL(w, fn, NULL, 0, 0,
                                       F3.GetInt32(c, NP(0, vr), 1, NP(1, i32), 1));
    else if (!strcmp(fn, "getb")) CALL(w, fn, NULL, 0, 0,
                                       F3.GetBoolean(c, NP(0, vr), 1, NP(1, b), 1));
    else if (!strcmp(fn, "getbin"))
        CALL(w, fn, NULL, 0, 0, F3.GetBinary(c, NP(0, vr), 1, NP(1, sizes), NP(2, bin), 1));
    else if (!strcmp(fn, "setr")) CALL(w, fn, NULL, 0, 1,
                                       F3.SetFloat64(c, NP(0, vr), 1, NP(1, r), 1));
    else if (!strcmp(fn, "seti")) CALL(w, fn, NULL, 0, 1,
                                       F3.SetInt64(c, NP(0, vr), 1, NP(1, i), 1));
    else if (!strcmp(fn, "setb")) CALL(w, fn, NULL, 0, 1,
                                       F3.SetBoolean(c, NP(0, vr), 1, NP(1, b), 1));
    else if (!strcmp(fn, "gst")) CALL(w, fn, NULL, 0, 0, F3.GetFMUState(c, NULL));
    else if (!strcmp(fn, "fst")) CALL(w, fn, NULL, 0, 0, F3.FreeFMUState(c, NULL));
    else if (!strcmp(fn, "sst")) CALL(w, fn, NULL, 0, 1, F3.SetFMUState(c, NULL));
    else if (!strcmp(fn, "sersize"))
        CALL(w, fn, NULL, 0, 0, F3.SerializedFMUStateSize(c, NP(0, state), NP(1, &size)));
    else if (!strcmp(fn, "ser"))
        CALL(w, fn, NULL, 0, 0, F3.SerializeFMUState(c, NP(0, state), NP(1, (fmi3Byte *)r), 64));
    else if (!strcmp(fn, "des")) {
        void *out = NULL;
        CALL(w, fn, NULL, 0, 0, F3.DeserializeFMUState(c, NP(0, (fmi3Byte *)r), 64, NP(1, &out)));
        if (out) F3.FreeFMUState(c, &out);
    } else if (!strcmp(fn, "dir"))
        CALL(w, fn, NULL, 0, 0, F3.GetDirectionalDerivative(c, NP(0, vr), 1, NP(1, vr), 1,
                                                            NP(2, r), 1, NP(3, r + 1), 1));
    else if (!strcmp(fn, "outder"))
        CALL(w, fn, NULL, 0, 0, F3.GetOutputDerivatives(c, NP(0, vr), 1, NP(1, i32), NP(2, r), 1));
    else if (!strcmp(fn, "disc"))
        CALL(w, fn, NULL, 0, 1, F3.UpdateDiscreteStates(c, NP(0, b), NP(1, b + 1), NP(2, b + 2),
                                                        NP(3, b + 3), NP(4, b + 4), NP(5, r)));
    else if (!strcmp(fn, "done"))
        CALL(w, fn, NULL, 0, 1, F3.CompletedIntegratorStep(c, fmi3True, NP(0, b), NP(1, b + 1)));
    else if (!strcmp(fn, "step"))
        CALL(w, fn, NULL, 0, 1, F3.DoStep(c, w->t, 1e-3, fmi3True, NP(0, b), NP(1, b + 1),
                                          NP(2, b + 2), NP(3, r)));
    else if (!strcmp(fn, "setx")) CALL(w, fn, NULL, 0, 1, F3.SetContinuousStates(c, NULL, NX));
    else if (!strcmp(fn, "getx")) CALL(w, fn, NULL, 0, 0, F3.GetContinuousStates(c, NULL, NX));
    else if (!strcmp(fn, "der")) CALL(w, fn, NULL, 0, 0,
                                      F3.GetContinuousStateDerivatives(c, NULL, NX));
    else if (!strcmp(fn, "ind")) CALL(w, fn, NULL, 0, 0, F3.GetEventIndicators(c, NULL, 3));
    else if (!strcmp(fn, "nominal")) CALL(w, fn, NULL, 0, 0,
                                          F3.GetNominalsOfContinuousStates(c, NULL, NX));
    else if (!strcmp(fn, "nind")) CALL(w, fn, NULL, 0, 0, F3.GetNumberOfEventIndicators(c, NULL));
    else if (!strcmp(fn, "nx")) CALL(w, fn, NULL, 0, 0, F3.GetNumberOfContinuousStates(c, NULL));
    else if (!strcmp(fn, "debug")) CALL(w, fn, NULL, 0, 0,
                                        F3.SetDebugLogging(c, fmi3True, 3, NULL));
    else if (!strcmp(fn, "init"))
        CALL(w, fn, NULL, 0, 1, F3.EnterInitializationMode(c, 0, 0, 0, 0, 0));
    else if (!strcmp(fn, "exit")) CALL(w, fn, NULL, 0, 1, F3.ExitInitializationMode(c));
    else if (!strcmp(fn, "term")) CALL(w, fn, NULL, 0, 0, F3.Terminate(c));
    else if (!strcmp(fn, "reset")) CALL(w, fn, NULL, 0, 0, F3.Reset(c));
    else if (!strcmp(fn, "time")) CALL(w, fn, NULL, 0, 1, F3.SetTime(c, 0.1));
    else if (!strcmp(fn, "event")) CALL(w, fn, NULL, 0, 1, F3.EnterEventMode(c));
    else if (!strcmp(fn, "cont")) CALL(w, fn, NULL, 0, 1, F3.EnterContinuousTimeMode(c));
    else if (!strcmp(fn, "stepmode")) CALL(w, fn, NULL, 0, 1, F3.EnterStepMode(c));
    else if (!strcmp(fn, "free")) { F3.FreeInstance(c); K->calls++; }
    (void)st;
}

static void op_null(World *w, const char *op, int argc, char **argv)
{
    const char *fn = argc > 1 ? argv[1] : "";
    unsigned mask = argc > 2 ? (unsigned)strtoul(argv[2], NULL, 10) : ~0u;
    int nullc = !strcmp(op, "nullc");
    void *c = nullc ? NULL : w->c[w->cur];
    if (nullc && !strcmp(fn, "free")) {  /* freeing NULL is allowed; nothing else to free */
        if (w->fmi == 2) F2.FreeInstance(NULL);
        else F3.FreeInstance(NULL);
        K->calls++;
        return;
    }
    if (!nullc && !strcmp(fn, "free")) return;  /* the instance is freed at the end */
    void *keep = w->c[w->cur];
    if (nullc) w->c[w->cur] = NULL;  /* no instance: no log expected */
    if (w->fmi == 2) null2(w, fn, mask, c);
    else null3(w, fn, mask, c);
    w->c[w->cur] = keep;
}

/* ------------------------------------------------------------------ one case */

static int split(char *line, char **argv)
{
    int argc = 0;
    for (char *tok = strtok(line, " \t\r\n"); tok && argc < MAXARG; tok = strtok(NULL, " \t\r\n"))
        argv[argc++] = tok;
    return argc;
}

static void run_line(World *w, char *line)
{
    char *argv[MAXARG];
    int argc = split(line, argv);
    if (argc == 0 || argv[0][0] == '#') return;
    const char *op = argv[0];
    if (!strcmp(op, "fmi")) w->fmi = argc > 1 && atoi(argv[1]) == 3 ? 3 : 2;
    else if (!strcmp(op, "inst")) op_inst(w, argc, argv);
    else if (!strcmp(op, "use")) w->cur = argc > 1 && atoi(argv[1]) == 1;
    else if (!w->c[w->cur] && strcmp(op, "nullc")) return;  /* no instance: nothing to call */
    else if (!strcmp(op, "setup") || !strcmp(op, "init") || !strcmp(op, "exit")
             || !strcmp(op, "term") || !strcmp(op, "reset") || !strcmp(op, "free"))
        op_cycle(w, op, argc, argv);
    else if (!strcmp(op, "setr") || !strcmp(op, "seti") || !strcmp(op, "setb")
             || !strcmp(op, "getr") || !strcmp(op, "geti") || !strcmp(op, "getb"))
        op_values(w, op, argc, argv);
    else if (!strcmp(op, "step")) op_step(w, argc, argv);
    else if (!strcmp(op, "run")) op_run(w, argc, argv);
    else if (!strcmp(op, "status")) op_status(w);
    else if (!strcmp(op, "merun")) op_merun(w, argc, argv);
    else if (!strcmp(op, "gst") || !strcmp(op, "sst") || !strcmp(op, "fst")
             || !strcmp(op, "ser") || !strcmp(op, "des") || !strcmp(op, "sstwild")
             || !strcmp(op, "sstself"))
        op_state(w, op, argc, argv);
    else if (!strcmp(op, "mut")) op_mut(w, argc, argv);
    else if (!strcmp(op, "null") || !strcmp(op, "nullc")) op_null(w, op, argc, argv);
    else me_call(w, op, argc, argv);
}

static void run_case(char **lines, int n)
{
    World w;
    memset(&w, 0, sizeof w);
    w.fmi = 2;
    for (int k = 0; k < 3; k++) w.z[k] = 1.0;
    for (int i = 0; i < n; i++) run_line(&w, lines[i]);
    for (int i = 0; i < 2; i++) {
        w.cur = i;
        free_instance(&w, i);
    }
    for (int s = 0; s < NSLOT; s++) free(w.buf[s]);
}

/* ------------------------------------------------------------------ the parent */

typedef struct {
    long cases, calls, crash, hang, sanitizer, nan_ok, after_error, silent_error;
} Totals;

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* The first line of a sanitizer's report in the child's stderr, or "". */
static void report_line(FILE *err, char *out, size_t n, int *sanitizer, int *segv)
{
    char line[512];
    out[0] = '\0';
    rewind(err);
    while (fgets(line, sizeof line, err)) {
        int asan = strstr(line, "ERROR: AddressSanitizer") || strstr(line, "ERROR: LeakSanitizer");
        int ubsan = strstr(line, "runtime error:") != NULL;
        if (asan || ubsan) {
            *sanitizer = 1;
            *segv = strstr(line, "SEGV") || strstr(line, "BUS") || strstr(line, "FPE")
                    || strstr(line, "deadly signal");
            line[strcspn(line, "\n")] = '\0';
            for (char *p = line; *p; p++) if (*p == '"') *p = '\'';
            snprintf(out, n, "%.300s", line);
            return;
        }
    }
}

static void one_case(const char *name, char **lines, int n, int timeout, Totals *T)
{
    memset(K, 0, sizeof *K);
    FILE *err = tmpfile();
    double t0 = now();
    fflush(stdout);
    pid_t pid = fork();
    if (pid == 0) {
        if (err) dup2(fileno(err), 2);
        alarm((unsigned)timeout);
        run_case(lines, n);
        exit(0);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    double ms = 1e3 * (now() - t0);
    char detail[400] = "";
    int sanitizer = 0, segv = 0;
    if (err) report_line(err, detail, sizeof detail, &sanitizer, &segv);
    const char *result = "ok";
    if (WIFSIGNALED(status) && WTERMSIG(status) == SIGALRM) {
        result = "hang";
        T->hang++;
        snprintf(detail, sizeof detail, "still running after %d s in %s", timeout, K->last);
    } else if (sanitizer && !segv) {
        result = "sanitizer";
        T->sanitizer++;
    } else if (segv || WIFSIGNALED(status) || WEXITSTATUS(status) != 0) {
        result = "crash";
        T->crash++;
        if (!detail[0]) snprintf(detail, sizeof detail, "%s %d in %s", WIFSIGNALED(status)
                                 ? "signal" : "exit", WIFSIGNALED(status) ? WTERMSIG(status)
                                 : WEXITSTATUS(status), K->last);
    }
    if (err) fclose(err);
    T->cases++;
    T->calls += K->calls;
    T->nan_ok += K->nan_ok;
    T->after_error += K->after_error;
    T->silent_error += K->silent_error;
    printf("CASE %s result=%s calls=%ld nan_ok=%ld after_error=%ld silent_error=%ld ms=%.1f",
           name, result, K->calls, K->nan_ok, K->after_error, K->silent_error, ms);
    if (strcmp(result, "ok")) printf(" last=%s detail=\"%s\"", K->last, detail);
    printf("\n");
}

static char *read_all(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    rewind(f);
    char *text = malloc((size_t)n + 1);
    if (text && fread(text, 1, (size_t)n, f) != (size_t)n) { free(text); text = NULL; }
    if (text) text[n] = '\0';
    fclose(f);
    return text;
}

int main(int argc, char **argv)
{
    if (argc < 6) {
        fprintf(stderr, "usage: %s LIB2.so LIB3.so TOKEN CORPUS TIMEOUT_S\n", argv[0]);
        return 2;
    }
    if (load(argv[1], 2) || load(argv[2], 3)) return 2;
    TOKEN = argv[3];
    verbose = getenv("ABUSE_VERBOSE") != NULL;
    char *text = read_all(argv[4]);
    if (!text) { fprintf(stderr, "cannot read %s\n", argv[4]); return 2; }
    int timeout = atoi(argv[5]);
    K = mmap(NULL, sizeof *K, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    if (K == MAP_FAILED) return 2;
    size_t cap = 1024, n = 0;
    char **lines = malloc(cap * sizeof *lines);
    for (char *line = strtok(text, "\n"); line; line = strtok(NULL, "\n")) {
        if (n == cap) lines = realloc(lines, (cap *= 2) * sizeof *lines);
        lines[n++] = line;
    }
    Totals T;
    memset(&T, 0, sizeof T);
    const char *name = NULL;
    size_t first = 0;
    for (size_t i = 0; i <= n; i++) {
        if (i < n && strncmp(lines[i], "dry ", 4) == 0) {
            char *save = NULL;
            strtok_r(lines[i], " ", &save);
            DRY_VR = (fmi2ValueReference)strtoul(strtok_r(NULL, " ", &save), NULL, 10);
            DRY_VALUE = strtol(strtok_r(NULL, " ", &save), NULL, 10);
            for (char *tok = strtok_r(NULL, " ", &save); tok && N_DRY_NAN < 16;
                 tok = strtok_r(NULL, " ", &save))
                DRY_NAN[N_DRY_NAN++] = (fmi2ValueReference)strtoul(tok, NULL, 10);
            first = i + 1;
            continue;
        }
        if (i < n && strncmp(lines[i], "reals ", 6) == 0) {
            char *save = NULL;
            strtok_r(lines[i], " ", &save);
            for (char *tok = strtok_r(NULL, " ", &save); tok && N_REALS < MAXREAL;
                 tok = strtok_r(NULL, " ", &save))
                REALS[N_REALS++] = (fmi2ValueReference)strtoul(tok, NULL, 10);
            first = i + 1;
            continue;
        }
        if (i == n || strncmp(lines[i], "case ", 5) == 0) {
            if (name) one_case(name, lines + first, (int)(i - first), timeout, &T);
            if (i < n) {
                name = lines[i] + 5;
                first = i + 1;
            }
        }
    }
    printf("TOTAL cases=%ld calls=%ld crash=%ld hang=%ld sanitizer=%ld nan_ok=%ld "
           "after_error=%ld silent_error=%ld\n", T.cases, T.calls, T.crash, T.hang,
           T.sanitizer, T.nan_ok, T.after_error, T.silent_error);
    free(lines);
    free(text);
    return 0;
}

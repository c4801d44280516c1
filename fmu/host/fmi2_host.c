/* A minimal FMI 2.0 co-simulation host without Python: loads the FMU's shared library with
 * dlopen, runs it at fixed communication steps, writes every output to a CSV and reports
 * timings. Used by the tests (tests/test_fmu_host.py) and the bench (bench/fmu_speed.py).
 *
 *   fmi2_host LIBRARY GUID STOP STEP PHASE_VR FIRST_OUTPUT_VR N_OUTPUTS COMMAND_VR
 *             COMMAND_TIME OUT.csv|- REPEATS [VR=VALUE ...]
 *
 * COMMAND_TIME < 0: the release command stays false. VR=VALUE sets a Real parameter (a value
 * with a leading 'i' sets an Integer: VR=i2). Prints "status=S message=... run_us=... step_us=..."
 * on its last line: run_us is the best whole run of REPEATS (instantiate to free), step_us
 * the best mean fmi2DoStep with its fmi2GetReal of every output. Exit 0 on success, 1 when
 * the FMU returned an error (its message printed), 2 on a usage or loading problem. */
#define _POSIX_C_SOURCE 200809L
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fmi2Functions.h"

static char last_message[1024];
static int last_status;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    (void)env; (void)name; (void)category;
    if (status >= last_status) {
        last_status = status;
        snprintf(last_message, sizeof last_message, "%s", message);
    }
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

#define LOAD(name) \
    name##TYPE *name = (name##TYPE *)dlsym(lib, #name); \
    if (!name) { fprintf(stderr, "missing %s\n", #name); return 2; }

int main(int argc, char **argv)
{
    if (argc < 12) {
        fprintf(stderr, "usage: %s LIBRARY GUID STOP STEP PHASE_VR FIRST_OUTPUT_VR N_OUTPUTS "
                "COMMAND_VR COMMAND_TIME OUT.csv|- REPEATS [VR=VALUE ...]\n", argv[0]);
        return 2;
    }
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "dlopen: %s\n", dlerror()); return 2; }
    LOAD(fmi2Instantiate) LOAD(fmi2FreeInstance) LOAD(fmi2SetupExperiment)
    LOAD(fmi2EnterInitializationMode) LOAD(fmi2ExitInitializationMode) LOAD(fmi2DoStep)
    LOAD(fmi2GetReal) LOAD(fmi2GetInteger) LOAD(fmi2SetReal) LOAD(fmi2SetInteger)
    LOAD(fmi2SetBoolean) LOAD(fmi2Terminate)
    const char *guid = argv[2];
    double stop = atof(argv[3]), h = atof(argv[4]);
    fmi2ValueReference phase_vr = (fmi2ValueReference)atoi(argv[5]);
    fmi2ValueReference first = (fmi2ValueReference)atoi(argv[6]);
    int n_out = atoi(argv[7]);
    fmi2ValueReference command_vr = (fmi2ValueReference)atoi(argv[8]);
    double command_time = atof(argv[9]);
    const char *out_path = argv[10];
    int repeats = atoi(argv[11]);
    long n_steps = (long)(stop / h + 0.5);
    fmi2ValueReference *vrs = malloc(n_out * sizeof *vrs);
    double *row = malloc((size_t)(n_steps + 1) * n_out * sizeof(double));
    int *phases = malloc((size_t)(n_steps + 1) * sizeof(int));
    for (int j = 0; j < n_out; j++) vrs[j] = first + j;
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    double best_run = 1e300, best_step = 1e300;
    for (int rep = 0; rep < repeats; rep++) {
        last_status = 0;
        last_message[0] = '\0';
        double t_start = now();
        fmi2Component c = fmi2Instantiate("host", fmi2CoSimulation, guid, "", &cb, fmi2False,
                                          fmi2False);
        if (!c) {
            printf("status=4 message=fmi2Instantiate returned NULL: %s\n", last_message);
            return 1;
        }
        for (int a = 12; a < argc; a++) {
            char *eq = strchr(argv[a], '=');
            if (!eq) continue;
            fmi2ValueReference vr = (fmi2ValueReference)atoi(argv[a]);
            if (eq[1] == 'i') {
                fmi2Integer v = atoi(eq + 2);
                fmi2SetInteger(c, &vr, 1, &v);
            } else {
                fmi2Real v = atof(eq + 1);
                fmi2SetReal(c, &vr, 1, &v);
            }
        }
        fmi2Status s = fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2True, stop);
        if (s == fmi2OK) s = fmi2EnterInitializationMode(c);
        if (s == fmi2OK) s = fmi2ExitInitializationMode(c);
        if (s != fmi2OK) {
            printf("status=%d message=%s\n", s, last_message);
            fmi2FreeInstance(c);
            return 1;
        }
        fmi2GetReal(c, vrs, n_out, row);
        fmi2GetInteger(c, &phase_vr, 1, &phases[0]);
        double t_steps = now();
        for (long k = 0; k < n_steps; k++) {
            double t = k * h;
            fmi2Boolean command = command_time >= 0.0 && t >= command_time;
            fmi2SetBoolean(c, &command_vr, 1, &command);
            s = fmi2DoStep(c, t, h, fmi2True);
            if (s > fmi2Warning) {
                printf("status=%d message=%s\n", s, last_message);
                fmi2FreeInstance(c);
                return 1;
            }
            fmi2GetReal(c, vrs, n_out, row + (k + 1) * n_out);
            fmi2GetInteger(c, &phase_vr, 1, &phases[k + 1]);
        }
        double t_end = now();
        fmi2Terminate(c);
        fmi2FreeInstance(c);
        double t_free = now();
        if (t_free - t_start < best_run) best_run = t_free - t_start;
        if ((t_end - t_steps) / n_steps < best_step) best_step = (t_end - t_steps) / n_steps;
    }
    if (strcmp(out_path, "-") != 0) {
        FILE *f = fopen(out_path, "w");
        if (!f) { fprintf(stderr, "cannot write %s\n", out_path); return 2; }
        for (long k = 0; k <= n_steps; k++) {
            fprintf(f, "%.17g,%d", k * h, phases[k]);
            for (int j = 0; j < n_out; j++) fprintf(f, ",%.17g", row[k * n_out + j]);
            fputc('\n', f);
        }
        fclose(f);
    }
    printf("status=%d message=%s run_us=%.3f step_us=%.4f\n", last_status, last_message,
           1e6 * best_run, 1e6 * best_step);
    free(vrs);
    free(row);
    free(phases);
    dlclose(lib);
    return 0;
}

/* One instance of the FMU, independent of the FMI version: variable values, the shot
 * (co-simulation) or the continuous state (model exchange), the release command. fmi2.c and
 * fmi3.c are thin layers over these functions. Functions return 0 (OK), 1 (a warning in
 * msg) or -1 (an error in msg). */
#ifndef TREB_MODEL_H
#define TREB_MODEL_H

#include "treb_scene.h"
#include "treb_variables.h"

#define TREB_NZ 3  /* event indicators of the model exchange */
#define TREB_NX_STATES 8  /* theta, psi, phi, theta_d, psi_d, phi_d, E_loss_pivot, E_loss_hinge */

typedef struct {
    int cosim;              /* 1 co-simulation, 0 model exchange */
    int initialized;
    double values[TREB_NV]; /* every variable by value reference */
    double time;            /* s */
    int command_prev;       /* release_command at the last communication point or event */
    int outputs_valid;
    int phase;              /* model exchange: 1 trough, 2 sling, 3 released */
    double x[TREB_NX_STATES];
    double z_ref[TREB_NZ];  /* indicators after the last event */
    TrebShot shot;          /* co-simulation: the shot; model exchange: scene and flight */
} TrebModel;

/* Every number the FMU takes is checked where it comes in: a start time in [0, TREB_HORIZON),
 * a finite communication point and step, finite states and times in model exchange; an
 * output, derivative or event indicator that comes out non-finite is an error, never a
 * value returned with OK. */
void treb_model_new(TrebModel *m, int cosim);
void treb_model_free(TrebModel *m);
void treb_model_reset(TrebModel *m);
int treb_model_exit_init(TrebModel *m, double start_time, char *msg);
int treb_model_check_start(double start_time, char *msg);
/* 0, 1 (a warning in msg), 2 (stopped at TREB_HORIZON: the outputs are those there, msg
 * says so) or -1. */
int treb_model_step(TrebModel *m, double t, double h, char *msg);
int treb_model_outputs(TrebModel *m, char *msg);
/* A parameter's or input's value (its causality and the instance's state checked by the
 * caller): finite; a choice or Boolean one of its values. */
int treb_model_set_value(TrebModel *m, int vr, double value, char *msg);
int treb_model_set_time(TrebModel *m, double t, char *msg);
int treb_model_set_states(TrebModel *m, const double *x, char *msg);
int treb_model_derivatives(TrebModel *m, double *dx, char *msg);
void treb_model_indicators(TrebModel *m, double *z);
int treb_model_event_indicators(TrebModel *m, double *z, char *msg);
/* 1 when the model exchange's time has reached TREB_HORIZON (the reason in msg), else 0. */
int treb_model_past_horizon(const TrebModel *m, char *msg);
int treb_model_directional(TrebModel *m, const unsigned *unknowns, size_t n_unknowns,
                           const unsigned *knowns, size_t n_knowns, const double *seed,
                           double *sensitivity, char *msg);
int treb_model_event(TrebModel *m, int *states_changed, int *time_defined, double *next_time,
                     char *msg);
int treb_model_copy(TrebModel *dst, const TrebModel *src);
/* A model read from bytes (treb_state.c): every field in range and consistent, the shot's
 * scene the one its parameters give. complete: a running co-simulation's whole shot. */
int treb_model_check(const TrebModel *m, int cosim, int complete, char *msg);

#endif

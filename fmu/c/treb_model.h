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

void treb_model_new(TrebModel *m, int cosim);
void treb_model_free(TrebModel *m);
void treb_model_reset(TrebModel *m);
int treb_model_exit_init(TrebModel *m, double start_time, char *msg);
int treb_model_step(TrebModel *m, double t, double h, char *msg);
int treb_model_outputs(TrebModel *m, char *msg);
void treb_model_derivatives(TrebModel *m, double *dx);
void treb_model_indicators(TrebModel *m, double *z);
int treb_model_directional(TrebModel *m, const unsigned *unknowns, size_t n_unknowns,
                           const unsigned *knowns, size_t n_knowns, const double *seed,
                           double *sensitivity, char *msg);
int treb_model_event(TrebModel *m, int *states_changed, int *time_defined, double *next_time,
                     char *msg);
int treb_model_copy(TrebModel *dst, const TrebModel *src);
size_t treb_model_serialized_size(const TrebModel *m);
void treb_model_serialize(const TrebModel *m, unsigned char *buf);
int treb_model_deserialize(TrebModel *m, const unsigned char *buf, size_t size);

#endif

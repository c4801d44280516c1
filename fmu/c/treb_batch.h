/* The in-process engine (trebuchet.model.c_engine): a shot from the scene's numbers, every
 * column of simulate's table at many times in one call, and the figures of a design reduced
 * without a table. Hand-written glue only: the rows are the generated formulas of treb_rows.c
 * (forces.row_loads and the equations of motion, from the model's Python), the shot is
 * treb_shot.c's (the FMU's). Units: s, rad, rad/s, m, m/s, N, N m, W, J. */
#ifndef TREB_BATCH_H
#define TREB_BATCH_H

#include "treb_rows.h"
#include "treb_shot.h"

/* flags[]: the scene's switches */
enum { TREB_FLAG_FIXED, TREB_FLAG_PROJECTILE /* 1 trough, 2 sling, 3 none */, TREB_FLAG_DRAG,
       TREB_FLAG_FRICTION, TREB_FLAG_HAS_TIME, TREB_FLAG_HAS_ANGLE, TREB_N_FLAGS };
/* par[]: start pose (rad), release rules (s, rad), drag (m, 1, kg/m3), tolerance, phase III
 * (s), the energies at rest of projectile, counterweight and beam (J, forces.rest_energies;
 * NaN: the generated treb_rest_energies, the same formula) */
enum { TREB_PAR_THETA, TREB_PAR_PSI, TREB_PAR_PHI, TREB_PAR_T_RELEASE, TREB_PAR_ANGLE,
       TREB_PAR_DIAMETER, TREB_PAR_DRAG_COEFFICIENT, TREB_PAR_AIR_DENSITY, TREB_PAR_RTOL,
       TREB_PAR_AFTER_RELEASE, TREB_PAR_REST, TREB_N_PARS = TREB_PAR_REST + 3 };
/* info[] of treb_engine_info */
enum { TREB_INFO_PHASES = 0, TREB_INFO_KIND = 1, TREB_INFO_T0 = 4, TREB_INFO_T1 = 7,
       TREB_INFO_NFEV = 10, TREB_INFO_T_LIFT = 13, TREB_INFO_T_RELEASE = 14,
       TREB_INFO_RELEASE = 15 /* t, x, y, vx, vy */, TREB_N_INFO = 20 };
/* out[] of treb_engine_summary: the extrema, then the time of each (s) */
enum { TREB_FIG_F_S = 0, TREB_FIG_F_H, TREB_FIG_F_R, TREB_FIG_F_R_PERP, TREB_FIG_TORQUE,
       TREB_FIG_TENSION_MIN, TREB_FIG_DRIFT, TREB_FIG_CLEARANCE, TREB_FIG_E_M_RELEASE,
       TREB_FIG_LOSS_RELEASE, TREB_N_FIGURES };

TrebShot *treb_engine_new(void);
void treb_engine_free(TrebShot *s);
const char *treb_engine_row_names(void);
const char *treb_engine_parameter_names(void);
int treb_engine_start(TrebShot *s, const double *q, const int *flags, const double *par,
                      char *msg);
void treb_engine_info(const TrebShot *s, double *info);
int treb_engine_states(TrebShot *s, int k, const double *t, long n, double *out, char *msg);
long treb_engine_step_count(const TrebShot *s, int k);
void treb_engine_steps(const TrebShot *s, int k, double *T, double *H, double *Y, double *F);
int treb_engine_rows(TrebShot *s, const double *t, long n, const long *dest, long dest_t,
                     double *out, long *phase, long *bad, char *msg);
#define TREB_ENGINE_INPUTS (TREB_MAXN + 5)
int treb_engine_inputs(const TrebScene *sc, int kind, const double *y, double *x);
void treb_engine_row(const TrebScene *sc, int kind, const double *y, double *row);
int treb_engine_summary(TrebShot *s, double dt, double t_clear, double *out, long *bad,
                        char *msg);

#endif

/* The trebuchet's shot in C: DOP853 with dense output and event location (as the simulator's
 * compiled kernel, model/shot_kernel.py), the phases of a shot (model/simulate.py) and the
 * outputs at any time. Hand-written glue only: every formula it evaluates is generated from
 * the model's Python (treb_formulas.c). Units: s, rad, rad/s, m, m/s, N, J. */
#ifndef TREB_SHOT_H
#define TREB_SHOT_H

#include <stddef.h>
#include "treb_formulas.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define TREB_NS 12     /* DOP853 stages */
#define TREB_NX 16     /* stages with the dense output's three */
#define TREB_NP 7      /* interpolating polynomial's coefficients */
#define TREB_MAXN 8    /* largest state: phase II with the two lost energies of friction */
#define TREB_MAXEV 3   /* most events at once */
#define TREB_MAX_SHOT 60.0  /* s: a shot still in the trough or sling by then is refused */
/* s after the trigger: the FMU's time ends here (the shot's meaningful horizon: a shot is
 * released by TREB_MAX_SHOT or refused); a step or an output beyond it is refused. */
#define TREB_HORIZON TREB_MAX_SHOT
/* Accepted integration steps one shot may store (phases and the flight with drag, each): a
 * 60 s shot of the paper's engine takes about 1,600; an engine stiffer than this budget is
 * refused with a message instead of growing without bound (TrebStep: 400 bytes). */
#define TREB_MAX_STEPS 100000
#define TREB_MSG 512

/* Event kinds: model/phase_events.py */
enum { TREB_LIFT_OFF = 0, TREB_SLING_UPRIGHT = 1, TREB_GROUND = 2, TREB_RELEASE_TIME = 3,
       TREB_RELEASE_ANGLE = 4 };
/* Right-hand sides: phases 1-3, and the projectile's flight with drag */
enum { TREB_DRAG_FLIGHT = 4 };

/* The scene: parameters of the formulas (q, treb_formulas.h order) and the rules. */
typedef struct {
    double q[TREB_NQ];
    int fixed;        /* counterweight rigid on the beam */
    int projectile;   /* 1 trough, 2 sling, 3 none */
    int drag;         /* flight with air drag */
    int friction;     /* friction in the bearings: two more states, the lost energies */
    double theta, psi, phi;             /* start pose, rad */
    int has_time, has_angle;
    double t_release, angle;            /* release rules: s, rad */
    double diameter, drag_coefficient, air_density;
    double rest[3];   /* energies at rest, J */
    double k_drag;    /* 1/m */
    /* The in-process engine's (treb_batch.c); 0 in the FMU: tolerance 1e-10, phase III open */
    double rtol;           /* integrator tolerance (atol = rtol / 100); 0: 1e-10 */
    int bounded;           /* phase III ends after_release s after the release (dry fire: 0) */
    double after_release;  /* s */
} TrebScene;

/* One accepted step: start time, size, start state and the dense output's coefficients. */
typedef struct {
    double t, h;
    double y[TREB_MAXN];
    double F[TREB_NP][TREB_MAXN];
} TrebStep;

/* A DOP853 integration in progress (no pointers: it is copied and serialised as bytes). */
typedef struct {
    int kind, n, fixed, friction;
    double q[TREB_NQ];
    double k_drag;
    double rtol, atol;
    int nev;
    int ev_kind[TREB_MAXEV];
    double ev_par[TREB_MAXEV], ev_dir[TREB_MAXEV], g_old[TREB_MAXEV];
    double t, t_bound, h_abs;
    double y[TREB_MAXN], f[TREB_MAXN];
    long nfev;
} TrebDop;

typedef struct {
    TrebStep *data;
    int n, cap;
} TrebSteps;

typedef struct {
    TrebScene sc;
    int n_phases;
    int phase[3];
    double t0[3], t1[3];     /* phase k covers (t1[k-1], t1[k]]; the last is open */
    int first[3];            /* its first step in steps */
    TrebSteps steps;
    TrebDop open;            /* the last phase, integrated further on demand */
    double t_lift, t_rel;    /* events (NAN: none) */
    double release[5];       /* projectile t, x, y, vx, vy at release */
    /* phase II's start, for a release command */
    int p2_phase_index;
    double p2_t0, p2_first_step, p2_y[TREB_MAXN];
    /* the flight with drag after release */
    TrebSteps flight;
    TrebDop flight_dop;
    int flight_started;
    long nfev[3];            /* right-hand sides of each closed phase (the open one: open.nfev) */
} TrebShot;

int treb_scene_rest(TrebScene *sc);
void treb_shot_init_empty(TrebShot *s);
int treb_shot_start(TrebShot *s, const TrebScene *sc, char *msg);
int treb_shot_outputs(TrebShot *s, double t, int *phase, double *out, char *msg);
int treb_shot_state(TrebShot *s, int k, double t, double *y, char *msg);
int treb_shot_command(TrebShot *s, double t_c, char *msg);
void treb_shot_free(TrebShot *s);
int treb_shot_copy(TrebShot *dst, const TrebShot *src);
size_t treb_shot_serialized_size(const TrebShot *s);
void treb_shot_serialize(const TrebShot *s, unsigned char *buf);
int treb_shot_deserialize(TrebShot *s, const unsigned char *buf, size_t size, char *msg);
/* A shot read from bytes, checked before use: every count, index, kind and number in range
 * and consistent with the scene s->sc (itself checked by the caller). complete: the shot of
 * a running co-simulation (every phase, the open phase III); else a model exchange's (no
 * phases) or an empty or broken one. 0, or -1 with the reason in msg. */
int treb_shot_check(const TrebShot *s, int cosim, int complete, char *msg);

/* Formulas by phase and counterweight (generated), used by the model exchange too. A state y
 * of phase I or III is (theta, psi, theta_d, psi_d), of phase II (theta, psi, phi, theta_d,
 * psi_d, phi_d); with friction the lost energies e_P, e_H (in units of treb_energy_scale)
 * follow. */
int treb_state_size(const TrebScene *sc, int phase);
void treb_outputs_of(const TrebScene *sc, int phase, const double *y, double *out);
void treb_friction_solve(const double *q, int phase, int fixed, const double *y, double *Q);
void treb_flight_at(TrebShot *s, double t, double *out);

#endif

/* The in-process engine: see treb_batch.h. Loaded by trebuchet.model.c_engine (ctypes). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "treb_batch.h"

typedef void (*Formula)(const double *, const double *, double *);

/* [friction][fixed][phase I, II, III, III of a dry fire] */
static const Formula ROWS[2][2][4] = {
    {{treb_rows1_hinged, treb_rows2_hinged, treb_rows3_hinged, treb_rows3_hinged_dry},
     {treb_rows1_fixed, treb_rows2_fixed, treb_rows3_fixed, treb_rows3_fixed_dry}},
    {{treb_rows1_hinged_friction, treb_rows2_hinged_friction, treb_rows3_hinged_friction,
      treb_rows3_hinged_dry_friction},
     {treb_rows1_fixed_friction, treb_rows2_fixed_friction, treb_rows3_fixed_friction,
      treb_rows3_fixed_dry_friction}}};

TrebShot *treb_engine_new(void)
{
    TrebShot *s = malloc(sizeof *s);
    if (s) treb_shot_init_empty(s);
    return s;
}

void treb_engine_free(TrebShot *s)
{
    if (!s) return;
    treb_shot_free(s);
    free(s);
}

/* The row columns' and the parameters' names, space-separated: the Python side checks its
 * own against them. */
const char *treb_engine_row_names(void)
{
    return TREB_ROW_NAMES;
}

const char *treb_engine_parameter_names(void)
{
    return TREB_PARAMETER_NAMES;
}

/* The shot of the scene, integrated through phase III's end (the release + after_release;
 * a dry fire: after_release). Returns 0, or -1 (refused: msg says why) or -2 (no memory). */
int treb_engine_start(TrebShot *s, const double *q, const int *flags, const double *par,
                      char *msg)
{
    TrebScene sc;
    memset(&sc, 0, sizeof sc);
    memcpy(sc.q, q, sizeof sc.q);
    sc.fixed = flags[TREB_FLAG_FIXED];
    sc.projectile = flags[TREB_FLAG_PROJECTILE];
    sc.drag = flags[TREB_FLAG_DRAG];
    sc.friction = flags[TREB_FLAG_FRICTION];
    sc.has_time = flags[TREB_FLAG_HAS_TIME];
    sc.has_angle = flags[TREB_FLAG_HAS_ANGLE];
    sc.theta = par[TREB_PAR_THETA];
    sc.psi = par[TREB_PAR_PSI];
    sc.phi = par[TREB_PAR_PHI];
    sc.t_release = par[TREB_PAR_T_RELEASE];
    sc.angle = par[TREB_PAR_ANGLE];
    sc.diameter = par[TREB_PAR_DIAMETER];
    sc.drag_coefficient = par[TREB_PAR_DRAG_COEFFICIENT];
    sc.air_density = par[TREB_PAR_AIR_DENSITY];
    sc.rtol = par[TREB_PAR_RTOL];
    sc.bounded = 1;
    sc.after_release = par[TREB_PAR_AFTER_RELEASE];
    treb_scene_rest(&sc);  /* the drag constant; the energies at rest where par has NaN */
    if (!isnan(par[TREB_PAR_REST])) memcpy(sc.rest, par + TREB_PAR_REST, sizeof sc.rest);
    int r = treb_shot_start(s, &sc, msg);
    if (r) return r;
    double y[TREB_MAXN];
    r = treb_shot_state(s, s->n_phases - 1, s->open.t_bound, y, msg);
    return r < 0 ? r : 0;
}

/* The phases (count, kinds, starts, ends, right-hand sides), the events (NAN: none) and the
 * projectile's state at release into info (TREB_N_INFO numbers, TREB_INFO_*). */
void treb_engine_info(const TrebShot *s, double *info)
{
    for (int i = 0; i < TREB_N_INFO; i++) info[i] = NAN;
    int last = s->n_phases - 1;
    info[TREB_INFO_PHASES] = s->n_phases;
    for (int k = 0; k < s->n_phases; k++) {
        info[TREB_INFO_KIND + k] = s->phase[k];
        info[TREB_INFO_T0 + k] = s->t0[k];
        info[TREB_INFO_T1 + k] = k == last ? s->open.t : s->t1[k];
        info[TREB_INFO_NFEV + k] = (double)(k == last ? s->open.nfev : s->nfev[k]);
    }
    info[TREB_INFO_T_LIFT] = s->t_lift;
    info[TREB_INFO_T_RELEASE] = s->t_rel;
    if (!isnan(s->t_rel))
        for (int i = 0; i < 5; i++) info[TREB_INFO_RELEASE + i] = s->release[i];
}

/* The state of phase index k at the n times t into the columns of out (state size x n). */
int treb_engine_states(TrebShot *s, int k, const double *t, long n, double *out, char *msg)
{
    int size = treb_state_size(&s->sc, s->phase[k]);
    for (long m = 0; m < n; m++) {
        double y[TREB_MAXN];
        int r = treb_shot_state(s, k, t[m], y, msg);
        if (r < 0) return r;
        for (int i = 0; i < size; i++) out[i * n + m] = y[i];
    }
    return 0;
}

/* The steps stored for the phase of index k. */
long treb_engine_step_count(const TrebShot *s, int k)
{
    int last = s->n_phases - 1;
    return (k == last ? s->steps.n : s->first[k + 1]) - s->first[k];
}

/* Those steps: start times T, sizes H, start states Y (count x n, C order) and the dense
 * output's coefficients F (count x 7 x n), n the phase's state size. */
void treb_engine_steps(const TrebShot *s, int k, double *T, double *H, double *Y, double *F)
{
    long count = treb_engine_step_count(s, k);
    int n = treb_state_size(&s->sc, s->phase[k]);
    for (long j = 0; j < count; j++) {
        const TrebStep *st = &s->steps.data[s->first[k] + j];
        T[j] = st->t;
        H[j] = st->h;
        for (int i = 0; i < n; i++) {
            Y[j * n + i] = st->y[i];
            for (int p = 0; p < TREB_NP; p++) F[(j * TREB_NP + p) * n + i] = st->F[p][i];
        }
    }
}

/* The inputs x (TREB_ENGINE_INPUTS numbers) of the row formulas of the state y of phase kind;
 * returns the formulas' index of the phase (I, II, III, III of a dry fire). */
int treb_engine_inputs(const TrebScene *sc, int kind, const double *y, double *x)
{
    int n = treb_state_size(sc, kind);
    memcpy(x, y, n * sizeof(double));
    if (sc->friction) {  /* the state, its lost energies, the couples' Q */
        treb_friction_solve(sc->q, kind, sc->fixed, y, x + n);
        n += 2;
    }
    memcpy(x + n, sc->rest, 3 * sizeof(double));
    return kind == 3 && sc->projectile == 3 ? 3 : kind - 1;
}

/* Every row column (TREB_ROW_*) of the state y of phase kind into row. */
void treb_engine_row(const TrebScene *sc, int kind, const double *y, double *row)
{
    double x[TREB_ENGINE_INPUTS];
    int k = treb_engine_inputs(sc, kind, y, x);
    ROWS[sc->friction != 0][sc->fixed != 0][k](sc->q, x, row);
}

/* After release, the projectile's columns of the flight in vacuum (with drag the caller's). */
static void flight_of(TrebShot *s, int kind, double t, double *row)
{
    if (kind != 3 || s->sc.projectile == 3 || s->sc.drag) return;
    double f[5];
    treb_flight_at(s, t, f);
    row[TREB_ROW_x_m] = f[0];
    row[TREB_ROW_y_m] = f[1];
    row[TREB_ROW_vx_m] = f[2];
    row[TREB_ROW_vy_m] = f[3];
    row[TREB_ROW_E_m] = f[4];
}

static int projectile_column(int j)
{
    return j == TREB_ROW_x_m || j == TREB_ROW_y_m || j == TREB_ROW_vx_m || j == TREB_ROW_vy_m;
}

/* Where simulate's table may hold a NaN: the sling after release, the projectile of a dry
 * fire; and the flight with drag, which the caller fills in and checks. */
static int may_be_nan(const TrebScene *sc, int kind, int j)
{
    if (kind == 3 && (j == TREB_ROW_phi || j == TREB_ROW_phi_d || j == TREB_ROW_phi_dd)) return 1;
    if (sc->projectile == 3 && projectile_column(j)) return 1;
    return kind == 3 && sc->drag && (projectile_column(j) || j == TREB_ROW_E_m);
}

/* Every value of the row finite where simulate's table must be (those that may be NaN, see
 * may_be_nan, are set to 0: the figures do not use them). */
static int row_finite(const TrebScene *sc, int kind, double *row)
{
    if (kind == 3) row[TREB_ROW_phi] = row[TREB_ROW_phi_d] = row[TREB_ROW_phi_dd] = 0.0;
    if (sc->projectile == 3 || (kind == 3 && sc->drag)) {
        row[TREB_ROW_x_m] = row[TREB_ROW_y_m] = row[TREB_ROW_vx_m] = row[TREB_ROW_vy_m] = 0.0;
        if (sc->drag) row[TREB_ROW_E_m] = 0.0;
    }
    double a = 0.0, b = 0.0, c = 0.0, d = 0.0;  /* x - x: 0, or NaN where x is not finite */
    int j = 0;
    for (; j + 4 <= TREB_N_ROWS; j += 4) {
        a += row[j] - row[j];
        b += row[j + 1] - row[j + 1];
        c += row[j + 2] - row[j + 2];
        d += row[j + 3] - row[j + 3];
    }
    for (; j < TREB_N_ROWS; j++) a += row[j] - row[j];
    return a + b + c + d == 0.0;
}

/* The rows at the n times t: row column j into out's row dest[j] (none where dest[j] < 0),
 * t into out's row dest_t (none if < 0); out is (rows, n), C order. phase[m]: the phase of
 * time m (at an event, the one that ends there). bad: the first of out's rows with a value
 * that is not finite where simulate's table must be, and its first column m (-1: none). */
int treb_engine_rows(TrebShot *s, const double *t, long n, const long *dest, long dest_t,
                     double *out, long *phase, long *bad, char *msg)
{
    long first_bad[TREB_N_ROWS];
    for (int j = 0; j < TREB_N_ROWS; j++) first_bad[j] = -1;
    for (long m = 0; m < n; m++) {
        double y[TREB_MAXN], row[TREB_N_ROWS];
        int k = treb_shot_state(s, -1, t[m], y, msg);
        if (k < 0) return k;
        int kind = s->phase[k];
        treb_engine_row(&s->sc, kind, y, row);
        flight_of(s, kind, t[m], row);
        phase[m] = kind;
        if (dest_t >= 0) out[dest_t * n + m] = t[m];
        for (int j = 0; j < TREB_N_ROWS; j++) {
            if (dest[j] < 0) continue;
            out[dest[j] * n + m] = row[j];
            if (first_bad[j] < 0 && !isfinite(row[j]) && !may_be_nan(&s->sc, kind, j))
                first_bad[j] = m;
        }
    }
    bad[0] = bad[1] = -1;
    for (int j = 0; j < TREB_N_ROWS; j++)
        if (first_bad[j] >= 0 && (bad[0] < 0 || dest[j] < bad[0])) {
            bad[0] = dest[j];
            bad[1] = first_bad[j];
        }
    return 0;
}

/* ------------------------------------------------------------------ the figures */

/* simulate's output times, in order: every multiple of dt up to t_end (numpy's arange) and
 * the events, each once (numpy's unique). */
typedef struct {
    double dt, t_end, ev[3];
    long i;
    int nev, j;
    double last;
} Times;

static void times_start(Times *g, double dt, double t_end, const double *events, int nev)
{
    g->dt = dt;
    g->t_end = t_end;
    g->nev = 0;
    for (int k = 0; k < nev; k++) {  /* sorted, the NaNs (no such event) left out */
        if (isnan(events[k])) continue;
        int at = g->nev++;
        while (at > 0 && g->ev[at - 1] > events[k]) {
            g->ev[at] = g->ev[at - 1];
            at--;
        }
        g->ev[at] = events[k];
    }
    g->i = 0;
    g->j = 0;
    g->last = -INFINITY;
}

/* The next time into *t; 0 when there is none. */
static int times_next(Times *g, double *t)
{
    for (;;) {
        double grid = (double)g->i * g->dt;
        int has_grid = grid <= g->t_end, has_ev = g->j < g->nev;
        if (!has_grid && !has_ev) return 0;
        if (has_grid && (!has_ev || grid <= g->ev[g->j])) {
            *t = grid;
            g->i++;
        } else {
            *t = g->ev[g->j++];
        }
        if (*t != g->last) {
            g->last = *t;
            return 1;
        }
    }
}

typedef struct {
    double value[TREB_N_FIGURES], time[TREB_N_FIGURES];
} Extrema;

static void most(Extrema *x, int f, double v, double t)
{
    if (v > x->value[f] || isnan(x->value[f])) {
        x->value[f] = v;
        x->time[f] = t;
    }
}

static void least(Extrema *x, int f, double v, double t)
{
    if (v < x->value[f] || isnan(x->value[f])) {
        x->value[f] = v;
        x->time[f] = t;
    }
}

/* One row's part of the figures (simulate.engine_energy's sum for the drift, with the
 * projectile's energy held at its release value in flight, e_release). */
static void reduce_row(Extrema *x, const TrebShot *s, int kind, double t, const double *row,
                       double e_release)
{
    most(x, TREB_FIG_F_S, fabs(row[TREB_ROW_F_S_abs]), t);
    most(x, TREB_FIG_F_H, fabs(row[TREB_ROW_F_H_abs]), t);
    most(x, TREB_FIG_F_R, fabs(row[TREB_ROW_F_R_abs]), t);
    most(x, TREB_FIG_F_R_PERP, fabs(row[TREB_ROW_F_R_perp]), t);
    most(x, TREB_FIG_TORQUE, fabs(row[TREB_ROW_torque]), t);
    if (kind <= 2) least(x, TREB_FIG_TENSION_MIN, row[TREB_ROW_sling_tension], t);
    double E_m = kind == 3 && !isnan(e_release) ? e_release : row[TREB_ROW_E_m];
    double total = E_m + row[TREB_ROW_E_M] + row[TREB_ROW_E_beam] + row[TREB_ROW_E_loss_pivot]
                   + row[TREB_ROW_E_loss_hinge];
    most(x, TREB_FIG_DRIFT, fabs(total), t);
    if (kind == 2 && t == s->t_rel) {
        x->value[TREB_FIG_E_M_RELEASE] = row[TREB_ROW_E_m];
        x->value[TREB_FIG_LOSS_RELEASE] = row[TREB_ROW_E_loss_pivot]
                                          + row[TREB_ROW_E_loss_hinge];
        x->time[TREB_FIG_E_M_RELEASE] = x->time[TREB_FIG_LOSS_RELEASE] = t;
    }
    least(x, TREB_FIG_CLEARANCE, row[TREB_ROW_y_M], t);
}

/* The figures of the shot over the rows simulate tabulates at step dt (through phase III's
 * end): peak |F_S|, |F_H|, |F_R|, |F_R_perp|, |torque|, the least sling tension while held,
 * the energy drift, the projectile's energy and the friction's loss at release (J); and the
 * lowest height of the counterweight's centre to t_clear (s; the rows at step dt beyond the
 * end, and t_clear). out: the TREB_N_FIGURES values (NAN: none), then the time of each.
 * bad[1]: the first row (its index) with a value that is not finite where simulate's table
 * must be (-1: none). */
int treb_engine_summary(TrebShot *s, double dt, double t_clear, double *out, long *bad,
                        char *msg)
{
    Extrema x;
    for (int f = 0; f < TREB_N_FIGURES; f++) x.value[f] = x.time[f] = NAN;
    double t_end = s->open.t_bound, e_release = NAN, t;
    if (!isnan(s->t_rel)) {
        double v[4] = {s->release[3], s->release[4], s->release[2], s->sc.rest[0]};
        treb_flight_energy(s->sc.q, v, &e_release);
    }
    double events[3] = {s->t_lift, s->t_rel, t_end};
    Times g;
    times_start(&g, dt, t_end, events, 3);
    bad[0] = bad[1] = -1;
    for (long m = 0; times_next(&g, &t); m++) {
        double y[TREB_MAXN], row[TREB_N_ROWS];
        int k = treb_shot_state(s, -1, t, y, msg);
        if (k < 0) return k;
        int kind = s->phase[k];
        treb_engine_row(&s->sc, kind, y, row);
        flight_of(s, kind, t, row);
        if (bad[0] < 0 && !row_finite(&s->sc, kind, row)) {
            bad[0] = 0;
            bad[1] = m;
        }
        reduce_row(&x, s, kind, t, row, e_release);
    }
    if (t_clear > t_end) {  /* the clearance's window runs on past the table's end */
        s->open.t_bound = t_clear;
        double ev_clear = t_clear;
        times_start(&g, dt, t_clear, &ev_clear, 1);
        while (times_next(&g, &t)) {
            if (t <= t_end) continue;
            double y[TREB_MAXN], y_M;
            int k = treb_shot_state(s, -1, t, y, msg);
            if (k < 0) return k;
            treb_counterweight_height(s->sc.q, y, &y_M);  /* theta, psi lead every state */
            least(&x, TREB_FIG_CLEARANCE, y_M, t);
        }
    }
    memcpy(out, x.value, sizeof x.value);
    memcpy(out + TREB_N_FIGURES, x.time, sizeof x.time);
    return 0;
}

/* The shot: DOP853 (scipy's tableau, error norm, step-size control, first step and dense
 * output, as model/shot_kernel.py), Brent's method on the step's polynomial for events, and
 * the phases of model/simulate.py. See treb_shot.h. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "treb_shot.h"
#include "treb_tableau.h"

#define SAFETY 0.9
#define MIN_FACTOR 0.2
#define MAX_FACTOR 10.0
#define ERROR_EXPONENT (-1.0 / 8.0)
#define XTOL (4.0 * 2.220446049250313e-16)
#define RTOL 1e-10          /* the simulator's default tolerance, atol = rtol / 100 */
#define FLIGHT_RTOL 1e-10   /* model/flight.py: the flight with drag */
#define FLIGHT_ATOL 1e-9

static const double DIRECTION[5] = {-1.0, 1.0, -1.0, 1.0, 1.0};

/* ------------------------------------------------------------------ friction */

typedef void (*Formula)(const double *, const double *, double *);
static const Formula PIECES[2][3] = {
    {treb_friction_pieces1_hinged, treb_friction_pieces2_hinged, treb_friction_pieces3_hinged},
    {treb_friction_pieces1_fixed, treb_friction_pieces2_fixed, treb_friction_pieces3_fixed}};
static const Formula RATES_FRICTION[2][3] = {
    {treb_rates1_hinged_friction, treb_rates2_hinged_friction, treb_rates3_hinged_friction},
    {treb_rates1_fixed_friction, treb_rates2_fixed_friction, treb_rates3_fixed_friction}};

int treb_state_size(const TrebScene *sc, int phase)
{
    return (phase == 2 ? 6 : 4) + (sc->friction ? 2 : 0);
}

/* The pieces of the bearings' friction at the state y of phase into p (TREB_N_PIECES) and the
 * load magnitudes |F_R|, |F_H| (N) the couples follow into n: the generated pieces, Newton's
 * first two steps, then more generated steps until both margins say the steps have converged
 * to round-off, at most TREB_FRICTION_NEWTON_STEPS in all (model/dynamics.py, friction_solve,
 * takes the same steps). */
static void friction_loads(const double *q, int phase, int fixed, const double *y, double *p,
                           double *n)
{
    double x[TREB_N_LOADS + 2], m[6], out[TREB_N_FIRST_STEPS];  /* m: n, n before, step before */
    PIECES[fixed != 0][phase - 1](q, y, p);
    treb_friction_first_steps(q, p, out);
    n[0] = out[0];
    n[1] = out[1];
    if (out[4] <= 0.0 && out[5] <= 0.0) return;
    memcpy(x, p, TREB_N_LOADS * sizeof(double));
    m[4] = out[2];
    m[5] = out[3];
    for (int i = 2; i < TREB_FRICTION_NEWTON_STEPS; i++) {
        m[2] = x[TREB_N_LOADS] = n[0];
        m[3] = x[TREB_N_LOADS + 1] = n[1];
        treb_friction_newton(q, x, n);
        m[0] = n[0];
        m[1] = n[1];
        treb_friction_newton_margins(q, m, out);
        if (out[0] <= 0.0 && out[1] <= 0.0) break;
        m[4] = out[2];
        m[5] = out[3];
    }
}

/* The generalised forces Q_th, Q_ps (N m) of the bearings' friction couples at the state y of
 * phase (model/dynamics.py, friction_forces). */
void treb_friction_solve(const double *q, int phase, int fixed, const double *y, double *Q)
{
    double p[TREB_N_PIECES], n[2];
    friction_loads(q, phase, fixed, y, p, n);
    double c[4] = {p[0], p[1], n[0], n[1]};
    treb_friction_couples(q, c, Q);
}

/* ------------------------------------------------------------------ right-hand sides */

static void rhs(const TrebDop *d, const double *y, double *dy)
{
    if (d->kind == TREB_DRAG_FLIGHT) {
        double x[5] = {d->k_drag, y[0], y[1], y[2], y[3]};
        treb_drag_rates(d->q, x, dy);
    } else if (d->friction) {  /* the state, its lost energies, the pieces, |F_R|, |F_H| */
        double x[TREB_MAXN + TREB_N_PIECES + 2];
        memcpy(x, y, d->n * sizeof(double));
        friction_loads(d->q, d->kind, d->fixed, y, x + d->n, x + d->n + TREB_N_PIECES);
        RATES_FRICTION[d->fixed != 0][d->kind - 1](d->q, x, dy);
    } else if (d->kind == 1) {
        (d->fixed ? treb_rates1_fixed : treb_rates1_hinged)(d->q, y, dy);
    } else if (d->kind == 2) {
        (d->fixed ? treb_rates2_fixed : treb_rates2_hinged)(d->q, y, dy);
    } else {
        (d->fixed ? treb_rates3_fixed : treb_rates3_hinged)(d->q, y, dy);
    }
}

static double event(const TrebDop *d, int j, double t, const double *y)
{
    double out[1], x[7];
    switch (d->ev_kind[j]) {
    case TREB_LIFT_OFF:
        if (d->friction) {
            memcpy(x, y, 4 * sizeof(double));
            treb_friction_solve(d->q, 1, d->fixed, y, x + 4);
            (d->fixed ? treb_lift_off_fixed_friction : treb_lift_off_hinged_friction)(d->q, x,
                                                                                       out);
        } else {
            (d->fixed ? treb_lift_off_fixed : treb_lift_off_hinged)(d->q, y, out);
        }
        break;
    case TREB_SLING_UPRIGHT:
        treb_sling_upright(d->q, y, out);
        break;
    case TREB_GROUND:
        treb_ground(d->q, y, out);
        break;
    case TREB_RELEASE_TIME:
        x[0] = t;
        x[1] = d->ev_par[j];
        treb_release_time(d->q, x, out);
        break;
    default:
        memcpy(x, y, 6 * sizeof(double));
        x[6] = d->ev_par[j];
        treb_climb(d->q, x, out);
    }
    return out[0];
}

/* ------------------------------------------------------------------ DOP853 */

static void stage(const double *y, double h, double K[TREB_NX][TREB_MAXN], int s, int n,
                  double *out)
{
    for (int i = 0; i < n; i++) {
        double acc = 0.0;
        for (int j = 0; j < s; j++) acc += TREB_A[s][j] * K[j][i];
        out[i] = y[i] + h * acc;
    }
}

/* One step from d->y with K[0] = f(y): K[1..12], y_new; the error norm (accept below 1). */
static double step(TrebDop *d, double h, double K[TREB_NX][TREB_MAXN], double *y_new)
{
    int n = d->n;
    double tmp[TREB_MAXN];
    for (int s = 1; s < TREB_NS; s++) {
        stage(d->y, h, K, s, n, tmp);
        rhs(d, tmp, K[s]);
    }
    for (int i = 0; i < n; i++) {
        double acc = 0.0;
        for (int j = 0; j < TREB_NS; j++) acc += TREB_B[j] * K[j][i];
        y_new[i] = d->y[i] + h * acc;
    }
    rhs(d, y_new, K[TREB_NS]);
    d->nfev += TREB_NS;
    double s5 = 0.0, s3 = 0.0;
    for (int i = 0; i < n; i++) {
        double sc = d->atol + d->rtol * fmax(fabs(d->y[i]), fabs(y_new[i]));
        double e5 = 0.0, e3 = 0.0;
        for (int j = 0; j < TREB_NS + 1; j++) {
            e5 += TREB_E5[j] * K[j][i];
            e3 += TREB_E3[j] * K[j][i];
        }
        e5 /= sc;
        e3 /= sc;
        s5 += e5 * e5;
        s3 += e3 * e3;
    }
    if (s5 == 0.0 && s3 == 0.0) return 0.0;
    return fabs(h) * s5 / sqrt((s5 + 0.01 * s3) * n);
}

static void dense(TrebDop *d, double h, const double *y_new, double K[TREB_NX][TREB_MAXN],
                  TrebStep *st)
{
    int n = d->n;
    double tmp[TREB_MAXN];
    for (int s = TREB_NS + 1; s < TREB_NX; s++) {
        stage(d->y, h, K, s, n, tmp);
        rhs(d, tmp, K[s]);
    }
    d->nfev += 3;
    for (int i = 0; i < n; i++) {
        double dy = y_new[i] - d->y[i];
        st->F[0][i] = dy;
        st->F[1][i] = h * K[0][i] - dy;
        st->F[2][i] = 2.0 * dy - h * (K[TREB_NS][i] + K[0][i]);
        for (int p = 0; p < TREB_NP - 3; p++) {
            double acc = 0.0;
            for (int j = 0; j < TREB_NX; j++) acc += TREB_D[p][j] * K[j][i];
            st->F[3 + p][i] = h * acc;
        }
    }
}

/* The step's polynomial at x = (t - t_step)/h (Horner in x and 1 - x, as DOP853). */
static void interp(const TrebStep *st, int n, double x, double *out)
{
    double u = 1.0 - x;
    for (int i = 0; i < n; i++) {
        double v = st->F[TREB_NP - 1][i] * x;
        for (int p = TREB_NP - 2; p >= 0; p--) {
            v += st->F[p][i];
            v *= (p % 2) ? u : x;
        }
        out[i] = v + st->y[i];
    }
}

static double next_step_size(double h_abs, double err, int rejected)
{
    if (err < 1.0) {
        double factor = err == 0.0 ? MAX_FACTOR
                                   : fmin(MAX_FACTOR, SAFETY * pow(err, ERROR_EXPONENT));
        if (rejected && factor > 1.0) factor = 1.0;
        return h_abs * factor;
    }
    if (err == err) return h_abs * fmax(MIN_FACTOR, SAFETY * pow(err, ERROR_EXPONENT));
    return h_abs * MIN_FACTOR;
}

static int crossed(double g_old, double g_new, double direction)
{
    int up = g_old <= 0.0 && 0.0 <= g_new;
    int down = g_old >= 0.0 && 0.0 >= g_new;
    if (direction > 0) return up;
    if (direction < 0) return down;
    return up || down;
}

static double event_at(const TrebDop *d, int j, double t, const TrebStep *st)
{
    double y[TREB_MAXN];
    interp(st, d->n, (t - st->t) / st->h, y);
    return event(d, j, t, y);
}

/* Brent's method, step for step as scipy's brentq.c with xtol = rtol = 4 eps. */
static double brent(const TrebDop *d, int j, double xa, double xb, double fa, double fb,
                    const TrebStep *st)
{
    double xpre = xa, xcur = xb, fpre = fa, fcur = fb;
    double xblk = 0.0, fblk = 0.0, spre = 0.0, scur = 0.0;
    for (int it = 0; it < 100; it++) {
        if (fpre != 0.0 && fcur != 0.0 && ((fpre < 0.0) != (fcur < 0.0))) {
            xblk = xpre;
            fblk = fpre;
            spre = scur = xcur - xpre;
        }
        if (fabs(fblk) < fabs(fcur)) {
            xpre = xcur; xcur = xblk; xblk = xpre;
            fpre = fcur; fcur = fblk; fblk = fpre;
        }
        double delta = (XTOL + XTOL * fabs(xcur)) / 2.0;
        double sbis = (xblk - xcur) / 2.0;
        if (fcur == 0.0 || fabs(sbis) < delta) return xcur;
        if (fabs(spre) > delta && fabs(fcur) < fabs(fpre)) {
            double stry;
            if (xpre == xblk) {
                stry = -fcur * (xcur - xpre) / (fcur - fpre);
            } else {
                double dpre = (fpre - fcur) / (xpre - xcur);
                double dblk = (fblk - fcur) / (xblk - xcur);
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre));
            }
            if (2.0 * fabs(stry) < fmin(fabs(spre), 3.0 * fabs(sbis) - delta)) {
                spre = scur;
                scur = stry;
            } else {
                spre = scur = sbis;
            }
        } else {
            spre = scur = sbis;
        }
        xpre = xcur;
        fpre = fcur;
        if (fabs(scur) > delta) xcur += scur;
        else xcur += sbis > 0.0 ? delta : -delta;
        fcur = event_at(d, j, xcur, st);
    }
    return xcur;
}

static double locate(const TrebDop *d, int j, const TrebStep *st, double g0, double g1)
{
    double t0 = st->t, t1 = st->t + st->h;
    if (g0 == 0.0) return t0;
    if (g1 == 0.0) return t1;
    double ga = event_at(d, j, t0, st), gb = event_at(d, j, t1, st);
    if (ga == 0.0) return t0;
    if (gb == 0.0 || ((ga > 0.0) == (gb > 0.0))) return fabs(gb) <= fabs(ga) ? t1 : t0;
    return brent(d, j, t0, t1, ga, gb, st);
}

/* Hairer's starting step, as scipy's select_initial_step; one right-hand-side call. */
static double initial_step(TrebDop *d)
{
    int n = d->n;
    double span = fabs(d->t_bound - d->t);
    if (span == 0.0) return 0.0;
    double d0 = 0.0, d1 = 0.0, y1[TREB_MAXN], f1[TREB_MAXN];
    for (int i = 0; i < n; i++) {
        double sc = d->atol + fabs(d->y[i]) * d->rtol;
        d0 += (d->y[i] / sc) * (d->y[i] / sc);
        d1 += (d->f[i] / sc) * (d->f[i] / sc);
    }
    d0 = sqrt(d0 / n);
    d1 = sqrt(d1 / n);
    double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    h0 = fmin(h0, span);
    for (int i = 0; i < n; i++) y1[i] = d->y[i] + h0 * d->f[i];
    rhs(d, y1, f1);
    d->nfev += 1;
    double d2 = 0.0;
    for (int i = 0; i < n; i++) {
        double sc = d->atol + fabs(d->y[i]) * d->rtol;
        d2 += ((f1[i] - d->f[i]) / sc) * ((f1[i] - d->f[i]) / sc);
    }
    d2 = sqrt(d2 / n) / h0;
    double h1 = (d1 <= 1e-15 && d2 <= 1e-15) ? fmax(1e-6, h0 * 1e-3)
                                             : pow(0.01 / fmax(d1, d2), 1.0 / 8.0);
    return fmin(fmin(100.0 * h0, h1), span);
}

static void dop_start(TrebDop *d, int kind, int n, const TrebScene *sc, double t0,
                      const double *y0, double t_bound, double first_step, int nev,
                      const int *ev_kind, const double *ev_par)
{
    memset(d, 0, sizeof *d);
    d->kind = kind;
    d->n = n;
    d->fixed = sc->fixed;
    d->friction = kind != TREB_DRAG_FLIGHT && sc->friction;
    memcpy(d->q, sc->q, sizeof d->q);
    d->k_drag = sc->k_drag;
    double rtol = sc->rtol > 0.0 ? sc->rtol : RTOL;
    d->rtol = kind == TREB_DRAG_FLIGHT ? FLIGHT_RTOL : rtol;
    d->atol = kind == TREB_DRAG_FLIGHT ? FLIGHT_ATOL : rtol * 1e-2;
    d->t = t0;
    d->t_bound = t_bound;
    memcpy(d->y, y0, n * sizeof(double));
    rhs(d, d->y, d->f);
    d->nfev = 1;
    d->nev = nev;
    for (int j = 0; j < nev; j++) {
        d->ev_kind[j] = ev_kind[j];
        d->ev_par[j] = ev_par[j];
        d->ev_dir[j] = DIRECTION[ev_kind[j]];
        d->g_old[j] = event(d, j, t0, d->y);
    }
    if (first_step > 0.0) d->h_abs = fmin(first_step, t_bound - t0);
    else d->h_abs = initial_step(d);
}

enum { STEP_ON = 0, STEP_EVENT = 1, STEP_END = 2, STEP_FAILED = -1 };

/* One accepted step into *st. STEP_EVENT: the first event that crossed, at *t_event with
 * state y_event, index *which; STEP_END: t_bound reached; STEP_FAILED: step too small. */
static int dop_step(TrebDop *d, TrebStep *st, double *t_event, double *y_event, int *which)
{
    double K[TREB_NX][TREB_MAXN], y_new[TREB_MAXN], g_new[TREB_MAXEV];
    int n = d->n, rejected = 0;
    double t = d->t, h = 0.0, t_new = t;
    double min_step = 10.0 * (nextafter(t, INFINITY) - t);
    if (d->h_abs < min_step) d->h_abs = min_step;
    for (;;) {
        if (!(d->h_abs >= min_step)) return STEP_FAILED;
        t_new = t + d->h_abs;
        if (t_new > d->t_bound) t_new = d->t_bound;
        h = t_new - t;
        d->h_abs = h;
        memcpy(K[0], d->f, n * sizeof(double));
        double err = step(d, h, K, y_new);
        d->h_abs = next_step_size(d->h_abs, err, rejected);
        if (err < 1.0) break;
        rejected = 1;
    }
    st->t = t;
    st->h = h;
    memcpy(st->y, d->y, n * sizeof(double));
    dense(d, h, y_new, K, st);
    int hit = 0, crossed_j[TREB_MAXEV];
    for (int j = 0; j < d->nev; j++) {
        g_new[j] = event(d, j, t_new, y_new);
        crossed_j[j] = crossed(d->g_old[j], g_new[j], d->ev_dir[j]);
        hit = hit || crossed_j[j];
    }
    d->t = t_new;
    memcpy(d->y, y_new, n * sizeof(double));
    memcpy(d->f, K[TREB_NS], n * sizeof(double));
    if (hit) {
        double te_best = t_new;
        *which = -1;
        for (int j = 0; j < d->nev; j++) {
            if (!crossed_j[j]) continue;
            double te = locate(d, j, st, d->g_old[j], g_new[j]);
            if (*which < 0 || te < te_best) {
                te_best = te;
                *which = j;
            }
        }
        *t_event = te_best;
        interp(st, n, (te_best - st->t) / st->h, y_event);
        return STEP_EVENT;
    }
    memcpy(d->g_old, g_new, sizeof g_new);
    return t_new >= d->t_bound ? STEP_END : STEP_ON;
}

/* ------------------------------------------------------------------ step stores */

static int push(TrebSteps *s, const TrebStep *st)
{
    if (s->n >= TREB_MAX_STEPS) return -1;  /* the budget: see treb_shot.h */
    if (s->n == s->cap) {
        int cap = s->cap ? 2 * s->cap : 256;
        TrebStep *data = realloc(s->data, (size_t)cap * sizeof(TrebStep));
        if (!data) return -1;
        s->data = data;
        s->cap = cap;
    }
    s->data[s->n++] = *st;
    return 0;
}

/* Index of the step of [first, first + count) that holds t: the last that starts before t
 * (a time on a step boundary takes the step that ends there), the first if none. */
static int find_step(const TrebSteps *s, int first, int count, double t)
{
    int lo = first, hi = first + count;  /* first index with start >= t */
    while (lo < hi) {
        int mid = lo + (hi - lo) / 2;
        if (s->data[mid].t < t) lo = mid + 1;
        else hi = mid;
    }
    int k = lo - 1;
    if (k < first) k = first;
    if (k > first + count - 1) k = first + count - 1;
    return k;
}

/* ------------------------------------------------------------------ the shot */

int treb_scene_rest(TrebScene *sc)
{
    double y_rest = 0.0, out[4], x[4];
    if (sc->projectile == 2) {
        x[0] = sc->theta; x[1] = sc->phi; x[2] = 0.0; x[3] = 0.0;
        treb_projectile(sc->q, x, out);
        y_rest = out[1];
    }
    x[0] = sc->theta; x[1] = sc->psi; x[2] = y_rest;
    treb_rest_energies(sc->q, x, sc->rest);
    if (sc->drag) {
        x[0] = sc->diameter; x[1] = sc->drag_coefficient; x[2] = sc->air_density;
        treb_drag_constant(sc->q, x, &sc->k_drag);
    }
    return 0;
}

void treb_shot_init_empty(TrebShot *s)
{
    memset(s, 0, sizeof *s);
    s->t_lift = s->t_rel = NAN;
}

void treb_shot_free(TrebShot *s)
{
    free(s->steps.data);
    free(s->flight.data);
    treb_shot_init_empty(s);
}

typedef struct {
    int status, which;
    double t_end, y_end[TREB_MAXN], last_full;
} PhaseEnd;

/* Integrate phase kind from t0 to t1 or its first event, storing every step. */
static int run_phase(TrebShot *s, int kind, double t0, double t1, const double *y0,
                     double first_step, int nev, const int *ev, const double *par, PhaseEnd *pe)
{
    TrebDop d;
    TrebStep st;
    int n = treb_state_size(&s->sc, kind), first = s->steps.n;
    dop_start(&d, kind, n, &s->sc, t0, y0, t1, first_step, nev, ev, par);
    memset(pe->y_end, 0, sizeof pe->y_end);
    pe->which = -1;
    for (;;) {
        int r = dop_step(&d, &st, &pe->t_end, pe->y_end, &pe->which);
        if (r == STEP_FAILED) {
            pe->status = -1;
            break;
        }
        if (push(&s->steps, &st)) return -1;
        if (r == STEP_EVENT) {
            pe->status = 1;
            break;
        }
        if (r == STEP_END) {
            pe->status = 0;
            pe->t_end = d.t;
            memcpy(pe->y_end, d.y, n * sizeof(double));
            break;
        }
    }
    int count = s->steps.n - first;
    pe->last_full = count >= 2 ? s->steps.data[s->steps.n - 1].t - s->steps.data[s->steps.n - 2].t
                               : 0.0;
    int k = s->n_phases++;
    s->phase[k] = kind;
    s->t0[k] = t0;
    s->t1[k] = pe->t_end;
    s->first[k] = first;
    s->nfev[k] = d.nfev;
    return 0;
}

static const char *const PHASE_NAME[4] = {"", "phase I", "phase II", "phase III"};

static int failed(char *msg, const char *what)
{
    snprintf(msg, TREB_MSG, "FMU parameters: the integration of %s failed: Required step size "
             "is less than spacing between numbers.", what);
    return -1;
}

/* A phase that outgrew TREB_MAX_STEPS (or the memory). */
static int no_room(char *msg, const char *what)
{
    snprintf(msg, TREB_MSG, "FMU parameters: the integration of %s needs more than %d steps "
             "(the FMU's budget) or more memory than there is: the engine is too stiff for "
             "the FMU (a sling or an arm far shorter than the others?)", what, TREB_MAX_STEPS);
    return -1;
}

/* Phase II from its start (saved in s) with the scene's release rules; then phase III. */
static int sling_and_after(TrebShot *s, char *msg)
{
    const TrebScene *sc = &s->sc;
    double t_rel = sc->has_time ? sc->t_release : INFINITY;
    int ev[3] = {TREB_GROUND, 0, 0}, nev = 1;
    double par[3] = {0.0, 0.0, 0.0};
    if (sc->has_time) { ev[nev] = TREB_RELEASE_TIME; par[nev++] = sc->t_release; }
    if (sc->has_angle) { ev[nev] = TREB_RELEASE_ANGLE; par[nev++] = sc->angle; }
    double t_stop = sc->has_angle ? TREB_MAX_SHOT : fmin(t_rel, TREB_MAX_SHOT);
    PhaseEnd pe;
    double first = s->p2_first_step > 0.0 ? fmin(s->p2_first_step, t_stop - s->p2_t0) : 0.0;
    if (run_phase(s, 2, s->p2_t0, t_stop, s->p2_y, first, nev, ev, par, &pe))
        return no_room(msg, PHASE_NAME[2]);
    if (pe.status < 0) return failed(msg, PHASE_NAME[2]);
    if (pe.status == 1 && pe.which == 0) {
        if (sc->has_time)
            snprintf(msg, TREB_MSG, "FMU parameters: [release] time = %g s: the projectile "
                     "strikes the ground at t = %.4g s while still in the sling; release it "
                     "earlier, use a shorter sling or raise the pivot", sc->t_release, pe.t_end);
        else
            snprintf(msg, TREB_MSG, "FMU parameters: [release] velocity_angle_deg = %g: the "
                     "projectile strikes the ground at t = %.4g s while still in the sling; "
                     "release it earlier, use a shorter sling or raise the pivot",
                     sc->angle * (180.0 / M_PI), pe.t_end);
        return -1;
    }
    if (pe.status == 0 && sc->has_angle) {
        snprintf(msg, TREB_MSG, "FMU parameters: [release] velocity_angle_deg = %g: the "
                 "projectile never climbs at that angle within %g s",
                 sc->angle * (180.0 / M_PI), TREB_MAX_SHOT);
        return -1;
    }
    s->t_rel = pe.t_end;
    double *y = pe.y_end, x[4] = {y[0], y[2], y[3], y[5]}, out[4];
    treb_projectile(sc->q, x, out);
    s->release[0] = pe.t_end;
    memcpy(s->release + 1, out, sizeof out);
    double beam[6] = {y[0], y[1], y[3], y[4], y[6], y[7]};  /* the lost energies go on */
    int k = s->n_phases++;
    s->phase[k] = 3;
    s->t0[k] = pe.t_end;
    s->t1[k] = INFINITY;
    s->first[k] = s->steps.n;
    dop_start(&s->open, 3, treb_state_size(sc, 3), sc, pe.t_end, beam,
              sc->bounded ? pe.t_end + sc->after_release : 1e300, pe.last_full, 0, NULL, NULL);
    s->flight_started = 0;
    s->flight.n = 0;
    return 0;
}

int treb_shot_start(TrebShot *s, const TrebScene *sc, char *msg)
{
    treb_shot_free(s);
    s->sc = *sc;
    double beam[6] = {sc->theta, sc->psi, 0.0, 0.0, 0.0, 0.0};  /* and the lost energies */
    double sling[2] = {sc->phi, 0.0}, t0 = 0.0, first = 0.0;
    if (sc->projectile == 3) {  /* dry fire: phase III from the start */
        int k = s->n_phases++;
        s->phase[k] = 3;
        s->t0[k] = 0.0;
        s->t1[k] = INFINITY;
        s->first[k] = 0;
        dop_start(&s->open, 3, treb_state_size(sc, 3), sc, 0.0, beam,
                  sc->bounded ? sc->after_release : 1e300, 0.0, 0, NULL, NULL);
        return 0;
    }
    if (sc->projectile == 1) {
        int ev[2] = {TREB_LIFT_OFF, TREB_SLING_UPRIGHT};
        double par[2] = {0.0, 0.0};
        PhaseEnd pe;
        if (run_phase(s, 1, 0.0, TREB_MAX_SHOT, beam, 0.0, 2, ev, par, &pe))
            return no_room(msg, PHASE_NAME[1]);
        if (pe.status < 0) return failed(msg, PHASE_NAME[1]);
        if (pe.status != 1) {
            snprintf(msg, TREB_MSG, "FMU parameters: [engine] the projectile did not lift off "
                     "within %g s: the counterweight (M = %g kg, L2 = %g m) cannot swing the beam "
                     "(I = %g kg m2, m_b = %g kg) and the projectile (m = %g kg) fast enough; a "
                     "heavier counterweight, a lighter beam or projectile would", TREB_MAX_SHOT,
                     sc->q[TREB_Q_M], sc->q[TREB_Q_L2], sc->q[TREB_Q_I], sc->q[TREB_Q_m_b],
                     sc->q[TREB_Q_m]);
            return -1;
        }
        if (pe.which == 1) {
            snprintf(msg, TREB_MSG, "FMU parameters: [engine] M = %g kg: the counterweight cannot "
                     "lift the projectile: at t = %.4g s the sling stands vertical over a "
                     "projectile still in the trough; use a heavier counterweight, a lighter "
                     "projectile or a longer sling", sc->q[TREB_Q_M], pe.t_end);
            return -1;
        }
        if (sc->has_time && pe.t_end >= sc->t_release) {
            snprintf(msg, TREB_MSG, "FMU parameters: [release] time = %g s comes before lift-off "
                     "at %.4g s: the projectile is still in the trough", sc->t_release, pe.t_end);
            return -1;
        }
        s->t_lift = pe.t_end;
        memcpy(beam, pe.y_end, treb_state_size(sc, 1) * sizeof(double));
        double out[TREB_N_OUTPUTS];
        treb_outputs_of(sc, 1, beam, out);
        sling[0] = out[TREB_OUT_phi];
        sling[1] = out[TREB_OUT_phi_d];
        t0 = pe.t_end;
        first = pe.last_full;
    }
    if (sc->has_time && sc->t_release <= t0) {
        snprintf(msg, TREB_MSG, "FMU parameters: [release] time = %g s: must come after the "
                 "start of phase II at %.4g s", sc->t_release, t0);
        return -1;
    }
    s->p2_phase_index = s->n_phases;
    s->p2_t0 = t0;
    s->p2_first_step = first;
    double y2[8] = {beam[0], beam[1], sling[0], beam[2], beam[3], sling[1], beam[4], beam[5]};
    memcpy(s->p2_y, y2, sizeof y2);
    return sling_and_after(s, msg);
}

static const Formula OUTPUTS_FRICTION[2][4] = {
    {treb_outputs1_hinged_friction, treb_outputs2_hinged_friction, treb_outputs3_hinged_friction,
     treb_outputs3_hinged_dry_friction},
    {treb_outputs1_fixed_friction, treb_outputs2_fixed_friction, treb_outputs3_fixed_friction,
     treb_outputs3_fixed_dry_friction}};

void treb_outputs_of(const TrebScene *sc, int phase, const double *y, double *out)
{
    double x[TREB_MAXN + 5];
    int n = treb_state_size(sc, phase);
    memcpy(x, y, n * sizeof(double));
    if (sc->friction) {  /* state, lost energies, the couples' Q, energies at rest */
        treb_friction_solve(sc->q, phase, sc->fixed, y, x + n);
        memcpy(x + n + 2, sc->rest, 3 * sizeof(double));
        int k = phase == 3 && sc->projectile == 3 ? 3 : phase - 1;
        OUTPUTS_FRICTION[sc->fixed != 0][k](sc->q, x, out);
        return;
    }
    memcpy(x + n, sc->rest, 3 * sizeof(double));
    if (phase == 1) (sc->fixed ? treb_outputs1_fixed : treb_outputs1_hinged)(sc->q, x, out);
    else if (phase == 2) (sc->fixed ? treb_outputs2_fixed : treb_outputs2_hinged)(sc->q, x, out);
    else if (sc->projectile == 3)
        (sc->fixed ? treb_outputs3_fixed_dry : treb_outputs3_hinged_dry)(sc->q, x, out);
    else (sc->fixed ? treb_outputs3_fixed : treb_outputs3_hinged)(sc->q, x, out);
}

/* The projectile after release at t: x, y, vx, vy, E_m into out. */
void treb_flight_at(TrebShot *s, double t, double *out)
{
    const double *r = s->release;
    if (!s->sc.drag) {
        double x[7] = {t, r[0], r[1], r[2], r[3], r[4], s->sc.rest[0]};
        treb_vacuum_flight(s->sc.q, x, out);
        return;
    }
    double state[4];
    if (t <= r[0]) {
        memcpy(state, r + 1, sizeof state);
    } else {
        if (!s->flight_started) {
            dop_start(&s->flight_dop, TREB_DRAG_FLIGHT, 4, &s->sc, r[0], r + 1, 1e300, 0.0, 0,
                      NULL, NULL);
            s->flight.n = 0;
            s->flight_started = 1;
        }
        TrebStep st;
        double te, ye[TREB_MAXN];
        int which;
        while (s->flight_dop.t < t) {
            if (dop_step(&s->flight_dop, &st, &te, ye, &which) == STEP_FAILED) break;
            if (push(&s->flight, &st)) break;
        }
        if (s->flight.n == 0) {
            memcpy(state, r + 1, sizeof state);
        } else {
            int k = find_step(&s->flight, 0, s->flight.n, t);
            interp(&s->flight.data[k], 4, (t - s->flight.data[k].t) / s->flight.data[k].h, state);
        }
    }
    double x[4] = {state[2], state[3], state[1], s->sc.rest[0]};
    out[0] = state[0];
    out[1] = state[1];
    out[2] = state[2];
    out[3] = state[3];
    treb_flight_energy(s->sc.q, x, out + 4);
}

/* The state at t of the phase of index k (k < 0: the phase holding t, the one that ends there
 * at an event) into y; returns that index, or -1 (-2: out of memory) with msg. */
int treb_shot_state(TrebShot *s, int k, double t, double *y, char *msg)
{
    if (s->n_phases < 1 || !(t <= (s->sc.bounded ? INFINITY : TREB_HORIZON))) {
        snprintf(msg, TREB_MSG, "the outputs at t = %g s: %s", t, s->n_phases < 1
                 ? "the shot is not initialised" : "beyond the FMU's horizon");
        return -1;
    }
    if (k < 0) {
        k = 0;
        while (k < s->n_phases - 1 && t > s->t1[k]) k++;
    }
    int last = s->n_phases - 1;
    if (k == last && s->phase[k] == 3) {  /* the open phase: integrate on to t (or its bound) */
        TrebStep st;
        double te, ye[TREB_MAXN];
        int which;
        while (s->open.t < t && s->open.t < s->open.t_bound) {
            if (dop_step(&s->open, &st, &te, ye, &which) == STEP_FAILED)
                return failed(msg, PHASE_NAME[3]);
            if (push(&s->steps, &st)) return no_room(msg, PHASE_NAME[3]);
        }
    }
    int count = (k == last ? s->steps.n : s->first[k + 1]) - s->first[k];
    int n = treb_state_size(&s->sc, s->phase[k]);
    if (count == 0) {
        memcpy(y, s->open.y, n * sizeof(double));
    } else {
        int j = find_step(&s->steps, s->first[k], count, t);
        const TrebStep *st = &s->steps.data[j];
        interp(st, n, (t - st->t) / st->h, y);
    }
    return k;
}

int treb_shot_outputs(TrebShot *s, double t, int *phase, double *out, char *msg)
{
    double y[TREB_MAXN];
    int k = treb_shot_state(s, -1, t, y, msg);
    if (k < 0) return k;
    *phase = s->phase[k];
    treb_outputs_of(&s->sc, *phase, y, out);
    if (*phase == 3 && s->sc.projectile != 3) {
        double f[5];
        treb_flight_at(s, t, f);
        out[TREB_OUT_x_m] = f[0];
        out[TREB_OUT_y_m] = f[1];
        out[TREB_OUT_vx_m] = f[2];
        out[TREB_OUT_vy_m] = f[3];
        out[TREB_OUT_E_m] = f[4];
    }
    return 0;
}

int treb_shot_command(TrebShot *s, double t_c, char *msg)
{
    if (s->sc.projectile == 3) {
        snprintf(msg, TREB_MSG, "release command at t = %.9g s ignored: a dry fire has no "
                 "projectile", t_c);
        return 1;
    }
    double lift = s->sc.projectile == 1 ? s->t_lift : 0.0;
    if (t_c <= lift) {
        snprintf(msg, TREB_MSG, "release command at t = %.9g s ignored: the projectile lies in "
                 "the trough until lift-off at %.9g s", t_c, lift);
        return 1;
    }
    if (t_c >= s->t_rel) {
        snprintf(msg, TREB_MSG, "release command at t = %.9g s ignored: the projectile was "
                 "released at %.9g s", t_c, s->t_rel);
        return 1;
    }
    s->sc.has_time = 1;
    s->sc.t_release = t_c;
    s->steps.n = s->first[s->p2_phase_index];
    s->n_phases = s->p2_phase_index;
    return sling_and_after(s, msg);
}

static int copy_steps(TrebSteps *dst, const TrebSteps *src)
{
    dst->data = NULL;
    dst->n = dst->cap = 0;
    if (src->n == 0) return 0;
    dst->data = malloc((size_t)src->n * sizeof(TrebStep));
    if (!dst->data) return -1;
    memcpy(dst->data, src->data, (size_t)src->n * sizeof(TrebStep));
    dst->n = dst->cap = src->n;
    return 0;
}

int treb_shot_copy(TrebShot *dst, const TrebShot *src)
{
    *dst = *src;
    if (copy_steps(&dst->steps, &src->steps) || copy_steps(&dst->flight, &src->flight)) {
        free(dst->steps.data);
        free(dst->flight.data);
        treb_shot_init_empty(dst);
        return -1;
    }
    return 0;
}

size_t treb_shot_serialized_size(const TrebShot *s)
{
    return sizeof(TrebShot) + (size_t)(s->steps.n + s->flight.n) * sizeof(TrebStep);
}

void treb_shot_serialize(const TrebShot *s, unsigned char *buf)
{
    TrebShot head = *s;
    head.steps.data = NULL;
    head.flight.data = NULL;
    memcpy(buf, &head, sizeof head);
    buf += sizeof head;
    if (s->steps.n) memcpy(buf, s->steps.data, (size_t)s->steps.n * sizeof(TrebStep));
    buf += (size_t)s->steps.n * sizeof(TrebStep);
    if (s->flight.n) memcpy(buf, s->flight.data, (size_t)s->flight.n * sizeof(TrebStep));
}

static TrebStep *steps_from(const unsigned char *buf, int n)
{
    TrebStep *a = malloc(n ? (size_t)n * sizeof(TrebStep) : 1);
    if (a && n) memcpy(a, buf, (size_t)n * sizeof(TrebStep));
    return a;
}

/* The shot of buf (size bytes exactly): its counts are checked here, the rest by
 * treb_shot_check. The pointers of the bytes are never used. */
int treb_shot_deserialize(TrebShot *s, const unsigned char *buf, size_t size, char *msg)
{
    TrebShot head;
    if (size < sizeof head) {
        snprintf(msg, TREB_MSG, "the shot is cut short (%lu bytes)", (unsigned long)size);
        return -1;
    }
    memcpy(&head, buf, sizeof head);
    int n = head.steps.n, nf = head.flight.n;
    if (n < 0 || n > TREB_MAX_STEPS || nf < 0 || nf > TREB_MAX_STEPS) {
        snprintf(msg, TREB_MSG, "the shot's step counts (%d, %d) lie outside 0..%d", n, nf,
                 TREB_MAX_STEPS);
        return -1;
    }
    size_t need = sizeof head + ((size_t)n + (size_t)nf) * sizeof(TrebStep);
    if (size != need) {
        snprintf(msg, TREB_MSG, "the shot's %d + %d steps need %lu bytes, the state has %lu",
                 n, nf, (unsigned long)need, (unsigned long)size);
        return -1;
    }
    TrebStep *a = steps_from(buf + sizeof head, n);
    TrebStep *b = steps_from(buf + sizeof head + (size_t)n * sizeof(TrebStep), nf);
    if (!a || !b) {
        free(a);
        free(b);
        snprintf(msg, TREB_MSG, "out of memory");
        return -1;
    }
    free(s->steps.data);
    free(s->flight.data);
    *s = head;
    s->steps.data = a;
    s->steps.cap = n;
    s->flight.data = b;
    s->flight.cap = nf;
    return 0;
}

/* ------------------------------------------------------------------ checks of a read shot */

static int all_finite(const double *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i])) return 0;
    return 1;
}

static int bad(char *msg, const char *what)
{
    snprintf(msg, TREB_MSG, "%s", what);
    return -1;
}

/* The states of a phase that are checked to be finite: those run_phase and
 * treb_shot_outputs use today. Memory stays safe whatever they become (every array has
 * TREB_MAXN entries, and a size is only checked to lie in 1..TREB_MAXN); a state the check
 * misses gives a non-finite output, which is refused where it is computed. */
static int checked_states(const TrebScene *sc, int phase)
{
    int n = treb_state_size(sc, phase);  /* with friction: the two lost energies too */
    return n < TREB_MAXN ? n : TREB_MAXN;
}

/* An integration read from bytes: kinds, sizes and numbers in range, the scene's q. */
static int check_dop(const TrebDop *d, const TrebScene *sc, int kind, char *msg)
{
    if (d->kind != kind || d->n < 1 || d->n > TREB_MAXN || d->fixed != sc->fixed)
        return bad(msg, "an integration's kind or size is not the phase's");
    if (memcmp(d->q, sc->q, sizeof d->q) != 0 || memcmp(&d->k_drag, &sc->k_drag, sizeof
                                                          d->k_drag) != 0)
        return bad(msg, "an integration's parameters are not the scene's");
    int drag = kind == TREB_DRAG_FLIGHT;
    double rtol = sc->rtol > 0.0 ? sc->rtol : RTOL;  /* the scene's (in process) or the FMU's */
    if (d->rtol != (drag ? FLIGHT_RTOL : rtol) || d->atol != (drag ? FLIGHT_ATOL : rtol * 1e-2))
        return bad(msg, "an integration's tolerances are not the FMU's");
    if (d->nev < 0 || d->nev > TREB_MAXEV) return bad(msg, "an event count lies out of range");
    for (int j = 0; j < d->nev; j++) {
        int k = d->ev_kind[j];
        if (k < TREB_LIFT_OFF || k > TREB_RELEASE_ANGLE || d->ev_dir[j] != DIRECTION[k]
            || !isfinite(d->ev_par[j]) || !isfinite(d->g_old[j]))
            return bad(msg, "an event's kind or numbers lie out of range");
    }
    if (!isfinite(d->t) || !(d->t_bound >= d->t) || !isfinite(d->h_abs) || d->h_abs < 0.0
        || !all_finite(d->y, d->n) || !all_finite(d->f, d->n) || d->nfev < 0)
        return bad(msg, "an integration's time, step or state is not a finite number");
    return 0;
}

/* Steps [first, end) of a phase with n states: finite, forward, in time order. */
static int check_steps(const TrebSteps *s, int first, int end, int n, char *msg)
{
    for (int i = first; i < end; i++) {
        const TrebStep *st = &s->data[i];
        if (!isfinite(st->t) || !isfinite(st->h) || !(st->h > 0.0) || !all_finite(st->y, n))
            return bad(msg, "a step's time, size or state is not a finite number");
        for (int p = 0; p < TREB_NP; p++)
            if (!all_finite(st->F[p], n)) return bad(msg, "a step's polynomial is not finite");
        if (i > first && !(st->t > s->data[i - 1].t))
            return bad(msg, "the steps are not in time order");
    }
    return 0;
}

/* Phases: kinds in order, first steps ascending, times joined, the open phase III. */
static int check_phases(const TrebShot *s, char *msg)
{
    int last = s->n_phases - 1;
    for (int k = 0; k <= last; k++) {
        int end = k < last ? s->first[k + 1] : s->steps.n;
        if (s->phase[k] < 1 || s->phase[k] > 3 || (k > 0 && s->phase[k] != s->phase[k - 1] + 1))
            return bad(msg, "a phase's kind lies out of range or order");
        if ((k == 0 && s->first[k] != 0) || s->first[k] < 0 || end < s->first[k]
            || end > s->steps.n)
            return bad(msg, "a phase's first step lies out of range");
        if (!isfinite(s->t0[k]) || (k < last && !(s->t1[k] == s->t0[k + 1]))
            || (k == last && s->phase[k] == 3 && s->t1[k] != INFINITY)
            || (s->phase[k] != 3 && !isfinite(s->t1[k])))
            return bad(msg, "a phase's times are not joined");
        if (check_steps(&s->steps, s->first[k], end, checked_states(&s->sc, s->phase[k]), msg))
            return -1;
    }
    if (last >= 0 && s->phase[last] == 3) {
        if (check_dop(&s->open, &s->sc, 3, msg)) return -1;
        if (!(s->open.t >= s->t0[last])) return bad(msg, "phase III starts after its end");
    }
    return 0;
}

int treb_shot_check(const TrebShot *s, int cosim, int complete, char *msg)
{
    const TrebScene *sc = &s->sc;
    if (s->n_phases < 0 || s->n_phases > 3 || s->steps.n < 0 || s->steps.n > TREB_MAX_STEPS
        || s->flight.n < 0 || s->flight.n > TREB_MAX_STEPS)
        return bad(msg, "a count of phases or steps lies out of range");
    if (!cosim && (s->n_phases != 0 || s->steps.n != 0))
        return bad(msg, "a model exchange's state holds the phases of a co-simulation");
    if (complete) {
        int first = sc->projectile, count = 4 - sc->projectile;
        if (s->n_phases != count || s->phase[0] != first || s->phase[count - 1] != 3)
            return bad(msg, "the shot's phases are not those of its scene");
    }
    if (check_phases(s, msg)) return -1;
    if (sc->projectile != 3 && s->n_phases > 0
        && (s->p2_phase_index < 0 || s->p2_phase_index >= s->n_phases
            || s->phase[s->p2_phase_index] != 2))
        return bad(msg, "phase II's index lies out of range");
    if (!isfinite(s->p2_t0) || !isfinite(s->p2_first_step) || s->p2_first_step < 0.0
        || !all_finite(s->p2_y, 6) || !all_finite(s->release, 5)
        || (!isnan(s->t_lift) && !isfinite(s->t_lift)) || (!isnan(s->t_rel) && !isfinite(s->t_rel)))
        return bad(msg, "an event time or the release is not a finite number");
    if (s->flight_started != 0 && s->flight_started != 1)
        return bad(msg, "the flight's flag is neither 0 nor 1");
    if (s->flight.n > 0 && !s->flight_started)
        return bad(msg, "flight steps without a flight");
    if (s->flight_started) {
        if (check_dop(&s->flight_dop, sc, TREB_DRAG_FLIGHT, msg)) return -1;
        if (!(s->flight_dop.t >= s->release[0])) return bad(msg, "the flight starts after its end");
    }
    return check_steps(&s->flight, 0, s->flight.n, s->flight_dop.n, msg);
}

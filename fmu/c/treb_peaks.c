/* A design's figures over the continuous shot: see treb_peaks.h. The search is
 * model/summary_kernel.py's (its numba kernel, the fallback without a compiler), step for
 * step: the same samples, brackets, golden sections and parabolas. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "treb_peaks.h"

/* out[]'s names, space-separated (trebuchet.model.c_peaks checks its own against them) */
const char *treb_engine_design_names(void)
{
    return "F_S_abs F_H_abs F_R_abs F_R_perp_abs torque_abs -sling_tension -y_M energy_sum_abs "
           "t:F_S_abs t:F_H_abs t:F_R_abs t:F_R_perp_abs t:torque_abs t:-sling_tension t:-y_M "
           "t:energy_sum_abs t_lift t_release release_t release_x release_y release_vx "
           "release_vy E_m_release loss_release t_end";
}

#define TREB_MEMO 32  /* the last states' quantities kept: brackets shared by several */

typedef struct {
    TrebShot *s;
    double em;             /* the projectile's energy over rest after release, J */
    double samples, share;
    int golden, parabola;
    /* the quantities at the last TREB_MEMO times evaluated (the same time of the same phase
     * gives the same numbers: the golden sections of several extrema in one bracket start
     * at the same two times) */
    int memo_n, memo_next, memo_p[TREB_MEMO];
    double memo_t[TREB_MEMO], memo_v[TREB_MEMO][TREB_N_PEAKS];
} Search;

typedef struct {
    double t;
    int p;
    double v[TREB_N_PEAKS];
} Sample;

typedef void (*Formula)(const double *, const double *, double *);

/* The generated columns of the search (TREB_PEAK_ROW_*): [friction][fixed][phase I, II, III,
 * III of a dry fire] */
static const Formula PEAK_ROWS[2][2][4] = {
    {{treb_rows1_hinged_peak, treb_rows2_hinged_peak, treb_rows3_hinged_peak,
      treb_rows3_hinged_dry_peak},
     {treb_rows1_fixed_peak, treb_rows2_fixed_peak, treb_rows3_fixed_peak,
      treb_rows3_fixed_dry_peak}},
    {{treb_rows1_hinged_friction_peak, treb_rows2_hinged_friction_peak,
      treb_rows3_hinged_friction_peak, treb_rows3_hinged_dry_friction_peak},
     {treb_rows1_fixed_friction_peak, treb_rows2_fixed_friction_peak,
      treb_rows3_fixed_friction_peak, treb_rows3_fixed_dry_friction_peak}}};

/* The extrema's quantities at the state y of phase kind (summary_kernel._values). */
static void values(const Search *x, int kind, const double *y, double *v)
{
    const TrebScene *sc = &x->s->sc;
    double in[TREB_ENGINE_INPUTS], row[TREB_N_PEAK_ROWS];
    int k = treb_engine_inputs(sc, kind, y, in);
    PEAK_ROWS[sc->friction != 0][sc->fixed != 0][k](sc->q, in, row);
    v[TREB_PEAK_F_S] = row[TREB_PEAK_ROW_F_S_abs];
    v[TREB_PEAK_F_H] = row[TREB_PEAK_ROW_F_H_abs];
    v[TREB_PEAK_F_R] = row[TREB_PEAK_ROW_F_R_abs];
    v[TREB_PEAK_F_R_PERP] = fabs(row[TREB_PEAK_ROW_F_R_perp]);
    v[TREB_PEAK_TORQUE] = fabs(row[TREB_PEAK_ROW_torque]);
    v[TREB_PEAK_TENSION] = kind <= 2 ? -row[TREB_PEAK_ROW_sling_tension] : -INFINITY;
    v[TREB_PEAK_CLEARANCE] = -row[TREB_PEAK_ROW_y_M];
    double e_m = kind <= 2 ? row[TREB_PEAK_ROW_E_m] : x->em;
    v[TREB_PEAK_DRIFT] = fabs(e_m + row[TREB_PEAK_ROW_E_M] + row[TREB_PEAK_ROW_E_beam]
                              + (row[TREB_PEAK_ROW_E_loss_pivot]
                                 + row[TREB_PEAK_ROW_E_loss_hinge]));
}

/* The quantities at time t of the phase of index p (summary_kernel._at). */
static int at(const Search *x, int p, double t, double *v, char *msg)
{
    double y[TREB_MAXN];
    int r = treb_shot_state(x->s, p, t, y, msg);
    if (r < 0) return r;
    values(x, x->s->phase[p], y, v);
    return 0;
}

/* Quantity j at time t of phase p, remembered (at); NAN (and *r set) if the state cannot be
 * had. */
static double at_j(Search *x, int p, int j, double t, int *r, char *msg)
{
    for (int i = 0; i < x->memo_n; i++)
        if (x->memo_t[i] == t && x->memo_p[i] == p) return x->memo_v[i][j];
    int k = x->memo_next;
    int e = at(x, p, t, x->memo_v[k], msg);
    if (e < 0) {
        *r = e;
        return NAN;
    }
    x->memo_t[k] = t;
    x->memo_p[k] = p;
    x->memo_next = (k + 1) % TREB_MEMO;
    if (x->memo_n < TREB_MEMO) x->memo_n++;
    return x->memo_v[k][j];
}

/* The index of the largest of f[0..m) (the first; the first NaN if any, as numpy's argmax). */
static int argmax(const double *f, int m)
{
    int best = 0;
    for (int i = 0; i < m; i++) {
        if (isnan(f[i])) return i;
        if (f[i] > f[best]) best = i;
    }
    return best;
}

/* The abscissa of the vertex of the parabola through three points (NAN if flat). */
static double vertex(double x1, double x2, double x3, double f1, double f2, double f3)
{
    double p = (x2 - x1) * (f2 - f3), q = (x2 - x3) * (f2 - f1), den = p - q;
    if (den == 0.0) return NAN;
    return x2 - 0.5 * ((x2 - x1) * p - (x2 - x3) * q) / den;
}

/* Largest value of quantity j of phase p on [a, b] (summary_kernel._locate_max), where it is
 * fa and fb (samples): golden sections, then parabolas through the best point and its
 * neighbours; the best point evaluated into *value, *time. */
static int locate_max(Search *x, int p, int j, double a, double b, double fa, double fb,
                      double *value, double *time, char *msg)
{
    const double gold = (sqrt(5.0) - 1.0) / 2.0;
    int r = 0;
    double c = b - gold * (b - a), d = a + gold * (b - a);
    double fc = at_j(x, p, j, c, &r, msg), fd = at_j(x, p, j, d, &r, msg);
    for (int k = 0; k < x->golden; k++) {
        if (fc >= fd) {
            b = d; fb = fd; d = c; fd = fc;
            c = b - gold * (b - a);
            fc = at_j(x, p, j, c, &r, msg);
        } else {
            a = c; fa = fc; c = d; fc = fd;
            d = a + gold * (b - a);
            fd = at_j(x, p, j, d, &r, msg);
        }
    }
    enum { MOST = 4 + 16 };
    double xs[MOST] = {a, c, d, b}, fs[MOST] = {fa, fc, fd, fb};
    int m = 4;
    for (int k = 0; k < x->parabola && m < MOST; k++) {
        for (int i = 1; i < m; i++)  /* in order of time (insertion: stable, as numpy's) */
            for (int h = i; h > 0 && xs[h - 1] > xs[h]; h--) {
                double tx = xs[h], tf = fs[h];
                xs[h] = xs[h - 1]; fs[h] = fs[h - 1];
                xs[h - 1] = tx; fs[h - 1] = tf;
            }
        int i = argmax(fs, m);
        if (i == 0 || i == m - 1) break;  /* the largest at an end: nothing to fit */
        double v = vertex(xs[i - 1], xs[i], xs[i + 1], fs[i - 1], fs[i], fs[i + 1]);
        if (!(xs[i - 1] < v && v < xs[i + 1])) break;
        xs[m] = v;
        fs[m++] = at_j(x, p, j, v, &r, msg);
    }
    int i = argmax(fs, m);
    *value = fs[i];
    *time = xs[i];
    return r;
}

/* The end of the phase of index p (the open one: as far as it is integrated). */
static double phase_end(const TrebShot *s, int p)
{
    return p == s->n_phases - 1 ? s->open.t : s->t1[p];
}

static long step_count(const TrebShot *s, int p)
{
    return (p == s->n_phases - 1 ? s->steps.n : s->first[p + 1]) - s->first[p];
}

/* One sample at t of phase p into smp[*m]. */
static int add(const Search *x, int p, double t, Sample *smp, long *m, char *msg)
{
    Sample *o = &smp[*m];
    int r = at(x, p, t, o->v, msg);
    if (r < 0) return r;
    o->t = t;
    o->p = p;
    ++*m;
    return 0;
}

/* Every phase's steps sampled (summary_kernel._samples): the samples of each step, with the
 * ends of the windows (t_hi, t_clear) and of the phase among them, up to the later window's
 * end; into smp, their count into *count. */
static int sample(const Search *x, double t_hi, double t_clear, Sample *smp, long *count,
                  char *msg)
{
    const TrebShot *s = x->s;
    double t_stop = fmax(t_hi, t_clear);
    long m = 0;
    for (int p = 0; p < s->n_phases; p++) {
        double t0 = s->t0[p], t_last = fmin(phase_end(s, p), t_stop);
        if (t_last < t0) continue;
        double special[3] = {t_hi, t_clear, t_last};
        for (int i = 1; i < 3; i++)
            for (int h = i; h > 0 && special[h - 1] > special[h]; h--) {
                double tmp = special[h];
                special[h] = special[h - 1];
                special[h - 1] = tmp;
            }
        int q = 0, r;
        long first = m, k0 = s->first[p], count_p = step_count(s, p);
        for (long k = k0; k < k0 + (count_p ? count_p : 1); k++) {
            double T = count_p ? s->steps.data[k].t : phase_end(s, p);
            double H = count_p ? s->steps.data[k].h : 1.0;  /* a phase of no steps: its end */
            for (int i = 0; i < (int)x->samples; i++) {
                double t = T + H * i / x->samples;
                if (t > t_last) break;
                while (q < 3 && special[q] < t) {
                    if (special[q] >= t0 && (m == first || special[q] > smp[m - 1].t))
                        if ((r = add(x, p, special[q], smp, &m, msg)) < 0) return r;
                    q++;
                }
                if (m > first && t <= smp[m - 1].t) continue;
                if ((r = add(x, p, t, smp, &m, msg)) < 0) return r;
            }
        }
        for (; q < 3; q++)
            if (t0 <= special[q] && special[q] <= t_last
                && (m == first || special[q] > smp[m - 1].t))
                if ((r = add(x, p, special[q], smp, &m, msg)) < 0) return r;
    }
    *count = m;
    return 0;
}

/* The extrema and their times (summary_kernel._reduce): the best sample of each within its
 * window, then every local best of the samples near it located on the dense output. */
static int reduce(Search *x, double t_hi, double t_clear, const Sample *smp, long n,
                  double *value, double *time, char *msg)
{
    for (int j = 0; j < TREB_N_PEAKS; j++) {
        double w = j == TREB_PEAK_CLEARANCE ? t_clear : t_hi, best = -INFINITY;
        time[j] = NAN;
        for (long i = 0; i < n; i++)
            if (smp[i].t <= w && smp[i].v[j] > best) {
                best = smp[i].v[j];
                time[j] = smp[i].t;
            }
        value[j] = best;
        if (j == TREB_PEAK_DRIFT || !isfinite(best)) continue;
        double floor = best - x->share * fabs(best);
        for (long i = 0; i < n; i++) {
            int p = smp[i].p;
            if (smp[i].t > w || smp[i].v[j] < floor) continue;
            long left = i > 0 && smp[i - 1].p == p ? i - 1 : i;
            long right = i < n - 1 && smp[i + 1].p == p && smp[i + 1].t <= w ? i + 1 : i;
            if (left == right || smp[left].v[j] > smp[i].v[j] || smp[right].v[j] > smp[i].v[j])
                continue;
            double found, when;
            int r = locate_max(x, p, j, smp[left].t, smp[right].t, smp[left].v[j],
                               smp[right].v[j], &found, &when, msg);
            if (r < 0) return r;
            if (found > value[j]) {
                value[j] = found;
                time[j] = when;
            }
        }
    }
    return 0;
}

/* The figures of the started shot s (TREB_DESIGN_*) into out: the extrema over the shot to
 * `after` s past the release (a dry fire: its end), the clearance to `clear_window` s past
 * it, by the search of settings `search`. Returns 0, or -1 (msg says why) or -2 (no memory). */
int treb_engine_peaks(TrebShot *s, double after, double clear_window, const double *search,
                      double *out, char *msg)
{
    Search x = {s, 0.0, search[TREB_SEARCH_SAMPLES], search[TREB_SEARCH_SHARE],
                (int)search[TREB_SEARCH_GOLDEN], (int)search[TREB_SEARCH_PARABOLA], 0, 0, {0},
                {0.0}, {{0.0}}};
    double t_end = phase_end(s, s->n_phases - 1), t_rel = s->t_rel;
    int dry = isnan(t_rel);
    for (int i = TREB_DESIGN_T_LIFT; i < TREB_N_DESIGN; i++) out[i] = NAN;
    out[TREB_DESIGN_T_LIFT] = s->t_lift;
    out[TREB_DESIGN_T_RELEASE] = t_rel;
    out[TREB_DESIGN_T_END] = t_end;
    if (!dry) {
        memcpy(out + TREB_DESIGN_RELEASE, s->release, 5 * sizeof(double));
        double v[4] = {s->release[3], s->release[4], s->release[2], s->sc.rest[0]};
        treb_flight_energy(s->sc.q, v, &x.em);
        double y[TREB_MAXN], row[TREB_N_ROWS];
        int k = treb_shot_state(s, -1, t_rel, y, msg);  /* phase II, which ends there */
        if (k < 0) return k;
        treb_engine_row(&s->sc, s->phase[k], y, row);
        out[TREB_DESIGN_LOSS_RELEASE] = s->sc.friction ? row[TREB_ROW_E_loss_pivot]
                                                         + row[TREB_ROW_E_loss_hinge] : 0.0;
    }
    out[TREB_DESIGN_E_M_RELEASE] = x.em;
    double t_hi = dry ? t_end : t_rel + after, t_clear = dry ? t_end : t_rel + clear_window;
    long total = (s->steps.n + s->n_phases + 1) * ((long)x.samples + 1) + 4 * s->n_phases, n;
    Sample *smp = malloc((size_t)total * sizeof *smp);
    if (!smp) return -2;
    int r = sample(&x, t_hi, t_clear, smp, &n, msg);
    if (r == 0) r = reduce(&x, t_hi, t_clear, smp, n, out + TREB_DESIGN_VALUE,
                           out + TREB_DESIGN_TIME, msg);
    free(smp);
    return r;
}

/* n designs, each a shot (treb_engine_start's q, flags and par, one row of each per design)
 * and its figures (treb_engine_peaks, `after[i]` s past the release) into out's row i;
 * status[i]: 0, or -1 where the engine refuses the design (the caller words it), -2 out of
 * memory. Returns the least status. */
int treb_engine_designs(long n, const double *q, const int *flags, const double *par,
                        const double *after, double clear_window, const double *search,
                        double *out, int *status)
{
    TrebShot *s = treb_engine_new();
    char msg[TREB_MSG];
    int least = 0;
    if (!s) return -2;
    for (long i = 0; i < n; i++) {
        int r = treb_engine_start(s, q + i * TREB_NQ, flags + i * TREB_N_FLAGS,
                                  par + i * TREB_N_PARS, msg);
        if (r == 0)
            r = treb_engine_peaks(s, after[i], clear_window, search, out + i * TREB_N_DESIGN,
                                  msg);
        status[i] = r;
        if (r < least) least = r;
    }
    treb_engine_free(s);
    return least;
}

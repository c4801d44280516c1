/* A design's figures over the continuous shot, in one call (trebuchet.model.c_peaks): the
 * shot (treb_engine_start), then the peak search of model/summary_kernel.py on its steps:
 * every step sampled, every local best near the best located on the dense output by
 * golden-section search and parabolic interpolation. Hand-written glue only: the loads are
 * the generated row formulas (treb_rows.c) of treb_engine_row. Units: s, m, m/s, N, N m, J. */
#ifndef TREB_PEAKS_H
#define TREB_PEAKS_H

#include "treb_batch.h"

/* search[]: the search's settings, summary_kernel's SAMPLES_PER_STEP, GOLDEN_STEPS,
 * PARABOLA_STEPS and CANDIDATE_SHARE (passed in, so that they live in one place) */
enum { TREB_SEARCH_SAMPLES, TREB_SEARCH_GOLDEN, TREB_SEARCH_PARABOLA, TREB_SEARCH_SHARE,
       TREB_N_SEARCH };
/* The extrema, summary_kernel's EXTREMA in order: each a maximum of the quantity (a minimum
 * the maximum of its negative) */
enum { TREB_PEAK_F_S, TREB_PEAK_F_H, TREB_PEAK_F_R, TREB_PEAK_F_R_PERP, TREB_PEAK_TORQUE,
       TREB_PEAK_TENSION /* -sling_tension, held */, TREB_PEAK_CLEARANCE /* -y_M */,
       TREB_PEAK_DRIFT /* |energy sum|, its best sample */, TREB_N_PEAKS };
/* out[] of a design: the extrema (-INFINITY where no sample lies), their times (NAN there),
 * the events (NAN: none), the projectile at release (t, x, y, vx, vy), its energy over rest
 * at release (J; 0 in a dry fire), the friction's heat by the release (J; 0 without
 * friction) and the end of phase III (s) */
enum { TREB_DESIGN_VALUE = 0, TREB_DESIGN_TIME = TREB_N_PEAKS,
       TREB_DESIGN_T_LIFT = 2 * TREB_N_PEAKS, TREB_DESIGN_T_RELEASE, TREB_DESIGN_RELEASE,
       TREB_DESIGN_E_M_RELEASE = TREB_DESIGN_RELEASE + 5, TREB_DESIGN_LOSS_RELEASE,
       TREB_DESIGN_T_END, TREB_N_DESIGN };

const char *treb_engine_design_names(void);
int treb_engine_peaks(TrebShot *s, double after, double clear_window, const double *search,
                      double *out, char *msg);
int treb_engine_designs(long n, const double *q, const int *flags, const double *par,
                        const double *after, double clear_window, const double *search,
                        double *out, int *status);

#endif

/* One FMU instance: see treb_model.h. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "treb_model.h"

void treb_model_new(TrebModel *m, int cosim)
{
    memset(m, 0, sizeof *m);
    m->cosim = cosim;
    for (int i = 0; i < TREB_NV; i++) m->values[i] = TREB_VAR_START[i];
    treb_shot_init_empty(&m->shot);
}

void treb_model_free(TrebModel *m)
{
    treb_shot_free(&m->shot);
}

void treb_model_reset(TrebModel *m)
{
    int cosim = m->cosim;
    treb_model_free(m);
    treb_model_new(m, cosim);
}

/* n numbers named from value reference first on: -1 (and why in msg) if one is not finite. */
static int finite_values(const double *v, int n, int first, double t, const char *what,
                         char *msg)
{
    for (int j = 0; j < n; j++) {
        if (!isfinite(v[j])) {
            snprintf(msg, TREB_MSG, "the %s at t = %.9g s are not finite (%s = %g): the "
                     "parameters or states lie outside what the model can compute", what, t,
                     TREB_VAR_NAME[first + j], v[j]);
            return -1;
        }
    }
    return 0;
}

/* The outputs of phase into values; -1 if one is not finite (none is published then). A dry
 * fire has no projectile: its position and velocity are NaN by definition (as the
 * simulator's), every other output must be finite. */
static int publish(TrebModel *m, int phase, const double *out, char *msg)
{
    int dry = m->shot.sc.projectile == 3;
    for (int j = 0; j < TREB_N_OUTPUTS; j++) {
        if (!isfinite(out[j]) && !(dry && (j == TREB_OUT_x_m || j == TREB_OUT_y_m
                                           || j == TREB_OUT_vx_m || j == TREB_OUT_vy_m))) {
            finite_values(out + j, 1, TREB_VR_FIRST_OUTPUT + j, m->time, "outputs", msg);
            return -1;
        }
    }
    m->values[TREB_VR_phase] = phase;
    for (int j = 0; j < TREB_N_OUTPUTS; j++) m->values[TREB_VR_FIRST_OUTPUT + j] = out[j];
    m->outputs_valid = 1;
    return 0;
}

int treb_model_check_start(double start_time, char *msg)
{
    if (!(start_time >= 0.0 && start_time < TREB_HORIZON)) {
        snprintf(msg, TREB_MSG, "start time = %g s: the FMU's time is the time after the "
                 "trigger: it starts at 0 or later, before the FMU's horizon of %g s",
                 start_time, TREB_HORIZON);
        return -1;
    }
    return 0;
}

/* The start of a shot or of a model exchange; on failure the model holds no shot. */
static int start_model(TrebModel *m, double start_time, char *msg)
{
    TrebScene sc;
    if (treb_model_check_start(start_time, msg)) return -1;
    if (treb_scene_from_values(m->values, &sc, msg)) return -1;
    m->time = start_time;
    m->command_prev = m->values[TREB_VR_release_command] != 0.0;
    if (m->cosim) {
        int r = treb_shot_start(&m->shot, &sc, msg);
        if (r) return -1;
    } else {
        treb_shot_free(&m->shot);
        m->shot.sc = sc;
        m->phase = sc.projectile == 1 ? 1 : sc.projectile == 2 ? 2 : 3;
        double x[TREB_NX_STATES] = {sc.theta, sc.psi, sc.phi, 0.0, 0.0, 0.0, 0.0, 0.0};
        if (m->phase == 1) {  /* the sling on the trough constraint */
            double out[TREB_N_OUTPUTS];
            treb_outputs_of(&sc, 1, (double[6]){x[0], x[1], 0.0, 0.0, 0.0, 0.0}, out);
            x[2] = out[TREB_OUT_phi];
        } else if (m->phase == 3) {
            x[2] = 0.0;
        }
        memcpy(m->x, x, sizeof x);
        treb_model_indicators(m, m->z_ref);
    }
    m->initialized = 1;
    m->outputs_valid = 0;
    return treb_model_outputs(m, msg);
}

int treb_model_exit_init(TrebModel *m, double start_time, char *msg)
{
    if (start_model(m, start_time, msg) == 0) return 0;
    treb_shot_free(&m->shot);  /* a failed start leaves nothing half made */
    m->initialized = 0;
    m->phase = 0;
    return -1;
}

int treb_model_step(TrebModel *m, double t, double h, char *msg)
{
    int status = 0, command = m->values[TREB_VR_release_command] != 0.0;
    double end = t + h;
    msg[0] = '\0';
    if (!isfinite(t) || !isfinite(h) || t < 0.0 || h < 0.0) {
        snprintf(msg, TREB_MSG, "fmiDoStep: communication point %g s, step %g s: both must be "
                 "finite, the point 0 or later, the step 0 or more", t, h);
        return -1;
    }
    if (t > TREB_HORIZON) {
        snprintf(msg, TREB_MSG, "fmiDoStep: communication point %g s lies beyond the FMU's "
                 "horizon of %g s after the trigger", t, TREB_HORIZON);
        return -1;
    }
    if (end > TREB_HORIZON) end = TREB_HORIZON;
    if (command && !m->command_prev) {
        int r = treb_shot_command(&m->shot, t, msg);
        if (r < 0) return -1;
        status = r;
    }
    m->command_prev = command;
    double out[TREB_N_OUTPUTS];
    int phase;
    char err[TREB_MSG];
    if (treb_shot_outputs(&m->shot, end, &phase, out, err)) {
        memcpy(msg, err, TREB_MSG);
        return -1;
    }
    m->time = end;
    if (publish(m, phase, out, msg)) return -1;
    if (end < t + h) {
        snprintf(msg, TREB_MSG, "fmiDoStep: t + h = %g s lies beyond the FMU's horizon of %g s "
                 "after the trigger (a shot is released by then or refused): the FMU stopped "
                 "there; its outputs are those at %g s", t + h, TREB_HORIZON, TREB_HORIZON);
        return 2;
    }
    return status;
}

int treb_model_set_value(TrebModel *m, int vr, double value, char *msg)
{
    if (!isfinite(value)) {
        snprintf(msg, TREB_MSG, "FMU parameters: %s = %g: must be finite", TREB_VAR_NAME[vr],
                 value);
        return -1;
    }
    if (TREB_VAR_TYPE[vr] != TREB_REAL && treb_parameter_check(vr, value, msg)) return -1;
    m->values[vr] = value;
    return 0;
}

int treb_model_set_time(TrebModel *m, double t, char *msg)
{
    if (!isfinite(t) || t < 0.0) {
        snprintf(msg, TREB_MSG, "fmiSetTime: t = %g s: the time must be finite and 0 or later "
                 "(the time after the trigger)", t);
        return -1;
    }
    m->time = t;
    m->outputs_valid = 0;
    return 0;
}

int treb_model_set_states(TrebModel *m, const double *x, char *msg)
{
    if (finite_values(x, TREB_NX_STATES, TREB_VR_theta, m->time, "continuous states", msg))
        return -1;
    memcpy(m->x, x, sizeof m->x);
    m->outputs_valid = 0;
    return 0;
}

int treb_model_past_horizon(const TrebModel *m, char *msg)
{
    if (m->time < TREB_HORIZON) return 0;
    snprintf(msg, TREB_MSG, "t = %g s: the FMU's horizon of %g s after the trigger is reached "
             "(a shot is released by then or refused): the simulation ends here", m->time,
             TREB_HORIZON);
    return 1;
}

/* The model exchange's phase state as the generated functions take it: the phase's angles and
 * rates, then (with friction) the lost energies in units of treb_energy_scale (the model
 * exchange's states hold them in J). */
static void phase_state(const TrebModel *m, double *y)
{
    int n = m->phase == 2 ? 6 : 4;
    if (m->phase == 2) {
        memcpy(y, m->x, 6 * sizeof(double));
    } else {
        y[0] = m->x[0]; y[1] = m->x[1]; y[2] = m->x[3]; y[3] = m->x[4];
    }
    if (m->shot.sc.friction) {
        double scale;
        treb_energy_scale(m->shot.sc.q, NULL, &scale);
        y[n] = m->x[6] / scale;
        y[n + 1] = m->x[7] / scale;
    }
}

/* Model exchange needs an initialised model (the scene exists from then on). */
static int initialised(const TrebModel *m, char *msg)
{
    if (m->initialized) return 1;
    snprintf(msg, TREB_MSG, "the model is evaluated after fmiExitInitializationMode only");
    return 0;
}

int treb_model_outputs(TrebModel *m, char *msg)
{
    if (m->outputs_valid) return 0;
    if (m->cosim) {
        double out[TREB_N_OUTPUTS];
        int phase;
        if (treb_shot_outputs(&m->shot, m->time, &phase, out, msg)) return -1;
        return publish(m, phase, out, msg);
    }
    if (!initialised(m, msg)) return -1;
    double y[TREB_MAXN], out[TREB_N_OUTPUTS];
    phase_state(m, y);
    treb_outputs_of(&m->shot.sc, m->phase, y, out);
    if (m->phase == 3 && m->shot.sc.projectile != 3) {
        double f[5];
        if (m->shot.sc.drag && !(m->time <= TREB_HORIZON)) {  /* integrated: bounded */
            snprintf(msg, TREB_MSG, "the projectile's flight with drag at t = %g s: beyond the "
                     "FMU's horizon of %g s after the trigger", m->time, TREB_HORIZON);
            return -1;
        }
        treb_flight_at(&m->shot, m->time, f);
        out[TREB_OUT_x_m] = f[0]; out[TREB_OUT_y_m] = f[1];
        out[TREB_OUT_vx_m] = f[2]; out[TREB_OUT_vy_m] = f[3]; out[TREB_OUT_E_m] = f[4];
    }
    return publish(m, m->phase, out, msg);
}

int treb_model_derivatives(TrebModel *m, double *dx, char *msg)
{
    double y[TREB_MAXN], out[TREB_N_OUTPUTS];
    if (!initialised(m, msg)) return -1;
    phase_state(m, y);
    treb_outputs_of(&m->shot.sc, m->phase, y, out);
    dx[0] = out[TREB_OUT_theta_d]; dx[1] = out[TREB_OUT_psi_d]; dx[2] = out[TREB_OUT_phi_d];
    dx[3] = out[TREB_OUT_theta_dd]; dx[4] = out[TREB_OUT_psi_dd]; dx[5] = out[TREB_OUT_phi_dd];
    dx[6] = out[TREB_OUT_P_loss_pivot]; dx[7] = out[TREB_OUT_P_loss_hinge];
    return finite_values(dx, TREB_NX_STATES, TREB_VR_theta_d, m->time, "derivatives", msg);
}

/* Phase I: lift-off margin F_N/(m g), sling upright margin; phase II: projectile height
 * (m), climb margin (m/s, with a release angle). Unused indicators are 1. */
void treb_model_indicators(TrebModel *m, double *z)
{
    const TrebScene *sc = &m->shot.sc;
    double y[TREB_MAXN];
    phase_state(m, y);
    z[0] = z[1] = z[2] = 1.0;
    if (m->phase == 1) {
        if (sc->friction) {
            double x[6] = {y[0], y[1], y[2], y[3], 0.0, 0.0};
            treb_friction_solve(sc->q, 1, sc->fixed, y, x + 4);
            (sc->fixed ? treb_lift_off_fixed_friction : treb_lift_off_hinged_friction)(sc->q, x,
                                                                                        &z[0]);
        } else {
            (sc->fixed ? treb_lift_off_fixed : treb_lift_off_hinged)(sc->q, y, &z[0]);
        }
        treb_sling_upright(sc->q, y, &z[1]);
    } else if (m->phase == 2) {
        treb_ground(sc->q, y, &z[0]);
        if (sc->has_angle) {
            double x[7];
            memcpy(x, y, sizeof y);
            x[6] = sc->angle;
            treb_climb(sc->q, x, &z[1]);
        }
    }
}

/* With friction: d(outputs)/d(x) by central differences of the generated outputs (the couples
 * are solved by Newton's steps, whose derivative is not generated), step FD_STEP relative. */
#define FD_STEP 1e-5
static void jacobian_friction(TrebModel *m, double J[TREB_N_OUTPUTS][TREB_NX_STATES])
{
    int used[TREB_NX_STATES] = {1, 1, m->phase == 2, 1, 1, m->phase == 2, 1, 1};
    double x0[TREB_NX_STATES], y[TREB_MAXN], up[TREB_N_OUTPUTS], down[TREB_N_OUTPUTS];
    memcpy(x0, m->x, sizeof x0);
    memset(J, 0, sizeof(double) * TREB_N_OUTPUTS * TREB_NX_STATES);
    for (int j = 0; j < TREB_NX_STATES; j++) {
        if (!used[j]) continue;
        double h = FD_STEP * fmax(1.0, fabs(x0[j]));
        m->x[j] = x0[j] + h;
        phase_state(m, y);
        treb_outputs_of(&m->shot.sc, m->phase, y, up);
        m->x[j] = x0[j] - h;
        phase_state(m, y);
        treb_outputs_of(&m->shot.sc, m->phase, y, down);
        m->x[j] = x0[j];
        for (int i = 0; i < TREB_N_OUTPUTS; i++) J[i][j] = (up[i] - down[i]) / (2.0 * h);
    }
}

int treb_model_event_indicators(TrebModel *m, double *z, char *msg)
{
    if (!initialised(m, msg)) return -1;
    treb_model_indicators(m, z);
    for (int k = 0; k < TREB_NZ; k++) {
        if (!isfinite(z[k])) {
            snprintf(msg, TREB_MSG, "the event indicator %d at t = %.9g s is not finite (%g): "
                     "the states lie outside what the model can compute", k, m->time, z[k]);
            return -1;
        }
    }
    return 0;
}

/* d(outputs)/d(x) at the model exchange's state (generated Jacobian of the phase; the
 * projectile's flight after release depends on time only). */
static void jacobian(TrebModel *m, double J[TREB_N_OUTPUTS][TREB_NX_STATES])
{
    static const int beam[4] = {0, 1, 3, 4};  /* theta, psi, theta_d, psi_d in x */
    const TrebScene *sc = &m->shot.sc;
    double y[TREB_MAXN], x[9], jp[TREB_N_OUTPUTS * 6];
    int n = m->phase == 2 ? 6 : 4;
    if (sc->friction) {
        jacobian_friction(m, J);
        n = 0;  /* the flight's rows below */
    }
    phase_state(m, y);
    if (!sc->friction) {
        memcpy(x, y, n * sizeof(double));
        memcpy(x + n, sc->rest, 3 * sizeof(double));
        if (m->phase == 1)
            (sc->fixed ? treb_jacobian1_fixed : treb_jacobian1_hinged)(sc->q, x, jp);
        else if (m->phase == 2)
            (sc->fixed ? treb_jacobian2_fixed : treb_jacobian2_hinged)(sc->q, x, jp);
        else (sc->fixed ? treb_jacobian3_fixed : treb_jacobian3_hinged)(sc->q, x, jp);
        memset(J, 0, sizeof(double) * TREB_N_OUTPUTS * TREB_NX_STATES);
        for (int i = 0; i < TREB_N_OUTPUTS; i++)
            for (int j = 0; j < n; j++) J[i][n == 6 ? j : beam[j]] = jp[i * n + j];
    }
    if (m->phase == 3) {
        static const int flight[5] = {TREB_OUT_x_m, TREB_OUT_y_m, TREB_OUT_vx_m, TREB_OUT_vy_m,
                                      TREB_OUT_E_m};
        for (int k = 0; k < 5; k++) memset(J[flight[k]], 0, sizeof J[0]);
    }
}

static int state_index(unsigned vr)
{
    static const unsigned states[TREB_NX_STATES] = {TREB_VR_theta, TREB_VR_psi, TREB_VR_phi,
                                                    TREB_VR_theta_d, TREB_VR_psi_d,
                                                    TREB_VR_phi_d, TREB_VR_E_loss_pivot,
                                                    TREB_VR_E_loss_hinge};
    for (int k = 0; k < TREB_NX_STATES; k++)
        if (states[k] == vr) return k;
    return -1;
}

int treb_model_directional(TrebModel *m, const unsigned *unknowns, size_t n_unknowns,
                           const unsigned *knowns, size_t n_knowns, const double *seed,
                           double *sensitivity, char *msg)
{
    double J[TREB_N_OUTPUTS][TREB_NX_STATES];
    if (m->cosim || !m->initialized) {
        snprintf(msg, TREB_MSG, "directional derivatives are provided in model exchange, after "
                 "initialisation, with respect to the continuous states");
        return -1;
    }
    for (size_t k = 0; k < n_knowns; k++) {
        if (state_index(knowns[k]) < 0) {
            snprintf(msg, TREB_MSG, "directional derivative: value reference %u is not a "
                     "continuous state", knowns[k]);
            return -1;
        }
    }
    jacobian(m, J);
    for (size_t u = 0; u < n_unknowns; u++) {
        long i = (long)unknowns[u] - TREB_VR_FIRST_OUTPUT;
        if (i < 0 || i >= TREB_N_OUTPUTS) {
            snprintf(msg, TREB_MSG, "directional derivative: value reference %u is not a Real "
                     "output", unknowns[u]);
            return -1;
        }
        double acc = 0.0;
        for (size_t k = 0; k < n_knowns; k++) acc += J[i][state_index(knowns[k])] * seed[k];
        if (!isfinite(acc)) {
            snprintf(msg, TREB_MSG, "directional derivative of %s: not finite (seeds or states "
                     "outside what the model can compute)", TREB_VAR_NAME[unknowns[u]]);
            return -1;
        }
        sensitivity[u] = acc;
    }
    return 0;
}

static void release_now(TrebModel *m)
{
    double x[4] = {m->x[0], m->x[2], m->x[3], m->x[5]}, out[4];
    treb_projectile(m->shot.sc.q, x, out);
    m->shot.release[0] = m->time;
    memcpy(m->shot.release + 1, out, sizeof out);
    m->shot.t_rel = m->time;
    m->shot.flight_started = 0;
    m->shot.flight.n = 0;
    m->phase = 3;
    m->x[2] = m->x[5] = 0.0;
}

int treb_model_event(TrebModel *m, int *states_changed, int *time_defined, double *next_time,
                     char *msg)
{
    const TrebScene *sc = &m->shot.sc;
    double z[TREB_NZ];
    int status = 0, command = m->values[TREB_VR_release_command] != 0.0;
    msg[0] = '\0';
    *states_changed = 0;
    treb_model_indicators(m, z);
    if (m->phase == 1) {
        if (z[1] >= 0.0 && m->z_ref[1] < 0.0) {
            snprintf(msg, TREB_MSG, "FMU parameters: [engine] M = %g kg: the counterweight "
                     "cannot lift the projectile: at t = %.4g s the sling stands vertical over "
                     "a projectile still in the trough", sc->q[TREB_Q_M], m->time);
            return -1;
        }
        if (z[0] <= 0.0 && m->z_ref[0] > 0.0 && sc->has_time && m->time >= sc->t_release) {
            snprintf(msg, TREB_MSG, "FMU parameters: [release] time = %g s comes before lift-off "
                     "at %.4g s: the projectile is still in the trough", sc->t_release, m->time);
            return -1;
        }
        if (z[0] <= 0.0 && m->z_ref[0] > 0.0) {  /* lift-off: the sling takes the projectile */
            double y[TREB_MAXN], out[TREB_N_OUTPUTS];
            phase_state(m, y);
            treb_outputs_of(sc, 1, y, out);
            m->x[2] = out[TREB_OUT_phi];
            m->x[5] = out[TREB_OUT_phi_d];
            m->shot.t_lift = m->time;
            m->phase = 2;
            *states_changed = 1;
        }
    } else if (m->phase == 2) {
        if (z[0] <= 0.0 && m->z_ref[0] > 0.0) {
            snprintf(msg, TREB_MSG, "FMU parameters: [release]: the projectile strikes the "
                     "ground at t = %.4g s while still in the sling; release it earlier, use a "
                     "shorter sling or raise the pivot", m->time);
            return -1;
        }
        int by_time = sc->has_time && m->time >= sc->t_release;
        int by_angle = sc->has_angle && z[1] >= 0.0 && m->z_ref[1] < 0.0;
        int by_command = command && !m->command_prev;
        if (by_time || by_angle || by_command) {
            release_now(m);
            *states_changed = 1;
        }
    } else if (command && !m->command_prev) {
        snprintf(msg, TREB_MSG, "release command at t = %.9g s ignored: %s", m->time,
                 sc->projectile == 3 ? "a dry fire has no projectile"
                                     : "the projectile was already released");
        status = 1;
    }
    if (m->phase == 1 && command && !m->command_prev) {
        snprintf(msg, TREB_MSG, "release command at t = %.9g s ignored: the projectile lies in "
                 "the trough until lift-off", m->time);
        status = 1;
    }
    m->command_prev = command;
    *time_defined = m->phase == 2 && sc->has_time && m->time < sc->t_release;
    *next_time = sc->t_release;
    if (!*time_defined && m->time < TREB_HORIZON) {  /* the horizon: the run ends there */
        *time_defined = 1;
        *next_time = TREB_HORIZON;
    }
    treb_model_indicators(m, m->z_ref);
    m->outputs_valid = 0;
    return status;
}

int treb_model_copy(TrebModel *dst, const TrebModel *src)
{
    *dst = *src;
    return treb_shot_copy(&dst->shot, &src->shot);
}


/* ------------------------------------------------------------------ checks of a read model */

static int bad(char *msg, const char *what)
{
    snprintf(msg, TREB_MSG, "%s", what);
    return -1;
}

#define SAME(a, b, field) (memcmp(&(a)->field, &(b)->field, sizeof (a)->field) == 0)

/* The shot's scene is the one of its parameters (a release command may have set the time
 * rule in co-simulation): every number bit for bit. */
static int same_scene(const TrebScene *a, const TrebScene *b, int cosim)
{
    int release = SAME(a, b, has_time) && SAME(a, b, t_release);
    if (!release && cosim)
        release = a->has_time == 1 && isfinite(a->t_release) && a->t_release > 0.0;
    return release && SAME(a, b, q) && SAME(a, b, fixed) && SAME(a, b, projectile)
           && SAME(a, b, drag) && SAME(a, b, theta) && SAME(a, b, psi) && SAME(a, b, phi)
           && SAME(a, b, has_angle) && SAME(a, b, angle) && SAME(a, b, diameter)
           && SAME(a, b, drag_coefficient) && SAME(a, b, air_density) && SAME(a, b, rest)
           && SAME(a, b, k_drag) && SAME(a, b, friction) && SAME(a, b, rtol)
           && SAME(a, b, bounded) && SAME(a, b, after_release);
}

static int check_values(const TrebModel *m, char *msg)
{
    for (int vr = 0; vr < TREB_NV; vr++) {
        double v = m->values[vr];
        int dry = m->shot.sc.projectile == 3 && (vr == TREB_VR_x_m || vr == TREB_VR_y_m
                                                 || vr == TREB_VR_vx_m || vr == TREB_VR_vy_m);
        if (!isfinite(v) && !(dry && isnan(v)))
            return bad(msg, "a variable's value is not a finite number");
        if (TREB_VAR_CAUSALITY[vr] != TREB_OUTPUT && TREB_VAR_TYPE[vr] != TREB_REAL
            && !(v >= TREB_VAR_MIN[vr] && v <= TREB_VAR_MAX[vr] && v == floor(v)))
            return bad(msg, "a choice or the release command lies out of range");
    }
    double phase = m->values[TREB_VR_phase];
    if (!(phase == 0.0 || phase == 1.0 || phase == 2.0 || phase == 3.0))
        return bad(msg, "the phase output lies out of range");
    return 0;
}

int treb_model_check(const TrebModel *m, int cosim, int complete, char *msg)
{
    TrebScene sc, zero;
    if (m->cosim != cosim)
        return bad(msg, cosim ? "a state of model exchange, not co-simulation"
                              : "a state of co-simulation, not model exchange");
    if ((m->initialized != 0 && m->initialized != 1) || (m->command_prev != 0
                                                         && m->command_prev != 1))
        return bad(msg, "a flag is neither 0 nor 1");
    if (check_values(m, msg)) return -1;
    if (!isfinite(m->time) || m->time < 0.0 || (cosim && m->time > TREB_HORIZON))
        return bad(msg, "the time lies out of range");
    for (int k = 0; k < TREB_NX_STATES; k++)
        if (!isfinite(m->x[k])) return bad(msg, "a continuous state is not a finite number");
    for (int k = 0; k < TREB_NZ; k++)
        if (!isfinite(m->z_ref[k])) return bad(msg, "an event indicator is not finite");
    memset(&zero, 0, sizeof zero);
    if (!m->initialized) {
        if (m->phase != 0 || !same_scene(&m->shot.sc, &zero, 0) || m->shot.n_phases != 0
            || m->shot.steps.n != 0 || m->shot.flight.n != 0 || m->shot.flight_started != 0)
            return bad(msg, "a state before initialisation holds a shot");
        return 0;
    }
    if (treb_scene_from_values(m->values, &sc, msg)) return -1;
    if (!same_scene(&m->shot.sc, &sc, cosim))
        return bad(msg, "the shot's scene is not the one its parameters give");
    int first = sc.projectile;  /* 1 trough, 2 sling, 3 none: the first phase */
    if (!cosim && (m->phase < first || m->phase > 3))
        return bad(msg, "the model exchange's phase lies out of range");
    return treb_shot_check(&m->shot, cosim, complete, msg);
}

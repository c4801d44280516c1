/* Parameter checks: the rules of model/scene.py (_parse_scene, _check_start_pose) on the
 * FMU's parameters, with the scene's messages. See treb_scene.h. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "treb_scene.h"
#include "treb_variables.h"

#define SOURCE "FMU parameters"
#define DEG (M_PI / 180.0)

static int fail(char *msg, const char *where, const char *problem)
{
    snprintf(msg, TREB_MSG, SOURCE ": %s: %s", where, problem);
    return -1;
}

/* A finite number, else the scene's message. */
static int number(const double *v, int vr, const char *where, char *msg, double *out)
{
    char problem[128];
    if (!isfinite(v[vr])) {
        snprintf(problem, sizeof problem, "must be finite, got %g", v[vr]);
        return fail(msg, where, problem);
    }
    *out = v[vr];
    return 0;
}

static int positive(const double *v, int vr, const char *where, const char *unit, char *msg,
                    double *out)
{
    char problem[160];
    if (number(v, vr, where, msg, out)) return -1;
    if (*out <= 0.0) {
        snprintf(problem, sizeof problem, "= %g: must be a positive %s", *out, unit);
        return fail(msg, where, problem);
    }
    return 0;
}

static int check_start_pose(const TrebScene *sc, double H, char *msg)
{
    const double *q = sc->q;
    char problem[256];
    double spigot_y = H + q[TREB_Q_L1] * sin(sc->theta);
    if (spigot_y < -1e-9 * q[TREB_Q_L1]) {
        snprintf(problem, sizeof problem, "= %g° puts the spigot %.3g m below ground (pivot "
                 "height H = %g m)", sc->theta / DEG, -spigot_y, H);
        return fail(msg, "[start] theta_deg", problem);
    }
    double cw_y = H - q[TREB_Q_L2] * sin(sc->theta) + q[TREB_Q_L3] * sin(sc->psi);
    if (cw_y < 0.0) {
        snprintf(problem, sizeof problem, "= %g° puts the counterweight %.3g m below ground "
                 "(pivot height H = %g m)", sc->psi / DEG, -cw_y, H);
        return fail(msg, "[start] psi_deg", problem);
    }
    if (sc->projectile == 3) return 0;
    double L4 = q[TREB_Q_L4], y_m = spigot_y + L4 * sin(sc->phi);
    if (sc->projectile == 2) {
        if (y_m < 0.0) {
            snprintf(problem, sizeof problem, "= %g° puts the projectile %.3g m below ground; "
                     "raise the pivot with [engine] H", sc->phi / DEG, -y_m);
            return fail(msg, "[start] phi_deg", problem);
        }
        return 0;
    }
    if (spigot_y > L4) {
        snprintf(problem, sizeof problem, "= %g m: the sling cannot reach the trough from the "
                 "spigot %.3g m above it", L4, spigot_y);
        return fail(msg, "[engine] L4", problem);
    }
    if (fabs(y_m) > 1e-6 * L4) {
        double fit = -M_PI + asin(spigot_y / L4);
        snprintf(problem, sizeof problem, "= %g° puts the projectile %.3g m %s; the sling lies "
                 "in the trough at phi_deg = %.6g", sc->phi / DEG, fabs(y_m),
                 y_m < 0 ? "below ground" : "above the trough", fit / DEG);
        return fail(msg, "[start] phi_deg", problem);
    }
    if (cos(sc->phi) > 0.0) {
        snprintf(problem, sizeof problem, "= %g°: the sling must point away from the throw "
                 "(between -270° and -90°), under the beam", sc->phi / DEG);
        return fail(msg, "[start] phi_deg", problem);
    }
    return 0;
}

/* [friction]: left out (no friction) where the four coefficients and radii are 0, as the
 * FMU's parameters become a scene (fmu/interface.py); each zero or positive, the smoothing
 * rate positive. The generated formulas take mu r of pivot and hinge. */
static int friction(const double *v, TrebScene *sc, char *msg)
{
    static const int vr[4] = {TREB_VR_friction_pivot_mu, TREB_VR_friction_pivot_radius,
                              TREB_VR_friction_hinge_mu, TREB_VR_friction_hinge_radius};
    static const char *const where[4] = {"[friction] pivot_mu", "[friction] pivot_radius",
                                         "[friction] hinge_mu", "[friction] hinge_radius"};
    double x[4], rate = 1e-3;
    char problem[128];
    int given = 0;
    for (int k = 0; k < 4; k++) given = given || v[vr[k]] != 0.0;
    if (given) {
        for (int k = 0; k < 4; k++) {
            if (number(v, vr[k], where[k], msg, &x[k])) return -1;
            if (x[k] < 0.0) {
                snprintf(problem, sizeof problem, "= %g: must not be negative", x[k]);
                return fail(msg, where[k], problem);
            }
        }
        if (positive(v, TREB_VR_friction_smoothing_rate, "[friction] smoothing_rate",
                     "rate in rad/s", msg, &rate))
            return -1;
    } else {
        x[0] = x[1] = x[2] = x[3] = 0.0;
    }
    sc->q[TREB_Q_pivot_friction] = x[0] * x[1];
    sc->q[TREB_Q_hinge_friction] = x[2] * x[3];
    sc->q[TREB_Q_friction_rate] = rate;
    sc->friction = sc->q[TREB_Q_pivot_friction] != 0.0 || sc->q[TREB_Q_hinge_friction] != 0.0;
    return 0;
}

/* The smallest values the FMU takes, beside the declared ranges: below them lengths, masses
 * and gravity stop meaning an engine (and 1/L or 1/m overflow to inf). */
static const struct { int vr; double floor; } FLOORS[] = {
    {TREB_VR_engine_L1, 1e-3}, {TREB_VR_engine_L2, 1e-3}, {TREB_VR_engine_L3, 1e-3},
    {TREB_VR_engine_L4, 1e-3}, {TREB_VR_engine_m_b, 1e-3}, {TREB_VR_engine_M, 1e-3},
    {TREB_VR_engine_m, 1e-3}, {TREB_VR_environment_g, 1e-2},
};

/* "[section] key" of a variable's name "section.key". */
static void key_of(int vr, char *out, size_t n)
{
    const char *name = TREB_VAR_NAME[vr], *dot = strchr(name, '.');
    if (dot) snprintf(out, n, "[%.*s] %s", (int)(dot - name), name, dot + 1);
    else snprintf(out, n, "%s", name);
}

int treb_parameter_check(int vr, double value, char *msg)
{
    char where[64], problem[256];
    if (vr < 0 || vr >= TREB_NV) return fail(msg, "value reference", "out of range");
    double lo = TREB_VAR_MIN[vr], hi = TREB_VAR_MAX[vr];
    int choice = TREB_VAR_TYPE[vr] == TREB_ENUMERATION || TREB_VAR_TYPE[vr] == TREB_INTEGER
                 || TREB_VAR_TYPE[vr] == TREB_BOOLEAN;
    if (isfinite(value) && value >= lo && value <= hi && (!choice || value == floor(value))) {
        int low = 0;  /* the common case, checked without formatting anything */
        for (size_t k = 0; k < sizeof FLOORS / sizeof FLOORS[0]; k++)
            low |= FLOORS[k].vr == vr && value > 0.0 && value < FLOORS[k].floor;
        if (!low) return 0;
    }
    const char *unit = TREB_VAR_UNIT[vr];
    key_of(vr, where, sizeof where);
    if (!isfinite(value)) {
        snprintf(problem, sizeof problem, "must be finite, got %g", value);
        return fail(msg, where, problem);
    }
    if (choice) {
        if (!(value >= lo && value <= hi && value == floor(value))) {
            snprintf(problem, sizeof problem, "= %.17g: must be one of the choices %g to %g",
                     value, lo, hi);
            return fail(msg, where, problem);
        }
        return 0;
    }
    const char *space = unit[0] ? " " : "";
    if (!(value >= lo && value <= hi)) {
        snprintf(problem, sizeof problem, "= %g%s%s: must lie between %g and %g%s%s (the range "
                 "in modelDescription.xml)", value, space, unit, lo, hi, space, unit);
        return fail(msg, where, problem);
    }
    for (size_t k = 0; k < sizeof FLOORS / sizeof FLOORS[0]; k++) {
        if (FLOORS[k].vr == vr && value > 0.0 && value < FLOORS[k].floor) {
            snprintf(problem, sizeof problem, "= %g%s%s: below %g%s%s, the smallest the FMU "
                     "takes", value, space, unit, FLOORS[k].floor, space, unit);
            return fail(msg, where, problem);
        }
    }
    return 0;
}

/* An Enumeration's value as its choice 1..n, or 0 (checked before any cast to int). */
static int choice(const double *v, int vr, int n)
{
    double x = v[vr];
    return x >= 1.0 && x <= n && x == floor(x) ? (int)x : 0;
}

int treb_scene_from_values(const double *v, TrebScene *sc, char *msg)
{
    double L1, L2, L3, L4, m_b, M, m, L_CM, I, H, g, x;
    char problem[256];
    memset(sc, 0, sizeof *sc);
    sc->projectile = choice(v, TREB_VR_start_projectile, 3);
    if (!sc->projectile)
        return fail(msg, "[start] projectile", "must be 1 (trough), 2 (sling) or 3 (none)");
    if (positive(v, TREB_VR_engine_L1, "[engine] L1", "length in m", msg, &L1)
        || positive(v, TREB_VR_engine_L2, "[engine] L2", "length in m", msg, &L2)
        || positive(v, TREB_VR_engine_L3, "[engine] L3", "length in m", msg, &L3)
        || positive(v, TREB_VR_engine_m_b, "[engine] m_b", "mass in kg", msg, &m_b)
        || positive(v, TREB_VR_engine_M, "[engine] M", "mass in kg", msg, &M))
        return -1;
    if (sc->projectile == 3) {
        if (number(v, TREB_VR_engine_L4, "[engine] L4", msg, &L4)
            || number(v, TREB_VR_engine_m, "[engine] m", msg, &m))
            return -1;
        if (L4 < 0.0) return fail(msg, "[engine] L4", "must not be negative");
        if (m < 0.0) return fail(msg, "[engine] m", "must not be negative");
        m = 0.0;
    } else if (positive(v, TREB_VR_engine_L4, "[engine] L4", "length in m", msg, &L4)
               || positive(v, TREB_VR_engine_m, "[engine] m", "mass in kg", msg, &m)) {
        return -1;
    }
    if (number(v, TREB_VR_engine_L_CM, "[engine] L_CM", msg, &L_CM)) return -1;
    if (!(-L2 <= L_CM && L_CM <= L1)) {
        snprintf(problem, sizeof problem, "= %g m puts the centre of mass off the beam (it must "
                 "lie between -L2 = %g m and L1 = %g m)", L_CM, -L2, L1);
        return fail(msg, "[engine] L_CM", problem);
    }
    double *q = sc->q;
    q[TREB_Q_L1] = L1; q[TREB_Q_L2] = L2; q[TREB_Q_L_CM] = L_CM; q[TREB_Q_L3] = L3;
    q[TREB_Q_L4] = L4; q[TREB_Q_m_b] = m_b; q[TREB_Q_M] = M; q[TREB_Q_m] = m;
    if (v[TREB_VR_engine_I] != 0.0) {
        if (positive(v, TREB_VR_engine_I, "[engine] I", "moment of inertia in kg m²", msg, &I))
            return -1;
    } else {
        treb_default_inertia(q, NULL, &I);
    }
    q[TREB_Q_I] = I;
    if (M * L2 <= m_b * L_CM) {
        snprintf(problem, sizeof problem, "= %g kg cannot lift the beam: the counterweight's "
                 "moment M L2 = %g kg m must exceed the beam's m_b L_CM = %g kg m", M, M * L2,
                 m_b * L_CM);
        return fail(msg, "[engine] M", problem);
    }
    int mount = choice(v, TREB_VR_engine_counterweight, 2);
    if (!mount)
        return fail(msg, "[engine] counterweight", "must be 1 (hinged) or 2 (fixed)");
    if (number(v, TREB_VR_start_theta_deg, "[start] theta_deg", msg, &x)) return -1;
    sc->theta = x * DEG;
    if (number(v, TREB_VR_start_psi_deg, "[start] psi_deg", msg, &x)) return -1;
    sc->psi = x * DEG;
    if (number(v, TREB_VR_start_phi_deg, "[start] phi_deg", msg, &x)) return -1;
    sc->phi = x * DEG;
    if (!(-M_PI / 2 < sc->theta && sc->theta < 0.0)) {
        snprintf(problem, sizeof problem, "= %g°: the beam must start between -90° and 0° "
                 "(spigot low, on the projectile's side)", sc->theta / DEG);
        return fail(msg, "[start] theta_deg", problem);
    }
    if (v[TREB_VR_engine_H] != 0.0) {
        if (positive(v, TREB_VR_engine_H, "[engine] H", "height in m", msg, &H)) return -1;
    } else {
        H = -L1 * sin(sc->theta);
    }
    q[TREB_Q_H] = H;
    sc->fixed = mount == 2;
    q[TREB_Q_offset] = sc->fixed ? sc->psi - sc->theta : 0.0;
    if (check_start_pose(sc, H, msg)) return -1;

    double t_rel = v[TREB_VR_release_time], angle = v[TREB_VR_release_velocity_angle_deg];
    sc->has_time = t_rel != 0.0;
    sc->has_angle = angle != 0.0;
    if (sc->projectile == 3) {
        if (sc->has_time || sc->has_angle)
            return fail(msg, "[release]", "a dry fire (projectile = \"none\") has no release");
    } else {
        if (!sc->has_time && !sc->has_angle)
            return fail(msg, "[release]", "give exactly one of time, velocity_angle_deg");
        if (sc->has_time && positive(v, TREB_VR_release_time, "[release] time", "time in s",
                                     msg, &sc->t_release))
            return -1;
        if (sc->has_angle) {
            if (number(v, TREB_VR_release_velocity_angle_deg, "[release] velocity_angle_deg",
                       msg, &x))
                return -1;
            sc->angle = x * DEG;
            if (!(0.0 < sc->angle && sc->angle < M_PI / 2)) {
                snprintf(problem, sizeof problem, "= %g°: must lie strictly between 0° and 90°",
                         sc->angle / DEG);
                return fail(msg, "[release] velocity_angle_deg", problem);
            }
        }
    }
    if (positive(v, TREB_VR_environment_g, "[environment] g", "acceleration in m/s²", msg, &g))
        return -1;
    q[TREB_Q_g] = g;
    int model = choice(v, TREB_VR_flight_model, 2);
    if (!model)
        return fail(msg, "[flight] model", "must be 1 (vacuum) or 2 (drag)");
    sc->drag = model == 2;
    if (sc->drag
        && (positive(v, TREB_VR_flight_diameter, "[flight] diameter", "length in m", msg,
                     &sc->diameter)
            || positive(v, TREB_VR_flight_drag_coefficient, "[flight] drag_coefficient",
                        "number", msg, &sc->drag_coefficient)
            || positive(v, TREB_VR_flight_air_density, "[flight] air_density",
                        "density in kg/m³", msg, &sc->air_density)))
        return -1;
    if (friction(v, sc, msg)) return -1;
    for (int vr = 0; vr < TREB_NV; vr++)  /* the scene's rules passed: each value's range */
        if (TREB_VAR_CAUSALITY[vr] == TREB_PARAMETER && treb_parameter_check(vr, v[vr], msg))
            return -1;
    return treb_scene_rest(sc);
}

"""An independent simulation of a shot, for checking designs: the engine's Lagrangian derived
here with sympy (none of the package's equations of motion, loads or integrator used), the
trough as a constraint with a Lagrange multiplier, scipy's ``solve_ivp`` (DOP853, rtol 1e-11),
the loads from Newton's second law on each body, their peaks on the dense output at 1 ms
and then refined by a bounded scalar search.

The engine is the paper's (Table 1): a beam (mass ``m_b``, moment of inertia ``I`` about the
pivot, centre of mass ``L_CM`` toward the spigot) on a pivot ``H`` above the ground, a point
counterweight ``M`` on an arm ``L3`` hinged ``L2`` behind the pivot, a point projectile ``m`` on
a massless sling ``L4`` from the spigot ``L1`` ahead. Angles as the package's scene files
(θ beam, ψ counterweight arm, φ sling, from +x, counter-clockwise); the projectile is thrown
toward −x. Only the scene's inputs and the release rule (its climb angle) are shared.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

__all__ = ["IndependentShot", "independent_shot"]

RTOL = 1e-11


@cache
def _equations():
    """Mass matrix, forces and the trough constraint of the three-angle engine, lambdified:
    ``M(q) q̈ = f(q, q̇)`` from ``L = T − V``; accelerations of each body from ``q, q̇, q̈``."""
    th, ps, ph = sp.symbols("theta psi phi")
    thd, psd, phd = sp.symbols("theta_d psi_d phi_d")
    thdd, psdd, phdd = sp.symbols("theta_dd psi_dd phi_dd")
    L1, L2, LCM, L3, L4, mb, M, m, I, H, g = sp.symbols("L1 L2 L_CM L3 L4 m_b M m I H g")
    t = sp.symbols("t")
    q_t = [sp.Function(n)(t) for n in ("th", "ps", "ph")]
    sub_q = dict(zip(q_t, (th, ps, ph), strict=True))
    sub_d = dict(zip([x.diff(t) for x in q_t], (thd, psd, phd), strict=True))
    sub_dd = dict(zip([x.diff(t, 2) for x in q_t], (thdd, psdd, phdd), strict=True))

    def pos(expr_t):
        return sp.Matrix(expr_t)

    a, b, c = q_t
    r_cm = pos([LCM * sp.cos(a), H + LCM * sp.sin(a)])
    r_M = pos([-L2 * sp.cos(a) + L3 * sp.cos(b), H - L2 * sp.sin(a) + L3 * sp.sin(b)])
    r_m = pos([L1 * sp.cos(a) + L4 * sp.cos(c), H + L1 * sp.sin(a) + L4 * sp.sin(c)])
    v_cm, v_M, v_m = (r.diff(t) for r in (r_cm, r_M, r_m))
    # the beam: its rotation about the pivot (I) carries its whole kinetic energy
    T = I * a.diff(t) ** 2 / 2 + M * v_M.dot(v_M) / 2 + m * v_m.dot(v_m) / 2
    V = g * (mb * r_cm[1] + M * r_M[1] + m * r_m[1])
    Lag = T - V
    qd = [x.diff(t) for x in q_t]
    eqs = [sp.diff(Lag.diff(qd[i]), t) - Lag.diff(q_t[i]) for i in range(3)]

    def plain(e):
        return e.subs(sub_dd).subs(sub_d).subs(sub_q)

    eqs = [plain(e) for e in eqs]
    qdd = (thdd, psdd, phdd)
    Mm = sp.Matrix(3, 3, lambda i, j: sp.expand(eqs[i]).coeff(qdd[j]))
    f = sp.Matrix([-(eqs[i] - sum(Mm[i, j] * qdd[j] for j in range(3))) for i in range(3)])
    Mm, f = sp.simplify(Mm), sp.simplify(f)
    # the trough: y_m = 0; its gradient and the rest of its second derivative
    y_m = plain(r_m[1])
    G = sp.Matrix([[y_m.diff(x) for x in (th, ps, ph)]])
    acc_y = plain(r_m[1].diff(t, 2))
    gamma = -(acc_y - sum(G[j] * qdd[j] for j in range(3)))  # G q̈ = gamma
    args = (th, ps, ph, thd, psd, phd, L1, L2, LCM, L3, L4, mb, M, m, I, H, g)
    acc_args = (*args, thdd, psdd, phdd)
    lam = {k: sp.lambdify(args, v, "numpy") for k, v in
           {"M": Mm, "f": f, "G": G, "gamma": sp.simplify(gamma)}.items()}
    for name, r in (("a_cm", r_cm), ("a_M", r_M), ("a_m", r_m)):
        lam[name] = sp.lambdify(acc_args, plain(r.diff(t, 2)), "numpy")
    for name, r in (("r_M", r_M), ("r_m", r_m), ("v_m", v_m)):
        lam[name] = sp.lambdify(args, plain(r), "numpy")
    return lam


@dataclass(frozen=True)
class IndependentShot:
    """What the independent simulation found: release time (s), range in vacuum from the
    pivot (m), peak |F_R| and |F_S| (N), the counterweight's lowest height to 0.5 s past the
    release (m), and the largest energy error over the energy released (1)."""

    release_time: float
    range: float
    F_R_peak: float
    F_S_peak: float
    cw_clearance: float
    energy_error: float


def independent_shot(scene, after_release: float = 0.5) -> IndependentShot:  # noqa: C901
    """Simulate ``scene`` (a :class:`trebuchet.Scene` with a climb-angle release, projectile in
    the trough) independently of the package's model."""
    eq = _equations()
    e, s = scene.engine, scene.start
    par = (e.L1, e.L2, e.L_CM, e.L3, e.L4, e.m_b, e.M, e.m, e.I, s.H, scene.g)
    alpha = scene.release.velocity_angle

    par3 = (*par[:7], 0.0, *par[8:])  # released: the projectile is no part of the engine

    def qdd_free(y, free):  # free: which angles move (phase 2: all three; 3: θ, ψ)
        p = par if len(free) == 3 else par3
        Mm = np.array(eq["M"](*y, *p), dtype=float)
        f = np.array(eq["f"](*y, *p), dtype=float).ravel()
        out = np.zeros(3)
        out[free] = np.linalg.solve(Mm[np.ix_(free, free)], f[free])
        return out

    def qdd_trough(y):
        Mm = np.array(eq["M"](*y, *par), dtype=float)
        f = np.array(eq["f"](*y, *par), dtype=float).ravel()
        G = np.array(eq["G"](*y, *par), dtype=float).ravel()
        A = np.zeros((4, 4))
        A[:3, :3], A[:3, 3], A[3, :3] = Mm, -G, G
        sol = np.linalg.solve(A, [*f, float(eq["gamma"](*y, *par))])
        return sol[:3], sol[3]  # q̈ and the normal force N (the multiplier on y_m)

    def rhs(phase):
        def f(t, y):
            if phase == 1:
                acc = qdd_trough(y)[0]
            else:
                acc = qdd_free(y, [0, 1, 2] if phase == 2 else [0, 1])
            out = np.concatenate([y[3:], acc])
            if phase == 3:
                out[2] = out[5] = 0.0
            return out
        return f

    def lift_off(t, y):
        return qdd_trough(y)[1]
    lift_off.terminal, lift_off.direction = True, -1

    def release(t, y):
        vx, vy = np.asarray(eq["v_m"](*y, *par), dtype=float).ravel()
        return math.sin(alpha) * (-vx) - math.cos(alpha) * vy
    release.terminal, release.direction = True, 1

    y0 = [s.theta, s.psi, s.phi, 0.0, 0.0, 0.0]
    kw = {"method": "DOP853", "rtol": RTOL, "atol": RTOL * 1e-2, "dense_output": True}
    p1 = solve_ivp(rhs(1), (0, 60), y0, events=lift_off, **kw)
    t1 = p1.t_events[0][0]
    p2 = solve_ivp(rhs(2), (t1, 60), p1.y_events[0][0], events=release, **kw)
    t2 = p2.t_events[0][0]
    y2 = p2.y_events[0][0]
    p3 = solve_ivp(rhs(3), (t2, t2 + after_release), y2, **kw)
    phases = ((1, p1, 0.0, t1), (2, p2, t1, t2), (3, p3, t2, t2 + after_release))

    def loads(phase, sol, t):
        y = sol.sol(t)
        if phase == 1:
            acc, N = qdd_trough(y)
        else:
            acc, N = qdd_free(y, [0, 1, 2] if phase == 2 else [0, 1]), 0.0
        a_cm, a_M, a_m = (np.asarray(eq[k](*y, *par, *acc), dtype=float).ravel()
                          for k in ("a_cm", "a_M", "a_m"))
        weight = np.array([0.0, scene.g])
        # Newton on each body: the force on the projectile from its sling; the pivot's
        # reaction balances every body's momentum change and weight (and the trough's push)
        F_S = e.m * (a_m + weight) - np.array([0.0, N]) if phase < 3 else np.zeros(2)
        F_R = e.m_b * (a_cm + weight) + e.M * (a_M + weight)
        if phase < 3:
            F_R = F_R + F_S
        y_M = float(np.asarray(eq["r_M"](*y, *par), dtype=float).ravel()[1])
        return math.hypot(*F_R), math.hypot(*F_S), y_M

    def peak(k, sign, t_end):
        best = -math.inf
        for phase, sol, a, b in phases:
            b = min(b, t_end)
            if b < a:
                continue
            ts = np.linspace(a, b, max(3, int((b - a) / 1e-3)))
            v = np.array([sign * loads(phase, sol, t)[k] for t in ts])
            i = int(np.argmax(v))
            lo, hi = ts[max(i - 1, 0)], ts[min(i + 1, ts.size - 1)]
            r = minimize_scalar(lambda t, phase=phase, sol=sol: -sign * loads(phase, sol, t)[k],
                                bounds=(lo, hi), method="bounded",
                                options={"xatol": 1e-10})
            best = max(best, v[i], -r.fun)
        return sign * best

    x, yy = np.asarray(eq["r_m"](*y2, *par), dtype=float).ravel()
    vx, vy = np.asarray(eq["v_m"](*y2, *par), dtype=float).ravel()
    t_flight = (vy + math.sqrt(vy * vy + 2 * scene.g * yy)) / scene.g
    energy = _energy_error(eq, par, phases, scene)
    return IndependentShot(release_time=float(t2), range=float(-(x + vx * t_flight)),
                           F_R_peak=peak(0, 1.0, math.inf), F_S_peak=peak(1, 1.0, t2),
                           cw_clearance=peak(2, -1.0, t2 + 0.5), energy_error=energy)


def _energy_error(eq, par, phases, scene) -> float:
    """Largest |E(t) − E(0)| over the energy the counterweight gives, phases 1 and 2 (the
    projectile's energy is conserved apart once it flies)."""
    L1, L2, LCM, L3, L4, mb, M, m, I, H, g = par
    out, e0, du = 0.0, None, scene.delta_U
    for _phase, sol, a, b in phases[:2]:
        for t in np.linspace(a, b, 200):
            y = sol.sol(t)
            r_M = np.asarray(eq["r_M"](*y, *par), dtype=float).ravel()
            r_m = np.asarray(eq["r_m"](*y, *par), dtype=float).ravel()
            v_m = np.asarray(eq["v_m"](*y, *par), dtype=float).ravel()
            th, ps, thd, psd = y[0], y[1], y[3], y[4]
            v_M = np.array([L2 * math.sin(th) * thd - L3 * math.sin(ps) * psd,
                            -L2 * math.cos(th) * thd + L3 * math.cos(ps) * psd])
            E = (I * thd ** 2 / 2 + M * v_M @ v_M / 2 + m * v_m @ v_m / 2
                 + g * (mb * (H + LCM * math.sin(th)) + M * r_M[1] + m * r_m[1]))
            e0 = E if e0 is None else e0
            out = max(out, abs(E - e0))
    return out / du

"""An independent model of the engine with Coulomb friction in its bearings, for the tests.

Nothing here comes from the package's formulas: the Lagrangian ``T − V`` of beam,
counterweight and projectile is written from the positions of the bodies, sympy derives the
mass matrix and the rest of the Lagrange equations, the loads follow from Newton's second law
on each body (the sling's tension and the trough's normal force solved from the projectile's
equation, the sling pulling along itself), the friction couples are found by plain fixed-point
iteration, and ``scipy.integrate.solve_ivp`` integrates phases I, II and III with its own
event location. Slow (a Python right-hand side) but plain. SI units throughout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

th, ps, ph = sp.symbols("theta psi phi", real=True)
thd, psd, phd = sp.symbols("theta_d psi_d phi_d", real=True)
P = sp.symbols("L1 L2 L_CM L3 L4 m_b M m I g H", real=True)
L1, L2, LCM, L3, L4, mb, M, m, I, g, H = P


def _e(a: sp.Expr) -> sp.Matrix:
    return sp.Matrix([sp.cos(a), sp.sin(a)])


@dataclass(frozen=True)
class PhaseModel:
    """Lambdified pieces of one phase: mass matrix, forces and the bodies' accelerations."""

    coords: tuple
    mass: object       # (params, q, qd) -> n x n
    rest: object       # (params, q, qd) -> n: generalised forces of gravity and velocities
    acc_terms: object  # (params, q, qd) -> (a_CM, a_M, a_m) at q̈ = 0, each 2-vector
    acc_jac: object    # (params, q, qd) -> d(a_CM, a_M, a_m)/dq̈: 6 x n


@cache
def phase_model(phase: int) -> PhaseModel:
    """Phase 1: coordinates (θ, ψ), the projectile on the ground on the taut sling; phase 2:
    (θ, ψ, φ); phase 3: (θ, ψ), no projectile."""
    t = sp.Symbol("t")
    q = [th, ps] if phase != 2 else [th, ps, ph]
    qf = [sp.Function(f"q{i}")(t) for i in range(len(q))]
    sub = dict(zip(q, qf, strict=True))
    pivot = sp.Matrix([0, H])
    r_cm = pivot + LCM * _e(th)
    r_M = pivot - L2 * _e(th) + L3 * _e(ps)
    if phase == 1:
        phi_c = -sp.pi + sp.asin((H + L1 * sp.sin(th)) / L4)
        r_m = pivot + L1 * _e(th) + L4 * _e(phi_c)
    elif phase == 2:
        r_m = pivot + L1 * _e(th) + L4 * _e(ph)
    else:
        r_m = None
    bodies = [(r_cm, None), (r_M, M)] + ([(r_m, m)] if r_m is not None else [])
    T = sp.Rational(1, 2) * I * sp.diff(th.subs(sub), t) ** 2
    V = mb * g * r_cm[1]
    for r, mass in bodies[1:]:
        v = sp.diff(r.subs(sub), t)
        T += sp.Rational(1, 2) * mass * (v.T * v)[0]
        V += mass * g * r.subs(sub)[1]
    Lag = T - V.subs(sub) if not isinstance(V, int) else T
    eqs = [sp.diff(sp.diff(Lag, sp.diff(f, t)), t) - sp.diff(Lag, f) for f in qf]
    qd_s = [thd, psd, phd][:len(q)]
    qdd_s = sp.symbols(f"a0:{len(q)}")
    back = {}
    for f, b, c in zip(qf, qd_s, qdd_s, strict=True):
        back[sp.diff(f, t, 2)] = c
        back[sp.diff(f, t)] = b
    eqs = [e.subs(back).subs(dict(zip(qf, q, strict=True))) for e in eqs]
    Mm = sp.Matrix([[sp.diff(e, a) for a in qdd_s] for e in eqs])
    rest = sp.Matrix([-e.subs(dict.fromkeys(qdd_s, 0)) for e in eqs])
    accs = []
    for r, _ in bodies:
        rf = r.subs(sub)
        a = sp.diff(rf, t, 2).subs(back).subs(dict(zip(qf, q, strict=True)))
        accs.append(a)
    A = sp.Matrix.vstack(*accs)
    A0 = A.subs(dict.fromkeys(qdd_s, 0))
    J = A.jacobian(qdd_s)
    args = (P, q, qd_s)
    return PhaseModel(tuple(q), sp.lambdify(args, Mm, "numpy"), sp.lambdify(args, rest, "numpy"),
                      sp.lambdify(args, A0, "numpy"), sp.lambdify(args, J, "numpy"))


def _params(scene) -> tuple:
    e = scene.engine
    return (e.L1, e.L2, e.L_CM, e.L3, e.L4, e.m_b, e.M, e.m, e.I, scene.g, scene.start.H)


def loads_at(phase: int, scene, q, qd, Q) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """q̈, F_R, F_H (N) and the trough's normal force (N) under generalised forces ``Q``."""
    pm = phase_model(phase)
    p = _params(scene)
    e = scene.engine
    qdd = np.linalg.solve(np.array(pm.mass(p, q, qd), float),
                          np.array(pm.rest(p, q, qd), float).ravel() + np.asarray(Q[:len(q)]))
    a = (np.array(pm.acc_terms(p, q, qd), float).ravel()
         + np.array(pm.acc_jac(p, q, qd), float) @ qdd)
    gy = np.array([0.0, scene.g])
    F_CM = e.m_b * (a[0:2] + gy)
    F_H = e.M * (a[2:4] + gy)
    F_S, N = np.zeros(2), 0.0
    if phase == 1:  # m (a + g e_y) = T e_φ + N e_y: the sling pulls along itself
        phi = -math.pi + math.asin((scene.start.H + e.L1 * math.sin(q[0])) / e.L4)
        need = e.m * (a[4:6] + gy)
        T, N = np.linalg.solve(np.array([[math.cos(phi), 0.0], [math.sin(phi), 1.0]]), need)
        F_S = T * np.array([math.cos(phi), math.sin(phi)])
    elif phase == 2:
        F_S = e.m * (a[4:6] + gy)
    return qdd, F_CM + F_H + F_S, F_H, N


def friction_forces(phase: int, scene, q, qd) -> tuple[tuple, float, float]:
    """The generalised forces ``(Q_θ, Q_ψ, 0)`` of the converged couples and the loss powers
    of pivot and hinge (W), by plain fixed-point iteration on the two load magnitudes."""
    fr = scene.engine.friction
    sP = math.tanh(qd[0] / fr.smoothing_rate)
    sH = math.tanh((qd[1] - qd[0]) / fr.smoothing_rate)
    n = np.zeros(2)
    for _ in range(200):
        tP, tH = fr.pivot * n[0] * sP, fr.hinge * n[1] * sH
        _, F_R, F_H, _ = loads_at(phase, scene, q, qd, (tH - tP, -tH, 0.0))
        new = np.array([np.hypot(*F_R), np.hypot(*F_H)])
        done = np.all(np.abs(new - n) <= 1e-15 * np.abs(new))
        n = new
        if done:
            break
    tP, tH = fr.pivot * n[0] * sP, fr.hinge * n[1] * sH
    return (tH - tP, -tH, 0.0), tP * qd[0], tH * (qd[1] - qd[0])


def simulate_reference(scene, rtol: float = 1e-12, after_release: float = 0.5):
    """Integrate phases I–III with friction; returns a callable ``state(t)`` giving
    ``(phase, q (θ, ψ, φ), qd, lost energies (pivot, hinge))`` and the event times."""
    e = scene.engine
    s = scene.start
    H = s.H

    def rhs(phase):
        def f(t, y):
            k = 3 if phase == 2 else 2
            q, qd = y[:k], y[k:2 * k]
            Q, PP, PH = friction_forces(phase, scene, q, qd)
            qdd = loads_at(phase, scene, q, qd, Q)[0]
            return np.concatenate([qd, qdd, [PP, PH]])
        return f

    def lift_off(t, y):
        Q = friction_forces(1, scene, y[:2], y[2:4])[0]
        return loads_at(1, scene, y[:2], y[2:4], Q)[3] / (e.m * scene.g)
    lift_off.terminal, lift_off.direction = True, -1

    def climb(t, y):
        th_, ph_, thd_, phd_ = y[0], y[2], y[3], y[5]
        vx = -e.L1 * math.sin(th_) * thd_ - e.L4 * math.sin(ph_) * phd_
        vy = e.L1 * math.cos(th_) * thd_ + e.L4 * math.cos(ph_) * phd_
        a = scene.release.velocity_angle
        return math.sin(a) * (-vx) - math.cos(a) * vy
    climb.terminal, climb.direction = True, 1

    opts = dict(method="DOP853", rtol=rtol, atol=rtol * 1e-2, dense_output=True)
    y0 = [s.theta, s.psi, 0.0, 0.0, 0.0, 0.0]
    s1 = solve_ivp(rhs(1), (0.0, 5.0), y0, events=[lift_off], **opts)
    t_lift = float(s1.t_events[0][0])
    y = s1.y_events[0][0]
    phi = -math.pi + math.asin((H + e.L1 * math.sin(y[0])) / e.L4)
    phid = -e.L1 * math.cos(y[0]) * y[2] / (e.L4 * math.cos(phi))
    y2 = [y[0], y[1], phi, y[2], y[3], phid, y[4], y[5]]
    if scene.release.time is not None:
        s2 = solve_ivp(rhs(2), (t_lift, scene.release.time), y2, **opts)
        t_rel, yr = scene.release.time, s2.y[:, -1]
    else:
        s2 = solve_ivp(rhs(2), (t_lift, 5.0), y2, events=[climb], **opts)
        t_rel, yr = float(s2.t_events[0][0]), s2.y_events[0][0]
    y3 = [yr[0], yr[1], yr[3], yr[4], yr[6], yr[7]]
    s3 = solve_ivp(rhs(3), (t_rel, t_rel + after_release), y3, **opts)

    def state(t):
        if t <= t_lift:
            y = s1.sol(t)
            phi = -math.pi + math.asin((H + e.L1 * math.sin(y[0])) / e.L4)
            return 1, np.array([y[0], y[1], phi]), y[2:4], y[4:6]
        if t <= t_rel:
            y = s2.sol(t)
            return 2, y[0:3], y[3:6], y[6:8]
        y = s3.sol(t)
        return 3, np.array([y[0], y[1], np.nan]), y[2:4], y[4:6]
    return state, {"lift_off": t_lift, "release": t_rel}

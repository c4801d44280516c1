"""Speed of one simulated shot of the paper's engine (Horsdal's large engine, release by time).

Times, over ``REPEATS`` runs after a warm-up, interleaved so that the load of the machine falls
on all alike:

* ``simulate``: :func:`trebuchet.model.simulate.simulate` at its defaults (DOP853 in the C
  generated from the model's formulas, run in process, rtol 1e-10, atol 1e-12, outputs every
  1 ms plus the events, every force of the contract), and with the numba kernels
  (``method="numba-DOP853"``, the default before; the fallback where no C compiler is);
* ``integrate``: the integration alone (:func:`trebuchet.model.simulate.integrate`);
* ``load columns``: every load on the shot's 1500 output rows from its angles with the numba
  kernel (:func:`trebuchet.model.loads.load_columns`, compiled
  :func:`~trebuchet.model.forces.row_loads`: the path of measured logs);
* ``simulate, back to back``: ``simulate`` called ``repeats`` times in a row, as a sweep does
  (the interleaved lines above run each call after the others, with colder caches);
* ``simulate (python-DOP853)``: the same steps taken by the pure-Python DOP853 of
  :mod:`trebuchet.model.integrator` (what the default was before the compiled kernel);
* ``simulate (scipy solve_ivp)``: the same simulator with ``method="scipy-DOP853"``;
* ``plain solve_ivp``: :func:`plain_shot` below, the baseline of the issue: the equations of
  motion written plainly from the Lagrangian (a numpy mass matrix and ``np.linalg.solve``
  in the right-hand side; phase I with the trough constraint as a Lagrange multiplier),
  scipy's ``solve_ivp`` DOP853 with events and dense output at the same tolerance, and the
  forces at the same output times.

The table gives the median, the quartiles and the minimum in ms, the right-hand-side
evaluations and each line's ratio to the plain baseline; the notes record the machine.
"""

from __future__ import annotations

import gc
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

from trebuchet.model.loads import load_columns
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import DEFAULT_RTOL, default_times, integrate, simulate

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "data_samples" / "horsdal_large.toml"
REPEATS = int(os.environ.get("BENCH_REPEATS", "50"))
WARMUP = 3
AFTER_RELEASE = 0.5  # s of phase III, as simulate's default
DT = 1e-3  # s, output grid, as simulate's default


# ---------------------------------------------------------------------------------------------
# The plain baseline: Lagrange's equations with a mass matrix, solve_ivp, forces at the outputs.

def _mass_and_force(q, qd, e, g, with_sling: bool):
    """Mass matrix and generalised forces (gravity and centripetal terms) of θ, ψ[, φ] from
    ``T = ½ I θ̇² + ½ M |v_M|² (+ ½ m |v_m|²)`` and ``V`` of beam, counterweight, projectile."""
    th, ps = q[0], q[1]
    thd, psd = qd[0], qd[1]
    c_tp = -e.M * e.L2 * e.L3  # coefficient of cos(θ − ψ) θ̇ ψ̇ in T
    n = 3 if with_sling else 2
    Mm = np.zeros((n, n))
    b = np.zeros(n)
    Mm[0, 0] = e.I + e.M * e.L2**2
    Mm[1, 1] = e.M * e.L3**2
    Mm[0, 1] = Mm[1, 0] = c_tp * np.cos(th - ps)
    b[0] = -(e.m_b * e.L_CM - e.M * e.L2) * g * np.cos(th) - c_tp * np.sin(th - ps) * psd**2
    b[1] = -e.M * g * e.L3 * np.cos(ps) - c_tp * np.sin(ps - th) * thd**2
    if with_sling:
        ph, phd = q[2], qd[2]
        c_tf = e.m * e.L1 * e.L4
        Mm[0, 0] += e.m * e.L1**2
        Mm[2, 2] = e.m * e.L4**2
        Mm[0, 2] = Mm[2, 0] = c_tf * np.cos(th - ph)
        b[0] += -e.m * g * e.L1 * np.cos(th) - c_tf * np.sin(th - ph) * phd**2
        b[2] = -e.m * g * e.L4 * np.cos(ph) - c_tf * np.sin(ph - th) * thd**2
    return Mm, b


def _trough_phi(th, thd, e, H):
    ph = -np.pi + np.arcsin((H + e.L1 * np.sin(th)) / e.L4)
    phd = -e.L1 * np.cos(th) * thd / (e.L4 * np.cos(ph))
    return ph, phd


def _phase1_acc(y, e, g, H):
    """θ̈, ψ̈, φ̈ and the trough's normal force λ (N): ``[M Aᵀ; A 0][q̈; −λ] = [b; c]`` with the
    constraint ``H + L1 sin θ + L4 sin φ = 0``."""
    th, ps, thd, psd = y
    ph, phd = _trough_phi(th, thd, e, H)
    Mm, b = _mass_and_force((th, ps, ph), (thd, psd, phd), e, g, True)
    A = np.array([e.L1 * np.cos(th), 0.0, e.L4 * np.cos(ph)])
    K = np.zeros((4, 4))
    K[:3, :3] = Mm
    K[:3, 3] = -A
    K[3, :3] = A
    rhs = np.append(b, e.L1 * np.sin(th) * thd**2 + e.L4 * np.sin(ph) * phd**2)
    return np.linalg.solve(K, rhs)


def plain_shot(scene: Scene, rtol: float = DEFAULT_RTOL) -> pd.DataFrame:
    """One shot, written plainly: solve_ivp DOP853 per phase with events and dense output,
    then angles, accelerations and forces at the output times."""
    e, g, H, s, rel = scene.engine, scene.g, scene.start.H, scene.start, scene.release
    atol = rtol * 1e-2

    def rhs1(t, y):
        a = _phase1_acc(y, e, g, H)
        return [y[2], y[3], a[0], a[1]]

    def lift_off(t, y):
        return _phase1_acc(y, e, g, H)[3] / (e.m * g)
    lift_off.terminal, lift_off.direction = True, -1

    def rhs2(t, y):
        Mm, b = _mass_and_force(y[:3], y[3:], e, g, True)
        return np.concatenate([y[3:], np.linalg.solve(Mm, b)])

    def rhs3(t, y):
        Mm, b = _mass_and_force(y[:2], y[2:], e, g, False)
        return np.concatenate([y[2:], np.linalg.solve(Mm, b)])

    def climb(t, y):
        th, _, ph, thd, _, phd = y
        vx = -e.L1 * thd * np.sin(th) - e.L4 * phd * np.sin(ph)
        vy = e.L1 * thd * np.cos(th) + e.L4 * phd * np.cos(ph)
        return np.sin(rel.velocity_angle) * (-vx) - np.cos(rel.velocity_angle) * vy
    climb.terminal, climb.direction = True, 1

    s1 = solve_ivp(rhs1, (0.0, 60.0), [s.theta, s.psi, 0.0, 0.0], method="DOP853", rtol=rtol,
                   atol=atol, dense_output=True, events=[lift_off])
    t_lift = s1.t_events[0][0]
    th, ps, thd, psd = s1.y_events[0][0]
    ph, phd = _trough_phi(th, thd, e, H)
    if rel.time is not None:
        s2 = solve_ivp(rhs2, (t_lift, rel.time), [th, ps, ph, thd, psd, phd], method="DOP853",
                       rtol=rtol, atol=atol, dense_output=True)
        t_rel, y_rel = s2.t[-1], s2.y[:, -1]
    else:
        s2 = solve_ivp(rhs2, (t_lift, 60.0), [th, ps, ph, thd, psd, phd], method="DOP853",
                       rtol=rtol, atol=atol, dense_output=True, events=[climb])
        t_rel, y_rel = s2.t_events[0][0], s2.y_events[0][0]
    t_end = t_rel + AFTER_RELEASE
    s3 = solve_ivp(rhs3, (t_rel, t_end), y_rel[[0, 1, 3, 4]], method="DOP853", rtol=rtol,
                   atol=atol, dense_output=True)

    grid = np.arange(0.0, t_end + 0.5 * DT, DT)
    t = np.unique(np.concatenate([grid[grid <= t_end], [t_lift, t_rel, t_end]]))
    rows = []
    for k, (sol, lo, hi) in enumerate(((s1, -1.0, t_lift), (s2, t_lift, t_rel),
                                       (s3, t_rel, t_end)), start=1):
        tk = t[(t > lo) & (t <= hi)]
        y = sol.sol(tk)
        if k == 1:
            th, ps, thd, psd = y
            ph, phd = _trough_phi(th, thd, e, H)
            acc = np.array([_phase1_acc(col, e, g, H) for col in y.T]).T
            thdd, psdd, lam = acc[0], acc[1], acc[3]
            phdd = (e.L4 * np.sin(ph) * phd**2 - e.L1 * (np.cos(th) * thdd
                                                          - np.sin(th) * thd**2)) / (
                e.L4 * np.cos(ph))
        elif k == 2:
            th, ps, ph, thd, psd, phd = y
            acc = np.array([rhs2(0.0, col)[3:] for col in y.T]).T
            thdd, psdd, phdd = acc
            lam = np.zeros_like(th)
        else:
            th, ps, thd, psd = y
            acc = np.array([rhs3(0.0, col)[2:] for col in y.T]).T
            thdd, psdd = acc
            ph = phd = phdd = lam = np.zeros_like(th)
        rows.append(pd.DataFrame({"t": tk, "phase": k, "theta": th, "psi": ps, "phi": ph,
                                  "theta_d": thd, "psi_d": psd, "phi_d": phd,
                                  "theta_dd": thdd, "psi_dd": psdd, "phi_dd": phdd,
                                  "F_N": lam}))
    run = pd.concat(rows, ignore_index=True)
    return _plain_forces(run, scene)


def _plain_forces(run: pd.DataFrame, scene: Scene) -> pd.DataFrame:
    """The paper's forces from the angles: ``F = Σ mass × length × R_a A_a + weight``."""
    e, g, H = scene.engine, scene.g, scene.start.H

    def ra(a, ad, add):  # R_a A_a = ä e_a⊥ − ȧ² e_a
        return np.array([-np.sin(a) * add - np.cos(a) * ad**2,
                         np.cos(a) * add - np.sin(a) * ad**2])

    th, ps, ph = run.theta.to_numpy(), run.psi.to_numpy(), run.phi.to_numpy()
    thd, psd, phd = run.theta_d.to_numpy(), run.psi_d.to_numpy(), run.phi_d.to_numpy()
    thdd, psdd, phdd = run.theta_dd.to_numpy(), run.psi_dd.to_numpy(), run.phi_dd.to_numpy()
    held = run.phase.to_numpy() <= 2
    ey = np.array([[0.0], [1.0]])
    A_th = ra(th, thd, thdd)
    F_CM = e.m_b * e.L_CM * A_th + e.m_b * g * ey
    F_H = -e.M * e.L2 * A_th + e.M * e.L3 * ra(ps, psd, psdd) + e.M * g * ey
    F_S = np.where(held, e.m * e.L1 * A_th + e.m * e.L4 * ra(ph, phd, phdd) + e.m * g * ey
                   - run.F_N.to_numpy() * ey, 0.0)
    F_R = F_H + F_CM + F_S
    perp = np.array([-np.sin(th), np.cos(th)])
    torque = (e.L2 * (F_H * perp).sum(0) - e.L_CM * e.m_b * g * perp[1]
              - e.L1 * (F_S * perp).sum(0))
    v_M = -e.L2 * thd * perp + e.L3 * psd * np.array([-np.sin(ps), np.cos(ps)])
    v_m = e.L1 * thd * perp + e.L4 * phd * np.array([-np.sin(ph), np.cos(ph)])
    y_M = H - e.L2 * np.sin(th) + e.L3 * np.sin(ps)
    y_m = H + e.L1 * np.sin(th) + e.L4 * np.sin(ph)
    E = (0.5 * e.I * thd**2 + e.m_b * g * (H + e.L_CM * np.sin(th))
         + 0.5 * e.M * (v_M**2).sum(0) + e.M * g * y_M
         + np.where(held, 0.5 * e.m * (v_m**2).sum(0) + e.m * g * y_m, 0.0))
    out = {"F_S_x": F_S[0], "F_S_y": F_S[1], "F_H_x": F_H[0], "F_H_y": F_H[1],
           "F_CM_x": F_CM[0], "F_CM_y": F_CM[1], "F_R_x": F_R[0], "F_R_y": F_R[1],
           "torque": torque, "E_engine": E}
    return pd.concat([run, pd.DataFrame(out, index=run.index)], axis=1)


# ---------------------------------------------------------------------------------------------

def machine_notes() -> list[str]:
    """What the numbers were measured on (CPU, versions, BLAS settings)."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            cpu = next((ln.split(":", 1)[1].strip() for ln in fh if ln.startswith("model name")),
                       cpu)
    except OSError:
        pass
    import scipy

    blas = {k: os.environ.get(k, "unset") for k in ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE")}
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return [
        f"machine: {cpu}, {os.cpu_count()} cores, load average {load:.2f} at the start",
        f"Python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}, "
        f"pandas {pd.__version__}",
        "OPENBLAS_CORETYPE={OPENBLAS_CORETYPE}, OPENBLAS_L2_SIZE={OPENBLAS_L2_SIZE} (BLAS plays "
        "no part here: the largest array solved is 4×4)".format(**blas),
    ]


def run(out_dir: str | Path | None = None, repeats: int = REPEATS) -> pd.DataFrame:
    """Time the four lines (interleaved, ``repeats`` each after a warm-up) and return the
    table; the accuracy of the baseline against ``simulate`` goes in ``attrs['notes']``."""
    scene = Scene.from_toml(SCENE)
    traj = integrate(scene)
    angles = traj.angle_columns(default_times(traj))
    cases = {
        "simulate (default: the generated C)": lambda: simulate(scene),
        "integrate only (the generated C)": lambda: integrate(scene),
        "simulate with method='numba-DOP853' (the numba kernels)": lambda: simulate(
            scene, method="numba-DOP853"),
        "load columns only (compiled row_loads, 1500 rows)": lambda: load_columns(
            angles, scene, release_state=traj.release_state),
        "simulate with method='python-DOP853' (same steps, pure Python)": lambda: simulate(
            scene, method="python-DOP853"),
        "simulate with method='scipy-DOP853' (solve_ivp)": lambda: simulate(
            scene, method="scipy-DOP853"),
        "plain solve_ivp implementation (baseline)": lambda: plain_shot(scene),
    }
    nfev = {name: integrate(scene, method=method).nfev for name, method in (
        ("simulate (default: the generated C)", "DOP853"),
        ("integrate only (the generated C)", "DOP853"),
        ("simulate with method='numba-DOP853' (the numba kernels)", "numba-DOP853"),
        ("simulate with method='python-DOP853' (same steps, pure Python)", "python-DOP853"),
        ("simulate with method='scipy-DOP853' (solve_ivp)", "scipy-DOP853"))}
    for fn in cases.values():
        for _ in range(WARMUP):
            fn()
    times: dict[str, list[float]] = {k: [] for k in cases}
    gc.collect()
    for i in range(repeats):
        for name, fn in cases.items():
            t0 = time.perf_counter()
            fn()
            times[name].append(1e3 * (time.perf_counter() - t0))
        if (i + 1) % 10 == 0:
            print(f"  model_speed: {i + 1}/{repeats} repeats", file=sys.stderr, flush=True)
    back_to_back = "simulate, back to back (as in a sweep)"
    times[back_to_back] = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        simulate(scene)
        times[back_to_back].append(1e3 * (time.perf_counter() - t0))
    nfev[back_to_back] = nfev["simulate (default: the generated C)"]
    base = float(np.median(times["plain solve_ivp implementation (baseline)"]))
    rows = []
    for name, ts in times.items():
        a = np.asarray(ts)
        rows.append({"case": name, "median_ms": np.median(a), "p25_ms": np.percentile(a, 25),
                     "p75_ms": np.percentile(a, 75), "min_ms": a.min(), "repeats": a.size,
                     "nfev": nfev.get(name, np.nan), "ratio_to_plain": np.median(a) / base})
    table = pd.DataFrame(rows)

    # the baseline is a check of the model too: same shot, independent equations
    ours = simulate(scene)
    plain = plain_shot(scene)
    diff = {c: float(np.max(np.abs(ours[c].to_numpy() - plain[c].to_numpy())))
            for c in ("theta", "psi", "theta_dd", "F_H_x", "F_H_y", "F_S_x", "F_S_y")}
    sim = table.set_index("case").median_ms
    notes = machine_notes() + [
        f"scene: {SCENE.relative_to(ROOT)} (release at t = {scene.release.time} s), "
        f"{len(ours)} output rows, {len(ours.columns)} columns from simulate, "
        f"rtol {DEFAULT_RTOL:g}, atol {DEFAULT_RTOL * 1e-2:g}",
        f"energy drift of simulate: {ours.attrs['diagnostics']['energy_drift_rel']:.2e} of ΔU",
        "plain baseline against simulate, max |difference|: "
        + ", ".join(f"{k} {v:.1e}" for k, v in diff.items()),
        f"target of the issue: simulate ≤ 3 ms median and ≤ 0.5 × plain: "
        f"{sim.iloc[0]:.2f} ms, {sim.iloc[0] / base:.3f} × plain",
    ]
    table.attrs["notes"] = notes
    return table


if __name__ == "__main__":  # pragma: no cover
    print(run().to_string())

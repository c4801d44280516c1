"""Design under load limits on the paper's engine: the optimiser against a 2912-design grid.

The case of issue 24: the paper's engine (Table 1) released at a 40° climb, L4 (3–8 m), L3
(1–4 m) and the climb angle (25–55°) free, limited to peak |F_R| ≤ 2.5 M g, peak |F_S| ≤
55 m g and the counterweight's centre at least 1.0 m above the ground (trigger to 0.5 s past
the release). The grid: 16 × 13 × 14 = 2912 designs, evenly spaced, both ends included
(`trebuchet sweep`); its best design meeting the limits is checked by an independent
simulation (`bench/_independent_shot.py`: the Lagrangian derived with sympy, scipy's
solve_ivp, loads from Newton's law on each body; none of the package's model), the next best
taken while a check fails. Then `trebuchet design` (differential evolution + SLSQP) with
three seeds, each best checked the same way. The sweep is timed before and after the
searches, and the faster of the two is the baseline of ``time_ratio``. The machine is shared
and each run takes well under a second: every time is the least of :data:`REPEATS` runs
(``BENCH_REPEATS``; another process's load only ever adds).

Targets: every search's independently checked range at least 99.5 % of the checked grid
best's, every limit met by the independent check, in at most 0.5 × the sweep's time.

``run(out_dir)`` also writes ``design_reoptimised.md``: the paper's engine re-optimised under
its own peak loads (docs/design.md).
"""

from __future__ import annotations

import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench._independent_shot import independent_shot  # noqa: E402
from trebuchet.model.design import design  # noqa: E402
from trebuchet.model.design_problem import parse_limit  # noqa: E402
from trebuchet.model.scene import Scene  # noqa: E402
from trebuchet.model.sweep import default_workers, design_scene, sweep  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "data_samples" / "horsdal_large.toml"
VARY = {"engine.L4": (3.0, 8.0), "engine.L3": (1.0, 4.0),
        "release.velocity_angle_deg": (25.0, 55.0)}
COUNTS = {"engine.L4": 16, "engine.L3": 13, "release.velocity_angle_deg": 14}
SEEDS = (1, 2, 3)


def base_scene() -> Scene:
    return Scene.from_toml(SCENE).with_release(velocity_angle=math.radians(40.0))


def limits(base: Scene) -> list[str]:
    e, g = base.engine, base.g
    return [f"F_R_peak <= {2.5 * e.M * g!r}", f"F_S_peak <= {55 * e.m * g!r}",
            "cw_clearance >= 1.0"]


def _checked(scene: Scene, lims: list[str]) -> tuple[dict, bool]:
    shot = independent_shot(scene)
    values = {"F_R_peak": shot.F_R_peak, "F_S_peak": shot.F_S_peak,
              "cw_clearance": shot.cw_clearance}
    met = all(parse_limit(x).margin(values[parse_limit(x).figure]) >= 0 for x in lims)
    return {"range": shot.range, **values}, met


def _row(label: str, designs: int, seconds: float, own_range: float, check: dict, met: bool,
         base: Scene) -> dict:
    e, g = base.engine, base.g
    return {"search": label, "designs": designs, "seconds": seconds, "range_m": own_range,
            "checked_range_m": check["range"], "F_R_peak_Mg": check["F_R_peak"] / (e.M * g),
            "F_S_peak_mg": check["F_S_peak"] / (e.m * g),
            "cw_clearance_m": check["cw_clearance"], "limits_met_checked": met}


REPEATS = int(os.environ.get("BENCH_REPEATS", "3"))


def _timed(call):
    """``call()``'s result and the least wall time of :data:`REPEATS` runs of it (s)."""
    best = math.inf
    for _ in range(max(1, REPEATS)):
        t0 = time.perf_counter()
        result = call()
        best = min(best, time.perf_counter() - t0)
    return result, best


def run(out_dir: str | Path | None = None) -> pd.DataFrame:
    base = base_scene()
    lims = limits(base)
    grid = {k: list(np.linspace(*VARY[k], COUNTS[k])) for k in VARY}
    table, first = _timed(lambda: sweep(base, grid, progress=False))
    sweep_s = [first]
    ok = table[table["status"] == "ok"]
    for text in lims:
        lim = parse_limit(text)
        ok = ok[lim.margin(ok[lim.figure]) >= 0]
    rows = []
    for _, best in ok.sort_values("range", ascending=False).iterrows():
        scene = design_scene(base, {k: best[k] for k in VARY})
        check, met = _checked(scene, lims)
        if met:
            rows.append(_row("grid sweep 16 x 13 x 14", len(table), sweep_s[0], best["range"],
                             check, met, base))
            break
    grid_best = rows[0]["checked_range_m"]
    for seed in SEEDS:
        res, seconds = _timed(lambda seed=seed: design(base, VARY, maximize="range",
                                                       limits=lims, seed=seed))
        check, met = _checked(res.scene, lims)
        rows.append(_row(f"design, seed {seed}", res.evaluations, seconds, res.value, check,
                         met, base))
    sweep_s.append(_timed(lambda: sweep(base, grid, progress=False))[1])
    baseline = min(sweep_s)
    out = pd.DataFrame(rows)
    out["time_ratio"] = out["seconds"] / baseline
    out["range_share"] = out["checked_range_m"] / grid_best
    searches = out.iloc[1:]
    out.attrs["notes"] = [
        f"the sweep took {sweep_s[0]:.2f} s and {sweep_s[1]:.2f} s (before and after the "
        f"searches, each the least of {REPEATS} runs); time_ratio is over the faster; each at "
        f"its default: the sweep on {default_workers()} worker processes, the design in this "
        "process (the generated C, many designs a call)",
        "targets: range_share >= 0.995, every limit met when checked, time_ratio <= 0.5; met: "
        f"range {bool((searches['range_share'] >= 0.995).all())}, limits "
        f"{bool(searches['limits_met_checked'].all())}, time "
        f"{bool((searches['time_ratio'] <= 0.5).all())}",
        "checked_*: the independent simulation (sympy Lagrangian, solve_ivp DOP853 rtol "
        "1e-11, peaks refined on its dense output); F_R in M g, F_S in m g",
        f"machine: {platform.machine()}, {default_workers()} usable cores, Python "
        f"{platform.python_version()}",
    ]
    if out_dir is not None:
        reoptimised(base, out_dir)
    return out


MU = 0.15  # Coulomb coefficient of both bearings in the friction rows (steel on bronze, dry)
SHEAR = 40e6  # Pa, the allowable shear stress the shafts are sized for


def _with_friction(scene: Scene) -> Scene:
    data = scene.to_dict()
    data["friction"] = {"pivot_mu": MU, "pivot_radius": 0.1, "hinge_mu": MU,
                        "hinge_radius": 0.06}
    return Scene.from_dict(data, source=f"{scene.source} with friction")


def reoptimised(base: Scene, out_dir: str | Path) -> pd.DataFrame:
    """The paper's engine (release by its time) and the same engine re-optimised under its own
    peak loads: L2, L3, L4 and the climb angle free, every peak load at most the paper's,
    the counterweight 1 m clear of the ground; then both again with friction in the bearings
    (μ = 0.15, each shaft sized for its own peak load at 40 MPa)."""
    from bench.__main__ import markdown
    from trebuchet.model.design_sizing import Sizing, sized
    from trebuchet.model.shot_summary import shot_figures

    paper = Scene.from_toml(SCENE)
    own = shot_figures(paper)
    names = ("F_R_peak", "F_H_peak", "F_S_peak", "torque_peak")
    lims = [f"{n} <= {getattr(own, n)!r}" for n in names] + ["cw_clearance >= 1.0"]
    vary = {"engine.L2": (0.5, 1.5), **VARY}
    sizing = Sizing(pivot_shear_stress=SHEAR, hinge_shear_stress=SHEAR)
    res = design(base, vary, maximize="range", limits=lims, seed=1)
    check, met = _checked(res.scene, [x for x in lims if x.split()[0] in
                                      ("F_R_peak", "F_S_peak", "cw_clearance")])
    rough_paper, rough_own = sized(_with_friction(paper), sizing, shot_figures)
    rough = design(_with_friction(base), vary, maximize="range", limits=lims, seed=1,
                   sizing=sizing)
    cols = ["range", "release_angle_deg", "F_R_peak", "F_H_peak", "F_S_peak", "torque_peak",
            "cw_clearance", "energy_share", "loss_share"]

    def row(label: str, scene: Scene, figures: dict) -> dict:
        e, fr = scene.engine, scene.to_dict().get("friction", {})
        return {"engine": label, "engine.L2": e.L2, "engine.L3": e.L3, "engine.L4": e.L4,
                **{c: figures[c] for c in cols},
                "pivot_radius_mm": 1e3 * fr.get("pivot_radius", math.nan),
                "hinge_radius_mm": 1e3 * fr.get("hinge_radius", math.nan)}

    out = pd.DataFrame([
        row("the paper's (Table 1, release at 0.997 s)", paper, own.as_dict()),
        row("re-optimised under its own peak loads", res.scene, res.figures),
        row("the paper's, friction in the bearings", rough_paper, rough_own.as_dict()),
        row("re-optimised under the same loads, friction in the bearings", rough.scene,
            rough.figures)])
    notes = [f"limits: {', '.join(lims)} (N, m); varied: L2 0.5-1.5 m, L3 1-4 m, L4 3-8 m, "
             "the release's climb 25-55 deg; seed 1",
             f"independent check of the frictionless re-optimised design: range "
             f"{check['range']:.2f} m, limits on F_R, F_S and clearance met: {met}",
             f"friction: mu = {MU} at pivot and hinge, each shaft a solid pin in double shear "
             f"sized for its own peak load at {SHEAR / 1e6:g} MPa, r = sqrt(F / (2 pi tau)) "
             "(docs/design.md); loss_share: heat by the release, % of dU",
             f"designs simulated: {res.evaluations} without friction, {rough.evaluations} with "
             "(each of these two or three shots: the radii's fixed point)"]
    title = "The paper's engine re-optimised under its own peak loads, without and with friction."
    Path(out_dir, "design_reoptimised.md").write_text(markdown(out, title, notes))
    out.to_csv(Path(out_dir, "design_reoptimised.csv"), index=False)
    return out


if __name__ == "__main__":
    result = run()
    print("\n".join(result.attrs["notes"]))
    print(result.to_string(index=False))

"""Every number the paper quotes that the model computes, side by side.

:func:`paper_comparison` simulates the engine of Table 1 and returns one row
per quoted number: the paper's value, the model's, their difference, the
tolerance the printed precision justifies (half a unit of the last printed
digit; wider where the paper says "about" or reads a number off a plot) and,
where the two differ beyond it, why. The command ``trebuchet paper`` prints
it, docs/paper.md quotes it, and the tests hold the model to it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model.initial import initial_state, static_forces
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import simulate

__all__ = ["PaperValue", "paper_values", "paper_comparison", "horsdal_scene_path"]


def horsdal_scene_path() -> Path:
    """Path of the shipped scene of the paper's Table 1 (g = 9.82 m/s²)."""
    return Path(str(resources.files("trebuchet.data_samples") / "horsdal_large.toml"))


@dataclass(frozen=True)
class PaperValue:
    """A number quoted by the paper: where, what, its value, unit and tolerance, and a note
    where the model differs."""

    section: str
    quantity: str
    paper: float
    unit: str
    tolerance: float
    compute: Callable[[dict], float]
    note: str = ""


class _Shot:
    """The simulated shot of Table 1 at 0.1 ms resolution, with helpers for extremes."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        e = scene.engine
        self.Mg = e.M * scene.g
        self.mg = e.m * scene.g
        self.run = simulate(scene, dt=1e-4)
        self.shot = self.run[self.run["phase"] <= 2].reset_index(drop=True)
        self.events = self.run.attrs["events"]
        self.flight = self.run.attrs["flight"]
        self.delta_u = self.run.attrs["diagnostics"]["delta_U"]
        self.static = static_forces(scene, "a")
        self.initial = initial_state(scene)

    def col(self, name: str) -> np.ndarray:
        return self.shot[name].to_numpy()

    def peak(self, values: np.ndarray) -> tuple[float, float]:
        """Largest value and its time, refined by a parabola through the three samples."""
        i = int(np.argmax(values))
        t = self.shot["t"].to_numpy()
        if 0 < i < len(values) - 1:
            y0, y1, y2 = values[i - 1], values[i], values[i + 1]
            curvature = y0 - 2 * y1 + y2
            if curvature < 0:
                shift = 0.5 * (y0 - y2) / curvature
                return float(y1 - 0.25 * (y0 - y2) * shift), float(t[i] + shift * (t[i + 1] - t[i]))
        return float(values[i]), float(t[i])

    def release(self, name: str) -> float:
        return float(self.shot[name].iloc[-1])

    def at(self, name: str, t: float) -> float:
        return float(np.interp(t, self.shot["t"], self.shot[name]))

    def first_crossing(self, values: np.ndarray, after: float = 0.0) -> float:
        t = self.shot["t"].to_numpy()
        idx = np.flatnonzero((np.sign(values[:-1]) != np.sign(values[1:])) & (t[:-1] >= after))
        i = int(idx[0])
        return float(t[i] - values[i] * (t[i + 1] - t[i]) / (values[i + 1] - values[i]))


def paper_values() -> list[PaperValue]:
    """The paper's quoted numbers and how the model computes each (the context ``c`` is a
    :class:`_Shot`), section by section."""
    rows: list[PaperValue] = []

    def add(section, quantity, paper, unit, tol, compute, note=""):
        rows.append(PaperValue(section, quantity, paper, unit, tol, compute, note))

    for part in (_tables, _initial_and_forces, _counterweight_and_torque, _release_and_energy):
        part(add)
    return rows


KN, MS = 1e3, 1e3  # kN per N, ms per s


def _tables(add) -> None:  # noqa: ANN001 - add(section, quantity, paper, unit, tol, compute)
    """Table 1, Section 4 and Table 3 (the forces at 0− and 0+)."""
    # Table 1 and Section 4.
    add("Table 1", "moment of inertia I", 7704, "kg m²", 0.5, lambda c: c.scene.engine.I)
    add("Sect. 4", "available energy ΔU", 255, "kJ", 0.5, lambda c: c.delta_u / KN)
    # Table 3, t = 0− (locking a, perpendicular at the spigot).
    for label, vec, scale, val_h, val_v, tol in (
        ("F_H/Mg", lambda c: c.static.F_H, "Mg", 0.0, 1.0, 0.5e-2),
        ("F_CM/Mg", lambda c: c.static.F_CM, "Mg", 0.0, 0.033, 0.5e-3),
        ("F_L/Mg", lambda c: c.static.F_L, "Mg", -0.058, -0.049, 0.5e-3),
        ("F_R/Mg", lambda c: c.static.F_R, "Mg", 0.058, 1.08, None),
    ):
        for k, comp, val in ((0, "h", val_h), (1, "v", val_v)):
            t_ = tol if tol is not None else (0.5e-3 if k == 0 else 0.5e-2)
            add("Table 3, 0−", f"{label} {comp}", val, "", t_,
                lambda c, vec=vec, k=k, scale=scale: vec(c)[k] / getattr(c, scale))
    # Table 3, t = 0+.
    for label, vec, scale, val_h, val_v, tol_h, tol_v in (
        ("F_m/mg", lambda c: c.initial.F_m, "mg", 2.93, 0.0, 0.5e-2, 0.5e-2),
        ("F_M/Mg", lambda c: c.initial.F_M, "Mg", 0.0, -0.33, 0.5e-2, 0.5e-2),
        ("F_H/Mg", lambda c: c.initial.F_H, "Mg", 0.0, 0.67, 0.5e-2, 0.5e-2),
        ("F_CM/Mg", lambda c: c.initial.F_CM, "Mg", 0.041, 0.067, 0.5e-3, 0.5e-3),
        ("F_R/Mg", lambda c: c.initial.F_R, "Mg", 0.057, 0.74, 0.5e-3, 0.5e-2),
    ):
        for k, comp, val, tol in ((0, "h", val_h, tol_h), (1, "v", val_v, tol_v)):
            add("Table 3, 0+", f"{label} {comp}", val, "", tol,
                lambda c, vec=vec, k=k, scale=scale: vec(c)[k] / getattr(c, scale))


def _initial_and_forces(add) -> None:  # noqa: ANN001
    """Section 9.5 (the accelerations and torque at 0+) and Section 11.1 (the forces)."""
    # Section 9: initial accelerations and torque.
    add("Sect. 9.5", "θ̈ at 0+", 5.79, "rad/s²", 0.005, lambda c: c.initial.theta_dd)
    add("Sect. 9.5", "torque N_i at 0+", 45, "kN m", 0.5, lambda c: c.initial.N / KN)
    add("Sect. 9.5", "hinge's torque 0.67 Mg L2 cos θ_i", 70, "kN m", 0.5,
        lambda c: c.initial.N_counterweight / KN)
    add("Sect. 9.5", "reduction of N_i by spigot and CM", 36, "%", 0.5,
        lambda c: 100 * (1 - c.initial.N / c.initial.N_counterweight))
    # Section 11: time dependencies.
    add("Sect. 11.1", "lift-off", 343, "ms", 0.5, lambda c: c.events["lift_off"] * MS,
        "the model lifts off 4.8 ms later; an independent implementation (docs/background.md) "
        "agrees with the model, so this is the paper's reading")
    add("Sect. 11.1", "sling tension at release", 52, "mg", 0.5,
        lambda c: c.release("F_S_abs") / c.mg,
        "at 997 ms; the paper's 52 mg is the model's value at 993 ms (52.3 mg): the paper's "
        "release-state numbers match a state ~4 ms earlier")
    add("Sect. 11.1", "max sling component across the beam", 35, "mg", 0.5,
        lambda c: c.peak(c.col("F_S_perp"))[0] / c.mg)
    add("Sect. 11.1", "time of that maximum", 876, "ms", 0.5,
        lambda c: c.peak(c.col("F_S_perp"))[1] * MS)
    add("Sect. 11.1", "hinge force F_H, minimum about halfway", 0.5, "Mg", 0.05,
        lambda c: c.col("F_H_abs").min() / c.Mg)
    add("Sect. 11.1", "hinge force F_H, maximum", 2.58, "Mg", 0.005,
        lambda c: c.col("F_H_abs").max() / c.Mg,
        "the model's peak is 0.3% lower; the paper's value is read off its Fig. 6a")
    add("Sect. 11.1", "F_R horizontal, extremum in the shooting direction", 0.2, "Mg", 0.05,
        lambda c: -c.col("F_R_x").min() / c.Mg)
    add("Sect. 11.1", "F_R horizontal, maximum against it before release", 0.3, "Mg", 0.05,
        lambda c: c.col("F_R_x").max() / c.Mg)
    add("Sect. 11.1", "max bending load |F_R·e_θ⊥|", 1.6, "Mg", 0.05,
        lambda c: np.abs(c.col("F_R_perp")).max() / c.Mg)
    add("Sect. 11.1", "time of max bending", 820, "ms", 5,
        lambda c: c.peak(np.abs(c.col("F_R_perp")))[1] * MS)
    add("Sect. 11.1", "sling's share of the max bending load", 10, "%", 1,
        lambda c: 100 * c.col("F_S_perp")[int(np.argmax(np.abs(c.col("F_R_perp"))))]
        / c.col("F_R_perp")[int(np.argmax(np.abs(c.col("F_R_perp"))))])


def _counterweight_and_torque(add) -> None:  # noqa: ANN001
    """Section 11.2 (the counterweight's force) and 11.3 (the torque)."""
    add("Sect. 11.2", "F_M at 0+ (paper: 1/3 of Mg; Table 3: 0.33)", 0.33, "Mg", 0.005,
        lambda c: c.col("F_M_abs")[0] / c.Mg)
    add("Sect. 11.2", "F_M at lift-off", 0.5, "Mg", 0.005,
        lambda c: c.at("F_M_abs", c.events["lift_off"]) / c.Mg)
    add("Sect. 11.2", "F_M turns horizontal", 695, "ms", 5,
        lambda c: c.first_crossing(c.col("F_M_y"), after=0.4) * MS)
    add("Sect. 11.2", "F_M maximum (paper: larger than 1.5 Mg)", 1.5, "Mg", 0.1,
        lambda c: c.col("F_M_abs").max() / c.Mg)
    add("Sect. 11.2", "F_M at release (paper: close to 0.5 Mg)", 0.5, "Mg", 0.05,
        lambda c: c.release("F_M_abs") / c.Mg,
        "0.38 Mg at 997 ms; 0.42 Mg at 993 ms. F_M falls fast near release; the paper's "
        "'close to 0.5' is a reading of its Fig. 8b")
    add("Sect. 11.2", "largest lifting force on the projectile (F_m·e_y)", 23, "mg", 0.5,
        lambda c: c.col("F_m_y").max() / c.mg)
    add("Sect. 11.3", "torque N crosses zero", 820, "ms", 15,
        lambda c: c.first_crossing(c.col("torque"), after=0.5) * MS,
        "the paper: 'near 820 ms ... at almost the same time' as the max bending (818 ms)")


def _release_and_energy(add) -> None:  # noqa: ANN001
    """Sections 11.4-11.6, 12 and 2: the release, the energies and the range."""
    add("Sect. 11.4", "climb at release", 40, "°", 0.5,
        lambda c: math.degrees(c.flight["release_angle"]),
        "39.5° at 997 ms; 40° is reached at 994 ms")
    add("Sect. 11.4", "release height", 15.1, "m", 0.05, lambda c: c.flight["release_height"],
        "15.28 m at 997 ms; 15.1 m is the model's height at 993 ms")
    add("Sect. 11.4", "release behind the fulcrum", 5.55, "m", 0.005,
        lambda c: c.flight["release_x"],
        "5.32 m at 997 ms; 5.53 m at 993 ms")
    add("Sect. 11.4", "release speed", 66, "m/s", 0.5, lambda c: c.flight["release_speed"])
    add("Sect. 11.4", "kinetic energy at release", 218, "kJ", 0.5,
        lambda c: 0.5 * c.scene.engine.m * c.flight["release_speed"] ** 2 / KN)
    add("Sect. 11.4", "potential energy at release", 15, "kJ", 0.5,
        lambda c: c.scene.engine.m * c.scene.g * c.flight["release_height"] / KN)
    add("Sect. 11.5", "projectile energy at release", 233, "kJ", 0.5,
        lambda c: c.release("E_m") / KN)
    add("Sect. 11.5", "max power on the projectile (paper: larger than 800 kW)", 800, "kW", 5,
        lambda c: c.col("P_m").max() / KN)
    add("Sect. 11.5", "time of max power on the projectile", 859, "ms", 0.5,
        lambda c: c.peak(c.col("P_m"))[1] * MS,
        "the model's peak lies at 859.5 ms, on the edge of the paper's rounding")
    add("Sect. 11.6", "beam's peak energy (almost 80 kJ)", 80, "kJ", 2.5,
        lambda c: c.col("E_beam").max() / KN)
    add("Sect. 11.6", "beam's peak share of ΔU", 30, "%", 1,
        lambda c: 100 * c.col("E_beam").max() / c.delta_u)
    add("Sect. 11.6", "beam's peak power to the projectile (almost 400 kW)", 400, "kW", 15,
        lambda c: -c.col("P_beam").min() / KN)
    add("Sect. 12", "projectile's share of ΔU at release", 91.3, "%", 0.05,
        lambda c: 100 * c.release("E_m") / c.delta_u,
        "233.2/254.6 = 91.6%; the paper's 91.3% does not follow from its own 233 and 255 kJ "
        "either (91.4%)")
    add("Sect. 12", "tension of circular motion at the release speed", 81, "mg", 0.5,
        lambda c: c.flight["release_speed"] ** 2 / c.scene.engine.L4 / c.scene.g,
        "the paper's footnote rounds v to 66 m/s and L4 to 5.5 m: 66²/(5.5·9.82) = 80.7")
    add("Sect. 2", "range in vacuum", 450, "m", 5, lambda c: c.flight["range"])


def paper_comparison(scene: Scene | None = None) -> pd.DataFrame:
    """The table "quantity | paper | computed | difference" for the engine of Table 1.

    Returns a DataFrame with columns ``section, quantity, unit, paper, computed, difference,
    tolerance, agrees, note``.
    """
    if scene is not None and scene.projectile != "trough":
        raise TrebuchetInputError(
            f"{scene.source}: [start] projectile = {scene.projectile!r}: the paper's numbers "
            "are for a shot from the trough; compare a scene that starts there")
    shot = _Shot(scene if scene is not None else Scene.from_toml(horsdal_scene_path()))
    records = []
    for row in paper_values():
        value = float(row.compute(shot))
        diff = value - row.paper
        records.append({
            "section": row.section, "quantity": row.quantity, "unit": row.unit,
            "paper": row.paper, "computed": value, "difference": diff,
            "tolerance": row.tolerance, "agrees": abs(diff) <= row.tolerance, "note": row.note,
        })
    return pd.DataFrame.from_records(records)

"""The paper's figures (its Section "Time dependencies") for a predicted and/or a measured shot.

Every figure function has the signature ``fig_x(predicted, measured, scene) -> Figure``:
``predicted`` and ``measured`` are DataFrames of the contract's columns (either may be
``None``, not both); measured frames carry ``X_sd`` for every quantity ``X`` and are drawn
as ±2 sd bands, predicted frames as lines. The scene gives the scales: forces over the
projectile's weight m·g or the counterweight's weight M·g, times in ms after the trigger,
torques in kN m, powers in kW, energies in kJ. Full points mark lift-off and release.
Curves run from the trigger to release. Nothing here computes physics: every curve is a
column of the frames.

Figures are built on :class:`matplotlib.figure.Figure` directly (no pyplot state); save
them with ``fig.savefig``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from trebuchet.ingest.uncertainty import BAND_SD
from trebuchet.model.scene import Scene
from trebuchet.model.timeline import shot_events, shot_time, shot_window
from trebuchet.report.figures_draw import (
    draw_curve,
    event_values,
    label_time_axis,
    legend,
    mark_events,
)
from trebuchet.report.figures_engine import draw_engine, greatest_bending_time

__all__ = [
    "FIGURES",
    "all_figures",
    "fig_tension",
    "fig_reactions",
    "fig_bending",
    "fig_loci",
    "fig_torque",
    "fig_configurations",
    "fig_energy",
    "SHARE_MIN_FRACTION",
]

Frame = pd.DataFrame | None

# shares of the bending load are drawn only where |F_R⊥| is at least this fraction of its peak
SHARE_MIN_FRACTION = 0.1

COLOURS = {"S": "#2ca02c", "S_perp": "#98df8a", "H": "#1f77b4", "CM": "#8c564b",
           "R": "#d62728", "R_x": "#ff7f0e", "M": "#1f77b4", "m": "#2ca02c", "beam": "#8c564b",
           "total": "black", "pivot": "#9467bd", "hinge": "#e377c2"}


def _frames(predicted: Frame, measured: Frame) -> list[tuple[pd.DataFrame, bool]]:
    """The frames to draw, each with ``True`` if measured; windowed to [0, release]."""
    out = [(shot_window(f), m) for f, m in ((predicted, False), (measured, True))
           if f is not None]
    if not out:
        raise ValueError("give a predicted frame, a measured frame, or both")
    return out


def _weights(scene: Scene) -> tuple[float, float]:
    """Projectile and counterweight weights m·g and M·g, N."""
    e = scene.engine
    return e.m * scene.g, e.M * scene.g


def _time_panel(ax: Axes, frames: list[tuple[pd.DataFrame, bool]],
                series: list[tuple[str, str, str]], *, scale: float, ylabel: str,
                absolute: bool = False, legend_at: str = "best") -> None:
    """Curves ``(column, label, colour)`` of every frame against time, with event points."""
    for frame, measured in frames:
        for column, label, colour in series:
            if column not in frame.columns:
                continue
            draw_curve(ax, frame, column, scale=scale, color=colour, label=label,
                       measured=measured, absolute=absolute)
            mark_events(ax, frame, column, scale=scale, color=colour, absolute=absolute)
    ax.axhline(0.0, color="0.8", lw=0.6, zorder=0)
    ax.set_ylabel(ylabel)
    label_time_axis(ax)
    ax.grid(alpha=0.3)
    legend(ax, loc=legend_at)


def _annotate(ax: Axes, frames: list[tuple[pd.DataFrame, bool]], column: str, scale: float,
              unit: str, *, at: str = "peak", absolute: bool = False,
              offset: tuple[float, float] = (-110, 6)) -> None:
    """Write the value and time of a column's peak (``at="peak"``, ``"trough"`` for the least
    value) or of its value at release (``at="release"``) beside the curve of the first frame
    (the predicted one when given)."""
    frame = frames[0][0]
    if column not in frame.columns or len(frame) == 0:
        return
    y = frame[column].to_numpy(dtype=float)
    y = np.abs(y) if absolute else y
    if at == "release":
        hit = event_values(frame, lambda f: np.abs(f[column]) if absolute else f[column])
        if "release" not in hit:
            return
        t, v = hit["release"]
    else:
        if not np.isfinite(y).any():
            return
        i = int(np.nanargmax(y) if at == "peak" else np.nanargmin(y))
        t, v = float(shot_time(frame)[i]), float(y[i])
    ax.annotate(f"{v / scale:.3g} {unit} at {t * 1e3:.0f} ms", (t * 1e3, v / scale),
                textcoords="offset points", xytext=offset, fontsize="small",
                arrowprops={"arrowstyle": "-", "color": "0.5", "lw": 0.6})


def _new_figure(title: str, nrows: int, ncols: int, size: tuple[float, float]
                ) -> tuple[Figure, np.ndarray]:
    fig = Figure(figsize=size, layout="constrained")
    axes = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False)).ravel()
    fig.suptitle(title, fontsize="medium")
    return fig, axes


def _panel_title(ax: Axes, letter: str, text: str) -> None:
    ax.set_title(f"{letter}) {text}", loc="left", fontsize="medium")


def fig_tension(predicted: Frame, measured: Frame, scene: Scene) -> Figure:
    """Sling tension on the projectile ``F_S`` and its component across the beam ``F_S⊥``,
    in m·g, against time (the paper's Fig. "Tension")."""
    frames = _frames(predicted, measured)
    mg, _ = _weights(scene)
    fig, (ax,) = _new_figure("Sling tension (full points: lift-off, release)", 1, 1, (7, 4.5))
    _time_panel(ax, frames, [("F_S_abs", "F_S", COLOURS["S"]),
                             ("F_S_perp", "F_S⊥ (across beam)", COLOURS["S_perp"])],
                scale=mg, ylabel=f"force / (m·g)  (m·g = {mg:.4g} N)")
    _annotate(ax, frames, "F_S_abs", mg, "m·g", at="release", offset=(-120, 0))
    _annotate(ax, frames, "F_S_perp", mg, "m·g", offset=(-40, -30))
    return fig


def fig_reactions(predicted: Frame, measured: Frame, scene: Scene) -> Figure:
    """Reaction forces in M·g: a) ``|F_H|`` at the hinge, b) ``|F_R|`` at the pivot,
    c) the horizontal component ``F_R,x`` at the pivot (the paper's Fig. "Reaction")."""
    frames = _frames(predicted, measured)
    _, Mg = _weights(scene)
    fig, axes = _new_figure("Reaction forces (full points: lift-off, release)", 1, 3,
                            (13, 4.2))
    unit = f"force / (M·g)  (M·g = {Mg / 1e3:.4g} kN)"
    _time_panel(axes[0], frames, [("F_H_abs", "|F_H|", COLOURS["H"])], scale=Mg, ylabel=unit)
    _annotate(axes[0], frames, "F_H_abs", Mg, "M·g", offset=(-130, -4))
    _panel_title(axes[0], "a", "at the hinge, on the counterweight")
    _time_panel(axes[1], frames, [("F_R_abs", "|F_R|", COLOURS["R"])], scale=Mg, ylabel=unit)
    _annotate(axes[1], frames, "F_R_abs", Mg, "M·g", offset=(-130, -4))
    _panel_title(axes[1], "b", "at the pivot, on the beam")
    _time_panel(axes[2], frames, [("F_R_x", "F_R,x", COLOURS["R_x"])], scale=Mg,
                ylabel="F_R,x / (M·g)  (> 0: away from the target)", legend_at="lower left")
    _annotate(axes[2], frames, "F_R_x", Mg, "M·g", at="trough", offset=(-60, 14))
    _annotate(axes[2], frames, "F_R_x", Mg, "M·g", offset=(-130, -4))
    _panel_title(axes[2], "c", "horizontal component at the pivot")
    return fig


def _share(column: str) -> Callable[[pd.DataFrame], np.ndarray]:
    """``100 X⊥ / F_R⊥`` (%) where ``|F_R⊥|`` reaches SHARE_MIN_FRACTION of its peak."""
    def share(frame: pd.DataFrame) -> np.ndarray:
        total = frame["F_R_perp"].to_numpy(dtype=float)
        part = frame[column].to_numpy(dtype=float)
        big = np.abs(total) >= SHARE_MIN_FRACTION * np.nanmax(np.abs(total))
        with np.errstate(all="ignore"):
            return np.where(big, 100.0 * part / total, np.nan)
    return share


def fig_bending(predicted: Frame, measured: Frame, scene: Scene) -> Figure:
    """Components across the beam (the paper's Fig. "PerpReac"): a) the bending load
    ``|F_R⊥|`` in M·g; b) the parts ``F_H⊥``, ``F_CM⊥``, ``F_S⊥`` of ``F_R⊥`` in M·g;
    c) each part's share of ``F_R⊥`` in % (measured shares as lines without band)."""
    frames = _frames(predicted, measured)
    _, Mg = _weights(scene)
    fig, axes = _new_figure("Forces across the beam (full points: lift-off, release)", 1, 3,
                            (13, 4.2))
    unit = f"force / (M·g)  (M·g = {Mg / 1e3:.4g} kN)"
    _time_panel(axes[0], frames, [("F_R_perp", "|F_R⊥|", COLOURS["R"])], scale=Mg,
                ylabel=unit, absolute=True)
    _annotate(axes[0], frames, "F_R_perp", Mg, "M·g", absolute=True, offset=(-130, -4))
    _panel_title(axes[0], "a", "bending load at the pivot")
    parts = [("F_H_perp", "F_H⊥", COLOURS["H"]), ("F_CM_perp", "F_CM⊥", COLOURS["CM"]),
             ("F_S_perp", "F_S⊥", COLOURS["S"]), ("F_R_perp", "F_R⊥ (sum)", COLOURS["R"])]
    _time_panel(axes[1], frames, parts, scale=Mg, ylabel=unit)
    _panel_title(axes[1], "b", "parts of F_R⊥ = (F_H + F_CM + F_S)·e_θ⊥")
    ax = axes[2]
    for frame, measured in frames:
        t_ms = shot_time(frame) * 1e3
        for column, label, colour in parts[:3]:
            ax.plot(t_ms, _share(column)(frame), color=colour, lw=0.9 if measured else 1.6,
                    ls="--" if measured else "-",
                    label=f"{label} {'measured' if measured else 'predicted'}")
            for te, v in event_values(frame, _share(column)).values():
                ax.plot(te * 1e3, v, "o", ms=5, mfc=colour, mec="black", mew=0.6)
    ax.axhline(0.0, color="0.8", lw=0.6, zorder=0)
    ax.set_ylabel("share of F_R⊥ (%)")
    label_time_axis(ax)
    ax.grid(alpha=0.3)
    legend(ax)
    _panel_title(ax, "c", f"shares where |F_R⊥| > {SHARE_MIN_FRACTION:.0%} of peak")
    return fig


def _locus(ax: Axes, frames: list[tuple[pd.DataFrame, bool]], x: str, y: str, scale: float,
           colour: str, label: str, every: int = 15, from_trigger: bool = True) -> None:
    """The curve traced by the tip of a force vector; open circle at the first row (0+) when
    ``from_trigger``, full points at lift-off and release; measured loci with ±2 sd error bars
    at ``every`` evenly spaced rows."""
    for frame, measured in frames:
        if len(frame) == 0:
            continue
        xs = frame[x].to_numpy(dtype=float) / scale
        ys = frame[y].to_numpy(dtype=float) / scale
        kind = "measured" if measured else "predicted"
        ax.plot(xs, ys, color=colour, lw=0.9 if measured else 1.6, ls="--" if measured else "-",
                label=f"{label} {kind}")
        if measured and f"{x}_sd" in frame.columns and f"{y}_sd" in frame.columns:
            idx = np.unique(np.linspace(0, len(frame) - 1, every).astype(int))
            ax.errorbar(xs[idx], ys[idx],
                        xerr=BAND_SD * frame[f"{x}_sd"].to_numpy(dtype=float)[idx] / scale,
                        yerr=BAND_SD * frame[f"{y}_sd"].to_numpy(dtype=float)[idx] / scale,
                        fmt="none", ecolor=colour, alpha=0.5, lw=0.8,
                        label=f"{label} measured ±{BAND_SD:g} sd")
        if from_trigger:
            ax.plot(xs[0], ys[0], "o", ms=7, mfc="white", mec=colour, mew=1.2, zorder=5)
        ex = event_values(frame, x)
        ey = event_values(frame, y)
        for name in ex:
            if name in ey:
                ax.plot(ex[name][1] / scale, ey[name][1] / scale, "o", ms=6, mfc=colour,
                        mec="black", mew=0.6, zorder=5)
    ax.axhline(0.0, color="0.8", lw=0.6, zorder=0)
    ax.axvline(0.0, color="0.8", lw=0.6, zorder=0)
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    legend(ax)


def _between(frame: pd.DataFrame, start: str | None, end: str) -> pd.DataFrame:
    """Rows between two events (from the trigger when ``start`` is None), inclusive."""
    ev = shot_events(frame)
    t = shot_time(frame)
    keep = np.ones(len(frame), dtype=bool)
    if start is not None:
        keep &= t >= ev.get(start, np.inf) * (1 - 1e-12)
    if end in ev:
        keep &= t <= ev[end] * (1 + 1e-12)
    return frame.loc[keep]


def fig_loci(predicted: Frame, measured: Frame, scene: Scene) -> Figure:
    """Loci of forces (the paper's Fig. "ForceLocus"): a) ``F_R`` on the beam and b) ``F_M``
    on the counterweight in M·g; c) ``F_m`` and ``F_S`` on the projectile in the trough and
    d) ``F_m`` in the sling, in m·g. Open circle: t = 0+; full points: lift-off, release."""
    frames = _frames(predicted, measured)
    mg, Mg = _weights(scene)
    fig, axes = _new_figure("Loci of forces (open: t = 0+; full: lift-off, release)", 2, 2,
                            (10, 9))
    _locus(axes[0], frames, "F_R_x", "F_R_y", Mg, COLOURS["R"], "F_R")
    _panel_title(axes[0], "a", "F_R on the beam at the pivot")
    _locus(axes[1], frames, "F_M_x", "F_M_y", Mg, COLOURS["M"], "F_M")
    _panel_title(axes[1], "b", "F_M, total force on the counterweight")
    for ax in axes[:2]:
        ax.set_xlabel("x component / (M·g)")
        ax.set_ylabel("y component / (M·g)")
    trough = [(_between(f, None, "lift_off"), m) for f, m in frames
              if "lift_off" in shot_events(f)]
    if trough:
        _locus(axes[2], trough, "F_m_x", "F_m_y", mg, COLOURS["m"], "F_m")
        _locus(axes[2], trough, "F_S_x", "F_S_y", mg, COLOURS["S_perp"], "F_S")
    else:
        axes[2].text(0.5, 0.5, "no trough phase", ha="center", transform=axes[2].transAxes)
    _panel_title(axes[2], "c", "F_m and F_S in the trough (to lift-off)")
    sling = [(_between(f, "lift_off", "release"), m) for f, m in frames
             if "lift_off" in shot_events(f)] or frames
    _locus(axes[3], sling, "F_m_x", "F_m_y", mg, COLOURS["m"], "F_m", from_trigger=False)
    _panel_title(axes[3], "d", "F_m on the projectile in the sling")
    for ax in axes[2:]:
        ax.set_xlabel("x component / (m·g)")
        ax.set_ylabel("y component / (m·g)")
    return fig


def fig_torque(predicted: Frame, measured: Frame, scene: Scene) -> Figure:
    """Torque on the beam about the pivot, kN m (the paper's Fig. "Torque"): a) the
    contributions of hinge, gravity at the centre of mass and spigot; b) the total N."""
    frames = _frames(predicted, measured)
    fig, axes = _new_figure("Torque on the beam (full points: lift-off, release)", 1, 2,
                            (12, 4.5))
    _time_panel(axes[0], frames, [("torque_hinge", "hinge", COLOURS["H"]),
                                  ("torque_cm", "gravity at CM", COLOURS["CM"]),
                                  ("torque_spigot", "spigot", COLOURS["S"])],
                scale=1e3, ylabel="torque (kN m)")
    _panel_title(axes[0], "a", "contributions")
    _time_panel(axes[1], frames, [("torque", "N", COLOURS["total"])], scale=1e3,
                ylabel="torque N (kN m)")
    _panel_title(axes[1], "b", "total torque N")
    return fig


def fig_configurations(predicted: Frame, measured: Frame, scene: Scene) -> Figure:
    """Stick drawings of the engine (the paper's Fig. "Configurations"): a) at the greatest
    bending load ``|F_R⊥|`` and b) at release; lengths in m. Each frame is drawn at its own
    instants (predicted in colour, measured in grey dashes)."""
    frames = _frames(predicted, measured)
    _, Mg = _weights(scene)
    fig, axes = _new_figure("Configurations (dotted: projectile path)", 1, 2, (12, 5.5))
    notes: list[list[str]] = [[], []]
    for frame, measured_ in frames:
        kind = "measured" if measured_ else "predicted"
        t_b, load = greatest_bending_time(frame)
        draw_engine(axes[0], frame, t_b, scene, measured=measured_, label=kind)
        notes[0].append(f"{kind}: t = {t_b * 1e3:.0f} ms, |F_R⊥| = {load / Mg:.2f} M·g")
        t_r = shot_events(frame).get("release")
        if t_r is None:
            t_r = float(shot_time(frame)[-1])
        draw_engine(axes[1], frame, t_r, scene, measured=measured_, label=kind)
        notes[1].append(f"{kind}: t = {t_r * 1e3:.0f} ms")
    for ax, letter, what, lines in zip(axes, "ab", ("greatest bending of the beam", "release"),
                                       notes, strict=True):
        _panel_title(ax, letter, what)
        ax.text(0.02, 0.98, "\n".join(lines), transform=ax.transAxes, va="top",
                fontsize="small")
        ax.axhline(0.0, color="0.3", lw=1)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x (m)  (target toward −x)")
        ax.set_ylabel("height y (m)")
        ax.grid(alpha=0.3)
        legend(ax, loc="lower right")
    return fig


def _crossing_times(frame: pd.DataFrame, column: str, fractions: tuple[float, ...]
                    ) -> list[float]:
    """First times (s) at which ``column`` reaches each fraction of its value at release."""
    at_release = event_values(frame, column).get("release")
    if at_release is None:
        return []
    t = shot_time(frame)
    y = frame[column].to_numpy(dtype=float)
    out = []
    for q in fractions:
        hit = np.flatnonzero(y >= q * at_release[1])
        if hit.size and hit[0] > 0:
            i = hit[0]
            out.append(float(np.interp(q * at_release[1], [y[i - 1], y[i]], [t[i - 1], t[i]])))
    return out


def fig_energy(predicted: Frame, measured: Frame, scene: Scene) -> Figure:
    """Rates of work (kW, upper row) and mechanical energy gained since t = 0 (kJ, lower
    row) for the counterweight, the beam and the projectile (the paper's Figs. "Power" and
    "Power_Beam"). Crosses on the projectile's power at 10, 50 and 90 % of its energy at
    release; the beam's peak energy is given as a share of the scene's ΔU (J). Where the
    scene has friction in its bearings, a fourth column: the heat made at pivot and hinge
    (``P_loss_*``, ``E_loss_*``) with its share of ΔU at the release."""
    frames = _frames(predicted, measured)
    friction = any("E_loss_pivot" in frame.columns for frame, _ in frames)
    n = 4 if friction else 3
    fig, axes = _new_figure("Rates of work and energies (full points: lift-off, release)", 2,
                            n, (4.7 * n, 7.5))
    parts = [("M", "counterweight"), ("beam", "beam"), ("m", "projectile")]
    for j, (key, name) in enumerate(parts):
        c = COLOURS[key]
        _time_panel(axes[j], frames, [(f"P_{key}", f"P_{key}", c)], scale=1e3,
                    ylabel="rate of work (kW)")
        _panel_title(axes[j], "aceg"[j], f"on the {name}")
        _time_panel(axes[n + j], frames, [(f"E_{key}", f"E_{key}", c)], scale=1e3,
                    ylabel="energy gained (kJ)",
                    legend_at={"M": "lower left", "beam": "lower right"}.get(key, "upper left"))
        _panel_title(axes[n + j], "bdfh"[j], f"of the {name}")
    if friction:
        _friction_panels(axes[3], axes[n + 3], frames, scene.delta_U)
    for k, (frame, _) in enumerate(frames):
        for tc in _crossing_times(frame, "E_m", (0.1, 0.5, 0.9)):
            p = np.interp(tc, shot_time(frame), frame["P_m"].to_numpy(dtype=float))
            axes[2].plot(tc * 1e3, p / 1e3, "x", ms=8, mew=1.5, color="black")
        delta_u = scene.delta_U
        e_beam = frame["E_beam"].to_numpy(dtype=float)
        if k == 0 and delta_u and np.isfinite(e_beam).any():  # one note: the first frame's
            i = int(np.nanargmax(e_beam))
            t_i = shot_time(frame)[i]
            axes[n + 1].annotate(f"peak {e_beam[i] / 1e3:.1f} kJ = {e_beam[i] / delta_u:.0%} of "
                             f"ΔU ({delta_u / 1e3:.0f} kJ)", (t_i * 1e3, e_beam[i] / 1e3),
                             textcoords="offset points", xytext=(-150, -16), fontsize="small")
    axes[2].plot([], [], "x", color="black", label="10, 50, 90 % of E_m at release")
    legend(axes[2])
    return fig


def _friction_panels(power: Axes, energy: Axes, frames: list[tuple[pd.DataFrame, bool]],
                     delta_u: float) -> None:
    """The heat made by friction at pivot and hinge: loss powers (kW) and energies (kJ), the
    total at the release as a share of ΔU (J)."""
    series = [(f"{q}_loss_{j}", f"{q}_loss_{j}", COLOURS[j]) for j in ("pivot", "hinge")
              for q in ("P",)]
    _time_panel(power, frames, series, scale=1e3, ylabel="heat made (kW)")
    _panel_title(power, "g", "lost to friction")
    _time_panel(energy, frames, [(c.replace("P_", "E_"), label.replace("P_", "E_"), colour)
                                 for c, label, colour in series], scale=1e3,
                ylabel="heat made (kJ)", legend_at="upper left")
    _panel_title(energy, "h", "lost to friction since t = 0")
    frame = frames[0][0]
    lost = [event_values(frame, f"E_loss_{j}").get("release") for j in ("pivot", "hinge")]
    if delta_u and all(v is not None for v in lost):
        total = lost[0][1] + lost[1][1]
        energy.annotate(f"together {total / 1e3:.3g} kJ = {total / delta_u:.1%} of ΔU\n"
                        "by the release", (lost[0][0] * 1e3, max(lost[0][1], lost[1][1]) / 1e3),
                        textcoords="offset points", xytext=(-150, -40), fontsize="small")


FIGURES: dict[str, Callable[[Frame, Frame, Scene], Figure]] = {
    "tension": fig_tension,
    "reactions": fig_reactions,
    "bending": fig_bending,
    "loci": fig_loci,
    "torque": fig_torque,
    "configurations": fig_configurations,
    "energy": fig_energy,
}


def all_figures(predicted: Frame, measured: Frame, scene: Scene,
                progress: Callable[[str], None] | None = None) -> dict[str, Figure]:
    """Every figure of :data:`FIGURES`, by name; ``progress`` is told each name before it is
    drawn."""
    out = {}
    for name, make in FIGURES.items():
        if progress is not None:
            progress(name)
        out[name] = make(predicted, measured, scene)
    return out

"""Do the measured angles fit the scene's geometry and the model's assumptions?

Checks on the reconstructed rows, each a :class:`~trebuchet.core.errors.ModelValidityWarning`
(also listed in ``Reconstruction.validity``) that names the rows (0-based positions in the log)
and their times (s, the log's time):

- in the trough (phase I, and at rest for a trough scene) the projectile must lie on the
  trough: ``y_m = H + L1 sin θ + L4 sin φ`` within ``tolerance`` (m) of zero;
- the counterweight never goes below ground (``y_M < 0``) and its arm never swings
  through the beam (``−360° < ψ − θ < 0°``): a ψ beyond its physical range;
- the projectile in the sling (phase II) never goes below ground;
- the sling stays taut (phase II tension not negative beyond 2 sd).

Positions come from :mod:`trebuchet.model.kinematics`; lengths in m.
"""

from __future__ import annotations

import numpy as np

from trebuchet.core.errors import ModelValidityWarning, warn_at_caller
from trebuchet.model import kinematics as kin
from trebuchet.model.scene import Scene

__all__ = ["row_ranges", "geometry_findings", "warn_findings"]


def row_ranges(rows: np.ndarray, t: np.ndarray, limit: int = 3,
               lines: np.ndarray | None = None) -> str:
    """``"rows 12–30 (t = 0.41–0.48 s), 57 (t = 0.62 s)"`` for sorted row positions; with
    ``lines`` (the file's line number of each row) ``"lines 14–32 (t = …) of the file"``:
    the numbers the reader's own notes use."""
    rows = np.asarray(rows, dtype=int)
    if rows.size == 0:
        return "no rows"
    label = np.arange(len(t)) if lines is None else np.asarray(lines, dtype=int)
    breaks = np.flatnonzero(np.diff(rows) > 1)
    starts = np.r_[rows[0], rows[breaks + 1]]
    ends = np.r_[rows[breaks], rows[-1]]
    parts = []
    for a, b in list(zip(starts, ends, strict=True))[:limit]:
        if a == b:
            parts.append(f"{label[a]} (t = {t[a]:.4g} s)")
        else:
            parts.append(f"{label[a]}–{label[b]} (t = {t[a]:.4g}–{t[b]:.4g} s)")
    more = len(starts) - limit
    text = ("rows " if lines is None else "lines ") + ", ".join(parts)
    text += f" and {more} more ranges" if more > 0 else ""
    return text + ("" if lines is None else " of the file")


def geometry_findings(t: np.ndarray, phase: np.ndarray, theta: np.ndarray, psi: np.ndarray,
                      phi: np.ndarray, scene: Scene, tolerance: float | None = None,
                      tension: np.ndarray | None = None,
                      tension_sd: np.ndarray | None = None,
                      lines: np.ndarray | None = None) -> list[str]:
    """Sentences naming the rows where the angles (rad, measured or smoothed) leave the
    scene's geometry; ``tolerance`` (m) defaults to 5 % of the sling (or of L3 for a dry
    fire). ``tension``/``tension_sd`` (N): the sling tension and its sd, for the slack
    check."""

    def _rows(rows: np.ndarray) -> str:
        return row_ranges(rows, t, lines=lines)

    e, H = scene.engine, scene.start.H
    tol = tolerance if tolerance is not None else 0.05 * (e.L4 if e.L4 > 0 else e.L3)
    found: list[str] = []
    with np.errstate(invalid="ignore"):
        r_M = kin.counterweight_position(theta, psi, e, H)
        low = np.flatnonzero(r_M[1] < -tol)
        if low.size:
            worst = low[np.argmin(r_M[1][low])]
            found.append(
                f"{_rows(low)}: psi up to {np.degrees(psi[worst]):.1f}° puts the "
                f"counterweight {-r_M[1][worst]:.2f} m below ground (beyond psi's physical "
                "range for this scene)")
        if not e.fixed_counterweight:
            rel = psi - theta
            through = np.flatnonzero((rel >= 0.0) | (rel <= -2.0 * np.pi))
            if through.size:
                worst = through[np.argmax(np.abs(rel[through] + np.pi))]
                found.append(
                    f"{_rows(through)}: psi - theta = {np.degrees(rel[worst]):.1f}° "
                    "swings the counterweight arm through the beam (physical range "
                    "-360° < psi - theta < 0°)")
        if scene.projectile == "none":
            return found
        r_m = kin.projectile_position(theta, phi, e, H)
        trough = (phase == 1) | ((phase == 0) & (scene.projectile == "trough"))
        off = np.flatnonzero(trough & (np.abs(r_m[1]) > tol))
        if off.size:
            worst = off[np.argmax(np.abs(r_m[1][off]))]
            where = "below ground" if r_m[1][worst] < 0 else "above the trough"
            found.append(
                f"{_rows(off)}: in the trough, theta = {np.degrees(theta[worst]):.1f}° "
                f"and phi = {np.degrees(phi[worst]):.1f}° put the projectile "
                f"{abs(r_m[1][worst]):.2f} m {where} (the scene's H, L1, L4 or the log's "
                "angles are off); phase-I loads use phi from the trough constraint")
        sling = np.flatnonzero((phase == 2) & (r_m[1] < -tol))
        if sling.size:
            worst = sling[np.argmin(r_m[1][sling])]
            found.append(f"{_rows(sling)}: in the sling the projectile is "
                         f"{-r_m[1][worst]:.2f} m below ground")
        if tension is not None:
            sd = np.zeros_like(tension) if tension_sd is None else tension_sd
            slack = np.flatnonzero((phase == 2) & (tension + 2.0 * sd < 0.0))
            if slack.size:
                found.append(f"{_rows(slack)}: the sling tension is negative beyond "
                             "2 sd (a slack sling: the rigid-sling loads there are fiction)")
    return found


def warn_findings(findings: list[str], source: str) -> None:
    """Warn once per finding as a ModelValidityWarning prefixed with ``source``."""
    for text in findings:
        warn_at_caller(f"{source}: {text}", ModelValidityWarning)

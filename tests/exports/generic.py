"""Plain CSV angle logs, as a user writes them from a spreadsheet or a script.

Layout (the package's own generic format, ``ingest/readers/generic.py``): a header row
``t`` / ``time`` / ``frame`` and the angle columns, units in parentheses when the writer
states them. The ambiguous ones here state none: degrees without ``(deg)`` and a time in
ms without ``(ms)``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .shot import filmed, near_branch
from .truth import Truth, rng_for

SOURCE = "trebuchet: ingest/readers/generic.py (the package's plain CSV)"


def angle_rows(name: str, fps: float, repeat: int = 1, sd_deg: float = 0.1):
    """Frames, the written angles (deg, 3 decimals) and their truth (rad)."""
    rng = rng_for(name)
    shot = filmed(fps / repeat)
    deg = {a: np.degrees(shot.angles[a]) + rng.normal(0, sd_deg, len(shot.t))
           for a in ("theta", "psi", "phi")}
    cells = {a: [("" if not math.isfinite(v) else f"{v:.3f}") for v in deg[a]] for a in deg}
    truth = {a: near_branch(np.radians([float(c) if c else np.nan for c in cells[a]]),
                            shot.angles[a]) for a in deg}
    return shot, cells, truth


def write(folder: Path) -> list[Truth]:
    out = []
    fps = 240.0
    common = dict(tool="generic", version="-", source=SOURCE)
    # degrees stated: read today
    shot, cells, truth = angle_rows("generic_deg.csv", fps)
    lines = ["t (s),theta (deg),psi (deg),phi (deg)"] + [
        f"{t:.6f},{cells['theta'][k]},{cells['psi'][k]},{cells['phi'][k]}"
        for k, t in enumerate(shot.t)]
    (folder / "generic_deg.csv").write_text("\n".join(lines) + "\n")
    out.append(Truth(name="generic_deg.csv", layout="t (s), theta/psi/phi (deg)", fps=fps,
                     t=shot.t, angles=truth, time_code="s", time_stated=True,
                     angle_unit="deg", angle_stated=True, read={}, t_tol=1e-6,
                     angle_tol=1e-6, **common))
    # degrees not stated
    shot, cells, truth = angle_rows("generic_nounit_deg.csv", fps)
    lines = ["t,theta,psi,phi"] + [
        f"{t:.6f},{cells['theta'][k]},{cells['psi'][k]},{cells['phi'][k]}"
        for k, t in enumerate(shot.t)]
    (folder / "generic_nounit_deg.csv").write_text("\n".join(lines) + "\n")
    out.append(Truth(name="generic_nounit_deg.csv", layout="t, theta, psi, phi: degrees "
                     "without a unit", fps=fps, t=shot.t, angles=truth, time_code="s",
                     time_stated=False, angle_unit="deg", angle_stated=False, read={},
                     t_tol=1e-6, angle_tol=1e-6,
                     notes=["|phi| reaches 180: no radian value; the start pose -50, -90, "
                            "-180 is the scene's in degrees"], **common))
    # time in ms without a unit, angles in rad stated
    shot, cells, truth = angle_rows("generic_time_ms.csv", fps)
    lines = ["time,theta (deg),psi (deg),phi (deg)"] + [
        f"{t * 1000:.4f},{cells['theta'][k]},{cells['psi'][k]},{cells['phi'][k]}"
        for k, t in enumerate(shot.t)]
    (folder / "generic_time_ms.csv").write_text("\n".join(lines) + "\n")
    out.append(Truth(name="generic_time_ms.csv", layout="time in ms without a unit, angles "
                     "in deg (stated)", fps=fps, t=shot.t, angles=truth, time_code="ms",
                     time_stated=False, angle_unit="deg", read={"fps": fps}, t_tol=1e-6,
                     angle_tol=1e-6, notes=["steps of 4.1667 at 240 fps: ms, not s"],
                     **common))
    # phone slow motion: 60 images/s in a 240 fps file, each image on 4 rows
    shot, cells, truth = angle_rows("phone_upconverted_generic.csv", fps, repeat=4)
    lines = ["t (s),theta (deg),psi (deg),phi (deg)"]
    for k in range(len(shot.t)):
        for r in range(4):
            t = (4 * k + r) / fps
            lines.append(f"{t:.6f},{cells['theta'][k]},{cells['psi'][k]},{cells['phi'][k]}")
    (folder / "phone_upconverted_generic.csv").write_text("\n".join(lines) + "\n")
    out.append(Truth(name="phone_upconverted_generic.csv", layout="t (s), angles (deg) of a "
                     "240 fps phone video up-converted from 60 fps (each image 4 rows)",
                     fps=60.0, t=shot.frame * 4 / fps, angles=truth, time_code="s",
                     time_stated=True, angle_unit="deg", read={}, t_tol=1e-6,
                     angle_tol=1e-6, notes=["runs of 4 identical rows: keep the first; "
                                            "effective rate 60 fps"], **common))
    return out

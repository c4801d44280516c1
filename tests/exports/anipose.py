"""anipose 3-D export: ``anipose triangulate`` writes ``pose-3d/<video>.csv``.

Layout (read from lambdaloop/anipose, ``anipose/triangulate.py`` ``triangulate``): pandas
``to_csv(index=False)`` of, for each joint, ``<joint>_x``, ``<joint>_y``, ``<joint>_z``,
``<joint>_error`` (mean reprojection error, px), ``<joint>_ncams`` (cameras used, float),
``<joint>_score`` (lowest 2-D score); then ``M_00`` ... ``M_22`` (rotation applied when
the config has ``triangulation.reference_point`` and ``axes``, else the identity) and
``center_0..2`` (else zeros); last ``fnum`` (frame number from 0). Coordinates in the
calibration board's unit (usually mm), in the first camera's frame unless axes are set:
the engine's plane is oblique and the vertical unknown. A joint seen by fewer than two
cameras is NaN (``_ncams`` NaN too) in the default (non-optimised) triangulation.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from .shot import ROLES, angles_of, filmed
from .truth import Truth, rng_for

SOURCE = "lambdaloop/anipose: anipose/triangulate.py (triangulate)"
JOINTS = {"pivot": "axle", "spigot": "arm_tip", "hinge": "hinge", "counterweight": "weight",
          "projectile": "stone"}
POINTS = dict(JOINTS)
NOISE_MM = 2.0


def rotation(rng: np.random.Generator) -> np.ndarray:
    """A random proper rotation (the first camera looks at the engine obliquely)."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 2] = -q[:, 2]
    return q


def write(folder: Path) -> list[Truth]:
    name = "anipose_pose3d.csv"
    fps = 100.0
    rng = rng_for(name)
    shot = filmed(fps)
    n = len(shot.t)
    rot = rotation(rng)
    centre = np.array([-350.0, 420.0, 9800.0])    # mm: the engine about 10 m from camera 1
    out = pd.DataFrame()
    plane: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for role in ROLES:
        x, y = shot.points[role]
        local = np.column_stack([x * 1000, y * 1000, np.zeros(n)])
        xyz = local @ rot.T + centre + rng.normal(0, NOISE_MM, (n, 3))
        seen = np.isfinite(x)
        ncams = np.where(seen, rng.integers(2, 4, n).astype(float), np.nan)
        out[f"{JOINTS[role]}_x"] = xyz[:, 0]
        out[f"{JOINTS[role]}_y"] = xyz[:, 1]
        out[f"{JOINTS[role]}_z"] = xyz[:, 2]
        out[f"{JOINTS[role]}_error"] = np.where(seen, rng.uniform(0.5, 3.0, n), np.nan)
        out[f"{JOINTS[role]}_ncams"] = ncams
        out[f"{JOINTS[role]}_score"] = np.where(seen, rng.uniform(0.9, 1.0, n), np.nan)
        # the truth: the written point taken back into the engine's plane (exact plane)
        back = (xyz - centre) @ rot
        plane[role] = (back[:, 0] / 1000, back[:, 1] / 1000)
    for i in range(3):
        for j in range(3):
            out[f"M_{i}{j}"] = float(i == j)
    for i in range(3):
        out[f"center_{i}"] = 0.0
    out["fnum"] = np.arange(n)
    out.to_csv(folder / name, index=False)
    angles = angles_of(plane, y_up=True, reference=shot.angles)
    return [Truth(
        name=name, tool="anipose", version="0.8-1.1 (triangulate)",
        layout="3-D CSV: <joint>_x/_y/_z/_error/_ncams/_score, M_ij, center_i, fnum; mm in "
               "the first camera's frame (no axes set), the engine's plane oblique",
        source=SOURCE, fps=fps, t=shot.t, angles=angles, time_code="frames (fnum)",
        time_stated=False, length_unit="mm (3-D, camera frame)",
        read={"fps": fps, "points": POINTS}, t_tol=1e-6, angle_tol=0.005,
        notes=["the truth takes the written points into the true plane; a reader fits the "
               "plane (2 mm noise out of it) and finds the vertical and the side from the "
               "engine (the counterweight hangs straight down at rest; the spigot starts on "
               "the side away from the throw), so it agrees to about 0.01 rad"])]

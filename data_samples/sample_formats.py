"""The file formats of the sample logs (``make_samples.py``): how Tracker, Kinovea and
DeepLabCut write their exports, and the generic log, as text."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["KINOVEA_NAMES", "DLC_NAMES", "DLC_SCORER", "ROLES", "fmt", "java_sci", "wrap_deg",
           "sling_branch_note", "central_rate", "generic_text", "tracker_text", "kinovea_text",
           "deeplabcut_text"]

#: Kinovea point names (object/point) of the sample.
KINOVEA_NAMES = {
    "pivot": "Beam/axle",
    "spigot": "Beam/tip",
    "hinge": "Beam/hinge",
    "counterweight": "Weight/centre",
    "projectile": "Stone/centre",
}

#: DeepLabCut bodypart names and scorer of the sample.
DLC_NAMES = {"pivot": "axle", "spigot": "arm_tip", "hinge": "hinge",
             "counterweight": "weight", "projectile": "stone"}
DLC_SCORER = "DLC_resnet50_trebuchetJun17shuffle1_200000"

#: The engine's points, in the order every point file lists them.
ROLES = ("pivot", "spigot", "hinge", "counterweight", "projectile")



def fmt(value: float, spec: str) -> str:
    """``format(value, spec)``, empty for NaN."""
    return "" if not math.isfinite(value) else format(value, spec)


def java_sci(value: float, comma: bool) -> str:
    """Java DecimalFormat ``0.000000E0`` (Tracker's unformatted export); empty for NaN."""
    if not math.isfinite(value):
        return ""
    mantissa, exponent = f"{value:.6E}".split("E")
    text = f"{mantissa}E{int(exponent)}"
    return text.replace(".", ",") if comma else text


def wrap_deg(d: np.ndarray) -> np.ndarray:
    """Angles (deg) into (−180, 180], as Tracker's protractor reports them."""
    return d - 360.0 * np.ceil((d - 180.0) / 360.0)


def sling_branch_note(shown: np.ndarray) -> str:
    """Where the first written sling angle (deg) lies, and what that means when read."""
    first = float(shown[np.isfinite(shown)][0])
    text = f"first sling value {first:+.1f}°"
    if first > 0:
        text += "; `read_log` moves each angle to the paper's start branch and reports it"
    return text


def central_rate(t: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Tracker's ω: ``(θ[i+1] − θ[i−1]) / (t[i+1] − t[i−1])``, NaN without both neighbours."""
    out = np.full(len(d), np.nan)
    out[1:-1] = (d[2:] - d[:-2]) / (t[2:] - t[:-2])
    return out


def generic_text(comment: str, t: np.ndarray, deg: np.ndarray, keep: np.ndarray) -> str:
    """A generic log: a comment line, ``t (s),theta (deg),psi (deg),phi (deg)``, rows."""
    lines = [f"# {comment}", "t (s),theta (deg),psi (deg),phi (deg)"]
    for k in np.nonzero(keep)[0]:
        lines.append(",".join([f"{t[k]:.6f}"] + [fmt(v, ".3f") for v in deg[k]]))
    return "\n".join(lines) + "\n"


def tracker_text(
    names: Sequence[str],
    header: Sequence[str],
    rows: list[list[str]],
    delimiter: str,
    newline: str,
) -> str:
    """Tracker's multi-track export: ``#multi:``, track names, column names, data rows.

    As Tracker writes it: the name row and the header end with the delimiter, the data
    rows do not; ``header`` is the columns of one track (repeated for each).
    """
    name_row = delimiter + "".join(n + delimiter * len(header) for n in names)
    head = "t" + delimiter + "".join(c + delimiter for _ in names for c in header)
    lines = ["#multi:", name_row, head] + [delimiter.join(r) for r in rows]
    return newline.join(lines) + newline


def kinovea_text(t_ms: np.ndarray, points: dict[str, tuple[np.ndarray, np.ndarray]]) -> str:
    """Kinovea trajectory CSV (English locale): quoted cells, ``,``, time in whole ms, CRLF."""
    head = ['"Time"']
    for role in ROLES:
        head += [f'"{KINOVEA_NAMES[role]}/X"', f'"{KINOVEA_NAMES[role]}/Y"']
    lines = [",".join(head)]
    for k, ms in enumerate(t_ms):
        cells = [f'"{int(ms)}"']
        for role in ROLES:
            x, y = points[role]
            for v in (x[k], y[k]):
                cells.append(f'"{v:.3f}"' if math.isfinite(v) else "")
        lines.append(",".join(cells))
    return "\r\n".join(lines) + "\r\n"


def deeplabcut_text(frames: np.ndarray, px: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]
                    ) -> str:
    """DeepLabCut CSV: scorer, bodyparts, coords rows, then frame index, x, y, likelihood."""
    parts = [DLC_NAMES[r] for r in ROLES]
    lines = [
        ",".join(["scorer"] + [DLC_SCORER] * (3 * len(parts))),
        ",".join(["bodyparts"] + [p for p in parts for _ in range(3)]),
        ",".join(["coords"] + ["x", "y", "likelihood"] * len(parts)),
    ]
    for k, f in enumerate(frames):
        cells = [str(int(f))]
        for role in ROLES:
            x, y, p = px[role]
            cells += [f"{x[k]:.4f}", f"{y[k]:.4f}", f"{p[k]:.4f}"]
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"

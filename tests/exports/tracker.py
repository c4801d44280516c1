"""Tracker exports (File > Export > Data, "Export Data" dialog).

Layout (read from OpenSourcePhysics/tracker,
``src/org/opensourcephysics/cabrillo/tracker/ExportDataDialog.java`` ``getDataString``;
default number patterns from ``TTrack.java`` ``getDefaultFormatPatterns``; protractor
columns from ``Protractor.java``):

* ``#multi:`` on the first line when more than one track is exported;
* a track-name row: the delimiter, then each track's name followed by one delimiter per
  exported column (so the name stands above its track's first column, and the row ends
  with a delimiter);
* a column-name row: the time variable (``t``), a delimiter, then every column name
  followed by a delimiter (ends with a delimiter); names only, **never a unit**
  (subscripts removed: ``θ_{rot}`` -> ``θrot``);
* one row per video frame from the first to the last frame with data in any track, no
  trailing delimiter; empty cells where a track has no data; the time is the frame's time
  in s;
* angle columns (names starting with θ, ω, α) are converted to **degrees** unless the
  angle-unit preference is radians (then they are written in rad, under the same names);
* "formatted" numbers use each column's display pattern (defaults: ``t`` 0.000, θ of a
  protractor 0.0); "full precision" (unformatted) uses ``0.000000E0`` for every column;
  both through ``DecimalFormat`` with the locale's symbols (decimal comma in many
  locales);
* delimiter: tab (default), space, comma, semicolon or a custom one (TrackerIO).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .shot import ROLES, angles_of, filmed, near_branch
from .truth import Truth, rng_for

SOURCE = ("OpenSourcePhysics/tracker: src/org/opensourcephysics/cabrillo/tracker/"
          "ExportDataDialog.java (getDataString), TTrack.java (getDefaultFormatPatterns), "
          "Protractor.java")
PROTRACTORS = {"theta": "beam", "psi": "arm", "phi": "sling"}
COLUMNS = {"beam": "theta", "arm": "psi", "sling": "phi"}
MASSES = {"pivot": "axle", "spigot": "tip", "hinge": "hinge", "counterweight": "weight",
          "projectile": "stone"}
POINTS = dict(MASSES)


def java_pattern(value: float, decimals: int, comma: bool) -> str:
    """``DecimalFormat("0.0...")`` (HALF_EVEN rounding) of a double."""
    if not math.isfinite(value):
        return ""
    text = f"{value:.{decimals}f}"     # Java also writes "-0.0" for -0.04
    return text.replace(".", ",") if comma else text


def java_sci(value: float, comma: bool) -> str:
    """``DecimalFormat("0.000000E0")``: ``-5.012345E1``, ``8.333333E-3``, ``0.000000E0``."""
    if not math.isfinite(value):
        return ""
    if value == 0:
        text = "0.000000E0"
    else:
        mantissa, exponent = f"{value:.6E}".split("E")
        text = f"{mantissa}E{int(exponent)}"
    return text.replace(".", ",") if comma else text


def parse(cell: str) -> float:
    return float(cell.replace(",", ".")) if cell else float("nan")


def wrap_deg(d: np.ndarray) -> np.ndarray:
    """Into (-180, 180], as a protractor reports it."""
    return d - 360.0 * np.ceil((d - 180.0) / 360.0)


def central(t: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Tracker's first derivative: central difference; NaN without both neighbours."""
    out = np.full(len(v), np.nan)
    out[1:-1] = (v[2:] - v[:-2]) / (t[2:] - t[:-2])
    return out


def table(names: list[str], header: list[str], rows: list[list[str]], delim: str,
          newline: str = "\n") -> str:
    """``#multi:``, the name row, the column row (both ending in the delimiter), rows."""
    name_row = delim + "".join(n + delim * len(header) for n in names)
    head = "t" + delim + "".join(c + delim for _ in names for c in header)
    return newline.join(["#multi:", name_row, head] + [delim.join(r) for r in rows]) + newline


def protractors(name: str, fps: float, unit: str, formatted: bool, delim: str,
                comma: bool) -> tuple[str, np.ndarray, dict]:
    """Three protractors (beam, arm, sling) with θ and ω; the sling's ends at release."""
    rng = rng_for(name)
    shot = filmed(fps)
    factor = 180 / math.pi if unit == "deg" else 1.0
    cols = []
    truth = {}
    for angle in ("theta", "psi", "phi"):
        exact = shot.angles[angle]
        noisy = exact + rng.normal(0, math.radians(0.15), len(exact))
        shown = wrap_deg(np.degrees(noisy))
        if unit == "rad":
            shown = np.radians(shown)
        rate = central(shot.t, np.unwrap(noisy)) * factor
        if formatted:
            th = [java_pattern(v, 1 if unit == "deg" else 3, comma) for v in shown]
            om = [java_pattern(v, 1 if unit == "deg" else 3, comma) for v in rate]
        else:
            th = [java_sci(v, comma) for v in shown]
            om = [java_sci(v, comma) for v in rate]
        om = [o if math.isfinite(s) else "" for o, s in zip(om, shown, strict=True)]
        cols += [th, om]
        written = np.array([parse(c) for c in th]) / factor
        truth[angle] = near_branch(written, _filled(exact))
    times = [java_pattern(v, 3, comma) if formatted else java_sci(v, comma) for v in shot.t]
    rows = [[times[k]] + [c[k] for c in cols] for k in range(len(shot.t))]
    text = table(list(PROTRACTORS.values()), ["θ", "ω"], rows, delim)
    return text, shot.t, truth


def _filled(ref: np.ndarray) -> np.ndarray:
    out = ref.copy()
    ok = np.isfinite(out)
    out[~ok] = out[ok][-1]
    return out


def point_masses(name: str, fps: float, delim: str, comma: bool) -> tuple[str, np.ndarray,
                                                                          dict]:
    """Five point masses with x, y (m, y up), full precision; the stone ends at release."""
    rng = rng_for(name)
    shot = filmed(fps)
    n = len(shot.t)
    cols = []
    written = {}
    for role in ROLES:
        x, y = shot.points[role]
        cx = [java_sci(v, comma) for v in x + rng.normal(0, 0.003, n)]
        cy = [java_sci(v, comma) for v in y + rng.normal(0, 0.003, n)]
        cols += [cx, cy]
        written[role] = (np.array([parse(c) for c in cx]), np.array([parse(c) for c in cy]))
    times = [java_sci(v, comma) for v in shot.t]
    rows = [[times[k]] + [c[k] for c in cols] for k in range(n)]
    text = table([MASSES[r] for r in ROLES], ["x", "y"], rows, delim)
    return text, shot.t, angles_of(written, y_up=True, reference=shot.angles)


def write(folder: Path) -> list[Truth]:
    out = []
    fps = 120.0
    common = dict(tool="tracker", source=SOURCE, fps=fps, time_code="s", time_stated=False)
    text, t, angles = protractors("tracker_protractor_deg.txt", fps, "deg", True, "\t", False)
    (folder / "tracker_protractor_deg.txt").write_text(text, encoding="utf-8")
    out.append(Truth(name="tracker_protractor_deg.txt", version="6.x (degrees, default)",
                     layout="#multi:, tab, three protractors (θ, ω), formatted: t 0.000, θ 0.0°",
                     t=t, angles=angles, angle_unit="deg", angle_stated=False,
                     read={"fps": fps, "columns": COLUMNS}, t_tol=1e-6, angle_tol=1e-6,
                     notes=["t rounded to 1 ms: the reader snaps it to the frame grid"],
                     **common))
    text, t, angles = protractors("tracker_protractor_rad.txt", fps, "rad", False, "\t", False)
    (folder / "tracker_protractor_rad.txt").write_text(text, encoding="utf-8")
    out.append(Truth(name="tracker_protractor_rad.txt", version="6.x (radians preference)",
                     layout="#multi:, tab, three protractors (θ, ω) in rad under the same "
                            "unit-less names, full precision 0.000000E0",
                     t=t, angles=angles, angle_unit="rad", angle_stated=False,
                     read={"fps": fps, "columns": COLUMNS}, t_tol=1e-6, angle_tol=1e-6,
                     notes=["nothing in the header says rad: values within ±π and ω = dθ/dt "
                            "in the same unit"], **common))
    text, t, angles = protractors("tracker_protractor_deg_comma.txt", fps, "deg", False, ";",
                                  True)
    (folder / "tracker_protractor_deg_comma.txt").write_bytes(
        text.replace("\n", "\r\n").encode("utf-8"))
    out.append(Truth(name="tracker_protractor_deg_comma.txt", version="6.x (German locale)",
                     layout="#multi:, ';', decimal comma, CRLF, full precision "
                            "(-5,012345E1), degrees",
                     t=t, angles=angles, angle_unit="deg", angle_stated=False,
                     read={"fps": fps, "columns": COLUMNS}, t_tol=1e-6, angle_tol=1e-6,
                     **common))
    text, t, angles = point_masses("tracker_pointmass.txt", fps, "\t", False)
    (folder / "tracker_pointmass.txt").write_text(text, encoding="utf-8")
    out.append(Truth(name="tracker_pointmass.txt", version="6.x",
                     layout="#multi:, tab, five point masses (x, y in m, y up), full "
                            "precision", t=t, angles=angles, length_unit="m (y up)",
                     read={"fps": fps, "points": POINTS}, t_tol=1e-6, angle_tol=1e-6,
                     **common))
    return out

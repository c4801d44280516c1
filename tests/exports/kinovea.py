"""Kinovea trajectory exports (Export > Spreadsheet > Trajectories to CSV).

Layout (read from Kinovea/Kinovea, tags 2023.1 ... 2025.2):

* ``Kinovea.ScreenManager/Exporters/Spreadsheet/ExporterCSVTrajectory.cs``: a header
  ``"Time"`` then ``"<object>/<point>/X"``, ``"<object>/<point>/Y"`` per point of every
  tracked object (trajectory tool: point ``0``; angle: ``o``, ``a``, ``b``; line: ``a``,
  ``b``); one row per distinct time over all objects (a sorted dictionary keyed by the
  float time), empty cells (no quotes) where an object has no point;
* ``CSVHelper.cs``: every cell quoted; numbers are .NET ``float.ToString(nfi)`` (single
  precision, "G": 7 significant digits, exponent form below 1e-5 or from 1e7); the
  decimal mark is the preference (system, point, comma); the list separator is the
  system's, except ``;`` when both would be ``,``; ``File.WriteAllLines``: CRLF, UTF-8;
* ``Kinovea.ScreenManager/Metadata/Metadata.cs`` ``GetNumericalTime(ts,
  TimeType.UserOrigin)``: the time follows the time-code preference, counted from the
  user's time origin (negative before it), frames = round(timestamps / per frame),
  ms = frames * frame interval / high-speed factor: ``Frames`` -> frames, ``Milliseconds``
  -> ms (fractional), ``Microseconds`` -> ms * 1000, ``TenThousandthOfHours`` -> ms / 360,
  ``HundredthOfMinutes`` -> ms / 600, ``Timestamps`` -> raw timestamps, anything else
  (``ClassicTime``, the default; ``TimeAndFrames``; ``Normalized``) -> seconds: whole ms
  / 1000 up to 2025.1 (``Math.Round(milliseconds) / 1000.0``), unrounded ms / 1000 from
  2025.2. The header says none of this: it is ``"Time"`` in every case;
* coordinates in world space (calibrated unit, y up; uncalibrated: pixels from the image
  centre, y up) or, with the image-space preference, pixels from the top-left, y down.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .shot import CAMERA, ROLES, angles_of, filmed
from .truth import Truth, rng_for

SOURCE = ("Kinovea/Kinovea: Kinovea.ScreenManager/Exporters/Spreadsheet/"
          "ExporterCSVTrajectory.cs, .../CSVHelper.cs, Kinovea.ScreenManager/Metadata/"
          "Metadata.cs (GetNumericalTime)")

#: Objects as a user names them: trajectory tools (point "0") on each part of the engine.
TRACKS = {"pivot": ("Axle", "0"), "spigot": ("Arm tip", "0"), "hinge": ("Hinge", "0"),
          "counterweight": ("Weight", "0"), "projectile": ("Stone", "0")}
TRACK_POINTS = {"pivot": "Axle", "spigot": "Arm tip", "hinge": "Hinge",
                "counterweight": "Weight", "projectile": "Stone"}
#: A tracked angle tool on the beam (o at the pivot, a at the spigot, b at the hinge) and
#: trajectory tools on the weight and the stone.
ANGLE_TOOL = {"pivot": ("Beam", "o"), "spigot": ("Beam", "a"), "hinge": ("Beam", "b"),
              "counterweight": ("Weight", "0"), "projectile": ("Stone", "0")}
ANGLE_POINTS = {"pivot": "Beam/o", "spigot": "Beam/a", "hinge": "Beam/b",
                "counterweight": "Weight", "projectile": "Stone"}
NOISE_M = 0.003
NOISE_PX = 0.3

#: Locales: (decimal mark, list separator) as CSVHelper chooses them.
LOCALES = {"en-US": (".", ","), "fr-FR": (",", ";"), "de-DE point": (".", ";"),
           "en-US comma": (",", ";")}


def net_single(value: float, decimal: str) -> str:
    """.NET Framework ``float.ToString()`` ("G", 7 significant digits) of a single."""
    f = float(np.float32(value))
    if f == 0:
        return "0"
    text = f"{f:.7G}"
    if "E" in text:
        mantissa, exponent = text.split("E")
        text = f"{mantissa}E{exponent[0]}{int(exponent[1:]):02d}"
    return text.replace(".", decimal)


def time_values(frames: np.ndarray, fps: float, code: str, version: str) -> np.ndarray:
    """What GetNumericalTime returns for frames counted from the time origin."""
    ms = frames * (1000.0 / fps)
    if code == "frames":
        return frames.astype(float)
    if code == "ms":
        return ms
    if code == "us":
        return ms * 1000
    if code == "hundredth_min":
        return np.round(ms) / 600.0
    if code == "s":
        return np.round(ms) / 1000.0 if version < "2025.2" else ms / 1000.0
    raise ValueError(code)


def export(name: str, fps: float, code: str, version: str, locale: str, origin: float,
           objects: dict[str, tuple[str, str]], space: str = "world"
           ) -> tuple[str, np.ndarray, dict]:
    """The file's text, the true time (s from the origin) of each row, and the angles.
    ``space``: "world" (calibrated m, y up) or "image" (pixels from the top-left, y down)."""
    rng = rng_for(name)
    shot = filmed(fps)
    decimal, sep = LOCALES[locale]
    n = len(shot.t)
    written: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    noise = NOISE_M if space == "world" else NOISE_PX
    for role in ROLES:
        x, y = shot.points[role]
        if space == "image":
            x, y = CAMERA.to_pixels(x, y)
        # the values as written (single precision, 7 significant digits) are the truth's
        xs = [_g7(v) for v in x + rng.normal(0, noise, n)]
        ys = [_g7(v) for v in y + rng.normal(0, noise, n)]
        written[role] = (np.array(xs), np.array(ys))
    rel = shot.frame - origin
    times = time_values(rel, fps, code, version)
    header = ['"Time"']
    order: list[str] = []
    for role in ROLES:
        obj, point = objects[role]
        header += [f'"{obj}/{point}/X"', f'"{obj}/{point}/Y"']
        order.append(role)
    lines = [sep.join(header)]
    for k in range(n):
        cells = [f'"{net_single(times[k], decimal)}"']
        for role in order:
            x, y = written[role]
            for v in (x[k], y[k]):
                cells.append("" if not np.isfinite(v) else f'"{net_single(v, decimal)}"')
        lines.append(sep.join(cells))
    angles = angles_of(written, y_up=space == "world", reference=shot.angles)
    return "\r\n".join(lines) + "\r\n", rel / fps, angles


def _g7(v: float) -> float:
    return float("nan") if not np.isfinite(v) else float(f"{float(np.float32(v)):.7G}")


CASES = [
    # name, fps, time code, version, locale, origin (frame), objects, note
    ("kinovea_2024_classic_s.csv", 240.0, "s", "2024.1", "en-US", 0.0, TRACKS,
     "ClassicTime (the default) up to 2025.1: seconds rounded to whole ms, no unit"),
    ("kinovea_2025_classic_s_fr.csv", 240.0, "s", "2025.2", "fr-FR", 0.0, ANGLE_TOOL,
     "ClassicTime from 2025.2: unrounded seconds (7 digits), French locale"),
    ("kinovea_ms_fraction_de.csv", 240.0, "ms", "2024.1", "de-DE point", None, TRACKS,
     "Milliseconds: fractional ms, origin at the trigger (negative before), ';' with '.'"),
    ("kinovea_us.csv", 240.0, "us", "2024.1", "en-US", 0.0, TRACKS,
     "Microseconds, no unit"),
    ("kinovea_frames_origin.csv", 240.0, "frames", "2024.1", "en-US", None, TRACKS,
     "Frames, origin at the trigger: negative frame numbers before it"),
    ("kinovea_frames_comma.csv", 120.0, "frames", "2023.1", "en-US comma", 0.0, TRACKS,
     "Frames, decimal comma preference on an English system: ';' separator"),
    ("kinovea_image_space_px.csv", 240.0, "ms", "2024.1", "en-US", 0.0, TRACKS,
     "Milliseconds; the image-space preference: pixels from the top-left corner, y down"),
    ("kinovea_hundredth_min.csv", 240.0, "hundredth_min", "2024.1", "en-US", 0.0, TRACKS,
     "HundredthOfMinutes: whole ms / 600, no unit (no keyword for it: to be refused)"),
]

TIME_CODES = {"s": "s", "ms": "ms", "us": "us", "frames": "frames",
              "hundredth_min": "1/100 min"}


def write(folder: Path) -> list[Truth]:
    out = []
    for name, fps, code, version, locale, origin, objects, note in CASES:
        shot = filmed(fps)
        origin_frame = round(shot.trigger_frame) if origin is None else origin
        space = "image" if "image_space" in name else "world"
        text, t, angles = export(name, fps, code, version, locale, origin_frame, objects,
                                 space)
        (folder / name).write_bytes(text.encode("utf-8"))
        points = ANGLE_POINTS if objects is ANGLE_TOOL else TRACK_POINTS
        dec, sep = LOCALES[locale]
        out.append(Truth(
            name=name, tool="kinovea", version=version + ("" if version >= "2025.2" else
                                                           " (2023.1-2025.1)"),
            layout=f"trajectory CSV, quoted cells, separator '{sep}', decimal '{dec}', CRLF; "
                   f"Time in {TIME_CODES[code]} without a unit; "
                   + ("calibrated m, y up" if space == "world" else "pixels, y down"),
            source=SOURCE, fps=fps, t=t, angles=angles, time_code=TIME_CODES[code],
            time_stated=False, length_unit="m (y up)" if space == "world" else "px (y down)",
            read={"fps": fps, "points": points}, t_tol=1e-6, angle_tol=1e-5,
            notes=[note] + ([f"time origin at frame {origin_frame:g} (the trigger)"]
                            if origin is None else [])))
    return out

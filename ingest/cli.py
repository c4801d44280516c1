"""Sub-command of the ingest room: ``trebuchet forces LOG --scene SCENE -o loads.csv``.

Light to import (docs/architecture.md, "Adding a sub-command"): the parser is built from
:mod:`trebuchet.ingest.settings`; numpy, pandas and the reconstruction load when ``forces``
runs.
"""

from __future__ import annotations

import argparse
import math
import sys
import warnings
from typing import TYPE_CHECKING

from trebuchet.core.errors import TrebuchetInputError, cli_command, command_line
from trebuchet.ingest.settings import FORMS, IMAGE_CALIBRATIONS, METHODS, TROUGH
from trebuchet.model.units import UNITS_HELP

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["register", "forces_summary", "parse_pairs", "add_log_arguments", "log_options",
           "add_reconstruct_arguments", "reconstruct_options", "add_event_arguments",
           "event_options", "add_image_calibration_argument", "EVENT_OPTIONS"]

ANGLE_NAMES = ("theta", "psi", "phi")
POINT_ROLES = ("pivot", "spigot", "hinge", "counterweight", "projectile")
EVENT_OPTIONS = ("trigger", "lift-off", "release")
SUMMARY_LOADS = (("F_R_abs", "|F_R|", "N"), ("F_H_abs", "|F_H|", "N"),
                 ("F_S_abs", "|F_S|", "N"), ("torque", "torque", "N m"))


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "forces", help="internal forces, with their sd, from a video angle log",
        description="Read an angle log, smooth it, find trigger, lift-off and release, and "
                    "write every force, torque and power with its standard deviation.")
    add_reconstruct_arguments(p)
    p.add_argument("-o", "--output", required=True, help="CSV file to write")
    p.add_argument("--units", action="store_true", help=UNITS_HELP)
    p.add_argument("--quiet", action="store_true",
                   help="no summary on stdout (warnings still go to stderr)")
    p.set_defaults(run=_forces)


def add_reconstruct_arguments(p: argparse.ArgumentParser) -> None:
    """Every argument of ``forces`` but its output: the log arguments
    (:func:`add_log_arguments`), ``--form``, ``--trough``, ``--method``,
    ``--image-calibration`` and the event times ``--trigger``, ``--lift-off``, ``--release``.
    ``compare`` adds exactly these too (docs/interface.md: it takes every option ``forces``
    takes, with the same names and meanings); read them back with
    :func:`reconstruct_options`."""
    add_log_arguments(p)
    p.add_argument("--form", choices=FORMS, default=None,
                   help="force formulas: projected on the arms (default) or the paper's direct")
    p.add_argument("--trough", choices=TROUGH, default=None,
                   help="phase-I sling angle from the trough constraint (default) or measured")
    p.add_argument("--method", choices=METHODS, default=None,
                   help="fit: loads of the engine fitted to the log where the fit passes its "
                        "residual check, else the smoother's (the default for a log of "
                        "angles; a log of tracked points keeps the smoother's unless fit is "
                        "given); smooth: loads of the smoothed angles")
    add_image_calibration_argument(p)
    add_event_arguments(p)


def add_image_calibration_argument(p: argparse.ArgumentParser) -> None:
    """``--image-calibration engine|none`` (point logs)."""
    p.add_argument("--image-calibration", choices=IMAGE_CALIBRATIONS, default=None,
                   help="point logs: the engine calibrates the camera's image itself "
                        "(engine, default) or the points are taken as seen (none)")


def add_event_arguments(p: argparse.ArgumentParser) -> None:
    """The event times ``--trigger``, ``--lift-off``, ``--release`` (read back with
    :func:`event_options`)."""
    for event in EVENT_OPTIONS:
        p.add_argument(f"--{event}", metavar="SECONDS",
                       help=f"{event} time in the log's time (s), or 'none'; default: found "
                            "in the data")


def event_options(args: argparse.Namespace) -> dict[str, float | None] | None:
    """The events of :func:`add_event_arguments` (log time, s; None = no such event), or
    None where none is given; each checked with an error naming its option."""
    return _event_args(args)


def reconstruct_options(args: argparse.Namespace) -> dict[str, object]:
    """The keywords of :func:`~trebuchet.ingest.reconstruct.reconstruct` from the arguments
    of :func:`add_reconstruct_arguments`: ``fps``, ``columns``, ``points``, ``events``,
    ``form``, ``trough``, ``method``, ``image_calibration``; each checked with an error naming
    its option."""
    return log_options(args) | {"events": _event_args(args), "form": args.form,
                                "trough": args.trough, "method": args.method,
                                "image_calibration": args.image_calibration}


def add_log_arguments(p: argparse.ArgumentParser) -> None:
    """The arguments every command that reads a log takes (docs/interface.md: ``forces``,
    ``reconstruct`` and ``compare`` take the same): LOG, --scene, --fps, --column, --point,
    --time-unit, --angle-unit, --min-likelihood, --individual, --calibration."""
    p.add_argument("log", help="angle or point log (generic CSV, Tracker, Kinovea, "
                               "DeepLabCut, SLEAP or anipose; docs/formats.md)")
    p.add_argument("--scene", required=True, help="scene file (TOML) of the engine filmed")
    p.add_argument("--fps", type=float,
                   help="frame rate (1/s): needed for frame numbers; also puts times "
                   "written with too few decimals back on its exact frame grid")
    p.add_argument("--column", action="append", default=[], metavar="NAME=ANGLE",
                   help="the file's column or track NAME holds ANGLE (theta, psi or phi); "
                        "repeatable")
    p.add_argument("--point", action="append", default=[], metavar="ROLE=NAME",
                   help="the file's point NAME is ROLE (pivot, spigot, hinge, counterweight, "
                        "projectile); repeatable")
    p.add_argument("--time-unit", choices=("s", "ms", "us", "frames"),
                   help="unit of a time column whose header states none (Kinovea's Time, a "
                        "plain 't'); default: decided from the frame steps, or refused")
    p.add_argument("--angle-unit", choices=("deg", "rad"),
                   help="unit of angle columns whose header states none (Tracker's θ, a "
                        "plain 'theta'); default: decided from the beam's sweep, or refused")
    p.add_argument("--min-likelihood", type=float, metavar="P",
                   help="DeepLabCut likelihood / SLEAP score below which a position is a gap "
                        "(default 0.6)")
    p.add_argument("--individual", metavar="NAME",
                   help="the DeepLabCut individual or SLEAP track that is the engine")
    p.add_argument("--calibration", metavar="FILE",
                   help="your own camera calibration, for DeepLabCut/SLEAP pixel tracks: "
                        "four or more known points of the engine's plane (CSV u,v px; x,y m, "
                        "or TOML [[point]]) or an OpenCV camera file (YAML, XML, JSON: "
                        "camera_matrix, distortion_coefficients); docs/formats.md")


def log_options(args: argparse.Namespace) -> dict[str, object]:
    """The keywords of :func:`read_log` from the log arguments (``fps``, ``columns``,
    ``points``, and those given of ``time_unit``, ``angle_unit``, ``min_likelihood``,
    ``individual``, ``calibration``), each checked with an error naming the option."""
    if args.fps is not None:  # before the file is read, which would take the blame
        from trebuchet.ingest.readers.timebase import check_fps

        with command_line():
            check_fps(args.fps)
    options: dict[str, object] = {
        "fps": args.fps,
        "columns": parse_pairs(args.column, "--column", ANGLE_NAMES, "right"),
        "points": parse_pairs(args.point, "--point", POINT_ROLES, "left")}
    p = getattr(args, "min_likelihood", None)
    if p is not None and not (math.isfinite(p) and 0 <= p <= 1):
        raise TrebuchetInputError(f"--min-likelihood {p:g}: must be in [0, 1]")
    for key in ("time_unit", "angle_unit", "min_likelihood", "individual", "calibration"):
        value = getattr(args, key, None)
        if value is not None:
            options[key] = value
    return options


def parse_pairs(items: list[str], option: str, allowed: tuple[str, ...],
                value_side: str) -> dict[str, str] | None:
    """``["NAME=theta", ...]`` as ``{NAME: "theta"}`` (``value_side="right"``: the allowed
    word is right of ``=``) or ``["pivot=NAME"]`` as ``{"pivot": NAME}`` (``"left"``)."""
    if not items:
        return None
    out: dict[str, str] = {}
    for item in items:
        if "=" not in item:
            form = "NAME=ANGLE with ANGLE" if value_side == "right" else "ROLE=NAME with ROLE"
            raise TrebuchetInputError(f"{option} {item!r}: expected {form} one of "
                                      + ", ".join(allowed))
        if value_side == "right":
            name, word = item.rsplit("=", 1)
            key, value = name.strip(), word.strip()
            check = value
        else:
            word, name = item.split("=", 1)
            key, value = word.strip(), name.strip()
            check = key
        if check not in allowed:
            raise TrebuchetInputError(f"{option} {item!r}: {check!r} is not one of "
                                      + ", ".join(allowed))
        if not (key and value):
            raise TrebuchetInputError(f"{option} {item!r}: a name is missing")
        out[key] = value
    return out


def _event_args(args: argparse.Namespace) -> dict[str, float | None] | None:
    events: dict[str, float | None] = {}
    for name in ("trigger", "lift_off", "release"):
        value = getattr(args, name)
        if value is None:
            continue
        if value.strip().lower() == "none":
            events[name] = None
            continue
        try:
            events[name] = float(value)
        except ValueError:
            raise TrebuchetInputError(f"--{name.replace('_', '-')} {value!r}: not a time in s "
                                      "(or 'none')") from None
        if not math.isfinite(events[name]):
            raise TrebuchetInputError(f"--{name.replace('_', '-')} {value!r}: not finite")
    return events or None


def _fmt_time(value: float | None, sd: float | None = None) -> str:
    if value is None:
        return "none"
    text = f"{value:.4f} s"
    if sd is not None and math.isfinite(sd) and sd > 0:
        text += f" ± {sd:.4f}"
    return text


def friction_summary(result: pd.DataFrame, release: float | None) -> list[str]:
    """The heat the bearings' friction made by the release (or the log's end), J with its sd,
    where the scene has friction (issue 22: losses from a measured log)."""
    import numpy as np

    if "E_loss_pivot" not in result.columns:
        return []
    t = result["t"].to_numpy()
    i = len(t) - 1 if release is None else max(int(np.searchsorted(t, release, "right")) - 1, 0)
    parts = [f"{joint} {result[f'E_loss_{joint}'].iloc[i]:.4g} ± "
             f"{result[f'E_loss_{joint}_sd'].iloc[i]:.2g} J"
             for joint in ("pivot", "hinge")]
    when = "the release" if release is not None else "the log's end"
    return [f"lost to friction by {when}: " + ", ".join(parts)]


def forces_summary(result: pd.DataFrame, output: str | None = None) -> str:
    """The summary the command prints: log, noise per angle, events, repairs, peak loads
    with their sd, advisories, validity findings and notes (e.g. a log without rest, whose
    ``t_shot`` counts from its first row)."""
    import numpy as np

    from trebuchet.ingest.logs.result import read_log_info
    from trebuchet.ingest.reconstruction import reconstruction_of

    a = reconstruction_of(result)
    info = read_log_info(result)
    source, fmt, repairs = (("log", "table", ()) if info is None
                            else (info.source, info.format, info.repairs))
    lines = [f"log: {source} ({fmt}), {len(result)} rows, "
             f"{a.fps:.4g} fps; formulas: {a.form}",
             "loads: " + ("of the engine fitted to the log (method fit)" if a.method == "fit"
                          else "of the smoothed angles (method smooth)")]
    if a.noise:
        parts = [f"{k} {math.degrees(v['r_sd']):.3g}°" for k, v in a.noise.items()]
        how = "fourth differences" if a.method == "fit" else "maximum likelihood"
        lines.append(f"angle noise (sd, {how}): " + ", ".join(parts))
    ev, sd, src = a.events, a.event_sd, a.event_sources
    lines.append("events (log time):")
    for key, label in (("trigger", "trigger"), ("lift_off", "lift-off"), ("release", "release")):
        lines.append(f"  {label:9s}{_fmt_time(ev.get(key), sd.get(key))}"
                     f"  ({src.get(key, '')})")
    lines.append(f"repairs: {len(repairs)}, each in a warning" if repairs else "repairs: none")
    lines.append("peak loads (sd at the peak):")
    moving = result["phase"].to_numpy() > 0
    t = result["t"].to_numpy()
    for col, label, unit in SUMMARY_LOADS:
        v = np.abs(result[col].to_numpy())
        ok = moving & np.isfinite(v)
        if not ok.any():
            continue
        i = np.flatnonzero(ok)[np.argmax(v[ok])]
        lines.append(f"  {label:7s}{v[i]:11.4g} ± {result[col + '_sd'].to_numpy()[i]:.3g} "
                     f"{unit} at t = {t[i]:.4f} s")
    lines += friction_summary(result, ev.get("release"))
    for key, title in (("advisories", "resolution advisory"), ("validity", "model validity"),
                       ("notes", "notes")):
        items = getattr(a, key)
        if items:
            lines.append(f"{title}:")
            lines += [f"  {getattr(it, 'message', it)}" for it in items]
    if output:
        lines.append(f"-> {output} ({result.shape[1]} columns)")
    return "\n".join(lines)


@cli_command
def _forces(args: argparse.Namespace) -> int:
    from trebuchet.core.csv_table import write_table
    from trebuchet.core.output import check_target
    from trebuchet.ingest.reconstruct import reconstruct
    from trebuchet.model.units import column_units

    inputs = [args.log, args.scene, args.calibration]
    check_target(args.output, inputs=inputs)
    options = reconstruct_options(args)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = reconstruct(args.log, args.scene, **options)
    write_table(result, args.output, inputs=inputs,
                units=column_units(list(result.columns)) if args.units else None)
    summary = "" if args.quiet else forces_summary(result, args.output)
    if summary:
        print(summary)
    for w in caught:  # on stderr, as compare's: what the summary does not already say
        text = str(w.message)
        if not any(part.strip() in text for part in summary.splitlines()[1:]
                   if len(part.strip()) > 20):
            print(f"trebuchet: warning: {text}", file=sys.stderr)
    return 0

"""Hostile and careless user files: a seeded corpus of mutated logs, scenes and calibrations.

Every format ``read_log`` reads (generic CSV, Tracker, Kinovea, DeepLabCut CSV and .h5 in
pandas' "table" and "fixed" formats, SLEAP CSV and .h5, anipose), the shipped scenes and
calibration files (points CSV and TOML, OpenCV YAML, XML and JSON) are mutated
(:mod:`bench._fuzz_cases`: encodings, cut and repeated rows, cells of text, huge numbers,
``-5_0.1`` and Arabic-Indic digits, a cell off by 30° or 90°, times offset by 1e15 s,
terminal control bytes in names, pickled objects in an HDF5 file, nested arrays, FIFOs,
``/dev/zero``, a 5 GB sparse file, ...). Each case runs in a worker process (3 GiB of
address space, 60 s) through ``read_log`` / ``Scene.from_toml`` / ``read_calibration`` and,
where the file was read, ``trebuchet forces`` on it; its outcome is the worst of:

- ``code ran``: a payload in the file ran (it writes a marker file);
- ``hang``: no answer within 60 s;
- ``traceback``: an exception other than ``TrebuchetInputError`` (or the command line
  printing a traceback);
- ``silent change``: read differently from the honest file with no warning naming the
  touched row, or a non-number read as a number, or ``forces`` exiting 0 with the loads
  missing (NaN) on more than a fifth of the rows the honest input has them;
- ``control bytes``: a raw terminal control byte in a message or on the terminal;
- ``unclean refusal``: a refusal of more than one line or that does not name the file;
- ``refused``: a one-line refusal naming the file (and row or key);
- ``warned``: read differently, with a warning naming the touched row;
- ``accepted``: a different, well-formed input read as written (a scene with another sling);
- ``identical``: read as the honest file is.

Targets: no case in the first six classes. ``run(out_dir)`` writes every case with its
outcome to ``fuzz_inputs_cases.csv`` and returns the counts by input kind and outcome;
``python -m bench fuzz_inputs``.
"""

from __future__ import annotations

import contextlib
import io
import multiprocessing
import re
import sys
import time
import traceback
import unicodedata
import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from bench._fuzz_cases import MARKER, Case, all_cases, make_special

SEED = 20260521
TIMEOUT = 60.0
MEMORY = 3 << 30
OUTCOMES = ("code ran", "hang", "traceback", "silent change", "control bytes",
            "unclean refusal", "refused", "warned", "accepted", "identical")
BAD = OUTCOMES[:6]


@dataclass(frozen=True)
class Outcome:
    """What one case gave: ``outcome`` (one of :data:`OUTCOMES`) and a short ``detail``."""

    outcome: str
    detail: str = ""


def worst(*outcomes: Outcome) -> Outcome:
    return min(outcomes, key=lambda o: OUTCOMES.index(o.outcome))


# --------------------------------------------------------------------------- in the worker

_BASELINES: dict[str, object] = {}


def _raw_control(text: str) -> bool:
    """Whether ``text`` holds a control character a terminal acts on (newlines of a
    multi-line output aside)."""
    return any(unicodedata.category(c) == "Cc" and c not in "\n\t" for c in text)


def _strip_name(message: str) -> str:
    """A message without the file name it starts with."""
    return message.split(": ", 1)[-1]


def _rows_named(messages: Iterable[str]) -> set[int]:
    """Every row (line) number the messages name: ``row 5``, ``rows 3-5, 9``, ``after row 7``,
    ``lines 3–287``."""
    out: set[int] = set()
    for m in messages:
        for span in re.findall(r"(?:rows?|lines?) ((?:\d+(?:[-–]\d+)?(?:, )?)+)", m):
            for part in span.split(","):
                m = re.fullmatch(r"(\d+)(?:[-–](\d+))?", part.strip())
                if m:
                    lo = int(m[1])
                    out.update(range(lo, min(int(m[2] or lo), lo + 100_000) + 1))
    return out


def _refusal(message: str, path: Path) -> Outcome:
    if "\n" in message or _raw_control(message):
        return Outcome("unclean refusal", message[:300])
    if path.name not in message:
        return Outcome("unclean refusal", f"names no file: {message[:300]}")
    return Outcome("refused", message[:300])


def _crash(exc: BaseException) -> Outcome:
    return Outcome("traceback", f"{type(exc).__name__}: {str(exc)[:200]}")


def _same_frames(a: pd.DataFrame, b: pd.DataFrame) -> bool:
    cols = ["t", "theta", "psi", "phi"]
    if a.shape[0] != b.shape[0]:
        return False
    return bool(np.allclose(a[cols].to_numpy(float), b[cols].to_numpy(float), rtol=1e-12,
                            atol=1e-12, equal_nan=True))


def _read_log(path: Path, read: dict) -> tuple[pd.DataFrame | None, list[str], Outcome | None]:
    from trebuchet import TrebuchetInputError, read_log

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            df = read_log(path, **read)
        except TrebuchetInputError as exc:
            return None, [], _refusal(str(exc), path)
        except Exception as exc:  # the point of the corpus: anything else is a traceback
            return None, [], _crash(exc)
    return df, [str(w.message) for w in caught], None


def _log_outcome(case: Case, path: Path) -> Outcome:
    base = case.base
    if base.key not in _BASELINES:
        _BASELINES[base.key] = _read_log(base.path, base.read)
    honest, honest_notes, _ = _BASELINES[base.key]
    df, notes, failed = _read_log(path, base.read)
    if failed is not None:
        return failed
    if any(_raw_control(n) for n in notes):
        return Outcome("control bytes", next(n for n in notes if _raw_control(n))[:300])
    if case.expect == "refuse":
        return Outcome("silent change", "read, not refused" + (
            " (as the honest file: a non-number read as one)" if _same_frames(df, honest)
            else ""))
    if _same_frames(df, honest):
        return Outcome("identical")
    known = {_strip_name(n) for n in honest_notes}
    new = [_strip_name(n) for n in notes if _strip_name(n) not in known]
    if new and (not case.rows or _rows_named(new) & {r + d for r in case.rows
                                                      for d in (-1, 0, 1)}):
        return Outcome("warned", new[0][:300])
    diff = f"{len(df)} rows (honest {len(honest)})"
    return Outcome("silent change", diff + (f"; new warnings name other rows: {new[0][:200]}"
                                            if new else "; no warning"))


def _cli_args(read: dict) -> list[str]:
    out: list[str] = []
    for key, value in read.items():
        flag = "--" + key.replace("_", "-")
        if key == "columns":
            for k, v in value.items():
                out += ["--column", f"{k}={v}"]
        elif key == "points":
            for k, v in value.items():
                out += ["--point", f"{k}={v}"]
        else:
            out += [flag, str(value)]
    return out


def _forces(log: Path, scene: Path, read: dict, folder: Path
            ) -> tuple[int | None, str, str, pd.DataFrame | None, Outcome | None]:
    """``trebuchet forces`` in this process: (status, stdout, stderr, loads, crash)."""
    from trebuchet.cli import main

    target = folder / "loads.csv"
    target.unlink(missing_ok=True)
    out, err = io.StringIO(), io.StringIO()
    args = ["forces", str(log), "--scene", str(scene), "-o", str(target), *_cli_args(read)]
    old = warnings.formatwarning
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), \
                warnings.catch_warnings():
            warnings.simplefilter("always")
            try:
                status = main(args)
            except SystemExit as exc:
                status = exc.code if isinstance(exc.code, int) else 1
    except Exception as exc:
        return None, out.getvalue(), err.getvalue(), None, _crash(exc)
    finally:
        warnings.formatwarning = old
    loads = None
    if status == 0 and target.exists():
        loads = pd.read_csv(target, comment="#")
    return status, out.getvalue(), err.getvalue(), loads, None


def _cli_outcome(log: Path, scene: Path, read: dict, folder: Path, key: str,
                 honest_log: Path, honest_scene: Path) -> Outcome:
    if key not in _BASELINES:
        _BASELINES[key] = _forces(honest_log, honest_scene, read, folder)[3]
    honest = _BASELINES[key]
    status, out, err, loads, crash = _forces(log, scene, read, folder)
    if crash is not None:
        return crash
    if "Traceback" in err:
        return Outcome("traceback", err.strip().splitlines()[-1][:300])
    if _raw_control(out) or _raw_control(err):
        return Outcome("control bytes", "in the output of forces")
    if status == 2:
        errors = [ln for ln in err.splitlines() if ln.startswith("trebuchet: error:")]
        if len(errors) == 1:
            return Outcome("refused", errors[0][:300])
        return Outcome("unclean refusal", err[-300:])
    if status != 0 or loads is None:
        return Outcome("traceback", f"status {status}: {err[-200:]}")
    if honest is not None and "F_S_abs" in loads and len(loads) == len(honest):
        lost = np.isfinite(honest["F_S_abs"].to_numpy(float)) & ~np.isfinite(
            loads["F_S_abs"].to_numpy(float))
        if lost.sum() > 0.2 * np.isfinite(honest["F_S_abs"].to_numpy(float)).sum():
            return Outcome("silent change", f"forces exits 0 with |F_S| NaN on {int(lost.sum())}"
                                            f" of {len(loads)} rows")
    return Outcome("identical")


def _scene_outcome(case: Case, path: Path, folder: Path, cli: bool) -> Outcome:
    from trebuchet import Scene, TrebuchetInputError

    try:
        scene = Scene.from_toml(path)
    except TrebuchetInputError as exc:
        return _refusal(str(exc), path)
    except Exception as exc:
        return _crash(exc)
    honest = Scene.from_toml(case.base.path)
    got = Outcome("identical") if scene == honest else Outcome("accepted")
    if case.expect == "refuse" or (case.expect == "same" and got.outcome != "identical"):
        got = Outcome("silent change", "read as a scene")
    if not cli or got.outcome == "identical":
        return got
    log = case.base.path.parent / case.base.path.name.replace(".toml", "_240fps.csv")
    if case.base.key == "horsdal_large.toml":
        log = case.base.path.parent / "horsdal_240fps.csv"
    outcome = _cli_outcome(log, path, {}, folder, f"cli/{case.base.key}", log, case.base.path)
    return worst(got, outcome) if outcome.outcome != "identical" else got


def _calibration_outcome(case: Case, path: Path) -> Outcome:
    from trebuchet import TrebuchetInputError
    from trebuchet.ingest.geometry.user_calibration import read_calibration

    try:
        cal = read_calibration(path)
    except TrebuchetInputError as exc:
        return _refusal(str(exc), path)
    except Exception as exc:
        return _crash(exc)
    honest = read_calibration(case.base.path)
    same = all(
        (a is None and b is None) or (a is not None and b is not None and np.allclose(a, b))
        for a, b in ((cal.homography, honest.homography),
                     (None if cal.lens is None else cal.lens.matrix,
                      None if honest.lens is None else honest.lens.matrix),
                     (None if cal.lens is None else cal.lens.distortion,
                      None if honest.lens is None else honest.lens.distortion)))
    got = Outcome("identical") if same else Outcome("accepted")
    if case.expect == "refuse" or (case.expect == "same" and not same):
        got = Outcome("silent change", "read as a calibration")
    from bench._fuzz_cases import SAMPLES

    _, notes, failed = _read_log(SAMPLES / "video_paper_dlc.csv",
                                 {"fps": 240, "calibration": str(path)})
    if failed is not None:
        return worst(got, failed) if failed.outcome != "refused" else failed
    if any(_raw_control(n) for n in notes):
        return Outcome("control bytes", "in read_log's warnings")
    return got


def run_case(case: Case, folder: Path, cli: bool = True) -> Outcome:
    """Run one case in this process (see the module doc)."""
    here = folder / "cases" / re.sub(r"[^\w.=-]+", "_", case.name)[:120]
    here.mkdir(parents=True, exist_ok=True)
    marker = folder / MARKER
    marker.unlink(missing_ok=True)
    if case.special:
        path = make_special(case.special, here, case.suffix)
    else:
        path = here / f"input{case.suffix}"
        path.write_bytes(case.data)
    try:
        if case.kind == "log":
            got = _log_outcome(case, path)
            if cli and case.base.scene is not None and got.outcome in (
                    "identical", "warned", "silent change") and case.special is None:
                outcome = _cli_outcome(path, case.base.scene, case.base.read, here,
                                       f"cli/{case.base.key}", case.base.path, case.base.scene)
                if outcome.outcome != "identical":
                    got = worst(got, outcome) if got.outcome != "identical" or \
                        outcome.outcome in BAD else outcome
        elif case.kind == "scene":
            got = _scene_outcome(case, path, here, cli)
        else:
            got = _calibration_outcome(case, path)
    except Exception as exc:
        got = _crash(exc)
    if marker.exists():
        got = Outcome("code ran", "a payload in the file wrote its marker")
    return got


def _serve(conn, folder: str, cli: bool) -> None:  # pragma: no cover - a worker process
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (MEMORY, MEMORY))
    while True:
        case = conn.recv()
        if case is None:
            return
        try:
            got = run_case(case, Path(folder), cli)
        except BaseException as exc:  # MemoryError, RecursionError in the harness itself
            got = Outcome("traceback", f"{type(exc).__name__} in the worker: "
                                       f"{traceback.format_exc(limit=1)[-200:]}")
        conn.send(got)


class Workers:
    """One worker process at a time: a case that does not answer within ``timeout`` s is a
    hang, its worker killed and a fresh one started."""

    def __init__(self, folder: Path, cli: bool, timeout: float) -> None:
        self.folder, self.cli, self.timeout = folder, cli, timeout
        self.ctx = multiprocessing.get_context("spawn")
        self.proc = None

    def _start(self) -> None:
        self.conn, child = self.ctx.Pipe()
        self.proc = self.ctx.Process(target=_serve, args=(child, str(self.folder), self.cli),
                                     daemon=True)
        self.proc.start()

    def _stop(self) -> None:
        if self.proc is not None:
            self.proc.kill()
            self.proc.join()
            self.proc = None

    def run(self, case: Case) -> tuple[Outcome, float]:
        if self.proc is None or not self.proc.is_alive():
            self._start()
        t0 = time.perf_counter()
        self.conn.send(case)
        if self.conn.poll(self.timeout):
            try:
                return self.conn.recv(), time.perf_counter() - t0
            except EOFError:
                pass
            self._stop()
            return Outcome("traceback", "the worker died (killed or crashed)"), \
                time.perf_counter() - t0
        self._stop()
        return Outcome("hang", f"no answer within {self.timeout:g} s"), \
            time.perf_counter() - t0

    def close(self) -> None:
        if self.proc is not None and self.proc.is_alive():
            self.conn.send(None)
            self.proc.join(10)
        self._stop()


def run_cases(cases: list[Case], folder: Path, *, cli: bool = True,
              timeout: float = TIMEOUT) -> pd.DataFrame:
    """Every case's outcome: columns case, kind, mutation, expect, outcome, detail, seconds."""
    workers = Workers(folder, cli, timeout)
    rows = []
    try:
        for case in cases:
            got, seconds = workers.run(case)
            rows.append({"case": case.name, "kind": _kind(case), "mutation": case.mutation,
                         "expect": case.expect, "outcome": got.outcome,
                         "detail": got.detail.replace("\n", " "), "seconds": seconds})
    finally:
        workers.close()
    return pd.DataFrame(rows)


def _kind(case: Case) -> str:
    if case.special:
        return "special path"
    if case.kind == "log":
        return "HDF5 log" if case.suffix == ".h5" else "text log"
    return case.kind


def summary(results: pd.DataFrame) -> pd.DataFrame:
    """Cases by input kind (rows) and outcome (columns), with a total row."""
    table = pd.crosstab(results["kind"], results["outcome"]).reindex(
        columns=list(OUTCOMES), fill_value=0)
    table.loc["all"] = table.sum()
    table.insert(0, "cases", table.sum(axis=1))
    return table.reset_index().rename(columns={"kind": "input"})


#: The cases ``make test`` always runs (tests/test_fuzz_inputs.py): one of each finding of
#: issue 21; :func:`sample` adds a few drawn by the seed.
MUST = (
    "log/horsdal_240fps.csv/utf16_odd_bytes", "log/horsdal_240fps.csv/cell_long",
    "log/horsdal_tracker.txt/header_long", "log/horsdal_240fps.csv/cell_underscore",
    "log/horsdal_240fps.csv/cell_arabic_digits", "log/horsdal_240fps.csv/angle_outlier_90deg",
    "log/horsdal_tracker.txt/angle_outlier_30deg", "log/horsdal_240fps.csv/time_offset_1e15",
    "log/horsdal_240fps.csv/header_control_bytes", "log/dlc_single_fixed.h5/pickled_object",
    "log/dlc_single.h5/pickled_attribute", "log/dlc_single.h5/values_1e300",
    "log/sleap_two_tracks.analysis.h5/tracks_bool",
    "log/sleap_two_tracks.analysis.h5/scores_shape_mismatch",
    "log/sleap_two_tracks.analysis.h5/tracks_huge_shape",
    "scene/horsdal_large.toml/M=1e308", "scene/horsdal_large.toml/M=10^400",
    "scene/horsdal_large.toml/M=5000_digits", "scene/horsdal_large.toml/L1=nested_arrays",
    "scene/horsdal_large.toml/m=inline_tables", "scene/horsdal_large.toml/L4=1mm",
    "calibration/camera.json/deep_nesting", "calibration/video_paper_points.csv/"
    "collinear_image_points", "log/fifo", "log/dev_zero", "log/sparse_5GB", "scene/fifo",
    "calibration/dev_urandom",
)


def sample(cases: list[Case], extra: int = 12, seed: int = SEED) -> list[Case]:
    """The cases of :data:`MUST` (those the corpus has: the HDF5 ones need PyTables to be
    written) and ``extra`` more drawn by ``seed``."""
    must = [c for c in cases if c.name in MUST]
    rest = [c for c in cases if c.name not in MUST]
    pick = np.random.default_rng(seed).choice(len(rest), size=min(extra, len(rest)),
                                              replace=False)
    return must + [rest[int(k)] for k in sorted(pick)]


def run(out_dir: Path) -> pd.DataFrame:
    folder = Path(out_dir) / "fuzz_inputs_files"
    if folder.exists():
        import shutil

        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    cases = all_cases(folder, SEED)
    t0 = time.perf_counter()
    results = run_cases(cases, folder)
    results["detail"] = results["detail"].str.replace(f"{folder}/", "", regex=False)
    results.to_csv(Path(out_dir) / "fuzz_inputs_cases.csv", index=False)
    table = summary(results)
    bad = results[results["outcome"].isin(BAD)]
    table.attrs["notes"] = [
        f"{len(results)} cases, seed {SEED}, {time.perf_counter() - t0:.0f} s; "
        f"{len(bad)} in the bad classes ({', '.join(BAD)})"] + [
        f"{r.case}: {r.outcome} ({r.detail[:160]})" for r in bad.itertuples()][:40]
    import shutil

    shutil.rmtree(folder, ignore_errors=True)
    return table


def main(argv: list[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", nargs="?", type=Path, default=Path("bench/results"))
    ap.add_argument("--only", help="run only the cases whose name contains this")
    ap.add_argument("--no-cli", action="store_true")
    args = ap.parse_args(argv)
    folder = args.out / "fuzz_inputs_files"
    folder.mkdir(parents=True, exist_ok=True)
    cases = [c for c in all_cases(folder, SEED) if not args.only or args.only in c.name]
    results = run_cases(cases, folder, cli=not args.no_cli)
    results["detail"] = results["detail"].str.replace(f"{folder}/", "", regex=False)
    results.to_csv(args.out / "fuzz_inputs_cases.csv", index=False)
    with pd.option_context("display.width", 250, "display.max_colwidth", 120,
                           "display.max_rows", 1000):
        print(results[["case", "outcome", "detail", "seconds"]].to_string(index=False))
        print(summary(results).to_string(index=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())

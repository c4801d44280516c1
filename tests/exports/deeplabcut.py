"""DeepLabCut exports: ``analyze_videos`` output as .h5 (pandas HDF) and .csv.

Layout, as DeepLabCut writes it (read from DeepLabCut/DeepLabCut,
``deeplabcut/pose_estimation_pytorch/apis/videos.py`` ``create_df_from_prediction`` and
``deeplabcut/refine_training_dataset/stitch.py`` ``TrackletStitcher.format_df`` /
``write_tracks``): a pandas DataFrame whose columns are a MultiIndex
``scorer / bodyparts / coords`` (single animal) or ``scorer / individuals / bodyparts /
coords`` (multi-animal; unique bodyparts under the individual ``single``), coords ``x``,
``y``, ``likelihood``, index = frame number from 0. ``df.to_hdf(path,
key="df_with_missing", format="table", mode="w")`` (multi-animal tracks after stitching:
``key="tracks"``), ``df.to_csv(path)`` with ``save_as_csv``. Pixels, origin at the
image's top-left corner, y down. The writers below make the same DataFrame and call the
same two pandas methods.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from .shot import CAMERA, ROLES, angles_of, filmed
from .truth import Truth, hdf5_writable, rng_for

SOURCE = ("DeepLabCut/DeepLabCut: deeplabcut/pose_estimation_pytorch/apis/videos.py "
          "(create_df_from_prediction)")
SOURCE_STITCH = ("DeepLabCut/DeepLabCut: deeplabcut/refine_training_dataset/stitch.py "
                 "(TrackletStitcher.format_df, write_tracks)")
SCORER = "DLC_Resnet50_trebuchetNov25shuffle1_snapshot_200"
#: Bodypart names of the fixtures and the ``points=`` a user gives for them.
NAMES = {"pivot": "axle", "spigot": "arm_tip", "hinge": "hinge", "counterweight": "weight",
         "projectile": "stone"}
POINTS = dict(NAMES)
#: The likelihood cut-off the truth assumes; the fixtures have no likelihood between
#: 0.45 and 0.95, so any cut-off in that range (the package's old 0.9, the issue's 0.6)
#: gives the same gaps.
CUT = 0.6
NOISE_PX = 0.3


def tracked(name: str, fps: float, repeat: int = 1):
    """Pixels (y down) and likelihoods of the five points, as a pose estimator gives them.

    Good positions: Gaussian noise of NOISE_PX, likelihood 0.95-0.9999. A few positions
    (2 % of the moving frames) are mislocated by 15-40 px with likelihood 0.05-0.45; the
    stone after release (lost) sits near its last place with likelihood 0.01-0.3.
    ``repeat`` > 1: a video up-converted from fps / repeat, each image ``repeat`` times
    (the network gives the same numbers for the same image).
    """
    rng = rng_for(name)
    shot = filmed(fps / repeat)
    n = len(shot.t)
    px: dict[str, np.ndarray] = {}
    for role in ROLES:
        x, y = CAMERA.to_pixels(*shot.points[role])
        x = x + rng.normal(0, NOISE_PX, n)
        y = y + rng.normal(0, NOISE_PX, n)
        p = rng.uniform(0.95, 0.9999, n)
        lost = ~np.isfinite(x)
        if lost.any():
            first = int(np.argmax(lost))
            x[lost] = x[first - 1] + rng.normal(0, 20, lost.sum())
            y[lost] = y[first - 1] + rng.normal(0, 20, lost.sum())
            p[lost] = rng.uniform(0.01, 0.3, lost.sum())
        px[role] = np.column_stack([x, y, p])
    moving = np.nonzero(shot.t > shot.release - 0.9)[0]
    for k in rng.choice(moving, size=max(1, len(moving) // 50 * len(ROLES) // 5), replace=False):
        role = ROLES[int(rng.integers(1, len(ROLES)))]
        if px[role][k, 2] < CUT:
            continue
        px[role][k, :2] += rng.uniform(15, 40, 2) * rng.choice([-1, 1], 2)
        px[role][k, 2] = rng.uniform(0.05, 0.45)
    frames = np.arange(n * repeat)
    images = frames // repeat
    table = {role: px[role][images] for role in ROLES}
    points = {role: (np.where(px[role][:, 2] >= CUT, px[role][:, 0], np.nan),
                     np.where(px[role][:, 2] >= CUT, px[role][:, 1], np.nan)) for role in ROLES}
    angles = angles_of(points, y_up=False, reference=shot.angles)
    t_kept = shot.frame * repeat / fps      # first frame of each run
    return frames, table, t_kept, angles


def single_frame(table: dict[str, np.ndarray], n: int) -> pd.DataFrame:
    """The single-animal DataFrame (scorer / bodyparts / coords)."""
    columns = pd.MultiIndex.from_product(
        [[SCORER], [NAMES[r] for r in ROLES], ["x", "y", "likelihood"]],
        names=["scorer", "bodyparts", "coords"])
    data = np.hstack([table[r] for r in ROLES])
    return pd.DataFrame(data, columns=columns, index=range(n))


def multi_frame(table: dict[str, np.ndarray], n: int, individuals: list[str],
                rng: np.random.Generator) -> pd.DataFrame:
    """Multi-animal DataFrame (scorer / individuals / bodyparts / coords) as the stitcher
    writes it: the engine is the first individual, the pivot (fixed scenery) a unique
    bodypart of ``single``; any further individual is a spurious detection on a few
    frames (NaN elsewhere)."""
    parts = [NAMES[r] for r in ROLES if r != "pivot"]
    columns = pd.MultiIndex.from_product(
        [[SCORER], individuals, parts, ["x", "y", "likelihood"]],
        names=["scorer", "individuals", "bodyparts", "coords"])
    blocks = [np.hstack([table[r] for r in ROLES if r != "pivot"])]
    for _ in individuals[1:]:
        other = np.full((n, 3 * len(parts)), np.nan)
        rows = rng.choice(n, size=n // 10, replace=False)
        other[rows] = np.column_stack([
            rng.uniform(0, 1920, (len(rows), len(parts))),
            rng.uniform(0, 1080, (len(rows), len(parts))),
            rng.uniform(0.6, 0.99, (len(rows), len(parts)))])[:, _interleave(len(parts))]
        blocks.append(other)
    df = pd.DataFrame(np.hstack(blocks), columns=columns, index=range(n))
    unique = pd.MultiIndex.from_product(
        [[SCORER], ["single"], [NAMES["pivot"]], ["x", "y", "likelihood"]],
        names=["scorer", "individuals", "bodyparts", "coords"])
    df2 = pd.DataFrame(table["pivot"], columns=unique, index=range(n))
    return df.join(df2, how="outer")


def _interleave(k: int) -> np.ndarray:
    """Column order x0, y0, p0, x1, ... from blocks [x0..xk, y0..yk, p0..pk]."""
    return np.array([j * k + i for i in range(k) for j in range(3)])


def _truth(name: str, layout: str, source: str, fps: float, t: np.ndarray, angles,
           read: dict, **kw) -> Truth:
    return Truth(name=name, tool="deeplabcut", version=kw.pop("version", "2.x, 3.x"),
                 layout=layout, source=source, fps=kw.pop("true_fps", fps), t=t,
                 angles=angles, time_code="frames (index)", time_stated=False,
                 length_unit="px (y down)", read=read, min_likelihood=CUT, **kw)


def write(folder: Path) -> list[Truth]:
    out = []
    h5 = hdf5_writable()
    fps = 120.0
    # single animal, CSV and HDF (same data)
    frames, table, t, angles = tracked("dlc_single", fps)
    df = single_frame(table, len(frames))
    df.to_csv(folder / "dlc_single.csv")
    if h5:
        df.to_hdf(folder / "dlc_single.h5", key="df_with_missing", format="table", mode="w")
    read = {"fps": fps, "points": POINTS}
    out.append(_truth("dlc_single.csv", "CSV, header rows scorer / bodyparts / coords, "
                      "first column the frame index", SOURCE, fps, t, angles, read))
    out.append(_truth("dlc_single.h5", "pandas HDF (PyTables 'table'), key "
                      "'df_with_missing', columns MultiIndex scorer / bodyparts / coords",
                      SOURCE, fps, t, angles, read))
    # multi-animal: two individuals (the second spurious) and the pivot as unique bodypart
    frames, table, t, angles = tracked("dlc_multi", fps)
    rng = rng_for("dlc_multi individuals")
    df = multi_frame(table, len(frames), ["ind1", "ind2"], rng)
    df.to_csv(folder / "dlc_multi.csv")
    if h5:
        df.to_hdf(folder / "dlc_multi_el.h5", key="tracks", format="table", mode="w")
    read = {"fps": fps, "points": POINTS, "individual": "ind1"}
    out.append(_truth("dlc_multi.csv", "CSV, header rows scorer / individuals / bodyparts / "
                      "coords; individuals ind1, ind2 and 'single' (unique bodypart axle)",
                      SOURCE_STITCH, fps, t, angles, read, individuals=["ind1", "ind2"],
                      version="2.2+ (multi-animal)"))
    out.append(_truth("dlc_multi_el.h5", "pandas HDF (PyTables 'table'), key 'tracks' "
                      "(stitched tracklets, '..._el.h5'), multi-animal columns",
                      SOURCE_STITCH, fps, t, angles, read, individuals=["ind1", "ind2"],
                      version="2.2+ (multi-animal)"))
    # multi-animal with a single individual (and 'single'): chosen by default
    frames, table, t, angles = tracked("dlc_multi_one", fps)
    df = multi_frame(table, len(frames), ["trebuchet"], rng)
    if h5:
        df.to_hdf(folder / "dlc_multi_one.h5", key="df_with_missing", format="table", mode="w")
    out.append(_truth("dlc_multi_one.h5", "pandas HDF, key 'df_with_missing', multi-animal "
                      "columns with one individual 'trebuchet' and 'single' (axle)", SOURCE,
                      fps, t, angles, {"fps": fps, "points": POINTS},
                      individuals=["trebuchet"], version="3.x (PyTorch engine)"))
    # a phone's slow-motion video: 60 images/s written at 240 fps, each image 4 times
    frames, table, t, angles = tracked("phone_upconverted_dlc", 240.0, repeat=4)
    df = single_frame(table, len(frames))
    df.to_csv(folder / "phone_upconverted_dlc.csv")
    out.append(_truth("phone_upconverted_dlc.csv", "DeepLabCut CSV of a 240 fps video "
                      "up-converted from 60 fps: every image 4 times, identical rows",
                      SOURCE, 240.0, t, angles, {"fps": 240.0, "points": POINTS},
                      true_fps=60.0, notes=["runs of 4 identical rows: keep the first of "
                                            "each run; the effective rate is 60 fps"]))
    return [t for t in out if h5 or not t.name.endswith(".h5")]

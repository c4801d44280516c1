"""SLEAP exports: the analysis HDF5 (File > Export Analysis HDF5) and the analysis CSV.

Layout (read from talmolab/sleap, ``sleap/info/write_tracking_h5.py``; the CSV adaptor
``sleap/io/format/csv.py`` calls the same ``main`` with ``all_frames=True, csv=True``):

* HDF5: SLEAP builds ``tracks`` (frames, nodes, 2, tracks), ``track_occupancy`` (tracks,
  frames), ``point_scores`` (frames, nodes, tracks), ``instance_scores`` and
  ``tracking_scores`` (frames, tracks) and writes every array **transposed** (for
  MATLAB): h5py therefore gives ``tracks`` as (tracks, 2, nodes, frames),
  ``track_occupancy`` as (frames, tracks), ``point_scores`` as (tracks, nodes, frames),
  ``instance_scores`` as (tracks, frames). ``track_names`` and ``node_names`` are byte
  strings; ``track_names`` is empty when the project has no tracks (then one unnamed
  track). Frames run from 0 (all frames) to the last labelled one; NaN where no instance.
  Also ``edge_names``, ``edge_inds``, ``labels_path``, ``video_path``, ``video_ind``,
  ``provenance`` (JSON). gzip level 9.
* CSV (pandas ``to_csv(index=False)``): ``track,frame_idx,instance.score,<node>.x,
  <node>.y,<node>.score,...``, one row per instance; frames without an instance are absent;
  ``track`` empty without tracks; NaN as empty cells.

Pixels, origin at the image's top-left corner, y down. No time: ``frame_idx / fps``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from .shot import CAMERA, ROLES, angles_of, filmed
from .truth import Truth, hdf5_writable, rng_for

SOURCE = "talmolab/sleap: sleap/info/write_tracking_h5.py (main, write_occupancy_file, " \
         "write_csv_file)"
NODES = {"pivot": "axle", "spigot": "arm_tip", "hinge": "hinge", "counterweight": "weight",
         "projectile": "stone"}
POINTS = dict(NODES)
CUT = 0.6


def predictions(name: str, fps: float, n_tracks: int):
    """(tracks (frames, nodes, 2, tracks), point_scores (frames, nodes, tracks),
    instance_scores (frames, tracks), occupancy (tracks, frames)) in SLEAP's own in-memory
    order, and the truth of track 0 (the engine). Track 1 (if any) is a spurious instance
    on every 7th frame. The stone after release is not predicted (NaN, score NaN); a few
    peaks are weak (score 0.1-0.4, gaps below the cut-off 0.6), the others 0.7-1.02 (SLEAP's
    confidence-map peaks can pass 1)."""
    rng = rng_for(name)
    shot = filmed(fps)
    n, k = len(shot.t), len(ROLES)
    tracks = np.full((n, k, 2, n_tracks), np.nan)
    scores = np.full((n, k, n_tracks), np.nan)
    inst = np.full((n, n_tracks), np.nan)
    occ = np.zeros((n_tracks, n), dtype=np.uint8)
    for j, role in enumerate(ROLES):
        x, y = CAMERA.to_pixels(*shot.points[role])
        tracks[:, j, 0, 0] = x + rng.normal(0, 0.3, n)
        tracks[:, j, 1, 0] = y + rng.normal(0, 0.3, n)
        scores[:, j, 0] = np.where(np.isfinite(x), rng.uniform(0.7, 1.02, n), np.nan)
    weak = rng.choice(n, size=n // 40, replace=False)
    for f in weak:
        j = int(rng.integers(1, k))
        if np.isfinite(scores[f, j, 0]):
            scores[f, j, 0] = rng.uniform(0.1, 0.4)
    inst[:, 0] = np.nanmean(scores[:, :, 0], axis=1) * k * rng.uniform(0.9, 1.0, n)
    occ[0] = 1
    if n_tracks > 1:
        extra = np.arange(3, n, 7)
        tracks[extra, :, 0, 1] = rng.uniform(0, 1920, (len(extra), k))
        tracks[extra, :, 1, 1] = rng.uniform(0, 1080, (len(extra), k))
        scores[extra, :, 1] = rng.uniform(0.3, 0.9, (len(extra), k))
        inst[extra, 1] = scores[extra, :, 1].sum(axis=1)
        occ[1, extra] = 1
    good = scores[:, :, 0] >= CUT
    points = {role: (np.where(good[:, j], tracks[:, j, 0, 0], np.nan),
                     np.where(good[:, j], tracks[:, j, 1, 0], np.nan))
              for j, role in enumerate(ROLES)}
    angles = angles_of(points, y_up=False, reference=shot.angles)
    return tracks, scores, inst, occ, shot.t, angles


def write_h5(path: Path, tracks, scores, inst, occ, track_names: list[str]) -> None:
    """The analysis HDF5 as SLEAP writes it: every array transposed, gzip 9."""
    import h5py

    nodes = [np.bytes_(NODES[r]) for r in ROLES]
    edges = [(nodes[0], nodes[1]), (nodes[0], nodes[2]), (nodes[2], nodes[3]),
             (nodes[1], nodes[4])]
    arrays = {"tracks": tracks, "track_occupancy": occ, "point_scores": scores,
              "instance_scores": inst, "tracking_scores": np.where(np.isfinite(inst), 0.0,
                                                                   np.nan)}
    with h5py.File(path, "w") as f:
        f.create_dataset("track_names", data=[np.bytes_(t) for t in track_names])
        f.create_dataset("node_names", data=nodes)
        f.create_dataset("edge_names", data=edges)
        f.create_dataset("edge_inds", data=[(0, 1), (0, 2), (2, 3), (1, 4)])
        for key, val in arrays.items():
            f.create_dataset(key, data=np.transpose(val), compression="gzip",
                             compression_opts=9)
        f.create_dataset("labels_path", data="trebuchet.slp")
        f.create_dataset("video_path", data="shot_120fps.mp4")
        f.create_dataset("video_ind", data=0)
        f.create_dataset("provenance", data=json.dumps({"sleap_version": "1.4.1"}))


def write_csv(path: Path, tracks, scores, inst, occ, track_names: list[str]) -> None:
    """The analysis CSV: one row per instance, frames without one absent."""
    rows = []
    occupied = np.transpose(occ).astype(bool)
    for f in np.argwhere(occupied.any(axis=1)).flatten():
        for i in range(tracks.shape[-1]):
            pts = tracks[f][..., i]
            if np.isnan(pts).all():
                continue
            row = {"track": track_names[i] if track_names else None, "frame_idx": f,
                   "instance.score": inst[f][i]}
            for j, role in enumerate(ROLES):
                row[f"{NODES[role]}.x"] = pts[j, 0]
                row[f"{NODES[role]}.y"] = pts[j, 1]
                row[f"{NODES[role]}.score"] = scores[f][j, i]
            rows.append(row)
    pd.DataFrame(rows).to_csv(path, index=False)


def write(folder: Path) -> list[Truth]:
    out = []
    fps = 120.0
    names = ["track_0", "track_1"]
    tracks, scores, inst, occ, t, angles = predictions("sleap_two_tracks", fps, 2)
    h5 = hdf5_writable()
    if h5:
        write_h5(folder / "sleap_two_tracks.analysis.h5", tracks, scores, inst, occ, names)
    write_csv(folder / "sleap_two_tracks.analysis.csv", tracks, scores, inst, occ, names)
    read = {"fps": fps, "points": POINTS, "individual": "track_0", "min_likelihood": CUT}
    common = dict(tool="sleap", version="1.2-1.4 (analysis export)", source=SOURCE, fps=fps,
                  time_code="frames (frame_idx)", time_stated=False, length_unit="px (y down)",
                  min_likelihood=CUT)
    out.append(Truth(name="sleap_two_tracks.analysis.h5", layout="analysis HDF5, datasets "
                     "transposed (h5py: tracks (tracks, 2, nodes, frames)); tracks track_0 "
                     "(engine), track_1 (spurious)", t=t, angles=angles, read=read,
                     individuals=names, **common))
    out.append(Truth(name="sleap_two_tracks.analysis.csv", layout="analysis CSV: track, "
                     "frame_idx, instance.score, <node>.x/.y/.score; frames without an "
                     "instance absent", t=t, angles=angles, read=read, individuals=names,
                     **common))
    tracks, scores, inst, occ, t, angles = predictions("sleap_untracked", fps, 1)
    if h5:
        write_h5(folder / "sleap_untracked.analysis.h5", tracks, scores, inst, occ, [])
    write_csv(folder / "sleap_untracked.analysis.csv", tracks, scores, inst, occ, [])
    read = {"fps": fps, "points": POINTS, "min_likelihood": CUT}
    out.append(Truth(name="sleap_untracked.analysis.h5", layout="analysis HDF5 of a project "
                     "without tracks: track_names empty, one track column", t=t,
                     angles=angles, read=read, individuals=[], **common))
    out.append(Truth(name="sleap_untracked.analysis.csv", layout="analysis CSV without "
                     "tracks: the track column empty", t=t, angles=angles, read=read,
                     individuals=[], **common))
    return [t for t in out if h5 or not t.name.endswith(".h5")]

"""What each written export holds: the values a correct reader gives back, and how it was made."""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field

import numpy as np

from .shot import ANGLES, BEAM_ROWS


@dataclass
class Truth:
    """One export file and its truth.

    ``t`` (s) and ``angles`` (rad, the paper's branch, NaN where the file gives no angle)
    are one entry per image that a correct reader keeps, in order: rows that give no
    angle at all are left out (``read_log`` drops them), and so are repeated images of an
    up-converted video. They are computed from the numbers *as written* (after the
    tool's rounding and the tracking noise), so a reader must match them to rounding.
    """

    name: str                      # file name
    tool: str                      # "deeplabcut", "sleap", "anipose", "kinovea", "tracker", ...
    version: str                   # tool versions that write this layout
    layout: str                    # one line: what the file looks like
    source: str                    # "<owner>/<repo>: <path>" the layout was read from
    fps: float                     # frame rate of the distinct images (1/s)
    t: np.ndarray                  # s: the log's own time of each kept image
    angles: dict[str, np.ndarray]  # rad
    time_code: str                 # what the time column holds: "s", "ms", "us", "frames", ...
    time_stated: bool              # whether the header says the time unit
    length_unit: str | None = None  # for point files: "px (y down)", "m (y up)", "mm (3-D)"
    angle_unit: str | None = None  # for angle files: "deg" or "rad"
    angle_stated: bool = True      # whether the header says the angle unit
    read: dict = field(default_factory=dict)   # what a user must give: fps, points, columns
    individuals: list[str] | None = None       # DeepLabCut individuals / SLEAP tracks
    t_tol: float = 1e-6            # s
    angle_tol: float = 1e-6        # rad
    min_likelihood: float | None = None        # the cut-off the truth's gaps assume
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        present = np.zeros(len(self.t), dtype=bool)
        for a in ANGLES:
            present |= np.isfinite(self.angles[a])
        self.t = np.asarray(self.t, dtype=float)[present]
        self.angles = {a: np.asarray(self.angles[a], dtype=float)[present]
                       for a in (*ANGLES, BEAM_ROWS) if a in self.angles}


def hdf5_writable() -> bool:
    """Whether h5py and PyTables (pandas' HDF5 engine) are installed to write .h5 files."""
    from importlib.util import find_spec

    return find_spec("h5py") is not None and find_spec("tables") is not None


def rng_for(name: str) -> np.random.Generator:
    """A random stream fixed by the file's name (the same bytes on every run)."""
    return np.random.default_rng([20261125, zlib.crc32(name.encode())])

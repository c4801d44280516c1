"""How large a log can be: what a filmed shot can mean, with a wide margin.

A shot lasts seconds; filmed at up to 100,000 fps (:data:`.timebase.FRAME_RATE_RANGE`) for a
few seconds, or at 1000 fps for a quarter of an hour, it is at most a million frames. Text
beyond :data:`MAX_TEXT_BYTES` (a million rows of 60 characters) and HDF5 datasets beyond
:data:`MAX_DATASET_BYTES` are no log of a shot: reading them would only fill the memory.
docs/logs.md states these bounds.
"""

from __future__ import annotations

#: Frames (rows) a log may hold.
MAX_ROWS = 1_000_000
#: Bytes of a text log (CSV, Tracker, Kinovea, DeepLabCut and SLEAP CSV, anipose).
MAX_TEXT_BYTES = 64 << 20
#: Bytes of an HDF5 log file (DeepLabCut .h5, SLEAP analysis .h5).
MAX_HDF5_BYTES = 256 << 20
#: Bytes one HDF5 dataset may hold once read (a declared shape can claim far more than the
#: file stores).
MAX_DATASET_BYTES = 256 << 20
#: Characters of one cell (the csv module's own field limit): no number or name is longer.
MAX_CELL_CHARS = 131_072
#: Largest coordinate of a tracked point, in any unit (px, mm, m): no image or survey of an
#: engine reaches it.
MAX_COORDINATE = 1e9

"""The choices of the ingest path as the command line names them: force form, trough, image
calibration, the compare report's release rule and alignment.

Light on purpose (no numpy): ``trebuchet``'s parser is built from these (``forces``,
``compare``) without importing the reconstruction, so that ``trebuchet --help`` and every usage
error answer at once. :mod:`trebuchet.ingest.reconstruct` and :mod:`trebuchet.ingest.compare`
take them from here.
"""

from __future__ import annotations

__all__ = ["FORMS", "TROUGH", "IMAGE_CALIBRATIONS", "METHODS", "RELEASE_MODES", "ALIGN_MODES",
           "CHANCE_RUNS"]

#: Force formulas: projected on the arms (default) or the paper's direct form.
FORMS = ("projected", "direct")
#: Phase-I sling angle: from the trough constraint (default) or as measured.
TROUGH = ("constraint", "measured")
#: How a point log's angles are found: "engine" (self-calibration) or "none" (read_log's).
IMAGE_CALIBRATIONS = ("none", "engine")
#: Where the loads come from: the engine fitted to the log (default, where a scene is given and
#: the fit passes its residual check; else the smoother's) or the smoothed angles.
METHODS = ("fit", "smooth")
#: The model's release in ``compare`` (``CompareOptions.release``).
RELEASE_MODES = ("auto", "log", "scene")
#: The model's start in ``compare`` (``CompareOptions.align``).
ALIGN_MODES = ("fit", "trigger")
#: Simulated logs that estimate what chance allows in ``compare`` (0: no verdict).
CHANCE_RUNS = 12

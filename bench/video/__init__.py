"""A realistic video bench: simulated shots filmed through a posed, distorting camera, tracked
by template matching, exported as DeepLabCut and Kinovea files.

Modules: :mod:`.camera` (pinhole camera, pose, radial distortion), :mod:`.truth` (frame
times, truth table, point positions during each exposure), :mod:`.render` (frames: markers,
moving engine, frame members, motion and lens blur, noise), :mod:`.track` (template
tracker), :mod:`.export` (DeepLabCut and Kinovea writers), :mod:`.shot` (one shot end to
end: :func:`tracked_shot`), :mod:`.metrics` (scores against the truth).
"""

from .camera import Camera, camera_framing, project, undistort_pixels
from .metrics import angle_errors, shot_scores
from .shot import Pose, TrackedShot, tracked_shot
from .track import TrackerSettings

__all__ = ["Camera", "camera_framing", "project", "undistort_pixels", "Pose", "TrackedShot",
           "tracked_shot", "TrackerSettings", "angle_errors", "shot_scores"]

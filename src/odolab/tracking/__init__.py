"""Ground truth from a camera: ArUco markers on the floor and on the robot, or one long-exposure
photo of a flashing LED (OpenCV).

- :mod:`odolab.tracking.camera`: ``CameraModel`` (CAMERA.toml), ``FloorMarker`` (FLOOR.csv).
- :mod:`odolab.tracking.markers`: dictionaries, printable markers (PNG, PDF).
- :mod:`odolab.tracking.tracker`: ``track_video`` -> ``TrackResult`` (t, x, y, heading, quality).
- :mod:`odolab.tracking.charuco`: camera intrinsics from a ChArUco board video.
- :mod:`odolab.tracking.render`: synthetic videos of a known trajectory (for tests).
- :mod:`odolab.tracking.photo`: ``track_photo`` -> ``PhotoTrack``: a long-exposure photo of a
  flashing LED read as a timed path (floor homography, dashes, order, time on the encoder log).
- :mod:`odolab.tracking.photo_render`: synthetic long-exposure photos of a known trajectory.

OpenCV is imported inside the functions, so importing this package stays cheap. See
docs/ground-truth.md.
"""

from __future__ import annotations

# The package's names are camera.py's (listed there once).
from odolab.tracking.camera import *  # noqa: F403
from odolab.tracking.camera import __all__ as __all__

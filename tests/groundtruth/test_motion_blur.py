"""Tracking a filmed run with motion blur (issue 30): 1/30 s exposure at 0.6 m/s. The grey-level
corner refinement (``--corners subpix``) misses the <= 1 degree heading of docs/ground-truth.md
on single frames; the edge-line refinements (``contour``, ``apriltag``) keep it."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from tests.worded import raises_worded

from odolab.core.errors import OdolabError
from odolab.core.trajectory import Trajectory
from odolab.tracking import CameraModel, FloorMarker
from odolab.tracking.render import look_at, render_video
from odolab.tracking.tracker import TrackOptions, track_video

CAMERA = CameraModel(900.0, 900.0, 640.0, 360.0, 1280, 720)
FLOOR = [
    FloorMarker(i, x, y, yaw, 0.2)
    for i, (x, y, yaw) in enumerate(
        [(-2.0, -1.0, 0.0), (2.0, -1.0, 0.5), (2.0, 1.5, 1.0), (-2.0, 1.5, -0.3), (0.0, -1.3, 0.0)]
    )
]


def _straight() -> Trajectory:
    """0.8 s straight at 0.6 m/s, heading 0.2 rad."""
    t = np.linspace(0.0, 0.8, 401)
    h = np.full_like(t, 0.2)
    return Trajectory.from_xyh(t, -0.9 + 0.6 * t * math.cos(0.2), -0.4 + 0.6 * t * math.sin(0.2), h)


@pytest.fixture(scope="module")
def blurred(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("blur") / "run.avi"
    scene = look_at(CAMERA, (0.0, -3.0, 3.2), (0.0, 0.3, 0.0))
    return render_video(
        out, _straight(), FLOOR, scene, robot_marker=10, marker_size=0.25, marker_height=0.3,
        exposure=1 / 30, exposure_steps=5,
    )  # fmt: skip


def _heading_errors(video: Path, corners: str) -> np.ndarray:
    r = track_video(video, FLOOR, CAMERA, TrackOptions(10, 0.25, 0.3, corners=corners))
    assert r.skipped == 0 and r.frames == 25
    return np.degrees(np.abs(r.heading - 0.2))


def test_edge_refinement_keeps_the_heading_under_blur(blurred: Path) -> None:
    subpix = _heading_errors(blurred, "subpix")
    # measured: max 1.83 deg, 4 of 25 frames over 1 deg (the saddle moves with the smear)
    assert subpix.max() > 1.0
    for corners in ("contour", "apriltag"):
        err = _heading_errors(blurred, corners)
        assert err.max() < 0.6, corners  # measured 0.25 (contour), 0.39 (apriltag)


def test_refinement_and_exposure_are_checked() -> None:
    with raises_worded(OdolabError, match="--corners is 'edges'; expected one of subpix"):
        TrackOptions(10, 0.25, 0.3, corners="edges")
    scene = look_at(CAMERA, (0.0, -3.0, 3.2), (0.0, 0.3, 0.0))
    with pytest.raises(OdolabError, match="expected exposure >= 0 s"):
        render_video("x.avi", _straight(), FLOOR, scene, robot_marker=10, marker_size=0.25,
                     marker_height=0.3, exposure=-1.0)  # fmt: skip

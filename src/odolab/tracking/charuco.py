"""Camera intrinsics from a video of a ChArUco board (OpenCV's CharucoDetector + calibrateCamera).

Film the printed board (``odolab markers --board``) from many angles and distances, filling the
picture's corners too. Every ``step``-th frame with at least ``min_corners`` chessboard corners
is used, at most ``max_views`` of them spread over the video.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from odolab.core.errors import opt
from odolab.tracking.camera import CameraModel, TrackingError
from odolab.tracking.markers import get_dictionary

__all__ = ["BoardSpec", "CameraCalibration", "board_image", "calibrate_camera_video"]


@dataclass(frozen=True)
class BoardSpec:
    """A ChArUco board: ``squares_x`` by ``squares_y`` chessboard squares of ``square`` m, with
    markers of ``marker`` m (smaller than the square) from ``dictionary``."""

    squares_x: int = 5
    squares_y: int = 7
    square: float = 0.04
    marker: float = 0.03
    dictionary: str = "DICT_4X4_50"

    def __post_init__(self) -> None:
        if self.squares_x < 3 or self.squares_y < 3:
            raise TrackingError(
                f"board of {self.squares_x}x{self.squares_y} squares; expected at least 3x3"
            )
        if not (0 < self.marker < self.square):
            raise TrackingError(
                f"board marker {self.marker!r} m and square {self.square!r} m; expected "
                "0 < marker < square"
            )

    def board(self) -> Any:
        """The OpenCV CharucoBoard (typed loosely: OpenCV's stubs give ``matchImagePoints``
        a list of corner arrays where the detector returns one array)."""
        import cv2

        return cv2.aruco.CharucoBoard(
            (self.squares_x, self.squares_y), self.square, self.marker,
            get_dictionary(self.dictionary),
        )  # fmt: skip


def board_image(spec: BoardSpec, dpi: int = 300) -> NDArray[np.uint8]:
    """The board to print at ``dpi`` (grey image, with a white margin of one square)."""
    px_per_m = dpi / 0.0254
    w = round(spec.squares_x * spec.square * px_per_m)
    h = round(spec.squares_y * spec.square * px_per_m)
    margin = round(spec.square * px_per_m)
    img = spec.board().generateImage((w + 2 * margin, h + 2 * margin), marginSize=margin)
    return np.asarray(img, dtype=np.uint8)


@dataclass(frozen=True)
class CameraCalibration:
    """The intrinsics, the RMS reprojection error (px) and how many views were used."""

    camera: CameraModel
    rms: float
    views: int
    frames: int

    def provenance(self) -> dict[str, object]:
        """A ``[provenance]`` table for CAMERA.toml."""
        return {
            "method": "ChArUco board video (odolab camera calibrate)",
            "rms_reprojection_px": self.rms,
            "views": self.views,
            "frames": self.frames,
        }


def calibrate_camera_video(
    video: str | Path,
    spec: BoardSpec,
    *,
    step: int = 5,
    min_corners: int = 8,
    max_views: int = 60,
) -> CameraCalibration:
    """Calibrate from a board video (see the module).

    Raises:
        TrackingError: the video is missing or unreadable, the step is below 1, the board is seen in
            fewer than 4 frames, or the calibration fails.
    """
    import cv2

    p = Path(video)
    if not p.is_file():
        raise TrackingError(f"{p}: no such video file")
    if step < 1:
        raise TrackingError(
            f"{opt('step')} is {step}; expected a whole number >= 1",
            option="step",
            value=step,
            allowed="a whole number >= 1",
        )
    cap = cv2.VideoCapture(str(p))
    if not cap.isOpened():
        raise TrackingError(f"{p}: not a video OpenCV can read")
    board = spec.board()
    detector = cv2.aruco.CharucoDetector(board)
    obj_pts: list[NDArray[np.float32]] = []
    img_pts: list[NDArray[np.float32]] = []
    size: tuple[int, int] | None = None
    frames = 0
    try:
        while True:
            ok, frame = cap.read()
            if not ok:
                break
            frames += 1
            if (frames - 1) % step:
                continue
            grey = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if frame.ndim == 3 else frame
            size = (grey.shape[1], grey.shape[0])
            corners, ids, _, _ = detector.detectBoard(grey)
            if ids is None or len(ids) < min_corners:
                continue
            obj, img = board.matchImagePoints(corners, ids)
            if obj is None or len(obj) < min_corners:
                continue
            obj_pts.append(obj.astype(np.float32))
            img_pts.append(img.astype(np.float32))
    finally:
        cap.release()
    if size is None:
        raise TrackingError(f"{p}: no frames could be read")
    if len(obj_pts) < 4:
        raise TrackingError(
            f"{p}: the board ({spec.squares_x}x{spec.squares_y}, {spec.dictionary}) was found in "
            f"{len(obj_pts)} of {frames} frames; expected at least 4 views (check {opt('board')})"
        )
    if len(obj_pts) > max_views:
        pick = np.linspace(0, len(obj_pts) - 1, max_views).round().astype(int)
        obj_pts = [obj_pts[i] for i in pick]
        img_pts = [img_pts[i] for i in pick]
    rms, k, dist, _, _ = cv2.calibrateCamera(obj_pts, img_pts, size, None, None)
    d = np.asarray(dist, dtype=np.float64).reshape(-1)
    d = np.concatenate((d, np.zeros(max(0, 5 - d.size))))
    if not (math.isfinite(rms) and k[0, 0] > 0):
        raise TrackingError(f"{p}: the calibration failed (rms {rms}); film the board more")
    cam = CameraModel(
        float(k[0, 0]), float(k[1, 1]), float(k[0, 2]), float(k[1, 2]), size[0], size[1],
        float(d[0]), float(d[1]), float(d[2]), float(d[3]), float(d[4]),
    )  # fmt: skip
    return CameraCalibration(cam, float(rms), len(obj_pts), frames)

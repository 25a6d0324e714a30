"""Synthetic videos of a robot filmed from above: for testing the tracker against a known truth.

A pinhole camera (no distortion) at ``position`` (m, floor frame, z up) looks at ``target``.
Each frame draws a textured floor, the floor markers, the robot's top plate and its marker at
height H (the robot's true pose at the frame's time, interpolated from a trajectory), at twice
the resolution, then shrinks it (anti-aliasing), blurs it (Gaussian, ``blur`` px), adds noise
(``noise`` grey levels) and writes it through a JPEG-based codec (MJPG AVI) at ``quality``.

Motion blur: with ``exposure`` (s) > 0 each frame is the mean of ``exposure_steps`` drawings of
the robot at evenly spaced times across the exposure, centred on the frame's time (the frame's
time is the middle of its exposure), as a shutter open for that long records it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from odolab.core.arrays import FloatArray
from odolab.core.trajectory import Trajectory
from odolab.tracking.camera import CameraModel, FloorMarker, TrackingError
from odolab.tracking.markers import marker_image

if TYPE_CHECKING:
    import cv2

__all__ = ["SceneCamera", "look_at", "render_video"]


@dataclass(frozen=True)
class SceneCamera:
    """Intrinsics and the floor-to-camera transform ``X_cam = R (X - position)``."""

    model: CameraModel
    rotation: FloatArray
    position: FloatArray

    def project(self, pts: FloatArray) -> FloatArray:
        """Floor-frame points (k, 3) -> pixels (k, 2)."""
        cam = (pts - self.position) @ self.rotation.T
        uv = cam[:, :2] / cam[:, 2:3]
        return np.column_stack(
            (self.model.fx * uv[:, 0] + self.model.cx, self.model.fy * uv[:, 1] + self.model.cy)
        )


def look_at(model: CameraModel, position: Sequence[float], target: Sequence[float]) -> SceneCamera:
    """A camera at ``position`` looking at ``target`` (floor frame), image x to the right."""
    c, g = np.asarray(position, dtype=np.float64), np.asarray(target, dtype=np.float64)
    z = g - c
    z /= np.linalg.norm(z)
    up = np.array([0.0, 1.0, 0.0]) if abs(z[2]) > 0.99 else np.array([0.0, 0.0, 1.0])
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return SceneCamera(model, np.vstack((x, y, z)), c)


def _placed(
    size: float, px: int, total: int, x: float, y: float, yaw: float, z: float
) -> FloatArray:
    """Marker-image pixel corners -> floor points of a marker image ``total`` px wide whose
    black square (``px`` wide) has side ``size`` m, centred at (x, y, z) with yaw."""
    half = size / 2.0 * total / px
    local = np.array([[-half, half], [half, half], [half, -half], [-half, -half]])
    cs, sn = math.cos(yaw), math.sin(yaw)
    xy = local @ np.array([[cs, sn], [-sn, cs]]) + np.array([x, y])
    return np.column_stack((xy, np.full(4, z)))


def _paste(canvas: NDArray[np.uint8], src: NDArray[np.uint8], dst: FloatArray) -> None:
    """Warp ``src`` so its corners land on ``dst`` (4, 2) in ``canvas`` (in place)."""
    import cv2

    h, w = src.shape[:2]
    x0 = max(math.floor(dst[:, 0].min()) - 2, 0)
    y0 = max(math.floor(dst[:, 1].min()) - 2, 0)
    x1 = min(math.ceil(dst[:, 0].max()) + 2, canvas.shape[1])
    y1 = min(math.ceil(dst[:, 1].max()) + 2, canvas.shape[0])
    if x1 <= x0 or y1 <= y0:
        return
    srcq = np.array([[0, 0], [w, 0], [w, h], [0, h]], dtype=np.float32)
    m = cv2.getPerspectiveTransform(srcq, (dst - [x0, y0]).astype(np.float32))
    size = (x1 - x0, y1 - y0)
    warped = cv2.warpPerspective(src, m, size, flags=cv2.INTER_LINEAR)
    mask = cv2.warpPerspective(np.full((h, w), 255, np.uint8), m, size, flags=cv2.INTER_LINEAR)
    roi = canvas[y0:y1, x0:x1]
    a = mask.astype(np.float32) / 255.0
    roi[:] = (roi * (1.0 - a) + warped * a).astype(np.uint8)


def _writer(p: Path, fps: float, model: CameraModel, quality: int) -> cv2.VideoWriter:
    """An open MJPG writer of ``model``-sized frames at ``p``."""
    import cv2

    writer = cv2.VideoWriter(
        str(p), cv2.VideoWriter.fourcc(*"MJPG"), fps, (model.width, model.height)
    )
    if not writer.isOpened():
        raise TrackingError(f"{p}: OpenCV cannot write an MJPG video here")
    writer.set(cv2.VIDEOWRITER_PROP_QUALITY, float(quality))
    return writer


def _floor_image(
    scene: SceneCamera,
    floor: Sequence[FloorMarker],
    rng: np.random.Generator,
    ss: int,
    px: int,
    dictionary: str,
) -> tuple[SceneCamera, NDArray[np.uint8]]:
    """The camera supersampled ``ss`` times, and its view of the textured floor with its markers."""
    import cv2

    model = scene.model
    big = SceneCamera(
        CameraModel(model.fx * ss, model.fy * ss, model.cx * ss + (ss - 1) / 2,
                    model.cy * ss + (ss - 1) / 2, model.width * ss, model.height * ss),
        scene.rotation, scene.position,
    )  # fmt: skip
    coarse = rng.normal(0.0, 1.0, (model.height * ss // 16 + 1, model.width * ss // 16 + 1))
    tex = cv2.resize(coarse, (model.width * ss, model.height * ss), interpolation=cv2.INTER_CUBIC)
    floor_img = np.clip(150 + 18 * tex, 0, 255).astype(np.uint8)
    images = {m.id: marker_image(m.id, px, dictionary) for m in floor}
    base = floor_img.copy()
    for m in floor:
        img = images[m.id]
        _paste(base, img, big.project(_placed(m.size, px, img.shape[0], m.x, m.y, m.yaw, 0.0)))
    return big, base


def _exposed(
    drawn: Callable[[float, bool], NDArray[np.uint8]],
    t: float,
    shown: bool,
    exposure: float,
    steps: int,
    shape: tuple[int, ...],
) -> NDArray[np.uint8]:
    """The frame at ``t``, or the mean of ``steps`` frames over the ``exposure`` around it."""
    if steps == 1:
        return drawn(t, shown)
    acc = np.zeros(shape, np.float32)
    for j in range(steps):
        acc += drawn(t + exposure * (j / (steps - 1) - 0.5), shown)
    return np.asarray(np.clip(acc / steps + 0.5, 0, 255).astype(np.uint8), dtype=np.uint8)


def _as_filmed(
    frame: NDArray[np.uint8],
    model: CameraModel,
    blur: float,
    noise: float,
    grain: NDArray[np.int16],
) -> NDArray[np.uint8]:
    """The supersampled frame at the camera's size, blurred, with grey-level noise."""
    import cv2

    small = cv2.resize(frame, (model.width, model.height), interpolation=cv2.INTER_AREA)
    if blur > 0:
        small = cv2.GaussianBlur(small, (0, 0), blur)
    # Gaussian grey-level noise, rounded to integers (std sqrt(noise^2 + 1/12)), added
    # with saturation; OpenCV's generator (seeded below) is 3x faster than numpy's here
    cv2.randn(grain, np.zeros(1), np.full(1, float(noise)))
    return np.asarray(cv2.add(small, grain, dtype=cv2.CV_8U), dtype=np.uint8)


# long: 31 lines of signature and docstring (a renderer with many scene settings); the body is one
# frame loop
def render_video(
    path: str | Path,
    truth: Trajectory,
    floor: Sequence[FloorMarker],
    scene: SceneCamera,
    *,
    robot_marker: int,
    marker_size: float,
    marker_height: float,
    marker_offset: tuple[float, float] = (0.0, 0.0),
    dictionary: str = "DICT_4X4_50",
    fps: float = 30.0,
    duration: float | None = None,
    blur: float = 0.7,
    noise: float = 2.0,
    quality: int = 90,
    seed: int = 0,
    hidden: Sequence[tuple[float, float]] = (),
    progress: Callable[[int, int], None] | None = None,
    exposure: float = 0.0,
    exposure_steps: int = 9,
) -> Path:
    """Write an MJPG AVI of the robot following ``truth`` (frame k at time ``k / fps``).

    ``hidden``: time spans ``(start, end)`` (s, the truth's clock) in which the robot's marker is
    not drawn (covered: a person walking past, the robot under a table); its plate still is.
    ``exposure``: motion blur (see the module).

    Raises:
        TrackingError: the exposure is negative or has no step, or the video cannot be written.
    """
    import cv2

    if not (exposure >= 0.0 and math.isfinite(exposure)) or exposure_steps < 1:
        raise TrackingError(
            f"exposure {exposure!r} s in {exposure_steps!r} steps; expected exposure >= 0 s "
            "and at least one step"
        )

    model = scene.model
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    writer = _writer(p, fps, model, quality)
    rng = np.random.default_rng(seed)
    cv2.setRNGSeed(seed)
    grain = np.empty((model.height, model.width), np.int16)
    ss = 2  # supersampling
    px = 96
    big, base = _floor_image(scene, floor, rng, ss, px, dictionary)
    robot_img = marker_image(robot_marker, px, dictionary)
    plate = np.full((8, 8), 70, np.uint8)
    end = truth.t[-1] if duration is None else min(truth.t[0] + duration, truth.t[-1])
    n = math.floor((end - truth.t[0]) * fps + 1e-9) + 1
    dx, dy = marker_offset
    steps = exposure_steps if exposure > 0 else 1

    def drawn(t: float, shown: bool) -> NDArray[np.uint8]:
        """The full-resolution frame with the robot at its pose at time ``t``."""
        x = float(np.interp(t, truth.t, truth.x))
        y = float(np.interp(t, truth.t, truth.y))
        h = float(np.interp(t, truth.t, truth.heading))
        frame = base.copy()
        _paste(frame, plate, big.project(_placed(0.5, 8, 8, x, y, h, marker_height)))
        if shown:
            cs, sn = math.cos(h), math.sin(h)
            mx, my = x + cs * dx - sn * dy, y + sn * dx + cs * dy
            corners = _placed(marker_size, px, robot_img.shape[0], mx, my, h, marker_height)
            _paste(frame, robot_img, big.project(corners))
        return np.asarray(frame, dtype=np.uint8)

    try:
        for k in range(n):
            t = truth.t[0] + k / fps
            shown = not any(a <= t <= b for a, b in hidden)
            frame = _exposed(drawn, t, shown, exposure, steps, base.shape)
            out = _as_filmed(frame, model, blur, noise, grain)
            writer.write(cv2.cvtColor(out, cv2.COLOR_GRAY2BGR))
            if progress is not None:
                progress(k + 1, n)
    finally:
        writer.release()
    return p

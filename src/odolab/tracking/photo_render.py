"""Synthetic long-exposure photos of a flashing LED on a robot: for testing ``track-photo``.

The physics, as a camera on a tripod records it: a pinhole camera (:class:`SceneCamera`, no
distortion) looks down at the floor; the shutter is open from ``t_open`` to ``t_close``; the LED
(a point on the floor plane below the robot's centre, or ``led_height`` above it) is ON while
``((t - phase) * led_hz) mod 1 < duty``. Its light is summed over each ON interval: the LED's
projected position is sampled every ``dt`` seconds and each sample adds ``power * dt`` to the
pixels around it (bilinear), so a slow robot draws a brighter dash than a fast one. The sum is
blurred (a Gaussian point-spread function of ``blur`` px: focus, the lens, the LED's size), put
on a dim floor with tile joints every ``tile`` metres, clipped at 255 (saturation), given
Gaussian sensor noise (``noise`` grey levels) and written as PNG, or JPEG at ``jpeg_quality``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from odolab.core.arrays import FloatArray
from odolab.core.trajectory import Trajectory
from odolab.tracking.camera import TrackingError
from odolab.tracking.render import SceneCamera

__all__ = ["led_on", "render_photo", "tilted_camera"]


def tilted_camera(
    model: object, height: float, tilt_deg: float, target: Sequence[float] = (0.0, 0.0)
) -> SceneCamera:
    """A camera ``height`` m above the floor whose axis is ``tilt_deg`` from straight down,
    looking at ``target`` on the floor (from the -y side).

    Raises:
        TrackingError: no camera model is given.
    """
    from odolab.tracking.camera import CameraModel
    from odolab.tracking.render import look_at

    if not isinstance(model, CameraModel):
        raise TrackingError("tilted_camera needs a CameraModel")
    back = height * math.tan(math.radians(tilt_deg))
    tx, ty = target
    return look_at(model, (tx, ty - back, height), (tx, ty, 0.0))


def led_on(t: FloatArray, led_hz: float, duty: float, phase: float) -> NDArray[np.bool_]:
    """Whether the LED is ON at each time ``t`` (s)."""
    return np.asarray(np.mod((t - phase) * led_hz, 1.0) < duty)


def render_photo(
    path: str | Path,
    truth: Trajectory,
    scene: SceneCamera,
    *,
    led_hz: float = 2.0,
    duty: float = 0.5,
    phase: float = 0.0,
    t_open: float | None = None,
    t_close: float | None = None,
    power: float = 150000.0,
    blur: float = 1.5,
    noise: float = 2.0,
    jpeg_quality: int | None = None,
    tile: float = 0.5,
    led_height: float = 0.0,
    seed: int = 0,
    dt: float = 0.0005,
) -> Path:
    """Write the photo of the LED following ``truth`` (see the module); returns the path.
    ``power``: grey levels per second of light on one pixel (before the blur spreads it).

    Raises:
        TrackingError: the exposure is not positive, or the photo cannot be encoded.
    """
    import cv2

    from odolab.core.writing import write_bytes_file

    model = scene.model
    h, w = model.height, model.width
    t0 = truth.t[0] if t_open is None else t_open
    t1 = truth.t[-1] if t_close is None else t_close
    if not (t1 > t0):
        raise TrackingError(f"shutter open {t0!r} s to {t1!r} s; expected a positive exposure")
    ts = np.arange(t0, t1, dt)
    ts = ts[led_on(ts, led_hz, duty, phase)]
    x = np.interp(ts, truth.t, truth.x)
    y = np.interp(ts, truth.t, truth.y)
    uv = scene.project(np.column_stack((x, y, np.full(len(x), led_height))))
    acc = np.zeros((h + 2, w + 2), np.float64)
    u0 = np.floor(uv[:, 0]).astype(np.int64)
    v0 = np.floor(uv[:, 1]).astype(np.int64)
    fu, fv = uv[:, 0] - u0, uv[:, 1] - v0
    keep = (u0 >= 0) & (v0 >= 0) & (u0 < w) & (v0 < h)
    for du, dv, wt in ((0, 0, (1 - fu) * (1 - fv)), (1, 0, fu * (1 - fv)),
                       (0, 1, (1 - fu) * fv), (1, 1, fu * fv)):  # fmt: skip
        np.add.at(acc, (v0[keep] + dv, u0[keep] + du), wt[keep] * power * dt)
    light = np.asarray(acc[:h, :w], dtype=np.float32)
    if blur > 0:
        light = np.asarray(cv2.GaussianBlur(light, (0, 0), blur), dtype=np.float32)
    # a dim floor with tile joints, as a long exposure in a dark room shows it
    vv, uu = np.mgrid[0:h, 0:w].astype(np.float64)
    ray_u, ray_v = (uu - model.cx) / model.fx, (vv - model.cy) / model.fy
    dirs = np.stack((ray_u, ray_v, np.ones_like(uu)), axis=-1) @ scene.rotation
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = -scene.position[2] / dirs[..., 2]
    fx = scene.position[0] + lam * dirs[..., 0]
    fy = scene.position[1] + lam * dirs[..., 1]
    joint = (np.abs(np.mod(fx + tile / 2, tile) - tile / 2) < 0.006) | (
        np.abs(np.mod(fy + tile / 2, tile) - tile / 2) < 0.006
    )
    plain = np.where(lam > 0, np.where(joint, 40.0, 25.0), 5.0).astype(np.float32)
    floor = np.asarray(cv2.GaussianBlur(plain, (0, 0), 0.8), dtype=np.float32)
    rng = np.random.default_rng(seed)
    img = floor + light + rng.normal(0.0, noise, (h, w)).astype(np.float32)
    out = np.clip(np.round(img), 0, 255).astype(np.uint8)
    p = Path(path)
    if jpeg_quality is None:
        ok, data = cv2.imencode(".png", out)
    else:
        ok, data = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, int(jpeg_quality)])
    if not ok:
        raise TrackingError(f"{p}: OpenCV cannot encode the photo")
    return write_bytes_file(p, data.tobytes(), what="photo")

"""Track a robot's marker in a video of the floor: ground truth from a phone camera.

Frames are searched for ArUco markers (corners from lines fitted to the edges): the whole frame every
``full_every`` frames (30: once a second) and whenever the robot's marker was lost; in between
only a window around where the robot's marker was in the previous frame (the camera stands
still, so only the robot moves; this makes 720p tracking several times faster). Markers lying on the floor at
known places (FLOOR.csv) define the floor frame: the camera's pose in it is found by
``cv2.solvePnP`` on all floor-marker corners seen in all frames (the camera stands still; a
marker the robot hides in some frames counts where it is seen). The robot's marker lies flat
``H`` metres above the floor, so its corners are on the plane z = H, which the camera sees
through the homography ``G = [r1 r2 H r3 + t]`` (normalised coordinates): each undistorted
corner maps back to the plane exactly. A rigid square of the marker's side is fitted to the four
mapped corners (least squares: Procrustes with known scale); its centre and x axis give the
marker's pose, and ``--marker-offset DX DY`` (the marker's centre in the robot frame) the robot's:
``p_robot = p_marker - R(heading) (DX, DY)``. ``quality`` is the RMS distance (m) of the four
mapped corners from the fitted square: millimetres when all is well, more when the corners are
blurred, the marker is bent, or H is wrong.

The marker gives the heading modulo a whole turn; the ``heading`` column is made continuous by
taking, between two tracked frames, the change of the least size. That is right only if the
robot cannot have turned half a turn in between: across a gap (frames without the robot's
marker) of ``dt`` seconds with ``max_yaw_rate * dt >= pi`` the whole turns are unknown. The
tracker then starts a new heading **segment** (:attr:`TrackResult.segment`; :attr:`TrackResult.gaps`
says where), continuing with the least change as its best guess, and :func:`bridge_gaps` decides
the whole turns from another sensor's heading change across the gap (the encoders').
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from odolab.core.arrays import FloatArray
from odolab.core.defaults import DEFAULT_CORNERS
from odolab.core.errors import opt
from odolab.core.trajectory import Trajectory
from odolab.tracking.camera import CameraModel, FloorMarker, TrackingError
from odolab.tracking.markers import get_dictionary

if TYPE_CHECKING:
    import cv2
    from cv2.typing import MatLike

__all__ = [
    "CORNER_METHODS",
    "CameraPose",
    "GapBridge",
    "HeadingGap",
    "TrackOptions",
    "TrackResult",
    "bridge_gaps",
    "camera_pose_from_floor",
    "segment_headings",
    "track_video",
]

Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class TrackOptions:
    """What the tracker needs besides the video, the floor table and the camera."""

    robot_marker: int
    marker_size: float
    marker_height: float
    marker_offset: tuple[float, float] = (0.0, 0.0)
    dictionary: str = "DICT_4X4_50"
    full_every: int = 30
    max_yaw_rate: float = math.pi  # rad/s: a gap the robot may turn half a turn in is a new segment
    corners: str = DEFAULT_CORNERS  #: corner refinement, one of :data:`CORNER_METHODS`

    def __post_init__(self) -> None:
        if self.corners not in _REFINEMENT:
            raise TrackingError(
                option="corners",
                value=self.corners,
                allowed=f"one of {', '.join(_REFINEMENT)}",
            )
        if not (math.isfinite(self.max_yaw_rate) and self.max_yaw_rate > 0):
            raise TrackingError(
                f"{opt('max_yaw_rate')} is {math.degrees(self.max_yaw_rate)!r} deg/s; expected the "
                "robot's fastest turn, a positive number"
            )
        if self.full_every < 1:
            raise TrackingError(f"full_every is {self.full_every}; expected a whole number >= 1")
        if not (math.isfinite(self.marker_size) and self.marker_size > 0):
            raise TrackingError(
                option="marker_size",
                value=self.marker_size,
                allowed="the black square's side in m",
            )
        if not (math.isfinite(self.marker_height) and 0 <= self.marker_height < 10):
            raise TrackingError(
                f"{opt('marker_height')} is {self.marker_height!r}; expected metres above the floor "
                "(0 to 10)"
            )
        if not all(math.isfinite(v) for v in self.marker_offset):
            raise TrackingError(
                option="marker_offset",
                value=self.marker_offset,
                allowed="metres",
            )
        if self.robot_marker < 0:
            raise TrackingError(
                f"{opt('robot_marker')} is {self.robot_marker}; expected an id >= 0",
                option="robot_marker",
                value=self.robot_marker,
                allowed="an id >= 0",
            )


@dataclass(frozen=True)
class CameraPose:
    """The floor-to-camera transform (``X_cam = R X_floor + t``) and the RMS reprojection error
    (px) of the floor corners it was fitted to."""

    rotation: FloatArray
    translation: FloatArray
    reprojection_rms: float
    corners: int

    @property
    def position(self) -> FloatArray:
        """The camera's centre in the floor frame (m)."""
        return np.asarray(-self.rotation.T @ self.translation, dtype=np.float64)


@dataclass(frozen=True)
class HeadingGap:
    """Frames without the robot's marker, too long to carry the heading's whole turns across.

    ``index``: the first tracked frame after the gap (its first frame of a new segment);
    ``t_before``, ``t_after``: the tracked frames around it (s, video clock); ``change``: the
    heading change across it taken (rad), the least one, right only up to whole turns.
    """

    index: int
    t_before: float
    t_after: float
    change: float

    @property
    def seconds(self) -> float:
        """How long the marker was not seen (s)."""
        return self.t_after - self.t_before


@dataclass(frozen=True)
class GapBridge:
    """How a gap was bridged: ``turns`` whole turns added to the least change, so that the
    change is ``change`` (rad), against ``reference`` (rad) from the other sensor; ``bridged``
    False when the other sensor's change is too far from every candidate to decide."""

    gap: HeadingGap
    turns: int
    change: float
    reference: float
    bridged: bool


@dataclass(frozen=True, eq=False)
class TrackResult:
    """Per tracked frame: ``t`` (s from the first frame), x, y (m), heading (rad, continuous
    within a segment), quality (m), ``segment`` (0, 1, ...: a new one after each gap in
    :attr:`gaps`); ``frames`` read, ``skipped`` frames without the robot's marker; the camera."""

    t: FloatArray
    x: FloatArray
    y: FloatArray
    heading: FloatArray
    quality: FloatArray
    frames: int
    skipped: int
    camera_pose: CameraPose
    fps: float
    floor_seen: dict[int, int] = field(default_factory=dict)
    segment: NDArray[np.int64] | None = None
    gaps: tuple[HeadingGap, ...] = ()

    def __post_init__(self) -> None:
        if self.segment is None:
            object.__setattr__(self, "segment", np.zeros(len(self.t), dtype=np.int64))

    @property
    def segments(self) -> NDArray[np.int64]:
        """:attr:`segment`, never None."""
        assert self.segment is not None
        return self.segment

    def trajectory(self, time_offset: float = 0.0) -> Trajectory:
        """As a trajectory, stamps shifted by ``-time_offset`` (video clock minus another)."""
        return Trajectory.from_xyh(self.t - time_offset, self.x, self.y, self.heading)

    def heading_without_gaps(self) -> FloatArray:
        """The heading with no change across the gaps (each segment shifted to start where the
        last ended): a yaw rate of zero where it is unknown, for lining up clocks by yaw rate."""
        h = self.heading.copy()
        for gap in self.gaps:
            k = gap.index
            h[k:] -= h[k] - h[k - 1]
        return h


def segment_headings(
    t: FloatArray, yaw: FloatArray, max_yaw_rate: float
) -> tuple[FloatArray, NDArray[np.int64], tuple[HeadingGap, ...]]:
    """Continuous heading from per-frame yaws (rad, any wrap): (heading, segment, gaps).

    Between two frames ``dt`` apart the change of least size is taken; it is the only one
    possible when ``max_yaw_rate * dt < pi``. Where it is not, a new segment starts (the least
    change is still taken, as the best guess) and the gap is listed.
    """
    from odolab.core.kinematics import wrap_angle

    yaw = np.asarray(yaw, dtype=np.float64)
    if len(yaw) == 0:
        return yaw.copy(), np.zeros(0, dtype=np.int64), ()
    d = np.asarray(wrap_angle(np.diff(yaw)), dtype=np.float64)
    dt = np.diff(np.asarray(t, dtype=np.float64))
    unsure = max_yaw_rate * dt >= math.pi
    heading = yaw[0] + np.concatenate(([0.0], np.cumsum(d)))
    segment = np.concatenate(([0], np.cumsum(unsure))).astype(np.int64)
    gaps = tuple(
        HeadingGap(int(k) + 1, float(t[k]), float(t[k + 1]), float(d[k]))
        for k in np.flatnonzero(unsure)
    )
    return heading, segment, gaps


def bridge_gaps(
    result: TrackResult,
    ref_t: FloatArray,
    ref_heading: FloatArray,
    time_offset: float = 0.0,
    *,
    tolerance: float = math.pi / 2,
) -> tuple[TrackResult, list[GapBridge]]:
    """Decide each gap's whole turns from another sensor's heading (the encoders' odometry).

    ``ref_t`` is on the other sensor's clock, ``time_offset`` the video's clock minus it. Across
    a gap the other sensor turned ``reference``; the tracker's change is the least one ``c``
    plus ``k`` whole turns, and ``k`` is the one that brings it nearest ``reference``. A gap is
    bridged (its segment joined to the one before, the heading after it shifted by ``k`` turns)
    when that nearest candidate is within ``tolerance`` of ``reference``; otherwise it stays a
    segment boundary. A gap outside the other sensor's time span is left as it is.
    """
    heading = result.heading.copy()
    segment = result.segments.copy()
    kept: list[HeadingGap] = []
    bridges: list[GapBridge] = []
    ref_t = np.asarray(ref_t, dtype=np.float64)
    ref_heading = np.asarray(ref_heading, dtype=np.float64)
    for gap in result.gaps:
        a, b = gap.t_before - time_offset, gap.t_after - time_offset
        if len(ref_t) < 2 or a < ref_t[0] or b > ref_t[-1]:
            kept.append(gap)
            continue
        reference = float(np.interp(b, ref_t, ref_heading) - np.interp(a, ref_t, ref_heading))
        turns = round((reference - gap.change) / (2.0 * math.pi))
        change = gap.change + 2.0 * math.pi * turns
        ok = abs(change - reference) <= tolerance
        bridges.append(GapBridge(gap, turns if ok else 0, change, reference, ok))
        if ok:
            heading[gap.index :] += 2.0 * math.pi * turns
            segment[gap.index :] -= 1
        else:
            kept.append(gap)
    fixed = replace(result, heading=heading, segment=segment, gaps=tuple(kept))
    return fixed, bridges


#: --corners: how the marker corners are refined (OpenCV's ArUco corner refinement methods).
#: ``subpix``: the grey-level saddle of each corner; ``contour``: lines fitted to the four edges,
#: intersected (an edge of a motion-blurred marker stays straight at half contrast while the
#: saddle moves with the smear); ``apriltag``: AprilTag's edge refinement. Measured on a
#: rendered drive with 1/30 s exposure at 0.6 m/s and 90 deg/s (docs/ground-truth.md).
_REFINEMENT = {
    "subpix": "CORNER_REFINE_SUBPIX",
    "contour": "CORNER_REFINE_CONTOUR",
    "apriltag": "CORNER_REFINE_APRILTAG",
}
CORNER_METHODS = tuple(_REFINEMENT)


def _detector(dictionary: str, corners: str = DEFAULT_CORNERS) -> cv2.aruco.ArucoDetector:
    import cv2

    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = getattr(cv2.aruco, _REFINEMENT[corners])
    params.cornerRefinementWinSize = 5
    params.cornerRefinementMaxIterations = 50
    params.cornerRefinementMinAccuracy = 0.01
    return cv2.aruco.ArucoDetector(get_dictionary(dictionary), params)


def camera_pose_from_floor(
    observed: Sequence[tuple[FloatArray, FloatArray]], camera: CameraModel
) -> CameraPose:
    """solvePnP on all (floor corners (k, 3), image corners (k, 2)) pairs pooled.

    Raises:
        TrackingError: no floor marker is seen, fewer than 4 floor corners are, or no camera pose
            fits them.
    """
    import cv2

    if not observed:
        raise TrackingError("no floor marker seen in any frame; expected the FLOOR.csv markers")
    obj = np.concatenate([o for o, _ in observed]).astype(np.float64)
    img = np.concatenate([i for _, i in observed]).astype(np.float64)
    unique = {tuple(np.round(p, 6)) for p in obj}
    if len(unique) < 4:
        raise TrackingError(f"{len(unique)} distinct floor corners seen; expected at least 4")
    # a first solution from one frame's worth of distinct corners, then all points refined
    ok, rvec, tvec = cv2.solvePnP(
        obj, img, camera.matrix, camera.distortion, flags=cv2.SOLVEPNP_SQPNP
    )
    if not ok:
        raise TrackingError("solvePnP found no camera pose from the floor markers")
    rvec, tvec = cv2.solvePnPRefineLM(obj, img, camera.matrix, camera.distortion, rvec, tvec)
    proj, _ = cv2.projectPoints(obj, rvec, tvec, camera.matrix, camera.distortion)
    rms = float(np.sqrt(np.mean(np.sum((proj.reshape(-1, 2) - img) ** 2, axis=1))))
    rot, _ = cv2.Rodrigues(rvec)
    return CameraPose(
        np.asarray(rot, dtype=np.float64),
        np.asarray(tvec, dtype=np.float64).reshape(3),
        rms,
        len(obj),
    )


def _square_fit(pts: FloatArray, size: float) -> tuple[float, float, float, float]:
    """Rigid fit of the marker's corners (TL, TR, BR, BL; x right, y up) to ``pts`` (4, 2):
    centre x, y, yaw, RMS residual."""
    h = size / 2.0
    model = np.array([[-h, h], [h, h], [h, -h], [-h, -h]])
    c = pts.mean(axis=0)
    q = pts - c
    # best rotation: atan2(sum cross, sum dot) of model -> observed (the model is centred)
    num = float(np.sum(model[:, 0] * q[:, 1] - model[:, 1] * q[:, 0]))
    den = float(np.sum(model[:, 0] * q[:, 0] + model[:, 1] * q[:, 1]))
    yaw = math.atan2(num, den)
    cs, sn = math.cos(yaw), math.sin(yaw)
    fitted = model @ np.array([[cs, sn], [-sn, cs]])
    rms = float(np.sqrt(np.mean(np.sum((q - fitted) ** 2, axis=1))))
    return float(c[0]), float(c[1]), yaw, rms


def _to_plane(
    corners: FloatArray, camera: CameraModel, pose: CameraPose, height: float
) -> FloatArray:
    """Image corners (k, 2) -> points (k, 2) on the plane z = height of the floor frame."""
    import cv2

    norm = cv2.undistortPoints(
        corners.reshape(-1, 1, 2).astype(np.float64), camera.matrix, camera.distortion
    ).reshape(-1, 2)
    r, t = pose.rotation, pose.translation
    g = np.column_stack((r[:, 0], r[:, 1], height * r[:, 2] + t))
    hom = np.linalg.solve(g, np.column_stack((norm, np.ones(len(norm)))).T).T
    return np.asarray(hom[:, :2] / hom[:, 2:3], dtype=np.float64)


def _frames(path: Path) -> cv2.VideoCapture:
    import cv2

    if not path.is_file():
        raise TrackingError(f"{path}: no such video file")
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        raise TrackingError(f"{path}: not a video OpenCV can read (try MP4/H.264 or MJPG AVI)")
    return cap


def _decoded(
    cap: cv2.VideoCapture, path: Path, camera: CameraModel, fps: float
) -> Iterator[tuple[float, MatLike]]:
    """(time s, grey frame) pairs; decoding runs in a thread beside the caller's detection
    (OpenCV releases the GIL in both), a few frames ahead."""
    import queue
    import threading

    import cv2

    q: queue.Queue[tuple[float, MatLike] | BaseException | None] = queue.Queue(maxsize=8)
    stop = threading.Event()

    def read() -> None:
        n = 0
        last = -math.inf
        try:
            while not stop.is_set():
                ok, frame = cap.read()
                if not ok:
                    break
                if frame.shape[1] != camera.width or frame.shape[0] != camera.height:
                    raise TrackingError(
                        f"{path}: frames are {frame.shape[1]}x{frame.shape[0]} px but the "
                        f"camera file is for {camera.width}x{camera.height}; expected the same "
                        "camera mode"
                    )
                msec = float(cap.get(cv2.CAP_PROP_POS_MSEC))
                t = msec / 1000.0 if (msec > 0 or n == 0) else n / fps
                if t <= last:
                    t = n / fps
                last = t
                n += 1
                grey = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if frame.ndim == 3 else frame
                q.put((t, grey))
        except BaseException as err:  # handed to the consumer, raised there
            q.put(err)
        finally:
            q.put(None)

    worker = threading.Thread(target=read, daemon=True)
    worker.start()
    try:
        while True:
            item = q.get()
            if item is None:
                break
            if isinstance(item, BaseException):
                raise item
            yield item
    finally:
        stop.set()
        while worker.is_alive():
            try:
                q.get_nowait()
            except queue.Empty:
                worker.join(0.05)
        cap.release()


def _detect(
    detector: cv2.aruco.ArucoDetector, grey: MatLike, last: FloatArray | None
) -> tuple[Sequence[MatLike], MatLike, FloatArray]:
    """The markers in the frame (corners, ids, and the pixel origin of the part searched): the
    whole frame, or (``last``, the robot's corners in the previous frame) only near the robot."""
    if last is None:
        corners, ids, _ = detector.detectMarkers(grey)
        return corners, ids, np.zeros(2)
    # the camera stands still: only the robot moves; search near where it was
    side = float(np.ptp(last, axis=0).max())
    pad = max(2.0 * side, 40.0)
    x0 = max(int(last[:, 0].min() - pad), 0)
    y0 = max(int(last[:, 1].min() - pad), 0)
    x1 = min(int(last[:, 0].max() + pad) + 1, grey.shape[1])
    y1 = min(int(last[:, 1].max() + pad) + 1, grey.shape[0])
    corners, ids, _ = detector.detectMarkers(grey[y0:y1, x0:x1])
    return corners, ids, np.array([x0, y0], dtype=np.float64)


def _robot_rows(
    robot: list[tuple[float, FloatArray]],
    t0: float,
    camera: CameraModel,
    pose: CameraPose,
    options: TrackOptions,
) -> FloatArray:
    """(t - t0, x, y, yaw, rms) of the robot's reference point in every frame it was seen."""
    dx, dy = options.marker_offset
    rows = []
    for t, c in robot:
        plane = _to_plane(c, camera, pose, options.marker_height)
        mx, my, yaw, rms = _square_fit(plane, options.marker_size)
        cs, sn = math.cos(yaw), math.sin(yaw)
        rows.append((t - t0, mx - (cs * dx - sn * dy), my - (sn * dx + cs * dy), yaw, rms))
    return np.array(rows)


# long: the frame loop and its refusals (no floor marker seen, no robot marker) in one place, in
# the order the video is read
def track_video(
    video: str | Path,
    floor: Sequence[FloorMarker],
    camera: CameraModel,
    options: TrackOptions,
    *,
    progress: Progress | None = None,
) -> TrackResult:
    """Track the robot's marker through ``video`` (see the module).

    Raises:
        TrackingError: the robot's marker is also a floor marker, the video cannot be read, or the
            floor markers or the robot's marker are never seen.
    """
    import cv2

    path = Path(video)
    by_id = {m.id: m for m in floor}
    if options.robot_marker in by_id:
        raise TrackingError(
            f"{opt('robot_marker')} {options.robot_marker} is also a floor marker in the floor table; "
            "expected a different id"
        )
    detector = _detector(options.dictionary, options.corners)
    cap = _frames(path)
    fps = float(cap.get(cv2.CAP_PROP_FPS)) or 30.0
    total = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
    floor_obs: list[tuple[FloatArray, FloatArray]] = []
    floor_seen: dict[int, int] = {}
    robot: list[tuple[float, FloatArray]] = []
    stamps: list[float] = []
    frames = 0
    last: FloatArray | None = None  # the robot's corners in the previous frame
    for t, grey in _decoded(cap, path, camera, fps):
        stamps.append(t)
        full = last is None or frames % options.full_every == 0
        frames += 1
        corners, ids, origin = _detect(detector, grey, None if full else last)
        found = None
        if ids is not None:
            for c, i in zip(corners, ids.reshape(-1), strict=True):
                mid = int(i)
                if mid == options.robot_marker:
                    found = c.reshape(4, 2).astype(np.float64) + origin
                elif mid in by_id and full:
                    floor_obs.append((by_id[mid].corners(), c.reshape(4, 2).astype(np.float64)))
                    floor_seen[mid] = floor_seen.get(mid, 0) + 1
        if found is not None:
            robot.append((t, found))
        last = found
        if progress is not None:
            progress(frames, total)
    if frames == 0:
        raise TrackingError(f"{path}: no frames could be read")
    if not floor_obs:
        raise TrackingError(
            f"{path}: none of the floor markers ({', '.join(str(i) for i in sorted(by_id))}, "
            f"{options.dictionary}) was seen in {frames} frames; expected them in view"
        )
    pose = camera_pose_from_floor(floor_obs, camera)
    if not robot:
        raise TrackingError(
            f"{path}: the robot's marker {options.robot_marker} ({options.dictionary}) was not "
            f"seen in any of {frames} frames"
        )
    arr = _robot_rows(robot, stamps[0], camera, pose, options)
    # before: np.unwrap across every gap, 360 deg off after a hidden turn of over half a turn
    heading, segment, gaps = segment_headings(arr[:, 0], arr[:, 3], options.max_yaw_rate)
    return TrackResult(
        t=arr[:, 0],
        x=arr[:, 1],
        y=arr[:, 2],
        heading=heading,
        quality=arr[:, 4],
        frames=frames,
        skipped=frames - len(robot),
        camera_pose=pose,
        fps=fps,
        floor_seen=floor_seen,
        segment=segment,
        gaps=gaps,
    )


def write_track_csv(path: str | Path, result: TrackResult, time_offset: float = 0.0) -> Path:
    """Write ``t,x,y,theta,heading,quality,segment`` (readable wherever odolab reads a
    trajectory). ``heading`` is continuous within a ``segment``; across segments its whole turns
    are a guess (see the module).

    Raises:
        TrackingError: the track cannot be written.
    """
    from odolab.core.kinematics import wrap_angle

    p = Path(path)
    table = np.column_stack(
        (result.t - time_offset, result.x, result.y, wrap_angle(result.heading),
         result.heading, result.quality, result.segments)
    )  # fmt: skip
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        np.savetxt(
            p, table, fmt=["%.9g"] * 6 + ["%d"], delimiter=",",
            header="t,x,y,theta,heading,quality,segment", comments="",
        )  # fmt: skip
    except OSError as err:
        raise TrackingError(f"{p}: cannot write the track ({err.strerror or err})") from err
    return p

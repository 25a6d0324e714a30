"""2-D laser scans (``sensor_msgs/msg/LaserScan``) from ROS 1 bags, ROS 2 bag folders and MCAP.

:func:`read_scans` reads one topic into :class:`LaserScans` (ranges as a float array, one row per
scan; every scan must have the first scan's beam count and angles). Stamps are the messages'
``header.stamp`` (the bag's receive time where that is zero). :func:`write_scan_mcap` writes
scans (and optionally the wheel angles as ``sensor_msgs/msg/JointState``) as a ROS 2 MCAP file, the
format :func:`read_scans` and ``odolab.io.rosbag.read_bag`` read back.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odolab.core.errors import LogFormatError, OdolabError
from odolab.core.writing import replacing_path
from odolab.io.rosbag import _close, _messages, _open, _stamp, reading

__all__ = ["SCAN_TYPE", "LaserScans", "read_scans", "write_scan_mcap"]

SCAN_TYPE = "sensor_msgs/msg/LaserScan"
_JOINT_TYPE = "sensor_msgs/msg/JointState"


@dataclass(frozen=True, eq=False)
class LaserScans:
    """n scans of ``beams`` ranges each.

    ``t``: (n,) stamps (s); ``ranges``: (n, beams) float32 (the message's own precision; half the
    memory of float64 for long bags) in metres (``inf`` or ``nan`` where the beam returned nothing); beam ``j`` points at ``angle_min + j * angle_increment`` (rad, counter-
    clockwise from the sensor's x axis); readings outside [``range_min``, ``range_max``] are
    invalid, as ROS defines them."""

    t: NDArray[np.float64]
    ranges: NDArray[np.float32 | np.float64]  # stored as float32
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    frame_id: str = "laser"

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=np.float64)
        r = np.asarray(self.ranges, dtype=np.float32)
        if t.ndim != 1 or r.ndim != 2 or len(t) != len(r):
            raise OdolabError(
                f"laser scans need (n,) stamps and (n, beams) ranges, got {t.shape} and {r.shape}"
            )
        if not np.isfinite(t).all():
            raise OdolabError("laser scan stamps must be finite")
        if not (math.isfinite(self.angle_min) and math.isfinite(self.angle_increment)):
            raise OdolabError("laser scan angles must be finite")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "ranges", r)

    def __len__(self) -> int:
        return len(self.t)

    @property
    def beams(self) -> int:
        """Rays per scan."""
        return int(self.ranges.shape[1])

    @property
    def angles(self) -> NDArray[np.float64]:
        """(beams,) beam angles in the sensor frame (rad)."""
        return self.angle_min + self.angle_increment * np.arange(self.beams, dtype=np.float64)

    def points(self, i: int, max_range: float | None = None) -> NDArray[np.float64]:
        """(k, 2) points ``x, y`` (m, sensor frame) of scan ``i``'s valid ranges, those in
        [``range_min``, ``min(range_max, max_range)``]."""
        r = self.ranges[i].astype(np.float64)
        top = self.range_max if max_range is None else min(self.range_max, max_range)
        with np.errstate(invalid="ignore"):
            ok = np.isfinite(r) & (r >= self.range_min) & (r <= top)
        a = self.angles[ok]
        return np.column_stack((r[ok] * np.cos(a), r[ok] * np.sin(a)))


def read_scans(path: str | Path, topic: str = "/scan", *, min_scans: int = 2) -> LaserScans:
    """Every ``sensor_msgs/msg/LaserScan`` on ``topic`` of a ROS 1 bag, ROS 2 bag folder or MCAP.

    One-sentence :class:`LogFormatError` when the topic is missing (the bag's topics are listed),
    carries another type, has fewer than ``min_scans`` scans, changes its beam layout, or its
    stamps go backwards.

    Raises:
        LogFormatError: the topic is missing or of another type, has too few scans, changes its beam
            layout, or its stamps go backwards.
    """
    p = Path(path)
    reader = _open(p)
    try:
        with reading(p):
            t: list[float] = []
            rows: list[NDArray[np.float32]] = []
            layout: tuple[float, float, int] | None = None
            rmin = rmax = 0.0
            frame = "laser"
            for bag_ns, msg in _messages(reader, p, topic, (SCAN_TYPE,)):
                r = np.asarray(msg.ranges, dtype=np.float32)
                this = (float(msg.angle_min), float(msg.angle_increment), len(r))
                if layout is None:
                    layout = this
                    rmin, rmax = float(msg.range_min), float(msg.range_max)
                    frame = str(msg.header.frame_id) or frame
                    if len(r) < 2 or not (math.isfinite(this[0]) and math.isfinite(this[1])):
                        raise LogFormatError(
                            f"{p}: the first scan on {topic!r} has {len(r)} beams from "
                            f"{this[0]} rad by {this[1]} rad; expected at least 2 beams, finite angles"
                        )
                elif this[2] != layout[2] or not np.allclose(this[:2], layout[:2], atol=1e-9):
                    raise LogFormatError(
                        f"{p}: scan {len(t)} on {topic!r} has {this[2]} beams from {this[0]:.6g} rad "
                        f"by {this[1]:.6g} rad; expected the first scan's {layout[2]} beams from "
                        f"{layout[0]:.6g} rad by {layout[1]:.6g} rad"
                    )
                t.append(_stamp(msg, bag_ns))
                rows.append(r)
    finally:
        _close(reader, p)
    if len(t) < max(min_scans, 2) or layout is None:
        raise LogFormatError(
            f"{p}: topic {topic!r} has {len(t)} laser scans; expected at least {max(min_scans, 2)}"
        )
    tt = np.array(t)
    back = np.diff(tt) < 0
    if back.any():
        i = int(np.argmax(back)) + 1
        raise LogFormatError(
            f"{p}: topic {topic!r} time goes backwards at scan {i} ({tt[i]} after {tt[i - 1]}); "
            "expected non-decreasing header stamps"
        )
    return LaserScans(
        t=tt,
        ranges=np.vstack(rows),
        angle_min=layout[0],
        angle_increment=layout[1],
        range_min=rmin,
        range_max=rmax,
        frame_id=frame,
    )


def _stamp_dict(t: float) -> dict[str, int]:
    ns = round(t * 1e9)
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


#: (time, topic, message) of a message to write.
_Message = tuple[float, str, dict[str, object]]


def _scan_messages(scans: LaserScans, topic: str) -> list[_Message]:
    """(time, topic, LaserScan message) of every scan."""
    msgs: list[_Message] = []
    end = scans.angle_min + scans.angle_increment * (scans.beams - 1)
    period = float(np.median(np.diff(scans.t))) if len(scans) > 1 else 0.0
    for ti, r in zip(scans.t, scans.ranges, strict=True):
        msgs.append(
            (
                float(ti),
                topic,
                {
                    "header": {"stamp": _stamp_dict(float(ti)), "frame_id": scans.frame_id},
                    "angle_min": scans.angle_min,
                    "angle_max": end,
                    "angle_increment": scans.angle_increment,
                    "time_increment": 0.0,
                    "scan_time": period,
                    "range_min": scans.range_min,
                    "range_max": scans.range_max,
                    "ranges": [float(v) for v in r],
                    "intensities": [],
                },
            )
        )
    return msgs


def _joint_messages(
    joint_t: ArrayLike | None,
    wheel_angles: ArrayLike | None,
    joint_names: tuple[str, str],
    joint_topic: str,
) -> list[_Message]:
    """(time, topic, JointState message) of every wheel-angle sample."""
    msgs: list[_Message] = []
    jt = np.asarray(joint_t, dtype=np.float64)
    wa = np.asarray(wheel_angles, dtype=np.float64)
    if jt.ndim != 1 or wa.shape != (len(jt), 2):
        raise OdolabError(
            f"wheel angles must be (k, 2) with (k,) stamps, got {wa.shape} and {jt.shape}"
        )
    for ti, (left, right) in zip(jt, wa, strict=True):
        msgs.append(
            (
                float(ti),
                joint_topic,
                {
                    "header": {"stamp": _stamp_dict(float(ti)), "frame_id": "base_link"},
                    "name": list(joint_names),
                    "position": [float(left), float(right)],
                    "velocity": [],
                    "effort": [],
                },
            )
        )
    return msgs


def write_scan_mcap(
    path: str | Path,
    scans: LaserScans,
    *,
    topic: str = "/scan",
    joint_t: ArrayLike | None = None,
    wheel_angles: ArrayLike | None = None,
    joint_names: tuple[str, str] = ("left_wheel_joint", "right_wheel_joint"),
    joint_topic: str = "/joint_states",
) -> dict[str, int]:
    """Write ``scans`` on ``topic`` (and, given ``joint_t`` (k,) and ``wheel_angles`` (k, 2) in
    rad, the wheels on ``joint_topic``) as a ROS 2 MCAP file; returns the count per topic."""
    from mcap.writer import CompressionType
    from mcap_ros2.writer import Writer
    from rosbags.typesys import Stores, get_typestore

    p = Path(path)
    if p.is_dir():
        raise OdolabError(f"{p}: is a folder; expected an .mcap file name")
    if float(scans.t.min()) < 0:
        raise OdolabError(f"scan stamps start at {scans.t.min()} s; expected times >= 0")
    msgs = _scan_messages(scans, topic)
    if joint_t is not None or wheel_angles is not None:
        msgs += _joint_messages(joint_t, wheel_angles, joint_names, joint_topic)
    msgs.sort(key=lambda m: m[0])
    store = get_typestore(Stores.ROS2_HUMBLE)
    counts: dict[str, int] = {}
    try:
        with replacing_path(p, what="scan bag", error=LogFormatError) as tmp, tmp.open("wb") as fh:
            writer = Writer(fh, compression=CompressionType.LZ4)
            schemas = {}
            for name, msgtype in ((topic, SCAN_TYPE), (joint_topic, _JOINT_TYPE)):
                text, _ = store.generate_msgdef(msgtype, ros_version=2)
                schemas[name] = writer.register_msgdef(msgtype, text)
            for ti, name, msg in msgs:
                ns = round(ti * 1e9)
                writer.write_message(name, schemas[name], msg, log_time=ns, publish_time=ns)
                counts[name] = counts.get(name, 0) + 1
            writer.finish()  # type: ignore[no-untyped-call]
    except OSError as err:
        raise OdolabError(f"{p}: cannot write the MCAP file ({err.strerror or err})") from err
    return counts

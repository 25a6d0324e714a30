"""ROS 1 and ROS 2 bags through ``rosbags``: wheel angles, robot odometry, ground-truth poses.

* ``sensor_msgs/msg/JointState`` on ``ReadOptions.joint_topic``: the ``position`` of the joints
  named ``ReadOptions.joint_names`` (left, right) is the wheel angle in radians. It becomes ticks as
  ``angle * ticks_per_rev / (2 pi)`` (default ``ticks_per_rev`` 2 pi: one tick per radian, so use
  parameters with ``ticks_per_rev = 6.283185307179586``, or pass your params' ``ticks_per_rev``).
  Angles are unwrapped first, so drivers that wrap them to (-pi, pi] work too.
* ``geometry_msgs/msg/PoseStamped`` or ``nav_msgs/msg/Odometry`` on
  ``ReadOptions.ground_truth_topic``: the ground truth (x, y, yaw from the quaternion).
* ``nav_msgs/msg/Odometry`` on ``ReadOptions.odometry_topic`` (optional): the robot's own estimate.

Stamps are the messages' ``header.stamp``; where that is zero, the bag's receive time.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from odolab.errors import LogFormatError, OdolabError
from odolab.io.run import OdometryRun, ReadOptions
from odolab.trajectory import Trajectory

__all__ = ["RosbagReader", "bag_topics", "read_bag", "read_bag_trajectory"]

POSE_TYPES = ("geometry_msgs/msg/PoseStamped", "nav_msgs/msg/Odometry")
JOINT_TYPE = "sensor_msgs/msg/JointState"


def _why(err: BaseException) -> str:
    """A third-party error in a few words: its message (one line, at most 200 characters), else
    its type."""
    from odolab.text import safe_terminal, shorten

    text = " ".join(str(err).split())
    return safe_terminal(shorten(text, 200)) if text else type(err).__name__


@contextmanager
def reading(path: Path, where: str = "") -> Iterator[None]:
    """Turn any failure of rosbags (or of a damaged message's fields) into one sentence naming
    the bag and, given ``where``, the topic and message: rosbags raises what its parsers raise
    (struct.error, KeyError, AttributeError, sqlite3's and the decompressors' errors)."""
    try:
        yield
    except OdolabError:
        raise
    except (KeyboardInterrupt, SystemExit):  # pragma: no cover - not a file's fault
        raise
    except Exception as err:
        at = f" at {where}" if where else ""
        raise LogFormatError(
            f"{path}: not a readable ROS 1 or ROS 2 bag{at} ({_why(err)}); expected a whole, "
            "undamaged bag"
        ) from err


def _open(path: Path) -> Any:
    from odolab.io._bagcheck import check_bag_sizes

    if not path.exists():
        raise LogFormatError(f"{path}: no such bag")
    with reading(path):
        check_bag_sizes(path)  # lengths against the file before rosbags allocates them
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore

        reader = AnyReader([path], default_typestore=get_typestore(Stores.LATEST))
        reader.open()
    return reader


def _close(reader: Any, path: Path) -> None:
    with reading(path):
        reader.close()


def bag_topics(path: str | Path) -> dict[str, str]:
    """Topic name -> message type of every topic in the bag."""
    p = Path(path)
    reader = _open(p)
    try:
        with reading(p):
            return {name: str(info.msgtype) for name, info in reader.topics.items()}
    finally:
        _close(reader, p)


def _messages(
    reader: Any, path: Path, topic: str, types: tuple[str, ...]
) -> Iterator[tuple[int, Any]]:
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns:
        have = ", ".join(f"{c.topic} ({c.msgtype})" for c in reader.connections) or "none"
        raise LogFormatError(f"{path}: no topic {topic!r} in the bag; it has {have}")
    for c in conns:
        if c.msgtype not in types:
            raise LogFormatError(
                f"{path}: topic {topic!r} carries {c.msgtype}; expected {' or '.join(types)}"
            )
    k = 0
    with reading(path, f"topic {topic!r}"):
        it = iter(reader.messages(connections=conns))
    while True:
        with reading(path, f"message {k + 1} of topic {topic!r}"):
            item = next(it, None)
            if item is None:
                return
            conn, stamp, raw = item
            msg = reader.deserialize(raw, conn.msgtype)
        k += 1
        yield stamp, msg


def _stamp(msg: Any, bag_ns: int) -> float:
    s = msg.header.stamp
    ns = int(s.sec) * 1_000_000_000 + int(s.nanosec)
    return (ns if ns else bag_ns) * 1e-9


def _poses(reader: Any, path: Path, topic: str) -> Trajectory:
    t, x, y, yaw = [], [], [], []
    for bag_ns, msg in _messages(reader, path, topic, POSE_TYPES):
        pose = msg.pose.pose if hasattr(msg.pose, "pose") else msg.pose
        q = pose.orientation
        t.append(_stamp(msg, bag_ns))
        x.append(pose.position.x)
        y.append(pose.position.y)
        # scale-invariant: the yaw of q for any length |q| (stored quaternions are rounded)
        yaw.append(
            math.atan2(2.0 * (q.w * q.z + q.x * q.y), q.w * q.w + q.x * q.x - q.y * q.y - q.z * q.z)
        )
    if len(t) < 2:
        raise LogFormatError(f"{path}: topic {topic!r} has {len(t)} poses; expected at least two")
    return _checked_trajectory(path, topic, np.array(t), np.array(x), np.array(y), np.array(yaw))


def _checked_trajectory(
    path: Path, topic: str, t: np.ndarray, x: np.ndarray, y: np.ndarray, yaw: np.ndarray
) -> Trajectory:
    back = np.diff(t) < 0
    if back.any():
        i = int(np.argmax(back)) + 1
        raise LogFormatError(
            f"{path}: topic {topic!r} time goes backwards at message {i} ({t[i]} after "
            f"{t[i - 1]}); expected non-decreasing header stamps"
        )
    return Trajectory.from_xytheta(t, x, y, yaw)


def read_bag(path: str | Path, options: ReadOptions | None = None) -> OdometryRun:
    """Wheel angles, ground truth (if the topic is there) and optional odometry of one bag."""
    o = options or ReadOptions()
    p = Path(path)
    reader = _open(p)
    try:
        with reading(p):
            tt, dl, dr, gt, est, meta = _read_open_bag(reader, p, o)
    finally:
        _close(reader, p)
    if o.ground_truth is not None:
        from odolab.io.trajectory_csv import read_trajectory

        gt = read_trajectory(o.ground_truth)
    return OdometryRun(
        name=p.stem,
        source=str(p),
        t=tt,
        dticks_left=dl,
        dticks_right=dr,
        ground_truth=gt,
        estimate=est,
        kind="bag",
        meta=meta,
    )


def _read_open_bag(
    reader: Any, p: Path, o: ReadOptions
) -> tuple[
    np.ndarray, np.ndarray, np.ndarray, Trajectory | None, Trajectory | None, dict[str, float | str]
]:
    """Stamps, wheel increments, ground truth, estimate and meta of an open bag."""
    left_name, right_name = o.joint_names
    t, left, right = [], [], []
    for bag_ns, msg in _messages(reader, p, o.joint_topic, (JOINT_TYPE,)):
        names = list(msg.name)
        try:
            il, ir = names.index(left_name), names.index(right_name)
        except ValueError as err:
            raise LogFormatError(
                f"{p}: JointState on {o.joint_topic!r} names {names}; expected joints "
                f"{left_name!r} and {right_name!r} (set joint_names)"
            ) from err
        t.append(_stamp(msg, bag_ns))
        left.append(float(msg.position[il]))
        right.append(float(msg.position[ir]))
    if len(t) < 2:
        raise LogFormatError(f"{p}: {o.joint_topic!r} has {len(t)} messages; expected two+")
    tt = np.array(t)
    back = np.diff(tt) < 0
    if back.any():
        i = int(np.argmax(back)) + 1
        raise LogFormatError(
            f"{p}: topic {o.joint_topic!r} time goes backwards at message {i} ({tt[i]} "
            f"after {tt[i - 1]}); expected non-decreasing header stamps"
        )
    scale = o.ticks_per_rev / (2.0 * math.pi)
    dl = np.concatenate(([0.0], np.diff(np.unwrap(np.array(left))) * scale))
    dr = np.concatenate(([0.0], np.diff(np.unwrap(np.array(right))) * scale))
    topics = {c.topic for c in reader.connections}
    meta: dict[str, float | str] = {"ticks_per_rev": o.ticks_per_rev}
    gt = None
    if o.ground_truth_topic in topics:
        gt = _poses(reader, p, o.ground_truth_topic)
    elif o.ground_truth is None:
        have = ", ".join(f"{c.topic} ({c.msgtype})" for c in reader.connections)
        meta["no_ground_truth"] = (
            f"no ground-truth topic {o.ground_truth_topic!r} in the bag; it has {have}"
        )
    est = _poses(reader, p, o.odometry_topic) if o.odometry_topic else None
    return tt, dl, dr, gt, est, meta


def read_bag_trajectory(path: str | Path, topic: str) -> Trajectory:
    """The poses on one topic (PoseStamped or Odometry) as a trajectory."""
    p = Path(path)
    reader = _open(p)
    try:
        with reading(p):
            return _poses(reader, p, topic)
    finally:
        _close(reader, p)


class RosbagReader:
    """Registry entry for :class:`odolab.io.registry.LogFormat` ``bag``."""

    def find(self, path: Path) -> list[Path]:
        """A ROS 1 ``.bag`` file, a ROS 2 bag folder, or the bags inside a folder."""
        if path.is_file() or (path.is_dir() and (path / "metadata.yaml").is_file()):
            return [path]
        if not path.is_dir():
            raise LogFormatError(f"{path}: no such bag")
        bags = sorted(
            q
            for q in path.iterdir()
            if q.suffix == ".bag" or (q.is_dir() and (q / "metadata.yaml").is_file())
        )
        if not bags:
            raise LogFormatError(f"{path}: no ROS bags (*.bag or rosbag2 folders) in this folder")
        return bags

    def read(self, path: Path, options: ReadOptions) -> OdometryRun:
        """Read one bag."""
        return read_bag(path, options)

"""ROS 1 and ROS 2 bags through ``rosbags``: wheel angles, robot odometry, ground-truth poses.

* ``sensor_msgs/msg/JointState`` on ``ReadOptions.joint_topic``: the ``position`` of the joints
  named ``ReadOptions.joint_names`` (left, right) is the wheel angle in radians. It becomes ticks as
  ``angle * ticks_per_rev / (2 pi)`` (default ``ticks_per_rev`` 2 pi: one tick per radian, so use
  parameters with ``ticks_per_rev = 6.283185307179586``, or pass your params' ``ticks_per_rev``).
  Angles are unwrapped first, so drivers that wrap them to (-pi, pi] work too.
* ``geometry_msgs/msg/PoseStamped``, ``PoseWithCovarianceStamped`` or ``nav_msgs/msg/Odometry``
  on ``ReadOptions.ground_truth_topic``: the ground truth (x, y, yaw from the quaternion). Where
  the default ``/ground_truth`` is missing and ``/amcl_pose`` is there (a Nav2 robot), AMCL's pose
  is the reference, and the run says so (``meta["reference"]``).
* ``nav_msgs/msg/Odometry`` on ``ReadOptions.odometry_topic`` (optional): the robot's own estimate.
* A bag without the default ``/joint_states`` (a TurtleBot under Nav2 records none) but with
  ``nav_msgs/Odometry`` on ``odometry_topic`` (default ``/odom``): the wheel increments are that
  odometry turned back into wheel turns (midpoint rule inverted) with ``ReadOptions.params``. They
  are the robot's own odometry, not encoder counts, and the run says so (``meta["wheels"]``).

Stamps are the messages' ``header.stamp``; where that is zero, the bag's receive time.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from odolab.core.errors import LogFormatError, OdolabError, opt
from odolab.core.params import RobotParams
from odolab.core.trajectory import (
    Trajectory,
    check_positions,
    check_times,
    yaw_from_quaternions,
)
from odolab.io.run import OdometryRun, ReadOptions
from odolab.io.sensorlog import ImuLog

if TYPE_CHECKING:
    from rosbags.highlevel import AnyReader

__all__ = [
    "BAG_SUFFIXES",
    "IMU_TYPE",
    "RosbagReader",
    "bag_topics",
    "is_bag",
    "read_bag",
    "read_bag_gyro",
    "read_bag_trajectory",
]

POSE_TYPES = (
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    "nav_msgs/msg/Odometry",
)
JOINT_TYPE = "sensor_msgs/msg/JointState"
IMU_TYPE = "sensor_msgs/msg/Imu"
DEFAULT_IMU_TOPIC = "/imu/data"
ODOMETRY_TYPE = "nav_msgs/msg/Odometry"
DEFAULT_JOINT_TOPIC = ReadOptions.joint_topic
DEFAULT_GROUND_TRUTH_TOPIC = ReadOptions.ground_truth_topic
ODOMETRY_TOPIC = "/odom"  #: where a bag without joint states is looked for wheel odometry
AMCL_TOPIC = "/amcl_pose"  #: the reference of a Nav2 bag without a ground-truth topic
#: The suffixes of a bag file: ROS 1, MCAP, a ROS 2 SQLite bag's database.
BAG_SUFFIXES = (".bag", ".mcap", ".db3")


def is_bag(p: Path) -> bool:
    """Whether ``p`` is a bag: a file with one of :data:`BAG_SUFFIXES`, or a ROS 2 bag folder
    (one that holds ``metadata.yaml``)."""
    return p.suffix.lower() in BAG_SUFFIXES or (p.is_dir() and (p / "metadata.yaml").is_file())


def _why(err: BaseException) -> str:
    """A third-party error in a few words: its message (one line, at most 200 characters), else
    its type."""
    from odolab.core.text import safe_terminal, shorten

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


def _open(path: Path) -> AnyReader:
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


def _close(reader: AnyReader, path: Path) -> None:
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
    reader: AnyReader, path: Path, topic: str, types: tuple[str, ...]
) -> Iterator[tuple[int, Any]]:  # a message: a class rosbags makes from the bag's types
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


def _poses(reader: AnyReader, path: Path, topic: str) -> Trajectory:
    t, x, y, q = [], [], [], []
    for bag_ns, msg in _messages(reader, path, topic, POSE_TYPES):
        pose = msg.pose.pose if hasattr(msg.pose, "pose") else msg.pose
        o = pose.orientation
        t.append(_stamp(msg, bag_ns))
        x.append(pose.position.x)
        y.append(pose.position.y)
        q.append((o.x, o.y, o.z, o.w))
    if len(t) < 2:
        raise LogFormatError(f"{path}: topic {topic!r} has {len(t)} poses; expected at least two")
    return _checked_trajectory(path, topic, np.array(t), np.array(x), np.array(y), np.array(q))


def _checked_trajectory(
    path: Path, topic: str, t: np.ndarray, x: np.ndarray, y: np.ndarray, q: np.ndarray
) -> Trajectory:
    """The poses of a topic, checked as every trajectory reader checks them: times, positions,
    unit quaternions (the yaw whatever the length near 1: stored quaternions are rounded)."""
    source = f"{path}: topic {topic!r}"
    check_times(t, source, row_offset=1, what="message")
    check_positions(x, y, source, line_of=lambda i: i + 1, what="message")
    yaw = yaw_from_quaternions(
        q[:, 0], q[:, 1], q[:, 2], q[:, 3], source, line_of=lambda i: i + 1, what="message"
    )
    return Trajectory.from_xytheta(t, x, y, yaw)


def read_bag(path: str | Path, options: ReadOptions | None = None) -> OdometryRun:
    """Wheel angles, ground truth (if the topic is there) and optional odometry of one bag."""
    o = options or ReadOptions()
    p = Path(path)
    reader = _open(p)
    try:
        with reading(p):
            tt, dl, dr, gt, est, meta, params = _read_open_bag(reader, p, o)
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
        params=params,
        estimate=est,
        kind="bag",
        meta=meta,
    )


def read_bag_gyro(path: str | Path, topic: str = DEFAULT_IMU_TOPIC) -> ImuLog:
    """The yaw rate (``angular_velocity.z``, rad/s) of a ``sensor_msgs/Imu`` topic, on the
    header stamps' clock (the bag's receive time where a stamp is zero), as an
    :class:`~odolab.io.sensorlog.ImuLog` (yaw: the rate's integral). A message repeated with
    the same stamp is kept once.

    Raises:
        LogFormatError: the topic is missing, has fewer than two IMU samples, or its time goes
            backwards.
    """
    p = Path(path)
    reader = _open(p)
    t: list[float] = []
    wz: list[float] = []
    try:
        with reading(p):
            for bag_ns, msg in _messages(reader, p, topic, (IMU_TYPE,)):
                t.append(_stamp(msg, bag_ns))
                wz.append(float(msg.angular_velocity.z))
    finally:
        _close(reader, p)
    ta, wa = np.asarray(t, dtype=np.float64), np.asarray(wz, dtype=np.float64)
    back = np.flatnonzero(np.diff(ta) < 0)
    if back.size:
        i = int(back[0]) + 1
        raise LogFormatError(
            f"{p}: topic {topic!r} time goes backwards at message {i + 1} ({ta[i]} after "
            f"{ta[i - 1]}); expected non-decreasing header stamps"
        )
    keep = np.concatenate(([True], np.diff(ta) > 0))
    ta, wa = ta[keep], wa[keep]
    if ta.size < 2:
        raise LogFormatError(
            f"{p}: topic {topic!r} has {ta.size} IMU samples; expected at least two"
        )
    yaw = np.concatenate(([0.0], np.cumsum(0.5 * (wa[1:] + wa[:-1]) * np.diff(ta))))
    return ImuLog(
        ta, yaw, wa, source=f"{p} ({topic})", heading_column=topic, rate_column=topic,
        time_column="header.stamp",
    )  # fmt: skip


def increments_from_odometry(
    odom: Trajectory, params: RobotParams
) -> tuple[np.ndarray, np.ndarray]:
    """Wheel increments (ticks of ``params``) that give ``odom`` back under the midpoint rule:
    ``ds = dx cos m + dy sin m`` (``m`` the mid-step heading), ``ds_l,r = ds -+ dtheta b / 2``;
    a sideways step (which no wheel makes) is dropped."""
    h = np.asarray(odom.heading, dtype=np.float64)
    dth = np.diff(h)
    m = h[:-1] + 0.5 * dth
    ds = np.diff(odom.x) * np.cos(m) + np.diff(odom.y) * np.sin(m)
    half = 0.5 * dth * params.track_width
    dl = np.concatenate(([0.0], (ds - half) / params.left_metres_per_tick))
    dr = np.concatenate(([0.0], (ds + half) / params.right_metres_per_tick))
    return dl, dr


def _replay_params(o: ReadOptions) -> RobotParams:
    """The parameters a bag's own odometry is turned back into wheel turns with."""
    if o.params is not None:
        return o.params
    return RobotParams(
        left_wheel_radius=1.0,
        right_wheel_radius=1.0,
        track_width=1.0,
        ticks_per_rev=o.ticks_per_rev,
        name="odom-replay",
    )


def _read_open_bag(
    reader: AnyReader, p: Path, o: ReadOptions
) -> tuple[
    np.ndarray,
    np.ndarray,
    np.ndarray,
    Trajectory | None,
    Trajectory | None,
    dict[str, float | str],
    RobotParams | None,
]:
    """Stamps, wheel increments, ground truth, estimate, meta and (for wheel increments made
    from the robot's odometry) the parameters of an open bag."""
    topics = {c.topic: str(c.msgtype) for c in reader.connections}
    have = ", ".join(f"{c.topic} ({c.msgtype})" for c in reader.connections) or "none"
    meta: dict[str, float | str] = {"ticks_per_rev": o.ticks_per_rev}
    params: RobotParams | None = None
    est: Trajectory | None = None
    if o.joint_topic in topics or o.joint_topic != DEFAULT_JOINT_TOPIC:
        tt, dl, dr = _joint_increments(reader, p, o)
    else:
        odom_topic = o.odometry_topic or ODOMETRY_TOPIC
        if topics.get(odom_topic) != ODOMETRY_TYPE:
            raise LogFormatError(
                f"{p}: no wheel data: no {JOINT_TYPE} on {o.joint_topic!r} (wheel angles, the "
                f"encoder path) and no {ODOMETRY_TYPE} on {odom_topic!r} (the robot's own "
                f"odometry); the bag has {have}; expected one of them ({opt('joint_topic')})"
            )
        est = _poses(reader, p, odom_topic)
        params = _replay_params(o)
        dl, dr = increments_from_odometry(est, params)
        tt = est.t
        meta["wheels"] = (
            f"the robot's own odometry on {odom_topic!r} ({ODOMETRY_TYPE}) turned back into "
            f"wheel turns with {params.name}: not encoder counts (the bag has no {JOINT_TYPE})"
        )
    gt_topic = o.ground_truth_topic
    if (
        gt_topic not in topics
        and gt_topic == DEFAULT_GROUND_TRUTH_TOPIC
        and AMCL_TOPIC in topics
        and o.ground_truth is None
    ):
        gt_topic = AMCL_TOPIC
        meta["reference"] = (
            f"AMCL's pose on {AMCL_TOPIC!r} ({topics[AMCL_TOPIC]}): a localisation in the map, "
            "not motion capture"
        )
    gt = None
    if gt_topic in topics:
        gt = _poses(reader, p, gt_topic)
    elif o.ground_truth is None:
        meta["no_ground_truth"] = (
            f"no ground-truth topic {o.ground_truth_topic!r} in the bag; it has {have}"
        )
    if o.odometry_topic and est is None:
        est = _poses(reader, p, o.odometry_topic)
    return tt, dl, dr, gt, est, meta, params


def _joint_increments(
    reader: AnyReader, p: Path, o: ReadOptions
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stamps and wheel increments (ticks) of the JointState topic."""
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
    check_times(tt, f"{p}: topic {o.joint_topic!r}", row_offset=1, what="message")
    scale = o.ticks_per_rev / (2.0 * math.pi)
    dl = np.concatenate(([0.0], np.diff(np.unwrap(np.array(left))) * scale))
    dr = np.concatenate(([0.0], np.diff(np.unwrap(np.array(right))) * scale))
    return tt, dl, dr


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
        """A ROS 1 ``.bag`` file, a ROS 2 bag folder, or the bags inside a folder.

        Raises:
            LogFormatError: the path is missing, or a folder without ROS bags.
        """
        if path.is_file() or (path.is_dir() and (path / "metadata.yaml").is_file()):
            return [path]
        if not path.is_dir():
            raise LogFormatError(f"{path}: no such bag")
        bags = sorted(
            q
            for q in path.iterdir()
            if q.suffix in (".bag", ".mcap") or (q.is_dir() and (q / "metadata.yaml").is_file())
        )
        if not bags:
            raise LogFormatError(f"{path}: no ROS bags (*.bag or rosbag2 folders) in this folder")
        return bags

    def read(self, path: Path, options: ReadOptions) -> OdometryRun:
        """Read one bag."""
        return read_bag(path, options)

"""Write small ROS 1 / ROS 2 bags with rosbags' own writers (JointState + ground-truth poses)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from odolab.core.trajectory import Trajectory


def _stamp(types: dict, t: float):  # type: ignore[no-untyped-def]
    sec = math.floor(t)
    return types["builtin_interfaces/msg/Time"](sec=sec, nanosec=round((t - sec) * 1e9))


def write_bag(
    path: Path,
    t: np.ndarray,
    left_angle: np.ndarray,
    right_angle: np.ndarray,
    gt: Trajectory | None,
    *,
    ros1: bool = False,
    storage: str = "sqlite3",
    joint_names: tuple[str, str] = ("left_wheel_joint", "right_wheel_joint"),
    gt_topic: str = "/ground_truth",
    gt_as_odometry: bool = False,
    gt_quaternion: tuple[float, float, float, float] | None = None,
) -> Path:
    """A bag with /joint_states (JointState: wheel angles in rad) and PoseStamped ground truth
    (``gt_quaternion``: every pose's orientation (x, y, z, w) instead of the heading's)."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    ty = store.types
    Header = ty["std_msgs/msg/Header"]
    JointState = ty["sensor_msgs/msg/JointState"]
    PoseStamped = ty["geometry_msgs/msg/PoseStamped"]
    Pose = ty["geometry_msgs/msg/Pose"]
    Point = ty["geometry_msgs/msg/Point"]
    Quaternion = ty["geometry_msgs/msg/Quaternion"]

    def header(ti: float, seq: int):  # type: ignore[no-untyped-def]
        if ros1:
            return Header(seq=seq, stamp=_stamp(ty, ti), frame_id="odom")
        return Header(stamp=_stamp(ty, ti), frame_id="odom")

    msgs: list[tuple[str, str, float, object]] = []
    for k, ti in enumerate(t):
        js = JointState(
            header=header(float(ti), k),
            name=list(joint_names),
            position=np.array([left_angle[k], right_angle[k]], dtype=np.float64),
            velocity=np.zeros(0),
            effort=np.zeros(0),
        )
        msgs.append(("/joint_states", "sensor_msgs/msg/JointState", float(ti), js))
    if gt is not None:
        for k in range(len(gt)):
            h = 0.5 * float(gt.heading[k])
            ps = PoseStamped(
                header=header(float(gt.t[k]), k),
                pose=Pose(
                    position=Point(x=float(gt.x[k]), y=float(gt.y[k]), z=0.0),
                    orientation=(
                        Quaternion(x=0.0, y=0.0, z=math.sin(h), w=math.cos(h))
                        if gt_quaternion is None
                        else Quaternion(
                            x=gt_quaternion[0],
                            y=gt_quaternion[1],
                            z=gt_quaternion[2],
                            w=gt_quaternion[3],
                        )
                    ),
                ),
            )
            if gt_as_odometry:
                od = ty["nav_msgs/msg/Odometry"](
                    header=ps.header,
                    child_frame_id="base_link",
                    pose=ty["geometry_msgs/msg/PoseWithCovariance"](
                        pose=ps.pose, covariance=np.zeros(36)
                    ),
                    twist=ty["geometry_msgs/msg/TwistWithCovariance"](
                        twist=ty["geometry_msgs/msg/Twist"](
                            linear=ty["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                            angular=ty["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                        ),
                        covariance=np.zeros(36),
                    ),
                )
                msgs.append((gt_topic, "nav_msgs/msg/Odometry", float(gt.t[k]), od))
            else:
                msgs.append((gt_topic, "geometry_msgs/msg/PoseStamped", float(gt.t[k]), ps))
    msgs.sort(key=lambda m: m[2])
    if ros1:
        from rosbags.rosbag1 import Writer as Writer1

        with Writer1(path) as w1:
            conns = {
                topic: w1.add_connection(topic, typ, typestore=store)
                for topic, typ in {(m[0], m[1]) for m in msgs}
            }
            for topic, typ, ti, msg in msgs:
                w1.write(conns[topic], int(ti * 1e9), store.serialize_ros1(msg, typ))
        return path
    from rosbags.rosbag2 import StoragePlugin, Writer

    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plugin) as w:
        conns2 = {
            topic: w.add_connection(topic, typ, typestore=store)
            for topic, typ in sorted({(m[0], m[1]) for m in msgs})
        }
        for topic, typ, ti, msg in msgs:
            w.write(conns2[topic], int(ti * 1e9), store.serialize_cdr(msg, typ))
    return path

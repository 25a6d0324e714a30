"""odolab's CDR encoding (odolab.export.cdr, used by `odolab export mcap`) gives the bytes of
mcap-ros2-support's encoder, message by message, for the four message types odolab writes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from odolab.core.trajectory import Trajectory
from odolab.export.cdr import Layout
from odolab.export.mcap import OdometryStream, _encoded, _layouts, stamp_parts, yaw_quaternion

pytest.importorskip("mcap_ros2")
from mcap_ros2._dynamic import serialize_dynamic
from rosbags.typesys import Stores, get_typestore

STORE = get_typestore(Stores.ROS2_HUMBLE)
TYPES = {
    "/odom": "nav_msgs/msg/Odometry",
    "/joint_states": "sensor_msgs/msg/JointState",
    "/ground_truth": "geometry_msgs/msg/PoseStamped",
    "/tf": "tf2_msgs/msg/TFMessage",
}


def _encoder(msgtype: str):  # type: ignore[no-untyped-def]
    text, _ = STORE.generate_msgdef(msgtype, ros_version=2)
    return serialize_dynamic(msgtype, text)[msgtype]


ENCODERS = {topic: _encoder(t) for topic, t in TYPES.items()}


def _as_dicts(stream: OdometryStream, odom: str, base: str, start: float) -> dict[str, list]:  # type: ignore[type-arg]
    """The messages as mcap-ros2-support takes them (dicts of fields)."""
    traj = stream.odometry
    out: dict[str, list] = {k: [] for k in TYPES}  # type: ignore[type-arg]

    def header(t: float, frame: str) -> dict[str, object]:
        sec, nanosec = stamp_parts(t)
        return {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": frame}

    def quat(h: float) -> dict[str, float]:
        return dict(zip("xyzw", yaw_quaternion(h), strict=True))

    for i in range(len(traj)):
        t = float(traj.t[i]) + start
        pos = {"x": float(traj.x[i]), "y": float(traj.y[i]), "z": 0.0}
        out["/tf"].append({"transforms": [{"header": header(t, odom), "child_frame_id": base,
                           "transform": {"translation": pos, "rotation": quat(traj.heading[i])}}]})  # fmt: skip
        assert stream.wheel_angles is not None
        out["/joint_states"].append({
            "header": header(t, base), "name": list(stream.joint_names),
            "position": [float(v) for v in stream.wheel_angles[i]],
            "velocity": [0.25, -0.5] if i else [0.0, 0.0], "effort": [],
        })  # fmt: skip
    gt = stream.ground_truth
    assert gt is not None
    for i in range(len(gt)):
        t = float(gt.t[i]) + start
        out["/ground_truth"].append({"header": header(t, odom), "pose": {
            "position": {"x": float(gt.x[i]), "y": float(gt.y[i]), "z": 0.0},
            "orientation": quat(gt.heading[i])}})  # fmt: skip
    return out


frames = st.text(st.characters(codec="utf-8", exclude_characters="\0"), min_size=0, max_size=12)


@given(
    odom=frames,
    base=frames,
    joints=st.tuples(frames, frames),
    n=st.integers(1, 6),
    start=st.sampled_from([0.0, 0.999999999, 1.7e9 + 0.123456789]),
    seed=st.integers(0, 2**16),
)
def test_every_message_is_the_reference_encoders_bytes(
    odom: str, base: str, joints: tuple[str, str], n: int, start: float, seed: int
) -> None:
    """Frame and joint names of any length (each string moves what follows it off its
    alignment) and any UTF-8; stamps whose fraction rounds up to a whole second."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.0, 0.1, n))
    traj = Trajectory.from_xyh(t, rng.normal(size=n), rng.normal(size=n), rng.normal(size=n) * 4)
    gt = Trajectory.from_xyh(t + 0.01, rng.normal(size=n), rng.normal(size=n), rng.normal(size=n))
    wheels = rng.normal(size=(n, 2)) * 50
    stream = OdometryStream(traj, wheel_angles=wheels, ground_truth=gt, joint_names=joints)
    packed, order = _encoded(stream, start, odom, base)
    want = _as_dicts(stream, odom, base, start)
    # the joint speeds as the export computes them are checked by test_mcap.py; here the bytes:
    speeds = np.zeros((n, 2))
    speeds[1:] = [0.25, -0.5]
    layout = _layouts(stream, odom, base)["/joint_states"]
    sec = np.array([stamp_parts(v)[0] for v in t + start], dtype=np.int32)
    nano = np.array([stamp_parts(v)[1] for v in t + start], dtype=np.uint32)
    joint_bytes = layout.pack(
        n, {"sec": sec, "nanosec": nano, "position": wheels, "velocity": speeds}
    )
    for topic in ("/tf", "/ground_truth"):
        assert packed[topic] == [ENCODERS[topic](m) for m in want[topic]], topic
    assert joint_bytes == [ENCODERS["/joint_states"](m) for m in want["/joint_states"]]
    assert len(order) == 4 * n and sorted(ns for *_, ns in order) == [ns for *_, ns in order]


def test_odometry_with_covariances_is_the_reference_encoders_bytes() -> None:
    """/odom: the pose and twist covariances' 6x6 (the twist's variances floored), the twist."""
    rng = np.random.default_rng(3)
    n = 5
    traj = Trajectory.from_xyh(np.arange(n) * 0.05, rng.normal(size=n), rng.normal(size=n),
                               rng.normal(size=n))  # fmt: skip
    cov = rng.uniform(0, 1e-3, (n, 6))
    twist = rng.uniform(0, 2e-6, (n, 6))
    stream = OdometryStream(traj, covariance=cov, twist_covariance=twist, covariance_source="noise")
    packed, _ = _encoded(stream, 0.0, "odom", "base_link")
    from odolab.export.mcap import TWIST_VARIANCE_FLOOR, UNOBSERVED, _body_twist

    vx, vy, wz = _body_twist(traj)
    for i in range(n):
        c = [0.0] * 36
        w = [0.0] * 36
        for d in (2, 3, 4):
            c[d * 7] = w[d * 7] = UNOBSERVED
        xx, xy, xh, yy, yh, hh = cov[i]
        c[0], c[1], c[5], c[6], c[7], c[11], c[30], c[31], c[35] = (
            xx,
            xy,
            xh,
            xy,
            yy,
            yh,
            xh,
            yh,
            hh,
        )
        a, b, e, f, g, h = twist[i]
        fl = TWIST_VARIANCE_FLOOR
        w[0], w[1], w[5], w[6], w[7], w[11] = max(a, fl), b, e, b, max(f, fl), g
        w[30], w[31], w[35] = e, g, max(h, fl)
        sec, nanosec = stamp_parts(float(traj.t[i]))
        msg = {
            "header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": "odom"},
            "child_frame_id": "base_link",
            "pose": {"pose": {"position": {"x": traj.x[i], "y": traj.y[i], "z": 0.0},
                              "orientation": dict(zip("xyzw", yaw_quaternion(traj.heading[i]), strict=True))},
                     "covariance": c},
            "twist": {"twist": {"linear": {"x": vx[i], "y": vy[i], "z": 0.0},
                                "angular": {"x": 0.0, "y": 0.0, "z": wz[i]}}, "covariance": w},
        }  # fmt: skip
        assert packed["/odom"][i] == ENCODERS["/odom"](msg), i


def test_a_layout_refuses_missing_unknown_and_repeated_columns() -> None:
    layout = Layout().i32("sec").f64("x", 2)
    with pytest.raises(ValueError, match=r"missing \['x'\], unknown \['y'\]"):
        layout.pack(1, {"sec": 1, "y": 2.0})
    with pytest.raises(ValueError, match="given twice"):
        Layout().f64("x").f64("x")
    assert layout.pack(0, {"sec": 0, "x": 0.0}) == []
    assert layout.dtype.itemsize == 4 + 8 + 16  # the header, sec and its padding, two doubles

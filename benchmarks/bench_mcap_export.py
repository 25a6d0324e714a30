"""``odolab export mcap``'s encoding: odolab's column-by-column CDR (``odolab.export.cdr``)
against mcap-ros2-support's encoder (one message at a time from a dict, what the export used
before), on the same messages in the same run; the bytes are checked equal.

Prints the time of each for the /tf and /joint_states messages of a synthetic run and the
ratio (mcap-ros2-support / odolab; higher is better). Needs the ros extra.

Usage: python benchmarks/bench_mcap_export.py [--samples N] [--repeats R]
"""

from __future__ import annotations

import argparse

import numpy as np
from _timing import best  # benchmarks/_timing.py (run as python benchmarks/...)
from mcap_ros2._dynamic import serialize_dynamic
from rosbags.typesys import Stores, get_typestore

from odolab.core.trajectory import Trajectory
from odolab.export.mcap import OdometryStream, _encoded, stamp_parts, yaw_quaternion


def _encoder(msgtype: str):  # type: ignore[no-untyped-def]
    text, _ = get_typestore(Stores.ROS2_HUMBLE).generate_msgdef(msgtype, ros_version=2)
    return serialize_dynamic(msgtype, text)[msgtype]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=20_000)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    n = args.samples
    rng = np.random.default_rng(0)
    t = np.arange(n) * 0.05
    traj = Trajectory.from_xyh(t, np.cumsum(rng.normal(0, 0.01, n)),
                               np.cumsum(rng.normal(0, 0.01, n)), np.cumsum(rng.normal(0, 0.01, n)))  # fmt: skip
    wheels = np.cumsum(rng.normal(0, 0.1, (n, 2)), axis=0)
    stream = OdometryStream(traj, wheel_angles=wheels)
    tf, js = _encoder("tf2_msgs/msg/TFMessage"), _encoder("sensor_msgs/msg/JointState")

    def ours() -> dict[str, list[bytes]]:
        return _encoded(stream, 0.0, "odom", "base_link")[0]

    def dicts() -> dict[str, list[bytes]]:
        out: dict[str, list[bytes]] = {"/tf": [], "/joint_states": []}
        speeds = np.zeros((n, 2))
        speeds[1:] = np.diff(wheels, axis=0) / np.diff(t)[:, None]  # as the export
        for i in range(n):
            sec, nanosec = stamp_parts(float(t[i]))
            q = dict(zip("xyzw", yaw_quaternion(float(traj.heading[i])), strict=True))
            out["/tf"].append(tf({"transforms": [{
                "header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": "odom"},
                "child_frame_id": "base_link",
                "transform": {"translation": {"x": float(traj.x[i]), "y": float(traj.y[i]),
                                              "z": 0.0}, "rotation": q}}]}))  # fmt: skip
            out["/joint_states"].append(js({
                "header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": "base_link"},
                "name": list(stream.joint_names), "position": [float(v) for v in wheels[i]],
                "velocity": [float(v) for v in speeds[i]], "effort": [],
            }))  # fmt: skip
        return out

    a, b = ours(), dicts()
    assert a["/tf"] == b["/tf"] and a["/joint_states"] == b["/joint_states"], "bytes differ"
    t_ours = best(ours, args.repeats)  # also encodes /odom (the widest message): odolab's side
    t_dicts = best(dicts, args.repeats)  # encodes /tf and /joint_states only
    print(f"odolab, /odom + /tf + /joint_states ({3 * n:,} messages): {t_ours:.3f} s")
    print(f"mcap-ros2-support, /tf + /joint_states only ({2 * n:,} messages): {t_dicts:.3f} s")
    print(
        f"ratio mcap-ros2-support / odolab (odolab encoding 1.5x the messages): {t_dicts / t_ours:.1f}x"
    )


if __name__ == "__main__":
    main()

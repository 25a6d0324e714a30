"""Runs as ROS 2 MCAP files that Foxglove, PlotJuggler, Rerun, ``ros2 bag`` and rosbags open.

Topics (ROS 2 message types, CDR-encoded by :mod:`odolab.export.cdr` (the bytes
``mcap-ros2-support`` gives) and written with the ``mcap`` package; message definitions from
rosbags' ROS 2 Humble type store):

* ``/odom`` - ``nav_msgs/msg/Odometry``: the odometry pose (yaw as a quaternion about z), its
  propagated covariance (x, y, yaw rows/columns of the 6x6; z, roll, pitch get
  :data:`UNOBSERVED`), the body twist from consecutive poses and its full covariance from
  ``[noise]`` (forward, sideways and yaw rate, with their cross terms:
  :func:`odolab.core.uncertainty.twist_covariance`; the variances no smaller than
  :data:`TWIST_VARIANCE_FLOOR`, so an idle cycle is not taken as a perfect measurement by a
  filter that fuses it);
* ``/joint_states`` - ``sensor_msgs/msg/JointState``: the wheel angles (rad, unwrapped counters x
  2 pi / ticks_per_rev) and speeds;
* ``/ground_truth`` - ``geometry_msgs/msg/PoseStamped``: where the run has ground truth;
* ``/tf`` - ``tf2_msgs/msg/TFMessage``: ``odom -> base_link`` at every pose.

Stamps: the run's own times (seconds since its start, or whatever clock the log used) plus an
optional ``start_time`` offset. A campaign is one stream of segments (its trials): the first
message of each segment carries no motion (zero twist and wheel speeds), never the jump from
the previous trial's end to this one's start.
"""

from __future__ import annotations

import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odolab.core.errors import LogFormatError, OdolabError, opt
from odolab.core.kinematics import Method
from odolab.core.params import RobotParams, covariance_source
from odolab.core.trajectory import Trajectory
from odolab.core.writing import replacing_path
from odolab.export.cdr import Layout
from odolab.export.ros2_controller import UNOBSERVED

if TYPE_CHECKING:
    from odolab.io.run import OdometryRun
    from odolab.store import Notebook

__all__ = [
    "MAX_STAMP_S",
    "TOPICS",
    "TWIST_VARIANCE_FLOOR",
    "OdometryStream",
    "check_start_time",
    "first_order_notes",
    "stamp_parts",
    "stream_from_campaign",
    "stream_from_encoder_log",
    "stream_from_run",
    "stream_from_run_folder",
    "stream_from_trajectories",
    "write_mcap",
    "yaw_quaternion",
]

#: topic -> ROS 2 message type
TOPICS = {
    "/odom": "nav_msgs/msg/Odometry",
    "/joint_states": "sensor_msgs/msg/JointState",
    "/ground_truth": "geometry_msgs/msg/PoseStamped",
    "/tf": "tf2_msgs/msg/TFMessage",
}


@dataclass(frozen=True, eq=False)
class OdometryStream:
    """Everything one MCAP holds for one run (arrays of n samples, SI units).

    ``covariance``: (n, 6) in :data:`odolab.core.uncertainty.COV_COLUMNS` or None (written as zeros);
    ``twist_covariance``: (n, 6) in :data:`odolab.core.uncertainty.TWIST_COLUMNS` (forward,
    sideways speed, yaw rate) or None; ``wheel_angles``: (n, 2) left, right (rad) or None;
    ``ground_truth``: any stamps, or None; ``segment_starts``: the samples where a new segment
    (a campaign's trial) begins, which carry no motion from the previous one."""

    odometry: Trajectory
    covariance: NDArray[np.float64] | None = None
    twist_covariance: NDArray[np.float64] | None = None
    wheel_angles: NDArray[np.float64] | None = None
    ground_truth: Trajectory | None = None
    joint_names: tuple[str, str] = ("left_wheel_joint", "right_wheel_joint")
    segments: list[tuple[float, str]] = field(default_factory=list)
    segment_starts: tuple[int, ...] = ()
    #: where the covariance came from (:func:`odolab.core.params.covariance_source`: "noise",
    #: "slip"; None: no covariance)
    covariance_source: str | None = None


#: Smallest variance written for the forward and sideways speed ((m/s)**2) and the yaw rate
#: ((rad/s)**2) when the twist's covariance is known: (1 mm/s)**2 and (1 mrad/s)**2. An idle
#: cycle's propagated variance is exactly 0, which a filter fusing the twist (robot_localization
#: replaces it by 1e-9) takes as a perfect measurement.
TWIST_VARIANCE_FLOOR = 1e-6


#: Latest stamp (s) a message may carry: ROS 2 stamps keep whole seconds in an int32.
MAX_STAMP_S = float(2**31 - 1)


def stamp_parts(t: float) -> tuple[int, int]:
    """``(sec, nanosec)`` of a time ``t`` (s) as ROS 2 and Foxglove stamps hold it
    (``0 <= nanosec < 1e9``; a fraction that rounds up to a whole second carries into ``sec``)."""
    sec = math.floor(t)
    nanosec = round((t - sec) * 1e9)
    if nanosec >= 1_000_000_000:
        sec += 1
        nanosec -= 1_000_000_000
    return int(sec), int(nanosec)


def _stamps(t: NDArray[np.float64]) -> tuple[NDArray[np.int32], NDArray[np.uint32]]:
    """:func:`stamp_parts` of every time in ``t``: the same numbers (round half to even)."""
    sec = np.floor(t)
    nanosec = np.round((t - sec) * 1e9)
    carry = nanosec >= 1e9
    sec[carry] += 1.0
    nanosec[carry] -= 1e9
    return sec.astype(np.int32), nanosec.astype(np.uint32)


def yaw_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """``(x, y, z, w)`` of the rotation by ``yaw`` (rad) about z."""
    return 0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw)


def _quats(yaw: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`yaw_quaternion` of every yaw, shape (n, 4) (libm's sin and cos, as it)."""
    half = [0.5 * h for h in yaw.tolist()]
    q = np.zeros((yaw.size, 4))
    q[:, 2] = [math.sin(a) for a in half]
    q[:, 3] = [math.cos(a) for a in half]
    return q


#: where the x, y and yaw terms go in a row-major 6x6 (x, y, z, roll, pitch, yaw): the pose
#: covariance's (xx, xy, xh, yy, yh, hh) and the twist's (vx, vy, wz) alike
_SIX = {0: (0,), 1: (1, 6), 2: (5, 30), 3: (7,), 4: (11, 31), 5: (35,)}
_UNOBSERVED_DIAGONAL = (14, 21, 28)  # z, roll, pitch


def _cov36(
    terms: NDArray[np.float64] | None, n: int, floor: float | None = None
) -> NDArray[np.float64]:
    """The (n, 36) row-major 6x6 covariances from (n, 6) terms (None: zeros), z, roll and pitch
    :data:`UNOBSERVED`; ``floor``: the smallest variance written (the twist's)."""
    c = np.zeros((n, 36))
    c[:, _UNOBSERVED_DIAGONAL] = UNOBSERVED
    if terms is None:
        return c
    for k, cells in _SIX.items():
        col = np.asarray(terms[:, k], dtype=np.float64)
        if floor is not None and k in (0, 3, 5):
            col = np.where(col < floor, floor, col)  # max(v, floor), NaN kept as max() keeps it
        for cell in cells:
            c[:, cell] = col
    return c


def _body_twist(
    traj: Trajectory,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Forward, sideways and yaw rate over each cycle (the first sample: 0): the displacement
    in the body frame at the cycle's middle heading, which is the direction of the pose step's
    chord (``heading + dtheta / 2``), so a turn's speed is not shortened by ``cos(dtheta / 2)``."""
    n = len(traj)
    vx = np.zeros(n)
    vy = np.zeros(n)
    wz = np.zeros(n)
    if n > 1:
        dt = np.diff(traj.t)
        ok = dt > 0
        safe = np.where(ok, dt, 1.0)
        dx, dy, dh = np.diff(traj.x), np.diff(traj.y), np.diff(traj.heading)
        m = traj.heading[:-1] + 0.5 * dh
        c, s = np.cos(m), np.sin(m)
        vx[1:] = np.where(ok, (dx * c + dy * s) / safe, 0.0)
        vy[1:] = np.where(ok, (dy * c - dx * s) / safe, 0.0)
        wz[1:] = np.where(ok, dh / safe, 0.0)
    return vx, vy, wz


def _layouts(stream: OdometryStream, odom_frame: str, base_frame: str) -> dict[str, Layout]:
    """Each topic's CDR layout (:mod:`odolab.export.cdr`), in the order of its message
    definition (rosbags' ROS 2 Humble type store)."""

    def header(frame: str) -> Layout:  # std_msgs/Header
        return Layout().i32("sec").u32("nanosec").string(frame)

    left, right = stream.joint_names
    return {
        "/odom": header(odom_frame).string(base_frame)  # child_frame_id
        .f64("position", 3).f64("orientation", 4).f64("pose_covariance", 36)
        .f64("linear", 3).f64("angular", 3).f64("twist_covariance", 36),
        "/tf": Layout().count(1)  # one TransformStamped
        .i32("sec").u32("nanosec").string(odom_frame).string(base_frame)
        .f64("translation", 3).f64("rotation", 4),
        "/joint_states": header(base_frame).count(2).string(left).string(right)
        .count(2).f64("position", 2).count(2).f64("velocity", 2).count(0),  # no effort
        "/ground_truth": header(odom_frame).f64("position", 3).f64("orientation", 4),
    }  # fmt: skip


def _xyz(traj: Trajectory) -> NDArray[np.float64]:
    return np.stack([traj.x, traj.y, np.zeros(len(traj))], axis=1)


# long: the four message streams (odometry, TF, joint states, ground truth) encoded together, so
# that their stamps and frames cannot drift apart
def _encoded(
    stream: OdometryStream, start_time: float, odom_frame: str, base_frame: str
) -> tuple[dict[str, list[bytes]], list[tuple[str, int, int]]]:
    """Every message's CDR bytes per topic, and the order to write them: (topic, index, stamp
    in ns) by time, stable: at each odometry sample /odom, /tf, /joint_states, and the ground
    truth after the odometry at the same stamp."""
    traj = stream.odometry
    n = len(traj)
    layouts = _layouts(stream, odom_frame, base_frame)
    vx, vy, wz = _body_twist(traj)
    speeds = None
    if stream.wheel_angles is not None:
        speeds = np.zeros_like(stream.wheel_angles)
        if n > 1:
            dt = np.diff(traj.t)[:, None]
            speeds[1:] = np.where(
                dt > 0, np.diff(stream.wheel_angles, axis=0) / np.where(dt > 0, dt, 1), 0
            )
    starts = [i for i in stream.segment_starts if 0 <= i < n]
    for arr in (vx, vy, wz, speeds):  # a segment's first sample: no motion across its start
        if arr is not None:
            arr[starts] = 0.0
    t = traj.t + start_time
    sec, nanosec = _stamps(t)
    xyz, quat = _xyz(traj), _quats(traj.heading)
    zeros = np.zeros(n)
    packed = {
        "/odom": layouts["/odom"].pack(n, {
            "sec": sec, "nanosec": nanosec, "position": xyz, "orientation": quat,
            "pose_covariance": _cov36(stream.covariance, n),
            "linear": np.stack([vx, vy, zeros], axis=1),
            "angular": np.stack([zeros, zeros, wz], axis=1),
            "twist_covariance": _cov36(stream.twist_covariance, n, TWIST_VARIANCE_FLOOR),
        }),
        "/tf": layouts["/tf"].pack(n, {
            "sec": sec, "nanosec": nanosec, "translation": xyz, "rotation": quat,
        }),
    }  # fmt: skip
    topics = ["/odom", "/tf"]
    if stream.wheel_angles is not None and speeds is not None:
        packed["/joint_states"] = layouts["/joint_states"].pack(n, {
            "sec": sec, "nanosec": nanosec, "position": stream.wheel_angles, "velocity": speeds,
        })  # fmt: skip
        topics.append("/joint_states")
    k = len(topics)
    times = [np.repeat(t, k)]
    which = [np.tile(np.arange(k), n)]
    index = [np.repeat(np.arange(n), k)]
    gt = stream.ground_truth
    if gt is not None and len(gt):
        tg = gt.t + start_time
        gsec, gnano = _stamps(tg)
        packed["/ground_truth"] = layouts["/ground_truth"].pack(len(gt), {
            "sec": gsec, "nanosec": gnano, "position": _xyz(gt), "orientation": _quats(gt.heading),
        })  # fmt: skip
        topics.append("/ground_truth")
        times.append(tg)
        which.append(np.full(len(gt), k))
        index.append(np.arange(len(gt)))
    all_t = np.concatenate(times)
    order = np.argsort(all_t, kind="stable")
    ns = np.round(all_t[order] * 1e9).astype(np.int64).tolist()
    names = [topics[w] for w in np.concatenate(which)[order].tolist()]
    return packed, list(zip(names, np.concatenate(index)[order].tolist(), ns, strict=True))


def first_order_notes(stream: OdometryStream) -> list[str]:
    """Where the stream's propagated covariance stops holding to first order
    (:func:`odolab.core.uncertainty.first_order_note`), per segment (a campaign's trial starts its
    covariance again), each sentence prefixed by the segment's name when there are several."""
    from odolab.core.uncertainty import first_order_note

    if stream.covariance is None or stream.covariance_source == "slip":
        return []  # the slip model's covariance has its second-order share (slip_uncertainty)
    traj = stream.odometry
    bounds = [*sorted(set(stream.segment_starts) | {0}), len(traj)]
    names = [name for _, name in stream.segments]
    notes = []
    for j, (a, b) in enumerate(itertools.pairwise(bounds)):
        if b - a < 2:
            continue
        part = Trajectory.from_xyh(traj.t[a:b], traj.x[a:b], traj.y[a:b], traj.heading[a:b])
        note = first_order_note(part, stream.covariance[a:b])
        if note:
            where = f"{names[j]}: " if len(bounds) > 2 and j < len(names) else ""
            notes.append(where + note)
    return notes


def write_mcap(
    path: str | Path,
    stream: OdometryStream,
    *,
    start_time: float = 0.0,
    odom_frame: str = "odom",
    base_frame: str = "base_link",
) -> dict[str, int]:
    """Write ``stream`` as a ROS 2 MCAP file; returns the message count per topic."""
    from mcap.writer import LIBRARY_IDENTIFIER, CompressionType, Writer
    from rosbags.typesys import Stores, get_typestore

    from odolab import __version__

    check_start_time(start_time)
    p = Path(path)
    if p.is_dir():
        raise OdolabError(f"{p}: is a folder; expected an .mcap file name")
    _check_stamps(stream, start_time)
    store = get_typestore(Stores.ROS2_HUMBLE)
    counts = dict.fromkeys(TOPICS, 0)
    packed, order = _encoded(stream, start_time, odom_frame, base_frame)
    # the file appears whole, or not at all; a link at p is replaced, not followed
    with (
        replacing_path(p, what="MCAP file", error=OdolabError) as tmp,
        tmp.open("wb") as fh,
    ):
        writer = Writer(fh, compression=CompressionType.LZ4)
        writer.start(profile="ros2", library=f"{LIBRARY_IDENTIFIER} odolab/{__version__}")
        schemas = {}
        for topic, msgtype in TOPICS.items():
            text, _ = store.generate_msgdef(msgtype, ros_version=2)
            schemas[topic] = writer.register_schema(msgtype, "ros2msg", text.encode())
        channels: dict[str, int] = {}
        for topic, i, ns in order:
            if topic not in channels:  # in the order topics first appear
                channels[topic] = writer.register_channel(topic, "cdr", schemas[topic])
            writer.add_message(
                channel_id=channels[topic], log_time=ns, data=packed[topic][i], publish_time=ns
            )
            counts[topic] += 1
        writer.finish()  # type: ignore[no-untyped-call]
    return {k: v for k, v in counts.items() if v}


def check_start_time(start_time: float) -> float:
    """``start_time`` (s) if it is a finite number from 0 to :data:`MAX_STAMP_S`; else one
    sentence naming ``--start-time``."""
    if not math.isfinite(start_time) or not 0 <= start_time <= MAX_STAMP_S:
        raise OdolabError(
            f"{opt('start_time')} is {start_time!r}; expected a number of seconds from 0 to "
            f"{MAX_STAMP_S:.0f} (a ROS 2 stamp holds its seconds in an int32)"
        )
    return float(start_time)


def _check_stamps(stream: OdometryStream, start_time: float) -> None:
    """Every stamp (+ ``start_time``) must be a finite time from 0 to :data:`MAX_STAMP_S`."""
    for what, traj in (("odometry", stream.odometry), ("ground truth", stream.ground_truth)):
        if traj is None or len(traj) == 0:
            continue
        first, last = float(np.min(traj.t)) + start_time, float(np.max(traj.t)) + start_time
        if not (math.isfinite(first) and math.isfinite(last)) or first < 0 or last > MAX_STAMP_S:
            raise OdolabError(
                f"the {what}'s times with the start time run from {first!r} to {last!r} s; a ROS 2 "
                f"MCAP needs stamps from 0 to {MAX_STAMP_S:.0f} s (give {opt('start_time')} to shift them)"
            )


def stream_from_encoder_log(
    t: NDArray[np.float64],
    left_ticks: NDArray[np.int64],
    right_ticks: NDArray[np.int64],
    params: RobotParams,
    method: Method | str = Method.MIDPOINT,
    *,
    ground_truth: Trajectory | None = None,
    source: str = "encoder log",
) -> OdometryStream:
    """Odometry, its covariance (:func:`odolab.core.params.covariance_source`: the ``[noise]``
    table's, or a slip model's own) and wheel angles from counters."""
    from odolab.core.encoders import unwrap_ticks
    from odolab.core.odometry import integrate, integrate_with_covariance

    cov = twist = None
    source_of_cov = covariance_source(params)
    if source_of_cov == "noise":
        traj, cov = integrate_with_covariance(
            t, left_ticks, right_ticks, params, method, source=source
        )
    else:
        traj = integrate(t, left_ticks, right_ticks, params, method, source=source)
    m = params.encoder_modulus
    ul = unwrap_ticks(left_ticks, m, name="left_ticks")
    ur = unwrap_ticks(right_ticks, m, name="right_ticks")
    dl = np.diff(ul, prepend=ul[0]).astype(np.float64)
    dr = np.diff(ur, prepend=ur[0]).astype(np.float64)
    if source_of_cov == "noise":
        twist = _twist_from_increments(traj.t, dl, dr, params)
    elif source_of_cov is not None:  # the model's own (the slip model's)
        cov, twist = _slip_covariances(traj.t, dl, dr, params)
    scale = 2.0 * math.pi / params.ticks_per_rev
    angles = np.stack([(ul - ul[0]) * scale, (ur - ur[0]) * scale], axis=1)
    return OdometryStream(
        traj, cov, twist, angles, ground_truth,
        covariance_source=source_of_cov if cov is not None else None,
    )  # fmt: skip


def stream_from_run_folder(
    folder: str | Path, params: RobotParams | None = None, method: Method | str = Method.MIDPOINT
) -> OdometryStream:
    """A robot run folder (``run.json`` + ``encoders.csv``, as ``odolab robot`` saves it) with
    ``params`` (default: the parameters recorded in ``run.json``)."""
    from odolab.core.params import params_from_mapping
    from odolab.io import read_encoder_csv

    f = Path(folder)
    meta = f / "run.json"
    try:
        doc = json.loads(meta.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as err:
        raise LogFormatError(
            f"{meta}: cannot read ({getattr(err, 'strerror', None) or err})"
        ) from err
    except RecursionError as err:
        raise LogFormatError(
            f"{meta}: JSON nested too deeply to read; expected the run.json odolab robot writes"
        ) from err
    except json.JSONDecodeError as err:
        raise LogFormatError(
            f"{meta}: line {err.lineno}, column {err.colno}: not valid JSON ({err.msg})"
        ) from err
    if params is None:
        if not isinstance(doc, dict) or not isinstance(doc.get("params"), dict):
            raise LogFormatError(
                f"{meta}: no 'params' object (the robot's parameters); give {opt('params')}"
            )
        params = params_from_mapping(doc["params"], source=str(meta))
    enc = read_encoder_csv(f / "encoders.csv", modulus=params.encoder_modulus)
    return stream_from_encoder_log(
        enc.t, enc.left_ticks, enc.right_ticks, params, method, source=str(f)
    )


def _twist_from_increments(
    t: NDArray[np.float64], dl: ArrayLike, dr: ArrayLike, params: RobotParams
) -> NDArray[np.float64]:
    """Per-sample twist covariance (:data:`odolab.core.uncertainty.TWIST_COLUMNS`) from counter
    increments (``[0]`` ignored: the first sample has no cycle behind it) and ``[noise]``."""
    from odolab.core.uncertainty import twist_covariance

    dsl = np.asarray(dl, dtype=np.float64) * params.left_metres_per_tick
    dsr = np.asarray(dr, dtype=np.float64) * params.right_metres_per_tick
    dt = np.diff(np.asarray(t, dtype=np.float64), prepend=np.nan)
    dt[0] = 0.0  # no cycle before the first sample: zeros (written as the floor)
    return twist_covariance(dt, dsl, dsr, params)


def stream_from_trajectories(
    estimate: Trajectory, ground_truth: Trajectory | None = None
) -> OdometryStream:
    """An evaluation (estimate and ground truth trajectories) as a stream (no covariance)."""
    if len(estimate) == 0:
        raise LogFormatError("the estimate has no poses")
    return OdometryStream(estimate, ground_truth=ground_truth)


def stream_from_run(
    run: OdometryRun, params: RobotParams | None = None, method: Method | str = Method.MIDPOINT
) -> OdometryStream:
    """A recorded run (increments, optional ground truth) with ``params`` (default its own)."""
    from odolab.core.odometry import integrate_increments
    from odolab.core.uncertainty import propagate_covariance

    p = params or run.params
    if p is None:
        raise OdolabError(f"{run.source}: the run carries no parameters; give {opt('params')}")
    traj = integrate_increments(run.t, run.dticks_left, run.dticks_right, p, method)
    cov = twist = None
    dl = np.asarray(run.dticks_left, dtype=np.float64).copy()
    dr = np.asarray(run.dticks_right, dtype=np.float64).copy()
    dl[0] = dr[0] = 0.0
    source = covariance_source(p)
    if source == "noise":
        cov = propagate_covariance(run.dticks_left, run.dticks_right, p, method)
        twist = _twist_from_increments(traj.t, dl, dr, p)
    elif source is not None:  # the model's own (the slip model's)
        cov, twist = _slip_covariances(traj.t, dl, dr, p)
    scale = 2.0 * math.pi / p.ticks_per_rev
    angles = np.stack([np.cumsum(dl) * scale, np.cumsum(dr) * scale], axis=1)
    return OdometryStream(
        traj, cov, twist, angles, run.ground_truth,
        covariance_source=source if cov is not None else None,
    )  # fmt: skip


def _slip_covariances(
    t: NDArray[np.float64], dl: NDArray[np.float64], dr: NDArray[np.float64], p: RobotParams
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The slip model's pose covariance (n, 6 in COV_COLUMNS; :mod:`odolab.core.slip_uncertainty`)
    and its twist covariance (n, 6 in TWIST_COLUMNS): each cycle's body-motion variance
    (:meth:`SlipModel.step_variance`: white noise and posterior; the drift is not a cycle's
    own) over its duration squared."""
    from odolab.core.models import own_covariance

    model = own_covariance(p.model)
    assert model is not None
    _, full = model.propagate_covariance(t, dl, dr, p)
    pose = full[:, [0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]
    dsl, dsr = dl * p.left_metres_per_tick, dr * p.right_metres_per_tick
    dt = np.diff(t, prepend=t[:1])
    tick = 0.5 * (p.left_metres_per_tick + p.right_metres_per_tick)
    var = model.step_variance(dsl, dsr, dt, p.track_width, tick / p.track_width)
    rate = np.where(dt > 0, 1.0 / np.where(dt > 0, dt, 1.0) ** 2, 0.0)
    twist = np.zeros((t.size, 6))
    twist[:, [0, 3, 5]] = var * rate[:, None]
    return np.asarray(pose, dtype=np.float64), twist


def stream_from_campaign(
    notebook: Notebook,
    campaign: str,
    params: RobotParams | None = None,
    method: Method | str = Method.MIDPOINT,
    *,
    gap: float = 1.0,
) -> OdometryStream:
    """Every recorded trial of ``campaign``, one after the other (each from the origin, ``gap``
    seconds apart), with its own parameters unless ``params`` is given."""
    names = notebook.campaign_names()
    if campaign not in names:
        known = ", ".join(sorted(names)) or "none"
        raise OdolabError(f"no campaign {campaign!r} in {notebook.path}; its campaigns: {known}")
    trials = [tr for tr in notebook.load_trials(campaign=campaign) if tr.encoder_log is not None]
    if not trials:
        raise OdolabError(
            f"campaign {campaign!r} has no trial with an encoder log in {notebook.path}"
        )
    parts: list[OdometryStream] = []
    offset = 0.0
    marks: list[tuple[float, str]] = []
    starts: list[int] = []
    n = 0
    for tr in trials:
        log = tr.encoder_log
        assert log is not None
        p = params or tr.params
        t = np.asarray(log.t, dtype=np.float64)
        s = stream_from_encoder_log(
            t - t[0] + offset, log.left_ticks, log.right_ticks, p, method, source=tr.trial_id
        )
        parts.append(s)
        marks.append((offset, tr.trial_id))
        starts.append(n)
        n += len(s.odometry)
        offset = float(s.odometry.t[-1]) + gap
    cat = np.concatenate

    def opt(arrays: list[NDArray[np.float64] | None]) -> NDArray[np.float64] | None:
        return None if any(a is None for a in arrays) else cat([a for a in arrays if a is not None])

    traj = Trajectory(
        cat([s.odometry.t for s in parts]),
        cat([s.odometry.x for s in parts]),
        cat([s.odometry.y for s in parts]),
        cat([s.odometry.theta for s in parts]),
        cat([s.odometry.heading for s in parts]),
    )
    return OdometryStream(
        traj,
        opt([s.covariance for s in parts]),
        opt([s.twist_covariance for s in parts]),
        opt([s.wheel_angles for s in parts]),
        None,
        segments=marks,
        segment_starts=tuple(starts),
        covariance_source=(
            parts[0].covariance_source if len({s.covariance_source for s in parts}) == 1 else None
        ),
    )

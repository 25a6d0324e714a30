"""A live run in Foxglove: poses, transforms and covariance over Foxglove's WebSocket protocol.

:class:`FoxgloveLive` starts a ``foxglove-sdk`` WebSocket server (default ``127.0.0.1:8765``)
and publishes, for every control cycle it is given:

* ``/odom_pose`` - ``foxglove.PoseInFrame`` in frame ``odom``;
* ``/tf`` - ``foxglove.FrameTransforms``: ``odom -> base_link``;
* ``/odolab/cycle`` - JSON: t, x, y, heading, the raw counters and, when known, the six
  covariance terms (``cov_xx ... cov_hh``).

Every message is logged at the pose's own time (the run's clock: simulated time on the virtual
Jaguar).

Open Foxglove, "Open connection", ``ws://127.0.0.1:8765``. The protocol has no authentication,
so the server only binds to a loopback address; to watch from another machine, forward the port
(``ssh -L 8765:127.0.0.1:8765 robot-laptop``).
"""

from __future__ import annotations

import ipaddress
import math

from odolab.core.closing import Closing
from odolab.core.errors import OdolabError, opt
from odolab.core.trajectory import Pose

__all__ = ["FoxgloveLive", "check_loopback", "check_port"]


def check_port(port: object) -> int:
    """``port`` if it is a port number 0..65535 (0: any free one, said when it listens);
    otherwise one sentence (a long number shown shortened).

    Raises:
        OdolabError: the port is not a whole number from 0 to 65535.
    """
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        from odolab.core.text import quote_input

        raise OdolabError(
            f"{opt('foxglove_port')} is {quote_input(port, 40)}; expected a port number 0..65535 "
            "(0: any free one)"
        )
    return port


def check_loopback(host: str) -> str:
    """``host`` if it is a loopback address or ``localhost``; otherwise one sentence why not.

    Raises:
        OdolabError: the host is not a loopback address.
    """
    if host == "localhost":
        return "127.0.0.1"
    try:
        ok = ipaddress.ip_address(host).is_loopback
    except ValueError:
        ok = False
    if not ok:
        raise OdolabError(
            f"{opt('foxglove_host')} {host!r} is not a loopback address: Foxglove's WebSocket protocol "
            "has no authentication, so odolab serves it on 127.0.0.1 only; forward the port "
            "(ssh -L 8765:127.0.0.1:8765 ...) to watch from elsewhere"
        )
    return host


class FoxgloveLive(Closing):
    """Publish a live run to Foxglove (see the module docstring). Use as a context manager."""

    def __init__(self, host: str = "127.0.0.1", port: int = 8765) -> None:
        import foxglove
        from foxglove.channels import FrameTransformsChannel, PoseInFrameChannel

        check_port(port)
        host = check_loopback(host)
        self._ctx = foxglove.Context()
        try:
            self._server = foxglove.start_server(
                name="odolab", host=host, port=port, context=self._ctx
            )
        except Exception as err:  # the SDK raises its own error types (port in use, ...)
            raise OdolabError(
                f"{opt('foxglove_port')} {port}: cannot serve Foxglove on {host}:{port} ({err}); choose "
                "another port"
            ) from err
        self._pose = PoseInFrameChannel("/odom_pose", context=self._ctx)
        self._tf = FrameTransformsChannel("/tf", context=self._ctx)
        self._cycle = foxglove.Channel("/odolab/cycle", message_encoding="json", context=self._ctx)

    @property
    def port(self) -> int:
        """The port the server listens on (useful with ``port=0``)."""
        return int(self._server.port)

    def publish(
        self,
        pose: Pose,
        *,
        ticks: tuple[int, int] | None = None,
        covariance: tuple[float, ...] | None = None,
    ) -> None:
        """One control cycle's pose (and counters, covariance) at the pose's time."""
        from foxglove.messages import (
            FrameTransform,
            FrameTransforms,
            PoseInFrame,
            Quaternion,
            Timestamp,
            Vector3,
        )
        from foxglove.messages import (
            Pose as FgPose,
        )

        from odolab.export.mcap import MAX_STAMP_S, stamp_parts, yaw_quaternion

        if not (math.isfinite(pose.t) and 0 <= pose.t <= MAX_STAMP_S):
            return  # no stamp can hold it
        stamp = Timestamp(*stamp_parts(pose.t))
        qx, qy, qz, qw = yaw_quaternion(pose.heading)
        q = Quaternion(x=qx, y=qy, z=qz, w=qw)
        pos = Vector3(x=pose.x, y=pose.y, z=0.0)
        ns = round(pose.t * 1e9)
        self._pose.log(
            PoseInFrame(timestamp=stamp, frame_id="odom", pose=FgPose(position=pos, orientation=q)),
            log_time=ns,
        )
        tf = FrameTransform(
            timestamp=stamp, parent_frame_id="odom", child_frame_id="base_link",
            translation=pos, rotation=q,
        )  # fmt: skip
        self._tf.log(FrameTransforms(transforms=[tf]), log_time=ns)
        doc: dict[str, object] = {"t": pose.t, "x": pose.x, "y": pose.y, "heading": pose.heading}
        if ticks is not None:
            doc["left_ticks"], doc["right_ticks"] = int(ticks[0]), int(ticks[1])
        if covariance is not None:
            from odolab.core.uncertainty import COV_COLUMNS

            doc.update({k: float(v) for k, v in zip(COV_COLUMNS, covariance, strict=True)})
        self._cycle.log(doc, log_time=ns)

    def close(self) -> None:
        """Stop the server."""
        self._server.stop()

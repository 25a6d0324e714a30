"""Foxglove live: a WebSocket client on loopback receives what a run publishes."""

from __future__ import annotations

import json
import struct

import pytest
from tests.worded import raises_worded
from websockets.sync.client import connect

from odolab.core.errors import OdolabError
from odolab.core.trajectory import Pose
from odolab.export.foxglove import FoxgloveLive, check_loopback

PROTOCOL = "foxglove.sdk.v1"  # foxglove-sdk 0.30 (the earlier foxglove.websocket.v1 is gone)


def _advertised(ws) -> dict[str, int]:  # type: ignore[no-untyped-def]
    channels: dict[str, int] = {}
    while len(channels) < 3:
        msg = json.loads(ws.recv(timeout=5))
        if msg.get("op") == "advertise":
            channels.update({c["topic"]: c["id"] for c in msg["channels"]})
    return channels


def test_a_client_receives_the_cycle() -> None:
    with (
        FoxgloveLive(port=0) as live,
        connect(f"ws://127.0.0.1:{live.port}", subprotocols=[PROTOCOL], open_timeout=5) as ws,
    ):
        channels = _advertised(ws)
        assert set(channels) == {"/odom_pose", "/tf", "/odolab/cycle"}
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": 7, "channelId": channels["/odolab/cycle"]}]}))  # fmt: skip
        got = None
        for _ in range(50):  # the subscription takes effect asynchronously: publish until heard
            live.publish(
                Pose(1.25, 0.5, -0.25, 0.1, 0.1), ticks=(12, 34), covariance=(1, 0, 0, 2, 0, 3)
            )
            try:
                frame = ws.recv(timeout=0.1)
            except TimeoutError:
                continue
            if isinstance(frame, bytes) and frame[0] == 1:
                got = frame
                break
        assert got is not None
        sub, stamp = struct.unpack_from("<IQ", got, 1)
        assert sub == 7
        assert stamp == 1_250_000_000
        doc = json.loads(got[13:])
        assert doc["x"] == 0.5 and doc["left_ticks"] == 12 and doc["cov_yy"] == 2.0


def test_only_loopback() -> None:
    assert check_loopback("127.0.0.1") == "127.0.0.1"
    assert check_loopback("localhost") == "127.0.0.1"
    with pytest.raises(OdolabError, match="is not a loopback address"):
        check_loopback("0.0.0.0")
    with pytest.raises(OdolabError, match="is not a loopback address"):
        FoxgloveLive(host="192.168.1.5", port=0)


def _varint(buf: bytes, i: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        b = buf[i]
        value |= (b & 0x7F) << shift
        i += 1
        shift += 7
        if not b & 0x80:
            return value, i


def _stamp_of(pose_in_frame: bytes) -> tuple[int, int]:
    """(sec, nsec) of an encoded foxglove.PoseInFrame (protobuf: field 1 = Timestamp)."""
    assert pose_in_frame[0] == 0x0A  # field 1, length-delimited
    n, i = _varint(pose_in_frame, 1)
    body = pose_in_frame[i : i + n]
    fields = {1: 0, 2: 0}
    j = 0
    while j < len(body):
        key, j = _varint(body, j)
        fields[key >> 3], j = _varint(body, j)
    return fields[1], fields[2]


class _Recorder:
    def __init__(self) -> None:
        self.logged: list[tuple[bytes, int]] = []

    def log(self, msg: object, log_time: int) -> None:
        self.logged.append((msg.encode(), log_time))  # type: ignore[attr-defined]


@pytest.mark.parametrize(
    ("t", "stamp"),
    [(1.25, (1, 250_000_000)), (0.9999999999, (1, 0)), (41.99999999995, (42, 0))],
)
def test_a_fraction_that_rounds_up_carries_into_the_seconds(
    t: float, stamp: tuple[int, int]
) -> None:
    # the stamp was (0, 0) for t = 0.9999999999: the nanoseconds wrapped, the second was lost
    with FoxgloveLive(port=0) as live:
        rec = _Recorder()
        live._pose = rec  # type: ignore[assignment]
        live.publish(Pose(t, 0.5, -0.25, 0.1, 0.1))
    assert _stamp_of(rec.logged[0][0]) == stamp
    assert rec.logged[0][1] == round(t * 1e9)


def test_a_port_in_use_is_one_sentence() -> None:
    import socket

    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        with raises_worded(OdolabError, match=rf"--foxglove-port {port}: cannot serve Foxglove"):
            FoxgloveLive(port=port)


def test_robot_drive_serves_the_live_run(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """`odolab robot drive --foxglove` on the virtual Jaguar: a client hears every cycle."""
    import socket
    import threading

    from odolab.cli import main
    from odolab.core.params import PRESETS, NoiseParams, save_params

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    params = save_params(
        tmp_path / "p.toml", PRESETS["jaguar-lite"].with_(noise=NoiseParams(1e-4, 1e-4))
    )
    heard: list[dict[str, float]] = []
    ready = threading.Event()

    def listen() -> None:
        for _ in range(200):  # until the CLI's server is up
            try:
                ws = connect(f"ws://127.0.0.1:{port}", subprotocols=[PROTOCOL], open_timeout=1)
                break
            except OSError:
                import time

                time.sleep(0.05)
        else:
            ready.set()
            return
        with ws:
            channels = _advertised(ws)
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": 1, "channelId": channels["/odolab/cycle"]}]}))  # fmt: skip
            ready.set()
            while True:
                try:
                    frame = ws.recv(timeout=5)
                except Exception:
                    return
                if isinstance(frame, bytes) and frame[0] == 1:
                    heard.append(json.loads(frame[13:]))

    thread = threading.Thread(target=listen, daemon=True)
    thread.start()
    code = main(
        ["robot", "drive", "--distance", "1.0", "--speed", "0.2", "--quiet", "--params",
         str(params), "--out", str(tmp_path / "run"), "--foxglove", "--foxglove-port", str(port),
         "--truth", "ideal", "--no-realtime"]
    )  # fmt: skip
    thread.join(timeout=10)
    assert code == 0
    assert heard, "the Foxglove client heard nothing"
    last = heard[-1]
    assert {"x", "left_ticks", "cov_xx", "cov_hh"} <= set(last)
    assert last["cov_xx"] > 0

"""Interoperability with code written only from JAGUAR_PROTOCOL.md (raw sockets and struct).

A hand-rolled client drives odolab's virtual Jaguar, and odolab's driver drives a hand-rolled
board; neither side uses odolab's codec. Loopback only, OS-assigned ports, bounded waits.
"""

from __future__ import annotations

import select
import socket
import struct
import threading
import time

import pytest

from odolab.core.odometry import Odometry
from odolab.core.params import PRESETS
from odolab.robot.clock import RealClock
from odolab.robot.jaguar.board import BoardConfig, VirtualJaguar, VirtualJaguarServer
from odolab.robot.jaguar.driver import JaguarDriver, UdpTransport, driver_config_for
from odolab.robot.loop import ControlLoop
from odolab.robot.motions import Straight
from odolab.sim.physics import VirtualRobot
from odolab.sim.presets import TRUTH_PRESETS

NOMINAL = PRESETS["jaguar-lite"]


def crc(data: bytes) -> int:
    reg = 0
    for byte in data:
        for i in range(8):
            fb = ((byte >> i) & 1) ^ (reg & 1)
            reg >>= 1
            if fb:
                reg ^= 0x8C
    return reg


def frame(des: int, typ: int, data: bytes) -> bytes:
    body = bytes([des, 0, typ, len(data)]) + data
    return b"\x5e\x02" + body + bytes([crc(body)]) + b"\x5e\x0d"


def unframe(raw: bytes) -> tuple[int, bytes] | None:
    if len(raw) < 9 or raw[:2] != b"\x5e\x02" or raw[-2:] != b"\x5e\x0d":
        return None
    n = raw[5]
    if len(raw) != n + 9 or crc(raw[2 : 6 + n]) != raw[6 + n]:
        return None
    return raw[4], raw[6 : 6 + n]


def test_hand_written_client_drives_the_virtual_jaguar() -> None:
    plant = VirtualRobot(TRUTH_PRESETS["ideal"], NOMINAL, "tile", seed=5)
    with (
        VirtualJaguarServer(VirtualJaguar(plant, BoardConfig.from_params(NOMINAL))) as server,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock,
    ):
        sock.settimeout(2.0)
        sock.sendto(bytes.fromhex("5E 02 01 00 FF 01 01 85 5E 0D"), server.address)
        first = unframe(sock.recv(256))
        assert first is not None and first[0] == 0x7B
        left0, right0 = (
            struct.unpack_from("<H", first[1], 24)[0],
            struct.unpack_from("<H", first[1], 28)[0],
        )
        # PWM all channels: 3/4 forward on 0 and 1 (0.5 m/s), others "leave alone"
        data = struct.pack("<6h", 24576, 24576, -32768, -32768, -32768, -32768)
        sock.sendto(frame(0x01, 6, data), server.address)
        t_end = time.monotonic() + 1.0
        last = first[1]
        while time.monotonic() < t_end:
            sock.sendto(frame(0x01, 6, data), server.address)  # within the command timeout
            got = unframe(sock.recv(256))
            if got is not None and got[0] == 0x7B:
                last = got[1]
        sock.sendto(frame(0x01, 6, struct.pack("<6h", *[16384] * 2, *[-32768] * 4)), server.address)
        time.sleep(0.2)
        speeds = server.call(lambda b: b.wheel_speeds)
    assert speeds == (0.0, 0.0)
    left = struct.unpack_from("<H", last, 24)[0]
    right = struct.unpack_from("<H", last, 28)[0]
    assert last[32] & 0b11 == 0b11  # both forward
    # about 0.5 m/s for ~1 s (within the report period and the start-up latency)
    for now, then in ((left, left0), (right, right0)):
        metres = ((now - then) % 32768) * NOMINAL.left_metres_per_tick
        assert 0.35 < metres < 0.6
    vel = struct.unpack_from("<H", last, 26)[0]
    assert vel * NOMINAL.left_metres_per_tick == pytest.approx(0.5, abs=0.02)


class HandWrittenBoard:
    """A board from the fact sheet: streams encoders at 10 Hz after ACK, PWM -> counts.

    Counters count 1000 counts/s at full forward PWM on each channel, and wrap at 32768;
    channel 0 is the RIGHT track here and its counter counts DOWN forward (to test the map).
    """

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.address = self.sock.getsockname()
        self.pwm = [16384, 16384]
        self.count = [30000.0, 100.0]
        self.commands: list[tuple[int, ...]] = []
        self.stop_flag = threading.Event()
        self.thread = threading.Thread(target=self.serve, daemon=True)

    def serve(self) -> None:
        peer = None
        last = time.monotonic()
        next_report = last
        while not self.stop_flag.is_set():
            r, _, _ = select.select([self.sock], [], [], 0.01)
            now = time.monotonic()
            for i in (0, 1):
                self.count[i] += (self.pwm[i] - 16384) / 16384 * 1000 * (now - last)
            last = now
            if r:
                raw, addr = self.sock.recvfrom(256)
                got = unframe(raw)
                if got is None:
                    continue
                typ, data = got
                if typ == 0xFF and data[0] == 1:
                    peer = addr
                elif typ == 6 and len(data) >= 12:
                    vals = struct.unpack_from("<6h", data)
                    self.commands.append(vals)
                    self.pwm = [vals[0], vals[1]]
            if peer is not None and now >= next_report:
                next_report = now + 0.1
                pos = [int(c) % 32768 for c in self.count]
                payload = struct.pack("<12H", *[0] * 12) + struct.pack(
                    "<HHHHB", pos[0], 0, pos[1], 0, 0
                )
                self.sock.sendto(frame(0x00, 0x7B, payload), peer)

    def __enter__(self) -> HandWrittenBoard:
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop_flag.set()
        self.thread.join(timeout=2)
        self.sock.close()


def test_driver_drives_a_hand_written_board() -> None:
    from odolab.robot.jaguar.driver import ChannelMap

    with HandWrittenBoard() as board:
        clock = RealClock()
        cfg = driver_config_for(
            NOMINAL,
            channels=ChannelMap(left=1, right=0, right_encoder_sign=-1, right_motor_sign=-1),
        )
        driver = JaguarDriver(UdpTransport(*board.address), clock, cfg)
        try:
            loop = ControlLoop(driver, Odometry(NOMINAL), clock, rate=20.0)
            res = loop.run(Straight(0.3, speed=0.5), settle=0.2)
        finally:
            driver.close()
        commands = list(board.commands)
    assert res.completed and res.final.x >= 0.3
    assert abs(res.final.heading) < 0.05  # both tracks moved forward alike
    # forward on the right (channel 0) is a negative motor sign: PWM below 16384
    moving = [c for c in commands if c[1] != 16384]
    assert moving and all(c[1] > 16384 and c[0] < 16384 for c in moving)
    assert commands[-1][:2] == (16384, 16384)
    assert all(c[2:] == (-32768,) * 4 for c in commands)

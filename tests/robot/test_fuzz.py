"""Fuzzing the Jaguar codec, driver and board: seeded, bounded, CI-sized (a few seconds).

- 10^6 mutated frames through the decoder (stream mode) and the driver's type decoders: no
  exception, and every accepted packet has a known destination, type, valid LEN and CRC.
- 10^5 mutated UDP datagrams at the virtual board: no exception, the board stays consistent.
- 10^5 real frames, each inside start-byte garbage: none is lost (the old decoder, which took
  any TYPE and DES, lost 9 of 10^5 here; benchmarks/bench_decoder.py measures 10^6).
"""

from __future__ import annotations

import numpy as np

from odolab.core.params import PRESETS
from odolab.robot.clock import SimClock
from odolab.robot.jaguar.board import BoardConfig, VirtualJaguar
from odolab.robot.jaguar.driver import JaguarDriver
from odolab.robot.jaguar.protocol import (
    DES_PC,
    Decoder,
    MessageType,
    MotorSensorData,
    SystemCode,
    crc8,
    decode_motor_command,
    decode_motor_sensor,
    decode_system,
    encode_motor_sensor,
    encode_packet,
    encode_system,
)
from odolab.robot.plant import IdealPlant

from .fuzzing import mutate, start_byte_garbage, valid_frames

KNOWN = {int(t) for t in MessageType}


def test_a_million_mutated_frames_through_the_decoder() -> None:
    rng = np.random.default_rng(20261123)
    mutated = mutate(rng, valid_frames(rng, 1000), 1000)
    assert len(mutated) == 10**6
    dec = Decoder()
    accepted = 0
    for i in range(0, len(mutated), 2000):
        for p in dec.feed(b"".join(mutated[i : i + 2000])):
            accepted += 1
            assert p.des in (0, 1) and p.type in KNOWN
            body = bytes((p.des, p.sn, p.type, len(p.data))) + p.data
            assert encode_packet(p.des, p.type, p.data, p.sn)[-3] == crc8(body)
            if p.type == MessageType.MOTOR_SENSOR:
                decode_motor_sensor(p)
            elif p.type in (
                MessageType.PWM_ALL,
                MessageType.VELOCITY_ALL,
                MessageType.POSITION_ALL,
            ):
                decode_motor_command(p)
            elif p.type == MessageType.SYSTEM:
                decode_system(p)
    st = dec.stats
    # everything was looked at: accepted + discarded candidates, nothing raised
    assert st.packets == accepted > 1000
    assert st.unknown_destination > 0 and st.unknown_type > 0 and st.bad_crc > 0


def test_mutated_datagrams_through_the_driver() -> None:
    rng = np.random.default_rng(7)
    mutated = mutate(rng, valid_frames(rng, 200), 250)  # 5 * 10^4 datagrams

    class Inbox:
        def __init__(self) -> None:
            self.items: list[bytes] = []
            self.sent: list[bytes] = []

        def send(self, data: bytes) -> None:
            self.sent.append(data)

        def receive(self) -> list[tuple[bytes, float]]:
            out, self.items = self.items, []
            return [(d, 0.0) for d in out]

        def close(self) -> None:
            pass

    t = Inbox()
    drv = JaguarDriver(t, SimClock())
    for i in range(0, len(mutated), 500):
        t.items = mutated[i : i + 500]
        drv.poll()
    assert drv.stats.received == len(mutated)
    # the driver accepts only packets addressed to the PC
    assert drv.decoder.stats.unknown_destination > 0


def test_a_hundred_thousand_mutated_datagrams_at_the_board() -> None:
    rng = np.random.default_rng(11)
    nominal = PRESETS["jaguar-lite"]
    board = VirtualJaguar(IdealPlant(nominal), BoardConfig.from_params(nominal))
    peer = ("127.0.0.1", 40000)
    stranger = ("127.0.0.1", 40001)
    board.handle(encode_system(SystemCode.ACK), peer, 0.0)
    mutated = mutate(rng, valid_frames(rng, 400), 250)
    assert len(mutated) == 10**5
    who = rng.random(len(mutated)) < 0.9
    now = 0.0
    for k, d in enumerate(mutated):
        now += 1e-4
        board.handle(d, peer if who[k] else stranger, now)
        if k % 100 == 0:
            board.step(now)
    board.step(now + 1.0)
    st = board.stats
    assert st.decode.stats.packets == st.received
    vmax = board.config.max_wheel_speed
    assert all(abs(v) <= vmax for v in board.wheel_speeds)
    # the stranger never took the board while its peer kept talking
    assert board.peer == peer and st.takeovers == 0 and st.rejected_acks > 0
    # 1 s without a valid command: the board stopped by itself
    assert board.wheel_speeds == (0.0, 0.0)


def test_real_frames_in_start_byte_garbage_are_not_lost() -> None:
    rng = np.random.default_rng(5)
    n = 10**5
    vals = rng.integers(0, 32768, (n, 2)).tolist()
    frames = [encode_motor_sensor(MotorSensorData((a, b), (1, 2), 3)) for a, b in vals]
    garbage = start_byte_garbage(rng, 80 * n)
    dec = Decoder({DES_PC})
    found = 0
    for i, f in enumerate(frames):
        g = garbage[80 * i : 80 * i + 80]
        packets = dec.feed_datagram(g[:40] + f + g[40:])
        found += sum(1 for p in packets if p.data == f[6:-3])
    lost = n - found
    assert lost == 0, f"{lost} of {n} real frames lost in garbage"
    assert dec.stats.garbage_bytes > 60 * n  # the garbage was looked at, not skipped wholesale

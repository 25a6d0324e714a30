"""The virtual Jaguar board's logic, in-process (no sockets), over a fake or ideal plant."""

from __future__ import annotations

import math

import pytest

from odolab.core.params import PRESETS
from odolab.robot.errors import BoardConfigError
from odolab.robot.jaguar.board import BoardConfig, Faults, VirtualJaguar
from odolab.robot.jaguar.protocol import (
    Decoder,
    MessageType,
    SystemCode,
    decode_motor_sensor,
    decode_system,
    encode_motor_command,
    encode_system,
)
from odolab.robot.plant import IdealPlant

from .conftest import FakePlant

PEER = ("127.0.0.1", 5555)
ACK = encode_system(SystemCode.ACK)


def sensors(out: list[tuple[bytes, object]]) -> list:  # type: ignore[type-arg]
    d = Decoder()
    return [
        decode_motor_sensor(p)
        for data, _ in out
        for p in d.feed_datagram(data)
        if p.type == MessageType.MOTOR_SENSOR
    ]


def board(plant: FakePlant, **faults: float) -> VirtualJaguar:
    cfg = BoardConfig(left_metres_per_tick=0.001, right_metres_per_tick=0.001, ping_interval=0)
    return VirtualJaguar(plant, cfg, faults=Faults(**faults), seed=1)


def test_before_ack_only_pings_are_answered(fake_plant: FakePlant) -> None:
    b = board(fake_plant)
    b.handle(encode_motor_command(MessageType.PWM_ALL, [32767] * 2 + [None] * 4), PEER, 0.0)
    b.handle(encode_system(SystemCode.PING), PEER, 0.1)
    out = b.step(1.0)
    assert fake_plant.commands == []  # the command before ACK was ignored
    assert b.stats.ignored_commands == 1
    assert len(out) == 1  # only the ACK answering the PING, no sensor stream
    p = Decoder().feed_datagram(out[0][0])[0]
    assert p.des == 0 and decode_system(p) is SystemCode.ACK


def resend(b: VirtualJaguar, cmd: bytes, until: float, every: float = 0.25) -> list:  # type: ignore[type-arg]
    """Send ``cmd`` every ``every`` s (inside the 0.5 s command timeout) up to ``until``."""
    out = []
    n = round(until / every)
    for k in range(n):
        b.handle(cmd, PEER, k * every)
        out += b.step((k + 1) * every)
    return out


def test_reports_at_ten_hz_after_ack(fake_plant: FakePlant) -> None:
    b = board(fake_plant)
    b.handle(ACK, PEER, 0.0)
    out = b.step(1.0)
    assert len(sensors(out)) == 11  # t = 0.0, 0.1, ..., 1.0
    assert all(peer == PEER for _, peer in out)


def test_pwm_maps_to_speed_and_channels(fake_plant: FakePlant) -> None:
    b = board(fake_plant)
    b.handle(ACK, PEER, 0.0)
    # channel 0 (left) 24576 = half forward, channel 1 (right) 12288 = quarter reverse
    cmd = encode_motor_command(MessageType.PWM_ALL, [24576, 12288] + [None] * 4)
    b.handle(cmd, PEER, 0.0)
    assert fake_plant.commands[-1] == pytest.approx((0.5, -0.25))
    s = sensors(resend(b, cmd, 2.0))
    last = s[-1]
    # 2 s at 0.5 m/s over 1 mm per tick = 1000 counts; -0.25 m/s wraps below 0: 32768 - 500
    assert last.encoder_position == (1000, 32768 - 500)
    assert last.encoder_velocity == (500, 250)  # |counts| per s over the last 0.1 s
    assert last.direction == 0b01  # left forward, right backward
    assert last.pwm[:2] == (24576, 12288)


def test_velocity_command_is_counts_per_second(fake_plant: FakePlant) -> None:
    b = board(fake_plant)
    b.handle(ACK, PEER, 0.0)
    b.handle(encode_motor_command(MessageType.VELOCITY_ALL, [100, -200, 0, 0, 0, 0]), PEER, 0.0)
    assert fake_plant.commands[-1] == pytest.approx((0.1, -0.2))
    # clipped to the board's maximum wheel speed (1 m/s = 1000 counts/s here)
    b.handle(encode_motor_command(MessageType.VELOCITY_ALL, [5000, 0, 0, 0, 0, 0]), PEER, 0.0)
    assert fake_plant.commands[-1] == pytest.approx((1.0, 0.0))


def test_leave_alone_keeps_the_channel(fake_plant: FakePlant) -> None:
    b = board(fake_plant)
    b.handle(ACK, PEER, 0.0)
    b.handle(encode_motor_command(MessageType.PWM_ALL, [24576, 24576] + [None] * 4), PEER, 0.0)
    b.handle(encode_motor_command(MessageType.PWM_ALL, [None, 16384] + [None] * 4), PEER, 0.0)
    assert fake_plant.commands[-1] == pytest.approx((0.5, 0.0))


def test_commands_from_another_peer_are_ignored(fake_plant: FakePlant) -> None:
    b = board(fake_plant)
    b.handle(ACK, PEER, 0.0)
    b.handle(encode_motor_command(MessageType.PWM_ALL, [0] * 6), ("127.0.0.1", 9), 0.0)
    assert fake_plant.commands == []


def test_counters_wrap_at_15_bits() -> None:
    nominal = PRESETS["jaguar-lite"]
    b = VirtualJaguar(IdealPlant(nominal), BoardConfig.from_params(nominal))
    b.handle(ACK, PEER, 0.0)
    s = sensors(resend(b, encode_motor_command(MessageType.PWM_ALL, [32767, 0] + [None] * 4), 60.0))
    assert all(0 <= r.encoder_position[0] < 32768 for r in s)
    dist = 60.0 * 32767 / 16384 - 60.0  # ~1 m/s * 60 s
    expected = math.floor(dist / nominal.left_metres_per_tick) % 32768
    assert s[-1].encoder_position[0] == expected


def test_board_pings_its_peer(fake_plant: FakePlant) -> None:
    b = VirtualJaguar(fake_plant, BoardConfig(ping_interval=1.0))
    b.handle(ACK, PEER, 0.0)
    d = Decoder()
    pings = [
        p
        for data, _ in b.step(3.5)
        for p in d.feed_datagram(data)
        if p.type == MessageType.SYSTEM and decode_system(p) is SystemCode.PING
    ]
    assert len(pings) == 3


def test_faults_drop_duplicate_corrupt_silent(fake_plant: FakePlant) -> None:
    b = board(fake_plant, drop=1.0)
    b.handle(ACK, PEER, 0.0)
    assert b.step(1.0) == []
    b = board(FakePlant(), duplicate=1.0)
    b.handle(ACK, PEER, 0.0)
    assert len(sensors(b.step(0.95))) == 20
    b = board(FakePlant(), corrupt=1.0)
    b.handle(ACK, PEER, 0.0)
    out = b.step(0.95)
    assert len(out) == 10 and sensors(out) == []
    b = board(FakePlant())
    b.handle(ACK, PEER, 0.0)
    b.silent = True
    assert b.step(1.0) == []


def test_delay_and_jitter_reorder(fake_plant: FakePlant) -> None:
    b = board(fake_plant, delay=0.05, jitter=0.3)
    b.handle(ACK, PEER, 0.0)
    b.handle(encode_motor_command(MessageType.PWM_ALL, [24576, 24576] + [None] * 4), PEER, 0.0)
    left = [r.encoder_position[0] for r in sensors(b.step(5.0))]
    assert len(left) >= 40
    assert left != sorted(left)  # some arrive out of order
    assert b.step(0.0) == []


def test_bad_fault_config() -> None:
    with pytest.raises(BoardConfigError, match="probability"):
        Faults(drop=1.5)

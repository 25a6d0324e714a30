"""The driver against a scripted transport: handshake, PINGs, commands, channel map, signs."""

from __future__ import annotations

import struct

import pytest

from odolab.core.errors import RobotLinkError
from odolab.robot.clock import SimClock
from odolab.robot.config import CommandMode
from odolab.robot.errors import RobotConfigError
from odolab.robot.jaguar.driver import (
    ChannelMap,
    DriverConfig,
    JaguarDriver,
    parse_robot_url,
)
from odolab.robot.jaguar.protocol import (
    STOP_PWM,
    STOP_VELOCITY,
    Decoder,
    MessageType,
    MotorSensorData,
    SystemCode,
    decode_motor_command,
    decode_system,
    encode_motor_sensor,
    encode_system,
)


class ScriptedTransport:
    """Records what is sent; hands out queued datagrams on receive, arrived at ``arrival``."""

    def __init__(self, arrival: float = 0.0) -> None:
        self.sent: list[bytes] = []
        self.inbox: list[bytes] = []
        self.arrival = arrival
        self.closed = False

    def send(self, data: bytes) -> None:
        self.sent.append(data)

    def receive(self) -> list[tuple[bytes, float]]:
        out, self.inbox = self.inbox, []
        return [(d, self.arrival) for d in out]

    def close(self) -> None:
        self.closed = True


def sent_packets(t: ScriptedTransport) -> list:  # type: ignore[type-arg]
    d = Decoder()
    return [p for data in t.sent for p in d.feed_datagram(data)]


def test_connect_sends_ack_and_times_out() -> None:
    t = ScriptedTransport()
    drv = JaguarDriver(t, SimClock(), DriverConfig(connect_timeout=1.0, ack_retry=0.25))
    with pytest.raises(RobotLinkError, match="no sensor data"):
        drv.connect()
    acks = [p for p in sent_packets(t) if decode_system(p) is SystemCode.ACK]
    assert len(acks) == 5  # t = 0, 0.25, 0.5, 0.75, 1.0
    assert all(p.des == 1 for p in acks)


def test_ping_is_answered_and_sensor_parsed() -> None:
    t = ScriptedTransport(arrival=2.5)  # arrived before the driver's clock (3.0) read it
    drv = JaguarDriver(t, SimClock(3.0))
    t.inbox = [
        encode_system(SystemCode.PING, des=0)
        + encode_motor_sensor(MotorSensorData((100, 200), (5, 6), 0b11)),
        b"garbage" + encode_motor_sensor(MotorSensorData((101, 202))),
    ]
    assert drv.poll() == 2
    assert drv.stats.link.pings_answered == 1
    assert decode_system(sent_packets(t)[0]) is SystemCode.ACK
    r = drv.latest
    assert r is not None and (r.t, r.left_ticks, r.right_ticks) == (2.5, 101, 202)


def test_channel_map_and_encoder_sign() -> None:
    t = ScriptedTransport()
    cfg = DriverConfig(channels=ChannelMap(left=1, right=0, right_encoder_sign=-1))
    drv = JaguarDriver(t, SimClock(), cfg)
    t.inbox = [encode_motor_sensor(MotorSensorData((10, 20)))]
    drv.poll()
    assert drv.latest is not None
    # left is motor 1 (20); right is motor 0 counting down: -10 mod 32768
    assert (drv.latest.left_ticks, drv.latest.right_ticks) == (20, 32758)


def test_pwm_command_values() -> None:
    t = ScriptedTransport()
    drv = JaguarDriver(t, SimClock(), DriverConfig(max_wheel_speed=2.0))
    drv.set_wheel_speeds(1.0, -0.5)
    drv.stop()
    cmds = [decode_motor_command(p) for p in sent_packets(t)]
    assert cmds[0].kind is MessageType.PWM_ALL
    # 16384 + 1.0 / 2.0 * 16384 = 24576; 16384 - 0.25 * 16384 = 12288; others left alone
    assert cmds[0].values == (24576, 12288, None, None, None, None)
    assert cmds[1].values[:2] == (16384, 16384)
    assert drv.stats.stops_sent == 1


def test_velocity_command_values_and_swapped_channels() -> None:
    t = ScriptedTransport()
    cfg = DriverConfig(
        mode=CommandMode.VELOCITY,
        left_metres_per_tick=0.002,
        right_metres_per_tick=0.001,
        channels=ChannelMap(left=1, right=0, right_motor_sign=-1),
    )
    drv = JaguarDriver(t, SimClock(), cfg)
    drv.set_wheel_speeds(0.3, 0.2)
    p = sent_packets(t)[0]
    assert p.type == 27
    # right (channel 0) 0.2 / 0.001 = 200, negated; left (channel 1) 0.3 / 0.002 = 150
    assert struct.unpack_from("<2h", p.data) == (-200, 150)


def test_bad_config_and_url() -> None:
    with pytest.raises(RobotConfigError):
        ChannelMap(left=0, right=0)
    with pytest.raises(RobotConfigError):
        ChannelMap(left_encoder_sign=2)
    assert parse_robot_url("udp://127.0.0.1:10001") == ("127.0.0.1", 10001)
    with pytest.raises(RobotLinkError, match="udp://HOST:PORT"):
        parse_robot_url("tcp://x:1")
    for bad in ("udp://127.0.0.1:99999", "udp://127.0.0.1:abc"):  # were ValueError tracebacks
        with pytest.raises(RobotLinkError, match="bad port"):
            parse_robot_url(bad)


def test_close_stops_and_closes() -> None:
    t = ScriptedTransport()
    drv = JaguarDriver(t, SimClock())
    drv.set_wheel_speeds(0.5, 0.5)
    drv.close()
    assert t.closed
    assert decode_motor_command(sent_packets(t)[-1]).values[:2] == (16384, 16384)


@pytest.mark.parametrize("mode", [CommandMode.PWM, CommandMode.VELOCITY])
@pytest.mark.parametrize("swap", [False, True])
@pytest.mark.parametrize("signs", [(1, 1), (-1, 1), (1, -1), (-1, -1)])
@pytest.mark.parametrize("vmax", [0.01, 1.0, 3.0])
def test_stop_is_one_fixed_packet_whatever_the_settings(
    mode: CommandMode, swap: bool, signs: tuple[int, int], vmax: float
) -> None:
    t = ScriptedTransport()
    cfg = DriverConfig(
        mode=mode,
        max_wheel_speed=vmax,
        channels=ChannelMap(
            left=int(swap),
            right=1 - int(swap),
            left_motor_sign=signs[0],
            right_motor_sign=signs[1],
            left_encoder_sign=signs[1],
            right_encoder_sign=signs[0],
        ),
    )
    drv = JaguarDriver(t, SimClock(), cfg)
    drv.set_wheel_speeds(0.7, -0.2)
    drv.stop()
    drv.close()
    fixed = STOP_PWM if mode is CommandMode.PWM else STOP_VELOCITY
    assert t.sent[1] == fixed and t.sent[2] == fixed
    cmd = decode_motor_command(sent_packets(t)[1])
    # hand-written values: PWM 16384 (stop) or velocity 0 on both track channels
    assert cmd.values == ((16384, 16384) if mode is CommandMode.PWM else (0, 0)) + (None,) * 4


def test_stop_packets_byte_for_byte() -> None:
    # DES 01, SN 00, TYPE 06 / 1b, LEN 0c, values LE; CRC from the fact sheet's rule
    assert STOP_PWM[:6] == bytes.fromhex("5e 02 01 00 06 0c")
    assert STOP_PWM[6:18] == bytes.fromhex("0040 0040 0080 0080 0080 0080")
    assert STOP_VELOCITY[4] == 27 and STOP_VELOCITY[6:10] == b"\x00\x00\x00\x00"
    assert STOP_PWM[-2:] == STOP_VELOCITY[-2:] == b"\x5e\x0d"

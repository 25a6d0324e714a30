"""The Jaguar codec: test vectors, round trips, and a decoder that never crashes."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from odolab.core.errors import ProtocolError
from odolab.robot.jaguar.protocol import (
    PWM_STOP,
    Decoder,
    MessageType,
    MotorCommand,
    MotorSensorData,
    Packet,
    SystemCode,
    crc8,
    decode_motor_command,
    decode_motor_sensor,
    decode_packet,
    decode_system,
    encode_motor_command,
    encode_motor_sensor,
    encode_packet,
    encode_system,
)

ACK_TO_BOARD = bytes.fromhex("5E 02 01 00 FF 01 01 85 5E 0D")


def crc8_bitwise(data: bytes) -> int:
    """The fact sheet's rule, literally: LSB first, feedback = bit XOR reg bit 0, XOR 0x8C."""
    reg = 0
    for byte in data:
        for i in range(8):
            feedback = ((byte >> i) & 1) ^ (reg & 1)
            reg >>= 1
            if feedback:
                reg ^= 0x8C
    return reg


def test_ack_test_vector() -> None:
    assert encode_system(SystemCode.ACK) == ACK_TO_BOARD
    assert crc8(ACK_TO_BOARD[2:7]) == 0x85
    p = decode_packet(ACK_TO_BOARD)
    assert (p.des, p.type, p.data) == (1, 0xFF, b"\x01")
    assert decode_system(p) is SystemCode.ACK


def test_crc8_standard_check_value() -> None:
    # CRC-8/MAXIM-DOW catalogue check value for "123456789"
    assert crc8(b"123456789") == 0xA1
    assert crc8(b"") == 0


@given(st.binary(max_size=64))
def test_crc8_table_equals_bitwise_rule(data: bytes) -> None:
    assert crc8(data) == crc8_bitwise(data)


def test_motor_command_bytes_by_hand() -> None:
    raw = encode_motor_command(MessageType.PWM_ALL, [24576, 8192, None, None, None, None])
    # 24576 = 0x6000, 8192 = 0x2000, -32768 = 0x8000 little-endian
    data = bytes.fromhex("0060 0020 0080 0080 0080 0080")
    body = bytes([0x01, 0x00, 0x06, 12]) + data
    assert raw == b"\x5e\x02" + body + bytes([crc8_bitwise(body)]) + b"\x5e\x0d"
    assert len(raw) == 12 + 9
    cmd = decode_motor_command(decode_packet(raw))
    assert cmd == MotorCommand(MessageType.PWM_ALL, (24576, 8192, None, None, None, None))


def test_velocity_command_with_time() -> None:
    raw = encode_motor_command(MessageType.VELOCITY_ALL, [-100, 250, 0, 0, 0, 0], time_ms=500)
    p = decode_packet(raw)
    assert p.type == 27 and len(p.data) == 14
    assert struct.unpack("<7h", p.data) == (-100, 250, 0, 0, 0, 0, 500)
    assert decode_motor_command(p).time_ms == 500


def test_motor_sensor_offsets() -> None:
    s = MotorSensorData((32767, 5), (120, 7), 0b10, (1, 2, 3, 4, 5, 6), (7, 8, 9, 10, 11, 12))
    raw = encode_motor_sensor(s)
    p = decode_packet(raw)
    assert (p.des, p.type, len(p.data)) == (0, 0x7B, 33)
    d = p.data
    assert struct.unpack_from("<H", d, 24)[0] == 32767
    assert struct.unpack_from("<H", d, 26)[0] == 120
    assert struct.unpack_from("<H", d, 28)[0] == 5
    assert struct.unpack_from("<H", d, 30)[0] == 7
    assert d[32] == 0b10
    assert struct.unpack_from("<6H", d, 0) == (1, 2, 3, 4, 5, 6)
    assert struct.unpack_from("<6H", d, 12) == (7, 8, 9, 10, 11, 12)
    back = decode_motor_sensor(p)
    assert back == s
    assert not back.forward(0) and back.forward(1)


u16 = st.integers(0, 0xFFFF)


@given(
    st.tuples(u16, u16),
    st.tuples(u16, u16),
    st.integers(0, 255),
    st.tuples(*[u16] * 6),
    st.tuples(*[u16] * 6),
    st.binary(max_size=20),
)
def test_motor_sensor_round_trip(pos, vel, direction, pwm, cur, extra) -> None:  # type: ignore[no-untyped-def]
    s = MotorSensorData(pos, vel, direction, pwm, cur, extra)
    assert decode_motor_sensor(decode_packet(encode_motor_sensor(s))) == s


i16 = st.one_of(st.none(), st.integers(-32767, 32767))


@given(
    st.sampled_from([MessageType.VELOCITY_ALL, MessageType.POSITION_ALL]),
    st.lists(i16, min_size=6, max_size=6),
    st.one_of(st.none(), st.integers(-32768, 32767)),
)
def test_motor_command_round_trip(kind, values, time_ms) -> None:  # type: ignore[no-untyped-def]
    cmd = decode_motor_command(decode_packet(encode_motor_command(kind, values, time_ms)))
    assert cmd == MotorCommand(kind, tuple(values), time_ms)


def test_bad_values_raise() -> None:
    with pytest.raises(ProtocolError, match=r"expected 0\.\.32767"):
        encode_motor_command(MessageType.PWM_ALL, [40000 - 65536, 0, 0, 0, 0, 0])
    with pytest.raises(ProtocolError, match="expected 6"):
        encode_motor_command(MessageType.PWM_ALL, [PWM_STOP] * 2)
    with pytest.raises(ProtocolError, match="not an all-channel"):
        encode_motor_command(0x7B, [0] * 6)
    with pytest.raises(ProtocolError, match="CRC"):
        decode_packet(ACK_TO_BOARD[:7] + b"\x00" + ACK_TO_BOARD[8:])
    with pytest.raises(ProtocolError, match="ETX"):
        decode_packet(ACK_TO_BOARD[:-1] + b"\x00")
    with pytest.raises(ProtocolError, match="bad length"):
        decode_packet(ACK_TO_BOARD + b"\x00")


# known destinations, and the known types whose LEN is free (custom and standard sensor data);
# unknown types and destinations are discarded by design (see test_fuzz.py)
packets = st.builds(
    Packet,
    st.sampled_from([0x00, 0x01]),
    st.sampled_from([0x7C, 0x7D]),
    st.binary(max_size=40),
    st.just(0),
)
clean_garbage = st.binary(max_size=12).map(lambda b: b.replace(b"\x5e", b"\x00"))


def _frame(p: Packet) -> bytes:
    return encode_packet(p.des, p.type, p.data, p.sn)


@given(st.lists(st.tuples(clean_garbage, packets), max_size=6), clean_garbage)
def test_decoder_resyncs_after_garbage(chunks, tail) -> None:  # type: ignore[no-untyped-def]
    stream = b"".join(g + _frame(p) for g, p in chunks) + tail
    expected = [p for _, p in chunks]
    whole = Decoder()
    assert whole.feed_datagram(stream) == expected
    assert whole.stats.discarded == 0
    # byte by byte as a stream gives the same packets
    d = Decoder()
    got = []
    for i in range(len(stream)):
        got += d.feed(stream[i : i + 1])
    assert got == expected


@given(packets, st.data())
def test_corrupted_byte_is_discarded_and_counted(p, data) -> None:  # type: ignore[no-untyped-def]
    raw = bytearray(_frame(p))
    i = data.draw(st.integers(2, len(raw) - 1))  # keep STX so the decoder tries the packet
    raw[i] ^= data.draw(st.integers(1, 255))
    d = Decoder()
    got = d.feed_datagram(bytes(raw))
    # CRC-8 catches every error burst of up to 8 bits, so one changed byte never passes
    assert got == []
    assert d.stats.discarded >= 1


@given(packets, st.data())
def test_truncated_packet_counts_as_bad_length(p, data) -> None:  # type: ignore[no-untyped-def]
    raw = _frame(p)
    n = data.draw(st.integers(2, len(raw) - 1))
    d = Decoder()
    assert d.feed_datagram(raw[:n]) == []
    assert d.stats.bad_length + d.stats.bad_etx + d.stats.bad_crc >= 1
    # the next datagram decodes normally: nothing carried over
    assert d.feed_datagram(raw) == [p]


@given(st.lists(st.binary(max_size=80), max_size=8))
def test_random_bytes_never_crash(chunks) -> None:  # type: ignore[no-untyped-def]
    d = Decoder()
    for c in chunks:
        for q in d.feed(c):
            assert isinstance(q, Packet)
        d.feed_datagram(c)


def test_random_streams_with_valid_packets_seeded() -> None:
    rng = np.random.default_rng(7)
    ok = encode_motor_sensor(MotorSensorData((1, 2)))
    d = Decoder()
    found = 0
    for _ in range(300):
        noise = rng.integers(0, 256, int(rng.integers(0, 60)), dtype=np.uint8).tobytes()
        cut = int(rng.integers(0, len(ok)))
        stream = noise + ok[:cut] + noise + ok
        found += sum(1 for q in d.feed_datagram(stream) if q.type == 0x7B and q.data == ok[6:-3])
    # the complete packet at the end of every datagram is always found
    assert found >= 300


def test_bad_etx_and_bad_crc_counted() -> None:
    d = Decoder()
    bad_etx = ACK_TO_BOARD[:-1] + b"\x0e"
    bad_crc = ACK_TO_BOARD[:7] + b"\x86" + ACK_TO_BOARD[8:]
    bad_len = encode_packet(1, 0x7B, b"\x00" * 10)  # a motor sensor packet needs LEN >= 33
    got = d.feed_datagram(bad_etx + bad_crc + bad_len + ACK_TO_BOARD)
    assert got == [decode_packet(ACK_TO_BOARD)]
    assert (d.stats.bad_etx, d.stats.bad_crc, d.stats.bad_length) == (1, 1, 1)

"""Seeded, bounded fuzzing material for the Jaguar codec and board (numpy-vectorised).

Frames are mutated in bulk: each frame gets 1-3 random byte substitutions (XOR with a non-zero
byte) at random offsets, some are truncated or get a random byte inserted. Garbage "full of
start bytes" is bytes drawn 1/4 each from 0x5E, 0x02, 0x0D and uniform.
"""

from __future__ import annotations

import numpy as np

from odolab.robot.jaguar.protocol import (
    MessageType,
    MotorSensorData,
    SystemCode,
    encode_motor_command,
    encode_motor_sensor,
    encode_system,
)


def valid_frames(rng: np.random.Generator, n: int) -> list[bytes]:
    """``n`` valid frames of every known kind, both directions."""
    out: list[bytes] = []
    kinds = rng.integers(0, 5, n)
    vals = rng.integers(0, 32768, (n, 6))
    for k, v in zip(kinds.tolist(), vals.tolist(), strict=True):
        if k == 0:
            out.append(encode_motor_sensor(MotorSensorData((v[0], v[1]), (v[2], v[3]), v[4] & 3)))
        elif k == 1:
            out.append(encode_motor_command(MessageType.PWM_ALL, v))
        elif k == 2:
            out.append(encode_motor_command(MessageType.VELOCITY_ALL, [x - 16384 for x in v]))
        elif k == 3:
            out.append(encode_system(SystemCode.ACK, des=v[0] & 1))
        else:
            out.append(encode_system(SystemCode.PING, des=v[0] & 1))
    return out


def mutate(rng: np.random.Generator, frames: list[bytes], copies: int) -> list[bytes]:
    """``copies`` mutated versions of each frame (len(frames) * copies in all)."""
    out: list[bytes] = []
    for frame in frames:
        base = np.frombuffer(frame, dtype=np.uint8)
        n = base.size
        arr = np.tile(base, (copies, 1))
        rows = np.arange(copies)
        for _ in range(3):
            pos = rng.integers(0, n, copies)
            flip = rng.integers(1, 256, copies, dtype=np.uint8)
            hit = rng.random(copies) < 0.7
            arr[rows[hit], pos[hit]] ^= flip[hit]
        cut = rng.integers(1, n + 1, copies)
        trunc = rng.random(copies) < 0.15
        ins_at = rng.integers(0, n, copies)
        insert = rng.random(copies) < 0.15
        ins_byte = rng.integers(0, 256, copies, dtype=np.uint8)
        for i in range(copies):
            b = arr[i].tobytes()
            if trunc[i]:
                b = b[: cut[i]]
            if insert[i]:
                b = b[: ins_at[i]] + bytes((int(ins_byte[i]),)) + b[ins_at[i] :]
            out.append(b)
    return out


def start_byte_garbage(rng: np.random.Generator, n: int) -> bytes:
    """``n`` bytes, a quarter each 0x5E (STX0/ETX0), 0x02 (STX1), 0x0D (ETX1) and random."""
    choice = rng.integers(0, 4, n)
    rnd = rng.integers(0, 256, n)
    g = np.where(choice == 0, 0x5E, np.where(choice == 1, 0x02, np.where(choice == 2, 0x0D, rnd)))
    return g.astype(np.uint8).tobytes()

"""Shared helpers for the notebook tests: a seeded trial factory and a trial fingerprint."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from odolab.core.params import PRESETS, RobotParams
from odolab.core.trajectory import Pose
from odolab.core.trials import Command, EncoderLog, Measurement, MotionKind, Trial, TrialStatus

JAGUAR = PRESETS["jaguar-lite"]


def make_trials(
    n: int,
    *,
    seed: int = 0,
    campaign: str = "rot-lab",
    terrain: str = "lab",
    kind: MotionKind = MotionKind.ROTATION,
    params: RobotParams = JAGUAR,
    with_logs: bool = False,
    prefix: str = "T",
    measured_every: int = 2,
) -> list[Trial]:
    """``n`` plausible trials; every ``measured_every``-th one measured, one excluded."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        if kind is MotionKind.ROTATION:
            angle = float(rng.integers(1, 21)) * math.pi
            heading = angle * (1 + 0.02 * rng.standard_normal())
            cmd = Command(kind, angle=angle, speed=0.5)
            pred = Pose(
                12.5 + i,
                1e-3 * rng.standard_normal(),
                1e-3 * rng.standard_normal(),
                math.remainder(heading, 2 * math.pi),
                heading,
            )
            actual = heading * 0.875
            turns = int(actual // (2 * math.pi))
            frac = math.degrees(actual - 2 * math.pi * turns)
            initial = float(rng.uniform(0, 360))
            m = Measurement(
                "compass",
                rotation=actual,
                sigma_rotation=0.0707,
                raw={
                    "compass_initial_deg": initial,
                    "compass_final_deg": (initial - frac) % 360.0,
                    "turns": float(turns),
                },
            )
        else:
            d = float(rng.choice([-2.5, -1.0, 1.0, 2.5]))
            cmd = Command(kind, distance=d, speed=0.3)
            pred = Pose(
                8.0, d + 0.01 * rng.standard_normal(), 0.02 * rng.standard_normal(), 0.01, 0.01
            )
            m = Measurement(
                "meterstick",
                x=d * 1.1,
                y=0.05 * rng.standard_normal(),
                sigma_xy=0.005,
                raw={"x_m": d * 1.1},
            )
        log = None
        if with_logs:
            k = int(rng.integers(5, 400))
            left = np.cumsum(rng.integers(-40, 41, k)) + 32700
            right = np.cumsum(rng.integers(-40, 41, k)) - 5
            log = EncoderLog(
                np.arange(k) * 0.05,
                left.astype(np.int64) % 32768,
                right.astype(np.int64),
                params.encoder_modulus,
            )
        measured = i % measured_every == 0
        status = TrialStatus.MEASURED if measured else TrialStatus.AWAITING
        reason = None
        if i == 3:
            status, reason = TrialStatus.EXCLUDED, "compass knocked over"
        true = (
            Pose(pred.t, pred.x * 0.9, pred.y, pred.theta, pred.heading * 0.9)
            if i % 5 == 1
            else None
        )
        out.append(
            Trial(
                trial_id=f"{prefix}{i:05d}",
                campaign=campaign,
                terrain=terrain,
                command=cmd,
                predicted=pred,
                params=params,
                measured=m if measured else None,
                true=true,
                encoder_log=log,
                status=status,
                exclusion_reason=reason,
                notes="" if i % 7 else f'note, with "quotes"\nand a line break {i}',
            )
        )
    return out


def fingerprint(t: Trial, *, logs: bool = True) -> tuple[Any, ...]:
    """Everything in a trial, comparable with ==, arrays as bytes."""
    m = t.measured
    log = t.encoder_log
    return (
        t.trial_id,
        t.campaign,
        t.terrain,
        t.command,
        tuple(t.predicted),
        t.params,
        None
        if m is None
        else (
            m.instrument,
            m.rotation,
            m.x,
            m.y,
            m.sigma_rotation,
            m.sigma_xy,
            tuple(sorted(m.raw.items())),
        ),
        None if t.true is None else tuple(t.true),
        None
        if (log is None or not logs)
        else (
            np.asarray(log.t, "<f8").tobytes(),
            np.asarray(log.left_ticks, "<i8").tobytes(),
            np.asarray(log.right_ticks, "<i8").tobytes(),
            log.modulus,
        ),
        str(t.status),
        t.exclusion_reason,
        t.notes,
    )


@pytest.fixture
def trials_factory() -> Callable[..., list[Trial]]:
    return make_trials

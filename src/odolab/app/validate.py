"""Validating calibrated parameters against a phone IMU: ``odolab validate`` calls
:func:`validate_log`.

The rule that decides the old parameters lives once, in
:func:`odolab.app.odometry.choose_params` (the ones the user names, else the log's own, else the
default robot); a notebook trial's old parameters are the ones it was recorded with.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from odolab.app.odometry import ParamsChoice
    from odolab.core.trials import EncoderLog
    from odolab.validation import ValidationResult

__all__ = ["ValidateOutcome", "ValidateRequest", "validate_log"]


@dataclass(frozen=True)
class ValidateRequest:
    """What ``odolab validate`` was asked: an encoder log (or a trial id with ``db``), a phone
    IMU log, the new parameters and, optionally, the old ones; the clock search's settings."""

    encoder_log: Path
    imu_log: Path
    new: str
    old: str | None = None
    db: Path | None = None
    offset: float = 0.0
    max_offset: float = 30.0
    smooth: float = 0.1
    wallclock: bool = False
    flip_imu: bool = False
    method: str = "midpoint"


@dataclass(frozen=True)
class ValidateOutcome:
    """The validation and which old parameters it compared (and why those)."""

    result: ValidationResult
    old: ParamsChoice


def _encoder_log(req: ValidateRequest) -> tuple[EncoderLog, ParamsChoice, str]:
    """The encoder log, the old parameters (their choice) and the log's name in the results.

    Raises:
        ImuLogError: the notebook's trial has no encoder log.
    """
    from odolab.app.odometry import ParamsChoice, choose_params
    from odolab.io import read_encoder_csv

    if req.db is None:
        choice = choose_params([req.encoder_log], req.old)
        enc = read_encoder_csv(req.encoder_log, modulus=choice.params.encoder_modulus)
        return enc, choice, str(req.encoder_log)
    from odolab.core.errors import ImuLogError
    from odolab.store import Notebook

    with Notebook(req.db) as nb:
        trial = nb.get_trial(str(req.encoder_log))
    if trial.encoder_log is None:
        raise ImuLogError(f"{req.db}: trial {trial.trial_id} has no encoder log to validate")
    source = f"{req.db}: trial {trial.trial_id}"
    if req.old is not None:
        choice = choose_params([], req.old)
    else:
        choice = ParamsChoice(trial.params, "log", source, found="the notebook's trial has them")
    return trial.encoder_log, choice, source


def validate_log(req: ValidateRequest) -> ValidateOutcome:
    """Old vs new parameters' heading against the phone IMU's (Fig. 21), the clock offset found
    by cross-correlating the yaw rates.

    Raises:
        ParamsError: a parameters file or preset that cannot be read.
        ImuLogError: an IMU log that cannot be read, or a trial without an encoder log.
    """
    from odolab.core.params import load_params
    from odolab.validation import read_sensorlog, validate

    new_params = load_params(req.new)
    enc, old, source = _encoder_log(req)
    imu = read_sensorlog(req.imu_log)
    if req.wallclock:
        imu = imu.on_wallclock()
    if req.flip_imu:
        imu = imu.flipped()
    result = validate(
        enc, imu, old.params, new_params, offset=req.offset, max_offset=req.max_offset,
        smooth=req.smooth, method=req.method, encoder_source=source,
    )  # fmt: skip
    return ValidateOutcome(result, old)

"""Entering a trial's measurement: the rules and sentences shared by the CLI and the web server.

``odolab trials measure`` and ``odolab serve`` (its form and ``POST /api/trials/{id}/measurement``)
call these functions, so a refusal reads the same everywhere:

- :func:`refuse_if_measured`: a measured trial is only overwritten with ``replace``;
- :func:`check_reading_names`: a rotation takes compass readings and turns, a translation x and y;
- :func:`measurement_for_trial`: the :class:`~odolab.core.trials.Measurement` from the readings (the
  checks of :mod:`odolab.core.measurement`: "typed in cm?", "about 9 turns would fit");
- :func:`record_measurement`: all of the above, then :meth:`Notebook.set_measurement`;
- :func:`virtual_readings`: what the instruments would show after a run on a virtual board
  (its true pose, through :mod:`odolab.robot.virtual_truth`), as a student reads them: compass
  bearings and whole turns, or the meterstick's x and y; never for a real robot's run.
"""

from __future__ import annotations

import dataclasses
import math
import zlib
from typing import TYPE_CHECKING

from odolab.core.errors import StoreError
from odolab.core.measurement import (
    COMPASS_SIGMA_RAD,
    METERSTICK_SIGMA_M,
    rotation_measurement_from_compass,
    translation_measurement,
)

if TYPE_CHECKING:
    from odolab.core.trials import Measurement, Trial
    from odolab.store.notebook import Notebook

__all__ = [
    "Readings",
    "build_measurement",
    "check_reading_names",
    "describe_measurement",
    "describe_readings",
    "is_rotation",
    "measurement_for_trial",
    "record_measurement",
    "refuse_if_measured",
    "virtual_measurement",
    "virtual_readings",
]


def _fmt(value: float | None, spec: str = ".3f") -> str:
    return (
        ""
        if value is None or (isinstance(value, float) and math.isnan(value))
        else format(value, spec)
    )


def describe_measurement(t: Trial) -> str:
    """Short text of ``t``'s measurement, e.g. ``rot 62.100 rad (19.77 pi) [compass]``."""
    m = t.measured
    if m is None:
        return ""
    parts = []
    if m.rotation is not None:
        parts.append(f"rot {m.rotation:.3f} rad ({m.rotation / math.pi:.2f} pi)")
    if m.x is not None:
        parts.append(f"x {m.x:.3f} y {_fmt(m.y)} m")
    return ", ".join(parts) + f" [{m.instrument}]"


def is_rotation(t: Trial) -> bool:
    """True when ``t`` is measured with a compass and counted turns (rotation, pivot)."""
    return t.command.kind.turns_in_place


def refuse_if_measured(t: Trial, replace: bool) -> None:
    """Refuse to overwrite ``t``'s measurement unless ``replace`` (before asking for readings).

    Raises:
        StoreError: the trial is already measured and ``replace`` is false.
    """
    if t.measured is not None and not replace:
        raise StoreError(
            f"trial {t.trial_id} is already measured ({describe_measurement(t)}); "
            "give {{replace}} to overwrite its measurement"
        )


@dataclasses.dataclass(frozen=True)
class Readings:
    """What the lab's instruments showed after a trial, as entered (any value: the checks say
    what is wrong with it): a rotation's compass ``initial`` and ``final`` bearings (degrees) and
    whole ``turns``, or a translation's meterstick ``x`` and ``y`` (m); ``sigma`` the uncertainty
    of one compass reading (rad) or of x and y (m), None for the default; ``direction``
    (``"ccw"``, ``"cw"``) the way the turns were counted, None for the command's."""

    initial: object = None
    final: object = None
    turns: object = None
    x: object = None
    y: object = None
    sigma: object = None
    direction: str | None = None


def check_reading_names(t: Trial, r: Readings, *, complete: bool = False) -> None:
    """Refuse readings of the wrong kind for ``t`` (and, with ``complete``, missing ones).

    Raises:
        StoreError: readings of the other motion kind are given, or (``complete``) one is missing.
    """
    rotation = is_rotation(t)
    values = {"initial": r.initial, "final": r.final, "turns": r.turns, "x": r.x, "y": r.y}
    needs = t.command.kind.readings
    wrong = [v for k, v in values.items() if k not in needs]
    given = [values[k] for k in needs]
    if any(v is not None for v in wrong) or (complete and any(v is None for v in given)):
        expected = "{{initial}}, {{final}} and {{turns}}" if rotation else "{{x}} and {{y}}"
        raise StoreError(
            f"trial {t.trial_id} is a {t.command.kind.value}: it is measured with {expected}"
        )


def build_measurement(t: Trial, r: Readings) -> Measurement:
    """The measurement of ``t`` from readings of the right kind, all given (unprefixed errors)."""
    if is_rotation(t):
        direction = r.direction
        if direction is None:
            direction = "cw" if t.command.direction == "cw" else None
        return rotation_measurement_from_compass(
            r.initial,  # type: ignore[arg-type]
            r.final,  # type: ignore[arg-type]
            r.turns,  # type: ignore[arg-type]
            commanded_angle=t.command.angle,
            direction=direction,  # type: ignore[arg-type]
            sigma_reading_rad=r.sigma or COMPASS_SIGMA_RAD,  # type: ignore[arg-type]
            predicted_angle=t.predicted.heading,  # the turn hint follows what odometry saw
        )
    distance = t.command.distance if t.command.kind.needs == "distance" else None
    return translation_measurement(
        r.x,  # type: ignore[arg-type]
        r.y,  # type: ignore[arg-type]
        sigma=r.sigma or METERSTICK_SIGMA_M,  # type: ignore[arg-type]
        commanded_distance=distance,
    )


def measurement_for_trial(t: Trial, r: Readings) -> Measurement:
    """The measurement of ``t``; every refusal is one sentence starting ``trial ID``.

    Raises:
        StoreError: a reading is missing, of the wrong kind, or out of range (the sentence starts
            ``trial ID``).
    """
    check_reading_names(t, r, complete=True)
    try:
        return build_measurement(t, r)
    except StoreError as err:
        raise StoreError(f"trial {t.trial_id}: {err}") from err


def record_measurement(nb: Notebook, trial_id: str, r: Readings, *, replace: bool = False) -> Trial:
    """Check and store the measurement of ``trial_id``; return the trial as stored.

    Nothing is written when any check fails (the same checks and sentences as
    ``odolab trials measure`` with every reading given on the command line).
    """
    t = nb.get_trial(trial_id)
    refuse_if_measured(t, replace)
    m = measurement_for_trial(t, r)
    nb.set_measurement(trial_id, m, replace=replace)
    return nb.get_trial(trial_id)


def virtual_readings(t: Trial) -> dict[str, float] | None:
    """What the lab's instruments would show after ``t`` on a virtual board, with their noise:
    ``compass_initial_deg``, ``compass_final_deg`` (degrees clockwise from north, read to the
    compass's 0.05 rad and its 1 degree marks), ``turns`` and ``clockwise`` (1.0 or 0.0: whole
    turns counted the way the robot truly turned, :func:`odolab.core.measurement.count_turns`) for a
    rotation or a pivot; ``x_m``, ``y_m`` (meterstick, 3 mm, read to the mm) in
    the start frame otherwise. The same trial always reads the same (the noise is drawn from its
    id). None when ``t`` has no true pose (a real robot's run: its instruments are real).
    """
    import numpy as np

    from odolab.sim.instruments import Instruments

    true = t.true
    if true is None:
        return None
    rng = np.random.default_rng(zlib.crc32(t.trial_id.encode("utf-8")))
    tools = Instruments()
    if is_rotation(t):
        b0, b1, turns, direction = tools.compass.read_turn(true.heading, rng)
        return {
            "compass_initial_deg": b0,
            "compass_final_deg": b1,
            "turns": float(turns),
            "clockwise": 1.0 if direction == "cw" else 0.0,
        }
    xy = tools.meterstick.read(np.array([true.x, true.y]), rng)
    return {"x_m": float(xy[0]), "y_m": float(xy[1])}


def describe_readings(readings: dict[str, float]) -> str:
    """``compass 12 -> 305 deg, 1 whole turn counted counter-clockwise`` or ``meterstick x 1.003 m, y -0.012 m``."""
    if "turns" in readings:
        n = int(readings["turns"])
        return (
            f"compass {readings['compass_initial_deg']:g} -> {readings['compass_final_deg']:g} deg, "
            f"{n} whole turn{'' if n == 1 else 's'} counted "
            f"{'clockwise' if readings.get('clockwise') else 'counter-clockwise'}"
        )
    return f"meterstick x {readings['x_m']:.3f} m, y {readings['y_m']:.3f} m"


def virtual_measurement(t: Trial, sigma: object = None) -> Measurement:
    """The measurement of ``t`` from :func:`virtual_readings` (the same checks and arithmetic as
    readings typed by hand); refused, in one sentence, for a run without a virtual board.

    Raises:
        StoreError: the trial was not driven on a virtual board.
    """
    readings = virtual_readings(t)
    if readings is None:
        raise StoreError(
            f"trial {t.trial_id} was not driven on a virtual board (it has no true pose), so "
            "there are no virtual instruments to read; measure it with the real ones "
            "({{initial}}, {{final}} and {{turns}}, or {{x}} and {{y}})"
        )
    if "turns" in readings:
        r = Readings(
            readings["compass_initial_deg"],
            readings["compass_final_deg"],
            int(readings["turns"]),
            sigma=sigma,
            direction="cw" if readings["clockwise"] else "ccw",
        )
    else:
        r = Readings(x=readings["x_m"], y=readings["y_m"], sigma=sigma)
    m = measurement_for_trial(t, r)
    return dataclasses.replace(m, instrument=f"virtual {m.instrument}")

"""Trials as a CSV spreadsheet: one row per trial, the unit in every numeric column's name.

Columns (header: meaning; *required* ones are marked; the rest may be left out or empty):

=========================  =================================================================
``trial_id``               *required*, unique text
``campaign``               *required*; must already be in the notebook (unless imported with
                           ``create_campaigns``)
``terrain``                *required*, e.g. lab, concrete, grass
``kind``                   *required*: rotation, translation, pivot, square or free
``angle_rad``              commanded angle (rad, ccw positive)
``distance_m``             commanded distance (m, negative = reverse)
``side_m``                 square side (m)
``direction``              cw/ccw (square), left/right (pivot), forward/reverse (translation:
                           ``reverse`` with a positive distance is a reverse run; a row whose
                           words contradict its numbers is refused)
``speed``                  commanded speed (m/s, or rad/s for a rotation)
``predicted_t_s``          time of the predicted pose (s; default 0)
``predicted_x_m``          *required*, odometry's final x (m)
``predicted_y_m``          *required*, odometry's final y (m)
``predicted_theta_rad``    odometry's final heading wrapped to (-pi, pi] (default: from heading)
``predicted_heading_rad``  *required*, odometry's final heading, unwrapped (rad)
``robot``                  *required*, robot name
``params_version``         the notebook's parameter version used for the prediction
``left_wheel_radius_m``    the parameter values (all four required unless ``params_version``
``right_wheel_radius_m``   names a version already in the notebook)
``track_width_m``
``ticks_per_rev``
``encoder_modulus``        counter modulus (empty: never wraps)
``model``                  the kinematic model as ``key=value`` pairs separated by ``;``, e.g.
                           ``kind=icr; y_icr_left=0.31; y_icr_right=-0.29; x_icr=0.02`` (the
                           parameters TOML's ``[model]`` table; empty: differential drive)
``noise``                  the random error the same way, e.g. ``k_left=2e-05; k_right=2e-05``
                           (the ``[noise]`` table; empty: none)
``status``                 awaiting / measured / excluded (default: measured when a
                           measurement is filled in, else awaiting)
``exclusion_reason``       required when status is excluded
``instrument``             e.g. compass, meterstick (default: compass when compass readings are
                           given, meterstick when x and y are)
``measured_rotation_rad``  actual rotation (rad, unwrapped); computed from the compass columns
                           when empty
``measured_x_m``           actual x (m, start frame)
``measured_y_m``           actual y (m, start frame)
``sigma_rotation_rad``     standard uncertainty of the rotation (rad)
``sigma_xy_m``             standard uncertainty of x and y (m)
``compass_initial_deg``    compass before (deg, clockwise from north, [0, 360))
``compass_final_deg``      compass after (deg)
``turns``                  whole turns counted (integer >= 0)
``true_t_s`` ...           ``true_x_m``, ``true_y_m``, ``true_theta_rad``, ``true_heading_rad``:
                           the true pose (simulation only)
``notes``                  free text
``raw_<key>``              any other raw reading, kept in the measurement's ``raw`` as ``<key>``
=========================  =================================================================

A numeric cell may carry its column's unit ("2.5 m", "12 deg"); any other unit is refused.
A text cell that starts with ``=``, ``+``, ``-``, ``@``, a tab, a carriage return or ``'`` is
written after a ``'`` so that a spreadsheet shows it and runs nothing; the reader takes one
leading ``'`` off any text cell (:func:`odolab.core.text.inert_csv_cell`).
Cells are separated by commas (or by semicolons or tabs, recognised from the header line);
numbers use a decimal point.
Every error names the file, the line and the column, and is raised before anything is written.
Units, headers and plausible ranges come from the one trial-record definition,
:data:`odolab.core.trials.TRIAL_FIELDS`; every row passes :func:`odolab.core.trials.validate_trial`, the
same check as ``odolab trials add``.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

from odolab.core.errors import InvalidTrialError, ParamsError, StoreError
from odolab.core.kinematics import wrap_angle
from odolab.core.measurement import check_position, rotation_measurement_from_compass
from odolab.core.models import DIFF_DRIVE, model_from_mapping
from odolab.core.params import RobotParams, check_param, noise_from_mapping
from odolab.core.text import inert_csv_cell, quote_input, read_csv_cell
from odolab.core.trajectory import Pose
from odolab.core.trials import (
    TRIAL_FIELDS,
    Command,
    Measurement,
    MotionKind,
    Trial,
    TrialStatus,
    signed_command,
    trial_field,
    validate_trial,
)
from odolab.core.writing import replacing_file
from odolab.store.records import record_from_trial

__all__ = ["COLUMNS", "REQUIRED", "ParsedRow", "read_trials_csv", "write_trials_csv"]

#: The parameter columns of a row (CSV only: the notebook keeps them as parameter versions).
_PARAM_UNITS: dict[str, str] = {
    "left_wheel_radius_m": "m",
    "right_wheel_radius_m": "m",
    "track_width_m": "m",
    "ticks_per_rev": "",
    "encoder_modulus": "",
}
#: The kinematic model and the noise of the row's parameter set, as ``key=value; ...`` text.
_TABLE_COLUMNS: dict[str, str | None] = {"model": None, "noise": None}
#: The compass readings and counted turns (CSV only: kept in the measurement's ``raw``).
_RAW_UNITS: dict[str, str] = {"compass_initial_deg": "deg", "compass_final_deg": "deg", "turns": ""}
_RAW_COLUMNS = tuple(_RAW_UNITS)
_PARAM_COLUMNS = tuple(c for c in _PARAM_UNITS if c != "encoder_modulus")
#: The column of each parameter -> its key in odolab.core.params (checked by ``check_param``).
_PARAM_KEYS = {c: c.removesuffix("_m") for c in _PARAM_UNITS}
_POSE = ("t", "x", "y", "theta", "heading")
_E = TypeVar("_E", MotionKind, TrialStatus)
_N = TypeVar("_N", int | None, float)


def _fields(*names: str) -> dict[str, str | None]:
    return {trial_field(n).csv: trial_field(n).unit for n in names}


#: Column name -> unit ("" for a number without unit, None for text), in file order; the trial
#: columns' names and units are those of :data:`odolab.core.trials.TRIAL_FIELDS`.
COLUMNS: dict[str, str | None] = {
    **_fields("trial_id", "campaign", "terrain", "kind", "angle", "distance", "side"),
    **_fields("direction", "speed", *(f"predicted_{k}" for k in _POSE), "robot"),
    **_fields("params_version"),
    **_PARAM_UNITS,
    **_TABLE_COLUMNS,
    **_fields("status", "exclusion_reason", "instrument", "measured_rotation", "measured_x"),
    **_fields("measured_y", "sigma_rotation", "sigma_xy"),
    **_RAW_UNITS,
    **_fields(*(f"true_{k}" for k in _POSE), "notes"),
}

#: Columns every file must have (and every row must fill); ``status`` has a default.
REQUIRED = tuple(f.csv for f in TRIAL_FIELDS if f.required and f.name != "status")

_UNITS = {"m", "cm", "mm", "km", "in", "ft", "rad", "deg", "degrees", "s", "ms", "min", "pi"}
_UNIT_WORDS = {"m": "metres", "rad": "radians", "deg": "degrees", "s": "seconds"}
_NUM_UNIT = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([A-Za-z°]+)\s*$")


def _unit_of(header: str) -> tuple[str, str] | None:
    """Split ``distance_cm`` into ("distance", "cm") when the suffix looks like a unit."""
    base, _, unit = header.rpartition("_")
    return (base, unit) if base and unit in _UNITS else None


_BASES = {
    parts[0]: name
    for name, unit in COLUMNS.items()
    if unit and (parts := _unit_of(name)) is not None
}


@dataclass(frozen=True)
class ParsedRow:
    """One checked row: its line in the file, the trial and the parameter version it names."""

    line: int
    trial: Trial
    params_version: int | None  #: a version known to the notebook with the row's values


def _or_zero(value: float | None) -> float:
    """``value``, or 0.0 when missing (keeping the sign of -0.0, unlike ``value or 0.0``)."""
    return 0.0 if value is None else value


class _Row:
    """Typed access to the cells of one row, every error naming the line and the column."""

    def __init__(self, source: str, line: int, cells: dict[str, str]) -> None:
        self.source, self.line, self.cells = source, line, cells

    def fail(self, column: str, problem: str) -> StoreError:
        return StoreError(f"{self.source}: line {self.line}, column {column!r}: {problem}")

    def given(self, column: str) -> bool:
        return bool(self.cells.get(column, "").strip())

    def text(self, column: str, *, required: bool = False) -> str | None:
        value = read_csv_cell(self.cells.get(column, "").strip())  # "'=1" was written for "=1"
        if not value:
            if required:
                raise self.fail(column, "missing value")
            return None
        return value

    def required_text(self, column: str) -> str:
        value = self.text(column, required=True)
        assert value is not None
        return value

    def _parse(self, column: str, cell: str) -> float:
        unit = COLUMNS.get(column) or ""
        try:
            return float(cell)
        except ValueError:
            pass
        m = _NUM_UNIT.match(cell)
        if m is None:
            what = f"a number in {_UNIT_WORDS.get(unit, unit)}" if unit else "a number"
            raise self.fail(column, f"{quote_input(cell)} is not a number; expected {what}")
        given = m.group(2).replace("°", "deg")
        if given != unit:
            expected = f"{unit} ({_UNIT_WORDS.get(unit, unit)})" if unit else "no unit"
            raise self.fail(
                column,
                f"{quote_input(cell)} has the wrong unit {quote_input(given)}; expected {expected}",
            )
        return float(m.group(1))

    def number(
        self, column: str, *, required: bool = False, positive: bool = False
    ) -> float | None:
        cell = self.cells.get(column, "").strip()
        if not cell:
            if required:
                raise self.fail(column, "missing value")
            return None
        value = self._parse(column, cell)
        if not math.isfinite(value):
            raise self.fail(column, f"{quote_input(cell)} is not a finite number")
        if positive and value <= 0:
            raise self.fail(column, f"{quote_input(cell)} must be positive")
        return value

    def required_number(self, column: str) -> float:
        value = self.number(column, required=True)
        assert value is not None
        return value

    def integer(self, column: str, *, minimum: int = 0, maximum: int = 2**62) -> int | None:
        value = self.number(column)
        if value is None:
            return None
        if not value.is_integer() or not minimum <= value <= maximum:
            raise self.fail(
                column,
                f"{quote_input(self.cells[column].strip())}; expected a whole number from "
                f"{minimum} to {maximum}",
            )
        return int(value)

    def choice(self, column: str, enum: type[_E]) -> _E | None:
        text = self.text(column)
        if text is None:
            return None
        try:
            return enum(text)
        except ValueError:
            expected = ", ".join(e.value for e in enum)
            raise self.fail(column, f"{quote_input(text)}; expected one of {expected}") from None


def _check_header(source: str, header: list[str]) -> None:
    seen: set[str] = set()
    for name in header:
        if name in seen:
            raise StoreError(f"{source}: line 1, column {quote_input(name)} appears twice")
        seen.add(name)
        if name in COLUMNS or (name.startswith("raw_") and len(name) > 4):
            continue
        split = _unit_of(name)
        if split is not None and split[0] in _BASES:
            good = _BASES[split[0]]
            unit = COLUMNS[good] or ""
            raise StoreError(
                f"{source}: line 1, column {quote_input(name)} is in unit {split[1]!r}; expected "
                f"{good!r} ({_UNIT_WORDS.get(unit, unit)})"
            )
        raise StoreError(
            f"{source}: line 1, unknown column {quote_input(name)}; see docs/notebook.md for the "
            "columns"
        )
    for name in REQUIRED:
        if name not in seen:
            raise StoreError(
                f"{source}: line 1, the required column {quote_input(name)} is missing"
            )


# -- one row, one piece at a time ------------------------------------------------------------------


def _command(row: _Row) -> Command:
    kind = row.choice("kind", MotionKind)
    if kind is None:
        raise row.fail("kind", "missing value")
    command = signed_command(
        Command(
            kind=kind,
            angle=row.number("angle_rad"),
            distance=row.number("distance_m"),
            side=row.number("side_m", positive=True),
            direction=row.text("direction"),
            speed=row.number("speed"),
        )
    )
    if kind is MotionKind.TRANSLATION and command.distance is None:
        raise row.fail("distance_m", "missing value (a translation needs its commanded distance)")
    return command


def _pose(row: _Row, prefix: str) -> Pose | None:
    """The predicted (required) or true (optional, all or nothing) pose of the row."""
    cols = {k: trial_field(f"{prefix}_{k}").csv for k in _POSE}
    if prefix == "true" and not any(row.given(c) for c in cols.values()):
        return None
    for k in ("x", "y", "heading"):
        if prefix == "true" and not row.given(cols[k]):
            raise row.fail(cols[k], "missing value (the true pose is given in part)")
    heading = row.required_number(cols["heading"])
    theta = row.number(cols["theta"])
    return Pose(
        _or_zero(row.number(cols["t"])),
        row.required_number(cols["x"]),
        row.required_number(cols["y"]),
        float(wrap_angle(heading)) if theta is None else theta,
        heading,
    )


def _plausible(row: _Row, column: str, value: _N) -> _N:
    """``value`` if it is in the plausible range of its parameter (:data:`odolab.core.params.RANGES`)."""
    if value is not None:
        try:
            check_param(_PARAM_KEYS[column], value)
        except ParamsError as err:
            raise row.fail(column, str(err)) from err
    return value


def _table_cell(row: _Row, column: str) -> dict[str, float | str] | None:
    """A ``model`` or ``noise`` cell (``key=value; ...``) as a TOML-like table, None when empty."""
    text = row.text(column)
    if text is None:
        return None
    table: dict[str, float | str] = {}
    for part in text.split(";"):
        if not part.strip():
            continue
        key, eq, value = (x.strip() for x in part.partition("="))
        if not eq or not key or not value:
            raise row.fail(
                column, f"{quote_input(part.strip())}; expected key=value pairs separated by ';'"
            )
        if key in table:
            raise row.fail(column, f"key {quote_input(key)} is given twice")
        if column == "model" and key == "kind":
            table[key] = value
            continue
        try:
            table[key] = float(value)
        except ValueError:
            raise row.fail(
                column, f"{quote_input(key)} = {quote_input(value)} is not a number"
            ) from None
    return table


def _table_text(table: Mapping[str, object] | None) -> str:
    """The cell of a ``model`` or ``noise`` table (``kind`` first; floats round-trip exactly)."""
    if not table:
        return ""
    return "; ".join(f"{k}={v!r}" if isinstance(v, float) else f"{k}={v}" for k, v in table.items())


def _params_by_value(row: _Row, robot: str, version: int | None, known: bool) -> RobotParams:
    values: dict[str, float] = {}
    for c in _PARAM_COLUMNS:
        v = row.number(c, positive=True)
        if v is None:
            if version is not None and not known:
                raise row.fail(
                    "params_version",
                    f"version {version} of {robot!r} is not in the notebook, and the "
                    f"parameter values are not all given ({c!r} is empty)",
                )
            raise row.fail(c, "missing value")
        values[c] = _plausible(row, c, v)
    model, noise = _table_cell(row, "model"), _table_cell(row, "noise")
    try:
        kinematic = DIFF_DRIVE if model is None else model_from_mapping(model, source="")
        random = None if noise is None else noise_from_mapping(noise, source="")
    except ParamsError as err:
        column = "model" if noise is None or "[model]" in str(err) else "noise"
        raise row.fail(column, str(err).removeprefix(": ")) from err
    try:
        return RobotParams(
            name=robot,
            left_wheel_radius=values["left_wheel_radius_m"],
            right_wheel_radius=values["right_wheel_radius_m"],
            track_width=values["track_width_m"],
            ticks_per_rev=values["ticks_per_rev"],
            encoder_modulus=_plausible(
                row, "encoder_modulus", row.integer("encoder_modulus", minimum=2, maximum=2**63 - 1)
            ),
            model=kinematic,
            noise=random,
        )
    except ParamsError as err:
        raise row.fail("robot", str(err)) from err


def _params(
    row: _Row, lookup_params: Callable[[str, int], RobotParams | None]
) -> tuple[RobotParams, int | None]:
    """Parameters by version, by value, or both (then they must agree); the known version."""
    robot = row.required_text("robot")
    version = row.integer("params_version", minimum=1)
    row.integer(
        "encoder_modulus", minimum=2, maximum=2**63 - 1
    )  # checked even when the version decides
    stored = lookup_params(robot, version) if version is not None else None
    by_value = any(row.given(c) for c in (*_PARAM_COLUMNS, *_TABLE_COLUMNS))
    if stored is not None and not by_value:
        return stored, version
    params = _params_by_value(row, robot, version, stored is not None)
    if stored is not None and stored != params:
        raise row.fail(
            "params_version",
            f"version {version} of {robot!r} in the notebook has other values than this row",
        )
    return params, version if stored is not None else None


def _raw_readings(row: _Row, raw_columns: Sequence[str]) -> dict[str, float]:
    """Compass readings with the turn count (all three or none), then ``raw_<key>`` columns."""
    raw: dict[str, float] = {}
    if any(row.given(c) for c in _RAW_COLUMNS):
        for c in _RAW_COLUMNS:
            if not row.given(c):
                raise row.fail(c, "missing value (compass readings come with the turn count)")
        for c in ("compass_initial_deg", "compass_final_deg"):
            v = row.required_number(c)
            if not 0.0 <= v < 360.0:
                raise row.fail(c, f"{v:g} deg is outside the compass range [0, 360)")
            raw[c] = v
        raw["turns"] = float(row.integer("turns", minimum=0) or 0)
    for c in raw_columns:
        value = row.number(c)
        if value is not None:
            raw[c[4:]] = value
    return raw


def _sigma(row: _Row, column: str) -> float | None:
    v = row.number(column)
    if v is not None and v < 0:
        raise row.fail(column, f"{v:g} is negative; an uncertainty is >= 0")
    return v


def _rotation_from_compass(
    row: _Row, raw: dict[str, float], command: Command, instrument: str | None
) -> Measurement:
    try:
        return rotation_measurement_from_compass(
            raw["compass_initial_deg"],
            raw["compass_final_deg"],
            int(raw["turns"]),
            commanded_angle=command.angle,
            direction="cw" if command.direction == "cw" else None,
            instrument=instrument or "compass",
        )
    except StoreError as err:
        raise row.fail("turns", str(err)) from err


def _measurement(row: _Row, raw_columns: Sequence[str], command: Command) -> Measurement | None:
    """The measured values, or the rotation computed from the compass readings; or None."""
    raw = _raw_readings(row, raw_columns)
    rotation = row.number("measured_rotation_rad")
    mx, my = row.number("measured_x_m"), row.number("measured_y_m")
    if (mx is None) != (my is None):
        raise row.fail("measured_y_m" if my is None else "measured_x_m", "missing value")
    for c, v in (("measured_x_m", mx), ("measured_y_m", my)):
        try:
            if v is not None:
                check_position(v, c)  # the range `trials add` and `trials measure` apply
        except StoreError as err:
            raise row.fail(c, str(err)) from err
    sigma_rot, sigma_xy = _sigma(row, "sigma_rotation_rad"), _sigma(row, "sigma_xy_m")
    instrument = row.text("instrument")
    if rotation is None and "turns" in raw:
        from_compass = _rotation_from_compass(row, raw, command, instrument)
        rotation = from_compass.rotation
        sigma_rot = from_compass.sigma_rotation if sigma_rot is None else sigma_rot
    if rotation is None and mx is None:
        if raw:
            raise row.fail("measured_rotation_rad", "raw readings given but no measured value")
        if sigma_rot is not None or sigma_xy is not None:
            raise row.fail("sigma_rotation_rad" if sigma_rot is not None else "sigma_xy_m",
                           "an uncertainty without a measured value")  # fmt: skip
        return None
    if instrument is None:
        instrument = "compass" if "turns" in raw else "meterstick" if mx is not None else None
    if instrument is None:
        raise row.fail("instrument", "missing value (which instrument measured this?)")
    return Measurement(instrument, rotation, mx, my, sigma_rot, sigma_xy, raw)


def _status(row: _Row, measured: Measurement | None) -> tuple[TrialStatus, str | None]:
    reason = row.text("exclusion_reason")
    status = row.choice("status", TrialStatus)
    if status is None:
        status = TrialStatus.MEASURED if measured is not None else TrialStatus.AWAITING
        status = TrialStatus.EXCLUDED if reason is not None else status
    if status is TrialStatus.EXCLUDED and reason is None:
        raise row.fail("exclusion_reason", "missing value (an excluded trial needs a reason)")
    if status is TrialStatus.MEASURED and measured is None:
        raise row.fail("status", "'measured' but no measurement is filled in")
    if status is TrialStatus.AWAITING and measured is not None:
        raise row.fail("status", "'awaiting' but a measurement is filled in")
    return status, reason


def _parse_row(
    row: _Row,
    raw_columns: Sequence[str],
    lookup_params: Callable[[str, int], RobotParams | None],
) -> ParsedRow:
    """The trial of one row: command, prediction, parameters, measurement, status, truth."""
    command = _command(row)
    predicted = _pose(row, "predicted")
    assert predicted is not None
    params, version = _params(row, lookup_params)
    measured = _measurement(row, raw_columns, command)
    status, reason = _status(row, measured)
    trial = Trial(
        trial_id=row.required_text("trial_id"),
        campaign=row.required_text("campaign"),
        terrain=row.required_text("terrain"),
        command=command,
        predicted=predicted,
        params=params,
        measured=measured,
        true=_pose(row, "true"),
        status=status,
        exclusion_reason=reason,
        notes=read_csv_cell(row.cells.get("notes", "")),
    )
    try:
        validate_trial(trial)  # its direction word against its numbers too
    except InvalidTrialError as err:
        column = trial_field(err.field).csv if err.field else "trial_id"
        raise row.fail(column, str(err).removeprefix(f"trial {trial.trial_id}: ")) from err
    return ParsedRow(row.line, trial, version)


def read_trials_csv(
    path: str | Path,
    *,
    known_campaigns: set[str] | None = None,
    known_trial_ids: set[str] | frozenset[str] = frozenset(),
    lookup_params: Callable[[str, int], RobotParams | None] = lambda robot, version: None,
) -> list[ParsedRow]:
    """Read and check every row of a trials CSV; raise on the first bad cell.

    ``known_campaigns``: when given, a campaign not in it is an error. ``known_trial_ids``: ids
    already stored (a row repeating one is an error). ``lookup_params(robot, version)`` gives a
    stored parameter version or None.

    Raises:
        StoreError: the file is unreadable, not UTF-8, empty, not CSV, or a line has the wrong
            number of cells (the line is named).
    """
    from odolab.io.limits import check_text_file  # here: odolab.io brings pandas

    p = Path(path)
    source = str(p)
    check_text_file(p, error=StoreError, expected="a trials CSV")
    try:
        fh = p.open(newline="", encoding="utf-8-sig")
    except OSError as err:
        raise StoreError(f"{source}: cannot read ({err.strerror or err})") from err
    out: list[ParsedRow] = []
    first_line: dict[str, int] = {}
    with fh:
        try:
            first = fh.readline()
        except UnicodeDecodeError as err:
            raise StoreError(f"{source}: line 1: not UTF-8 text ({err.reason})") from err
        fh.seek(0)
        # a spreadsheet saved in a locale with decimal commas separates with ';' (or a tab)
        sep = ";" if first.count(";") > first.count(",") else ","
        sep = "\t" if first.count("\t") > first.count(sep) else sep
        reader = csv.reader(fh, delimiter=sep)
        try:
            header = [h.strip() for h in next(reader)]
        except StopIteration:
            raise StoreError(f"{source}: empty file; expected a header line") from None
        except (csv.Error, UnicodeDecodeError) as err:
            raise StoreError(f"{source}: line 1: not readable as CSV ({err})") from err
        _check_header(source, header)
        raw_columns = [h for h in header if h.startswith("raw_")]
        try:
            for cells in reader:
                line = reader.line_num
                if not any(c.strip() for c in cells):
                    continue
                if len(cells) > len(header):
                    raise StoreError(
                        f"{source}: line {line}: {len(cells)} cells but {len(header)} columns"
                    )
                row = _Row(source, line, dict(zip(header, cells, strict=False)))
                parsed = _parse_row(row, raw_columns, lookup_params)
                tid = parsed.trial.trial_id
                if tid in first_line:
                    raise row.fail(
                        "trial_id", f"{quote_input(tid)} is a duplicate of line {first_line[tid]}"
                    )
                if tid in known_trial_ids:
                    raise row.fail("trial_id", f"{quote_input(tid)} is already in the notebook")
                first_line[tid] = line
                camp = parsed.trial.campaign
                if known_campaigns is not None and camp not in known_campaigns:
                    raise row.fail(
                        "campaign",
                        f"unknown campaign {quote_input(camp)}; add it first (odolab trials campaign-add) "
                        "or import with {{create_campaigns}}",
                    )
                out.append(parsed)
        except (csv.Error, UnicodeDecodeError) as err:
            raise StoreError(
                f"{source}: line {reader.line_num}: not readable as CSV ({err})"
            ) from err
    return out


def _fmt(value: object) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value)


def _csv_row(t: Trial, version: int | None, extra: Sequence[str]) -> list[str]:
    """The cells of one trial, in :data:`COLUMNS` order, then ``raw_<key>`` for ``extra``."""
    rec = record_from_trial(t, version)
    par = t.params
    raw = dict(t.measured.raw) if t.measured is not None else {}
    turns = raw.get("turns")
    if turns is not None and float(turns).is_integer():
        raw["turns"] = int(turns)
    by_csv = {f.csv: rec[f.name] for f in TRIAL_FIELDS if f.name != "raw"}
    by_csv.update(
        {
            "left_wheel_radius_m": par.left_wheel_radius,
            "right_wheel_radius_m": par.right_wheel_radius,
            "track_width_m": par.track_width,
            "ticks_per_rev": par.ticks_per_rev,
            "encoder_modulus": par.encoder_modulus,
            "model": _table_text(par.model_table()),
            "noise": _table_text(None if par.noise is None else par.noise.to_dict()),
        }
    )
    by_csv.update({c: raw.get(c) for c in _RAW_COLUMNS})
    # a text cell a spreadsheet would run as a formula gets a leading "'" (numbers stay numbers)
    cells = [
        inert_csv_cell(_fmt(by_csv[c])) if unit is None else _fmt(by_csv[c])
        for c, unit in COLUMNS.items()
    ]
    return cells + [_fmt(raw.get(k)) for k in extra]


def write_trials_csv(path: str | Path, trials: Iterable[tuple[Trial, int | None]]) -> Path:
    """Write ``(trial, params_version)`` pairs with the :data:`COLUMNS` (and ``raw_<key>``)."""
    items = list(trials)
    extra = sorted(
        {
            k
            for t, _ in items
            if t.measured is not None
            for k in t.measured.raw
            if k not in _RAW_COLUMNS
        }
    )
    header = [*COLUMNS, *(f"raw_{k}" for k in extra)]
    p = Path(path)
    with replacing_file(p, newline="", what="trials CSV", error=StoreError) as fh:
        w = csv.writer(fh)  # "\r\n" ends rows, so a lone "\r" or "\n" in a cell is quoted
        w.writerow(header)
        for t, version in items:
            w.writerow(_csv_row(t, version, extra))
    return p

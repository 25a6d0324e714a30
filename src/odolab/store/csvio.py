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
``direction``              cw/ccw (square), left/right (pivot)
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
Cells are separated by commas (or by semicolons or tabs, recognised from the header line);
numbers use a decimal point.
Every error names the file, the line and the column, and is raised before anything is written.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from odolab.errors import ParamsError, StoreError
from odolab.kinematics import wrap_angle
from odolab.params import RobotParams, check_param
from odolab.store.entry import check_position, rotation_measurement_from_compass
from odolab.text import quote_input
from odolab.trajectory import Pose
from odolab.trials import Command, Measurement, MotionKind, Trial, TrialStatus

__all__ = ["COLUMNS", "REQUIRED", "ParsedRow", "read_trials_csv", "write_trials_csv"]

#: Column name -> unit ("" for a number without unit, None for text), in file order.
COLUMNS: dict[str, str | None] = {
    "trial_id": None,
    "campaign": None,
    "terrain": None,
    "kind": None,
    "angle_rad": "rad",
    "distance_m": "m",
    "side_m": "m",
    "direction": None,
    "speed": "",
    "predicted_t_s": "s",
    "predicted_x_m": "m",
    "predicted_y_m": "m",
    "predicted_theta_rad": "rad",
    "predicted_heading_rad": "rad",
    "robot": None,
    "params_version": "",
    "left_wheel_radius_m": "m",
    "right_wheel_radius_m": "m",
    "track_width_m": "m",
    "ticks_per_rev": "",
    "encoder_modulus": "",
    "status": None,
    "exclusion_reason": None,
    "instrument": None,
    "measured_rotation_rad": "rad",
    "measured_x_m": "m",
    "measured_y_m": "m",
    "sigma_rotation_rad": "rad",
    "sigma_xy_m": "m",
    "compass_initial_deg": "deg",
    "compass_final_deg": "deg",
    "turns": "",
    "true_t_s": "s",
    "true_x_m": "m",
    "true_y_m": "m",
    "true_theta_rad": "rad",
    "true_heading_rad": "rad",
    "notes": None,
}

#: Columns every file must have (and every row must fill).
REQUIRED = (
    "trial_id",
    "campaign",
    "terrain",
    "kind",
    "predicted_x_m",
    "predicted_y_m",
    "predicted_heading_rad",
    "robot",
)

_RAW_COLUMNS = ("compass_initial_deg", "compass_final_deg", "turns")
_PARAM_COLUMNS = ("left_wheel_radius_m", "right_wheel_radius_m", "track_width_m", "ticks_per_rev")
_PARAM_KEYS = ("left_wheel_radius", "right_wheel_radius", "track_width", "ticks_per_rev")
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

    def text(self, column: str, *, required: bool = False) -> str | None:
        value = self.cells.get(column, "").strip()
        if not value:
            if required:
                raise self.fail(column, "missing value")
            return None
        return value

    def number(
        self, column: str, *, required: bool = False, positive: bool = False
    ) -> float | None:
        cell = self.cells.get(column, "").strip()
        if not cell:
            if required:
                raise self.fail(column, "missing value")
            return None
        unit = COLUMNS.get(column) or ""
        try:
            value = float(cell)
        except ValueError:
            m = _NUM_UNIT.match(cell)
            if m is None:
                what = f"a number in {_UNIT_WORDS.get(unit, unit)}" if unit else "a number"
                raise self.fail(
                    column, f"{quote_input(cell)} is not a number; expected {what}"
                ) from None
            given = m.group(2).replace("°", "deg")
            if given != unit:
                expected = f"{unit} ({_UNIT_WORDS.get(unit, unit)})" if unit else "no unit"
                raise self.fail(
                    column,
                    f"{quote_input(cell)} has the wrong unit {quote_input(given)}; expected {expected}",
                ) from None
            value = float(m.group(1))
        if not math.isfinite(value):
            raise self.fail(column, f"{quote_input(cell)} is not a finite number")
        if positive and value <= 0:
            raise self.fail(column, f"{quote_input(cell)} must be positive")
        return value

    def integer(self, column: str, *, minimum: int = 0) -> int | None:
        value = self.number(column)
        if value is None:
            return None
        if not value.is_integer() or value < minimum:
            raise self.fail(
                column,
                f"{quote_input(self.cells[column].strip())}; expected a whole number >= {minimum}",
            )
        return int(value)


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
            f"{source}: line 1, unknown column {quote_input(name)}; see docs/notebook.md for the columns"
        )
    for name in REQUIRED:
        if name not in seen:
            raise StoreError(
                f"{source}: line 1, the required column {quote_input(name)} is missing"
            )


def _parse_row(
    row: _Row,
    raw_columns: Sequence[str],
    lookup_params: Callable[[str, int], RobotParams | None],
) -> ParsedRow:
    kind_text = row.text("kind", required=True)
    try:
        kind = MotionKind(str(kind_text))
    except ValueError:
        raise row.fail(
            "kind",
            f"{quote_input(kind_text)}; expected one of {', '.join(k.value for k in MotionKind)}",
        ) from None
    angle = row.number("angle_rad")
    command = Command(
        kind=kind,
        angle=angle,
        distance=row.number("distance_m"),
        side=row.number("side_m", positive=True),
        direction=row.text("direction"),
        speed=row.number("speed"),
    )
    if kind is MotionKind.TRANSLATION and command.distance is None:
        raise row.fail("distance_m", "missing value (a translation needs its commanded distance)")
    heading = row.number("predicted_heading_rad", required=True)
    assert heading is not None
    theta = row.number("predicted_theta_rad")
    predicted = Pose(
        _or_zero(row.number("predicted_t_s")),
        _or_zero(row.number("predicted_x_m", required=True)),
        _or_zero(row.number("predicted_y_m", required=True)),
        float(wrap_angle(heading)) if theta is None else theta,
        heading,
    )

    # parameters: by version, by value, or both (then they must agree)
    robot = row.text("robot", required=True)
    assert robot is not None
    version = row.integer("params_version", minimum=1)
    stored = lookup_params(robot, version) if version is not None else None
    values = {c: row.number(c, positive=True) for c in _PARAM_COLUMNS}
    modulus = row.integer("encoder_modulus", minimum=2)
    # the same plausible ranges as every other way parameters are built (odolab.params)
    for c, key in (*zip(_PARAM_COLUMNS, _PARAM_KEYS, strict=True), ("encoder_modulus", None)):
        v = modulus if key is None else values[c]
        if v is not None:
            try:
                check_param(key or "encoder_modulus", v)
            except ParamsError as err:
                raise row.fail(c, str(err)) from err
    if any(v is not None for v in values.values()) or stored is None:
        for c, v in values.items():
            if v is None:
                if version is not None and stored is None:
                    raise row.fail(
                        "params_version",
                        f"version {version} of {robot!r} is not in the notebook, and the "
                        f"parameter values are not all given ({c!r} is empty)",
                    )
                raise row.fail(c, "missing value")
        try:
            params = RobotParams(
                name=robot,
                left_wheel_radius=values["left_wheel_radius_m"],  # type: ignore[arg-type]
                right_wheel_radius=values["right_wheel_radius_m"],  # type: ignore[arg-type]
                track_width=values["track_width_m"],  # type: ignore[arg-type]
                ticks_per_rev=values["ticks_per_rev"],  # type: ignore[arg-type]
                encoder_modulus=modulus,
            )
        except ParamsError as err:  # pragma: no cover - cells are checked above
            raise row.fail("robot", str(err)) from err
        if stored is not None and stored != params:
            raise row.fail(
                "params_version",
                f"version {version} of {robot!r} in the notebook has other values than this row",
            )
    else:
        params = stored
    known_version = version if stored is not None else None

    # measurement: compass readings and turns, or the values themselves
    raw: dict[str, float] = {}
    compass = {c: row.number(c) for c in _RAW_COLUMNS}
    if any(v is not None for v in compass.values()):
        for c, v in compass.items():
            if v is None:
                raise row.fail(c, "missing value (compass readings come with the turn count)")
        for c in ("compass_initial_deg", "compass_final_deg"):
            if not 0.0 <= compass[c] < 360.0:  # type: ignore[operator]
                raise row.fail(c, f"{compass[c]:g} deg is outside the compass range [0, 360)")
        row.integer("turns", minimum=0)
        raw.update({c: v for c, v in compass.items() if v is not None})
    for c in raw_columns:
        value = row.number(c)
        if value is not None:
            raw[c[4:]] = value
    rotation = row.number("measured_rotation_rad")
    mx, my = row.number("measured_x_m"), row.number("measured_y_m")
    if (mx is None) != (my is None):
        raise row.fail("measured_y_m" if my is None else "measured_x_m", "missing value")
    for c, v in (("measured_x_m", mx), ("measured_y_m", my)):
        if v is not None:
            try:
                check_position(v, c)  # the range `trials add` and `trials measure` apply
            except StoreError as err:
                raise row.fail(c, str(err)) from err
    sigma_rot = row.number("sigma_rotation_rad")
    sigma_xy = row.number("sigma_xy_m")
    for c, v in (("sigma_rotation_rad", sigma_rot), ("sigma_xy_m", sigma_xy)):
        if v is not None and v < 0:
            raise row.fail(c, f"{v:g} is negative; an uncertainty is >= 0")
    instrument = row.text("instrument")
    measured: Measurement | None = None
    if rotation is None and "turns" in raw:
        try:
            from_compass = rotation_measurement_from_compass(
                raw["compass_initial_deg"],
                raw["compass_final_deg"],
                int(raw["turns"]),
                commanded_angle=angle,
                direction="cw" if command.direction == "cw" else None,
                instrument=instrument or "compass",
            )
        except StoreError as err:
            raise row.fail("turns", str(err)) from err
        rotation = from_compass.rotation
        if sigma_rot is None:
            sigma_rot = from_compass.sigma_rotation
    if rotation is not None or mx is not None or raw:
        if rotation is None and mx is None:
            raise row.fail("measured_rotation_rad", "raw readings given but no measured value")
        if instrument is None:
            instrument = "compass" if "turns" in raw else "meterstick" if mx is not None else None
        if instrument is None:
            raise row.fail("instrument", "missing value (which instrument measured this?)")
        measured = Measurement(
            instrument=instrument,
            rotation=rotation,
            x=mx,
            y=my,
            sigma_rotation=sigma_rot,
            sigma_xy=sigma_xy,
            raw=raw,
        )
    elif sigma_rot is not None or sigma_xy is not None:
        raise row.fail("sigma_rotation_rad" if sigma_rot is not None else "sigma_xy_m",
                       "an uncertainty without a measured value")  # fmt: skip

    status_text = row.text("status")
    reason = row.text("exclusion_reason")
    if status_text is None:
        status = TrialStatus.MEASURED if measured is not None else TrialStatus.AWAITING
        if reason is not None:
            status = TrialStatus.EXCLUDED
    else:
        try:
            status = TrialStatus(status_text)
        except ValueError:
            raise row.fail(
                "status",
                f"{quote_input(status_text)}; expected one of {', '.join(s.value for s in TrialStatus)}",
            ) from None
    if status is TrialStatus.EXCLUDED and reason is None:
        raise row.fail("exclusion_reason", "missing value (an excluded trial needs a reason)")
    if status is TrialStatus.MEASURED and measured is None:
        raise row.fail("status", "'measured' but no measurement is filled in")
    if status is TrialStatus.AWAITING and measured is not None:
        raise row.fail("status", "'awaiting' but a measurement is filled in")

    true_cols = ("true_t_s", "true_x_m", "true_y_m", "true_theta_rad", "true_heading_rad")
    true_vals = {c: row.number(c) for c in true_cols}
    true: Pose | None = None
    if any(v is not None for c, v in true_vals.items()):
        for c in ("true_x_m", "true_y_m", "true_heading_rad"):
            if true_vals[c] is None:
                raise row.fail(c, "missing value (the true pose is given in part)")
        th = true_vals["true_heading_rad"]
        assert th is not None
        true = Pose(
            _or_zero(true_vals["true_t_s"]),
            _or_zero(true_vals["true_x_m"]),
            _or_zero(true_vals["true_y_m"]),
            float(wrap_angle(th)) if true_vals["true_theta_rad"] is None
            else true_vals["true_theta_rad"],  # type: ignore[arg-type]
            th,
        )  # fmt: skip

    trial = Trial(
        trial_id=row.text("trial_id", required=True),  # type: ignore[arg-type]
        campaign=row.text("campaign", required=True),  # type: ignore[arg-type]
        terrain=row.text("terrain", required=True),  # type: ignore[arg-type]
        command=command,
        predicted=predicted,
        params=params,
        measured=measured,
        true=true,
        status=status,
        exclusion_reason=reason,
        notes=row.cells.get("notes", ""),
    )
    return ParsedRow(row.line, trial, known_version)


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
                        "or import with --create-campaigns",
                    )
                out.append(parsed)
        except (csv.Error, UnicodeDecodeError) as err:
            raise StoreError(
                f"{source}: line {reader.line_num}: not readable as CSV ({err})"
            ) from err
    return out


def _fmt(value: float | int | str | None) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value)


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
    p.parent.mkdir(parents=True, exist_ok=True)
    with p.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)  # "\r\n" ends rows, so a lone "\r" or "\n" in a cell is quoted
        w.writerow(header)
        for t, version in items:
            c, pr, m, tr, par = t.command, t.predicted, t.measured, t.true, t.params
            raw = dict(m.raw) if m is not None else {}
            turns = raw.get("turns")
            row: list[float | int | str | None] = [
                t.trial_id, t.campaign, t.terrain, c.kind.value, c.angle, c.distance, c.side,
                c.direction, c.speed, pr.t, pr.x, pr.y, pr.theta, pr.heading, par.name, version,
                par.left_wheel_radius, par.right_wheel_radius, par.track_width, par.ticks_per_rev,
                par.encoder_modulus, TrialStatus(t.status).value, t.exclusion_reason,
                m.instrument if m else None, m.rotation if m else None, m.x if m else None,
                m.y if m else None, m.sigma_rotation if m else None, m.sigma_xy if m else None,
                raw.get("compass_initial_deg"), raw.get("compass_final_deg"),
                int(turns) if turns is not None and float(turns).is_integer() else turns,
                tr.t if tr else None, tr.x if tr else None, tr.y if tr else None,
                tr.theta if tr else None, tr.heading if tr else None, t.notes,
                *(raw.get(k) for k in extra),
            ]  # fmt: skip
            w.writerow([_fmt(v) for v in row])
    return p

"""The report's ground-truth section: where a run's actual path came from when there was no
motion-capture lab (docs/ground-truth.md).

:func:`ground_truth_summary` reads what the ground-truth commands write: a tracked path
(``odolab track``: ``t,x,y,theta,heading,quality``, one row per tracked frame), a path read from
a long-exposure photo (``odolab track-photo``: ``t,x,y,quality``, three rows a dash) and its
``--overlay`` PNG (shown as the lab report's Fig. 2: the photo with the estimated path over it),
or an odometry + sensor calibration (``odolab calibrate sensor --json``), and returns a title,
readable rows and, for a PNG, the image.
``write_report(..., extra={"ground_truth": [summary, ...]})`` shows them as a section.
"""

from __future__ import annotations

import base64
import csv
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from odolab.core import numfmt
from odolab.core.errors import LogFormatError, opt

__all__ = ["ground_truth_summary"]


def fmt(v: float, sig: int = 4) -> str:
    return numfmt.plain(float(v), sig, strip=True)


_TRACK_COLUMNS = ("t", "x", "y", "heading", "quality")
_PHOTO_COLUMNS = ("t", "x", "y", "quality")
_MAX_BYTES = 200_000_000
_MAX_IMAGE_BYTES = 20_000_000  #: embedded in the page: a phone's photo, not a film
_PNG = b"\x89PNG\r\n\x1a\n"


def _numbers(
    path: Path, head: list[str], rows: list[list[str]], columns: tuple[str, ...], what: str
) -> NDArray[np.float64]:
    """The data rows' ``columns`` as numbers (two finite rows at least), one sentence if not."""
    idx = [head.index(c) for c in columns]
    values = []
    for n, row in enumerate(rows, start=2):
        try:
            values.append([float(row[i]) for i in idx])
        except (ValueError, IndexError):
            raise LogFormatError(
                f"{path}: line {n} is {','.join(row)[:80]!r}; expected numbers in every column"
            ) from None
    a = np.array(values, dtype=np.float64).reshape(-1, len(columns))
    if len(a) < 2 or not np.isfinite(a).all():
        raise LogFormatError(f"{path}: {len(a)} finite rows; expected {what}")
    return a


def _photo_track(path: Path, head: list[str], rows: list[list[str]]) -> dict[str, object]:
    a = _numbers(path, head, rows, _PHOTO_COLUMNS, "a path read from a photo")
    t, x, y, q = a.T
    path_m = float(np.sum(np.hypot(np.diff(x), np.diff(y))))
    return {
        "title": f"Read from a long-exposure photo: {path.name}",
        "rows": [
            ("method", "a flashing LED's dashes on one photo, timed on the encoder log "
             "(odolab track-photo; position only, the heading is the path's tangent)"),
            ("rows (start, centre and end of each timed dash)", str(len(t))),
            ("time", f"{fmt(t[0], 4)} to {fmt(t[-1], 4)} s"),
            ("path length", f"{fmt(path_m, 4)} m"),
            ("quality, median / worst",
             f"{fmt(1000 * float(np.median(q)), 3)} / {fmt(1000 * float(q.max()), 3)} mm"),
        ],
    }  # fmt: skip


def _image(path: Path, data: bytes) -> dict[str, object]:
    if len(data) > _MAX_IMAGE_BYTES:
        raise LogFormatError(
            f"{path}: {len(data)} bytes; expected a PNG of at most {_MAX_IMAGE_BYTES} bytes "
            "(the report embeds it)"
        )
    return {
        "title": f"The photo with the estimated path: {path.name}",
        "rows": [
            ("what it shows", "the LED's dashes as read (the true path) and the odometry's path "
             "drawn over them (the overlay of odolab track-photo): where they part, the estimate drifts"),
        ],
        "image": base64.b64encode(data).decode("ascii"),
    }  # fmt: skip


def _track(path: Path, text: str) -> dict[str, object]:
    rows = list(csv.reader(text.splitlines()))
    if not rows:
        raise LogFormatError(f"{path}: empty; expected a tracked path or a calibrate sensor JSON")
    head = [h.strip() for h in rows[0]]
    if "heading" not in head and "theta" not in head and all(c in head for c in _PHOTO_COLUMNS):
        return _photo_track(path, head, rows[1:])
    missing = [c for c in _TRACK_COLUMNS if c not in head]
    if missing:
        raise LogFormatError(
            f"{path}: line 1 has no column {missing[0]!r}; expected odolab track's "
            "t,x,y,theta,heading,quality or odolab track-photo's t,x,y,quality"
        )
    a = _numbers(path, head, rows[1:], _TRACK_COLUMNS, "a tracked path")
    t, x, y, _, q = a.T
    dt = np.diff(t)
    frame = float(np.median(dt))
    gaps = int(np.sum(dt > 1.5 * frame)) if frame > 0 else 0
    path_m = float(np.sum(np.hypot(np.diff(x), np.diff(y))))
    return {
        "title": f"Tracked by a camera: {path.name}",
        "rows": [
            ("method", "a marker on the robot filmed over floor markers (odolab track)"),
            ("frames tracked", str(len(t))),
            ("time", f"{fmt(t[0], 4)} to {fmt(t[-1], 4)} s (frame every {fmt(frame, 3)} s)"),
            ("gaps (frames without the robot's marker)", str(gaps)),
            ("path length", f"{fmt(path_m, 4)} m"),
            (
                "marker fit quality, median / worst",
                f"{fmt(1000 * float(np.median(q)), 3)} / {fmt(1000 * float(q.max()), 3)} mm",
            ),
        ],
    }


def _sensor(
    path: Path, data: dict[str, Any]
) -> dict[str, object]:  # parsed JSON: the try checks its shape
    try:
        values, stderr = data["values"], data["stderr"]
        rows: list[tuple[str, str]] = [
            ("method", str(data.get("method", "odometry + sensor calibration"))),
            ("sensor", str(data.get("sensor", "-"))),
            ("intervals (outliers trimmed)",
             f"{int(data['intervals'])} ({int(data.get('outliers_trimmed', 0))})"),
            ("time offset (sensor minus encoder clock)", f"{fmt(data['time_offset_s'], 4)} s"),
        ]  # fmt: skip
        for key, value in values.items():
            # null is how a strict JSON file says not finite (odolab.core.writing.strict_json)
            v, se = (math.nan if x is None else float(x) for x in (value, stderr[key]))
            if not (math.isfinite(v) and math.isfinite(se)):
                raise ValueError(key)
            unit = "rad" if key.endswith("yaw") else "m"
            text = numfmt.with_uncertainty(v, se, show=True)
            rows.append((f"{key.replace('_', ' ')} ({unit})", text))
    except (KeyError, TypeError, ValueError, AttributeError) as err:
        raise LogFormatError(
            f"{path}: not an 'odolab calibrate sensor {opt('json')}' result ({err!s}); expected its "
            "values, stderr, intervals and time_offset_s"
        ) from None
    return {"title": f"Odometry and a sensor calibrated together: {path.name}", "rows": rows}


def ground_truth_summary(path: str | Path) -> dict[str, object]:
    """``{"title": str, "rows": [(label, text), ...]}`` (and ``"image"``, base64 PNG) for a
    tracked path CSV, a photo's path or overlay PNG, or a ``calibrate sensor --json`` file;
    one-sentence :class:`LogFormatError` otherwise.

    Raises:
        LogFormatError: the file is too large, unreadable, or not one of the ground-truth files
            odolab writes.
    """
    p = Path(path)
    try:
        if p.stat().st_size > _MAX_BYTES:
            raise LogFormatError(f"{p}: larger than {_MAX_BYTES} bytes; expected a summary file")
        data = p.read_bytes()
    except OSError as err:
        raise LogFormatError(f"{p}: cannot read it ({err.strerror or err})") from None
    if data.startswith(_PNG):
        return _image(p, data)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise LogFormatError(
            f"{p}: not UTF-8 text; expected a CSV or JSON file, or an overlay PNG"
        ) from None
    if text.lstrip().startswith("{"):
        try:
            data = json.loads(text)
        except (json.JSONDecodeError, RecursionError) as err:
            raise LogFormatError(f"{p}: not valid JSON ({err})") from None
        return _sensor(p, data)
    return _track(p, text)

"""Camera intrinsics (pinhole + OpenCV distortion) and the floor-marker table, read and written.

CAMERA.toml::

    [camera]
    fx = 900.0      # focal lengths (px)
    fy = 900.0
    cx = 640.0      # principal point (px)
    cy = 360.0
    width = 1280    # image size (px)
    height = 720
    k1 = 0.0        # OpenCV distortion (radial k1 k2 k3, tangential p1 p2); zero if left out
    k2 = 0.0
    p1 = 0.0
    p2 = 0.0
    k3 = 0.0

FLOOR.csv: header ``id,x,y,yaw,size``: each marker lying flat on the floor, its centre at
(x, y) (m) in the floor frame, its x axis at ``yaw`` (rad, counter-clockwise) from the floor's
x axis, ``size`` the side of its black square (m).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import tomli_w
from numpy.typing import NDArray

from odolab.core.errors import LogFormatError, check_table_keys

__all__ = [
    "CameraModel",
    "FloorMarker",
    "TrackingError",
    "load_camera",
    "read_floor_csv",
    "save_camera",
    "write_floor_csv",
]

_REQUIRED = ("fx", "fy", "cx", "cy", "width", "height")
_DISTORTION = ("k1", "k2", "p1", "p2", "k3")


class TrackingError(LogFormatError):
    """A video, camera file or floor table that the tracker cannot use."""


@dataclass(frozen=True)
class CameraModel:
    """Pinhole intrinsics (px) and OpenCV distortion coefficients of one camera."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    k1: float = 0.0
    k2: float = 0.0
    p1: float = 0.0
    p2: float = 0.0
    k3: float = 0.0

    def __post_init__(self) -> None:
        for key in ("fx", "fy", "cx", "cy", *_DISTORTION):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise TrackingError(f"camera {key} is {v!r}; expected a finite number")
            object.__setattr__(self, key, float(v))
        for key in ("fx", "fy"):
            if getattr(self, key) <= 0:
                raise TrackingError(f"camera {key} is {getattr(self, key)!r}; expected > 0 px")
        for key in ("width", "height"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise TrackingError(f"camera {key} is {v!r}; expected a whole number of pixels")

    @property
    def matrix(self) -> NDArray[np.float64]:
        """The 3x3 camera matrix K."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def distortion(self) -> NDArray[np.float64]:
        """OpenCV's (k1, k2, p1, p2, k3)."""
        return np.array([self.k1, self.k2, self.p1, self.p2, self.k3])

    def to_dict(self) -> dict[str, object]:
        """Plain dict in file order."""
        return asdict(self)


def load_camera(path: str | Path) -> CameraModel:
    """Read CAMERA.toml (see the module); every problem is one sentence naming the file.

    Raises:
        TrackingError: the file is missing, unreadable, not TOML, or its [camera] table lacks a key
            or has an unknown one.
    """
    p = Path(path)
    try:
        doc = tomllib.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError as err:
        raise TrackingError(f"{p}: no such camera file") from err
    except (OSError, UnicodeDecodeError) as err:
        raise TrackingError(f"{p}: cannot read the camera file ({err})") from err
    except tomllib.TOMLDecodeError as err:
        raise TrackingError(f"{p}: not valid TOML ({err})") from err
    cam = doc.get("camera")
    if not isinstance(cam, dict):
        raise TrackingError(f"{p}: missing the [camera] table; expected fx, fy, cx, cy, ...")
    allowed = _REQUIRED + _DISTORTION
    check_table_keys(
        cam,
        allowed,
        _REQUIRED,
        str(p),
        "[camera]",
        expected=", ".join(allowed),
        error=TrackingError,
    )
    try:
        return CameraModel(**cam)
    except TrackingError as err:
        raise TrackingError(f"{p}: {err}") from err


def save_camera(
    path: str | Path, camera: CameraModel, *, provenance: dict[str, object] | None = None
) -> Path:
    """Write CAMERA.toml (and an optional ``[provenance]`` table)."""
    p = Path(path)
    doc: dict[str, object] = {"camera": camera.to_dict()}
    if provenance:
        doc["provenance"] = provenance
    from odolab.core.writing import write_text_file

    return write_text_file(p, tomli_w.dumps(doc), what="camera file", error=TrackingError)


@dataclass(frozen=True)
class FloorMarker:
    """A marker lying flat on the floor (m, rad; see the module)."""

    id: int
    x: float
    y: float
    yaw: float
    size: float

    def corners(self) -> NDArray[np.float64]:
        """Its four corners in the floor frame (4, 3), z = 0, in ArUco's order: top-left,
        top-right, bottom-right, bottom-left of the printed marker (x right, y up)."""
        h = self.size / 2.0
        local = np.array([[-h, h], [h, h], [h, -h], [-h, -h]])
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        xy = local @ np.array([[c, s], [-s, c]]) + np.array([self.x, self.y])
        return np.column_stack((xy, np.zeros(4)))


def read_floor_csv(path: str | Path) -> list[FloorMarker]:
    """FLOOR.csv (``id,x,y,yaw,size``); errors name the file and line.

    Raises:
        TrackingError: the table has no markers, or a bad or repeated id, or a size not above 0 (the
            line is named).
    """
    from odolab.io._table import data_line_numbers, read_numeric_columns

    p = Path(path)
    d = read_numeric_columns(p, ("id", "x", "y", "yaw", "size"))
    lines = data_line_numbers(p)
    out: list[FloorMarker] = []
    seen: dict[int, int] = {}
    for i in range(d["id"].size):
        line = int(lines[i]) if i < lines.size else i + 2
        mid = d["id"][i]
        if not (mid >= 0 and float(mid).is_integer()):
            raise TrackingError(f"{p}: line {line}, id is {mid}; expected a marker number >= 0")
        if not (d["size"][i] > 0):
            raise TrackingError(f"{p}: line {line}, size is {d['size'][i]}; expected > 0 m")
        if int(mid) in seen:
            raise TrackingError(
                f"{p}: line {line}, marker {int(mid)} is also on line {seen[int(mid)]}; "
                "expected each marker once"
            )
        seen[int(mid)] = line
        out.append(
            FloorMarker(int(mid), float(d["x"][i]), float(d["y"][i]), float(d["yaw"][i]),
                        float(d["size"][i]))
        )  # fmt: skip
    if not out:
        raise TrackingError(f"{p}: no markers; expected rows id,x,y,yaw,size")
    return out


def write_floor_csv(path: str | Path, markers: list[FloorMarker]) -> Path:
    """Write FLOOR.csv."""
    p = Path(path)
    rows = ["id,x,y,yaw,size"] + [f"{m.id},{m.x!r},{m.y!r},{m.yaw!r},{m.size!r}" for m in markers]
    from odolab.core.writing import write_text_file

    return write_text_file(p, "\n".join(rows) + "\n", what="floor table", error=TrackingError)

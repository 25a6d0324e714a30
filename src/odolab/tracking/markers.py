"""ArUco dictionaries and printable markers (PNG at a stated DPI, PDF at true size).

A printed marker is its black square of ``size`` metres (what FLOOR.csv and ``--marker-size``
give) inside a white quiet zone one marker-bit wide all round, which detection needs.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from odolab.tracking.camera import TrackingError

if TYPE_CHECKING:
    import cv2

__all__ = [
    "DICTIONARIES",
    "get_dictionary",
    "marker_cells",
    "marker_image",
    "write_marker_files",
]

DICTIONARIES = (
    "DICT_4X4_50", "DICT_4X4_100", "DICT_4X4_250", "DICT_4X4_1000",
    "DICT_5X5_50", "DICT_5X5_100", "DICT_5X5_250", "DICT_5X5_1000",
    "DICT_6X6_50", "DICT_6X6_100", "DICT_6X6_250", "DICT_6X6_1000",
    "DICT_7X7_50", "DICT_7X7_100", "DICT_7X7_250", "DICT_7X7_1000",
    "DICT_ARUCO_ORIGINAL", "DICT_APRILTAG_16h5", "DICT_APRILTAG_25h9", "DICT_APRILTAG_36h11",
)  # fmt: skip


def get_dictionary(name: str) -> cv2.aruco.Dictionary:
    """The OpenCV ArUco dictionary by name (``DICT_4X4_50`` ...).

    Raises:
        TrackingError: the dictionary is not one odolab knows.
    """
    import cv2

    if name not in DICTIONARIES or not hasattr(cv2.aruco, name):
        raise TrackingError(
            f"unknown marker dictionary {name!r}; expected one of {', '.join(DICTIONARIES)}"
        )
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))


def _check_id(dictionary: cv2.aruco.Dictionary, name: str, marker_id: int) -> None:
    count = int(dictionary.bytesList.shape[0])
    if not (0 <= marker_id < count):
        raise TrackingError(f"marker id {marker_id} is not in {name}; expected 0 to {count - 1}")


def marker_image(marker_id: int, pixels: int, name: str = "DICT_4X4_50") -> NDArray[np.uint8]:
    """The marker's black square, ``pixels`` wide, inside a white quiet zone of one bit width.

    Returns a uint8 grey image; the black square spans the middle ``pixels`` of it."""
    import cv2

    d = get_dictionary(name)
    _check_id(d, name, marker_id)
    bits = int(d.markerSize) + 2
    img = cv2.aruco.generateImageMarker(d, marker_id, pixels, borderBits=1)
    quiet = max(1, round(pixels / bits))
    return np.asarray(
        cv2.copyMakeBorder(img, quiet, quiet, quiet, quiet, cv2.BORDER_CONSTANT, value=255),
        dtype=np.uint8,
    )


def write_marker_files(
    ids: list[int],
    size: float,
    folder: str | Path,
    *,
    name: str = "DICT_4X4_50",
    dpi: int = 300,
    pdf: bool = True,
) -> list[Path]:
    """One PNG per marker (``marker_<id>.png`` at ``dpi``: print at that resolution, no
    scaling) and, with ``pdf``, one PDF per marker at its true size, its cells drawn as vector
    squares. Returns the files.

    Raises:
        TrackingError: the size or dpi is out of range, or the files cannot be written.
    """
    import cv2

    if not (size > 0):
        raise TrackingError(f"marker size is {size!r} m; expected a positive number of metres")
    if not (72 <= dpi <= 2400):
        raise TrackingError(f"dpi is {dpi!r}; expected 72 to 2400")
    out = Path(folder)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise TrackingError(f"{out}: cannot create the folder ({err.strerror or err})") from err
    pixels = round(size / 0.0254 * dpi)
    files: list[Path] = []
    for marker_id in ids:
        img = marker_image(marker_id, pixels, name)
        png = out / f"marker_{marker_id}.png"
        if not cv2.imwrite(str(png), img, [cv2.IMWRITE_PNG_COMPRESSION, 9]):
            raise TrackingError(f"{png}: cannot write the marker image")
        files.append(png)
        if pdf:
            files.append(_write_pdf(marker_id, size, name, out))
    return files


def marker_cells(marker_id: int, name: str = "DICT_4X4_50") -> NDArray[np.bool_]:
    """The marker's cells, its one-bit black border included: True where a cell is black (a
    square array, ``markerSize + 2`` cells a side)."""
    import cv2

    d = get_dictionary(name)
    _check_id(d, name, marker_id)
    bits = int(d.markerSize) + 2
    cells: NDArray[np.uint8] = np.asarray(
        cv2.aruco.generateImageMarker(d, marker_id, bits, borderBits=1), dtype=np.uint8
    )
    return np.equal(cells, 0)


def _write_pdf(marker_id: int, size: float, name: str, out: Path) -> Path:
    """The marker at true size as vector graphics: its black cells are one filled path (no
    seams between cells, sharp at any printer's resolution, a file of a few kB), inside a
    white quiet zone one cell wide."""
    from matplotlib.figure import Figure
    from matplotlib.patches import PathPatch
    from matplotlib.path import Path as MplPath
    from matplotlib.transforms import Affine2D

    cells = marker_cells(marker_id, name)
    n = cells.shape[0]
    total_in = size / 0.0254 * (n + 2) / n  # the black square and its quiet zone, inches
    margin = 0.6
    fig = Figure(figsize=(total_in + 2 * margin, total_in + 2 * margin + 0.4))
    w, h = fig.get_size_inches()
    ax = fig.add_axes((margin / w, (margin + 0.4) / h, total_in / w, total_in / h))
    ax.set_xlim(-1, n + 1)
    ax.set_ylim(n + 1, -1)  # row 0 at the top, as in the image
    squares = [
        MplPath.unit_rectangle().transformed(Affine2D().translate(float(col), float(row)))
        for row, col in zip(*np.nonzero(cells), strict=True)
    ]
    ax.add_patch(PathPatch(MplPath.make_compound_path(*squares), fc="black", lw=0))
    ax.set_axis_off()
    fig.text(
        0.5, 0.3 / h, f"{name} id {marker_id}: black square {size * 1000:.1f} mm - print at 100 %",
        ha="center", fontsize=9,
    )  # fmt: skip
    from odolab.core.writing import replacing_path

    path = out / f"marker_{marker_id}.pdf"
    with replacing_path(path, what="marker sheet", error=TrackingError) as tmp:
        fig.savefig(tmp, format="pdf")
    return path

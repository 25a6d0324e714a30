"""How every odolab writer writes a file: path first, through a temporary file, never via a link.

Two rules, each in one place:

- **One argument order.** Every writer is ``write_x(path, obj)``. Writers used to disagree
  (``write_encoder_csv(log, path)`` but ``write_trials_csv(path, trials)``); for the callers
  written before, :func:`path_first` still accepts the old ``(obj, path)`` order, with a
  :class:`DeprecationWarning`.
- **One way to put bytes in a file.** A writer never opens its output path for writing. It writes
  a temporary file in the same folder and then renames it over the path (:func:`replacing_path`,
  :func:`replacing_file`, :func:`write_text_file`, :func:`write_bytes_file`). The rename replaces
  whatever is at the path, a symbolic link included, and never follows it: a link planted at
  ``out/report.html`` that points at a file outside ``out`` leaves that file untouched. The file
  appears whole or not at all (a crash or a full disk leaves the old file, and no half file).
  A sub-folder odolab makes inside the folder it was given (``out/figures``) is refused when it
  is a link (:func:`sub_folder`).
- **One way to write JSON.** Every JSON text odolab writes (``--json`` files, ``run.json``,
  ``results.json``, ``fleet.json``, the web API's answers) comes from :func:`strict_json`: a
  non-finite number (NaN, ±inf: a value not defined for that run) becomes ``null``, and the text
  is made with ``allow_nan=False``, so strict parsers (JavaScript's ``JSON.parse``, jq, Go, serde)
  read every file. A document that says why a value is missing keeps saying it beside the null.
"""

from __future__ import annotations

import json
import math
import os
import stat
import sys
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO, TextIO, TypeVar

from odolab.core.errors import OdolabError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "NEW_FILE_MODE",
    "OutputFileError",
    "given_folder",
    "path_first",
    "replacing_file",
    "replacing_path",
    "strict_json",
    "strict_value",
    "sub_folder",
    "write_bytes_file",
    "write_png",
    "write_text_file",
]

T = TypeVar("T")

#: The process's umask, read once at import (os.umask can only be read by setting it); a new
#: file gets the permissions ``open()`` would have given it, not mkstemp's owner-only 0o600.
_UMASK = os.umask(0o022)
os.umask(_UMASK)
#: The permissions of a new file (what ``open(path, "w")`` gives under the process's umask).
NEW_FILE_MODE = 0o666 & ~_UMASK


class OutputFileError(OdolabError):
    """An output file or folder cannot be written (a folder in its place, a link, no permission,
    a full disk)."""


def path_first(first: object, second: object, cls: type[T], writer: str) -> tuple[Path, T]:
    """``(path, obj)`` from a writer's two arguments, in either order; ``obj`` must be a ``cls``.

    The old order ``(obj, path)`` is swapped with a :class:`DeprecationWarning` naming ``writer``.
    """
    if isinstance(first, cls) and isinstance(second, str | os.PathLike):
        warnings.warn(
            f"{writer}(obj, path) is the old argument order; call {writer}(path, obj)",
            DeprecationWarning,
            stacklevel=3,
        )
        first, second = second, first
    if not isinstance(first, str | os.PathLike) or not isinstance(second, cls):
        raise TypeError(
            f"{writer}(path, obj) takes a path and a {cls.__name__}, got "
            f"{type(first).__name__} and {type(second).__name__}"
        )
    return Path(first), second


def strict_value(obj: object) -> object:
    """``obj`` as strict JSON holds it: a non-finite float (NumPy's too) as ``None``, NumPy
    arrays and tuples as lists, NumPy scalars as Python's; recursively. (NumPy is not imported
    here: ``odolab --help`` loads no numerics; a NumPy value exists only once NumPy is loaded.)"""
    np = sys.modules.get("numpy")
    if isinstance(obj, dict):
        return {
            k.item() if np is not None and isinstance(k, np.generic) else k: strict_value(v)
            for k, v in obj.items()
        }
    if isinstance(obj, list | tuple):
        return [strict_value(v) for v in obj]
    if isinstance(obj, bool):
        return obj
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if np is not None:
        if isinstance(obj, np.ndarray):
            return strict_value(obj.tolist())
        if isinstance(obj, np.bool_):
            return bool(obj)
        if isinstance(obj, np.integer):
            return int(obj)
        if isinstance(obj, np.floating):
            v = float(obj)
            return v if math.isfinite(v) else None
    return obj


def strict_json(doc: object, *, indent: int | None = 2, sort_keys: bool = False) -> str:
    """``doc`` as strict JSON text (RFC 8259): every non-finite number is ``null``
    (:func:`strict_value`) and the text is made with ``allow_nan=False``, so no ``NaN`` or
    ``Infinity`` token can reach a file or an answer. The one place odolab makes JSON text."""
    return json.dumps(strict_value(doc), indent=indent, sort_keys=sort_keys, allow_nan=False)


def _cannot(path: Path, what: str, err: OSError, error: type[OdolabError]) -> OdolabError:
    return error(f"{path}: cannot write the {what} ({err.strerror or err})")


def given_folder(
    path: str | Path, *, expected: str, cannot: str, error: type[OdolabError] = OutputFileError
) -> Path:
    """The folder the user gave, created (with its parents) if missing; a link to a folder is
    used as it is. Refused with ``error`` when it is a file ("is a file; expected ``expected``")
    or cannot be made ("cannot create ``cannot`` (why)")."""
    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        raise error(f"{folder}: is a file; expected {expected}")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise error(f"{folder}: cannot create {cannot} ({err.strerror or err})") from err
    return folder


def sub_folder(
    parent: str | Path, name: str, *, what: str, error: type[OdolabError] = OutputFileError
) -> Path:
    """``parent/name``, created (with ``parent``) if missing; refused when it is a link.

    ``parent`` is the folder the user gave and may itself be a link; a sub-folder odolab makes
    inside it never is one, so that nothing written into it lands outside ``parent``.
    """
    folder = Path(parent) / name
    if folder.is_symlink():
        raise error(
            f"{folder}: is a symbolic link; expected the {what} folder inside {parent} "
            "(odolab does not write through a link)"
        )
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise error(f"{folder}: is a file; expected the {what} folder") from None
    except OSError as err:
        raise error(f"{folder}: cannot create the {what} folder ({err.strerror or err})") from err
    return folder


@contextmanager
def replacing_path(
    path: str | Path, *, what: str, error: type[OdolabError] = OutputFileError
) -> Iterator[Path]:
    """A temporary file in ``path``'s folder to write; it replaces ``path`` when the block ends.

    The temporary file exists (empty) and ends in ``path``'s suffix, so that a writer that picks
    its format by the extension (Parquet, CSV ...) or needs a file name (``savefig``, polars)
    can write to it. When the block raises, the temporary file is removed and ``path`` is left as
    it was. ``path``'s folder is created if missing; a ``path`` that is a folder is refused. Any
    ``OSError`` becomes ``error`` naming ``path`` and ``what`` it holds.
    """
    p = Path(path)
    if p.is_dir() and not p.is_symlink():
        raise error(f"{p}: is a folder; expected a file name for the {what}")
    tmp: Path | None = None
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        import tempfile  # here: 6 ms of every command's start-up otherwise

        fd, name = tempfile.mkstemp(
            prefix=f".{p.name[:100]}.", suffix=f".part{p.suffix}", dir=p.parent
        )
        tmp = Path(name)
        # the permissions open() would give a new file, or those of the file it replaces
        mode = NEW_FILE_MODE
        if p.is_file() and not p.is_symlink():
            mode = stat.S_IMODE(p.stat().st_mode)
        try:
            os.fchmod(fd, mode)
        finally:
            os.close(fd)
        yield tmp
        tmp.replace(p)  # renames over a link at p, never through it
        tmp = None
    except OSError as err:
        raise _cannot(p, what, err, error) from err
    finally:
        if tmp is not None:
            tmp.unlink(missing_ok=True)


@contextmanager
def replacing_file(
    path: str | Path,
    *,
    what: str,
    error: type[OdolabError] = OutputFileError,
    newline: str | None = None,
) -> Iterator[TextIO]:
    """A temporary text file (UTF-8), open for writing, that replaces ``path`` when the block
    ends without error; see :func:`replacing_path` (a binary writer opens that path itself)."""
    with (
        replacing_path(path, what=what, error=error) as tmp,
        tmp.open("w", encoding="utf-8", newline=newline) as fh,
    ):
        yield fh


def write_text_file(
    path: str | Path, text: str, *, what: str, error: type[OdolabError] = OutputFileError
) -> Path:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file; return ``path``."""
    with replacing_path(path, what=what, error=error) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def write_bytes_file(
    path: str | Path, data: bytes, *, what: str, error: type[OdolabError] = OutputFileError
) -> Path:
    """Write ``data`` to ``path`` through a temporary file; return ``path``."""
    with replacing_path(path, what=what, error=error) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_png(fig: Figure, target: Path | BinaryIO, dpi: float | None = None) -> None:
    """``fig`` (at ``dpi``, else its own) as a PNG of its opaque pixels: RGB at zlib level 1,
    the dpi in the file. What ``savefig`` draws with Matplotlib's default ``savefig.*`` settings
    (a user's matplotlibrc does not change odolab's figures), encoded in half its time and 3 %
    smaller (its RGBA at level 6: 0.95 s against 0.44 s for the 37 figures of docs/analysis.md's
    report, 2.08 MB against 2.01 MB, with zlib 1.2.13). Matplotlib and Pillow (which Matplotlib
    requires) are imported here: the ``report`` extra."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image

    if dpi is not None:
        fig.set_dpi(dpi)
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.draw()  # type: ignore[no-untyped-call]
    pixels = canvas.buffer_rgba()  # type: ignore[no-untyped-call]
    rgba = Image.frombuffer("RGBA", canvas.get_width_height(), pixels, "raw")
    rgba.convert("RGB").save(target, format="PNG", compress_level=1, dpi=(fig.dpi, fig.dpi))

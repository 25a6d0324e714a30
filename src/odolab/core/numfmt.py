"""One rule for writing numbers, used by the terminal, the HTML report and results.json text.

- A number with an uncertainty carries the digits the uncertainty supports: the uncertainty is
  rounded to two significant digits and the value to the same decimal place
  (``with_uncertainty(0.87503, 0.0086)`` -> ``"0.8750"``, ``"0.8750 ± 0.0086"``). A 95 %
  interval is written with the same decimals as its value, the decimals coming from the
  interval's half-width.
- A number without one is written with four significant digits (``plain(7.806e-4)`` ->
  ``"0.0007806"``), in scientific notation only when it is below 1e-4 or at least 1e6.
- A p-value has two significant digits, ``"< 0.001"`` below 0.001.
- Numbers written to files (TOML, CSV, JSON) are not formatted at all: they are the float as
  stored, in its shortest round-trip form (:func:`shortest`, what ``repr`` gives), so that
  ``0.05`` reads back as ``0.05``.

Every function returns text; none prints. Non-finite values are written ``nan``, ``inf``,
``-inf``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike, NDArray

__all__ = [
    "clean",
    "coefficients_with_se",
    "count",
    "csv_lines",
    "decimals_for",
    "interval",
    "p_value",
    "plain",
    "shortest",
    "with_ci",
    "with_open_ci",
    "with_uncertainty",
]


def shortest(x: float) -> str:
    """The shortest text that reads back as the same float (``repr``): ``0.05``, not
    ``0.050000000000000003``; integers stay integers."""
    if isinstance(x, bool):
        return str(x)
    if isinstance(x, int):
        return str(x)
    return repr(float(x))


def decimals_for(uncertainty: float, digits: int = 2) -> int:
    """Decimal places that keep ``digits`` significant digits of ``uncertainty`` (>= 0)."""
    u = abs(float(uncertainty))
    if not math.isfinite(u) or u == 0.0:
        return 4
    exponent = math.floor(math.log10(u))
    # rounding may carry into the next decade (0.0996 -> 0.10): recompute on the rounded value
    rounded = round(u, digits - 1 - exponent)
    if rounded > 0:
        exponent = math.floor(math.log10(rounded))
    return max(0, digits - 1 - exponent)


def _fixed(x: float, decimals: int) -> str:
    if not math.isfinite(x):
        return str(x)
    text = f"{x:.{decimals}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text


def plain(x: float, sig: int = 4, *, strip: bool = False) -> str:
    """A number without an uncertainty: ``sig`` significant digits, no float noise.

    Trailing zeros are significant and kept (``1.000``) unless ``strip`` (for commanded
    distances and angles: ``2.5``, ``-1``).
    """
    x = float(x)
    if not math.isfinite(x):
        return str(x)
    if x == 0.0:
        return "0"
    x = float(f"{x:.{sig - 1}e}")  # rounded first: 9.99996 is 10.00, not 10.000
    a = abs(x)
    if a < 1e-4 or a >= 1e6:
        mant, _, exp = f"{x:.{sig - 1}e}".partition("e")
        mant = mant.rstrip("0").rstrip(".") if "." in mant else mant
        return f"{mant}e{int(exp)}"
    exponent = math.floor(math.log10(a))
    decimals = max(0, sig - 1 - exponent)
    text = f"{x:.{decimals}f}"
    if strip and "." in text:
        text = text.rstrip("0").rstrip(".")
    return text


def with_uncertainty(x: float, u: float, *, show: bool = False) -> str:
    """``x`` to the decimals its standard uncertainty ``u`` supports; ``show`` adds ``± u``."""
    x, u = float(x), float(u)
    if not math.isfinite(u) or u <= 0.0:
        return plain(x)
    d = decimals_for(u)
    text = _fixed(x, d)
    return f"{text} ± {_fixed(u, d)}" if show else text


def coefficients_with_se(
    values: Mapping[str, float],
    stderr: Mapping[str, float],
    *,
    name: Callable[[str], str] = str,
    plus_minus: str = "±",
) -> str:
    """A fit's coefficients, each with its standard error: ``k = v ± se`` (the value to 6
    significant digits, the error to 2), joined by ``", "``. Each face brings its own escaping:
    ``name`` writes a coefficient's name, ``plus_minus`` is the sign (HTML: ``&plusmn;``)."""
    return ", ".join(f"{name(k)} = {v:.6g} {plus_minus} {stderr[k]:.2g}" for k, v in values.items())


def interval(lo: float, hi: float, decimals: int | None = None) -> str:
    """``[lo, hi]``, with the decimals of its half-width unless given."""
    d = decimals_for((float(hi) - float(lo)) / 2.0) if decimals is None else decimals
    return f"[{_fixed(float(lo), d)}, {_fixed(float(hi), d)}]"


def with_ci(x: float | None, lo: float | None, hi: float | None) -> str:
    """``x [lo, hi]`` with the decimals the interval's half-width supports; ``x`` alone when
    there is no interval (an end is None, not finite, or the ends are not in order), ``-``
    when there is no value."""
    if x is None:
        return "-"
    if lo is None or hi is None:
        return plain(x)
    lo, hi = float(lo), float(hi)
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return plain(x)
    d = decimals_for((hi - lo) / 2.0)
    return f"{_fixed(float(x), d)} {interval(lo, hi, d)}"


def with_open_ci(x: float, lo: float | None, hi: float | None, *, at_bound: bool = False) -> str:
    """``x [lo, hi]`` where an end may be open (None or infinite: the data do not bound it),
    written ``unbounded``; the decimals come from the finite half of the interval.
    ``at_bound``: ``x`` is where a bounded search stopped (the likelihood still rises beyond it),
    not an estimate: written ``<= x`` or ``>= x`` (the side away from the finite end)."""
    ends = [None if v is None or not math.isfinite(float(v)) else float(v) for v in (lo, hi)]
    if ends[0] is not None and ends[1] is not None:
        text = with_ci(x, ends[0], ends[1])
        d = decimals_for((ends[1] - ends[0]) / 2.0)
    else:
        finite = [v for v in ends if v is not None]
        d = decimals_for(abs(float(x) - finite[0]) / 2.0) if finite else 2
        shown = ["unbounded" if v is None else _fixed(v, d) for v in ends]
        text = f"{_fixed(float(x), d)} [{shown[0]}, {shown[1]}]"
    if at_bound:
        side = "≤" if ends[0] is None or (ends[1] is not None and float(x) < ends[1]) else "≥"
        head, _, rest = text.partition(" ")
        text = f"{side} {head} (search's edge) {rest}".rstrip()
    return text


def p_value(p: float) -> str:
    """A p-value: two significant digits, ``< 0.001`` below 0.001."""
    p = float(p)
    if not math.isfinite(p):
        return str(p)
    if p < 0.001:
        return "< 0.001"
    return plain(p, 2)


def count(n: int, noun: str, plural: str | None = None) -> str:
    """``1 trial``, ``2 trials``: a count with its noun in the right number."""
    return f"{n} {noun if n == 1 else (plural or noun + 's')}"


def clean(x: float, sig: int = 12) -> float:
    """``x`` rounded to ``sig`` significant digits: a value computed from exact inputs
    (``0.0835 * 0.905``) without the last-bit noise of the arithmetic (``0.07556750000000001``
    becomes ``0.0755675``). Twelve digits are far below any physical precision of a robot's
    parameters and far above what a calibration's interval supports."""
    x = float(x)
    if not math.isfinite(x) or x == 0.0:
        return x
    return float(f"{x:.{sig}g}")


def _column_text(values: ArrayLike) -> NDArray[np.str_]:
    """Each float as the shortest text (up to 17 digits) that reads back as the same float."""
    import numpy as np

    a = np.asarray(values, dtype=np.float64)
    out = np.char.mod("%.15g", a).astype("<U32")
    bad = ~np.isfinite(a)
    out[bad] = [repr(float(v)) for v in a[bad]]
    for digits in (16, 17):
        wrong = np.isfinite(a) & (out.astype(np.float64) != a)
        if not wrong.any():
            break
        out[wrong] = np.char.mod(f"%.{digits}g", a[wrong])
    return out


def csv_lines(columns: Sequence[ArrayLike], *, sep: str = ",", integer: Sequence[bool] = ()) -> str:
    """Rows of equally long numeric columns as text lines, every float in its shortest
    round-trip form (``0.05``, not ``0.050000000000000003``); ``integer`` marks columns
    written as integers. Ends with a newline when there is a row."""
    import numpy as np

    texts = []
    for i, col in enumerate(columns):
        if i < len(integer) and integer[i]:
            texts.append(np.asarray(col, dtype=np.int64).astype(str))
        else:
            texts.append(_column_text(col))
    if not texts or len(texts[0]) == 0:
        return ""
    line = texts[0].astype(object)
    for t in texts[1:]:
        line = line + sep + t.astype(object)
    return "\n".join(line.tolist()) + "\n"

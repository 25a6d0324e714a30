"""A measurement as the web takes it: the form's text fields and the API's JSON numbers checked
before the store's rules (:mod:`odolab.store.measure`), and the store's sentences in the page's
own words (the store speaks the CLI's: ``--replace``, ``--initial``).

The form's x and y are text fields (a phone's decimal keypad has no minus key; a drift to the
right is a negative y): a number with an optional sign, a decimal point or comma, at most
:data:`MAX_CHARS` characters. Every refusal names the field it is about (:attr:`ReadingError.
fields`), so that the page can mark it ``aria-invalid``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import TYPE_CHECKING

from odolab.core.errors import NEUTRAL, StoreError, Wording

if TYPE_CHECKING:
    from odolab.store.measure import Readings

__all__ = [
    "FIELDS",
    "HTML_PATTERN",
    "HTML_PATTERN_UNSIGNED",
    "MAX_CHARS",
    "ReadingError",
    "fields_of",
    "form_readings",
    "in_words",
    "json_readings",
    "reading_words",
    "readings_of",
]

#: The fields of the form and the API, in the page's words.
FIELDS = {
    "initial": "the compass before",
    "final": "the compass after",
    "turns": "the whole turns counted",
    "x": "x",
    "y": "y",
    "sigma": "σ",
}
#: A typed number longer than this is refused (no measurement needs more digits).
MAX_CHARS = 24
#: The ``pattern`` of the signed fields (x, y) and of the others (the server checks again).
HTML_PATTERN = r"\s*[\-+−]?([0-9]+([.,][0-9]*)?|[.,][0-9]+)\s*"
HTML_PATTERN_UNSIGNED = r"\s*\+?([0-9]+([.,][0-9]*)?|[.,][0-9]+)\s*"
_NUMBER = re.compile(r"[-+]?(\d+(\.\d*)?|\.\d+)")
_DEFAULT_SIGMA = "for the default: 0.05 rad of one compass reading, 0.005 m for x and y"
_JSON_KINDS = {bool: "true/false", list: "a list", dict: "an object"}


class ReadingError(StoreError):
    """A reading refused before the store saw it; ``fields``: the fields it is about."""

    def __init__(self, message: str, fields: tuple[str, ...]) -> None:
        super().__init__(message)
        self.fields = fields


def _typed_number(name: str, text: str) -> float:
    """The number typed in field ``name`` (a sign, U+2212 minus, a decimal comma allowed)."""
    what = FIELDS[name]
    if len(text) > MAX_CHARS:
        raise ReadingError(
            f"{what} has {len(text)} characters; type a measurement of at most "
            f"{MAX_CHARS} (e.g. -0.031)",
            (name,),
        )
    plain = text.strip().replace("−", "-").replace(" ", "")
    if plain.count(",") == 1 and "." not in plain:
        plain = plain.replace(",", ".")
    if not _NUMBER.fullmatch(plain):
        raise ReadingError(f"{what} is {text!r}; type a number such as 12.5 or -0.031", (name,))
    return float(plain)


def _sigma_checked(value: float | None, api: bool) -> float | None:
    if value is not None and value <= 0:
        how = f"{'leave it out' if api else 'leave it empty'} {_DEFAULT_SIGMA}"
        name = '"sigma"' if api else "σ"
        raise ReadingError(f"{name} is {value:g}; it must be more than 0 ({how})", ("sigma",))
    return value


def readings_of(values: Mapping[str, float | None]) -> Readings:
    """The readings of :func:`form_readings` or :func:`json_readings` (keys :data:`FIELDS`) as
    :func:`odolab.store.measure.record_measurement` takes them."""
    from odolab.store.measure import Readings

    return Readings(
        values["initial"], values["final"], values["turns"], values["x"], values["y"],
        values["sigma"],
    )  # fmt: skip


def form_readings(form: Mapping[str, object]) -> dict[str, float | None]:
    """The form's readings as numbers (None for an empty field), or a :class:`ReadingError`."""
    out: dict[str, float | None] = {}
    for name in FIELDS:
        raw = form.get(name)
        text = raw.strip() if isinstance(raw, str) else ""
        out[name] = _typed_number(name, text) if text else None
    _sigma_checked(out["sigma"], api=False)
    return out


def json_readings(body: Mapping[str, object]) -> dict[str, float | None]:
    """The API body's readings: each a JSON number (text such as ``"0.5"`` is refused), finite,
    σ more than 0; None for a key not given (or null)."""
    out: dict[str, float | None] = {}
    for name in FIELDS:
        value = body.get(name)
        if value is None:
            out[name] = None
            continue
        example = "9" if name == "turns" else "0.5"
        if isinstance(value, bool) or not isinstance(value, int | float):
            kind = (
                "text" if isinstance(value, str) else _JSON_KINDS.get(type(value), "not a number")
            )
            raise ReadingError(
                f'"{name}" is {kind}; send a JSON number, e.g. "{name}": {example} '
                f'(not "{example}")',
                (name,),
            )
        if isinstance(value, float) and not math.isfinite(value):
            shown = "NaN" if math.isnan(value) else "too large (or Infinity)"
            raise ReadingError(f'"{name}" is {shown}; send a finite number', (name,))
        try:
            number = float(value)
        except OverflowError:
            number = math.inf
        if not math.isfinite(number):
            digits = len(str(abs(int(value))))
            raise ReadingError(
                f'"{name}" has {digits} digits; no measurement is that large', (name,)
            )
        out[name] = number
    _sigma_checked(out["sigma"], api=True)
    return out


# the store's three sentences that name the CLI's options, as templates (the settings as marks)
_REPLACE_T = "give {{replace}} to overwrite its measurement"
_ROTATION_T = "it is measured with {{initial}}, {{final}} and {{turns}}"
_TRANSLATION_T = "it is measured with {{x}} and {{y}}"
# as str() reads them (the library's words), how fields_of finds them
_REPLACE = NEUTRAL.say(_REPLACE_T)
#: the flags of ``odolab trials measure`` (the CLI's sentence, e.g. in the parity tests)
_MEASURE_FLAGS = Wording(
    {"replace": "--replace", "initial": "--initial", "final": "--final", "turns": "--turns",
     "x": "--x", "y": "--y"}
)  # fmt: skip


def in_words(message: str, *, api: bool = False) -> str:
    """The store's sentence (``str()``: the library's words, or the CLI's with its flags) in
    the page's (or the API's)."""
    if api:
        words = {
            _REPLACE_T: 'send "replace": true to overwrite its measurement',
            _ROTATION_T: 'it is measured with "initial", "final" and "turns"',
            _TRANSLATION_T: 'it is measured with "x" and "y"',
        }
    else:
        words = {
            _REPLACE_T: 'tick "replace the measurement above" to overwrite it',
            _ROTATION_T: "it is measured with the compass before and after and the whole turns",
            _TRANSLATION_T: "it is measured with the end point's x and y",
        }
    for template, page in words.items():
        for said in (NEUTRAL.say(template), _MEASURE_FLAGS.say(template)):
            message = message.replace(said, page)
    if api:
        return message.replace("sigma_reading_rad", '"sigma"')
    message = message.replace("sigma_reading_rad", "σ").replace("sigma must", "σ must")
    return message.replace("compass initial reading", "the compass before").replace(
        "compass final reading", "the compass after"
    )


def fields_of(err: Exception) -> tuple[str, ...]:
    """The fields a refusal is about (to mark them on the page), from its sentence when the
    store raised it."""
    if isinstance(err, ReadingError):
        return err.fields
    text = str(err)
    if "compass initial reading" in text:
        return ("initial",)
    if "compass final reading" in text:
        return ("final",)
    if "check the counted turns" in text or text.startswith("turns "):
        return ("turns",)
    if "measured end point" in text:
        return ("x", "y")
    for name in ("x", "y"):
        if re.search(rf"(^|: ){name} (is|must)", text):
            return (name,)
    if "sigma" in text:
        return ("sigma",)
    if _REPLACE in text:
        return ("replace",)
    if text.startswith("excluding trial ") and text.endswith(" needs a reason"):
        return ("reason",)
    return ()


#: A measurement's stored readings (``Measurement.raw``) in the page's words, with units.
_RAW = {
    "compass_initial_deg": ("compass before", "°"),
    "compass_final_deg": ("compass after", "°"),
    "turns": ("turns", ""),
    "x_m": ("x", " m"),
    "y_m": ("y", " m"),
}


def reading_words(raw: Mapping[str, object]) -> str:
    """``compass before 100°, compass after 136°, turns 9`` for the stored readings."""
    order = list(_RAW)
    parts = []
    for key, value in sorted(raw.items(), key=lambda kv: [*order, kv[0]].index(kv[0])):
        label, unit = _RAW.get(key, (key.replace("_", " "), ""))
        shown = format(value, "g") if isinstance(value, int | float) else str(value)
        parts.append(f"{label} {shown}{unit}")
    return ", ".join(parts)

"""The web's words for the library's settings: its form fields and API keys.

The library's errors name a setting by its library name (:data:`odolab.core.errors.OPTION_NAMES`);
a page or a JSON error names the field the user filled in (``robot``, ``replace``), and a
setting the web has no field for keeps the library's neutral words. :data:`FIELDS` is the one
table; :data:`WEB` words an error (:func:`odolab.serve.routes._web.web_text` uses it).
"""

from __future__ import annotations

from odolab.analysis.selection import Wording as SelectionWording
from odolab.core.errors import Wording

__all__ = ["CALIBRATE_WORDS", "FIELDS", "WEB"]

#: setting (library name) -> the form field or API key that sets it on the web
FIELDS: dict[str, str] = {
    "campaign": "campaign",
    "create_campaigns": "create_campaigns",
    "exclude_campaign": "exclude_campaign",
    "replace": "replace",
    "robot": "robot",
    "terrain": "terrain",
}

#: The web's wording.
WEB = Wording(FIELDS, "the web")

#: The calibrate page's words for what a selection left out (its campaigns come from Table I's
#: address).
CALIBRATE_WORDS = SelectionWording(
    "campaign", "exclude_campaign", "add ?campaign=NAME to the Table I address to include it"
)

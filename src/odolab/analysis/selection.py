"""Which trials an analysis uses: campaigns chosen explicitly, validation runs kept out.

A campaign whose notes start with ``validation:`` (:data:`VALIDATION_TAG`) holds runs that check
a calibration (the demo's phone run): they are never part of the characterization (Table I,
the calibrations) unless asked for by name. ``analyze``, ``calibrate`` and ``report`` all select
through :func:`select_trials` and print :meth:`TrialSelection.describe`.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

from odolab.core.errors import OdolabError, opt
from odolab.core.numfmt import count
from odolab.core.trials import Trial, TrialStatus

__all__ = [
    "CLI_WORDS",
    "VALIDATION_TAG",
    "WEB_WORDS",
    "SelectionError",
    "TrialSelection",
    "UnknownCampaignError",
    "Wording",
    "reason_in_words",
    "select_trials",
]

#: the start of a campaign's notes that marks it as a validation campaign
VALIDATION_TAG = "validation:"


@dataclass(frozen=True)
class Wording:
    """How a face names the selection's options in its sentences."""

    campaign: str  #: the option that names campaigns
    exclude: str  #: the option that leaves one out
    include: str  #: how to include a validation campaign


#: The library's words, the settings as marks (:func:`odolab.core.errors.opt`) that each face words
#: (the CLI as its flags: ``odolab.cli.wording``); what a sentence says unless a face asks for
#: its own.
CLI_WORDS = Wording(
    opt("campaign"), opt("exclude_campaign"), f"name it with {opt('campaign')} to include it"
)
#: The web's (the query and JSON keys of its pages and API).
WEB_WORDS = Wording(
    "campaign", "exclude_campaign", "select it by name (campaign=NAME) to include it"
)


class SelectionError(OdolabError):
    """A campaign filter names no campaign of the notebook, or leaves no trial. ``words``:
    the sentence in a face's words (:meth:`worded`); ``str()`` is the library's."""

    def __init__(self, message: str | Callable[[Wording], str]) -> None:
        self._words = message if callable(message) else None
        super().__init__(message(CLI_WORDS) if callable(message) else message)

    def worded(self, words: Wording) -> str:
        """The sentence with ``words`` for the options."""
        return self._words(words) if self._words is not None else str(self)


class UnknownCampaignError(SelectionError):
    """A campaign filter names a campaign the notebook does not have (a bad request)."""


def reason_in_words(why: str, words: Wording) -> str:
    """A left-out campaign's reason (as stored: ``validation campaign``, ``excluded``, ``not
    selected``) in a face's words."""
    if why == "validation campaign":
        return f"{why}; {words.include}"
    if why == "excluded":
        return words.exclude
    return why


@dataclass(frozen=True)
class TrialSelection:
    """The trials kept, and what was left out and why."""

    trials: list[Trial]
    used: dict[str, int]  #: campaign -> number of measured trials used
    left_out: dict[str, str]  #: campaign -> why it was left out

    def describe(self, words: Wording = CLI_WORDS) -> str:
        """One sentence: which campaigns (and how many measured trials each) were used."""
        n = sum(self.used.values())
        parts = ", ".join(f"{c} ({k})" for c, k in self.used.items()) or "none"
        text = f"using {count(n, 'measured trial')} from {parts}"
        if self.left_out:
            text += "; left out: " + ", ".join(
                f"{c} ({reason_in_words(why, words)})" for c, why in self.left_out.items()
            )
        return text


def select_trials(
    trials: Sequence[Trial],
    *,
    campaigns: Iterable[str] = (),
    exclude: Iterable[str] = (),
    validation_campaigns: Iterable[str] = (),
) -> TrialSelection:
    """Keep the trials of ``campaigns`` (all when empty) minus ``exclude``.

    Validation campaigns are left out unless named in ``campaigns``. A name that is not a
    campaign of ``trials`` is an error (a typo would otherwise select nothing silently).
    """
    wanted = list(dict.fromkeys(campaigns))
    dropped = list(dict.fromkeys(exclude))
    present = list(dict.fromkeys(t.campaign for t in trials))
    expected = ", ".join(present) or "(none: the notebook has no trials)"
    for option, names in (("campaign", wanted), ("exclude", dropped)):
        unknown = [c for c in names if c not in present]
        if unknown:

            def sentence(w: Wording, option: str = option, unknown: list[str] = unknown) -> str:
                return (
                    f"{getattr(w, option)} {', '.join(unknown)}: no such campaign; expected one "
                    f"of {expected}"
                )

            raise UnknownCampaignError(sentence)
    validation = set(validation_campaigns)
    left_out: dict[str, str] = {}
    keep: set[str] = set()
    for c in present:
        if wanted and c not in wanted:
            left_out[c] = "not selected"
        elif c in dropped:
            left_out[c] = "excluded"
        elif c in validation and c not in wanted:
            left_out[c] = "validation campaign"
        else:
            keep.add(c)
    kept = [t for t in trials if t.campaign in keep]
    measured = Counter(
        t.campaign for t in kept if t.status is TrialStatus.MEASURED and t.measured is not None
    )
    used = {c: measured.get(c, 0) for c in present if c in keep}
    if not present:
        raise SelectionError(
            "the notebook holds no trial yet; record some first (odolab sim run, odolab robot, "
            "odolab trials add or import)"
        )
    if not kept:
        raise SelectionError(
            lambda w: (
                "the campaign filters leave no trial; campaigns: "
                + ", ".join(f"{c} ({reason_in_words(why, w)})" for c, why in left_out.items())
            )
        )
    return TrialSelection(trials=kept, used=used, left_out=left_out)

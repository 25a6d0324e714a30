"""Which trials an analysis uses: campaigns chosen explicitly, validation runs kept out.

A campaign whose notes start with ``validation:`` (:data:`VALIDATION_TAG`) holds runs that check
a calibration (the demo's phone run): they are never part of the characterization (Table I,
the calibrations) unless asked for by name. ``analyze``, ``calibrate`` and ``report`` all select
through :func:`select_trials` and print :meth:`TrialSelection.describe`.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from odolab.errors import OdolabError
from odolab.numfmt import count
from odolab.trials import Trial, TrialStatus

__all__ = ["VALIDATION_TAG", "SelectionError", "TrialSelection", "select_trials"]

#: the start of a campaign's notes that marks it as a validation campaign
VALIDATION_TAG = "validation:"


class SelectionError(OdolabError):
    """A campaign filter names no campaign of the notebook, or leaves no trial."""


@dataclass(frozen=True)
class TrialSelection:
    """The trials kept, and what was left out and why."""

    trials: list[Trial]
    used: dict[str, int]  #: campaign -> number of measured trials used
    left_out: dict[str, str]  #: campaign -> why it was left out

    def describe(self) -> str:
        """One sentence: which campaigns (and how many measured trials each) were used."""
        n = sum(self.used.values())
        parts = ", ".join(f"{c} ({k})" for c, k in self.used.items()) or "none"
        text = f"using {count(n, 'measured trial')} from {parts}"
        if self.left_out:
            text += "; left out: " + ", ".join(f"{c} ({why})" for c, why in self.left_out.items())
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
    for option, names in (("--campaign", wanted), ("--exclude-campaign", dropped)):
        unknown = [c for c in names if c not in present]
        if unknown:
            raise SelectionError(
                f"{option} {', '.join(unknown)}: no such campaign; expected one of "
                f"{', '.join(present) or '(none: the notebook has no trials)'}"
            )
    validation = set(validation_campaigns)
    left_out: dict[str, str] = {}
    keep: set[str] = set()
    for c in present:
        if wanted and c not in wanted:
            left_out[c] = "not selected"
        elif c in dropped:
            left_out[c] = "--exclude-campaign"
        elif c in validation and c not in wanted:
            left_out[c] = "validation campaign; name it with --campaign to include it"
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
            "the campaign filters leave no trial; campaigns: "
            + ", ".join(f"{c} ({why})" for c, why in left_out.items())
        )
    return TrialSelection(trials=kept, used=used, left_out=left_out)

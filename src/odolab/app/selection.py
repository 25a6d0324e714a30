"""Which trials of a notebook count: the rule every analysis, calibration and report shares.

A campaign whose notes start with ``validation:`` holds runs that check a calibration (the demo's
phone runs): it is left out of every characterization unless named in ``campaigns``. One function,
:func:`select`, applies it for every face.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from odolab.core.errors import StoreError, opt
from odolab.core.trials import Trial, TrialStatus

if TYPE_CHECKING:
    from odolab.analysis.selection import TrialSelection, Wording
    from odolab.store import Notebook

__all__ = [
    "EVERY_CAMPAIGN",
    "Selection",
    "SelectionRequest",
    "check_robot",
    "open_notebook",
    "robots_among",
    "select",
    "select_among",
    "validation_campaigns",
]


@dataclass(frozen=True)
class SelectionRequest:
    """Which campaigns to use: ``campaigns`` (all when empty; a validation campaign only when
    named here) minus ``exclude``; ``robot``: only the trials of this robot (None: every one)."""

    campaigns: tuple[str, ...] = ()
    exclude: tuple[str, ...] = ()
    robot: str | None = None

    def to_dict(self) -> dict[str, object]:
        return {
            "campaigns": list(self.campaigns),
            "exclude": list(self.exclude),
            "robot": self.robot,
        }


#: every campaign except the validation ones (the default selection of every face)
EVERY_CAMPAIGN = SelectionRequest()


@dataclass(frozen=True)
class Selection:
    """The trials kept and the sentence that says which (every face shows it)."""

    trials: list[Trial]
    used: dict[str, int]  #: campaign -> number of measured trials used
    left_out: dict[str, str]  #: campaign -> why it was left out
    robot: str | None = None  #: the robot the trials were limited to, if any
    other_robots: tuple[str, ...] = ()  #: robots whose trials a robot filter left out

    @property
    def measured(self) -> list[Trial]:
        return [t for t in self.trials if t.status is TrialStatus.MEASURED and t.measured]

    def describe(self, words: Wording | None = None) -> str:
        """One sentence: which campaigns (and how many measured trials each) were used, in a
        face's ``words`` (the CLI's unless given)."""
        from odolab.analysis.selection import CLI_WORDS, reason_in_words

        w = words or CLI_WORDS
        n = sum(self.used.values())
        parts = ", ".join(f"{c} ({k})" for c, k in self.used.items()) or "none"
        text = f"using {n} measured trial{'' if n == 1 else 's'} from {parts}"
        if self.robot is not None:
            text += f" (robot {self.robot})"
        else:
            robots = robots_among(self.trials)
            if len(robots) > 1:
                text += f" (of {len(robots)} robots, pooled: {', '.join(robots)})"
        if self.left_out:
            text += "; left out: " + ", ".join(
                f"{c} ({reason_in_words(why, w)})" for c, why in self.left_out.items()
            )
        return text

    def to_dict(self) -> dict[str, object]:
        return {
            "used": dict(self.used),
            "left_out": dict(self.left_out),
            "robot": self.robot,
            "n_trials": len(self.trials),
            "n_measured": sum(self.used.values()),
            "describe": self.describe(),
        }


def robots_among(trials: Iterable[Trial]) -> list[str]:
    """The robots (names, sorted) of the measured trials among ``trials``: the one count of "how
    many robots are selected", for the trials-used sentence (:meth:`Selection.describe`) and for
    the robot a calibration is for (:func:`odolab.app.calibration.choose_robot`). A trial still
    awaiting its measurement, or excluded, brings no robot into the selection."""
    return sorted(
        {t.params.name for t in trials if t.status is TrialStatus.MEASURED and t.measured}
    )


def open_notebook(db: str | Path) -> Notebook:
    """The notebook at ``db`` (an existing file; a missing one is one sentence, as every face
    says it)."""
    from odolab.store import Notebook

    path = Path(db)
    if not path.is_file():
        raise StoreError(
            f"{path}: no such lab notebook; give {opt('db')} FILE (or set ODOLAB_DB), or create one "
            f"with `odolab notebook init {opt('db')} {path}`"
        )
    return Notebook(path)


def validation_campaigns(nb: Notebook) -> set[str]:
    """Names of the notebook's validation campaigns (notes starting ``validation:``)."""
    from odolab.analysis.selection import VALIDATION_TAG

    return {c.name for c in nb.campaigns() if c.notes.strip().lower().startswith(VALIDATION_TAG)}


def select(
    nb: Notebook, request: SelectionRequest = EVERY_CAMPAIGN, *, with_logs: bool = False
) -> Selection:
    """The trials of ``nb`` that ``request`` selects (validation campaigns out unless named).

    Raises :class:`~odolab.analysis.selection.SelectionError` for a campaign name the notebook
    does not have, or when nothing is left.
    """
    trials = nb.load_trials(with_logs=with_logs)
    return select_among(trials, validation_campaigns(nb), request)


def select_among(
    trials: list[Trial], validation: set[str], request: SelectionRequest = EVERY_CAMPAIGN
) -> Selection:
    """:func:`select` on trials already loaded (``validation``: the validation campaigns)."""
    from odolab.analysis.selection import SelectionError, select_trials

    sel: TrialSelection = select_trials(
        trials,
        campaigns=request.campaigns,
        exclude=request.exclude,
        validation_campaigns=validation,
    )
    if request.robot is None:
        return Selection(sel.trials, sel.used, sel.left_out)
    robots = sorted({t.params.name for t in sel.trials})
    if request.robot not in robots:
        raise SelectionError(
            f"robot {request.robot!r} has no trials in the selected campaigns; expected one of "
            f"{', '.join(robots) or '(none)'}"
        )
    kept = [t for t in sel.trials if t.params.name == request.robot]
    measured = Counter(
        t.campaign for t in kept if t.status is TrialStatus.MEASURED and t.measured is not None
    )
    used = {c: measured.get(c, 0) for c in sel.used if any(t.campaign == c for t in kept)}
    return Selection(
        kept,
        used,
        sel.left_out,
        robot=request.robot,
        other_robots=tuple(r for r in robots if r != request.robot),
    )


def check_robot(nb: Notebook, robot: str) -> None:
    """Refuse a robot the notebook has no parameters of."""
    if robot not in nb.robots():
        raise StoreError(
            f"no parameters of robot {robot!r} in {nb.path}; expected one of "
            f"{', '.join(nb.robots()) or '(none)'}"
        )

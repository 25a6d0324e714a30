"""The kinds of motion and their rules, in one place (as evo's ``PoseRelation`` carries its formula).

Three vocabularies, each a :class:`~enum.StrEnum` whose values are the words stored in notebooks,
CSV and JSON (a member *is* its word: it compares, hashes, formats and serialises as that
string), each parsed from text by ``parse`` with one sentence naming the allowed words:

- :class:`MotionKind`: what a trial commanded (``rotation``, ``translation``, ``pivot``,
  ``square``, ``free``): whether it turns in place, what the command needs, which instrument
  readings measure it, which fits it feeds, the shape of its noise record.
- :class:`Motion`: what the analysis fits from measured trials (``rotation``, ``pivot``, ``x``,
  ``y_forward``, ``y_reverse``): angular or linear, its unit, whether it has an ideal 1:1 line
  (actual = predicted), how its error is formed, which residual of the noise record it is.
- :class:`DriveShape`: the motion of an open-question experiment's condition (``rotate``,
  ``curve``, ``pivot``, ``straight``; :mod:`odolab.analysis.questions`): the keys it needs and
  how it is measured.

Turn in place (a rotation or a pivot) is measured with a compass and counted whole turns, can be
off by whole turns when they are miscounted, has a 1:1 ideal line in rad, and its predicted angle
scales with the wheels' radius over the track width; a straight run is measured with a meterstick
(x, y) and its predicted distance scales with the wheels' radius alone.
"""

from __future__ import annotations

from enum import StrEnum
from typing import TYPE_CHECKING, Self

from odolab.core.errors import InsufficientDataError, OdolabError

if TYPE_CHECKING:  # numpy is imported where a noise record is made: the words stay light (CLI)
    import numpy as np
    from numpy.typing import NDArray

__all__ = ["DriveShape", "Motion", "MotionKind", "MotionWordError"]


class MotionWordError(OdolabError, ValueError):
    """A word that names no member of the motion vocabulary it was read as."""


class _Words(StrEnum):
    """A vocabulary of stored words (no members of its own)."""

    @classmethod
    def parse(
        cls, text: object, where: str = "", error: type[OdolabError] = MotionWordError
    ) -> Self:
        """The member spelled ``text`` (exactly, as stored); ``error`` (one sentence naming the
        allowed words, after ``where``) for any other word or value."""
        if isinstance(text, cls):
            return text
        for member in cls:
            if member.value == text:
                return member
        place = f"{where}: " if where else ""
        allowed = ", ".join(m.value for m in cls)
        raise error(f"{place}{cls._noun()} {text!r} is not one of {allowed}")

    @classmethod
    def _noun(cls) -> str:
        """What a word of this vocabulary is called in a refusal."""
        return "motion"


class MotionKind(_Words):
    """What a trial commanded."""

    ROTATION = "rotation"  #: turn in place by ``angle`` (both tracks, opposite directions)
    TRANSLATION = "translation"  #: straight by ``distance`` (negative = reverse)
    PIVOT = "pivot"  #: turn by ``angle`` on one track, the other held
    SQUARE = "square"  #: UMBmark square of ``side``, ``direction`` "cw" or "ccw"
    FREE = "free"  #: anything else (a recorded log; an exploration: :attr:`Command.explore`)

    @classmethod
    def _noun(cls) -> str:
        return "motion kind"

    @property
    def turns_in_place(self) -> bool:
        """A rotation or a pivot: the result is a heading change (rad), measured with a compass
        and counted whole turns."""
        return self in (MotionKind.ROTATION, MotionKind.PIVOT)

    @property
    def needs(self) -> str | None:
        """The command's quantity it cannot do without (``angle``, ``distance``, ``side``), or
        None (a free motion)."""
        return {
            MotionKind.ROTATION: "angle",
            MotionKind.PIVOT: "angle",
            MotionKind.TRANSLATION: "distance",
            MotionKind.SQUARE: "side",
        }.get(self)

    @property
    def readings(self) -> tuple[str, ...]:
        """The readings a person enters to measure one trial of this kind: a compass before and
        after and the whole turns counted, or x and y by meterstick."""
        return ("initial", "final", "turns") if self.turns_in_place else ("x", "y")

    @property
    def fits(self) -> tuple[Motion, ...]:
        """The analysis fits a measured trial of this kind feeds (none for a square or a free
        motion: squares have their own analysis)."""
        return tuple(m for m in Motion if m.command is self)

    @property
    def residuals(self) -> tuple[str, ...]:
        """The residuals its noise record holds, in order: ``turn``, or ``x`` and ``y``."""
        return tuple(dict.fromkeys(m.noise_residual for m in self.fits))

    def noise_weights(
        self, amount: float, track_width: float, *, held: str | None = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
        """``(A_r, A_l, turn)`` of the noise record of one trial (:mod:`odolab.analysis.noise`):
        the residual's covariance is ``k_r A_r + k_l A_l`` (plus the instrument's), linearised
        about the command, and ``turn`` (rad) is the commanded turning that scrub acts on.

        ``amount``: the heading change (rad) of a turn, the signed distance (m) of a
        translation; ``held``: the pivot's standing track (``left``, the default, or
        ``right``). A rotation rolls each wheel ``|h| b / 2``; a pivot rolls the moving wheel
        ``|h| b``; a straight run of ``d`` gives residuals (x, y) with ``var x = k d / 4``,
        ``var y = k d**3 / (3 b**2)``, ``cov = sgn (k_r - k_l) d**2 / (4 b)``.
        :class:`~odolab.core.errors.InsufficientDataError` for a square or a free motion."""
        import numpy as np

        b = track_width
        if self is MotionKind.ROTATION:
            a = np.array([[abs(amount) / (2.0 * b)]])
            return a, a.copy(), abs(amount)
        if self is MotionKind.PIVOT:
            v = np.array([[abs(amount) / b]])
            zero = np.zeros((1, 1))
            right_moves = (held or "left") == "left"
            return (v, zero, abs(amount)) if right_moves else (zero, v, abs(amount))
        if self is MotionKind.TRANSLATION:
            d = abs(amount)
            sgn = 1.0 if amount >= 0 else -1.0
            vx, vy, c = d / 4.0, d**3 / (3.0 * b**2), sgn * d**2 / (4.0 * b)
            return np.array([[vx, c], [c, vy]]), np.array([[vx, -c], [-c, vy]]), 0.0
        raise InsufficientDataError(
            f"a {self.value} has no noise record (rotation, pivot, translation)"
        )


class Motion(_Words):
    """What the analysis fits from measured trials, in report order."""

    ROTATION = "rotation"  #: actual against predicted heading change of rotations
    PIVOT = "pivot"  #: the same for pivots
    X = "x"  #: actual against predicted x of translations
    Y_FORWARD = "y_forward"  #: y error (predicted - actual) against predicted x, forward runs
    Y_REVERSE = "y_reverse"  #: the same for reverse runs

    @classmethod
    def of_y(cls, distance: float) -> Motion:
        """The y fit a translation of signed ``distance`` feeds."""
        return cls.Y_FORWARD if distance >= 0 else cls.Y_REVERSE

    @property
    def command(self) -> MotionKind:
        """The commanded kind whose trials this fit is made of."""
        return (
            MotionKind(self.value)
            if self in (Motion.ROTATION, Motion.PIVOT)
            else (MotionKind.TRANSLATION)
        )

    @property
    def angular(self) -> bool:
        """A heading change (rad), else a position (m); also: whole turns can be miscounted."""
        return self.command.turns_in_place

    @property
    def unit(self) -> str:
        return "rad" if self.angular else "m"

    @property
    def ratio_unit(self) -> str:
        return f"{self.unit}/{self.unit}"

    @property
    def ideal_line(self) -> bool:
        """True: fitted as actual against predicted, ideally on the 1:1 line (and its ratio is
        the proportional fit's slope, ``1 - ratio`` the error per predicted unit). False (the y
        rows): fitted as the error against predicted x, ideally zero (the slope is the error per
        metre travelled)."""
        return self.angular or self is Motion.X

    @property
    def is_y(self) -> bool:
        """A y row (forward or reverse), fitted on the error predicted - actual."""
        return not self.ideal_line

    @property
    def ratio_sign(self) -> float:
        """A reverse run's slope against (negative) predicted x is negated into its ratio."""
        return -1.0 if self is Motion.Y_REVERSE else 1.0

    @property
    def x_label(self) -> str:
        """What is regressed on (the fit's x axis)."""
        return "predicted rotation (rad)" if self.angular else "predicted x (m)"

    @property
    def y_label(self) -> str:
        """What is regressed (the fit's y axis)."""
        if self.angular:
            return "actual rotation (rad)"
        return "actual x (m)" if self is Motion.X else "y error, predicted - actual (m)"

    @property
    def noise_residual(self) -> str:
        """Which residual of the trial's noise record a residual of this fit is: ``turn``,
        ``x`` or ``y``."""
        return "turn" if self.angular else ("x" if self is Motion.X else "y")

    def actual_side(self, residual: float) -> float:
        """A residual of this fit as a residual of the actual motion (the noise record's side):
        the y fits are on predicted - actual, so flipped."""
        return -residual if self.is_y else residual

    def errors(
        self, predicted: NDArray[np.float64], actual: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Each trial's error, predicted - actual: formed here for the 1:1 fits; a y fit's
        series already holds it."""
        return predicted - actual if self.ideal_line else actual

    def rescaled(
        self,
        predicted: NDArray[np.float64],
        radius: tuple[float, float],
        track: tuple[float, float],
    ) -> NDArray[np.float64]:
        """Predictions re-made for new parameters without the logs, from the (old, new) mean
        wheel ``radius`` and ``track`` width (exact when both wheels scale alike): a turn's
        angle scales with the radius over the track, a distance with the radius alone."""
        scaled = predicted * (radius[1] / radius[0])
        return scaled * (track[0] / track[1]) if self.angular else scaled


class DriveShape(_Words):
    """The motion of an open-question experiment's condition (:mod:`odolab.analysis.questions`)."""

    ROTATE = "rotate"  #: turn in place by ``angle_deg``
    CURVE = "curve"  #: turn by ``angle_deg`` along a circle of ``radius``
    PIVOT = "pivot"  #: turn by ``angle_deg`` about the ``held`` track
    STRAIGHT = "straight"  #: ``distance`` (m, negative = reverse)

    @property
    def angular(self) -> bool:
        """Measured as a heading change by the compass; else as a distance by meterstick/tape."""
        return self is not DriveShape.STRAIGHT

    @property
    def needs(self) -> tuple[str, ...]:
        """The condition's keys this shape needs."""
        if self is DriveShape.STRAIGHT:
            return ("distance",)
        return ("angle_deg", "radius") if self is DriveShape.CURVE else ("angle_deg",)

    @property
    def takes(self) -> tuple[str, ...]:
        """Every shape key that applies: what it needs and (a pivot) the held track."""
        return (*self.needs, "held") if self is DriveShape.PIVOT else self.needs

    @property
    def mirrors(self) -> bool:
        """Has a mirror image (turn sign, pivot track) that an alternating experiment uses."""
        return self.angular

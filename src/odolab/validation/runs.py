"""Several phone runs against the predicted random error: what the lab's Fig. 21 can show.

One rotation with a phone cannot tell a calibration from luck: its random error (turn scrub,
σ ≈ 2.9 rad at 20 π on the Jaguar) is as large as what the calibration removes. What it can
show is the *systematic* part: the old model's heading error grows with the angle far beyond
the random error the lab measured, the new model's stays inside that band. Several runs show it
run after run and average the random part down (its mean error shrinks like 1/√runs).

:func:`summarize_runs` compares each run's final heading error with the band
``±1.96 σ(θ)`` predicted from Table I's random error, σ(θ) = σ_ref · (θ/θ_ref)^p (p from the
growth fit, 0.5 for a random walk), and says how many runs fall inside; the clock offsets found
on each run give the accuracy of the offset search. :func:`plot_validation_runs` is the figure.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odolab.core import numfmt
from odolab.core.errors import OdolabError
from odolab.validation.compare import ValidationResult

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["RandomBand", "RunsSummary", "plot_validation_runs", "summarize_runs"]


@dataclass(frozen=True)
class RandomBand:
    """σ(θ) = sigma_ref · (|θ| / at_ref)^p: the random heading error predicted at angle θ."""

    sigma_ref: float
    at_ref: float
    p: float = 0.5

    def sigma(self, angle: ArrayLike) -> NDArray[np.float64]:
        """σ of the heading error after turning ``angle`` rad (a 0-d array for one angle)."""
        a = np.abs(np.asarray(angle, dtype=np.float64))
        return np.asarray(self.sigma_ref * (a / self.at_ref) ** self.p, dtype=np.float64)


@dataclass(frozen=True)
class RunsSummary:
    """What the phone runs show, in numbers, and in words."""

    runs: int
    angles: list[float]
    final_old: list[float]
    final_new: list[float]
    predicted_sigma: list[float]
    inside_old: int
    inside_new: int
    offsets: list[float]
    offset_true: float | None

    @property
    def mean_new(self) -> float:
        return float(np.mean(self.final_new))

    @property
    def mean_old(self) -> float:
        return float(np.mean(self.final_old))

    def mean_new_se(self) -> float:
        """Standard error of the new model's mean final error, from the predicted σ."""
        return float(math.sqrt(sum(s * s for s in self.predicted_sigma)) / self.runs)

    def ratio_resolution(self) -> float:
        """Half-width of the 95 % interval on the rotation ratio these runs give (relative)."""
        return 1.96 * self.mean_new_se() / float(np.mean(np.abs(self.angles)))

    def offset_spread(self) -> float:
        return float(np.std(self.offsets, ddof=1)) if len(self.offsets) > 1 else math.nan

    def verdict(self) -> list[str]:
        """Plain sentences: what these runs prove and what they cannot."""
        s = self.predicted_sigma
        band = f"±1.96 σ (σ = {numfmt.plain(float(np.mean(s)), 3)} rad at this angle)"
        se = self.mean_new_se()
        out = [
            f"Final heading error, old parameters: {self.inside_old} of {self.runs} runs inside "
            f"the random-error band {band}; mean {numfmt.with_uncertainty(self.mean_old, se)} "
            "rad: the systematic error the calibration is for.",
            f"New parameters: {self.inside_new} of {self.runs} runs inside the band; mean "
            f"{numfmt.with_uncertainty(self.mean_new, se, show=True)} rad, compatible with 0 "
            "if within about two of its ± (random error alone).",
            f"What {self.runs} runs cannot prove: the new rotation ratio to better than "
            f"±{numfmt.plain(self.ratio_resolution() * 100, 2)} % (95 %; one run alone: "
            f"±{numfmt.plain(self.ratio_resolution() * math.sqrt(self.runs) * 100, 2)} %). "
            "Table I's fit over many rotations measures the ratio; the phone shows its effect "
            "on whole runs.",
        ]
        if self.offsets:
            mean = float(np.mean(self.offsets))
            spread = self.offset_spread()
            text = (
                f"Clock offset found on each run: mean {numfmt.plain(mean, 4)} s, spread "
                f"{numfmt.plain(spread, 2)} s (1 σ over {len(self.offsets)} runs)"
            )
            if self.offset_true is not None:
                worst = max(abs(o - self.offset_true) for o in self.offsets)
                text += (
                    f"; the simulated phone's true offset is {numfmt.plain(self.offset_true, 4)} "
                    f"s, the largest error {numfmt.plain(worst, 2)} s. A constant-rate turn is "
                    "timed only by its start and stop, so expect this accuracy from one run"
                )
            out.append(text + ".")
        return out

    def to_dict(self) -> dict[str, object]:
        return {
            "runs": self.runs,
            "rotation_rad": self.angles,
            "ratio_resolution_95": self.ratio_resolution(),
            "final_error_old_rad": self.final_old,
            "final_error_new_rad": self.final_new,
            "predicted_sigma_rad": self.predicted_sigma,
            "inside_band_old": self.inside_old,
            "inside_band_new": self.inside_new,
            "mean_final_error_new_rad": self.mean_new,
            "mean_final_error_new_se_rad": self.mean_new_se(),
            "clock_offsets_s": self.offsets,
            "clock_offset_true_s": self.offset_true,
            "verdict": self.verdict(),
        }


def summarize_runs(
    checks: Sequence[ValidationResult], band: RandomBand, *, offset_true: float | None = None
) -> RunsSummary:
    """Each run's final heading error against the band predicted at its angle.

    Raises:
        OdolabError: there are no validation runs.
    """
    if not checks:
        raise OdolabError("no validation runs to summarize; expected at least one phone run")
    fo, fn, sig, offs, angles = [], [], [], [], []
    for c in checks:
        angle = float(c.imu_heading[-1])
        angles.append(angle)
        s = float(band.sigma(angle))
        fo.append(float(c.old.error[-1]))
        fn.append(float(c.new.error[-1]))
        sig.append(s)
        offs.append(float(c.clock_offset))
    inside = [sum(abs(e) <= 1.96 * s for e, s in zip(errs, sig, strict=True)) for errs in (fo, fn)]
    return RunsSummary(len(checks), angles, fo, fn, sig, inside[0], inside[1], offs, offset_true)


def plot_validation_runs(
    checks: Sequence[ValidationResult], band: RandomBand, ax: Axes | None = None
) -> Axes:
    """Heading error (odometry − IMU) against the rotation so far, every run, old and new, on
    the ±1.96 σ(θ) band of the random error predicted from Table I."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6.4, 4.2))
    top = max(float(np.max(np.abs(c.imu_heading))) for c in checks)
    th = np.linspace(0.0, top, 200)
    s = 1.96 * band.sigma(th)
    ax.fill_between(th, -s, s, color="0.85", label="random error predicted, 95 %")
    for i, c in enumerate(checks):
        ax.plot(
            np.abs(c.imu_heading),
            c.old.error,
            color="tab:red",
            lw=1.0,
            ls="--",
            label="old parameters" if i == 0 else None,
        )
        ax.plot(
            np.abs(c.imu_heading),
            c.new.error,
            color="tab:blue",
            lw=1.0,
            label="new parameters" if i == 0 else None,
        )
    ax.axhline(0.0, color="black", lw=0.8)
    ax.set_xlabel("rotation so far, measured by the IMU (rad)")
    ax.set_ylabel("heading error, odometry - IMU (rad)")
    ax.set_title(f"{len(checks)} phone runs against the predicted random error")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left")
    return ax

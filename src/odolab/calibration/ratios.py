"""Calibration by ratios: the lab report's section VIII, done right.

Convention (``ratio = actual / predicted``, both from the fits):

* distance ratio ``q_d`` (x fit slope): each wheel rolls ``q_d`` times what odometry assumed,
  so every wheel radius is MULTIPLIED by it: ``r_new = q_d * r_old``;
* rotation ratio ``q_r`` (rotation fit slope): the heading change is ``(ds_r - ds_l) / b``;
  with the new radii the wheel distances grow by ``q_d`` while the robot actually turned only
  ``q_r`` of the prediction, so ``b_new = b_old * q_d / q_r``.

Example: ``q_d = 0.905``, ``q_r = 0.875`` turn ``r`` and ``b`` into ``0.905 r`` and
``1.0343 b``. (The lab report divides where this multiplies; with its numbers it made the
wheels larger and the robot narrower, which doubles the errors instead of removing them.)

The 95% intervals of the new parameters come from the ratios' intervals by the delta method on
the log scale (the two fits are independent).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from odolab.errors import CalibrationError
from odolab.numfmt import clean
from odolab.params import NoiseParams, RobotParams, save_params

if TYPE_CHECKING:
    from odolab.analysis import LabAnalysis

__all__ = ["CalibrationResult", "check_track_model", "ratios", "ratios_from_analysis"]

_Z95 = 1.959963984540054


@dataclass(frozen=True)
class CalibrationResult:
    """A new parameter set, the one it replaces, and where it came from."""

    method: str
    params: RobotParams
    old_params: RobotParams
    provenance: dict[str, Any] = field(default_factory=dict)

    def save(self, path: str | Path) -> Path:
        """Write the new parameters as TOML with a ``[provenance]`` table."""
        return save_params(path, self.params, provenance=self.provenance)

    def to_dict(self) -> dict[str, Any]:
        return {
            "method": self.method,
            "params": self.params.to_dict(),
            "old_params": self.old_params.to_dict(),
            "provenance": dict(self.provenance),
        }


def _now() -> str:
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def _check_ratio(name: str, value: float) -> float:
    v = float(value)
    if not math.isfinite(v) or not 0.2 <= v <= 5.0:
        raise CalibrationError(
            f"{name} must be actual/predicted, a finite number between 0.2 and 5, got {value!r}"
        )
    return v


def _rel_se(ci: tuple[float, float] | None, value: float) -> float | None:
    if ci is None:
        return None
    lo, hi = ci
    return (hi - lo) / (2 * _Z95) / value


def check_track_model(params: RobotParams, method: str) -> None:
    """Refuse parameters whose kinematic model ignores the ``[robot]`` track width (the ICR
    model turns by its own ICR coordinates): a calibration that corrects the track width
    would write a value that changes nothing."""
    model = params.model
    if model.coefficients(1.0).denominator == model.coefficients(2.0).denominator:
        raise CalibrationError(
            f"{params.name}: {method} corrects the [robot] radii and track width, but the "
            f"parameters' [model] is {model.kind}, which turns by its own geometry, not the "
            "track width; expected parameters of a differential drive (no [model]) or an "
            f"extended one, or `odolab calibrate lsq --model {model.kind}`"
        )


def ratios(
    params: RobotParams,
    distance_ratio: float,
    rotation_ratio: float,
    *,
    distance_ratio_ci95: tuple[float, float] | None = None,
    rotation_ratio_ci95: tuple[float, float] | None = None,
    source: str = "ratios given by hand",
    terrain: str | None = None,
) -> CalibrationResult:
    """New parameters from the distance and rotation ratios (actual/predicted); see module doc."""
    check_track_model(params, "the ratios calibration")
    qd = _check_ratio("distance ratio", distance_ratio)
    qr = _check_ratio("rotation ratio", rotation_ratio)
    # 12 significant digits: the products without their last-bit noise (numfmt.clean)
    new = params.with_(
        left_wheel_radius=clean(params.left_wheel_radius * qd),
        right_wheel_radius=clean(params.right_wheel_radius * qd),
        track_width=clean(params.track_width * qd / qr),
        name=f"{params.name}-ratios",
    )
    prov: dict[str, Any] = {
        "method": "ratios",
        "created": _now(),
        "source": source,
        **({"terrain": terrain} if terrain else {}),
        "from_params": params.name,
        "distance_ratio": qd,
        "rotation_ratio": qr,
        "convention": (
            "ratio = actual/predicted; wheel_radius_new = wheel_radius_old * distance_ratio; "
            "track_width_new = track_width_old * distance_ratio / rotation_ratio"
        ),
        "old": params.to_dict(),
    }
    sd = _rel_se(distance_ratio_ci95, qd)
    sr = _rel_se(rotation_ratio_ci95, qr)
    if distance_ratio_ci95 is not None:
        prov["distance_ratio_ci95"] = list(distance_ratio_ci95)
    if rotation_ratio_ci95 is not None:
        prov["rotation_ratio_ci95"] = list(rotation_ratio_ci95)
    if sd is not None:
        r = new.left_wheel_radius
        prov["wheel_radius_ci95"] = [r * math.exp(-_Z95 * sd), r * math.exp(_Z95 * sd)]
        if sr is not None:
            s = math.hypot(sd, sr)
            b = new.track_width
            prov["track_width_ci95"] = [b * math.exp(-_Z95 * s), b * math.exp(_Z95 * s)]
    return CalibrationResult("ratios", new, params, prov)


def _with_noise(result: CalibrationResult, analysis: LabAnalysis) -> CalibrationResult:
    """Add the analysis' per-wheel noise constants as the new parameters' ``[noise]``.

    The noise was measured in the old parameters' wheel distances; the new radii scale every
    distance by the distance ratio ``q``, so ``var = k |ds|`` becomes ``(q k) |ds_new|``."""
    noise = analysis.noise
    if noise is None:
        return result
    q = float(result.provenance["distance_ratio"])
    k = NoiseParams(k_left=noise.k_left * q, k_right=noise.k_right * q)
    prov = {
        **result.provenance,
        "noise": (
            "[noise] from the analysis' maximum-likelihood k_left, k_right (var = k |ds|), "
            "scaled by the distance ratio to the new radii"
            + ("" if noise.identifiable else "; the wheels were not separable: k_left = k_right")
        ),
    }
    return replace(result, params=result.params.with_(noise=k), provenance=prov)


def ratios_from_analysis(
    analysis: LabAnalysis,
    params: RobotParams | None = None,
    *,
    terrain: str | None = None,
) -> CalibrationResult:
    """Ratios taken from the notebook's fits: the x and rotation slopes on one terrain.

    ``terrain`` defaults to the first terrain (alphabetical) that has both a rotation and an x
    fit; ``params`` default to the parameters the trials were run with.
    """
    base = params or analysis.params
    if base is None:
        raise CalibrationError("no parameters given and the analysis has no trials' parameters")
    terrains = [terrain] if terrain else analysis.terrains
    for t in terrains:
        rot = analysis.get("rotation", t)
        x = analysis.get("x", t)
        if rot is not None and x is not None:
            result = ratios(
                base,
                x.ratio,
                rot.ratio,
                distance_ratio_ci95=x.ratio_ci95,
                rotation_ratio_ci95=rot.ratio_ci95,
                source=(
                    f"analysis fits on {t}: x slope from {x.fit.n} trials, rotation slope "
                    f"from {rot.fit.n} trials"
                ),
                terrain=t,
            )
            return _with_noise(result, analysis)
    where = f"terrain {terrain!r}" if terrain else "any one terrain"
    raise CalibrationError(
        f"ratios calibration needs both a rotation fit and an x fit on {where}; "
        "each needs at least 3 measured trials"
    )

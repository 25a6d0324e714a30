"""Calibration by ratios: the lab report's section VIII, done right.

Convention (``ratio = actual / predicted``, both from the fits):

* distance ratio ``q_d`` (the x fit's ratio through the origin, Table I's ratio): each wheel
  rolls ``q_d`` times what odometry assumed, so every wheel radius is MULTIPLIED by it:
  ``r_new = q_d * r_old``;
* rotation ratio ``q_r`` (the rotation fit's ratio through the origin): the heading change is
  ``(ds_r - ds_l) / b``; with the new radii the wheel distances grow by ``q_d`` while the robot actually turned only
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

from odolab.core.distributions import Z95
from odolab.core.errors import CalibrationError, opt
from odolab.core.numfmt import clean
from odolab.core.params import NoiseParams, RobotParams, save_params

if TYPE_CHECKING:
    from odolab.analysis import LabAnalysis
    from odolab.analysis.noise import SeparatedNoise

__all__ = [
    "CalibrationResult",
    "check_track_model",
    "describe_noise",
    "noise_provenance",
    "ratios",
    "ratios_from_analysis",
    "with_noise",
]


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

    def to_dict(self) -> dict[str, object]:
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
    return (hi - lo) / (2 * Z95) / value


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
            f"extended one, or `odolab calibrate lsq {opt('model')} {model.kind}`"
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
    prov: dict[str, object] = {
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
        prov["wheel_radius_ci95"] = [r * math.exp(-Z95 * sd), r * math.exp(Z95 * sd)]
        if sr is not None:
            s = math.hypot(sd, sr)
            b = new.track_width
            prov["track_width_ci95"] = [b * math.exp(-Z95 * s), b * math.exp(Z95 * s)]
    return CalibrationResult("ratios", new, params, prov)


def noise_provenance(
    split: SeparatedNoise, wheel_scale: float = 1.0, scrub_scale: float = 1.0
) -> tuple[NoiseParams | None, dict[str, object]]:
    """The ``[noise]`` of a separated noise fit and its provenance table.

    ``wheel_scale`` multiplies ``k_left``, ``k_right`` (new radii: the distance ratio);
    ``scrub_scale`` multiplies ``k_scrub`` (new radii and track width: 1 / the rotation ratio,
    as each radian of commanded turning becomes ``q_r`` of a radian). Without the wheel
    constants there is no ``[noise]``; without ``k_scrub`` it is written 0 and said unknown."""
    prov: dict[str, object] = {
        "rule": (
            "k_left, k_right (m) by maximum likelihood from straight runs alone; k_scrub (rad) "
            "from turns with the wheels' share fixed; never pooled across kinds of motion"
        ),
        "k_left": split.k_left.provenance(wheel_scale),
        "k_right": split.k_right.provenance(wheel_scale),
        "k_scrub": split.k_scrub.provenance(scrub_scale),
    }
    if split.scrub_pvalue is not None:
        prov["scrub_pvalue"] = split.scrub_pvalue
    notes = split.notes()
    if split.k_left.known and not split.k_scrub.known:
        notes.append("[noise] written with k_scrub = 0: turns would be under-covered")
    if not split.k_left.known:
        notes.append("no [noise] written")
    if notes:
        prov["notes"] = notes
    if split.k_left.value is None or split.k_right.value is None:
        return None, prov
    k_scrub = (split.k_scrub.value or 0.0) * scrub_scale
    noise = NoiseParams(
        k_left=clean(split.k_left.value * wheel_scale),
        k_right=clean(split.k_right.value * wheel_scale),
        k_scrub=clean(k_scrub),
    )
    return noise, prov


def with_noise(result: CalibrationResult, analysis: LabAnalysis) -> CalibrationResult:
    """Add the analysis' separated noise constants as the new parameters' ``[noise]``.

    The noise was measured in the old parameters' wheel distances and turns; the new radii
    scale every distance by the distance ratio ``q_d`` (``var = k |ds|`` becomes
    ``(q_d k) |ds_new|``) and every commanded turn by the rotation ratio ``q_r``
    (``k_scrub`` becomes ``k_scrub / q_r``), both taken from the new radii and track width
    against those the trials were run with (the analysis' parameters; else the result's old
    ones)."""
    split = analysis.noise_split
    if split is None:
        return result
    old, new = analysis.params or result.old_params, result.params
    q_d = (new.left_wheel_radius + new.right_wheel_radius) / (
        old.left_wheel_radius + old.right_wheel_radius
    )
    q_r = q_d * old.track_width / new.track_width
    noise, prov_noise = noise_provenance(split, q_d, 1.0 / q_r)
    prov = {
        **result.provenance,
        "noise": (
            "[noise] from the analysis: k_left, k_right from straight runs, k_scrub from turns "
            "(var = k |ds|, + k_scrub per rad of commanded turning), scaled to the new geometry"
            if noise is not None
            else "no [noise]: " + "; ".join(split.notes())
        ),
        "noise_fit": prov_noise,
    }
    params = new.with_(noise=noise) if noise is not None else new
    return replace(result, params=params, provenance=prov)


def describe_noise(result: CalibrationResult) -> str | None:
    """One line on the result's ``[noise]``: each constant with its interval and trial count,
    and what stays unknown (None when the result carries no noise fit)."""
    fit = result.provenance.get("noise_fit")
    if not isinstance(fit, dict):
        return None
    parts = []
    for key, unit in (("k_left", "m"), ("k_right", "m"), ("k_scrub", "rad")):
        entry = fit.get(key, {})
        if "value" in entry:
            ci = entry.get("ci95")
            where = f" [{ci[0]:.3g}, {ci[1]:.3g}]" if ci else ""
            parts.append(
                f"{key} = {entry['value']:.3g} {unit}{where} ({len(entry.get('trials', []))} "
                "trials)"
            )
        else:
            parts.append(f"{key} unknown ({entry.get('unknown', 'not measured')})")
    notes = [n for n in fit.get("notes", []) if "unknown" not in n]
    return "[noise] " + "; ".join(parts + notes)


def ratios_from_analysis(
    analysis: LabAnalysis,
    params: RobotParams | None = None,
    *,
    terrain: str | None = None,
) -> CalibrationResult:
    """Ratios taken from the notebook's fits: the x and rotation ratios (through the origin,
    Table I's ratio column; not the slopes of the lines with an intercept) on one terrain.

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
                    f"analysis fits on {t}: x ratio (through the origin) from {x.fit.n} "
                    f"trials, rotation ratio from {rot.fit.n} trials"
                ),
                terrain=t,
            )
            return with_noise(result, analysis)
    where = f"terrain {terrain!r}" if terrain else "any one terrain"
    raise CalibrationError(
        f"ratios calibration needs both a rotation fit and an x fit on {where}; "
        "each needs at least 3 measured trials"
    )

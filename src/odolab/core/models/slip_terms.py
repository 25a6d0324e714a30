"""The slip model's vocabulary: its basis of the measured speeds, its outputs and the names of
its terms (:mod:`odolab.core.models.slip`), shared with its covariance (:mod:`odolab.core.models.slip_covariance`)
without either importing the other's module."""

from __future__ import annotations

__all__ = ["DRIFT_KEYS", "FEATURES", "KIND", "NOISE_KEYS", "OUTPUTS", "TURN_CYCLES"]

#: The slip model's ``kind`` in a ``[model]`` table.
KIND = "slip"
#: The basis, in order (v: forward speed m/s, w: turn rate rad/s, both from the measured tracks).
FEATURES: tuple[str, ...] = ("v", "w", "absv", "absw", "v_absv", "v_absw", "w_absv", "w_absw")
#: The slipping body velocities: forward, lateral (left), yaw rate.
OUTPUTS: tuple[str, ...] = ("fwd", "lat", "yaw")
_COEF_KEYS = tuple(f"{o}_{f}" for o in OUTPUTS for f in FEATURES)
#: The noise terms, in the order of :meth:`SlipModel.noise_multipliers`.
NOISE_KEYS: tuple[str, ...] = ("q_fwd", "q_lat", "q_yaw", "k_fwd", "k_lat", "k_yaw")
_NOISE_KEYS = NOISE_KEYS
#: The drift terms, in the order of :meth:`SlipModel.drift_multipliers`.
DRIFT_KEYS: tuple[str, ...] = ("d_fwd", "d_lat", "d_yaw", "d_turn")
#: Cycles the commanded turn of a cycle is averaged over (:meth:`SlipModel.noise_multipliers`).
TURN_CYCLES = 5


def _features(v: float, w: float) -> tuple[float, ...]:
    av, aw = abs(v), abs(w)
    return (v, w, av, aw, v * av, v * aw, w * av, w * aw)

"""A new time-dependent model is one module plus its registration (issue 41).

The model below is such a module in miniature: a frozen dataclass with the
:class:`~odolab.core.models.KinematicModel` methods and those of :class:`~odolab.core.models.TimedModel`,
registered with :func:`~odolab.core.models.registry.register`. Nothing else in odolab changes, yet the
``[model]`` table, batch and streaming odometry and the faces' words take it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

from odolab.core.errors import ParamsError
from odolab.core.models import (
    DIFF_DRIVE,
    MODELS,
    ModelCoefficients,
    model_from_mapping,
    model_words,
    own_covariance,
    timed_model,
)
from odolab.core.models.registry import register, unregister
from odolab.core.odometry import Odometry, integrate_increments
from odolab.core.params import PRESETS, covariance_source, load_params, save_params

NOMINAL = PRESETS["jaguar-lite"]


@dataclass(frozen=True)
class SpeedDrag:
    """A test model: the forward motion falls short by ``drag`` times the speed (m/s), so a
    cycle's motion depends on its duration; the heading is the differential drive's."""

    drag: float = 0.0
    kind: ClassVar[str] = "test-speed-drag"
    KEYS: ClassVar[tuple[str, ...]] = ("drag",)
    time_dependent: ClassVar[bool] = True

    def coefficients(self, track_width: float) -> ModelCoefficients:
        return ModelCoefficients(0.5, 0.5, 1.0, 1.0, track_width, 0.0)

    def to_dict(self) -> dict[str, float]:
        return {"drag": self.drag}

    @property
    def is_differential_drive(self) -> bool:
        return self.drag == 0.0

    @property
    def is_linear(self) -> bool:
        return self.drag == 0.0

    def body_motion(
        self, ds_left: float, ds_right: float, dt: float, track_width: float
    ) -> tuple[float, float, float]:
        ds = 0.5 * (ds_left + ds_right)
        v = ds / dt if dt > 0 else 0.0
        return ds * (1.0 - self.drag * abs(v)), 0.0, (ds_right - ds_left) / track_width

    def body_motion_arrays(
        self, ds_left: Any, ds_right: Any, dt: Any, track_width: float
    ) -> tuple[Any, Any, Any]:
        ds = 0.5 * (ds_left + ds_right)
        v = np.where(dt > 0, ds / np.where(dt > 0, dt, 1.0), 0.0)
        return (
            ds * (1.0 - self.drag * np.abs(v)),
            np.zeros_like(ds),
            (ds_right - ds_left) / (track_width),
        )

    def speed_slip_gain(self, v_low: float, v_high: float) -> tuple[float, float, float]:
        return self.drag * (abs(v_high) - abs(v_low)), math.nan, math.nan


@pytest.fixture
def registered() -> Iterator[type[SpeedDrag]]:
    register(SpeedDrag)
    yield SpeedDrag
    unregister(SpeedDrag.kind)


def test_a_registered_kind_is_read_and_written_as_a_model_table(
    registered: type[SpeedDrag], tmp_path: Path
) -> None:
    model = model_from_mapping({"kind": "test-speed-drag", "drag": 0.25})
    assert model == SpeedDrag(0.25)
    path = tmp_path / "drag.toml"
    save_params(path, NOMINAL.with_(model=model))
    assert 'kind = "test-speed-drag"' in path.read_text()
    assert load_params(path).model == SpeedDrag(0.25)
    assert model_words(model) == "test-speed-drag (drag 0.25)"


def test_an_unregistered_kind_is_refused_in_one_sentence(registered: type[SpeedDrag]) -> None:
    unregister(SpeedDrag.kind)
    assert SpeedDrag.kind not in MODELS
    with pytest.raises(ParamsError, match="unknown model kind 'test-speed-drag'"):
        model_from_mapping({"kind": "test-speed-drag", "drag": 0.25})


def test_a_kind_is_registered_once(registered: type[SpeedDrag]) -> None:
    @dataclass(frozen=True)
    class Impostor(SpeedDrag):
        pass

    with pytest.raises(ValueError, match="registered twice"):
        register(Impostor)
    assert MODELS["test-speed-drag"] is SpeedDrag
    assert register(SpeedDrag) is SpeedDrag  # the same class again changes nothing


@pytest.mark.parametrize("method", ["midpoint", "arc"])
def test_batch_and_streaming_odometry_integrate_the_whole_timed_model(method: str) -> None:
    params = NOMINAL.with_(model=SpeedDrag(0.3))
    assert timed_model(params.model) is params.model
    assert own_covariance(params.model) is None and covariance_source(params) is None
    rng = np.random.default_rng(41)
    n = 200
    t = np.cumsum(rng.uniform(0.02, 0.08, n))
    dl, dr = rng.normal(30.0, 10.0, n), rng.normal(30.0, 10.0, n)
    batch = integrate_increments(t, dl, dr, params, method)
    odo = Odometry(params, method)
    for i in range(n):
        pose = odo.update_increments(t[i], dl[i], dr[i])
        assert (pose.x, pose.y, pose.heading) == pytest.approx(
            (batch.x[i], batch.y[i], batch.heading[i]), abs=1e-12
        )
    # the drag shortens the path against the same log with the plain differential drive
    plain = integrate_increments(t, dl, dr, NOMINAL.with_(model=DIFF_DRIVE), method)
    travelled = np.sum(np.hypot(np.diff(batch.x), np.diff(batch.y)))
    plain_travelled = np.sum(np.hypot(np.diff(plain.x), np.diff(plain.y)))
    assert travelled < plain_travelled
    assert batch.heading[-1] == pytest.approx(plain.heading[-1], abs=1e-12)


@pytest.mark.parametrize("kind", ["diff", "extended", "icr", "slip"])
def test_neutral_values_are_what_the_fit_starts_from(kind: str) -> None:
    # calibration/lsq.py's FitModel.values reads every kind's keys with isinstance branches;
    # models.neutral_values gives the same without them (what lsq.py should call)
    from odolab.calibration.lsq import FIT_MODELS
    from odolab.core.models import ExtendedDiffDrive, IcrModel, SlipModel, neutral_values

    models = {
        "diff": DIFF_DRIVE,
        "extended": ExtendedDiffDrive(1.02, 0.97, 1.3),
        "icr": IcrModel(0.4, -0.31, 0.05),
        "slip": SlipModel(fwd_v=-0.05, yaw_w=-0.1, q_fwd=1e-4),
    }
    params = NOMINAL.with_(model=models[kind])
    for spec in FIT_MODELS.values():
        values = spec.values(params)
        robot = {
            "left_wheel_radius": params.left_wheel_radius,
            "right_wheel_radius": params.right_wheel_radius,
            "track_width": params.track_width,
        }
        expected = {**robot, **neutral_values(params.model, params.track_width)}
        assert values == {k: expected[k] for k in spec.names}

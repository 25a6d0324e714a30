"""One kinematic model for every user: batch, streaming, the simulator and the virtual board."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from odolab.core.errors import ParamsError
from odolab.core.kinematics import body_motion, pose_step
from odolab.core.models import DIFF_DRIVE, KinematicModel, ModelCoefficients, model_from_mapping
from odolab.core.odometry import Odometry, integrate_increments
from odolab.core.params import PRESETS, RobotParams, load_params, save_params
from odolab.robot.plant import IdealPlant
from odolab.sim.physics import TrueParams, VirtualRobot

NOMINAL = PRESETS["jaguar-lite"]


@dataclass(frozen=True)
class SideSlip:
    """A test model with sideways motion: the body's ICR is ``x_icr`` ahead of the axle."""

    x_icr: float
    kind: ClassVar[str] = "test-side-slip"
    KEYS: ClassVar[tuple[str, ...]] = ("x_icr",)

    def coefficients(self, track_width: float) -> ModelCoefficients:
        return ModelCoefficients(0.5, 0.5, 1.0, 1.0, track_width, -self.x_icr)

    def to_dict(self) -> dict[str, float]:
        return {"x_icr": self.x_icr}

    @property
    def is_differential_drive(self) -> bool:
        return self.x_icr == 0.0


def _increments(seed: int, n: int = 300) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.05
    dl = rng.normal(20.0, 15.0, n)
    dr = rng.normal(20.0, 15.0, n)
    return t, dl, dr


def test_diff_drive_coefficients_are_eqs_3_3_3_4() -> None:
    c = NOMINAL.coefficients
    assert c == ModelCoefficients(0.5, 0.5, 1.0, 1.0, 0.56, 0.0)
    fwd, side, dth = c.body_motion(0.1, 0.3)
    assert (fwd, side, dth) == pytest.approx((0.2, 0.0, 0.2 / 0.56), abs=1e-15)
    assert body_motion(*c, 0.1, 0.3) == (fwd, side, dth)  # compiled == python, bit for bit


@pytest.mark.parametrize("method", ["midpoint", "arc"])
@pytest.mark.parametrize("model", [DIFF_DRIVE, SideSlip(0.07), SideSlip(-0.2)])
def test_batch_streaming_and_pose_step_agree(method: str, model: KinematicModel) -> None:
    params = NOMINAL.with_(model=model)
    t, dl, dr = _increments(3)
    batch = integrate_increments(t, dl, dr, params, method)
    odo = Odometry(params, method)
    kl, kr = params.left_metres_per_tick, params.right_metres_per_tick
    x = y = h = 0.0
    for i in range(t.size):
        pose = odo.update_increments(t[i], dl[i], dr[i])
        if i > 0:
            fwd, side, dth = params.coefficients.body_motion(dl[i] * kl, dr[i] * kr)
            x, y, h = pose_step(x, y, h, fwd, dth, method, lateral=side)
        assert (pose.x, pose.y, pose.heading) == pytest.approx((x, y, h), abs=1e-12)
        assert (batch.x[i], batch.y[i], batch.heading[i]) == pytest.approx((x, y, h), abs=1e-12)


def test_lateral_icr_offset_turns_on_a_circle_about_the_icr() -> None:
    # rotation in place with the ICR 0.1 m ahead: the axle centre circles the ICR and comes back
    params = NOMINAL.with_(model=SideSlip(0.1))
    n = 400
    per_step = 2 * math.pi / n * params.track_width / 2 / params.right_metres_per_tick
    dl = np.full(n + 1, -per_step)
    dr = np.full(n + 1, per_step)
    traj = integrate_increments(np.arange(n + 1.0), dl, dr, params, "arc")
    assert traj.heading[-1] == pytest.approx(2 * math.pi, abs=1e-12)
    assert (traj.x[-1], traj.y[-1]) == pytest.approx((0.0, 0.0), abs=1e-12)
    # after half a turn the axle centre is 2 * 0.1 m from where it started, straight ahead
    half = traj.x[n // 2], traj.y[n // 2]
    assert half == pytest.approx((0.2, 0.0), abs=1e-12)


def test_ideal_plant_and_simulator_follow_the_same_model() -> None:
    # constant wheel speeds: the exact arc is exact however the time is cut
    plant = IdealPlant(NOMINAL)
    robot = VirtualRobot(TrueParams.from_nominal(NOMINAL).noiseless, NOMINAL, seed=1)
    robot.reset(misalign=False)
    segments = [(0.3, 0.5, 2.0), (-0.4, 0.4, 1.5), (0.6, 0.2, 3.0)]
    x = y = h = 0.0
    for vl, vr, dur in segments:
        plant.set_wheel_speeds(vl, vr)
        plant.advance(dur)
        robot.set_wheel_speeds(vl, vr)
        robot.advance(dur)
        fwd, side, dth = NOMINAL.coefficients.body_motion(vl * dur, vr * dur)
        x, y, h = pose_step(x, y, h, fwd, dth, "arc", lateral=side)
        for pose in (plant.true_pose, robot.true_pose):
            assert (pose.x, pose.y, pose.heading) == pytest.approx((x, y, h), abs=1e-12)
        robot.set_wheel_speeds(0.0, 0.0)  # the noiseless truth has no stop slide


@given(st.floats(-0.3, 0.3), st.floats(0.2, 1.0))
def test_side_slip_with_zero_offset_is_the_differential_drive(x_icr: float, track: float) -> None:
    base = NOMINAL.with_(track_width=track)
    t, dl, dr = _increments(11, 80)
    a = integrate_increments(t, dl, dr, base, "arc")
    b = integrate_increments(t, dl, dr, base.with_(model=SideSlip(0.0)), "arc")
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.heading, b.heading)
    c = integrate_increments(t, dl, dr, base.with_(model=SideSlip(x_icr)), "arc")
    np.testing.assert_allclose(c.heading, a.heading, atol=1e-12)  # sideways slip keeps heading


def test_model_table_round_trip_and_errors(tmp_path: Path) -> None:
    path = save_params(tmp_path / "p.toml", NOMINAL)
    assert "[model]" not in path.read_text()  # the default model writes no table
    assert load_params(path) == NOMINAL
    path.write_text(path.read_text() + '\n[model]\nkind = "diff"\n')
    assert load_params(path).model == DIFF_DRIVE
    path.write_text(path.read_text().replace('kind = "diff"', 'kind = "tank"'))
    with pytest.raises(ParamsError, match=r"unknown model kind 'tank' in \[model\]; expected one"):
        load_params(path)
    with pytest.raises(ParamsError, match=r"unknown key 'track' in \[model\] of kind 'diff'"):
        model_from_mapping({"kind": "diff", "track": 0.5}, source="x.toml")
    with pytest.raises(ParamsError, match="model must be a kinematic model"):
        RobotParams(0.1, 0.1, 0.5, 100, model="diff")  # type: ignore[arg-type]


@pytest.mark.parametrize("kind", ["[1]", "{ a = 1 }", "1.5"])
def test_a_model_kind_that_is_not_text_is_one_sentence(tmp_path: Path, kind: str) -> None:
    # a list or a table as the kind was a TypeError (unhashable) traceback
    path = save_params(tmp_path / "p.toml", NOMINAL)
    path.write_text(path.read_text() + f"\n[model]\nkind = {kind}\n")
    with pytest.raises(ParamsError, match=r"p.toml: unknown model kind .* in \[model\]; expected"):
        load_params(path)

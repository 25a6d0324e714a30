"""The diff_drive_controller YAML: loads, and value x multiplier is the calibration to 1e-9."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from tests.core.test_models import SideSlip
from typer.testing import CliRunner

from odolab.cli import app
from odolab.errors import ParamsError
from odolab.export.ros2_controller import UNOBSERVED, controller_numbers, diff_drive_controller_yaml
from odolab.params import PRESETS, NoiseParams, save_params

NOMINAL = PRESETS["jaguar-lite"]
CALIBRATED = NOMINAL.with_(
    name="jaguar-calibrated",
    left_wheel_radius=0.0755675,
    right_wheel_radius=0.0757,
    track_width=0.5792,
    noise=NoiseParams(1.2e-4, 2.3e-4),
)


def _load(text: str, name: str = "diff_drive_controller") -> dict[str, object]:
    doc = yaml.safe_load(text)
    assert list(doc) == [name]
    params = doc[name]["ros__parameters"]
    assert isinstance(params, dict)
    return params


def test_effective_values_are_the_calibrated_ones() -> None:
    p = _load(diff_drive_controller_yaml(CALIBRATED, nominal=NOMINAL))
    assert p["wheel_radius"] == NOMINAL.left_wheel_radius  # the nominal geometry as the base
    assert p["wheel_separation"] == NOMINAL.track_width
    left = p["wheel_radius"] * p["left_wheel_radius_multiplier"]  # type: ignore[operator]
    right = p["wheel_radius"] * p["right_wheel_radius_multiplier"]  # type: ignore[operator]
    sep = p["wheel_separation"] * p["wheel_separation_multiplier"]  # type: ignore[operator]
    assert left == pytest.approx(CALIBRATED.left_wheel_radius, rel=1e-9)
    assert right == pytest.approx(CALIBRATED.right_wheel_radius, rel=1e-9)
    assert sep == pytest.approx(CALIBRATED.track_width, rel=1e-9)
    assert p["left_wheel_names"] == ["left_wheel_joint"]


def test_covariance_follows_the_documented_formula() -> None:
    v, f, d = 0.4, 20.0, 2.0
    p = _load(diff_drive_controller_yaml(CALIBRATED, speed=v, rate=f, horizon=d))
    k = 1.2e-4 + 2.3e-4
    b = CALIBRATED.track_width
    twist = p["twist_covariance_diagonal"]
    pose = p["pose_covariance_diagonal"]
    assert twist == pytest.approx(
        [k * v * f / 4, k * v * f / 4, UNOBSERVED, UNOBSERVED, UNOBSERVED, k * v * f / b**2]
    )
    assert pose == pytest.approx(
        [k * d / 4, k * d**3 / (3 * b**2), UNOBSERVED, UNOBSERVED, UNOBSERVED, k * d / b**2]
    )
    assert all(x > 0 for x in [*twist, *pose])  # type: ignore[union-attr]
    assert p["publish_rate"] == f


def test_a_model_the_controller_cannot_express_is_said_so() -> None:
    icr_like = CALIBRATED.with_(model=SideSlip(0.05))
    text = diff_drive_controller_yaml(icr_like)
    assert "not a differential drive" in text
    n = controller_numbers(icr_like)
    assert not n.exact
    assert n.effective_separation == pytest.approx(CALIBRATED.track_width, rel=1e-12)
    assert controller_numbers(CALIBRATED).exact


def test_without_noise_the_file_says_the_covariance_is_a_placeholder() -> None:
    text = diff_drive_controller_yaml(NOMINAL)
    assert "no [noise] table" in text
    _load(text)


def test_cli_writes_provenance_as_comments(tmp_path: Path) -> None:
    src = save_params(
        tmp_path / "cal.toml", CALIBRATED, provenance={"method": "ratios", "q_d": 0.905}
    )
    out = tmp_path / "dd.yaml"
    res = CliRunner().invoke(
        app,
        ["export", "ros2-controller", str(src), "-o", str(out), "--nominal", "jaguar-lite",
         "--controller-name", "base_controller", "--left-wheel", "fl", "--left-wheel", "rl",
         "--right-wheel", "fr", "--right-wheel", "rr"],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    text = out.read_text()
    assert "#   method: ratios" in text and "#   q_d: 0.905" in text
    p = _load(text, "base_controller")
    assert p["wheels_per_side"] == 2 and p["right_wheel_names"] == ["fr", "rr"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--speed", "-1"], "--speed is -1.0; expected a positive number"),
        (["--rate", "nan"], "--rate is nan; expected a positive number"),
        (["--controller-name", "a b<script>"], "is not a ROS 2 node name"),
        (["--left-wheel", "a", "--left-wheel", "b"], "expected as many wheels on each side"),
    ],
)
def test_bad_options_are_one_sentence(
    tmp_path: Path, args: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from odolab.cli import main

    out = tmp_path / "x.yaml"
    code = main(["export", "ros2-controller", "jaguar-lite", "-o", str(out), *args])
    err = capsys.readouterr().err
    assert code == 1
    assert message in err and err.count("\n") == 1
    assert not out.exists()


def test_library_refuses_a_bad_horizon() -> None:
    with pytest.raises(ParamsError, match="--horizon is 0; expected a positive number"):
        controller_numbers(CALIBRATED, horizon=0)

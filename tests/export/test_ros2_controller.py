"""The diff_drive_controller YAML: loads, and value x multiplier is the calibration to 1e-9."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from tests.core.test_models import SideSlip
from tests.worded import raises_worded
from typer.testing import CliRunner

from odolab.cli import app
from odolab.cli.wording import said
from odolab.core.errors import ParamsError
from odolab.core.params import PRESETS, NoiseParams, RobotParams, save_params
from odolab.export.ros2_controller import UNOBSERVED, controller_numbers, diff_drive_controller_yaml

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
    v, f, d, w = 0.4, 20.0, 2.0, 10
    p = _load(diff_drive_controller_yaml(CALIBRATED, speed=v, rate=f, horizon=d))
    k = 1.2e-4 + 2.3e-4
    b = CALIBRATED.track_width
    twist = p["twist_covariance_diagonal"]
    pose = p["pose_covariance_diagonal"]
    # the controller's own estimate: a rolling mean over its window of 10 update cycles
    assert p["velocity_rolling_window_size"] == w
    vx, wz = k * v * f / (4 * w), k * v * f / (w * b**2)
    assert twist == pytest.approx([vx, vx, UNOBSERVED, UNOBSERVED, UNOBSERVED, wz])
    p5 = _load(diff_drive_controller_yaml(CALIBRATED, speed=v, rate=f, horizon=d, window=5))
    assert p5["twist_covariance_diagonal"][0] == pytest.approx(2 * vx)  # type: ignore[index]
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
    assert "wheels_per_side" not in p and p["right_wheel_names"] == ["fr", "rr"]  # jazzy
    res = CliRunner().invoke(
        app,
        ["export", "ros2-controller", str(src), "-o", str(out), "--ros-distro", "humble",
         "--left-wheel", "fl", "--left-wheel", "rl", "--right-wheel", "fr", "--right-wheel", "rr"],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    assert _load(out.read_text())["wheels_per_side"] == 2  # humble still has it


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
    with raises_worded(ParamsError, match="--horizon is 0; expected a positive number"):
        controller_numbers(CALIBRATED, horizon=0)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--speed", "1e308"], "--speed is 1e+308; expected a positive number up to 100"),
        (["--horizon", "1e200"], "--horizon is 1e+200; expected a positive number up to 100000"),
        (["--rate", "inf"], "--rate is inf; expected a positive number up to 100000"),
        (["--left-wheel", "ok", "--right-wheel", "b\x1b[31m"], "--right-wheel 'b\\x1b[31m' is"),
        (["--left-wheel", "\u00e9"], "--left-wheel '\u00e9' is not a ROS 2 joint name"),
    ],
)
def test_huge_numbers_and_bad_joint_names_are_one_sentence(
    tmp_path: Path, args: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # 1e308 m/s made an infinite covariance (the YAML said 'inf', a string to ROS); 1e200 m of
    # horizon an OverflowError; a bad joint name was blamed on the controller name
    from odolab.cli import main

    out = tmp_path / "x.yaml"
    code = main(["export", "ros2-controller", "jaguar-lite", "-o", str(out), *args])
    err = capsys.readouterr().err
    assert code == 1
    assert message in err and err.count("\n") == 1, err
    assert not out.exists()


def test_provenance_cannot_add_yaml_keys(tmp_path: Path) -> None:
    # provenance keys and values are typed by people; a line break in them (\n, \r, NEL, U+2028:
    # all line breaks to a YAML reader) used to end the comment and add top-level keys
    src = save_params(tmp_path / "cal.toml", CALIBRATED, provenance={"method": "ratios"})
    src.write_text(
        src.read_text(encoding="utf-8")
        + '"evil\\nkey: 1\\nx" = "v"\nnote = "a\\rinjected: true\\u2028b: 2\\u0085c: 3"\n',
        encoding="utf-8",
    )
    out = tmp_path / "dd.yaml"
    res = CliRunner().invoke(app, ["export", "ros2-controller", str(src), "-o", str(out)])
    assert res.exit_code == 0, res.output
    text = out.read_text(encoding="utf-8")
    assert list(yaml.safe_load(text)) == ["diff_drive_controller"]
    assert "#   evil\\x0akey: 1\\x0ax: v" in text
    assert "#   note: a\\x0dinjected: true\\u2028b: 2\\x85c: 3" in text
    assert all(line.startswith(("#", "diff_drive_controller:", "  ")) for line in text.splitlines())


# --- each ROS 2 distribution's own keys; floats that load as floats (issue 26.4) ----------------

SCHEMAS = Path(__file__).parent / "ros2_schemas"


def _schema_keys(distro: str) -> set[str]:
    """Top-level parameters of the recorded diff_drive_controller schema (its text is not
    plain YAML: ``validation`` entries like ``gt<>`` are read by generate_parameter_library)."""
    import re

    text = (SCHEMAS / f"{distro}.yaml").read_text()
    return set(re.findall(r"^  ([a-z_]+):", text, flags=re.MULTILINE))


@pytest.mark.parametrize("distro", ["humble", "jazzy", "kilted", "rolling"])
def test_key_lists_are_the_recorded_schemas(distro: str) -> None:
    from odolab.export.ros2_controller import DISTRO_KEYS

    assert set(DISTRO_KEYS[distro]) == _schema_keys(distro)


@pytest.mark.parametrize("distro", ["humble", "jazzy", "kilted", "rolling"])
def test_each_distro_gets_only_its_own_keys(distro: str) -> None:
    text = diff_drive_controller_yaml(
        CALIBRATED.with_(noise=NoiseParams(5e-5, 7e-6, 1e-3)), distro=distro
    )
    p = _load(text)
    assert set(p) <= _schema_keys(distro)
    removed = {"humble": set(), "jazzy": {"wheels_per_side"}, "kilted": {"wheels_per_side"}}
    for key in removed.get(distro, {"wheels_per_side", "publish_rate"}):
        assert key not in p, (distro, key)
    assert f"for ROS 2 {distro}" in text
    # every covariance value loads as a float in YAML 1.1 (5e-05 would be a string)
    values = [*p["pose_covariance_diagonal"], *p["twist_covariance_diagonal"]]  # type: ignore[misc]
    assert all(type(v) is float for v in values), values
    for key in ("wheel_radius", "wheel_separation", "left_wheel_radius_multiplier"):
        assert type(p[key]) is float


def test_yaml_floats_keep_a_dot_in_the_mantissa() -> None:
    from odolab.export.ros2_controller import yaml_float

    for v in (5e-05, 1e-300, 1e22, -2.5e-7, 0.5, 1e6, 123456789012345678.0):
        text = yaml_float(v)
        assert yaml.safe_load(text) == v and type(yaml.safe_load(text)) is float, text
    assert yaml_float(5e-05) == "5.0e-05"
    assert isinstance(yaml.safe_load(repr(5e-05)), str)  # what repr gave before


def test_an_unknown_distro_is_one_sentence() -> None:
    with raises_worded(ParamsError, match="--ros-distro is 'iron'; expected one of humble"):
        diff_drive_controller_yaml(CALIBRATED, distro="iron")


def test_multipliers_without_nominal_are_the_radii_over_their_mean() -> None:
    """docs/ros2.md said 1 without --nominal; with unequal radii they are not."""
    p = _load(diff_drive_controller_yaml(CALIBRATED))
    mean = (CALIBRATED.left_wheel_radius + CALIBRATED.right_wheel_radius) / 2
    assert p["wheel_radius"] == pytest.approx(mean, rel=1e-12)
    assert p["left_wheel_radius_multiplier"] == pytest.approx(
        CALIBRATED.left_wheel_radius / mean, rel=1e-12
    )
    assert p["left_wheel_radius_multiplier"] != 1.0 and p["wheel_separation_multiplier"] == 1.0


def test_a_horizon_past_first_order_is_said_so() -> None:
    """A straight 5 m with k = 1.87e-4 m a wheel: heading variance 0.006 rad^2, where the Monte
    Carlo finds the along-track variance 1.28 times the first-order one (tests/core)."""
    noisy = CALIBRATED.with_(noise=NoiseParams(1.87e-4, 1.87e-4))
    assert "understates the spread" in diff_drive_controller_yaml(noisy, horizon=5.0)
    assert "understates" not in diff_drive_controller_yaml(noisy, horizon=1.0)


# --- the slip model (issue 29): its equivalent at --speed and its own covariance ---------------


def _slip(**coefficients: float) -> RobotParams:
    from odolab.core.models import SlipModel

    return NOMINAL.with_(name="slip", model=SlipModel(**coefficients))


def test_a_linear_slip_model_is_a_differential_drive_of_the_right_size() -> None:
    """The slip model's linear part has a rotation denominator of 1 m; the export took it for the
    separation and the radius from the rotation term: 1.55x the wheel radius and 1 m of track
    for a fit of the tracked Jaguar (its straight runs 1.55x too long)."""
    p = _slip(fwd_v=-0.1, yaw_w=-0.15, q_fwd=1e-4, k_yaw=1e-3)
    n = controller_numbers(p, nominal=NOMINAL)
    assert n.exact and not n.notes
    assert n.effective_left_radius == pytest.approx(0.9 * NOMINAL.left_wheel_radius, rel=1e-12)
    assert n.effective_right_radius == pytest.approx(0.9 * NOMINAL.right_wheel_radius, rel=1e-12)
    assert n.effective_separation == pytest.approx(NOMINAL.track_width * 0.9 / 0.85, rel=1e-12)
    assert n.covariance_source == "slip"


def test_a_speed_dependent_slip_model_is_its_equivalent_at_the_stated_speed() -> None:
    v, b = 0.8, NOMINAL.track_width
    p = _slip(fwd_v_absv=-0.2, yaw_w_absw=-0.1, yaw_v=0.02)
    n = controller_numbers(p, nominal=NOMINAL, speed=v)
    assert not n.exact
    (note,) = map(said, n.notes)  # as the CLI writes it
    assert "equivalent at --speed 0.8 m/s" in note and "0.92 at 0.4 m/s" in note
    assert "0.68 at 1.6 m/s" in note
    r = NOMINAL.left_wheel_radius
    forward = 1.0 - 0.2 * v  # per metre of track, straight at v
    turn = 1.0 - 0.1 * (2.0 * v / b)  # per commanded radian, in place at wheel speed v
    assert (n.effective_left_radius + n.effective_right_radius) / 2 == pytest.approx(r * forward)
    assert n.effective_separation == pytest.approx(b * forward / turn)
    # the straight run's heading drift (0.02 rad per metre) is in the radii
    drift = (n.effective_right_radius - n.effective_left_radius) / r / n.effective_separation
    assert drift == pytest.approx(0.02 * forward / forward, rel=1e-9)
    assert controller_numbers(p, nominal=NOMINAL, speed=0.3).effective_separation != pytest.approx(
        n.effective_separation
    )


def test_the_slip_models_covariance_is_its_predictive_variance_of_a_straight_run() -> None:
    import numpy as np

    from odolab.core.slip_uncertainty import propagate_covariance

    v, f, d, w = 0.5, 50.0, 1.0, 10
    p = _slip(fwd_v=-0.1, q_fwd=2e-4, q_lat=1e-4, q_yaw=3e-4, k_fwd=1e-4, d_yaw=1e-3)
    text = diff_drive_controller_yaml(p, speed=v, rate=f, horizon=d, window=w)
    assert "the slip model's predictive variance" in text and "no [noise] table" not in text
    loaded = _load(text)
    n = round(d / v * f)
    t = np.arange(n + 1) / f
    ticks = np.full(n + 1, v / f / NOMINAL.left_metres_per_tick)
    ticks[0] = 0.0
    _, cov = propagate_covariance(t, ticks, ticks, p)
    pose = loaded["pose_covariance_diagonal"]
    assert pose == pytest.approx(  # type: ignore[comparison-overlap]
        [cov[-1, 0, 0], cov[-1, 1, 1], UNOBSERVED, UNOBSERVED, UNOBSERVED, cov[-1, 2, 2]],
        rel=1e-9,
    )
    span = w / f  # the controller's velocity: the displacement over its window, over that time
    twist = loaded["twist_covariance_diagonal"]
    assert twist[0] == pytest.approx(cov[w, 0, 0] / span**2, rel=1e-9)  # type: ignore[index]
    assert twist[5] == pytest.approx(cov[w, 2, 2] / span**2, rel=1e-9)  # type: ignore[index]
    assert all(x > 0 for x in pose[:2])  # type: ignore[index]


def test_a_model_that_cannot_drive_is_one_sentence(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from odolab.cli import main

    src = save_params(tmp_path / "s.toml", _slip(fwd_v=-1.5))
    out = tmp_path / "x.yaml"
    assert main(["export", "ros2-controller", str(src), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert "moves -0.5 m forward per metre of straight driving" in err, err
    assert "a differential drive needs both positive" in err and err.count("\n") == 1
    assert not out.exists()

from __future__ import annotations

import math
from pathlib import Path

import pytest

from odolab import PRESETS, ParamsError, RobotParams, load_params, save_params


def test_preset_is_nominal_jaguar() -> None:
    p = load_params("jaguar-lite")
    assert p is PRESETS["jaguar-lite"]
    assert p.track_width == pytest.approx(2 * 0.28)
    assert p.encoder_modulus == 32768
    assert p.left_metres_per_tick == pytest.approx(2 * math.pi * 0.0835 / 380)


def test_toml_round_trip(tmp_path: Path) -> None:
    p = RobotParams(0.1, 0.11, 0.5, 2796.8, None, name="r1")
    path = save_params(tmp_path / "p.toml", p, provenance={"method": "test"})
    text = path.read_text()
    assert "encoder_modulus" not in text and "[provenance]" in text
    assert load_params(path) == p


@pytest.mark.parametrize(
    ("body", "needle"),
    [
        ("left_wheel_radius = -0.1", "left_wheel_radius must be a positive finite number"),
        ("trak_width = 0.5", "unknown key 'trak_width'"),
        ("track_width = 'wide'", "track_width must be a number"),
        ("encoder_modulus = 1", "encoder_modulus must be an integer >= 2"),
    ],
)
def test_bad_file_names_file_and_key(tmp_path: Path, body: str, needle: str) -> None:
    base = {
        "left_wheel_radius": "0.1",
        "right_wheel_radius": "0.1",
        "track_width": "0.5",
        "ticks_per_rev": "100",
    }
    key = body.split("=")[0].strip()
    base.pop(key, None)
    lines = [f"{k} = {v}" for k, v in base.items()] + [body]
    path = tmp_path / "bad.toml"
    path.write_text("[robot]\n" + "\n".join(lines) + "\n")
    with pytest.raises(ParamsError) as err:
        load_params(path)
    msg = str(err.value)
    assert str(path) in msg and needle in msg
    assert "\n" not in msg


def test_missing_file_and_bad_toml(tmp_path: Path) -> None:
    with pytest.raises(ParamsError, match="no such parameters file or preset"):
        load_params(tmp_path / "nope.toml")
    bad = tmp_path / "x.toml"
    bad.write_text("[robot\n")
    with pytest.raises(ParamsError, match="not valid TOML"):
        load_params(bad)
    bad.write_text("[robt]\nx=1\n")
    with pytest.raises(ParamsError, match=r"missing the \[robot\] table"):
        load_params(bad)


@pytest.mark.parametrize("value", [0.0, -1.0, math.nan, math.inf])
def test_invalid_values_rejected(value: float) -> None:
    with pytest.raises(ParamsError):
        RobotParams(value, 0.1, 0.5, 100)
    with pytest.raises(ParamsError):
        RobotParams(0.1, 0.1, value, 100)

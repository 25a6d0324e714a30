"""One number-formatting rule (odolab.core.numfmt), and numbers written to files without float noise."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from odolab.cli import main
from odolab.core import numfmt


@pytest.mark.parametrize(
    ("value", "unc", "text"),
    [
        (0.87503, 0.0086, "0.8750 ± 0.0086"),  # 2 significant digits of u -> 4 decimals
        (2.963, 0.55, "2.96 ± 0.55"),
        (2.963, 1.1, "3.0 ± 1.1"),
        (1234.5, 23.0, "1234 ± 23"),
        (0.0996, 0.0996, "0.10 ± 0.10"),  # u rounds up into the next decade: 0.10, not 0.0996
        (-0.00001, 0.01, "0.000 ± 0.010"),  # no "-0.000"
    ],
)
def test_value_carries_the_digits_its_uncertainty_supports(
    value: float, unc: float, text: str
) -> None:
    assert numfmt.with_uncertainty(value, unc, show=True) == text


def test_interval_and_plain_and_p() -> None:
    assert numfmt.with_ci(0.87504, 0.85786, 0.89222) == "0.875 [0.858, 0.892]"
    assert numfmt.with_ci(0.9049, 0.90314, 0.90667) == "0.9049 [0.9031, 0.9067]"
    # no interval (a noise constant from too few trials), no value: never a TypeError
    assert numfmt.with_ci(0.02471, None, None) == "0.02471"
    assert numfmt.with_ci(0.02471, 0.01, None) == "0.02471"
    assert numfmt.with_ci(None, None, None) == "-"
    assert numfmt.plain(7.806e-4) == "0.0007806"
    assert numfmt.plain(1.0002) == "1.000"  # trailing zeros are significant
    assert numfmt.plain(-2.5, strip=True) == "-2.5"
    assert numfmt.plain(3.2e-7) == "3.2e-7"
    assert numfmt.p_value(0.3349) == "0.33" and numfmt.p_value(1.9e-69) == "< 0.001"
    assert numfmt.count(1, "measured trial") == "1 measured trial"
    assert numfmt.count(2, "trial") == "2 trials"


@pytest.mark.parametrize(
    ("value", "sig", "text"),
    [
        # rounding that carries into the next decade keeps sig digits (was "10.000": five)
        (9.99996, 4, "10.00"),
        (-0.99996, 4, "-1.000"),
        (99.995, 4, "100.0"),
        (999999.9, 4, "1e6"),  # rounds to 1e6: scientific from there (was "1000000")
        (9.99996e-5, 4, "0.0001000"),  # rounds to 1e-4: not below it
        (0.0996, 2, "0.10"),  # the p-value digits (was "0.100")
        (1234.5678, 4, "1235"),
        (0.012344, 4, "0.01234"),
    ],
)
def test_plain_keeps_its_significant_digits_when_rounding_carries(
    value: float, sig: int, text: str
) -> None:
    assert numfmt.plain(value, sig) == text


def test_written_floats_are_shortest_round_trip() -> None:
    a = np.array([0.05, 0.1 + 0.2, 1 / 3, 2.5, 1e-5, 62.83185307179586, math.pi * 1e10])
    lines = numfmt.csv_lines([a, a * 3]).splitlines()
    first = [line.split(",")[0] for line in lines]
    assert first == [repr(float(v)) for v in a]
    rng = np.random.default_rng(1)
    r = rng.normal(size=5000) * 10.0 ** rng.integers(-8, 8, size=5000)
    text = numfmt.csv_lines([r]).splitlines()
    assert [float(v) for v in text] == r.tolist()
    assert all(len(t) <= len(repr(float(v))) for t, v in zip(text, r, strict=True))
    assert numfmt.clean(0.0835 * 0.905) == 0.0755675


def test_odometry_csv_keeps_the_inputs_digits(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    log.write_text("t,left_ticks,right_ticks\n0,0,0\n0.05,3,4\n0.1,6,8\n", encoding="utf-8")
    out = tmp_path / "traj.csv"
    assert main(["odometry", str(log), "--params", "jaguar-lite", "-o", str(out)]) == 0
    rows = out.read_text().splitlines()
    assert rows[2].startswith("0.05,") and "0.050000000000000003" not in out.read_text()


def test_calibrated_toml_has_no_float_noise(tmp_path: Path) -> None:
    out = tmp_path / "new.toml"
    args = ["calibrate", "ratios", "-p", "jaguar-lite", "--distance-ratio", "0.905"]
    assert main([*args, "--rotation-ratio", "0.875", "-o", str(out)]) == 0
    text = out.read_text()
    assert "left_wheel_radius = 0.0755675\n" in text and "0.07556750000000001" not in text
    robot = tomllib.loads(text)["robot"]
    assert robot["track_width"] == pytest.approx(0.56 * 0.905 / 0.875, rel=1e-12)

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from odolab import integrate, load_params
from odolab.cli import main
from odolab.core.trials import EncoderLog
from odolab.io import (
    read_encoder_csv,
    read_trajectory_csv,
    read_tum,
    write_encoder_csv,
    write_trajectory_csv,
    write_tum,
)


def _log(tmp_path: Path, text: str, name: str = "log.csv") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_encoder_csv_round_trip(tmp_path: Path) -> None:
    log = EncoderLog(
        np.array([0.0, 0.05, 0.1]), np.array([32760, 5, 20]), np.array([0, 3, 9]), 32768
    )
    back = read_encoder_csv(write_encoder_csv(tmp_path / "e.csv", log), modulus=32768)
    np.testing.assert_array_equal(back.left_ticks, log.left_ticks)
    np.testing.assert_array_equal(back.t, log.t)


def test_increment_csv_is_summed(tmp_path: Path) -> None:
    p = _log(tmp_path, "t,dticks_left,dticks_right\n0,0,0\n1,5,-2\n2,5,-2\n")
    log = read_encoder_csv(p)
    assert list(log.left_ticks) == [0, 5, 10] and list(log.right_ticks) == [0, -2, -4]
    assert log.modulus is None


def test_trajectory_csv_and_tum_round_trip(tmp_path: Path) -> None:
    n = 50
    tr = integrate(
        np.arange(n) * 0.1, np.arange(n) * 7, np.arange(n) * 19, load_params("jaguar-lite")
    )
    a = read_trajectory_csv(write_trajectory_csv(tmp_path / "t.csv", tr))
    np.testing.assert_array_equal(a.heading, tr.heading)
    np.testing.assert_array_equal(a.x, tr.x)
    b = read_tum(write_tum(tmp_path / "t.tum", tr))
    np.testing.assert_allclose(b.theta, tr.theta, atol=1e-12)
    np.testing.assert_allclose(b.heading, tr.heading, atol=1e-9)


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("t,left_ticks\n0,1\n", "missing column 'right_ticks'"),
        ("t,left_ticks,right_ticks\n0,1,2\n0.05,,3\n", "line 3, column 'left_ticks' is empty"),
        ("t,left_ticks,right_ticks\n0,1,2\n0.05,abc,3\n", "line 3, column 'left_ticks' is 'abc'"),
        ("t,left_ticks,right_ticks\n0,1,2\n0.05,nan,3\n", "line 3, column 'left_ticks' is 'nan'"),
        ("t,left_ticks,right_ticks\n0,1,2\n0.05,2,3\n0.01,3,4\n", "time goes backwards at line 4"),
        ("t,left_ticks,right_ticks\n0,1,2\n0.05,40000,3\n", "expected a counter value in 0..32767"),
        ("", "empty or unreadable"),
    ],
)
def test_cli_bad_log_one_sentence(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, needle: str
) -> None:
    log = _log(tmp_path, text)
    code = main(["odometry", str(log), "-o", str(tmp_path / "out.csv")])
    err = capsys.readouterr().err
    assert code == 1
    assert needle in err and str(log) in err
    assert "Traceback" not in err and err.count("\n") == 1
    assert not (tmp_path / "out.csv").exists()


def test_cli_bad_params_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = _log(tmp_path, "t,left_ticks,right_ticks\n0,1,2\n")
    params = _log(
        tmp_path,
        "[robot]\nleft_wheel_radius = -0.1\nright_wheel_radius = 0.1\ntrack_width = 0.5\nticks_per_rev = 100\n",
        "p.toml",
    )
    assert main(["odometry", str(log), "--params", str(params)]) == 1
    err = capsys.readouterr().err
    assert str(params) in err and "left_wheel_radius must be a positive" in err
    assert "Traceback" not in err


def test_cli_typo_in_command(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["odometri"]) == 1  # a usage error: one sentence, exit 1 (issue 25.9)
    assert "No such command" in capsys.readouterr().err


def test_cli_odometry_wrapping_log_gives_same_pose(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rng = np.random.default_rng(11)
    n = 400
    left = np.cumsum(rng.integers(-5, 60, n))
    right = np.cumsum(rng.integers(-5, 50, n))
    t = np.arange(n) * 0.05
    poses = {}
    for bits in (15, 16):
        m = 2**bits
        (tmp_path / f"p{bits}.toml").write_text(
            "[robot]\nleft_wheel_radius = 0.0835\nright_wheel_radius = 0.0835\n"
            f"track_width = 0.56\nticks_per_rev = 380\nencoder_modulus = {m}\n"
        )
        for name, off in (("wrap", m - 700), ("nowrap", 0)):
            log = EncoderLog(t, (left + off) % m, (right + off) % m, m)
            path = write_encoder_csv(tmp_path / f"{name}{bits}.csv", log)
            out = tmp_path / f"{name}{bits}.out.csv"
            assert (
                main(["odometry", str(path), "-p", str(tmp_path / f"p{bits}.toml"), "-o", str(out)])
                == 0
            )
            poses[(name, bits)] = read_trajectory_csv(out).final
    ref = poses[("nowrap", 15)]
    for pose in poses.values():
        assert pose.x == pytest.approx(ref.x, abs=1e-9)
        assert pose.y == pytest.approx(ref.y, abs=1e-9)
        assert pose.heading == pytest.approx(ref.heading, abs=1e-9)
    capsys.readouterr()


def test_cli_tum_and_arc(tmp_path: Path) -> None:
    log = _log(tmp_path, "t,left_ticks,right_ticks\n0,0,0\n1,100,300\n2,200,600\n")
    out = tmp_path / "o.tum"
    assert main(["odometry", str(log), "--method", "arc", "--format", "tum", "-o", str(out)]) == 0
    lines = out.read_text().splitlines()
    assert len(lines) == 3 and len(lines[0].split()) == 8


def test_cli_params_show(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["params", "show", "jaguar-lite"]) == 0
    out = capsys.readouterr().out
    assert "track_width = 0.56" in out and "[robot]" in out
    assert math.isclose(load_params("jaguar-lite").track_width, 0.56)


def test_cli_turns_any_file_error_into_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import odolab.io

    def denied(*args: object, **kwargs: object) -> None:
        raise PermissionError(13, "Permission denied", "locked.csv")

    monkeypatch.setattr(odolab.io, "read_encoder_csv", denied)
    assert main(["odometry", "locked.csv"]) == 1
    err = capsys.readouterr().err
    assert err == "odolab: error: locked.csv: Permission denied\n"

"""`odolab odometry --covariance`: the six covariance columns, batch and chunked, every format.

References: the numpy midpoint propagation :func:`odolab.core.uncertainty.pose_covariance` (written
independently of the compiled kernel), the closed form of a straight run, and the covariance in an
MCAP written by `odolab export mcap`, read back with mcap-ros2-support's decoder.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from typer.testing import CliRunner

from odolab.cli import app, main
from odolab.core.params import PRESETS, NoiseParams, save_params
from odolab.core.trials import EncoderLog
from odolab.core.uncertainty import COV_COLUMNS, pose_covariance, straight_line_covariance
from odolab.io import write_encoder_csv
from odolab.io.chunked import ChunkedOdometry
from odolab.io.tabular import read_columns

MOD = 32768
NOISE = NoiseParams(1e-4, 3e-4)
PARAMS = replace(PRESETS["jaguar-lite"], noise=NOISE)
POSE = ("t", "x", "y", "theta", "heading")


def _log(n: int = 3000, seed: int = 5) -> EncoderLog:
    """Counters that wrap several times (modulus 32768), turning both ways."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.02
    left = (np.cumsum(rng.integers(-20, 120, n)) + 32000) % MOD
    right = (np.cumsum(rng.integers(-40, 140, n)) + 100) % MOD
    return EncoderLog(t, left.astype(np.int64), right.astype(np.int64), MOD)


def _reference(log: EncoderLog, heading0: float = 0.0) -> np.ndarray:
    """Six terms per row from the numpy midpoint propagation of the unwrapped increments."""
    dl = np.diff(np.unwrap(log.left_ticks, period=MOD)) * PARAMS.left_metres_per_tick
    dr = np.diff(np.unwrap(log.right_ticks, period=MOD)) * PARAMS.right_metres_per_tick
    full = pose_covariance(
        dl, dr, PARAMS.track_width, NOISE.k_left, NOISE.k_right, heading0=heading0
    )
    return full[:, [0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]


def _odometry(tmp_path: Path, log_path: Path, out: Path, *extra: str) -> dict[str, np.ndarray]:
    params_file = save_params(tmp_path / "p.toml", PARAMS)
    res = CliRunner().invoke(
        app,
        ["odometry", str(log_path), "-p", str(params_file), "--covariance", "-o", str(out),
         *extra],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    return read_columns(out, (*POSE, *COV_COLUMNS))


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".arrow"])
def test_batch_covariance_equals_the_numpy_propagation(tmp_path: Path, suffix: str) -> None:
    log = _log()
    src = write_encoder_csv(tmp_path / f"log{suffix}", log)
    cols = _odometry(tmp_path, src, tmp_path / f"traj{suffix}", "--start", "1", "2", "0.7",
                     "--chunk-rows", "0")  # fmt: skip
    got = np.column_stack([cols[c] for c in COV_COLUMNS])
    np.testing.assert_allclose(got, _reference(log, heading0=0.7), rtol=1e-9, atol=1e-15)
    assert got[0].tolist() == [0.0] * 6
    assert (got[1:, 0] > 0).all() and (got[1:, 5] > 0).all()


def test_straight_run_matches_the_closed_form(tmp_path: Path) -> None:
    n = 20_001
    ticks = (np.arange(n) * 7) % MOD  # both wheels 7 counts a cycle: a straight line
    log = EncoderLog(np.arange(n) * 0.01, ticks, ticks, MOD)
    p = replace(PARAMS, left_wheel_radius=PARAMS.right_wheel_radius)
    params_file = save_params(tmp_path / "p.toml", p)
    out = tmp_path / "traj.csv"
    src = write_encoder_csv(tmp_path / "log.csv", log)
    res = CliRunner().invoke(
        app, ["odometry", str(src), "-p", str(params_file), "--covariance", "-o", str(out)]
    )
    assert res.exit_code == 0, res.output
    cols = read_columns(out, ("x", *COV_COLUMNS))
    d = float(cols["x"][-1])
    assert d == pytest.approx((n - 1) * 7 * p.right_metres_per_tick, rel=1e-12)
    want = straight_line_covariance(d, p.track_width, NOISE.k_left, NOISE.k_right)
    want6 = want[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]
    got = np.array([cols[c][-1] for c in COV_COLUMNS])
    # the continuous limit: 20,000 midpoint steps are within 1e-4 of it
    np.testing.assert_allclose(got, want6, rtol=1e-3)


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".arrow"])
def test_chunked_equals_whole(tmp_path: Path, suffix: str) -> None:
    log = _log(n=2500, seed=11)
    src = write_encoder_csv(tmp_path / f"log{suffix}", log)
    whole = _odometry(tmp_path, src, tmp_path / f"whole{suffix}", "--chunk-rows", "0",
                      "--method", "arc", "--start", "0", "0", "-2.5")  # fmt: skip
    for rows in (1, 7, 333, 2499):
        part = _odometry(tmp_path, src, tmp_path / f"c{rows}{suffix}", "--chunk-rows", str(rows),
                         "--method", "arc", "--start", "0", "0", "-2.5")  # fmt: skip
        for c in (*POSE, *COV_COLUMNS):
            np.testing.assert_allclose(part[c], whole[c], rtol=1e-12, atol=1e-12, err_msg=c)


def test_stepper_carries_the_covariance_across_a_wrap() -> None:
    log = _log(n=600, seed=2)
    odo = ChunkedOdometry(PARAMS, covariance=True)
    parts = [odo.step(log.t[k : k + 64], log.left_ticks[k : k + 64], log.right_ticks[k : k + 64])
             for k in range(0, 600, 64)]  # fmt: skip
    got = np.concatenate([p.covariance for p in parts if p.covariance is not None])
    np.testing.assert_allclose(got, _reference(log), rtol=1e-9, atol=1e-15)


def test_errors_are_one_sentence(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    src = write_encoder_csv(tmp_path / "log.csv", _log(n=50))
    out = tmp_path / "traj.csv"
    bare = save_params(tmp_path / "bare.toml", replace(PARAMS, noise=None))
    assert main(["odometry", str(src), "-p", str(bare), "--covariance", "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert "bare.toml have no [noise] table" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    good = save_params(tmp_path / "p.toml", PARAMS)
    args = ["odometry", str(src), "-p", str(good), "--covariance", "--format", "tum"]
    assert main([*args, "-o", str(tmp_path / "t.tum")]) == 1
    assert "TUM has no covariance columns" in capsys.readouterr().err
    assert not out.exists() and not (tmp_path / "t.tum").exists()
    with pytest.raises(Exception, match=r"no \[noise\] table"):
        ChunkedOdometry(replace(PARAMS, noise=None), covariance=True)


def test_many_logs_carry_the_covariance(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    for k in range(3):
        write_encoder_csv(logs / f"r{k}.csv", _log(n=200, seed=k))
    params_file = save_params(tmp_path / "p.toml", PARAMS)
    out = tmp_path / "out"
    res = CliRunner().invoke(
        app,
        ["odometry", str(logs), "-p", str(params_file), "--covariance", "-o", str(out),
         "--workers", "1"],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    for k in range(3):
        cols = read_columns(out / f"r{k}.csv", COV_COLUMNS)
        got = np.column_stack([cols[c] for c in COV_COLUMNS])
        np.testing.assert_allclose(got, _reference(_log(n=200, seed=k)), rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("chunk_rows", ["0", "37"])
def test_mcap_covariance_equals_the_csv_output(tmp_path: Path, chunk_rows: str) -> None:
    log = _log(n=240, seed=3)
    folder = tmp_path / "run"
    write_encoder_csv(folder / "encoders.csv", log)
    doc = {"params": replace(PARAMS, noise=None).to_dict(), "trial_id": "r1"}
    (folder / "run.json").write_text(json.dumps(doc))
    params_file = save_params(tmp_path / "p.toml", PARAMS)
    mcap = tmp_path / "run.mcap"
    res = CliRunner().invoke(
        app, ["export", "mcap", str(folder), "-p", str(params_file), "-o", str(mcap)]
    )
    assert res.exit_code == 0, res.output
    cols = _odometry(tmp_path, folder / "encoders.csv", tmp_path / "cov.csv",
                     "--chunk-rows", chunk_rows)  # fmt: skip
    want = np.column_stack([cols[c] for c in COV_COLUMNS])
    with mcap.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        odom = [m for _s, ch, _m, m in reader.iter_decoded_messages() if ch.topic == "/odom"]
    assert len(odom) == len(want) == 240
    # the 6x6 ROS covariance (x, y, z, roll, pitch, yaw): rows/columns 0, 1 and 5
    got = np.array([[m.pose.covariance[i] for i in (0, 1, 5, 7, 11, 35)] for m in odom])
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)
    assert got[-1, 0] > 0

"""MCAP written by odolab, read back by mcap-ros2-support's decoder and by rosbags."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore
from typer.testing import CliRunner

from odolab.cli import app
from odolab.io import read_trajectory, write_encoder_csv, write_trajectory_csv
from odolab.odometry import integrate
from odolab.params import PRESETS, NoiseParams, save_params
from odolab.trials import EncoderLog
from odolab.uncertainty import covariance_from_ticks

PARAMS = PRESETS["jaguar-lite"].with_(noise=NoiseParams(1e-4, 2e-4, k_scrub=0.01))


def _run_folder(tmp_path: Path) -> Path:
    rng = np.random.default_rng(3)
    n = 240
    t = np.arange(n) * 0.05
    left = np.cumsum(rng.integers(-5, 50, n)) % 32768
    right = np.cumsum(rng.integers(-5, 60, n)) % 32768
    folder = tmp_path / "run"
    write_encoder_csv(folder / "encoders.csv", EncoderLog(t, left, right, 32768))
    write_trajectory_csv(folder / "predicted.csv", integrate(t, left, right, PARAMS))
    doc = {"params": PARAMS.with_(noise=None).to_dict(), "trial_id": "r1"}
    (folder / "run.json").write_text(json.dumps(doc))
    return folder


def _decoded(path: Path) -> dict[str, list[object]]:
    out: dict[str, list[object]] = {}
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for _schema, channel, _msg, decoded in reader.iter_decoded_messages():
            out.setdefault(channel.topic, []).append(decoded)
    return out


def test_run_folder_round_trip(tmp_path: Path) -> None:
    folder = _run_folder(tmp_path)
    params_file = save_params(tmp_path / "p.toml", PARAMS)
    out = tmp_path / "run.mcap"
    res = CliRunner().invoke(
        app, ["export", "mcap", str(folder), "-p", str(params_file), "-o", str(out)]
    )
    assert res.exit_code == 0, res.output
    predicted = read_trajectory(folder / "predicted.csv")
    msgs = _decoded(out)
    n = len(predicted)
    assert {k: len(v) for k, v in msgs.items()} == {"/odom": n, "/tf": n, "/joint_states": n}
    enc = np.loadtxt(folder / "encoders.csv", delimiter=",", skiprows=1)
    cov = covariance_from_ticks(enc[:, 1].astype(int), enc[:, 2].astype(int), PARAMS)
    for i, m in enumerate(msgs["/odom"]):
        pos = m.pose.pose.position  # type: ignore[attr-defined]
        q = m.pose.pose.orientation  # type: ignore[attr-defined]
        assert (pos.x, pos.y) == pytest.approx((predicted.x[i], predicted.y[i]), abs=1e-9)
        yaw = math.atan2(2 * q.w * q.z, q.w * q.w - q.z * q.z)
        assert yaw == pytest.approx(predicted.theta[i], abs=1e-9)
        c = m.pose.covariance  # type: ignore[attr-defined]
        got = [c[0], c[1], c[5], c[7], c[11], c[35]]
        np.testing.assert_allclose(got, cov[i], rtol=1e-12, atol=0)
        stamp = m.header.stamp  # type: ignore[attr-defined]
        assert stamp.sec + stamp.nanosec * 1e-9 == pytest.approx(predicted.t[i], abs=1e-9)
    js = msgs["/joint_states"][-1]
    ul = np.unwrap(enc[:, 1], period=32768)
    assert js.position[0] == pytest.approx((ul[-1] - ul[0]) * 2 * math.pi / 380, rel=1e-12)  # type: ignore[attr-defined]

    # rosbags reads it too (its own deserializer), with the same counts and poses
    with AnyReader([out], default_typestore=get_typestore(Stores.LATEST)) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        assert counts == {"/odom": n, "/tf": n, "/joint_states": n}
        odom = [c for c in reader.connections if c.topic == "/odom"]
        xs = [
            reader.deserialize(raw, c.msgtype).pose.pose.position.x
            for c, _, raw in reader.messages(odom)
        ]
    np.testing.assert_allclose(xs, predicted.x, atol=1e-9)


def test_evaluation_with_ground_truth(tmp_path: Path, optiodom_dir: Path) -> None:
    run = sorted((optiodom_dir / "square").rglob("*_run-01.csv"))[0]
    out = tmp_path / "eval.mcap"
    res = CliRunner().invoke(
        app, ["export", "mcap", str(run), "--format", "optiodom", "-o", str(out)]
    )
    assert res.exit_code == 0, res.output
    msgs = _decoded(out)
    assert len(msgs["/ground_truth"]) == len(msgs["/odom"]) > 100
    assert "/tf" in msgs and "/joint_states" in msgs


def test_bad_sources_are_one_sentence(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from odolab.cli import main

    assert main(["export", "mcap", str(tmp_path), "-o", str(tmp_path / "x.mcap")]) == 1
    assert "export mcap takes a robot run folder" in capsys.readouterr().err
    assert main(["export", "mcap", "--campaign", "c", "-o", str(tmp_path / "x.mcap")]) == 1
    assert "needs --db and --campaign" in capsys.readouterr().err
    assert not (tmp_path / "x.mcap").exists()


def test_notebook_campaign(tmp_path: Path) -> None:
    db = tmp_path / "lab.db"
    runner = CliRunner()
    res = runner.invoke(
        app, ["sim", "run", "translation", "--db", str(db), "-o", str(tmp_path / "t.csv")]
    )
    assert res.exit_code == 0, res.output
    out = tmp_path / "c.mcap"
    res = runner.invoke(
        app, ["export", "mcap", "--db", str(db), "--campaign", "translation-indoor", "-o", str(out)]
    )
    assert res.exit_code == 0, res.output
    from odolab.store import Notebook

    with Notebook(db) as nb:
        trials = nb.load_trials(campaign="translation-indoor")
    rows = sum(len(tr.encoder_log) for tr in trials if tr.encoder_log is not None)
    msgs = _decoded(out)
    assert len(msgs["/odom"]) == rows
    stamps = [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in msgs["/odom"]]  # type: ignore[attr-defined]
    assert np.all(np.diff(stamps) >= 0)  # trials one after the other
    # each trial starts at the origin, ends where its prediction says
    last = msgs["/odom"][len(trials[0].encoder_log) - 1]  # type: ignore[arg-type]
    assert last.pose.pose.position.x == pytest.approx(trials[0].predicted.x, abs=1e-9)  # type: ignore[attr-defined]


def test_a_real_robot_run_folder(tmp_path: Path) -> None:
    """`odolab robot drive` on the virtual Jaguar, then `odolab export mcap` of its folder."""
    from odolab.cli import main

    folder = tmp_path / "run"
    assert main(["robot", "drive", "--distance", "0.5", "--quiet", "--out", str(folder),
                 "--no-realtime"]) == 0  # fmt: skip
    params_file = save_params(tmp_path / "p.toml", PARAMS)
    out = tmp_path / "robot.mcap"
    assert main(["export", "mcap", str(folder), "-p", str(params_file), "-o", str(out)]) == 0
    predicted = read_trajectory(folder / "predicted.csv")
    odom = _decoded(out)["/odom"]
    assert len(odom) == len(predicted)
    xs = [m.pose.pose.position.x for m in odom]  # type: ignore[attr-defined]
    np.testing.assert_allclose(xs, predicted.x, atol=1e-9)
    assert odom[-1].pose.covariance[0] > 0  # type: ignore[attr-defined]

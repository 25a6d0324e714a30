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
from odolab.core.odometry import integrate
from odolab.core.params import PRESETS, NoiseParams, save_params
from odolab.core.trials import EncoderLog
from odolab.core.uncertainty import covariance_from_ticks
from odolab.io import read_trajectory, write_encoder_csv, write_trajectory_csv

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
    # a campaign name that is not there is named with the ones that are
    from odolab.core.errors import OdolabError

    with pytest.raises(OdolabError, match="its campaigns: translation-indoor") as err:
        runner.invoke(
            app,
            ["export", "mcap", "--db", str(db), "--campaign", "translation", "-o", str(out)],
            catch_exceptions=False,
        )
    assert "no campaign 'translation' in" in str(err.value)


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


@pytest.mark.parametrize(
    ("start", "message"),
    [
        (
            "1e12",
            "--start-time is 1000000000000.0; expected a number of seconds from 0 to 2147483647",
        ),
        ("1e300", "--start-time is 1e+300; expected"),
        ("-1", "--start-time is -1.0; expected"),
        (
            "2147483640",
            "the odometry's times with the start time run from 2147483640.0 to 2147483651",
        ),
    ],
)
def test_stamps_a_ros_2_time_cannot_hold_are_one_sentence(
    tmp_path: Path, start: str, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # 1e12 was a struct.error traceback that left a 70-byte file; 1e300 an OverflowError
    from odolab.cli import main

    folder = _run_folder(tmp_path)
    out = tmp_path / "out" / "run.mcap"
    code = main(["export", "mcap", str(folder), "-o", str(out), "--start-time", start])
    err = capsys.readouterr().err
    assert code == 1
    assert message in err and err.count("\n") == 1, err
    assert not out.exists()


def test_a_failure_while_writing_leaves_no_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from mcap.writer import Writer

    from odolab.core.errors import OdolabError
    from odolab.export.mcap import stream_from_run_folder, write_mcap

    stream = stream_from_run_folder(_run_folder(tmp_path), PARAMS)
    out = tmp_path / "run.mcap"
    out.write_bytes(b"an older file")
    calls = 0
    original = Writer.add_message

    def failing(self: Writer, *args: object, **kwargs: object) -> None:
        nonlocal calls
        calls += 1
        if calls > 100:
            raise OSError(28, "No space left on device")
        original(self, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(Writer, "add_message", failing)
    with pytest.raises(OdolabError, match=r"cannot write the MCAP file \(No space left on device"):
        write_mcap(out, stream)
    assert out.read_bytes() == b"an older file"  # untouched: the new file was never half there
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run", "run.mcap"]  # no .part left


@pytest.mark.parametrize(
    ("run_json", "message"),
    [
        ("{bad", "run.json: line 1, column 2: not valid JSON"),
        ("{}", "run.json: no 'params' object (the robot's parameters); give --params"),
        ("[1]", "run.json: no 'params' object"),
        ('{"params": {"name": "x"}}', "run.json: missing key 'left_wheel_radius'"),
    ],
)
def test_a_bad_run_json_is_one_sentence(
    tmp_path: Path, run_json: str, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # each of these was a traceback (JSONDecodeError, KeyError, TypeError)
    from odolab.cli import main

    folder = _run_folder(tmp_path)
    (folder / "run.json").write_text(run_json)
    out = tmp_path / "r.mcap"
    assert main(["export", "mcap", str(folder), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1, err
    assert not out.exists()


def test_a_missing_notebook_is_refused_not_created(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from odolab.cli import main

    db = tmp_path / "nothere.db"
    out = tmp_path / "c.mcap"
    assert main(["export", "mcap", "--db", str(db), "--campaign", "c", "-o", str(out)]) == 1
    assert "nothere.db: no such notebook" in capsys.readouterr().err
    assert not db.exists() and not out.exists()


def test_the_twist_is_the_chord_over_the_cycle(tmp_path: Path) -> None:
    # the forward speed was the displacement along the heading at the cycle's start, short by
    # cos(dtheta / 2) in every turn; the pose step moves along the middle heading
    from odolab.export.mcap import stream_from_run_folder, write_mcap

    out = tmp_path / "run.mcap"
    write_mcap(out, stream_from_run_folder(_run_folder(tmp_path), PARAMS))
    predicted = read_trajectory(tmp_path / "run" / "predicted.csv")
    odom = _decoded(out)["/odom"]
    dt = np.diff(predicted.t)
    chord = np.hypot(np.diff(predicted.x), np.diff(predicted.y)) / dt
    vx = np.array([m.twist.twist.linear.x for m in odom[1:]])  # type: ignore[attr-defined]
    vy = np.array([m.twist.twist.linear.y for m in odom[1:]])  # type: ignore[attr-defined]
    wz = np.array([m.twist.twist.angular.z for m in odom[1:]])  # type: ignore[attr-defined]
    turning = np.abs(np.diff(predicted.heading)) > 0.05
    assert turning.sum() > 10  # the test path turns
    np.testing.assert_allclose(np.abs(vx), chord, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(vy, 0.0, atol=1e-9)  # a differential drive does not slide
    np.testing.assert_allclose(wz, np.diff(predicted.heading) / dt, rtol=1e-12)


def test_odolabs_own_bag_reader_reads_the_mcap_back(tmp_path: Path, optiodom_dir: Path) -> None:
    # "MCAP bags are read as input wherever bags are": the run comes back as it went in
    from odolab.export.mcap import stream_from_run, write_mcap
    from odolab.io.registry import read_run
    from odolab.io.run import ReadOptions

    src = sorted((optiodom_dir / "square").rglob("*_run-01.csv"))[0]
    run = read_run(src, "optiodom")
    assert run.params is not None and run.ground_truth is not None
    out = tmp_path / "run.mcap"
    write_mcap(out, stream_from_run(run), start_time=1_687_000_000.0)
    back = read_run(out, "bag", ReadOptions(ticks_per_rev=run.params.ticks_per_rev))
    np.testing.assert_allclose(back.t, run.t + 1_687_000_000.0, rtol=0, atol=1e-6)
    np.testing.assert_allclose(
        np.cumsum(back.dticks_left[1:]), np.cumsum(run.dticks_left[1:]), atol=1e-6
    )
    np.testing.assert_allclose(
        np.cumsum(back.dticks_right[1:]), np.cumsum(run.dticks_right[1:]), atol=1e-6
    )
    gt = back.ground_truth
    assert gt is not None
    np.testing.assert_allclose(gt.x, run.ground_truth.x, atol=1e-12)
    np.testing.assert_allclose(gt.y, run.ground_truth.y, atol=1e-12)
    np.testing.assert_allclose(gt.theta, run.ground_truth.theta, atol=1e-12)


# --- the twist and its covariance on every path (issue 26.3) ----------------------------------


def _twist_terms(m: object) -> tuple[float, float, float, float, float, float]:
    c = m.twist.covariance  # type: ignore[attr-defined]
    return c[0], c[35], c[5], c[30], c[7], c[1]  # var vx, var wz, vx-wz both ways, var vy, vx-vy


def test_a_csv_run_carries_the_full_twist_covariance(tmp_path: Path) -> None:
    """--format csv: positive vx and wz variances and their cross term on every moving message,
    equal to U / dt**2 of the documented model; the floor on idle ones; mode 0644 (umask)."""
    import os
    import stat

    from odolab.export.mcap import TWIST_VARIANCE_FLOOR

    rng = np.random.default_rng(5)
    n = 200
    t = np.arange(n) * 0.02
    dl = np.where(np.arange(n) < 150, rng.integers(20, 40, n), 0)  # the last 50 cycles idle
    dr = np.where(np.arange(n) < 150, rng.integers(30, 60, n), 0)
    dl[0] = dr[0] = 0
    log = tmp_path / "log.csv"
    rows = "\n".join(f"{a:.2f},{b},{c}" for a, b, c in zip(t, dl, dr, strict=True))
    log.write_text("t,dticks_left,dticks_right\n" + rows + "\n")
    p = save_params(tmp_path / "p.toml", PARAMS)
    out = tmp_path / "run.mcap"
    res = CliRunner().invoke(
        app, ["export", "mcap", str(log), "--format", "csv", "-p", str(p), "-o", str(out)]
    )
    assert res.exit_code == 0, res.output
    odom = _decoded(out)["/odom"]
    assert len(odom) == n
    k, b = PARAMS.noise, PARAMS.track_width
    assert k is not None
    for i in range(1, 150):
        vx_var, wz_var, cross, cross_t, vy_var, _ = _twist_terms(odom[i])
        sl, sr = dl[i] * PARAMS.left_metres_per_tick, dr[i] * PARAMS.right_metres_per_tick
        ql, qr = k.k_left * abs(sl), k.k_right * abs(sr)
        qs = k.k_scrub * abs(sr - sl) / b
        dt2 = 0.02**2
        assert vx_var == pytest.approx((ql + qr) / 4 / dt2, rel=1e-9)
        assert wz_var == pytest.approx((ql + qr) / b**2 / dt2 + qs / dt2, rel=1e-9)
        assert cross == cross_t == pytest.approx((qr - ql) / (2 * b) / dt2, rel=1e-9)
        assert vx_var > 0 and wz_var > 0 and cross != 0
        assert vy_var == TWIST_VARIANCE_FLOOR  # a differential drive: no sideways noise
    for m in odom[150:]:  # idle: the stated floor, never 0
        vx_var, wz_var, cross, _, _, _ = _twist_terms(m)
        assert vx_var == wz_var == TWIST_VARIANCE_FLOOR and cross == 0
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(out.stat().st_mode) == 0o666 & ~umask


def test_a_campaign_has_no_velocity_spike_at_its_trial_boundaries(tmp_path: Path) -> None:
    from odolab.store import Notebook

    db = tmp_path / "lab.db"
    runner = CliRunner()
    res = runner.invoke(
        app, ["sim", "run", "translation", "--db", str(db), "-o", str(tmp_path / "t.csv")]
    )
    assert res.exit_code == 0, res.output
    p = save_params(tmp_path / "p.toml", PARAMS)
    out = tmp_path / "c.mcap"
    args = ["export", "mcap", "--db", str(db), "--campaign", "translation-indoor"]
    res = runner.invoke(app, [*args, "-p", str(p), "-o", str(out)])
    assert res.exit_code == 0, res.output
    with Notebook(db) as nb:
        trials = nb.load_trials(campaign="translation-indoor")
    sizes = [len(tr.encoder_log) for tr in trials if tr.encoder_log is not None]
    starts = np.cumsum([0, *sizes[:-1]])
    msgs = _decoded(out)
    vx = np.array([m.twist.twist.linear.x for m in msgs["/odom"]])  # type: ignore[attr-defined]
    wz = np.array([m.twist.twist.angular.z for m in msgs["/odom"]])  # type: ignore[attr-defined]
    speeds = np.array([m.velocity for m in msgs["/joint_states"]])  # type: ignore[attr-defined]
    assert len(starts) > 1
    for i in starts:
        assert vx[i] == wz[i] == 0.0 and np.all(speeds[i] == 0.0)
        assert _twist_terms(msgs["/odom"][i])[0] > 0  # the floor, not zero
    # the fastest forward speed anywhere is a plausible one (the old boundary said -1.08 m/s,
    # the wheels -214 rad/s)
    assert np.max(np.abs(vx)) < 0.5 and np.max(np.abs(speeds)) < 10.0


def test_the_export_says_where_first_order_stops_holding(tmp_path: Path) -> None:
    n = 401  # a straight 7 m in 20 s at a noise that takes it past first order's range
    t = np.arange(n) * 0.05
    per_cycle = 20  # counts a cycle: 20 x 1.38 mm
    log = tmp_path / "log.csv"
    rows = "\n".join(f"{a:.2f},{0 if i == 0 else per_cycle},{0 if i == 0 else per_cycle}"
                     for i, a in enumerate(t))  # fmt: skip
    log.write_text("t,dticks_left,dticks_right\n" + rows + "\n")
    noisy = save_params(tmp_path / "n.toml", PARAMS.with_(noise=NoiseParams(3e-4, 3e-4)))
    quiet = save_params(tmp_path / "q.toml", PARAMS.with_(noise=NoiseParams(1e-6, 1e-6)))
    for p, said in ((noisy, True), (quiet, False)):
        res = CliRunner().invoke(
            app,
            ["export", "mcap", str(log), "--format", "csv", "-p", str(p), "-o",
             str(tmp_path / "r.mcap")],
        )  # fmt: skip
        assert res.exit_code == 0, res.output
        out = " ".join(res.output.split())
        assert ("understates the spread from t = " in out) is said, out


def test_a_slip_file_gives_odom_the_slip_models_covariance(tmp_path: Path) -> None:
    """With a slip model's parameters the /odom pose covariance is the model's predictive one
    (odolab.core.slip_uncertainty, as `odometry --covariance` and `evaluate --nees` use it) and the
    twist's is each cycle's body-motion variance over dt**2; the output says which; without
    a [noise] table or a slip model it says there is none."""
    from odolab.core.models import SlipModel
    from odolab.core.slip_uncertainty import propagate_covariance

    rng = np.random.default_rng(8)
    n = 160
    t = np.arange(n) * 0.05
    dl = rng.integers(10, 40, n)
    dr = rng.integers(20, 60, n)
    dl[0] = dr[0] = 0
    log = tmp_path / "log.csv"
    rows = "\n".join(f"{a:.2f},{b},{c}" for a, b, c in zip(t, dl, dr, strict=True))
    log.write_text("t,dticks_left,dticks_right\n" + rows + "\n")
    model = SlipModel(yaw_w=-0.1, fwd_v_absv=-0.05, q_fwd=1e-4, q_yaw=1e-3, k_yaw=0.02, d_yaw=1e-3)
    params = PARAMS.with_(model=model, noise=None)
    p = save_params(tmp_path / "slip.toml", params)
    out = tmp_path / "run.mcap"
    res = CliRunner().invoke(
        app, ["export", "mcap", str(log), "--format", "csv", "-p", str(p), "-o", str(out)]
    )
    assert res.exit_code == 0, res.output
    assert "the slip model's predictive variance" in res.output
    odom = _decoded(out)["/odom"]
    _, cov = propagate_covariance(t, dl, dr, params)
    for i in (40, 100, n - 1):
        c = odom[i].pose.covariance  # type: ignore[attr-defined]
        assert c[0] == pytest.approx(cov[i, 0, 0], rel=1e-9)
        assert c[1] == pytest.approx(cov[i, 0, 1], rel=1e-9)
        assert c[35] == pytest.approx(cov[i, 2, 2], rel=1e-9)
        vx_var, wz_var, *_ = _twist_terms(odom[i])
        assert vx_var > 0 and wz_var > 0
    plain = save_params(tmp_path / "plain.toml", PARAMS.with_(noise=None))
    res = CliRunner().invoke(
        app, ["export", "mcap", str(log), "--format", "csv", "-p", str(plain), "-o", str(out)]
    )
    assert res.exit_code == 0, res.output
    assert "has no covariance" in res.output

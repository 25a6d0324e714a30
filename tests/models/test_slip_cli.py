"""`odolab sim explore` and `calibrate compare --models ...,slip --learning-curve` (issue 29)."""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path

import pytest

from odolab.cli import main


def test_explore_then_compare_with_a_learning_curve(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # piped output with no COLUMNS: the table whole, as wide as it needs (a COLUMNS narrower
    # than the table gives plain blocks instead; it reached this test once in a full run)
    monkeypatch.delenv("COLUMNS", raising=False)
    run = tmp_path / "run"
    assert main(["sim", "explore", "-o", str(run), "--seconds", "30", "--seed", "1"]) == 0
    assert "explored 30.0 s (jaguar-lab-tracked, seed 1)" in capsys.readouterr().out
    assert (run / "explore.csv").read_text().startswith("t,dticks_left,dticks_right\n")
    assert (run / "explore_gt.csv").is_file()
    assert main(["sim", "explore", "-o", str(run), "--seconds", "20", "--seed", "2",
                 "--name", "held", "--max-speed", "0.5"]) == 0  # fmt: skip
    out = tmp_path / "cmp.json"
    code = main([
        "calibrate", "compare", str(run / "explore.csv"), "--validate", str(run / "held.csv"),
        "--format", "csv", "--params", "jaguar-lite", "--models", "diff,slip",
        "--learning-curve", "10,30", "--json", str(out),
    ])  # fmt: skip
    assert code == 0
    doc = json.loads(out.read_text())
    assert [m["model"] for m in doc["models"]] == ["diff", "slip"]
    curve = doc["learning_curve"]
    assert [(r["seconds"], r["model"]) for r in curve] == [
        (10.0, "diff"), (10.0, "slip"), (30.0, "diff"), (30.0, "slip"),
    ]  # fmt: skip
    assert all(r["endpoint_error"] >= 0 for r in curve)
    text = capsys.readouterr().out
    assert "learning curve" in text
    # piped output is never cut (issue 38, item 13: 80 columns, 12 cut cells): whole cells
    assert "…" not in text
    assert re.search(r"│ +diff │ +3 │ [0-9.]+ \[[0-9.]+, [0-9.]+\] │", text), text


def test_bad_learning_curve_is_one_sentence(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["calibrate", "compare", str(tmp_path), "--learning-curve", "10,soon"])
    assert code == 1
    assert "--learning-curve: 'soon' is not a positive number of seconds" in capsys.readouterr().err


def _explore_and_fit(tmp_path: Path, seed: int, seconds: int = 30) -> tuple[Path, Path]:
    """`odolab sim explore` then `calibrate lsq --model slip` on it: (run folder, slip file)."""
    run = tmp_path / "run"
    assert main(["sim", "explore", "-o", str(run), "--seconds", str(seconds), "--seed",
                 str(seed)]) == 0  # fmt: skip
    params = tmp_path / "slip.toml"
    code = main(["calibrate", "lsq", str(run / "explore.csv"), "--format", "csv", "--params",
                 "jaguar-lite", "--model", "slip", "-o", str(params)])  # fmt: skip
    assert code == 0
    return run, params


def test_calibrate_lsq_model_slip_writes_a_loadable_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from odolab.core.models import SlipModel
    from odolab.core.params import load_params

    _, out = _explore_and_fit(tmp_path, 3)
    params = load_params(out)
    assert isinstance(params.model, SlipModel) and params.model.k_yaw > 0
    assert "Bayesian linear regression" in out.read_text()


def test_odometry_covariance_with_a_slip_model_is_its_predictive_variance(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # issue 29: the slip model's predictive variance feeds the covariance of `odolab odometry`
    import numpy as np

    from odolab.calibration.slipfit import propagate_covariance
    from odolab.core.params import load_params
    from odolab.io.tabular import read_columns

    run, params = _explore_and_fit(tmp_path, 4)
    inc = read_columns(run / "explore.csv", ("t", "dticks_left", "dticks_right"))
    counts = tmp_path / "counts.csv"
    left, right = np.cumsum(inc["dticks_left"]), np.cumsum(inc["dticks_right"])
    counts.write_text(
        "t,left_ticks,right_ticks\n"
        + "".join(
            f"{float(t)!r},{int(a) % 32768},{int(b) % 32768}\n"
            for t, a, b in zip(inc["t"], left, right, strict=True)
        )
    )
    capsys.readouterr()
    out = tmp_path / "odometry.csv"
    code = main(["odometry", str(counts), "--params", str(params), "--covariance", "-o", str(out)])
    assert code == 0, capsys.readouterr().err
    said = capsys.readouterr()
    assert "the slip model's predictive variance" in said.out + said.err
    table = read_columns(out, ("t", "x", "cov_xx", "cov_xy", "cov_hh"))
    p = load_params(str(params))
    _, cov = propagate_covariance(
        inc["t"], np.diff(left, prepend=left[0]), np.diff(right, prepend=right[0]), p
    )
    assert np.allclose(table["cov_hh"], cov[:, 2, 2], rtol=1e-9, atol=1e-15)
    assert np.allclose(table["cov_xy"], cov[:, 0, 1], rtol=1e-9, atol=1e-15)
    assert table["cov_hh"][0] == 0.0 and table["cov_hh"][-1] > 0.0
    # the file carries the coefficients' posterior: one error for the whole run, whose share
    # may shrink as turns of both signs cancel; the cycles' noise alone only adds up
    from dataclasses import replace

    model = p.model
    assert getattr(model, "posterior", ())
    _, noise = propagate_covariance(
        inc["t"], np.diff(left, prepend=left[0]), np.diff(right, prepend=right[0]),
        p.with_(model=replace(model, posterior=())),
    )  # fmt: skip
    assert np.all(np.diff(noise[:, 2, 2]) >= -1e-15)
    assert np.all(table["cov_hh"] >= noise[:, 2, 2] - 1e-12)


def test_evaluate_nees_uses_the_slip_models_predictive_variance(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`evaluate --nees` with a slip file judges the model's own predictive variance (it was
    refused for want of a [noise] table), with the numbers of slipfit.nees_pieces."""
    import numpy as np

    from odolab.calibration.slipfit import nees_pieces
    from odolab.core.params import load_params
    from odolab.io.registry import read_run

    run, params = _explore_and_fit(tmp_path, 5, seconds=40)
    assert main(["sim", "explore", "-o", str(run), "--seconds", "30", "--seed", "6",
                 "--name", "held"]) == 0  # fmt: skip
    capsys.readouterr()
    out = tmp_path / "nees.json"
    code = main(["evaluate", str(run / "held.csv"), "--format", "csv", "--params", str(params),
                 "--nees", "--nees-segment", "3", "--json", str(out)])  # fmt: skip
    said = capsys.readouterr()
    assert code == 0, said.err
    assert "the slip model's predictive variance" in said.out
    summary = json.loads(out.read_text())["nees"]["summary"]
    expected = nees_pieces([read_run(run / "held.csv", "csv")], load_params(str(params)), 3.0)
    assert summary["n"] == expected.size
    assert summary["mean_nees"] == pytest.approx(float(np.mean(expected)), rel=1e-9)
    assert summary["pieces_past_first_order"] == 0  # its covariance has the second-order share
    # a file with neither a [noise] table nor a slip model: one sentence, nothing computed
    plain = tmp_path / "plain.toml"
    plain.write_text(params.read_text().split("[model]")[0])
    code = main(["evaluate", str(run / "held.csv"), "--format", "csv", "--params", str(plain),
                 "--nees"])  # fmt: skip
    err = capsys.readouterr().err
    assert code != 0 and "no [noise] table" in err and "slip model" in err


def test_a_failed_exploration_keeps_the_earlier_pair(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The log was renamed into place before the truth failed: a new log beside an old truth."""
    run = tmp_path / "run"
    assert main(["sim", "explore", "-o", str(run), "--seconds", "3", "--seed", "1"]) == 0
    before = (run / "explore.csv").read_bytes()
    (run / "explore_gt.csv").unlink()
    (run / "explore_gt.csv").mkdir()  # in the way
    capsys.readouterr()
    assert main(["sim", "explore", "-o", str(run), "--seconds", "4", "--seed", "2"]) == 1
    err = capsys.readouterr().err
    assert "explore_gt.csv: is a folder; expected a file name for the exploration's ground" in err
    assert (run / "explore.csv").read_bytes() == before
    assert sorted(p.name for p in run.iterdir()) == ["explore.csv", "explore_gt.csv"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--max-speed", "1e9"], "--max-speed is 1e+09; expected a number in (0, 3] m/s"),
        (["--max-turn-rate", "9"], "--max-turn-rate is 9; expected a number in (0, 3.57143]"),
        (["--fence", "1e4"], "--fence is 10000; expected a number in (0, 100] m"),
        (["--seconds", "1e6"], "--seconds is 1e+06; expected a number in (0, 600] s"),
    ],
)
def test_sim_explore_has_the_robots_bounds(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], message: str
) -> None:
    assert main(["sim", "explore", "-o", str(tmp_path / "r"), *args]) == 1
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1, err
    assert not (tmp_path / "r").exists()


def test_sim_explore_says_when_the_robot_left_its_fence(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = tmp_path / "r"
    assert main(["sim", "explore", "-o", str(run), "--seconds", "5", "--fence", "0.01"]) == 0
    out = capsys.readouterr().out
    assert "beyond the 0.01 m fence" in out
    assert main(["sim", "explore", "-o", str(run), "--seconds", "5"]) == 0
    assert "fence" not in capsys.readouterr().out


@pytest.mark.parametrize(
    "command",
    [
        ["calibrate", "lsq", "RUN", "-f", "csv", "--model", "slip"],
        ["calibrate", "noise", "RUN", "-f", "csv"],
        ["calibrate", "ratios", "--distance-ratio", "0.9", "--rotation-ratio", "0.88"],
    ],
)
def test_new_parameters_never_replace_the_params_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], command: list[str]
) -> None:
    """`robot explore` printed `... -p slip.toml --model slip -o slip.toml`: run as printed, it
    replaced the user's calibrated file (found by a hostile-input review)."""
    from odolab.core.params import PRESETS, save_params

    run = tmp_path / "run"
    assert main(["sim", "explore", "-o", str(run), "--seconds", "5", "--seed", "1"]) == 0
    mine = save_params(tmp_path / "mine.toml", PRESETS["jaguar-lite"].with_(name="mine"))
    before = mine.read_bytes()
    capsys.readouterr()
    args = [str(run / "explore.csv") if a == "RUN" else a for a in command]
    assert main([*args, "-p", str(mine), "-o", str(mine)]) == 1
    err = capsys.readouterr().err
    assert "is the --params file this calibration starts from" in err and err.count("\n") == 1
    assert mine.read_bytes() == before


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    """A 20 s exploration, a held-out one and a slip fit of the first."""
    folder = tmp_path_factory.mktemp("two")
    assert main(["sim", "explore", "-o", str(folder), "--seconds", "20", "--seed", "1"]) == 0
    assert main(["sim", "explore", "-o", str(folder), "--seconds", "10", "--seed", "2",
                 "--name", "held"]) == 0  # fmt: skip
    slip = folder / "slip.toml"
    assert main(["calibrate", "lsq", str(folder / "explore.csv"), "-f", "csv", "-p",
                 "jaguar-lite", "--model", "slip", "-o", str(slip)]) == 0  # fmt: skip
    return folder / "explore.csv", folder / "held.csv", slip


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--learning-curve", "10,,20"], "--learning-curve '10,,20' has an empty item"),
        (["--learning-curve", ","], "--learning-curve ',' has an empty item"),
        (["--learning-curve", "10,10"], "--learning-curve: 10 s is given twice"),
        (["--learning-curve", "100"], "--learning-curve: 100 s is longer than the first training"),
        (["--segment", "1e9"], "with segments of 1e+09 s: diff, extended: 3 residuals for 4"),
    ],
)
def test_compare_options_that_meant_nothing_are_refused(
    two_runs: tuple[Path, Path, Path],
    capsys: pytest.CaptureFixture[str],
    args: list[str],
    message: str,
) -> None:
    """Each was accepted: an empty item dropped, a repeated point, a point past the run (the
    whole run under another label), a reason repeated once a model (hostile-input review)."""
    explore, held, _ = two_runs
    capsys.readouterr()
    code = main(["calibrate", "compare", str(explore), "--validate", str(held), "-f", "csv",
                 "-p", "jaguar-lite", "--workers", "1", *args])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 1 and message in err and err.count("\n") == 1, err


def test_a_nees_piece_shorter_than_a_cycle_is_refused(
    two_runs: tuple[Path, Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    _, held, slip = two_runs
    capsys.readouterr()
    code = main(["evaluate", str(held), "-f", "csv", "--params", str(slip), "--nees",
                 "--nees-segment", "1e-9"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 1
    assert "piece length 1e-09 s is shorter than the log's sample spacing (0.05 s)" in err


def test_a_slip_fit_its_exploration_cannot_determine_is_flagged_on_every_face(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 38, item 11: 12 s of exploration fit 24 coefficients; every face says so."""
    run, params = _explore_and_fit(tmp_path, seed=0, seconds=12)
    printed = capsys.readouterr().out
    assert "warning: the slip model is not determined by these runs" in printed
    provenance = tomllib.loads(params.read_text())["provenance"]
    assert provenance["warnings"][0].startswith("the slip model is not determined")
    out = tmp_path / "c.yaml"
    assert main(["export", "ros2-controller", str(params), "--nominal", "jaguar-lite",
                 "-o", str(out)]) == 0  # fmt: skip
    assert f"warning: {params}: the slip model is not determined" in capsys.readouterr().out
    # 30 s of the same exploration determine it (median share 0.04 measured): no warning
    assert main(["sim", "explore", "-o", str(run), "--seconds", "30", "--seed", "0",
                 "--name", "long"]) == 0  # fmt: skip
    doc = tmp_path / "long.json"
    assert main(["calibrate", "lsq", str(run / "long.csv"), "--format", "csv", "--params",
                 "jaguar-lite", "--model", "slip", "--json", str(doc),
                 "-o", str(tmp_path / "long.toml")]) == 0  # fmt: skip
    assert json.loads(doc.read_text())["warnings"] == []

"""`calibrate lsq --truth-sigma` / `--loss` and `calibrate compare --truth-sigma` (issue 37)."""

from __future__ import annotations

from pathlib import Path

import pytest

from odolab.cli import main


@pytest.mark.slow  # two slip fits (cross-fitted predictive variance): 20 to 80 s on 2 busy cores
def test_slip_fit_says_what_it_took_the_truths_noise_to_be(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = tmp_path / "run"
    assert main(["sim", "explore", "-o", str(run), "--seconds", "12", "--seed", "3"]) == 0
    log = str(run / "explore.csv")
    out = str(tmp_path / "slip.toml")
    base = ["calibrate", "lsq", log, "-f", "csv", "-p", "jaguar-lite", "--model", "slip", "-o", out]
    capsys.readouterr()
    assert main([*base, "--truth-sigma", "0.02,0.01"]) == 0
    text = capsys.readouterr().out
    assert "ground truth taken as noisy: 20 mm in position, 0.01 rad in heading, as given" in text
    # without it, estimated from the truth's own updates (the simulator's truth is exact: a
    # millimetre or less, the path's own bend)
    assert main(base) == 0
    text = capsys.readouterr().out
    assert "estimated from" in text and "of its updates' deviations from their neighbours" in text


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ["--truth-sigma", "5cm"],
            "the ground truth's noise is '5cm'; expected two numbers XY,YAW",
        ),
        (["--loss", "squares"], "loss is 'squares'; expected one of linear, huber"),
    ],
)
@pytest.mark.parametrize("command", ["lsq", "compare"])
def test_bad_truth_sigma_or_loss_is_one_sentence(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    command: str,
    args: list[str],
    message: str,
) -> None:
    # refused before any run is read (the folder is empty)
    extra = ["-o", str(tmp_path / "x.toml")] if command == "lsq" else []
    code = main(["calibrate", command, str(tmp_path), "-f", "csv", *extra, *args])
    assert code == 1
    err = capsys.readouterr().err
    assert message in err
    assert "Traceback" not in err

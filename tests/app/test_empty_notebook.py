"""A notebook with no trial yet: every face says so in one sentence (was "the campaign filters
leave no trial; campaigns: " with nothing after it)."""

from __future__ import annotations

from pathlib import Path

import pytest

from odolab.cli import main


@pytest.mark.parametrize(
    "command",
    [["analyze"], ["report", "--out", "rep"], ["calibrate", "ratios", "-o", "new.toml"]],
)
def test_an_empty_notebook_says_it_holds_no_trial(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
    command: list[str],
) -> None:  # fmt: skip
    monkeypatch.chdir(tmp_path)
    assert main(["notebook", "init", "--db", "lab.db"]) == 0
    capsys.readouterr()
    assert main([*command, "--db", "lab.db"]) == 1
    err = capsys.readouterr().err
    assert err == (
        "odolab: error: the notebook holds no trial yet; record some first (odolab sim run, "
        "odolab robot, odolab trials add or import)\n"
    )
    assert not (tmp_path / "rep").exists() and not (tmp_path / "new.toml").exists()

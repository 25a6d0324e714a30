"""Protocol size limits: a typo that would run until memory is gone is one sentence naming the
file and the key, said before the trials are made."""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import pytest

import odolab.sim.export
import odolab.sim.presets
import odolab.sim.protocols  # noqa: F401  (imported now: the memory measured is the command's)
from odolab.cli import main

HEAD = '[protocol]\ncampaign = "c"\n'


def _sim(tmp_path: Path, text: str, capsys: pytest.CaptureFixture[str]) -> str:
    path = tmp_path / "p.toml"
    path.write_text(text)
    capsys.readouterr()
    tracemalloc.start()
    try:
        rc = main(["sim", "run", str(path), "-o", str(tmp_path / "t.csv")])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    err = capsys.readouterr().err
    assert rc == 1 and err.count("\n") == 1, err
    assert peak < 20e6  # bytes: nothing was built (the first of 10^9 repeats alone is more)
    assert not (tmp_path / "t.csv").exists()
    return err.removeprefix(f"odolab: error: {path}: ").rstrip("\n")


@pytest.mark.parametrize(
    ("trials", "message"),
    [
        ('motion = "rotation"\nangle_pi = 20\nrepeats = 1000000000',
         "[[trials]] #1 key 'repeats': 1000000000 repeats; expected at most 10000"),
        ('motion = "rotation"\nangle_pi = { from = 1, to = 1e9, step = 1 }',
         "[[trials]] #1 key 'angle_pi'.to: 1e+09 pi is outside the allowed 0 to 100 pi"),
        ('motion = "rotation"\nangle = [1e9]',
         "[[trials]] #1 key 'angle'[0]: 1e+09 rad is outside the allowed 0 to 314.159 rad"),
        ('motion = "translation"\ndistance = { from = 0.001, to = 999, step = 0.001 }',
         "[[trials]] #1 key 'distance': the range from 0.001 to 999 in steps of 0.001 has "
         "999000 values; expected at most 1000"),
        ('motion = "translation"\ndistance = 1e308',
         "[[trials]] #1 key 'distance': 1e+308 m is outside the allowed 0 to 1000 m"),
        ('motion = "square"\nside = 4\nspeed = 1e-9',
         "[[trials]] #1 key 'speed': 1e-09 m/s is outside the allowed 0.01 to 5 m/s"),
        ('motion = "translation"\ndistance = { from = 1, to = 1000, step = 1 }\nrepeats = 11',
         "[[trials]] #1 key 'repeats': 1000 values x 11 repeats = 11000 trials; expected at "
         "most 10000 in a protocol"),
    ],
)  # fmt: skip
def test_oversized_trial_sets_are_refused_naming_file_and_key(
    tmp_path: Path, trials: str, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert _sim(tmp_path, f"{HEAD}\n[[trials]]\n{trials}\n", capsys) == message


@pytest.mark.parametrize(
    ("head", "message"),
    [
        ("dt = 1e-9", "[protocol] key 'dt': 1e-09 s is outside the allowed 0.0001 to 1 s"),
        ("report_rate = 1e12",
         "[protocol] key 'report_rate': 1e+12 Hz is outside the allowed 0.1 to 1000 Hz"),
        ("linear_speed = 50", "[protocol] key 'linear_speed': 50 m/s is outside the allowed"
         " 0.01 to 5 m/s"),
    ],
)  # fmt: skip
def test_oversized_settings_are_refused(
    tmp_path: Path, head: str, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    text = f'{HEAD}{head}\n\n[[trials]]\nmotion = "square"\nside = 1\n'
    assert _sim(tmp_path, text, capsys) == message


def test_too_long_a_trial_is_refused_before_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 1000 m at 0.01 m/s: 100,000 s (jaguar-lite: 380 counts of 2 pi 0.0835 m)
    text = f'{HEAD}\n[[trials]]\nmotion = "translation"\ndistance = 1000\nspeed = 0.01\n'
    msg = _sim(tmp_path, text, capsys)
    assert msg.startswith("trial 1 (translation 1000 m) would last 100000 s; expected at most")


def test_too_many_reports_in_one_run_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 10 x 1000 trials of 100 m at 0.3 m/s: 333.3 s x 20 Hz = 6668 reports each, 6.7e7 in all
    sets = '\n[[trials]]\nmotion = "translation"\ndistance = 100\nrepeats = 1000\n' * 10
    msg = _sim(tmp_path, HEAD + sets, capsys)
    assert msg.startswith("10000 trials of up to 333 s at 20 Hz are 6.67e+07 encoder reports")

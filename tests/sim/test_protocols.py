"""Protocol files: the built-ins, bad input with one clear error, the CLI and the trials CSV."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from odolab.cli import main
from odolab.core.errors import SimError
from odolab.core.params import PRESETS
from odolab.core.trials import MotionKind
from odolab.sim.presets import TRUTH_PRESETS
from odolab.sim.protocols import builtin_protocols, load_protocol, run_protocol
from odolab.store.csvio import COLUMNS, write_trials_csv

NOM = PRESETS["jaguar-lite"]


def test_builtin_protocols_match_the_lab_report() -> None:
    assert {"rotation", "translation", "outdoor", "umbmark", "lab-report"} <= set(
        builtin_protocols()
    )
    rot = load_protocol("rotation")
    angles = [t.command.angle / math.pi for t in rot.trials]  # type: ignore[operator]
    assert angles[:20] == pytest.approx(list(range(1, 21)))
    assert angles[19:] == pytest.approx([20.0] * 18)  # the ladder's 20 pi and 17 more
    tr = load_protocol("translation")
    dists = sorted(t.command.distance for t in tr.trials)  # type: ignore[type-var]
    assert dists == [-2.5] * 5 + [-1.0] * 5 + [1.0] * 5 + [2.5] * 5
    out = load_protocol("outdoor")
    assert [t.terrain for t in out.trials] == ["concrete"] * 10 + ["grass"] * 10
    assert [t.command.distance for t in out.trials[:10]] == pytest.approx(
        [0.5 * i for i in range(1, 11)]
    )
    umb = load_protocol("umbmark")
    assert [t.command.direction for t in umb.trials] == ["cw"] * 5 + ["ccw"] * 5
    assert all(t.command.kind is MotionKind.SQUARE and t.command.side == 4.0 for t in umb.trials)
    assert len(load_protocol("lab-report")) == 77


def test_umbmark_square_returns_near_start() -> None:
    trials = run_protocol(load_protocol("umbmark"), TRUTH_PRESETS["ideal"], NOM)
    for t in trials:
        # the odometry closes the square up to the count rounding of each 90 degree turn
        assert math.hypot(t.predicted.x, t.predicted.y) < 0.05
        assert abs(t.predicted.heading) == pytest.approx(2 * math.pi, abs=0.02)


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "bad.toml"
    p.write_text('[protocol]\ncampaign = "x"\n' + text, encoding="utf-8")
    return p


@pytest.mark.parametrize(
    ("body", "needle"),
    [
        ('[[trials]]\nmotion = "spin"\nangle = 1.0\n', "key 'motion': got 'spin'"),
        (
            '[[trials]]\nmotion = "translation"\ndistance = -1.0\n',
            "key 'distance': expected a number > 0",
        ),
        ('[[trials]]\nmotion = "translation"\ndistance = 1.0\nterrain = "mud"\n', "key 'terrain'"),
        ('[[trials]]\nmotion = "translation"\ndistance = 1.0\nspeeed = 1\n', "key 'speeed'"),
        ('[[trials]]\nmotion = "rotation"\ndistance = 1.0\n', "key 'distance': does not apply"),
        ('[[trials]]\nmotion = "rotation"\nangle_pi = { from = 1, to = 3 }\n', "key 'angle_pi'"),
        ('[[trials]]\nmotion = "square"\nside = 4\nrepeats = 0\n', "key 'repeats'"),
    ],
)
def test_bad_protocol_one_clear_error(tmp_path: Path, body: str, needle: str) -> None:
    p = _write(tmp_path, body)
    with pytest.raises(SimError) as info:
        load_protocol(p)
    msg = str(info.value)
    assert str(p) in msg and needle in msg and "\n" not in msg


def test_bad_protocol_file_and_name(tmp_path: Path) -> None:
    p = tmp_path / "broken.toml"
    p.write_text("[protocol\n", encoding="utf-8")
    with pytest.raises(SimError, match="not valid TOML"):
        load_protocol(p)
    with pytest.raises(SimError, match="no such protocol file or built-in protocol"):
        load_protocol("nope")
    with pytest.raises(SimError, match="does not divide"):
        load_protocol(_write(tmp_path, "dt = 0.03\n[[trials]]\nmotion = 'square'\nside = 1\n"))


def test_cli_sim_run_writes_csv(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "trials.csv"
    enc = tmp_path / "enc"
    code = main(
        ["sim", "run", "translation", "--seed", "7", "-o", str(out), "--encoder-dir", str(enc)]
    )
    assert code == 0
    with out.open() as fh:
        rows = list(csv.DictReader(fh))
    assert tuple(rows[0])[: len(COLUMNS)] == tuple(COLUMNS)
    assert len(rows) == 20 and rows[0]["trial_id"] == "translation-indoor-000"
    trials = run_protocol(load_protocol("translation"), TRUTH_PRESETS["jaguar-lab"], NOM, seed=7)
    assert float(rows[3]["measured_y_m"]) == trials[3].measured.y  # type: ignore[union-attr]
    assert float(rows[3]["true_x_m"]) == trials[3].true.x  # type: ignore[union-attr]
    # the same layout as the notebook's: it imports
    from odolab.store import Notebook

    with Notebook(tmp_path / "nb.db") as nb:
        nb.import_csv(out, create_campaigns=True)
        back = nb.get_trial("translation-indoor-003")
    assert back.measured.y == trials[3].measured.y  # type: ignore[union-attr]
    assert len(list(enc.glob("*.csv"))) == 20
    assert "20 trials" in capsys.readouterr().out


def test_cli_errors_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "run", "rotation", "--terrain", "mud", "-o", str(tmp_path / "x.csv")]) == 1
    err = capsys.readouterr().err
    assert "unknown terrain 'mud'" in err and err.count("\n") == 1
    bad = _write(tmp_path, '[[trials]]\nmotion = "spin"\n')
    assert main(["sim", "run", str(bad)]) == 1
    err = capsys.readouterr().err
    assert str(bad) in err and "'motion'" in err


def test_write_trials_csv_rotation_columns(tmp_path: Path) -> None:
    trials = run_protocol(load_protocol("rotation"), TRUTH_PRESETS["jaguar-lab"], NOM, seed=1)
    path = write_trials_csv(tmp_path / "r.csv", [(t, None) for t in trials])
    with path.open() as fh:
        rows = list(csv.DictReader(fh))
    raw = trials[-1].measured.raw  # type: ignore[union-attr]
    assert float(rows[-1]["compass_initial_deg"]) == raw["compass_initial_deg"]
    assert int(rows[-1]["turns"]) == raw["turns"]
    assert rows[-1]["measured_x_m"] == ""


def test_cli_default_seed_is_the_documented_one() -> None:
    from odolab.cli import sim as cli_sim
    from odolab.sim.presets import LAB_REPORT_SEED

    assert cli_sim._LAB_REPORT_SEED == LAB_REPORT_SEED


def test_encoder_dir_that_is_a_file_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from odolab.sim.export import write_encoder_logs

    a_file = tmp_path / "logs"
    a_file.write_text("not a folder")
    out = tmp_path / "t.csv"
    assert main(["sim", "run", "umbmark", "-o", str(out), "--encoder-dir", str(a_file)]) == 1
    err = capsys.readouterr().err
    assert "expected a folder for --encoder-dir" in err and err.count("\n") == 1
    with pytest.raises(SimError, match="expected a folder"):
        write_encoder_logs(a_file, [])


def test_an_encoder_dir_that_cannot_be_made_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a folder under a file: the message was the bare "[Errno 20] Not a directory"
    a_file = tmp_path / "logs"
    a_file.write_text("not a folder")
    out = tmp_path / "t.csv"
    args = ["sim", "run", "umbmark", "-o", str(out), "--encoder-dir", str(a_file / "sub")]
    assert main(args) == 1
    err = capsys.readouterr().err
    assert f"{a_file / 'sub'}: cannot create the folder for the encoder logs" in err
    assert err.count("\n") == 1
    assert out.exists()  # the trials written before it are kept

"""Issue 38's wrong results 1-7, each as a user meets it on the faces (each failed on the code
before its fix): a reverse run's direction column, the simulator's cw rotations and stalled trials
into a notebook, an infinite interval, two robots in one selection, UMBmark's two answers, a JSON
export its own import refused, and the /table1 page's digits."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from odolab.cli import main
from odolab.core.errors import CalibrationError

from .faces import cli, cli_json

_HEAD = [
    "trial_id",
    "campaign",
    "terrain",
    "kind",
    "distance_m",
    "direction",
    "predicted_x_m",
    "predicted_y_m",
    "predicted_heading_rad",
    "robot",
    "left_wheel_radius_m",
    "right_wheel_radius_m",
    "track_width_m",
    "ticks_per_rev",
    "measured_x_m",
    "measured_y_m",
]


def _straight_runs(path: Path, convention: str, *, flip: int | None = None) -> Path:
    """Forward and reverse runs of 1 m and 2 m, three each (seeded), written with the reverse
    runs as a negative distance ("signed") or as ``direction = reverse`` with a positive one
    ("direction"); ``flip``: that row's predicted x gets the wrong sign."""
    rng = np.random.default_rng(3)
    rows: list[list[object]] = []
    for d in (1.0, 2.0):
        for sgn in (1, -1):
            for _ in range(3):
                px = sgn * d * (1 + rng.normal(0, 0.01))
                py = sgn * 0.02 * d + rng.normal(0, 0.005)
                mx = px * (0.93 if sgn > 0 else 0.9) + rng.normal(0, 0.005)
                my = py - (0.04 if sgn > 0 else -0.08) * abs(px)
                dist = sgn * d if convention == "signed" else d
                way = "" if convention == "signed" else ("forward" if sgn > 0 else "reverse")
                if flip == len(rows):
                    px = -px
                rows.append([f"T{len(rows)}", "straight", "tile", "translation", dist, way,
                             px, py, 0.0, "jaguar-lite", 0.0825, 0.0825, 0.52, 1200, mx, my])  # fmt: skip
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(_HEAD)
        writer.writerows(rows)
    return path


def test_1_a_reverse_run_is_a_reverse_run_whatever_the_sign_convention(tmp_path: Path) -> None:
    docs = {}
    for convention in ("signed", "direction"):
        sheet = _straight_runs(tmp_path / f"{convention}.csv", convention)
        db = tmp_path / f"{convention}.db"
        cli("trials", "import", sheet, "--create-campaigns", "--db", db)
        docs[convention] = cli_json(tmp_path / f"{convention}.json", "analyze", "--db", db)
    signed, direction = docs["signed"], docs["direction"]
    assert direction["table1"] == signed["table1"]
    assert direction["motions"] == signed["motions"]
    rows = {r["motion"]: r for r in direction["table1"]}
    assert rows["y_forward"]["n"] == rows["y_reverse"]["n"] == 6
    # x's sigma at each repeated distance: forward and reverse apart
    assert sorted(s["commanded"] for s in rows["x"]["sigmas"]) == [-2.0, -1.0, 1.0, 2.0]


@pytest.mark.parametrize(
    ("flip", "edit", "said"),
    [
        (4, None, "line 6, column 'predicted_x_m'"),  # reverse 1 m, x +1.0
        (None, (",1.0,reverse,-", ",-1.0,reverse,"), "line 5, column 'predicted_x_m'"),
        (None, (",1.0,forward,", ",-1.0,forward,"), "line 2, column 'direction'"),
        # a word that is not a translation's direction is refused, naming the accepted ones
        (None, (",1.0,reverse,", ",1.0,backward,"), "line 5, column 'direction'"),
        (None, (",1.0,reverse,", ",1.0,rev,"), "expected 'forward' or 'reverse'"),
    ],
)
def test_1_a_contradiction_is_refused_with_its_line(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    flip: int | None,
    edit: tuple[str, str] | None,
    said: str,
) -> None:
    sheet = _straight_runs(tmp_path / "s.csv", "direction", flip=flip)
    if edit is not None:  # the distance made negative, the predicted x made positive
        text = sheet.read_text(encoding="utf-8")
        sheet.write_text(text.replace(edit[0], edit[1], 1), encoding="utf-8")
    assert main(["trials", "import", str(sheet), "--create-campaigns", "--db",
                 str(tmp_path / "x.db")]) == 1  # fmt: skip
    err = capsys.readouterr().err
    assert said in err and "Traceback" not in err, err


def test_1_the_direction_word_in_any_case_and_on_the_write_path(tmp_path: Path) -> None:
    from dataclasses import replace

    from odolab.core.errors import InvalidTrialError
    from odolab.core.trials import Command, MotionKind, signed_command, validate_trial
    from odolab.store.notebook import Notebook

    for word in ("Reverse", "REVERSE", " reverse "):
        cmd = Command(MotionKind.TRANSLATION, distance=1.0, direction=word)
        assert signed_command(cmd).distance == -1.0 and cmd.direction == "reverse"
    # a spreadsheet written with capitals: the same reverse runs as lowercase ones
    sheet = _straight_runs(tmp_path / "s.csv", "direction")
    sheet.write_text(sheet.read_text(encoding="utf-8").replace(",reverse,", ",Reverse,"), "utf-8")
    db = tmp_path / "x.db"
    cli("trials", "import", sheet, "--create-campaigns", "--db", db)
    with Notebook(db) as nb:
        trials = nb.load_trials(with_logs=False)
        back = [t for t in trials if t.command.direction == "reverse"]
        assert len(back) == 6 and all(t.command.distance < 0 for t in back)  # type: ignore[operator]
        # add_trials checks the word against the numbers and stores what a read gives back
        one = replace(back[0], trial_id="W1")
        one = replace(one, command=replace(one.command, distance=1.0))
        nb.add_trials([one])
        assert nb.get_trial("W1").command.distance == -1.0
        raw = nb._conn.execute("SELECT distance FROM trials WHERE trial_id = 'W1'").fetchone()
        assert raw[0] == -1.0
        wrong = replace(one, trial_id="W2", command=replace(one.command, direction="backward"))
        with pytest.raises(InvalidTrialError, match="expected 'forward' or 'reverse'"):
            nb.add_trials([wrong])
        ahead = replace(one, trial_id="W3", predicted=one.predicted._replace(x=0.95))
        with pytest.raises(InvalidTrialError, match="ends ahead of its start"):
            validate_trial(ahead)
        with pytest.raises(InvalidTrialError, match="ends ahead of its start"):
            nb.add_trials([ahead])


_CW = """
[protocol]
campaign = "cw"
terrain = "{terrain}"
report_rate = 10.0
dt = 0.05
turn_speed = 0.6

[[trials]]
motion = "rotation"
angle_pi = [2, 4, 7]
direction = "{way}"
"""


@pytest.mark.parametrize(("way", "terrain"), [("cw", "tile"), ("ccw", "concrete")])
def test_2_sim_run_records_its_cw_rotations_and_stalled_trials(
    tmp_path: Path, way: str, terrain: str
) -> None:
    """`sim run` with cw rotations into --db failed ("raw reading 'turns' is -1") and recorded
    nothing; so did stalled rotations (a tracked robot on concrete)."""
    from odolab.store import Notebook, read_trials_csv

    proto = tmp_path / "p.toml"
    proto.write_text(_CW.format(terrain=terrain, way=way), encoding="utf-8")
    db = tmp_path / "s.db"
    cli("sim", "run", proto, "--db", db, "-o", tmp_path / "t.csv", "--seed", "5")
    written = [p.trial for p in read_trials_csv(tmp_path / "t.csv")]
    with Notebook(db) as nb:
        stored = nb.load_trials(with_logs=False)
    assert [t.trial_id for t in stored] == [t.trial_id for t in written] and len(stored) == 3
    for s, w in zip(stored, written, strict=True):
        assert s.measured is not None and w.measured is not None
        assert s.measured.rotation == w.measured.rotation
        assert s.measured.raw["turns"] >= 0
        assert s.true is not None
        if terrain == "tile":  # the compass and the turns counted read the true rotation
            assert s.command.angle is not None and s.command.angle < 0
            assert abs(s.measured.rotation - s.true.heading) < 0.4  # measured: <= 0.18 in 30
        else:  # stalled: nothing turned, and the reading says about none
            assert s.status.value == "excluded" and "stalled" in (s.exclusion_reason or "")
            assert abs(s.measured.rotation) < 0.4  # measured: <= 0.13 rad in 30 trials


def _unbounded_growth(path: Path) -> Path:
    """Six straight runs at 1 m and 1.25 m (seeded): too close together for the growth of sigma
    to be bounded (y_forward's exponent stops at the search's edge, its interval open below)."""
    rng = np.random.default_rng(1)
    head = [h for h in _HEAD if h != "direction"]
    rows: list[list[object]] = []
    for d in (1.0, 1.25):
        for _ in range(3):
            mx, my = 0.93 * d + rng.normal(0, 0.01), rng.normal(0, 0.01)
            rows.append([f"T{len(rows)}", "straight", "tile", "translation", d, d, 0.0, 0.0,
                         "jaguar-lite", 0.0825, 0.0825, 0.52, 1200, mx, my])  # fmt: skip
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(head)
        writer.writerows(rows)
    return path


def _strict(text: str) -> object:
    def refuse(name: str) -> None:
        raise AssertionError(f"{name} in JSON")

    return json.loads(text, parse_constant=refuse)


def test_3_an_unbounded_interval_is_said_so_on_every_face(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """/api/table1 answered 500 ("Out of range float values are not JSON compliant"), analyze
    --json wrote -Infinity, the terminal showed -3.000 (the search's edge) without a word."""
    from .faces import client

    db = tmp_path / "g.db"
    cli("trials", "import", _unbounded_growth(tmp_path / "g.csv"), "--create-campaigns", "--db", db)
    capsys.readouterr()
    cli("analyze", "--db", db, "--json", tmp_path / "a.json")
    terminal = capsys.readouterr().out
    doc = _strict((tmp_path / "a.json").read_text(encoding="utf-8"))
    c = client(db)
    api = c.get("/api/table1")
    assert api.status_code == 200, api.text
    report = c.get("/api/report")
    assert report.status_code == 200, report.text
    for rows in (doc["table1"], _strict(api.text)["rows"], _strict(report.text)["table1"]):  # type: ignore[index]
        y = {r["motion"]: r for r in rows}["y_forward"]
        assert y["growth_p_ci95"][0] is None and y["growth_p_ci95"][1] is not None
        assert y["growth_p_at_bound"] is True
        assert "unbounded" in y["growth_p_note"] and "search's edge" in y["growth_p_note"]
    assert "≤ -3.0 (search's edge) [unbounded, 0.1]" in terminal
    assert "-3.000" not in terminal
    # the report's HTML table (report.view, what report.html shows) writes it alike
    from odolab.report.view import table1_rows

    cells = {c.label: c.text for c in table1_rows(doc["table1"])[1]}  # type: ignore[index]
    assert cells["growth p [95 % CI]"] == "≤ -3.0 (search's edge) [unbounded, 0.1]"


def test_4_two_robots_in_one_selection_one_rule_on_every_face(tmp_path: Path) -> None:
    """`calibrate --db` and POST /api/calibrate refused two robots ("name the one"); the report
    and /api/report calibrated one of them silently beside a Table I that pooled both."""
    from .faces import client, geometry, table_of
    from .notebooks import make_notebook

    gen = make_notebook(tmp_path, 0, two_robots=True)
    c = client(gen.db)
    refused = c.post("/api/calibrate", json={"method": "ratios", "record": False})
    assert refused.status_code == 400
    sentence = "the selected trials are of 2 robots (jaguar-lite, rover-b); name the one"
    assert sentence in refused.json()["error"]
    report = c.get("/api/report").json()
    assert report["calibration"] == {}
    assert sentence in report["extra"]["not_calibrated"]
    assert "of 2 robots, pooled: jaguar-lite, rover-b" in report["extra"]["trials_used"]
    # named, one robot's trials: its Table I and its calibration, alike on every face
    robot = "rover-b"
    mine = c.get("/api/report", params={"robot": robot}).json()
    doc = cli_json(tmp_path / "a.json", "analyze", "--db", gen.db, "--robot", robot)
    assert table_of(mine["table1"]) == table_of(doc["table1"]) != table_of(report["table1"])
    assert table_of(c.get("/api/table1", params={"robot": robot}).json()["rows"]) == table_of(
        doc["table1"]
    )
    cal = c.post("/api/calibrate", json={"method": "ratios", "robot": robot, "record": False})
    assert cal.status_code == 200, cal.text
    assert geometry(mine["calibration"]["ratios"]["params"]) == geometry(cal.json()["params"])
    assert "(robot rover-b)" in mine["extra"]["trials_used"]


def test_4_an_awaiting_robot_is_not_a_selected_robot(tmp_path: Path) -> None:
    """Robot A measured, robot B's runs only awaiting their measurement: the trials-used line
    and the robot a calibration is for count the same robots (measured ones): one."""
    from dataclasses import replace

    from odolab.app.calibration import choose_robot
    from odolab.app.selection import select_among, validation_campaigns
    from odolab.core.trials import TrialStatus
    from odolab.store.notebook import Notebook

    from .notebooks import make_notebook

    gen = make_notebook(tmp_path, 0, two_robots=True)
    with Notebook(gen.db) as nb:
        trials, validation = nb.load_trials(with_logs=False), validation_campaigns(nb)
    waiting = [
        replace(t, status=TrialStatus.AWAITING, measured=None) if t.params.name == "rover-b" else t
        for t in trials
    ]
    sel = select_among(waiting, validation)
    assert "rover-b" in {t.params.name for t in sel.trials}  # selected, not yet measured
    assert "robots" not in sel.describe()
    assert choose_robot(sel.trials, None, None) == "jaguar-lite"
    both = select_among(trials, validation)  # both measured: pooled, and a robot must be named
    assert "of 2 robots, pooled" in both.describe()
    with pytest.raises(CalibrationError, match="of 2 robots"):
        choose_robot(both.trials, None, None)


def test_5_umbmark_gives_one_answer_and_its_interval(tmp_path: Path) -> None:
    """The documented `calibrate umbmark --params jaguar-lite --db` iterated from the preset
    (its scale: track 0.602 m) where the report and `calibrate umbmark --db` started from the
    ratios of the same trials (0.549 m); the report's "new [95 % CI]" showed no interval."""
    from odolab.app.report import report_content
    from odolab.report.view import verdict
    from odolab.store import Notebook

    from .faces import geometry
    from .notebooks import make_notebook

    gen = make_notebook(tmp_path, 4, two_robots=False)
    named = cli_json(tmp_path / "n.json", "calibrate", "umbmark", "--params", "jaguar-lite",
                     "--db", gen.db, "-o", tmp_path / "n.toml")  # fmt: skip
    plain = cli_json(tmp_path / "p.json", "calibrate", "umbmark", "--db", gen.db,
                     "-o", tmp_path / "p.toml")  # fmt: skip
    with Notebook(gen.db) as nb:
        content = report_content(nb)
    umb = content.calibrations["umbmark"]
    assert geometry(named["params"]) == geometry(plain["params"]) == geometry(umb.params.to_dict())
    assert named["base"]["reason"].startswith("the ratios calibration of the same trials")
    assert "--params jaguar-lite" in named["base"]["reason"]
    # the report's UMBmark table: each new value with its interval, or why there is none
    # (these 2 + 2 squares scatter by up to 0.75 m: past the small-error model at 95 %)
    v = verdict(content.analysis.analysis, content.calibrations, content.analysis.table1, None,
                content.extra)  # fmt: skip
    rows = dict((name, prows) for name, _, prows in v.calibrations)["umbmark"]
    assert all("(no interval: the 2 + 2 squares' return errors scatter" in r.new for r in rows)


def test_5_umbmarks_interval_holds_its_value() -> None:
    from odolab.calibration import umbmark
    from odolab.core.params import PRESETS
    from odolab.report.view import _calibration_rows

    rng = np.random.default_rng(5)
    cw = np.array([0.12, -0.30]) + 0.01 * rng.standard_normal((5, 2))
    ccw = np.array([-0.05, 0.25]) + 0.01 * rng.standard_normal((5, 2))
    umb = umbmark(cw, ccw, 4.0, PRESETS["jaguar-lite"])
    prov = umb.calibration.provenance
    _, rows = _calibration_rows(umb)  # the rows verdict() gives the report's table
    for row, key in zip(rows, ("left_wheel_radius", "right_wheel_radius", "track_width"),
                        strict=True):  # fmt: skip
        lo, hi = prov[f"{key}_ci95"]
        assert lo < getattr(umb.params, key) < hi
        assert row.new.endswith("]") and " [" in row.new, row


def test_6_an_export_of_the_same_preset_imports(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two notebooks that each recorded preset jaguar-lite as version 1 (one by `sim run --db`,
    "recorded with a trial"; one by the demo's way, "nominal preset"): the one's JSON export was
    refused by the other ("parameter version 1 of 'jaguar-lite' differs")."""
    from odolab.core.params import PRESETS
    from odolab.store import Notebook

    proto = tmp_path / "p.toml"
    proto.write_text(_CW.format(terrain="tile", way="ccw"), encoding="utf-8")
    a, b = tmp_path / "a.db", tmp_path / "b.db"
    cli("sim", "run", proto, "--db", a, "-o", tmp_path / "t.csv", "--seed", "5")
    cli("trials", "export", tmp_path / "a.json", "--db", a)
    with Notebook(b) as nb:
        nb.add_params_version(PRESETS["jaguar-lite"], method="nominal preset")
        nb.add_params_version(PRESETS["jaguar-lite"].with_(track_width=0.6), method="ratios")
    cli("trials", "import", tmp_path / "a.json", "--db", b)
    with Notebook(b) as nb:
        assert len(nb.params_versions("jaguar-lite")) == 2  # no copy of version 1
        trials = nb.load_trials(with_logs=False)
        assert len(trials) == 3 and all(t.params == PRESETS["jaguar-lite"] for t in trials)
    # other numbers under the same version number: refused, saying which
    c = tmp_path / "c.db"
    with Notebook(c) as nb:
        nb.add_params_version(PRESETS["jaguar-lite"].with_(track_width=0.6), method="ratios")
    assert main(["trials", "import", str(tmp_path / "a.json"), "--db", str(c)]) == 1
    err = capsys.readouterr().err
    assert "parameter version 1 of 'jaguar-lite' differs from the notebook's version 1" in err
    assert "track_width 0.6 here, 0.56 in the file" in err, err


def test_7_the_table1_page_writes_the_clis_digits_and_signs(tmp_path: Path) -> None:
    """The page showed 4 significant digits (``0.9326 [0.8876, 0.9776]``) where the CLI and the
    report follow the interval rule (``0.933 [0.888, 0.978]``), and "σ @ 1" for the reverse
    runs the CLI shows "@ -1"."""
    import html
    import re

    from odolab.core import numfmt
    from odolab.report.table import sigma_text

    from .faces import client

    db = tmp_path / "s.db"
    cli("trials", "import", _straight_runs(tmp_path / "s.csv", "direction"), "--create-campaigns",
        "--db", db)  # fmt: skip
    rows = cli_json(tmp_path / "a.json", "analyze", "--db", db)["table1"]
    page = client(db).get("/table1").text
    for r in rows:
        found = re.search(
            rf'data-motion="{r["motion"]}" data-terrain="{r["terrain"]}">.*?'
            r'<td class="ratio"[^>]*>([^<]*)</td><td data-label="95 % CI">([^<]*)</td>.*?'
            r'<td class="sigma"[^>]*>(.*?)</td>',
            page,
            re.S,
        )
        assert found, r["motion"]
        assert f"{found.group(1)} {found.group(2)}" == numfmt.with_ci(r["ratio"], *r["ratio_ci95"])
        shown = html.unescape(found.group(3)).split("<br>")
        cli_cells = [sigma_text(s, r["unit"]) for s in r["sigmas"]]  # what the terminal shows
        if not cli_cells:  # no repeats: none on either face
            assert shown == ["–"]
            continue
        assert len(shown) == len(cli_cells)
        for web, term in zip(shown, cli_cells, strict=True):
            assert web.split(" (n ")[0] == term.split(" [")[0], (web, term)
    # the repeats: forward @ 1, 2 and reverse @ -1, -2, each with its sign
    x_cells = re.search(r'data-motion="x".*?<td class="sigma"[^>]*>(.*?)</td>', page, re.S)
    assert x_cells and all(f" @ {d} (n 3)" in x_cells.group(1) for d in (-1, -2, 1, 2))

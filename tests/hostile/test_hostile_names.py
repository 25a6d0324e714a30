"""Hostile names in every text field: the report shows them as text, the terminal shows them
without obeying them, and every file written stays in its folder with a safe name."""

from __future__ import annotations

import dataclasses
import re
import sys
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from odolab.cli import main
from odolab.core.params import PRESETS
from odolab.core.trials import TrialStatus
from odolab.store import Notebook

sys.path.insert(0, str(Path(__file__).parents[1] / "analysis"))
from synth_trials import rotation_trials, translation_trials

SCRIPT = "<script>alert('x')</script>"
IMG = '"><img src=x onerror=alert(1)>'
ANSI = "\x1b[31mred\x1b[2J\x1b]0;owned\x07"
LONG = "n" * 10_000
ROBOT = f"{SCRIPT}{IMG}{ANSI}"  # a parameter-set name

#: what a safe file name may contain (letters and digits of any script, - _ . + = @ ,)
SAFE_NAME = re.compile(r"^[\w\-.+=@,]+$")


class _Tags(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.tags: list[tuple[str, list[tuple[str, str | None]]]] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append((tag, attrs))


def _live_tags(html: str) -> list[str]:
    """Tags that could run script: <script>, <img>, or any on* attribute."""
    parser = _Tags()
    parser.feed(html)
    bad = []
    for tag, attrs in parser.tags:
        if tag in ("script", "img") and not any(
            k == "src" and (v or "").startswith("data:image/png;base64,") for k, v in attrs
        ):
            bad.append(tag)
        bad += [f"{tag} {k}" for k, _ in attrs if k.startswith("on")]
    return bad


@pytest.fixture
def hostile_db(tmp_path: Path) -> Path:
    """A notebook whose campaigns, terrains, trial ids, reasons and robot name are hostile."""
    rng = np.random.default_rng(5)
    params = PRESETS["jaguar-lite"].with_(name=ROBOT)
    rot = rotation_trials(rng, repeats_at_20pi=6)
    tra = translation_trials(rng, distances=(1.0, 2.0), repeats=4)
    trials = []
    for i, t in enumerate(rot):
        trials.append(
            dataclasses.replace(
                t,
                trial_id=f"../../r{i}{ANSI}",
                campaign=SCRIPT,
                terrain=f"tile/../../{SCRIPT}{ANSI}$x^{{",
                params=params,
            )
        )
    for i, t in enumerate(tra):
        trials.append(
            dataclasses.replace(
                t,
                trial_id=f"/etc/t{i}{IMG}",
                campaign=IMG,
                terrain="/abs/" + LONG,
                params=params,
            )
        )
    trials[3] = dataclasses.replace(
        trials[3], status=TrialStatus.EXCLUDED, exclusion_reason=f"{SCRIPT}{IMG}{ANSI}"
    )
    db = tmp_path / "lab.db"
    with Notebook(db) as nb:
        nb.add_trials(trials)
    return db


def _files(root: Path) -> set[Path]:
    return {p for p in root.rglob("*") if p.is_file()}


def test_report_shows_hostile_names_as_text(
    tmp_path: Path, hostile_db: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    before = _files(tmp_path)
    out = tmp_path / "report"
    assert main(["report", "--db", str(hostile_db), "--out", str(out)]) == 0
    html = (out / "report.html").read_text(encoding="utf-8")
    assert _live_tags(html) == []
    assert "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;" in html  # the campaign, as text
    assert "&#34;&gt;&lt;img src=x onerror=alert(1)&gt;" in html  # excluded reason / campaign
    # the excluded trial id, its escape sequence shown as the CLI shows it
    assert '<td class="l">../../r3\\x1b[31mred' in html and "\x1b" not in html
    # files: only inside the report folder, with safe names (terrains are in figure names)
    written = _files(tmp_path) - before
    assert written and all(out in p.parents for p in written)
    figs = sorted(p.name for p in (out / "figures").iterdir())
    assert figs and all(SAFE_NAME.match(name) and len(name) <= 64 for name in figs)
    assert any("tile_.._.._" in name for name in figs)  # the "/" terrain has its figures
    # the terminal: Table I names the terrains without obeying their escape sequences
    printed = capsys.readouterr()
    assert "\x1b" not in printed.out + printed.err


def test_trials_list_and_show_print_escape_sequences_as_text(
    hostile_db: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["trials", "list", "--db", str(hostile_db)]) == 0
    assert main(["trials", "show", f"../../r3{ANSI}", "--db", str(hostile_db)]) == 0
    assert main(["notebook", "info", "--db", str(hostile_db)]) == 0
    assert main(["trials", "campaigns", "--db", str(hostile_db)]) == 0
    assert main(["trials", "params-versions", ROBOT, "--db", str(hostile_db)]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\x07" not in out
    assert "trial ../../r3\\x1b[31mred\\x1b[2J\\x1b]0;owned\\x07" in out
    assert "status: excluded (<script>" in out
    assert "parameters <script>alert('x')</script>\"><img src=x onerror=alert(1)>\\x1b[31m" in out


def test_a_markup_like_terrain_does_not_break_analyze(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rng = np.random.default_rng(1)
    trials = [dataclasses.replace(t, terrain="[/]x[bold]") for t in rotation_trials(rng)]
    db = tmp_path / "lab.db"
    with Notebook(db) as nb:
        nb.add_trials(trials)
    assert main(["analyze", "--db", str(db)]) == 0
    assert "[/]x[bold]" in capsys.readouterr().out.replace("\n", "")


#: text that matplotlib would parse as mathtext: `$\foo$` is a parse error when drawn
MATH = r"$\foo$ and $x^{2}$"


def test_names_that_look_like_mathtext_are_drawn_as_written(tmp_path: Path) -> None:
    """Before: a terrain named ``$\\foo$`` ended `odolab report` in matplotlib's ValueError
    (a traceback), and ``$x^{2}$`` was drawn as a formula. Terrains and robot names are drawn
    as typed, in the report's figures and the fleet's."""
    from odolab.fleet.section import fleet_section

    rng = np.random.default_rng(1)
    params = PRESETS["jaguar-lite"].with_(name=MATH)
    trials = [
        dataclasses.replace(t, terrain=MATH, params=params)
        for t in rotation_trials(rng, repeats_at_20pi=4)
    ]
    db = tmp_path / "lab.db"
    with Notebook(db) as nb:
        nb.add_trials(trials)
    out = tmp_path / "report"
    assert main(["report", "--db", str(db), "--out", str(out)]) == 0
    assert len(list((out / "figures").glob("*.png"))) >= 3
    rows: dict[str, list[object]] = {  # a fleet table read back: its dates are any text
        "robot": [MATH] * 4 + ["robot-02"] * 5,
        "date": ["2026-11-01", "2026-11-02", "2026-11-03", "2026-11-04"] * 2 + [MATH],
        "drift_pct": [1.0, 1.1, 1.2, 1.3, 1.0, 1.0, 1.1, 1.0, 1.0],
        "run": [f"r{i}" for i in range(9)],
        "error": [""] * 9,
    }
    fleet_section(rows).save(tmp_path / "fleet")  # type: ignore[arg-type]
    assert (tmp_path / "fleet" / "fleet_drift_per_day.png").stat().st_size > 10_000


def test_an_error_message_never_carries_escape_sequences(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "lab.db"
    with Notebook(db):
        pass
    assert (
        main(["trials", "show", f"nope\nodolab: fake second line{ANSI}{LONG}", "--db", str(db)])
        == 1
    )
    err = capsys.readouterr().err
    assert "\x1b" not in err and "\x07" not in err and err.count("\n") == 1
    assert err.startswith("odolab: error: ") and len(err) < 2100


def test_write_report_escapes_parameter_set_names_in_the_validation(
    tmp_path: Path,
) -> None:
    from odolab.analysis import analyze_trials
    from odolab.report import write_report

    rng = np.random.default_rng(2)
    analysis = analyze_trials(rotation_trials(rng, repeats_at_20pi=4))
    p = PRESETS["jaguar-lite"].to_dict()
    validation = {
        "method": "midpoint",
        "encoder_log": f"{SCRIPT}.csv",
        "old": {"params": {**p, "name": f"{IMG}old"}, "rms_error_rad": 0.1},
        "new": {"params": {**p, "name": f"{SCRIPT}new"}, "rms_error_rad": 0.05},
        "warnings": [f"{IMG} warning"],
        f"{SCRIPT}key": IMG,
    }
    path = write_report(tmp_path / "r", analysis, validation=validation)
    html = path.read_text(encoding="utf-8")
    assert _live_tags(html) == []
    assert "&#34;&gt;&lt;img src=x onerror=alert(1)&gt;old" in html
    assert "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;new" in html


def test_run_tables_show_markup_like_names_as_text_and_tell_runs_apart(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Run and robot names are user text in rich tables: ``[bold]`` is shown, not obeyed; runs
    that share a name (``run-001`` of every robot and day) are shown by their paths."""
    from odolab.cli._fleet import print_fleet
    from odolab.fleet import FleetSpec, simulate_fleet
    from odolab.io.run import ReadOptions
    from odolab.metrics.cluster import Cluster
    from odolab.metrics.runs import evaluate_runs

    spec = FleetSpec(robots=2, days=2, runs_per_day=1, run_seconds=4.0, wearing=0, seed=5)
    runs = simulate_fleet(tmp_path / "fleet", spec)
    robot = runs[0].parents[1]
    hostile = robot.with_name("[bold]bot")
    robot.rename(hostile)
    capsys.readouterr()
    args = ["evaluate", str(tmp_path / "fleet"), "--format", "csv", "-p", "jaguar-lite"]
    code = main([*args, "--workers", "1"])
    assert code == 0
    out = capsys.readouterr().out
    assert f"[bold]bot/{spec.start_date}/run-001" in out
    assert "mean, [bold]bot (2 runs)" in out
    other = runs[-1].parents[1].name
    assert other != robot.name
    assert f"{other}/{spec.start_date}/run-001" in out  # the other robot's run, told apart

    moved = sorted((tmp_path / "fleet").rglob("run-*[0-9].csv"))
    outcomes = evaluate_runs(
        moved,
        "csv",
        params=PRESETS["jaguar-lite"],
        read_options=ReadOptions(modulus=PRESETS["jaguar-lite"].encoder_modulus),
        cluster=Cluster(workers=1),
    )
    print_fleet(outcomes)
    fleet_out = capsys.readouterr().out
    assert fleet_out.count("[bold]bot") >= 3  # per robot, per day, worst runs


def test_markup_like_paths_are_printed_as_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """File names are user text too: a folder ``[red]x`` is shown, not read as a colour."""
    folder = tmp_path / "[red]x"
    folder.mkdir()
    db = folder / "[bold]lab.db"
    assert main(["notebook", "init", "--db", str(db)]) == 0
    assert main(["sim", "run", "rotation", "--db", str(db), "-o", str(folder / "r.csv")]) == 0
    capsys.readouterr()
    assert main(["trials", "list", "--db", str(db)]) == 0
    assert f"37 trials in {db}" in capsys.readouterr().out
    out_json = folder / "[i]a.json"
    assert main(["analyze", "--db", str(db), "--json", str(out_json)]) == 0
    assert f"analysis written to {out_json}" in capsys.readouterr().out


def test_a_path_with_an_escape_sequence_is_echoed_as_text(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "log.csv"
    log.write_text("t,left_ticks,right_ticks\n0,0,0\n0.05,10,12\n")
    out = tmp_path / f"e{ANSI}vil" / "traj.csv"
    out.parent.mkdir()
    assert main(["odometry", str(log), "-o", str(out)]) == 0
    said = capsys.readouterr().out
    assert "\x1b" not in said and "\x07" not in said
    assert "e\\x1b[31mred\\x1b[2J\\x1b]0;owned\\x07vil" in said
    assert out.exists()


def test_params_show_stays_toml_and_obeys_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import tomllib

    name = f"jag{ANSI}\u0085uar\tlite"
    source = tmp_path / "p.toml"
    from odolab.core.params import save_params

    save_params(source, PRESETS["jaguar-lite"].with_(name=name))
    assert tomllib.loads(source.read_text())["robot"]["name"] == name
    capsys.readouterr()
    assert main(["params", "show", str(source)]) == 0
    shown = capsys.readouterr().out
    assert not any(c in shown for c in "\x1b\x07\x85\t")
    assert tomllib.loads(shown)["robot"]["name"] == name

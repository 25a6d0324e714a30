"""Every face on 20 random notebooks (issue 38; tests/parity/generator.py draws them: one or two
robots, cw or ccw rotations, squares, trials recorded directly or imported from CSV or JSON in
either sign convention of reverse runs, a growth exponent the data cannot bound, validation
campaigns, excluded trials), refusals included: `analyze --json` and its terminal, /api/table1,
the /table1 page, /api/report, POST /api/calibrate and `calibrate ratios --db` agree with each
other and with the generator's own count of each Table I row."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from odolab.cli import main

from .faces import cli_json, client, geometry, page_table1, table_of
from .generator import OPEN_TERRAIN, random_notebook

SEEDS = range(20)

_CONTRADICTION = (
    "trial_id,campaign,terrain,kind,distance_m,direction,predicted_x_m,predicted_y_m,"
    "predicted_heading_rad,robot,measured_x_m,measured_y_m,params_version\n"
    "X1,contradiction,tile,translation,1.0,reverse,0.98,0.0,0.0,jaguar-lite,0.9,0.0,1\n"
)


def _strict(text: str) -> Any:
    def refuse(name: str) -> None:
        raise AssertionError(f"{name} in JSON")

    return json.loads(text, parse_constant=refuse)


@pytest.mark.slow  # about 1.5 s of CPU a notebook (three analyses: the CLI's two, the web's one)
@pytest.mark.parametrize("seed", SEEDS)
def test_every_face_on_a_random_notebook(
    tmp_path: Path, seed: int, capsys: pytest.CaptureFixture[str]
) -> None:
    drawn = random_notebook(tmp_path, seed)
    capsys.readouterr()
    doc = cli_json(tmp_path / "a.json", "analyze", "--db", drawn.db)
    terminal = capsys.readouterr().out
    _strict((tmp_path / "a.json").read_text(encoding="utf-8"))  # no Infinity, no NaN
    by_cli = table_of(doc["table1"])
    # the generator's own count of each row: reverse runs are reverse in either convention,
    # excluded and validation trials count nowhere
    assert {k: n for k, (n, _) in by_cli.items()} == drawn.counts, (drawn, by_cli)
    for robot, way in drawn.rotation_way.items():  # cw: a ratio near the ccw one, not negative
        assert 0.5 < by_cli[("rotation", "tile")][1] < 1.5, (robot, way)
    c = client(drawn.db)
    api = c.get("/api/table1")
    assert api.status_code == 200, api.text
    assert table_of(_strict(api.text)["rows"]) == by_cli
    assert page_table1(c.get("/table1").text) == by_cli
    report = c.get("/api/report")
    assert report.status_code == 200, report.text
    results = _strict(report.text)
    assert table_of(results["table1"]) == by_cli
    if drawn.validation:
        assert drawn.validation in doc["selection"]["left_out"]
    # an interval the data cannot bound: null with its reason on every face, said on the terminal
    if drawn.open_growth:
        for rows in (doc["table1"], _strict(api.text)["rows"], results["table1"]):
            y = {(r["motion"], r["terrain"]): r for r in rows}[("y_forward", OPEN_TERRAIN)]
            assert y["growth_p_ci95"][0] is None and y["growth_p_at_bound"] is True
            assert "unbounded" in y["growth_p_note"]
        assert "[unbounded, " in terminal
    # one robot: the report's ratios are the API's and the CLI's; two: every face refuses alike
    cal = c.post("/api/calibrate", json={"method": "ratios", "record": False})
    code = main(["calibrate", "ratios", "--db", str(drawn.db), "--json",
                 str(tmp_path / "c.json"), "-o", str(tmp_path / "c.toml")])  # fmt: skip
    if len(drawn.robots) == 1:
        assert cal.status_code == 200 and code == 0, cal.text
        want = geometry(cal.json()["params"])
        assert geometry(results["calibration"]["ratios"]["params"]) == want
        by_cli_cal = json.loads((tmp_path / "c.json").read_text(encoding="utf-8"))
        assert geometry(by_cli_cal["params"]) == want
    else:
        sentence = "of 2 robots (jaguar-lite, rover-b); name the one to calibrate"
        assert cal.status_code == 400 and sentence in cal.json()["error"]
        assert code == 1 and sentence in capsys.readouterr().err
        assert results["calibration"] == {} and sentence in results["extra"]["not_calibrated"]
        assert "of 2 robots, pooled" in results["extra"]["trials_used"]
    # a row whose direction contradicts its x is refused with its line; nothing is written
    sheet = tmp_path / "contradiction.csv"
    sheet.write_text(_CONTRADICTION, encoding="utf-8")
    capsys.readouterr()
    assert main(["trials", "import", str(sheet), "--create-campaigns", "--db",
                 str(drawn.db)]) == 1  # fmt: skip
    assert "line 2, column 'predicted_x_m'" in capsys.readouterr().err
    assert table_of(c.get("/api/table1").json()["rows"]) == by_cli

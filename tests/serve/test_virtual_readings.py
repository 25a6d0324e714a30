"""The phone's trial page shows what the virtual instruments read after a run on a virtual
board (issue 38, items 8-9): the student types what an instrument shows and odolab does the
arithmetic; a trial without a true pose shows nothing of the kind."""

from __future__ import annotations

import math
import re
from pathlib import Path

from starlette.testclient import TestClient

from odolab.core.params import PRESETS
from odolab.core.trials import Command, MotionKind
from odolab.robot.session import run_motion_simulated
from odolab.serve import ServeSettings, create_app
from odolab.store import Notebook
from odolab.store.measure import virtual_readings

LOCAL = "http://127.0.0.1:8000"


def test_the_trial_page_shows_the_virtual_readings_and_takes_them(tmp_path: Path) -> None:
    db = tmp_path / "lab.db"
    trial, _ = run_motion_simulated(
        Command(MotionKind.ROTATION, angle=2.5 * math.pi, speed=2.0), nominal=PRESETS["jaguar-lite"]
    )
    assert trial.true is not None
    with Notebook(db) as nb:
        nb.add_trial(trial)
    c = TestClient(create_app(ServeSettings(db=db)), base_url=LOCAL)
    page = c.get(f"/trial?id={trial.trial_id}").text
    shown = re.search(r'<p id="virtual">.*?show: compass (\S+) -&gt; (\S+) deg, (\d+) whole', page)
    assert shown is not None, page
    readings = virtual_readings(trial)
    assert readings is not None
    b0, b1, turns = (float(v) for v in shown.groups())
    assert (b0, b1, turns) == (
        readings["compass_initial_deg"],
        readings["compass_final_deg"],
        readings["turns"],
    )
    token = re.search(r'name="csrf" value="([0-9a-f]{64})"', page)
    assert token is not None
    form = {"csrf": token.group(1), "id": trial.trial_id}
    form |= {"initial": f"{b0:g}", "final": f"{b1:g}", "turns": str(int(turns))}
    assert c.post("/trial/measure", data=form, follow_redirects=True).status_code == 200
    with Notebook(db) as nb:
        m = nb.get_trial(trial.trial_id).measured
    # compass read to 0.05 rad twice, 1 degree marks: within 0.3 rad of the true turn
    assert m is not None and m.rotation is not None
    assert abs(m.rotation - trial.true.heading) < 0.3

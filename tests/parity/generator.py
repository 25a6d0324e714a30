"""Random lab notebooks for the parity suite (issue 38), each drawn from its seed, with what the
faces must then show kept beside it (:class:`Drawn`).

A notebook draws: one robot or two; per robot a rotation campaign (clockwise or
counter-clockwise), a translation campaign (forward and reverse runs, three repeats at each
distance) and, sometimes, UMBmark squares (both ways); how its trials come in (recorded as the
simulator's ``--db`` does, a trials CSV, or a JSON export: by turns, the seed modulo 3), and,
for a CSV or JSON, the sign convention of its reverse runs (by turns too) (a negative distance, or ``direction = reverse`` with a positive
one); sometimes a campaign whose growth of sigma the data cannot bound (straight runs at 1 m and
1.25 m on terrain ``lino``: the exponent stops at the search's edge, its interval open below),
sometimes a validation campaign and an excluded trial. Small protocols, in process: a notebook
takes a fraction of a second.
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from odolab.core.params import RobotParams
from odolab.core.trials import MotionKind, Trial, TrialStatus
from odolab.sim.protocols import parse_protocol, run_protocol
from odolab.store import Notebook, write_trials_csv

from .notebooks import ROBOT_A, ROBOT_B, _truth

#: the terrain of the campaign whose growth exponent cannot be bounded
OPEN_TERRAIN = "lino"


@dataclass
class Drawn:
    """A drawn notebook and what it holds (the faces' expectations)."""

    db: Path
    seed: int
    robots: list[str]
    way_in: str  #: "db" (as sim run --db), "csv" or "json"
    convention: str  #: reverse runs: "signed" (negative distance) or "direction"
    rotation_way: dict[str, str] = field(default_factory=dict)  #: robot -> "cw" / "ccw"
    squares: bool = False
    open_growth: bool = False
    validation: str | None = None
    excluded: list[str] = field(default_factory=list)
    #: (motion, terrain) -> trials each Table I row counts, by the generator's own reckoning
    counts: dict[tuple[str, str], int] = field(default_factory=dict)


def _protocol(campaign: str, sets: list[dict[str, Any]]) -> Any:
    doc = {
        "protocol": {
            "campaign": campaign,
            "terrain": "tile",
            "report_rate": 10.0,
            "dt": 0.05,
            "turn_speed": 0.6,
            "linear_speed": 0.6,
        },
        "trials": sets,
    }
    return parse_protocol(doc, source=f"<generated {campaign}>")


def _sim(campaign: str, sets: list[dict[str, Any]], robot: RobotParams, seed: int) -> list[Trial]:
    return run_protocol(_protocol(campaign, sets), _truth(robot), robot, seed=seed)


def _open_growth_trials(robot: RobotParams, tag: str) -> list[Trial]:
    """Six straight runs at 1 m and 1.25 m, forward (rng seed 1, as tests/parity's item 3):
    y_forward's growth exponent stops at -3, its interval open below."""
    from odolab.core.trajectory import Pose
    from odolab.core.trials import Command, Measurement

    rng = np.random.default_rng(1)
    out = []
    for d in (1.0, 1.25):
        for _ in range(3):
            mx, my = 0.93 * d + rng.normal(0, 0.01), rng.normal(0, 0.01)
            out.append(
                Trial(
                    f"open-{tag}-{len(out)}",
                    f"open-{tag}",
                    OPEN_TERRAIN,
                    Command(MotionKind.TRANSLATION, distance=d),
                    Pose(0.0, d, 0.0, 0.0, 0.0),
                    robot,
                    Measurement("meterstick", x=float(mx), y=float(my), sigma_xy=0.003),
                    status=TrialStatus.MEASURED,
                )
            )
    return out


def _csv_way(trials: list[Trial], path: Path, convention: str) -> Path:
    """The trials as a trials CSV, reverse runs in the drawn sign convention."""
    write_trials_csv(path, [(t, None) for t in trials])
    if convention == "signed":
        return path
    with path.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    head = rows[0]
    kind, dist, way = head.index("kind"), head.index("distance_m"), head.index("direction")
    for row in rows[1:]:
        if row[kind] == "translation" and float(row[dist]) < 0:
            row[dist], row[way] = repr(-float(row[dist])), "reverse"
    with path.open("w", newline="", encoding="utf-8") as fh:
        csv.writer(fh).writerows(rows)
    return path


def _json_way(trials: list[Trial], folder: Path, convention: str) -> Path:
    """The trials as a JSON export of a scratch notebook, reverse runs in the convention."""
    scratch = folder / "scratch.db"
    with Notebook(scratch) as nb:
        nb.add_trials(trials)
        nb.export_json(folder / "export.json")
    path = folder / "export.json"
    if convention == "direction":
        doc = json.loads(path.read_text(encoding="utf-8"))
        for rec in doc["trials"]:
            if rec["kind"] == "translation" and rec["distance"] < 0:
                rec["distance"], rec["direction"] = -rec["distance"], "reverse"
        path.write_text(json.dumps(doc), encoding="utf-8")
    return path


def _count(drawn: Drawn, trials: list[Trial]) -> None:
    """Table I's n per row, reckoned here: rotations by their campaign's terrain; a
    translation counts in x and in y_forward or y_reverse by the way it was driven."""
    for t in trials:
        if t.status is not TrialStatus.MEASURED or t.measured is None:
            continue
        if t.command.kind is MotionKind.ROTATION:
            keys = [("rotation", t.terrain)]
        elif t.command.kind is MotionKind.TRANSLATION:
            assert t.command.distance is not None
            way = "y_forward" if t.command.distance >= 0 else "y_reverse"
            keys = [("x", t.terrain), (way, t.terrain)]
        else:
            continue
        for key in keys:
            drawn.counts[key] = drawn.counts.get(key, 0) + 1


def random_notebook(folder: Path, seed: int) -> Drawn:
    """A notebook drawn from ``seed`` (see the module's doc)."""
    rng = np.random.default_rng(seed)
    robots = [ROBOT_A, ROBOT_B] if rng.random() < 0.35 else [ROBOT_A]
    drawn = Drawn(
        folder / f"random-{seed}.db",
        seed,
        [r.name for r in robots],
        ("db", "csv", "json")[seed % 3],  # every way in and convention, on every 6 seeds
        ("signed", "direction")[(seed // 3) % 2],
        squares=bool(rng.random() < 0.2),
        open_growth=bool(rng.random() < 0.35),
    )
    trials: list[Trial] = []
    for k, robot in enumerate(robots):
        tag = "ab"[k]
        way = str(rng.choice(["cw", "ccw"]))
        drawn.rotation_way[robot.name] = way
        angles = sorted(int(a) for a in rng.choice(np.arange(1, 9), size=4, replace=False))
        rot = [{"motion": "rotation", "angle_pi": angles, "direction": way, "repeats": 2}]
        trials += _sim(f"rotation-{tag}", rot, robot, seed * 10 + k)
        distances = [1.0, 2.0] if rng.random() < 0.5 else [1.0, 2.0, 3.0]
        straight = [
            {"motion": "translation", "distance": distances, "direction": d, "repeats": 3}
            for d in ("forward", "reverse")
        ]
        trials += _sim(f"translation-{tag}", straight, robot, seed * 10 + k + 5)
        if drawn.squares:
            sq = [
                {"motion": "square", "side": 1.0, "direction": d, "repeats": 2}
                for d in ("cw", "ccw")
            ]
            trials += _sim(f"square-{tag}", sq, robot, seed * 10 + k + 7)
        if drawn.open_growth:
            trials += _open_growth_trials(robot, tag)
    work = folder / f"in-{seed}"
    work.mkdir()
    with Notebook(drawn.db) as nb:
        if drawn.way_in == "db":
            drawn.convention = "signed"  # the simulator's own: a negative distance
            nb.add_trials(trials)
        elif drawn.way_in == "csv":
            nb.import_csv(_csv_way(trials, work / "t.csv", drawn.convention), create_campaigns=True)
        else:
            nb.import_json(_json_way(trials, work, drawn.convention))
        counted = list(trials)
        if rng.random() < 0.4:  # a validation campaign: never in Table I unless named
            drawn.validation = "phone-check"
            nb.add_campaign(drawn.validation, "rotation", "tile", notes="validation: a phone")
            val = _sim(drawn.validation, [{"motion": "rotation", "angle_pi": [2, 4]}], ROBOT_A,
                       seed + 3)  # fmt: skip
            nb.add_trials(val)
        if rng.random() < 0.5:  # one bumped trial
            measured = sorted(t.trial_id for t in counted if t.status is TrialStatus.MEASURED)
            tid = str(rng.choice(measured))
            nb.exclude_trial(tid, "generated: a bumped trial")
            drawn.excluded.append(tid)
    _count(drawn, [t for t in counted if t.trial_id not in drawn.excluded])
    return drawn

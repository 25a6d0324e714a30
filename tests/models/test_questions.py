"""The lab's open questions: experiment files, effects with CIs against hand-computed truths."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from odolab.analysis.questions import (
    builtin_experiments,
    legs_for,
    load_experiment,
    parse_experiment,
    run_experiment,
)
from odolab.core.errors import SimError
from odolab.core.models import ExtendedDiffDrive, IcrModel, KinematicModel
from odolab.core.params import PRESETS
from odolab.sim.physics import TrueParams
from odolab.sim.presets import TRUTH_PRESETS

NOMINAL = PRESETS["jaguar-lite"]
QUIET = {"compass_sigma": 1e-6, "meterstick_sigma": 1e-6, "tape_sigma": 1e-6}


def _exp(conditions: list[dict], effects: list[dict] | None = None, **head) -> object:  # type: ignore[type-arg]
    doc = {"experiment": {"name": "t", "repeats": 2, **QUIET, **head}, "conditions": conditions}
    if effects:
        doc["effects"] = effects
    return parse_experiment(doc, "t.toml")


def test_builtin_experiments_answer_the_four_questions() -> None:
    names = builtin_experiments()
    assert set(names) == {"in-place-vs-curves", "pivot-terrains", "speed-sweep", "stops"}
    for name in names:
        exp = load_experiment(name)
        assert exp.effects and exp.question.endswith("?")


def test_curve_legs_turn_the_nominal_heading() -> None:
    exp = _exp([{"label": "c", "motion": "curve", "angle_deg": -90, "radius": 1.0}])
    (leg,) = legs_for(exp.conditions[0], NOMINAL)  # type: ignore[attr-defined]
    b = NOMINAL.track_width
    assert (leg.right - leg.left) * leg.duration / b == pytest.approx(-math.pi / 2, abs=1e-12)
    assert (leg.left + leg.right) / 2 * leg.duration == pytest.approx(math.pi / 2, abs=1e-12)
    assert max(abs(leg.left), abs(leg.right)) == pytest.approx(0.3)


def test_turn_slip_effect_is_the_icr_spread() -> None:
    # gamma = 0.1: in place the spread is b (no slip); on a 1 m curve s = b / 2 m, the spread
    # b * (1 - 0.1 * (1 - s)): the curve turns 1 / (1 - 0.1 * (1 - s)) times the odometry
    truth = TrueParams.from_nominal(NOMINAL, turn_slip=0.1)
    exp = _exp(
        [
            {"label": "in place", "motion": "rotate", "angle_deg": 180},
            {"label": "curve", "motion": "curve", "angle_deg": 180, "radius": 1.0},
        ],
        [{"a": "in place", "b": "curve"}],
        alternate=True,
    )
    res = run_experiment(exp, truth, NOMINAL, seed=1)  # type: ignore[arg-type]
    s = NOMINAL.track_width / 2.0
    expected = -100.0 * (1.0 / (1.0 - 0.1 * (1.0 - s)) - 1.0)  # -7.76 %
    # measured |value - expected| 0.000526-0.000608 over seed shifts 0-3; tolerance 0.1
    assert res.condition("in place").mean == pytest.approx(0.0, abs=0.1)
    # measured |value - expected| 0.0119-0.012 over seed shifts 0-3; tolerance 0.1; at seed shift 0
    # it is 853x the spread over seeds away
    assert res.condition("curve").mean == pytest.approx(expected, abs=0.1)
    (eff,) = res.effects
    # measured |value - expected| 0.0124-0.0126 over seed shifts 0-3; tolerance 0.15; at seed shift
    # 0 it is 873x the spread over seeds away
    assert eff.difference == pytest.approx(-expected, abs=0.15)
    assert eff.low <= eff.difference <= eff.high
    assert "in place slips 7.7 % more than curve" in eff.sentence() or "7.8 %" in eff.sentence()


def test_speed_trend_and_stop_slide() -> None:
    truth = TrueParams.from_nominal(NOMINAL, speed_slip=0.1, stop_slide=0.05)
    sweep = _exp(
        [
            {
                "label": f"{v}",
                "motion": "straight",
                "distance": 1.0,
                "speed": v,
                "stop": "gradual",
                "decel": 0.5,
            }
            for v in (0.1, 0.3, 0.5)
        ],
        trend="speed",
    )
    res = run_experiment(sweep, truth, NOMINAL, seed=2)  # type: ignore[arg-type]
    assert res.trend is not None
    # slip = speed_slip * v (10 % per m/s) on the steady part; the slow-down part slips less
    # measured 9.73 over seed shifts 0-3; bound 10; at seed shift 0 it is 467x the spread over seeds
    # away
    assert 7.0 < res.trend.slope < 10.0
    stops = _exp(
        [
            {"label": "abrupt", "motion": "straight", "distance": 1.0, "speed": 0.5},
            {
                "label": "gradual",
                "motion": "straight",
                "distance": 1.0,
                "speed": 0.5,
                "stop": "gradual",
                "decel": 1.0,
            },
        ],
        [{"a": "abrupt", "b": "gradual"}],
    )
    res = run_experiment(stops, TrueParams.from_nominal(NOMINAL, stop_slide=0.05), NOMINAL)  # type: ignore[arg-type]
    # the abrupt stop slides 0.05 * 0.5**2 = 12.5 mm past its counts on a 1 m run: -1.25 %
    # measured |value - expected| 0.0416-0.0417 over seed shifts 0-3; tolerance 0.05; at seed shift
    # 0 it is 50.5x the spread over seeds away
    assert res.condition("abrupt").mean == pytest.approx(-1.25, abs=0.05)
    # measured |value - expected| 0.0418-0.0419 over seed shifts 0-3; tolerance 0.05; at seed shift
    # 0 it is 56.9x the spread over seeds away
    assert res.condition("gradual").mean == pytest.approx(0.0, abs=0.05)
    assert "abrupt slips 1.2 % less than gradual" in res.effects[0].sentence()


def test_turns_in_place_stall_outdoors_but_pivots_work() -> None:
    exp = load_experiment("pivot-terrains")
    res = run_experiment(exp, TRUTH_PRESETS["jaguar-lab-tracked"], NOMINAL, repeats=4, seed=3)
    for terrain in ("concrete", "grass"):
        assert res.condition(f"in place, {terrain}").stalled == 4
        pivot = res.condition(f"pivot, {terrain}")
        assert pivot.stalled == 0 and len(pivot.slip) == 4
    assert res.condition("in place, tile").stalled == 0
    doc = res.to_dict()
    assert doc["effects"][0]["answer"].startswith("pivot, tile slips")


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"motion": "spin"}, r"t\.toml: \[\[conditions\]\] #1 key 'motion': expected one of"),
        ({"radius": 1.0}, r"key 'radius': does not apply to a rotate"),
        ({"angle_deg": "90"}, r"key 'angle_deg': expected a finite number, got '90'"),
        ({"decel": 1.0}, r"key 'decel': applies only to stop = \"gradual\""),
        ({"terrain": "ice"}, r"unknown terrain 'ice'"),
    ],
)
def test_bad_experiment_files_get_one_sentence(change: dict, message: str) -> None:  # type: ignore[type-arg]
    cond = {"label": "a", "motion": "rotate", "angle_deg": 90, **change}
    with pytest.raises(SimError, match=message):
        _exp([cond])


def test_bad_effect_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(SimError, match=r"\[\[effects\]\] #1 key 'b': expected a condition label"):
        _exp([{"label": "a", "motion": "rotate", "angle_deg": 90}], [{"a": "a", "b": "z"}])
    with pytest.raises(SimError, match="no such experiment file or built-in experiment"):
        load_experiment("nope")
    bad = tmp_path / "x.toml"
    bad.write_text("[experiment\n")
    with pytest.raises(SimError, match=r"x\.toml: not valid TOML"):
        load_experiment(bad)


def test_an_experiment_file_is_read_as_a_protocol_file_is(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """One reader for both kinds of file (odolab.sim.protocols.read_toml): the same size cap,
    the same sentences, the kind's own word in them."""
    from odolab.sim.protocols import MAX_TOML_BYTES, load_protocol

    big = tmp_path / "big.toml"
    big.write_text("# " + "x" * MAX_TOML_BYTES + "\n")
    for load, what in ((load_experiment, "experiment"), (load_protocol, "protocol")):
        with pytest.raises(
            SimError, match=rf"big\.toml: 1,000,003 bytes; a {what} TOML is at most"
        ):
            load(big)
        with pytest.raises(SimError, match=rf"missing\.toml: cannot read the {what} \("):
            load(tmp_path / "missing.toml")
        with pytest.raises(SimError, match=rf"nope: no such {what} file or built-in {what}"):
            load("nope")


def test_effects_that_are_not_a_list_get_one_sentence() -> None:
    doc = {
        "experiment": {"name": "t", "repeats": 2},
        "conditions": [{"label": "a", "motion": "rotate", "angle_deg": 90}],
        "effects": 5,
    }
    with pytest.raises(SimError, match=r"t\.toml: \[\[effects\]\]: expected an array of tables"):
        parse_experiment(doc, "t.toml")
    doc = {"experiment": {"name": "t"}, "conditions": {"label": "a"}}
    with pytest.raises(SimError, match=r"\[\[conditions\]\]: expected an array of tables"):
        parse_experiment(doc, "t.toml")


@pytest.mark.parametrize(
    ("change", "message"),
    [
        # each of these ran for ever (a drive of 1e9 m, or at 1e-300 m/s) or overflowed (1e300 m/s)
        ({"speed": 1e300}, r"key 'speed': expected a wheel speed from 0\.01 to 5 m/s, got 1e\+300"),
        ({"speed": 1e-300}, r"key 'speed': expected a wheel speed from 0\.01 to 5 m/s"),
        ({"motion": "straight", "distance": 1e9, "angle_deg": None}, r"key 'distance': .*1000 m"),
        ({"angle_deg": -1e9}, r"key 'angle_deg': expected at most 18000 degrees either way"),
        ({"motion": "curve", "radius": 1e9}, r"key 'radius': expected at most 250 m"),
        ({"stop": "gradual", "decel": 1e9}, r"key 'decel': expected at most 3600 s"),
    ],
)
def test_out_of_range_conditions_get_one_sentence(change: dict, message: str) -> None:  # type: ignore[type-arg]
    cond = {"label": "a", "motion": "rotate", "angle_deg": 90, **change}
    cond = {k: v for k, v in cond.items() if v is not None}
    with pytest.raises(SimError, match=r"t\.toml: \[\[conditions\]\] #1 " + message):
        _exp([cond])


def test_a_condition_too_long_or_too_short_to_drive_is_refused_before_driving() -> None:
    # 1000 m at 0.01 m/s: 100000 s of simulation per repeat
    slow = _exp([{"label": "far", "motion": "straight", "distance": 1000, "speed": 0.01}])
    with pytest.raises(SimError, match=r"t\.toml: condition 'far' would last 100000 s.*3600 s"):
        run_experiment(slow, TRUTH_PRESETS["jaguar-lab-tracked"], NOMINAL)
    # 1 um at 0.01 m/s: not one encoder tick, so the odometry's distance was 0 (ZeroDivisionError)
    tiny = _exp([{"label": "tiny", "motion": "straight", "distance": 1e-6, "speed": 0.01}])
    with pytest.raises(SimError, match=r"condition 'tiny' moves the faster wheel 0\.0 encoder"):
        run_experiment(tiny, TRUTH_PRESETS["jaguar-lab-tracked"], NOMINAL)


def test_too_many_drives_are_refused_before_driving() -> None:
    exp = _exp([{"label": f"c{i}", "motion": "rotate", "angle_deg": 90} for i in range(3)])
    calls: list[int] = []
    with pytest.raises(SimError, match=r"t\.toml: 3 conditions x 50000 repeats are 150000 drives"):
        run_experiment(
            exp, TRUTH_PRESETS["jaguar-lab-tracked"], NOMINAL, repeats=50_000,
            progress=lambda done, total: calls.append(done),
        )  # fmt: skip
    assert calls == []


@pytest.mark.parametrize(
    ("where", "text"),
    [
        ("experiment", "e\x1b[31mRED"),  # a colour change
        ("question", "q\x1b]0;title\x07?"),  # sets the terminal's title
        ("label", "a\x1b[2J"),  # clears the screen
        ("label", "a\u202eb"),  # reverses the text after it
    ],
)
def test_names_with_control_characters_are_refused(where: str, text: str) -> None:
    # they reached the terminal raw through `odolab sim questions` (and the JSON, a report)
    cond = {"label": text if where == "label" else "a", "motion": "rotate", "angle_deg": 90}
    head = {"name": text} if where == "experiment" else {}
    if where == "question":
        head = {"question": text}
    key = {"experiment": "name"}.get(where, where)
    with pytest.raises(SimError, match=rf"key '{key}': .*control or invisible character"):
        _exp([cond], **head)


def test_a_trend_over_a_key_that_never_changes_is_refused() -> None:
    # trend = "radius" over turns in place (radius 0 in each) gave no trend and no word of why
    cond = [{"label": f"r{i}", "motion": "rotate", "angle_deg": 90 * (i + 1)} for i in range(2)]
    with pytest.raises(SimError, match=r"key 'trend': radius is 0 in every condition; expected"):
        _exp(cond, trend="radius")


@pytest.mark.parametrize(
    "model", [IcrModel(0.36, -0.22, 0.05), ExtendedDiffDrive(0.9, 1.05, 1.3)], ids=lambda m: m.kind
)
@pytest.mark.parametrize(
    ("cond", "forward", "turn"),
    [
        ({"motion": "rotate", "angle_deg": 180}, 0.0, math.pi),
        ({"motion": "curve", "angle_deg": -90, "radius": 1.5}, 1.5 * math.pi / 2, -math.pi / 2),
        ({"motion": "pivot", "angle_deg": 90, "held": "right"}, None, math.pi / 2),
        ({"motion": "straight", "distance": -2.0}, -2.0, 0.0),
    ],
)
def test_legs_make_any_nominal_model_do_the_condition(
    model: KinematicModel,
    cond: dict,
    forward: float | None,
    turn: float,  # type: ignore[type-arg]
) -> None:
    # the legs came from the differential drive of the track width whatever the nominal model:
    # with --params of an ICR robot, "rotate 180" turned its odometry by 180 * 0.56 / 0.58 deg
    nominal = NOMINAL.with_(model=model)
    (c,) = _exp([{"label": "c", **cond}]).conditions  # type: ignore[attr-defined]
    (leg,) = legs_for(c, nominal)
    fwd, _, dth = nominal.coefficients.body_motion(
        leg.left * leg.duration, leg.right * leg.duration
    )
    assert dth == pytest.approx(turn, abs=1e-12)
    if forward is not None:
        assert fwd == pytest.approx(forward, abs=1e-12)
    if c.motion == "pivot":
        assert leg.right == 0.0  # the held track stands
    assert max(abs(leg.left), abs(leg.right)) == pytest.approx(0.3)

"""odolab.core.motion: each kind of motion carries its rules; words parse strictly, with one sentence."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from odolab.core import trials
from odolab.core.errors import InsufficientDataError, OdolabError, SimError
from odolab.core.motion import DriveShape, Motion, MotionKind, MotionWordError


def test_motion_kind_rules() -> None:
    rules = {
        kind: (kind.turns_in_place, kind.needs, kind.readings, kind.fits) for kind in MotionKind
    }
    assert rules == {
        MotionKind.ROTATION: (True, "angle", ("initial", "final", "turns"), (Motion.ROTATION,)),
        MotionKind.TRANSLATION: (
            False,
            "distance",
            ("x", "y"),
            (Motion.X, Motion.Y_FORWARD, Motion.Y_REVERSE),
        ),
        MotionKind.PIVOT: (True, "angle", ("initial", "final", "turns"), (Motion.PIVOT,)),
        MotionKind.SQUARE: (False, "side", ("x", "y"), ()),
        MotionKind.FREE: (False, None, ("x", "y"), ()),
    }
    # the old home still names the same type
    assert trials.MotionKind is MotionKind


def test_fitted_motion_rules() -> None:
    rules = {
        m: (m.angular, m.unit, m.ratio_unit, m.ideal_line, m.is_y, m.ratio_sign, m.noise_residual)
        for m in Motion
    }
    assert rules == {
        Motion.ROTATION: (True, "rad", "rad/rad", True, False, 1.0, "turn"),
        Motion.PIVOT: (True, "rad", "rad/rad", True, False, 1.0, "turn"),
        Motion.X: (False, "m", "m/m", True, False, 1.0, "x"),
        Motion.Y_FORWARD: (False, "m", "m/m", False, True, 1.0, "y"),
        Motion.Y_REVERSE: (False, "m", "m/m", False, True, -1.0, "y"),
    }
    assert [m.command for m in Motion] == [
        MotionKind.ROTATION,
        MotionKind.PIVOT,
        *[MotionKind.TRANSLATION] * 3,
    ]
    assert (Motion.of_y(2.0), Motion.of_y(0.0), Motion.of_y(-0.5)) == (
        Motion.Y_FORWARD,
        Motion.Y_FORWARD,
        Motion.Y_REVERSE,
    )


def test_fitted_motion_labels_are_the_analysis_table() -> None:
    from odolab.analysis.core import MOTIONS

    rot = {"x": "predicted rotation (rad)", "y": "actual rotation (rad)"}
    y_err = {"x": "predicted x (m)", "y": "y error, predicted - actual (m)"}
    metres = {"unit": "m", "ratio_unit": "m/m"}
    table = dict(MOTIONS)
    assert list(table) == ["rotation", "pivot", "x", "y_forward", "y_reverse"]  # report order
    assert table == {
        "rotation": {**rot, "unit": "rad", "ratio_unit": "rad/rad"},
        "pivot": {**rot, "unit": "rad", "ratio_unit": "rad/rad"},
        "x": {"x": "predicted x (m)", "y": "actual x (m)", **metres},
        "y_forward": {**y_err, **metres},
        "y_reverse": {**y_err, **metres},
    }


def test_error_and_sides() -> None:
    pred = np.array([1.0, 2.0])
    act = np.array([0.75, 2.5])
    # 1:1 fits form predicted - actual; a y fit's series already is the error
    np.testing.assert_array_equal(Motion.X.errors(pred, act), [0.25, -0.5])
    np.testing.assert_array_equal(Motion.ROTATION.errors(pred, act), [0.25, -0.5])
    np.testing.assert_array_equal(Motion.Y_REVERSE.errors(pred, act), act)
    assert Motion.Y_FORWARD.actual_side(0.5) == -0.5
    assert Motion.PIVOT.actual_side(0.5) == 0.5
    # a turn scales with the radius over the track, a distance with the radius alone
    p = np.array([10.0])
    np.testing.assert_allclose(Motion.ROTATION.rescaled(p, (0.1, 0.11), (0.5, 0.4)), [13.75])
    np.testing.assert_allclose(Motion.X.rescaled(p, (0.1, 0.11), (0.5, 0.4)), [11.0])


def test_noise_weights() -> None:
    b = 0.5
    a_r, a_l, turn = MotionKind.ROTATION.noise_weights(-2 * math.pi, b)
    np.testing.assert_allclose(a_r, [[2 * math.pi / (2 * b)]])
    np.testing.assert_array_equal(a_r, a_l)
    assert turn == pytest.approx(2 * math.pi)
    # a pivot rolls only the moving wheel, the one opposite the held track
    a_r, a_l, _ = MotionKind.PIVOT.noise_weights(math.pi, b, held="left")
    assert (a_r[0, 0], a_l[0, 0]) == pytest.approx((math.pi / b, 0.0))
    a_r, a_l, _ = MotionKind.PIVOT.noise_weights(math.pi, b, held="right")
    assert (a_r[0, 0], a_l[0, 0]) == pytest.approx((0.0, math.pi / b))
    a_r, a_l, turn = MotionKind.TRANSLATION.noise_weights(-2.0, b)
    np.testing.assert_allclose(a_r, [[0.5, -2.0], [-2.0, 8 / 0.75]])
    np.testing.assert_allclose(a_l, [[0.5, 2.0], [2.0, 8 / 0.75]])
    assert turn == 0.0
    with pytest.raises(InsufficientDataError, match="a square has no noise record"):
        MotionKind.SQUARE.noise_weights(1.0, b)


def test_drive_shape_rules() -> None:
    rules = {s: (s.angular, s.needs, s.takes, s.mirrors) for s in DriveShape}
    assert rules == {
        DriveShape.ROTATE: (True, ("angle_deg",), ("angle_deg",), True),
        DriveShape.CURVE: (True, ("angle_deg", "radius"), ("angle_deg", "radius"), True),
        DriveShape.PIVOT: (True, ("angle_deg",), ("angle_deg", "held"), True),
        DriveShape.STRAIGHT: (False, ("distance",), ("distance",), False),
    }


@pytest.mark.parametrize("vocabulary", [MotionKind, Motion, DriveShape])
def test_words_round_trip(vocabulary: type[MotionKind | Motion | DriveShape]) -> None:
    for member in vocabulary:
        word = member.value
        assert vocabulary.parse(word) is member
        assert vocabulary.parse(member) is member
        # stored as the same word in notebooks, CSV and JSON
        assert (str(member), f"{member}", json.dumps({member: member})) == (
            word,
            word,
            json.dumps({word: word}),
        )


@pytest.mark.parametrize(
    ("vocabulary", "words"),
    [
        (MotionKind, "rotation, translation, pivot, square, free"),
        (Motion, "rotation, pivot, x, y_forward, y_reverse"),
        (DriveShape, "rotate, curve, pivot, straight"),
    ],
)
@pytest.mark.parametrize("bad", ["Rotation", " pivot", "rot", "", None, 3])
def test_bad_words_are_one_sentence(
    vocabulary: type[MotionKind | Motion | DriveShape], words: str, bad: object
) -> None:
    with pytest.raises(MotionWordError) as err:
        vocabulary.parse(bad, "trials.csv row 4")
    text = str(err.value)
    assert text.startswith("trials.csv row 4: ")
    assert text.endswith(f"{bad!r} is not one of {words}")
    assert "\n" not in text and "Traceback" not in text
    assert isinstance(err.value, (OdolabError, ValueError))


def test_bad_word_with_the_callers_error() -> None:
    with pytest.raises(SimError, match=r"^motion 'spin' is not one of rotate, curve"):
        DriveShape.parse("spin", error=SimError)


def test_noise_record_and_condition_parse_their_words() -> None:
    from odolab.analysis.noise import NoiseRecord
    from odolab.analysis.questions import Condition

    z = np.zeros((1, 1))
    rec = NoiseRecord("pivot", np.zeros(1), z, z, z)  # type: ignore[arg-type]
    assert rec.kind is MotionKind.PIVOT
    with pytest.raises(MotionWordError, match="noise record: motion kind 'spin'"):
        NoiseRecord("spin", np.zeros(1), z, z, z)  # type: ignore[arg-type]
    assert Condition("a", "straight", distance=1.0).motion is DriveShape.STRAIGHT  # type: ignore[arg-type]
    with pytest.raises(SimError, match="condition 'a': motion 'spin' is not one of"):
        Condition("a", "spin")  # type: ignore[arg-type]

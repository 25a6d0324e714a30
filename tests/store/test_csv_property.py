"""Property: any storable trial survives write_trials_csv -> read_trials_csv exactly."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

from hypothesis import given
from hypothesis import strategies as st

from odolab.params import RobotParams
from odolab.store.csvio import read_trials_csv, write_trials_csv
from odolab.trajectory import Pose
from odolab.trials import Command, Measurement, MotionKind, Trial, TrialStatus

from .conftest import fingerprint

finite = st.floats(allow_nan=False, allow_infinity=False)
positive = st.floats(min_value=1e-6, max_value=1e6)
#: a measured position within odolab.store.entry.MAX_POSITION_M (import refuses the rest)
position = st.floats(min_value=-100.0, max_value=100.0)
word = st.text(
    st.characters(blacklist_categories=("Cs", "Cc", "Zs", "Zl", "Zp")), min_size=1, max_size=12
)
free_text = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"))


@st.composite
def trials(draw: st.DrawFn) -> Trial:
    kind = draw(st.sampled_from(list(MotionKind)))
    params = RobotParams(
        # within odolab.params.RANGES: every entry path refuses implausible parameters
        left_wheel_radius=draw(st.floats(0.002, 2.0)),
        right_wheel_radius=draw(st.floats(0.002, 2.0)),
        track_width=draw(st.floats(0.01, 20.0)),
        ticks_per_rev=draw(st.floats(1.0, 1e8)),
        encoder_modulus=draw(st.one_of(st.none(), st.integers(2, 2**40))),
        name=draw(word),
    )
    heading = draw(finite)
    predicted = Pose(draw(finite), draw(finite), draw(finite), draw(finite), heading)
    status = draw(st.sampled_from(list(TrialStatus)))
    measured = None
    if status is TrialStatus.MEASURED or (status is TrialStatus.EXCLUDED and draw(st.booleans())):
        raw = draw(st.dictionaries(st.sampled_from(["x_m", "reading", "temp_c"]), finite))
        measured = Measurement(
            instrument=draw(word),
            rotation=draw(st.one_of(st.none(), finite)),
            x=draw(position),
            y=draw(position),
            sigma_rotation=draw(st.one_of(st.none(), positive)),
            sigma_xy=draw(st.one_of(st.none(), positive)),
            raw=raw,
        )
    true = None
    if draw(st.booleans()):
        true = Pose(draw(finite), draw(finite), draw(finite), draw(finite), draw(finite))
    return Trial(
        trial_id=draw(word),
        campaign=draw(word),
        terrain=draw(word),
        command=Command(
            kind,
            angle=draw(st.one_of(st.none(), finite)),
            # a translation needs its distance (import refuses one without)
            distance=draw(
                finite if kind is MotionKind.TRANSLATION else st.one_of(st.none(), finite)
            ),
            side=draw(st.one_of(st.none(), positive)),
            direction=draw(st.one_of(st.none(), word)),
            speed=draw(st.one_of(st.none(), finite)),
        ),
        predicted=predicted,
        params=params,
        measured=measured,
        true=true,
        status=status,
        exclusion_reason=draw(word) if status is TrialStatus.EXCLUDED else None,
        notes=draw(free_text),
    )


@given(st.lists(trials(), min_size=1, max_size=5, unique_by=lambda t: t.trial_id))
def test_csv_round_trip_is_exact(items: list[Trial]) -> None:
    with tempfile.TemporaryDirectory() as d:
        path = write_trials_csv(Path(d) / "t.csv", [(t, None) for t in items])
        back = read_trials_csv(path)
    # repr: exact to the bit, -0.0 included
    assert repr([fingerprint(p.trial) for p in back]) == repr([fingerprint(t) for t in items])
    assert all(not math.isnan(p.trial.predicted.heading) for p in back)

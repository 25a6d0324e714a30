"""A command line the application layer hands to a face (issue 41): settings by their library
names, each face writes its own flags."""

from __future__ import annotations

import shlex

import pytest

from odolab.app.models import Invocation
from odolab.cli.wording import flag


def test_the_cli_writes_an_invocation_with_its_flags_and_quotes_user_paths() -> None:
    inv = Invocation(
        ("evaluate", "runs/a b.csv"),
        (("format", ("csv",)), ("nees", ()), ("nees_segment", ("1",))),
    )
    line = inv.line(flag)
    assert line == "odolab evaluate 'runs/a b.csv' --format csv --nees --nees-segment 1"
    assert shlex.split(line)[2] == "runs/a b.csv"
    # another face's words: the same invocation, other flags
    assert inv.line(lambda name: f"<{name}>").endswith("'<format>' csv '<nees>' '<nees_segment>' 1")


def test_a_setting_without_words_is_refused_when_the_invocation_is_made() -> None:
    with pytest.raises(KeyError, match="nees_segmnt"):
        Invocation(("evaluate",), (("nees_segmnt", ("1",)),))

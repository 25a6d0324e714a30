"""Errors carry data, faces choose the words (issue 41): the library names a setting by its
library name, the CLI by its flag, the web by its form field."""

from __future__ import annotations

import pickle
import re
from pathlib import Path

import pytest

from odolab.cli.wording import FLAGS, said, worded
from odolab.core.errors import NEUTRAL, OPTION_NAMES, OdolabError, ParamsError, opt
from odolab.core.params import PRESETS
from odolab.export.ros2_controller import controller_numbers
from odolab.robot.config import RunConfig
from odolab.robot.errors import RobotConfigError
from odolab.serve.wording import FIELDS, WEB

SRC = Path(__file__).resolve().parents[2] / "src" / "odolab"
FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9]+(-[a-z0-9]+)*")
NAMED = re.compile(
    r"""\{\{([a-z][a-z0-9_]*)\}\}|\bopt\(["']([a-z_0-9]+)["']\)|\boption=["']([a-z_0-9]+)["']"""
    r"""|\b(?:Bound|_check_positive)\(\s*["']([a-z_0-9]+)["']"""
)


def _named_settings() -> dict[str, str]:
    """Every setting the library names, with where: ``opt("x")``, ``option="x"``, a ``{{x}}``
    mark, the first argument of a ``Bound`` or a ``_check_positive`` (errors.py, which defines
    the marks, left out)."""
    found: dict[str, str] = {}
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC)
        if rel.parts[0] in ("cli", "serve") or rel == Path("core/errors.py"):
            continue
        text = path.read_text(encoding="utf-8")
        for m in NAMED.finditer(text):
            name = next(g for g in m.groups() if g)
            found.setdefault(name, f"{rel}:{text.count(chr(10), 0, m.start()) + 1}")
    return found


def test_every_setting_the_library_names_has_library_words_and_a_flag() -> None:
    named = _named_settings()
    assert {"nees_segment", "robot", "watchdog", "db"} <= set(named)  # the scan finds them
    missing = {k: w for k, w in named.items() if k not in OPTION_NAMES or k not in FLAGS}
    assert not missing, f"settings without words or flag (add them to both tables): {missing}"
    assert set(FLAGS) == set(OPTION_NAMES)
    assert all(re.fullmatch(r"--[a-z][a-z0-9]*(-[a-z0-9]+)*", f) for f in FLAGS.values())
    assert all(not FLAG.search(w) for w in OPTION_NAMES.values()), "library words with a flag"
    assert set(FIELDS) <= set(OPTION_NAMES)


def test_an_error_carries_the_setting_and_each_face_words_it() -> None:
    with pytest.raises(RobotConfigError) as info:
        RunConfig(rate=5000)
    err = info.value
    assert (err.option, err.value, err.allowed) == ("rate", 5000, "[5, 1000] Hz")
    assert str(err) == "the loop rate is 5000; expected a number in [5, 1000] Hz"
    assert worded(err) == "--rate is 5000; expected a number in [5, 1000] Hz"
    # a sentence naming two settings names both in the face's words
    with pytest.raises(RobotConfigError) as info:
        RunConfig(watchdog=0.2, link_timeout=0.1)
    assert worded(info.value).startswith("--link-timeout is 0.1 s, shorter than --watchdog 0.2 s")
    assert not FLAG.search(str(info.value))
    # the web has a field for the robot; a setting it has no field for keeps the library's words
    err = OdolabError(f"{opt('robot')} is missing; expected it with {opt('nees_segment')}")
    assert WEB.error(err) == "robot is missing; expected it with the NEES segment length"


def test_the_fields_survive_a_process_boundary_and_a_re_raise() -> None:
    err = ParamsError(option="window", value=0, allowed="a whole number of cycles")
    back = pickle.loads(pickle.dumps(err))
    assert (back.option, back.value, worded(back)) == ("window", 0, worded(err))
    assert worded(err) == "--window is 0; expected a whole number of cycles"
    again = OdolabError(err)  # re-raised as another error: the marks are kept
    assert worded(again) == worded(err) and str(again) == str(err)


def test_hints_and_written_text_use_the_face_words() -> None:
    nominal = PRESETS["jaguar-lite"]
    with pytest.raises(ParamsError) as info:
        controller_numbers(nominal, speed=-1)
    assert worded(info.value) == "--speed is -1; expected a positive number up to 100"
    assert NEUTRAL.say("{{db}} and {{nosuch}}") == "the lab notebook's path and {{nosuch}}"
    assert said("run it with {{db}} FILE") == "run it with --db FILE"

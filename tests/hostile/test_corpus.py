"""Every case of the hostile-input corpus (tests/hostile/corpus.py) is refused with one
sentence naming what, where and what was expected (issue 39: each of these was read, integrated
or imported without a word, or gave a traceback)."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from hostile.corpus import CASES, prepare
from odolab.core.errors import OdolabError


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_corpus_is_refused_with_one_sentence(name: str, tmp_path: Path) -> None:
    case = CASES[name]
    path = prepare(case, tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's overflow warning reached the user
        with pytest.raises(OdolabError) as caught:
            case.read(path)
    text = str(caught.value)
    assert "\n" not in text.strip(), text
    for part in case.expect:
        assert part in text, (name, text)

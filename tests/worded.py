"""Assertions on an error's sentence as the CLI shows it (its settings named by their flags)."""

from __future__ import annotations

import re
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest

from odolab.cli.wording import worded

__all__ = ["raises_worded", "worded"]


@contextmanager
def raises_worded(
    expected: type[BaseException] | tuple[type[BaseException], ...], *, match: str
) -> Iterator[Any]:
    """``pytest.raises(expected, match=match)``, matched against the sentence the CLI prints
    (:func:`odolab.cli.wording.worded`); ``str()`` names the settings in the library's words."""
    with pytest.raises(expected) as info:
        yield info
    text = worded(info.value)
    assert re.search(match, text), f"{match!r} not found in {text!r}"

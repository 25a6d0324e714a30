"""Issue 41's figures may only go down (tests/arch/figures.py prints them).

Each ceiling is the figure measured when the one-home work landed; a change that adds a motion-kind
string test, a model-kind branch outside models/, a `--flag` in library code, a second copy of the
wrap, unwrap or step, an import circle, a function over 80 lines or an `Any` fails here with the
places that broke it. Lower a ceiling when a figure goes down.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

import figures

# the figures when issue 41's work landed (2026-11-28); goals in figures.py's docstring
CEILINGS = {
    "motion-kind string tests": 0,
    "model-kind branches outside models/": 0,
    "flag strings outside cli/ and serve/": 0,
    "angle wrap copies": 1,
    "counter unwrap copies": 1,
    "odometry step copies": 1,
    "import circles": 0,
    "functions over 80 lines": 7,
    "Any in code": 103,
}


@pytest.fixture(scope="module")
def measured() -> dict[str, figures.Figure]:
    return {f.name: f for f in figures.measure(with_duplicates=False) if f.count >= 0}


@pytest.mark.parametrize("name", sorted(CEILINGS))
def test_figure_does_not_grow(measured: dict[str, figures.Figure], name: str) -> None:
    fig = measured[name]
    assert fig.count <= CEILINGS[name], (
        f"{name}: {fig.count} (ceiling {CEILINGS[name]}); the places:\n" + "\n".join(fig.places)
    )


def test_every_function_over_80_lines_says_why(measured: dict[str, figures.Figure]) -> None:
    """Issue 41: at most 10 functions over 80 lines, each with a reason (``# long: ...``)."""
    silent = [p for p in measured["functions over 80 lines"].places if "no reason given" in p]
    assert not silent, "functions over 80 lines without a '# long: ...' comment:\n" + "\n".join(
        silent
    )

"""Every numeric bound in the statistical tests says what was measured (issue 36).

A test that asserts a fitted, simulated or sampled number against a bound is testing luck when
the bound sits a few percent from the value: another machine's floating point or another seed
moves the number across it (``skid-dynamic`` NEES 1.2389 against 1.2602 did). So each such
``assert`` in the folders below carries, in a comment on its own lines or in the comment block
just above it, the word "measured" and the range it was measured in (``tests/bounds.py``
measures it over seeds; docs/testing.md says how), or it is listed in :data:`EXCEPTIONS` with
why it needs none.

What counts as a bound: an ``assert`` whose test compares (``<``, ``<=``, ``>``, ``>=``) with a
float literal of magnitude 1e-6 or more, or calls ``approx``/``isclose``/``allclose`` with such a
``rel``/``abs``/``rtol``/``atol``. Smaller tolerances check arithmetic, not statistics.
"""

from __future__ import annotations

import ast
import io
import tokenize
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FOLDERS = ("tests/models", "tests/metrics", "tests/calibration", "tests/analysis")
#: how many lines above an assert its comment may be (a comment block over two or three asserts)
REACH = 4

#: (file, first line of the assert's source, stripped) -> why it needs no measured range
EXCEPTIONS: dict[tuple[str, str], str] = {}


def _floats(node: ast.AST) -> Iterator[float]:
    for n in ast.walk(node):
        if isinstance(n, ast.Constant) and isinstance(n.value, float) and abs(n.value) >= 1e-6:
            yield n.value


def is_bound(test: ast.expr) -> bool:
    for n in ast.walk(test):
        if (
            isinstance(n, ast.Compare)
            and any(isinstance(o, ast.Lt | ast.LtE | ast.Gt | ast.GtE) for o in n.ops)
            and any(True for _ in _floats(n))
        ):
            return True
        if isinstance(n, ast.Call) and ast.unparse(n.func).endswith(
            ("approx", "isclose", "allclose")
        ):
            for kw in n.keywords:
                if kw.arg in ("rel", "abs", "rtol", "atol") and any(
                    True for _ in _floats(kw.value)
                ):
                    return True
    return False


def _comments(source: str) -> dict[int, str]:
    out: dict[int, str] = {}
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            out[tok.start[0]] = tok.string
    return out


def undocumented(path: Path, rel: str | None = None) -> list[tuple[int, str]]:
    """The bound asserts of ``path`` with no "measured" comment near them: (line, source)."""
    source = path.read_text(encoding="utf-8")
    lines = source.splitlines()
    comments = _comments(source)
    rel = rel if rel is not None else str(path.relative_to(ROOT))
    missing: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Assert) or not is_bound(node.test):
            continue
        first = lines[node.lineno - 1].strip()
        if (rel, first) in EXCEPTIONS:
            continue
        end = node.end_lineno or node.lineno
        own = any("measured" in comments.get(i, "").lower() for i in range(node.lineno, end + 1))
        above = any(
            "measured" in comments.get(i, "").lower()
            for i in range(max(1, node.lineno - REACH), node.lineno)
        )
        if not (own or above):
            missing.append((node.lineno, first))
    return missing


def _files() -> list[Path]:
    return sorted(p for folder in FOLDERS for p in (ROOT / folder).rglob("*.py"))


def test_every_statistical_bound_says_what_was_measured() -> None:
    missing = [
        f"{p.relative_to(ROOT)}:{line}: {src}" for p in _files() for line, src in undocumented(p)
    ]
    assert not missing, (
        f"{len(missing)} bound(s) without a 'measured' comment (the value's range over seeds; "
        "tests/bounds.py measures it):\n" + "\n".join(missing)
    )


def test_the_check_sees_bounds_and_comments(tmp_path: Path) -> None:
    """The rule itself: a bare bound is caught; a comment above or beside it, or a tolerance
    below 1e-6, passes."""
    sample = tmp_path / "test_sample.py"
    sample.write_text(
        "def test_a(x):\n"
        "    assert x < 0.5\n"
        "    # measured 0.1-0.2 over seeds 0-4; bound 0.5\n"
        "    assert x < 0.5\n"
        "    assert x > 0.01  # measured 0.1-0.2\n"
        "    assert abs(x) < 1e-9\n"
        "    assert len(x) > 3\n"
        "    y = 1\n"
        "    y = 2\n"
        "    assert x == pytest.approx(1.0, rel=0.05)\n",
        encoding="utf-8",
    )
    # line 2 has no comment; line 10 is more than REACH lines below line 5's
    assert [line for line, _ in undocumented(sample, rel="sample.py")] == [2, 10]


def test_every_exception_names_an_assert_that_exists() -> None:
    for (rel, first), why in EXCEPTIONS.items():
        assert why
        text = (ROOT / rel).read_text(encoding="utf-8")
        assert any(line.strip() == first for line in text.splitlines()), (rel, first)

"""Every JSON text odolab writes is strict JSON (RFC 8259): no ``NaN``, no ``Infinity``.

One function makes it (:func:`odolab.core.writing.strict_json`); a scan of src/odolab fails on any
other ``json.dump``/``json.dumps`` (unless it says ``allow_nan=False``) and on Starlette's
JSONResponse used anywhere but the web API's one strict subclass.
"""

from __future__ import annotations

import ast
import json
import math
from pathlib import Path

import numpy as np
import pytest

from odolab.core.writing import strict_json, strict_value

SRC = Path(__file__).resolve().parents[2] / "src" / "odolab"


def strict_loads(text: str) -> object:
    """``json.loads`` as a strict parser reads: ``NaN``, ``Infinity``, ``-Infinity`` refused."""

    def refuse(token: str) -> object:
        raise ValueError(f"not strict JSON: {token}")

    return json.loads(text, parse_constant=refuse)


def test_non_finite_numbers_become_null_at_any_depth() -> None:
    doc = {
        "a": math.nan,
        "b": [1.5, math.inf, -math.inf, (2, np.float32("nan"))],
        "c": {"d": np.array([[1.0, np.nan], [np.inf, 3.0]]), "e": np.float64(0.25)},
        "f": np.int64(7),
        "g": np.bool_(True),
        "h": "NaN",  # a string is text, not a number: kept
        np.int32(3): None,
    }
    text = strict_json(doc)
    assert strict_loads(text) == {
        "a": None,
        "b": [1.5, None, None, [2, None]],
        "c": {"d": [[1.0, None], [None, 3.0]], "e": 0.25},
        "f": 7,
        "g": True,
        "h": "NaN",
        "3": None,
    }
    assert strict_value((np.float16(np.inf),)) == [None]
    # finite numbers are written as json.dumps writes them (store lookups compare the text)
    same = {"x": 0.1, "y": [1, 2.5e-300], "z": None}
    assert strict_json(same, indent=None, sort_keys=True) == json.dumps(same, sort_keys=True)


def test_the_strict_parser_refuses_what_json_dumps_writes_by_default() -> None:
    """The check the CLI tests rely on can fail: Python's default writes NaN and Infinity."""
    for bad in (math.nan, math.inf, -math.inf):
        with pytest.raises(ValueError, match="not strict JSON"):
            strict_loads(json.dumps({"v": bad}))


# -- the scan: one way to make JSON text ---------------------------------------------------------

#: Where Starlette's JSONResponse may be used: the strict subclass every answer goes through.
_RESPONSE_HOME = "serve/security.py"


def json_writes(source: str) -> list[tuple[int, str]]:
    """``(line, what)`` of every call in ``source`` that makes JSON text other than through
    ``strict_json`` (``json.dumps``/``json.dump``, or the names imported from json, without
    ``allow_nan=False``), and every use of Starlette's ``JSONResponse``."""
    tree = ast.parse(source)
    aliases = {"json"}
    direct: set[str] = set()
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            aliases |= {a.asname or a.name for a in node.names if a.name == "json"}
        elif isinstance(node, ast.ImportFrom) and node.module == "json":
            direct |= {a.asname or a.name for a in node.names if a.name in ("dump", "dumps")}
        elif (
            isinstance(node, ast.ImportFrom)
            and node.module == "starlette.responses"
            and any(a.name == "JSONResponse" for a in node.names)
        ):
            found.append((node.lineno, "JSONResponse"))
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        f = node.func
        is_json = (
            isinstance(f, ast.Attribute)
            and f.attr in ("dump", "dumps")
            and isinstance(f.value, ast.Name)
            and f.value.id in aliases
        ) or (isinstance(f, ast.Name) and f.id in direct)
        strict = any(
            k.arg == "allow_nan" and isinstance(k.value, ast.Constant) and k.value.value is False
            for k in node.keywords
        )
        if is_json and not strict:
            found.append((node.lineno, ast.unparse(f)))
    return found


def test_the_scan_finds_every_way_round_the_function() -> None:
    bad = (
        "import json\nimport json as j\nfrom json import dumps as d\n"
        "from starlette.responses import JSONResponse\n"
        "json.dumps(x)\nj.dump(x, f, allow_nan=True)\nd(x, indent=2)\n"
    )
    assert [w for _, w in json_writes(bad)] == ["JSONResponse", "json.dumps", "j.dump", "d"]
    good = "import json\njson.dumps(x, allow_nan=False)\njson.loads(t)\nstrict_json(x)\n"
    assert json_writes(good) == []


def test_odolab_makes_json_text_only_through_strict_json() -> None:
    offenders = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        if rel == "core/writing.py":
            continue
        text = path.read_text(encoding="utf-8")
        if "dump" not in text and "JSONResponse" not in text:  # nothing to find: skip the parse
            continue
        for line, what in json_writes(text):
            if what == "JSONResponse" and rel == _RESPONSE_HOME:
                continue
            offenders.append(f"src/odolab/{rel}:{line}: {what}")
    assert offenders == [], "make JSON text with odolab.core.writing.strict_json:\n" + "\n".join(
        offenders
    )

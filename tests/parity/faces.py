"""The faces, each asked the same question: the CLI's JSON, the web API, the web pages (numbers
read from the HTML) and the report's ``results.json``."""

from __future__ import annotations

import html
import json
import re
from pathlib import Path
from typing import Any

from starlette.testclient import TestClient

from odolab.cli import main
from odolab.serve import ServeSettings, create_app

LOCAL = "http://127.0.0.1:8000"

_ROW = re.compile(
    r'<tr class="row" data-motion="([^"]*)" data-terrain="([^"]*)">.*?'
    r'<td class="n"[^>]*>(\d+)</td>\s*<td class="ratio"[^>]*?data-value="([^"]*)"[^>]*>([^<]*)</td>'
    r'<td data-label="95 % CI">([^<]*)</td>',
    re.S,
)


def client(db: Path) -> TestClient:
    return TestClient(create_app(ServeSettings(db=db)), base_url=LOCAL)


def cli(*args: str) -> None:
    code = main([str(a) for a in args])
    assert code == 0, args


def cli_json(path: Path, *args: str) -> dict[str, Any]:
    cli(*args, "--json", str(path))
    doc: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    return doc


def table_of(rows: list[dict[str, Any]]) -> dict[tuple[str, str], tuple[int, float]]:
    """Table I as {(motion, terrain): (n, ratio)}."""
    return {(r["motion"], r["terrain"]): (int(r["n"]), float(r["ratio"])) for r in rows}


def page_table1(text: str) -> dict[tuple[str, str], tuple[int, float]]:
    """Table I read from the web page: n, and the ratio the page shows (its data-value, checked
    against the digits on the page: the interval rule, the value with its interval's decimals,
    as the CLI and the report write it)."""
    out: dict[tuple[str, str], tuple[int, float]] = {}
    for motion, terrain, n, exact, shown, ci in _ROW.findall(text):
        value = float(exact)
        decimals = len(shown.strip().partition(".")[2])
        ends = ci.strip().strip("[]").split(", ")
        assert all(len(e.partition(".")[2]) == decimals for e in ends), (shown, ci)
        assert f"{value:.{decimals}f}" == shown.strip(), (motion, terrain, exact, shown)
        out[(html.unescape(motion), html.unescape(terrain))] = (int(n), value)
    assert out, "no Table I rows on the page"
    return out


def csrf_of(page: str) -> str:
    found = re.search(r'name="csrf" value="([0-9a-f]{64})"', page)
    assert found
    return found.group(1)


def page_calibration(text: str) -> dict[str, float]:
    """The new parameters the calibration page shows (data-value, checked against its digits)."""
    out: dict[str, float] = {}
    for key in ("left_wheel_radius", "right_wheel_radius", "track_width"):
        found = re.search(rf'id="{key}"[^>]*?data-value="([^"]*)"[^>]*>([^<]*)<', text)
        assert found, (key, text[:2000])
        value = float(found.group(1))
        assert format(value, ".5g") == found.group(2).strip()
        out[key] = value
    return out


def geometry(params: dict[str, Any]) -> dict[str, float]:
    return {k: float(params[k]) for k in ("left_wheel_radius", "right_wheel_radius", "track_width")}

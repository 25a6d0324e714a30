"""The pages in Debian's Chromium at a phone's 400 px and a computer's 1280 px (issue 30): a
negative y typed and stored, no page wider than the screen, Table I as cards, tap targets of
44 px, the phone-size figures chosen by the phone. With ``$ODOLAB_SCREENSHOTS`` set, a
screenshot of every page goes there.

Skipped as ``test_browser.py`` is when Chromium or Playwright is missing (a failure in CI).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from urllib.parse import quote

import pytest

from odolab.serve import ServeSettings, run_in_thread
from odolab.store import Notebook

from .conftest import HOSTILE_TRIAL, PATH_TRIAL
from .test_browser import _chromium

PAGES = [
    "/",
    "/table1",
    "/params",
    "/calibrate",
    "/data",
    "/trial?id=R20",
    "/trial?id=F1",
    "/trial?id=R1",
    f"/trial?id={quote(HOSTILE_TRIAL, safe='')}",
    f"/trial?id={quote(PATH_TRIAL, safe='')}",
    "/trial?id=nope",  # the error page
    "/report",
]


@pytest.fixture
def shots() -> Path | None:
    """Where screenshots go: ``$ODOLAB_SCREENSHOTS`` when set (none otherwise: they are the
    slow part)."""
    where = os.environ.get("ODOLAB_SCREENSHOTS")
    if not where:
        return None
    folder = Path(where)
    folder.mkdir(parents=True, exist_ok=True)
    return folder


@pytest.fixture(scope="module")
def chromium_browser() -> Iterator[Any]:
    """One Chromium for the module (Playwright launches Debian's, never downloads one)."""
    chromium = _chromium()
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        b = pw.chromium.launch(
            executable_path=chromium,
            args=["--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage"],
        )
        try:
            yield b
        finally:
            b.close()


@pytest.fixture
def browser(chromium_browser: Any, lab_db: Path) -> Iterator[tuple[Any, str]]:
    """(browser, base URL) with the server running on an ephemeral loopback port."""
    with run_in_thread(ServeSettings(db=lab_db)) as info:
        yield chromium_browser, info.base_url


def _shot(page: Any, shots: Path | None, name: str) -> None:
    if shots is not None:
        page.screenshot(path=shots / name, full_page=True)


def _page(browser: Any, width: int) -> Any:
    context = browser.new_context(
        viewport={"width": width, "height": 900}, device_scale_factor=1,
        is_mobile=width < 600, has_touch=width < 600,
    )  # fmt: skip
    page = context.new_page()
    page.set_default_timeout(30_000)
    return page


def _overflow(page: Any) -> int:
    """How many CSS px the page is wider than the window (0: no sideways scrolling)."""
    return int(page.evaluate("document.documentElement.scrollWidth - window.innerWidth"))


def test_a_negative_y_typed_on_a_phone_is_stored(
    browser: tuple[Any, str], lab_db: Path, shots: Path | None
) -> None:
    b, base = browser
    page = _page(b, 400)
    page.goto(base + "/trial?id=F1")
    y = page.locator("#y")
    # a phone shows its text keyboard (with a minus key), not the decimal keypad (without)
    assert y.get_attribute("type") == "text" and y.get_attribute("inputmode") == "text"
    page.fill("#x", "2.46")
    page.fill("#y", "-0.031")
    assert page.evaluate("document.querySelector('#y').validity.valid")
    page.fill("#y", "left")
    assert page.evaluate("document.querySelector('#y').validity.patternMismatch")
    page.fill("#y", "-0.031")
    page.click("#save")
    assert page.inner_text("[role=status]") == "measured: x 2.460 y -0.031 m [meterstick]"
    _shot(page, shots, "phone-negative-y.png")
    with Notebook(lab_db) as nb:
        m = nb.get_trial("F1").measured
    assert m is not None and m.y == -0.031 and m.x == 2.46


@pytest.mark.parametrize("width", [400, 1280])
def test_no_page_is_wider_than_the_screen(
    browser: tuple[Any, str], shots: Path | None, width: int
) -> None:
    b, base = browser
    page = _page(b, width)
    wide = {}
    for i, path in enumerate(PAGES):
        page.goto(base + path)
        _shot(page, shots, f"w{width}-{i:02d}.png")
        if _overflow(page) > 0:
            wide[path] = _overflow(page)
    # a refused entry (a long message, the values kept)
    page.goto(base + "/trial?id=R20")
    page.fill("#initial", "100")
    page.fill("#final", "136")
    page.fill("#turns", "3")
    page.click("#save")
    assert page.get_attribute("#turns", "aria-invalid") == "true"
    _shot(page, shots, f"w{width}-refused.png")
    if _overflow(page) > 0:
        wide["refused"] = _overflow(page)
    assert wide == {}


def test_table1_is_cards_on_a_phone_and_a_table_on_a_computer(browser: tuple[Any, str]) -> None:
    b, base = browser
    phone = _page(b, 400)
    phone.goto(base + "/table1")
    row = phone.locator("#table1 tr.row").first
    assert row.evaluate("e => getComputedStyle(e).display") == "block"
    assert not phone.locator("#table1 tr.head").is_visible()  # the header row is hidden...
    ci = row.locator("td").nth(4)
    label = ci.evaluate("e => getComputedStyle(e, '::before').content")
    assert label == '"95 % CI"'  # ...and each value carries its column's name
    box = row.bounding_box()
    assert box["x"] >= 0 and box["x"] + box["width"] <= 400
    computer = _page(b, 1280)
    computer.goto(base + "/table1")
    first = computer.locator("#table1 tr.row").first
    assert first.evaluate("e => getComputedStyle(e).display") == "table-row"
    cells = first.locator("td")
    tops = {round(cells.nth(i).bounding_box()["y"]) for i in range(cells.count())}
    assert len(tops) == 1  # one line per row (the cells were wrapped into two lines)


def test_tap_targets_are_44_px(browser: tuple[Any, str]) -> None:
    b, base = browser
    page = _page(b, 400)
    page.goto(base + "/trial?id=R1")
    small = {}
    for selector in ("nav a", "a.back", "label.check", "#save", "#exclude", "details summary"):
        for i in range(page.locator(selector).count()):
            box = page.locator(selector).nth(i).bounding_box()
            if box["height"] < 44:
                small[f"{selector}[{i}]"] = box["height"]
    assert small == {}
    page.goto(base + "/")
    card = page.locator("ul.trials li").first
    link = card.locator("a")
    cbox, lbox = card.bounding_box(), link.bounding_box()
    # the whole card is the link (only its text was)
    assert abs(cbox["height"] - lbox["height"]) <= 2 and abs(cbox["width"] - lbox["width"]) <= 2
    link.click(position={"x": lbox["width"] - 5, "y": lbox["height"] - 5})  # its corner
    page.wait_for_url("**/trial?id=**")


def test_the_phone_gets_the_phone_figure(browser: tuple[Any, str], lab_db: Path) -> None:
    b, base = browser
    for width, size in ((400, "size=phone"), (1280, None)):
        page = _page(b, width)
        page.goto(base + "/table1")
        img = page.locator("img.plot").first
        img.scroll_into_view_if_needed()
        for _ in range(300):  # drawn on request (wait_for_function is refused by the CSP)
            if img.evaluate("e => e.complete && e.naturalWidth > 0"):
                break
            page.wait_for_timeout(100)
        src = img.evaluate("e => e.currentSrc")
        assert (size in src) if size else ("size=" not in src), src
        natural = img.evaluate("e => [e.naturalWidth, e.naturalHeight]")
        assert natural == ([726, 1012] if size else [936, 598])
        shown = img.bounding_box()["width"]
        # the smallest text (8 pt on 3.3 in, 9 pt on 7.2 in) at the width it is shown
        smallest = 8 * shown / (72 * 3.3) if size else 9 * shown / (72 * 7.2)
        assert smallest >= 11, (width, shown)


def test_the_measurement_history_is_cards_on_a_phone(
    browser: tuple[Any, str], lab_db: Path
) -> None:
    from .conftest import cli

    cli("trials", "measure", "R1", "--initial", "320", "--final", "0", "--turns", "0",
        "--replace", "--db", str(lab_db))  # fmt: skip
    b, base = browser
    page = _page(b, 400)
    page.goto(base + "/trial?id=R1")
    row = page.locator("#history tr").nth(1)
    assert row.evaluate("e => getComputedStyle(e).display") == "block"
    readings = row.locator("td").nth(5)
    assert readings.evaluate("e => getComputedStyle(e, '::before').content") == '"readings"'
    assert "compass before 324°" in readings.inner_text()
    assert _overflow(page) == 0

"""What a user on a phone meets (issue 30): numbers a phone can type (a negative y), refusals in
the page's words with the field marked, post/redirect/get, 405, the icon, colours that read,
figure text that stays legible at a phone's width, the API's refusals of JSON that is not a
number."""

from __future__ import annotations

import json
import re
from pathlib import Path
from urllib.parse import quote

import pytest
from starlette.testclient import TestClient

from odolab.serve import ServeSettings, create_app
from odolab.store import Notebook

LOCAL = "http://127.0.0.1:8000"
TEMPLATES = Path(__file__).parents[2] / "src" / "odolab" / "serve" / "templates"


@pytest.fixture
def c(lab_db: Path) -> TestClient:
    return TestClient(create_app(ServeSettings(db=lab_db)), base_url=LOCAL)


def csrf_of(page: str) -> str:
    found = re.search(r'name="csrf" value="([0-9a-f]{64})"', page)
    assert found
    return found.group(1)


def measure(c: TestClient, trial_id: str, **fields: str) -> object:
    token = csrf_of(c.get(f"/trial?id={quote(trial_id, safe='')}").text)
    return c.post(
        "/trial/measure", data={"csrf": token, "id": trial_id, **fields}, follow_redirects=False
    )


def input_tag(page: str, name: str) -> str:
    found = re.search(rf'<input id="{name}" [^>]*>', page)
    assert found, name
    return found.group(0)


# -- numbers a phone can type ---------------------------------------------------------------


def test_x_and_y_are_text_a_phone_can_sign(c: TestClient) -> None:
    page = c.get("/trial?id=F1").text
    for name in ("x", "y"):
        tag = input_tag(page, name)
        # type=number with inputmode=decimal gave iOS's keypad, which has no minus key
        assert 'type="text"' in tag and 'inputmode="text"' in tag, tag
        assert "pattern=" in tag
    pattern = re.search(r'pattern="([^"]+)"', input_tag(page, "y"))
    assert pattern
    regex = re.compile(pattern.group(1).replace("&#34;", '"'))
    for ok in ("-0.03", "0.03", "+1", "−0.5", "-,5", "2.", " -1.25 "):
        assert regex.fullmatch(ok), ok
    for bad in ("abc", "1-", "--1", "1e3", "1.2.3", ""):
        assert not regex.fullmatch(bad), bad


@pytest.mark.parametrize(("typed", "stored"), [("-0.03", -0.03), ("−0,03", -0.03), ("0.02", 0.02)])
def test_a_negative_y_is_stored(c: TestClient, lab_db: Path, typed: str, stored: float) -> None:
    r = measure(c, "F2", x="0.98", y=typed)
    assert r.status_code == 303  # type: ignore[attr-defined]
    with Notebook(lab_db) as nb:
        m = nb.get_trial("F2").measured
    assert m is not None and m.y == stored and m.x == 0.98


def test_a_refused_field_is_marked_and_described(c: TestClient, lab_db: Path) -> None:
    r = measure(c, "F1", x="2.4", y="left")
    assert r.status_code == 400  # type: ignore[attr-defined]
    page = r.text  # type: ignore[attr-defined]
    assert "y is &#39;left&#39;; type a number such as 12.5 or -0.031" in page
    y, x = input_tag(page, "y"), input_tag(page, "x")
    assert 'aria-invalid="true"' in y and 'aria-describedby="error"' in y
    assert "aria-invalid" not in x
    assert 'id="error"' in page  # what aria-describedby points at
    # the store's refusal of a miscounted turn marks the turns
    r = measure(c, "R20", initial="100", final="136", turns="3")
    page = r.text  # type: ignore[attr-defined]
    assert 'aria-invalid="true"' in input_tag(page, "turns")
    assert "aria-invalid" not in input_tag(page, "initial")
    with Notebook(lab_db) as nb:
        assert nb.get_trial("F1").measured is None and nb.get_trial("R20").measured is None


def test_an_exclusion_without_a_reason_marks_the_reason(c: TestClient) -> None:
    token = csrf_of(c.get("/trial?id=R2").text)
    r = c.post("/trial/exclude", data={"csrf": token, "id": "R2", "reason": " "})
    assert r.status_code == 400 and "excluding trial R2 needs a reason" in r.text
    assert 'aria-invalid="true"' in input_tag(r.text, "reason")


def test_sigma_zero_is_refused_not_replaced_by_the_default(c: TestClient, lab_db: Path) -> None:
    # it was stored with the default 0.005 m: "sigma or METERSTICK_SIGMA_M"
    r = measure(c, "F1", x="2.4", y="0", sigma="0")
    assert r.status_code == 400  # type: ignore[attr-defined]
    page = r.text  # type: ignore[attr-defined]
    assert "σ is 0; it must be more than 0 (leave it empty for the default" in page
    assert 'aria-invalid="true"' in input_tag(page, "sigma")
    assert re.search(r"<details open>", page)  # the refused field is shown, not folded away
    api = c.post("/api/trials/F1/measurement", json={"x": 2.4, "y": 0, "sigma": 0})
    assert api.status_code == 400 and api.json()["error"].startswith('"sigma" is 0; it must be')
    with Notebook(lab_db) as nb:
        assert nb.get_trial("F1").measured is None


def test_a_number_of_5000_digits_is_a_sentence(c: TestClient, lab_db: Path) -> None:
    r = measure(c, "F1", x="1" * 5000, y="0")
    assert r.status_code == 400  # type: ignore[attr-defined]
    assert "x has 5000 characters; type a measurement of at most 24" in r.text  # type: ignore[attr-defined]
    for digits in (5000, 4000):  # past Python's int limit (4300), and under it
        body = '{"x": 1' + "0" * digits + ', "y": 0}'
        api = c.post(
            "/api/trials/F1/measurement", content=body, headers={"content-type": "application/json"}
        )
        error = api.json()["error"]
        assert api.status_code == 400
        assert "sys." not in error and "set_int_max_str_digits" not in error and len(error) < 200
    assert error == '"x" has 4001 digits; no measurement is that large'
    with Notebook(lab_db) as nb:
        assert nb.get_trial("F1").measured is None


@pytest.mark.parametrize(
    ("body", "error"),
    [
        ({"x": "2.4", "y": 0}, '"x" is text; send a JSON number, e.g. "x": 0.5 (not "0.5")'),
        ({"x": 2.4, "y": [0]}, '"y" is a list; send a JSON number, e.g. "y": 0.5 (not "0.5")'),
        ({"x": 2.4, "y": True}, '"y" is true/false; send a JSON number, e.g. "y": 0.5 (not "0.5")'),
    ],
)
def test_the_api_wants_json_numbers(
    c: TestClient, lab_db: Path, body: dict[str, object], error: str
) -> None:
    r = c.post("/api/trials/F1/measurement", json=body)
    assert r.status_code == 400 and r.json() == {"error": error}
    with Notebook(lab_db) as nb:  # "2.4" was stored as 2.4
        assert nb.get_trial("F1").measured is None


# -- the page's own words ----------------------------------------------------------------


def test_messages_name_the_page_not_the_cli(c: TestClient) -> None:
    r = measure(c, "R1", initial="1", final="0", turns="0")  # already measured
    page = r.text  # type: ignore[attr-defined]
    assert "tick &#34;replace the measurement above&#34; to overwrite it" in page
    assert "--replace" not in page
    assert 'aria-invalid="true"' in re.search(r'<input type="checkbox"[^>]*>', page).group(0)  # type: ignore[union-attr]
    # a translation's fields posted to a rotation (the form cannot, a hand-made post can)
    r = measure(c, "R20", x="1", y="0")
    page = r.text  # type: ignore[attr-defined]
    assert "it is measured with the compass before and after and the whole turns" in page
    assert "--initial" not in page
    # the stored readings in words, not compass_final_deg
    trial = c.get("/trial?id=R1").text
    assert "Current readings: compass before 324°, compass after 0°, turns 0" in trial
    assert "compass_initial_deg" not in trial and "compass_final_deg" not in trial


# -- post/redirect/get, 405, the icon ------------------------------------------------------


def test_a_calibration_post_redirects_and_a_reload_records_nothing(
    c: TestClient, lab_db: Path
) -> None:
    from .conftest import cli

    for tid, x in (("F1", 2.31), ("F2", 0.93)):
        assert c.post(f"/api/trials/{tid}/measurement", json={"x": x, "y": 0.0}).status_code == 200
    cli("trials", "add", "--id", "F3", "--campaign", "fwd-lab", "--kind", "translation",
        "--distance", "1.5", "--predicted-x", "1.5", "--x", "1.39", "--y", "0.0",
        "--db", str(lab_db))  # fmt: skip
    token = csrf_of(c.get("/calibrate").text)
    r = c.post(
        "/calibrate",
        data={"csrf": token, "method": "ratios", "robot": "jaguar-lite", "terrain": "tile"},
        follow_redirects=False,
    )
    assert r.status_code == 303
    assert r.headers["location"] == "/calibrate?robot=jaguar-lite&version=2"
    for _ in range(2):  # the result page, and a reload of it
        page = c.get(r.headers["location"]).text
        assert "new jaguar-lite parameters version 2 recorded" in page
        # in words: no raw provenance keys, no CLI flag
        assert "<dt>distance ratio</dt>" in page and "<dt>distance_ratio</dt>" not in page
        assert "--campaign" not in page
    with Notebook(lab_db) as nb:
        assert nb.latest_params_version("jaguar-lite") == 2
    # another server (restarted) shows the stored version
    other = TestClient(create_app(ServeSettings(db=lab_db)), base_url=LOCAL)
    page = other.get(r.headers["location"]).text
    assert "jaguar-lite parameters version 2</strong>" in page and 'id="track_width"' in page


def test_an_import_redirects_and_only_this_server_says_so(c: TestClient, lab_db: Path) -> None:
    exported = c.get("/data/export", params={"format": "csv", "campaign": "fwd-lab"}).text
    rows = exported.replace("F1,", "G1,").replace("F2,", "G2,")
    token = csrf_of(c.get("/data").text)
    r = c.post(
        "/data/import",
        data={"csrf": token},
        files={"file": ("more.csv", rows.encode(), "text/csv")},
        follow_redirects=False,
    )
    assert r.status_code == 303, r.text
    assert r.headers["location"].startswith("/data?done=2+trials+imported+from+more.csv&sig=")
    assert "2 trials imported from more.csv" in c.get(r.headers["location"]).text
    forged = c.get("/data?done=1000+trials+imported&sig=" + "0" * 64).text
    assert "1000 trials imported" not in forged
    with Notebook(lab_db) as nb:
        assert {"G1", "G2"} <= set(nb.trial_ids())


@pytest.mark.parametrize("action", ["measurement", "exclude", "include"])
def test_get_on_a_post_route_is_405_with_allow(c: TestClient, action: str) -> None:
    r = c.get(f"/api/trials/R20/{action}")
    assert r.status_code == 405 and r.headers["allow"] == "POST"
    assert r.json() == {"error": f"/api/trials/R20/{action} takes POST (a JSON body), not GET"}
    page = c.get("/trial/measure")
    assert page.status_code == 405 and page.headers["allow"] == "POST"
    assert page.text == "/trial/measure does not take GET; it takes POST"


def test_a_trial_named_like_a_post_route_is_still_found(c: TestClient, lab_db: Path) -> None:
    from .conftest import cli

    cli("trials", "add", "--id", "A/measurement", "--campaign", "fwd-lab", "--kind",
        "translation", "--distance", "1", "--predicted-x", "1.0", "--db", str(lab_db))  # fmt: skip
    r = c.get("/api/trials/A/measurement")
    assert r.status_code == 200 and r.json()["trial_id"] == "A/measurement"


def test_the_icon_is_served(c: TestClient) -> None:
    r = c.get("/favicon.ico")
    assert r.status_code == 200 and r.headers["content-type"] == "image/svg+xml"
    assert r.content.startswith(b"<svg") and len(r.content) < 1024
    for path in ("/", "/table1", "/data"):
        assert '<link rel="icon" href="/favicon.ico"' in c.get(path).text


# -- colours and tap targets from the CSS ---------------------------------------------------


def _luminance(hex_colour: str) -> float:
    h = hex_colour.lstrip("#")
    if len(h) == 3:
        h = "".join(ch * 2 for ch in h)
    channels = [int(h[i : i + 2], 16) / 255 for i in (0, 2, 4)]
    lin = [v / 12.92 if v <= 0.03928 else ((v + 0.055) / 1.055) ** 2.4 for v in channels]
    return 0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2]


def contrast(fg: str, bg: str) -> float:
    """WCAG 2 contrast ratio of two sRGB colours."""
    a, b = sorted((_luminance(fg), _luminance(bg)), reverse=True)
    return (a + 0.05) / (b + 0.05)


def css_rule(selector: str) -> dict[str, str]:
    css = (TEMPLATES / "base.html.j2").read_text(encoding="utf-8")
    found = re.search(rf"^{re.escape(selector)} \{{([^}}]*)\}}", css, re.M)
    assert found, selector
    out = {}
    for decl in found.group(1).split(";"):
        if ":" in decl:
            key, value = decl.split(":", 1)
            out[key.strip()] = value.strip()
    return out


def test_contrast_helper_against_known_values() -> None:
    assert contrast("#000", "#fff") == pytest.approx(21.0)
    assert contrast("#6b6f76", "#eef0f2") == pytest.approx(4.42, abs=0.01)  # the number


@pytest.mark.parametrize("badge", [".awaiting", ".measured", ".excluded"])
def test_badges_read_at_4_5_to_1(badge: str) -> None:
    rule = css_rule(badge)
    variables = css_rule(":root")
    colour = rule["color"]
    if colour.startswith("var("):
        colour = variables[colour[4:-1]]
    assert contrast(colour, rule["background"]) >= 4.5, (badge, rule)


def test_tap_targets_are_44_px_in_the_css() -> None:
    # 2.75rem of 16 px = 44 px: nav links, "← trials", the whole trial card, the checkbox row
    for selector in ("nav a", "a.back", "ul.trials li a", "label.check"):
        assert "min-height:2.75rem" in css_rule(selector).get("min-height", "") or (
            css_rule(selector).get("min-height") == "2.75rem"
        ), selector
    assert css_rule("ul.trials li.card")["padding"] == "0"  # the link fills the card


# -- figures drawn for their width ----------------------------------------------------------


def test_figure_text_stays_legible_where_it_is_shown() -> None:
    from odolab.serve.plots import LAYOUTS

    for name, lay in LAYOUTS.items():
        assert lay.px(lay.text_pt) >= 11.0, name
    # the old figure: 6 in wide, 7 pt legend, shown 368 px wide on a phone
    assert 7 * 368 / (72 * 6.0) < 6.0


def test_the_fit_figure_has_its_legend_under_the_axes(lab_db: Path) -> None:
    from matplotlib.figure import Figure

    from odolab.app.analysis import analyze
    from odolab.report.figures import plot_fit

    with Notebook(lab_db) as nb:
        m = analyze(nb).analysis.motions[0]
    fig = Figure(figsize=(6, 4), layout="constrained")
    ax = fig.subplots()
    plot_fit(m, ax)
    fig.canvas.draw()
    legend = ax.get_legend()
    assert legend is not None
    box = legend.get_window_extent()
    assert box.y1 <= ax.get_window_extent().y0  # below the axes: on none of the data


def test_api_json_body_errors_speak_json(c: TestClient) -> None:
    bad = c.post(
        "/api/trials/F1/measurement", content='{"x": ', headers={"content-type": "application/json"}
    )
    assert bad.json() == {
        "error": "the body is not valid JSON (expecting value at line 1, column 7)"
    }
    assert json.loads(bad.text)


# -- the report: drawn once per state of the notebook ---------------------------------------


def test_the_report_is_drawn_once_per_notebook_state(
    c: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    import odolab.app.report

    drawn: list[int] = []

    def fake_report(nb: Notebook, req: object) -> bytes:
        drawn.append(len(nb.load_trials(with_logs=False)))
        return f"<!doctype html><p>report {len(drawn)}</p>".encode()

    monkeypatch.setattr(odolab.app.report, "report_html", fake_report)
    first = c.get("/report.html")
    assert first.status_code == 200 and first.text == "<!doctype html><p>report 1</p>"
    assert first.headers["content-disposition"] == 'attachment; filename="odolab-report.html"'
    assert c.get("/report.html").text == first.text  # kept: not drawn again
    page = c.get("/report").text
    assert "Ready: drawn in" in page and 'http-equiv="refresh"' not in page
    assert drawn == [10]
    # a measurement changes the notebook: the next report is drawn anew
    assert c.post("/api/trials/F1/measurement", json={"x": 2.4, "y": 0.0}).status_code == 200
    assert c.get("/report.html").text == "<!doctype html><p>report 2</p>"
    assert drawn == [10, 10]


def test_the_report_page_says_how_far_the_drawing_is(
    c: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    import threading

    import odolab.app.report

    release = threading.Event()

    def slow_report(nb: Notebook, req: object) -> bytes:
        release.wait(10)
        return b"<!doctype html>"

    monkeypatch.setattr(odolab.app.report, "report_html", slow_report)
    page = c.get("/report").text
    # it was "It takes a few seconds" while a download took 22-46 s
    assert "a few seconds" not in page
    assert "Drawing the report: 0 s so far." in page
    assert '<meta http-equiv="refresh" content="3">' in page
    # no download button while the page reloads itself (a reload would cut the download)
    assert 'id="download-report"' not in page
    release.set()
    assert c.get("/report.html").text == "<!doctype html>"
    assert "Ready: drawn in" in c.get("/report").text


def test_the_reports_figures_are_legible_at_a_phones_width(lab_db: Path, tmp_path: Path) -> None:
    """The report shows each figure at the column's width, 368 px on a 400 px phone: its
    smallest text (10 pt) must stay 11 px there (it was 9 pt on 6 in: 7.7 px)."""
    from PIL import Image

    from odolab.app.report import write_notebook_report
    from odolab.report.html import _RC

    c = TestClient(create_app(ServeSettings(db=lab_db)), base_url=LOCAL)
    body = {"initial": 100, "final": 136, "turns": 9}  # (the fixture's four rotations alone:
    assert c.post("/api/trials/R20/measurement", json=body).status_code == 200  # a traceback)
    with Notebook(lab_db) as nb:
        out = write_notebook_report(nb, tmp_path / "report")
    smallest_pt = min(_RC["font.size"], _RC["legend.fontsize"])
    figures = sorted((out.path.parent / "figures").glob("*.png"))
    assert figures
    for png in figures:
        with Image.open(png) as im:
            inches = im.width / im.info["dpi"][0]
        assert smallest_pt * 368 / (72 * inches) >= 11, (png.name, inches)


def test_table1s_figures_are_of_the_tables_selection(c: TestClient) -> None:
    # the figures' addresses lacked ?campaign=: they showed every campaign's fits
    page = c.get("/table1", params=[("campaign", "rot-lab"), ("exclude_campaign", "fwd-lab")]).text
    assert re.search(
        r'src="/table1/fit\.png\?i=0&amp;v=[0-9a-f]+&amp;campaign=rot-lab&amp;exclude_campaign=fwd-lab"',
        page,
    )
    assert "&amp;campaign=rot-lab&amp;exclude_campaign=fwd-lab&amp;size=phone" in page
    assert "&amp;campaign=" not in c.get("/table1").text


def test_a_report_that_fails_is_a_sentence(c: TestClient, monkeypatch: pytest.MonkeyPatch) -> None:
    import odolab.app.report

    def broken(nb: Notebook, req: object) -> bytes:
        return float(None)  # type: ignore[arg-type,return-value]  # a bug, as in numfmt.with_ci

    monkeypatch.setattr(odolab.app.report, "report_html", broken)
    r = c.get("/report.html")
    assert r.status_code == 400
    assert "the report could not be drawn (TypeError in odolab; the server&#39;s log" in r.text
    assert "Traceback" not in r.text


def test_two_robots_the_calibrate_sentence_names_the_form_not_the_flag(tmp_path: Path) -> None:
    from tests.parity.notebooks import make_notebook

    gen = make_notebook(tmp_path, 0, two_robots=True)
    c = TestClient(create_app(ServeSettings(db=gen.db)), base_url=LOCAL)
    form = c.post(
        "/calibrate", data={"csrf": csrf_of(c.get("/calibrate").text), "method": "ratios"}
    )
    assert form.status_code == 400
    assert "name the one to calibrate (choose it under robot)" in form.text
    api = c.post("/api/calibrate", json={"method": "ratios"})
    assert api.json()["error"].endswith('name the one to calibrate (send "robot")')
    assert "--robot" not in form.text and "--robot" not in api.text

"""The demo's report read in a real browser at 1280, 800 and 400 px: nothing wider than the screen.

Headless Chromium loads the report inside an iframe of the wanted width (Chromium's own window is
at least 500 px wide), a small script measures every table, figure, image and block against the
iframe's viewport and posts the result to the page around it, whose DOM Chromium prints. A
screenshot of each width is written too (to $ODOLAB_SCREENSHOTS when set, for a person to look
at). CI installs Debian's chromium (.ci/run); without a browser the test is skipped.
"""

from __future__ import annotations

import html
import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

#: `make test-fast` leaves these out (two demos rendered in chromium at three widths); `make test` and CI run them
pytestmark = pytest.mark.slow


MEASURE = """<script>
window.addEventListener('load', function () {
  var vw = document.documentElement.clientWidth, bad = [], n = 0;
  document.querySelectorAll('table, figure, img, section, p, h1, h2, h3, ul, dl, details')
    .forEach(function (e) {
      var r = e.getBoundingClientRect();
      if (r.width === 0) { return; }
      n += 1;
      if (r.right > vw + 0.5 || r.left < -0.5) {
        bad.push(e.tagName + '#' + (e.id || '') + ' right=' + Math.round(r.right));
      }
    });
  parent.postMessage(JSON.stringify({vw: vw, scroll: document.documentElement.scrollWidth,
                                     checked: n, bad: bad}), '*');
});
</script>"""


def _browser() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


@pytest.fixture(scope="module", params=["jaguar-lab", "jaguar-lab-tracked"])
def report(request: pytest.FixtureRequest) -> Path:
    """The demo's report, on the default truth and on the tracked one (whose report has the
    slip model's section and its wide tables)."""
    if _browser() is None:
        pytest.skip("no chromium to render the report (.ci/run installs it)")
    if request.param == "jaguar-lab-tracked":  # the session's demos (conftest)
        return Path(request.getfixturevalue("tracked_demo").report)
    return Path(request.getfixturevalue("default_demo")[0].report)


def _chromium(*args: str) -> str:
    browser = _browser()
    assert browser is not None
    cmd = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars"]
    cmd += ["--allow-file-access-from-files", *args]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    return proc.stdout


@pytest.mark.parametrize("width", [1280, 800, 400])
def test_no_table_or_figure_is_wider_than_the_screen(
    report: Path, width: int, tmp_path: Path
) -> None:
    page = report.read_text(encoding="utf-8")
    assert '<meta name="viewport" content="width=device-width, initial-scale=1">' in page
    (tmp_path / "report.html").write_text(page.replace("</body>", MEASURE + "</body>"))
    frame = (
        '<!DOCTYPE html><html><body style="margin:0">'
        f'<iframe src="report.html" style="width:{width}px;height:1400px;border:0"></iframe>'
        '<pre id="out"></pre><script>window.addEventListener("message", function (e) {'
        'document.getElementById("out").textContent = e.data; });</script></body></html>'
    )
    (tmp_path / "frame.html").write_text(frame)
    window = f"--window-size={max(width, 500)},1400"
    dom = _chromium(
        window, "--virtual-time-budget=8000", "--dump-dom", (tmp_path / "frame.html").as_uri()
    )
    m = re.search(r'<pre id="out">(.*?)</pre>', dom, re.S)
    assert m and m.group(1), dom[-2000:]
    got = json.loads(html.unescape(m.group(1)))
    assert got["vw"] == width  # the report's own viewport is the wanted width
    assert got["checked"] > 50  # tables, figures, paragraphs were measured
    assert got["bad"] == [], got["bad"]
    assert got["scroll"] <= got["vw"]  # nothing makes the page scroll sideways
    shots = Path(os.environ.get("ODOLAB_SCREENSHOTS", tmp_path))
    shots.mkdir(parents=True, exist_ok=True)
    (shots / "report.html").write_text(page)
    (shots / f"frame-{width}.html").write_text(frame)
    png = shots / f"report-{width}.png"
    _chromium(window, f"--screenshot={png}", (shots / f"frame-{width}.html").as_uri())
    assert png.exists() and png.stat().st_size > 10_000

"""The pages' work: calibration recorded and downloadable, parameter versions, the run plot."""

from __future__ import annotations

import io
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread
from starlette.testclient import TestClient

from odolab.serve import ServeSettings, create_app
from odolab.store import Notebook

from .conftest import cli, measured_pairs, rotation_ratio

LOCAL = "http://127.0.0.1:8000"


def csrf_of(page: str) -> str:
    found = re.search(r'name="csrf" value="([0-9a-f]{64})"', page)
    assert found
    return found.group(1)


def test_calibrate_ratios_and_download_the_toml(lab_db: Path) -> None:
    c = TestClient(create_app(ServeSettings(db=lab_db)), base_url=LOCAL)
    token = csrf_of(c.get("/calibrate").text)
    # one terrain has no x fit yet: the library's sentence, nothing recorded
    r = c.post("/calibrate", data={"csrf": token, "method": "ratios", "robot": "jaguar-lite",
                                   "terrain": "tile"})  # fmt: skip
    assert r.status_code == 400
    assert (
        "ratios calibration needs both a rotation fit and an x fit on terrain &#39;tile&#39;"
        in r.text
    )
    # three straight runs on tile, measured by meterstick
    straight = [("F1", 2.5, 2.31), ("F2", 1.0, 0.93)]
    for tid, _, x in straight:
        assert c.post(f"/api/trials/{tid}/measurement", json={"x": x, "y": 0.01}).status_code == 200
    cli("trials", "add", "--id", "F3", "--campaign", "fwd-lab", "--kind", "translation",
        "--distance", "1.5", "--predicted-x", "1.5", "--x", "1.39", "--y", "0.0",
        "--db", str(lab_db))  # fmt: skip
    straight.append(("F3", 1.5, 1.39))
    r = c.post("/calibrate", data={"csrf": token, "method": "ratios", "robot": "jaguar-lite",
                                   "terrain": "tile"})  # fmt: skip
    assert r.status_code == 200, r.text
    assert "new jaguar-lite parameters version 2 recorded" in r.text
    # by hand: ratios are the slopes through the origin; r' = r q_d, b' = b q_d / q_r
    q_d = sum(p * a for _, p, a in straight) / sum(p * p for _, p, _ in straight)
    q_r = rotation_ratio(measured_pairs())
    toml = c.get("/params.toml", params={"robot": "jaguar-lite", "version": "2"})
    assert toml.status_code == 200
    assert toml.headers["content-disposition"] == 'attachment; filename="jaguar-lite-v2.toml"'
    doc = tomllib.loads(toml.text)
    robot = doc["robot"]
    assert robot["left_wheel_radius"] == robot["right_wheel_radius"]
    assert abs(robot["left_wheel_radius"] - 0.0835 * q_d) < 1e-12
    assert abs(robot["track_width"] - 0.56 * q_d / q_r) < 1e-12
    assert doc["provenance"]["method"] == "ratios"
    assert sorted(doc["provenance"]["source_trials"]) == ["F1", "F2", "F3", "R1", "R2", "R3", "R4"]
    params_page = c.get("/params").text
    assert "v2" in params_page and "ratios" in params_page
    with Notebook(lab_db) as nb:
        assert nb.latest_params_version("jaguar-lite") == 2
    missing = c.get("/params.toml", params={"robot": "jaguar-lite", "version": "9"})
    assert missing.status_code == 404


def test_run_plot_of_a_trial_with_an_encoder_log(lab_db: Path) -> None:
    import dataclasses

    from odolab.core.odometry import integrate
    from odolab.core.trials import EncoderLog

    t = np.linspace(0.0, 4.0, 81)
    per_metre = 380 / (2 * np.pi * 0.0835)
    left = np.round(per_metre * 1.0 * t / 4.0).astype(np.int64)
    right = np.round(per_metre * 1.02 * t / 4.0).astype(np.int64)  # a slight left curve
    with Notebook(lab_db) as nb:
        template = nb.get_trial("F2")
        final = integrate(t, left, right, template.params).final
        nb.add_trial(
            dataclasses.replace(
                template,
                trial_id="L1",
                predicted=final,
                encoder_log=EncoderLog(t, left, right, modulus=32768),
            )
        )
    c = TestClient(create_app(ServeSettings(db=lab_db)), base_url=LOCAL)
    page = c.get("/trial?id=L1").text
    assert 'src="/trial/plot.png?id=L1"' in page
    png = c.get("/trial/plot.png?id=L1")
    assert png.status_code == 200 and png.headers["content-type"] == "image/png"
    img = imread(io.BytesIO(png.content))
    assert img.shape[:2] == (442, 936)  # 7.2 x 3.4 in at 130 dpi, side by side
    # a phone (under 600 px) gets its own rendering: one panel above the other, 3.3 in wide
    assert 'media="(max-width: 37.5rem)" srcset="/trial/plot.png?id=L1&amp;size=phone"' in page
    phone = imread(io.BytesIO(c.get("/trial/plot.png?id=L1&size=phone").content))
    assert phone.shape[:2] == (1276, 726)
    assert c.get("/trial/plot.png?id=F1").status_code == 404  # no log: no plot
    assert "no run to plot" in c.get("/trial?id=F1").text


def test_parameter_versions_show_the_model_and_noise_as_the_cli_does(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The web listed only radii and track: an ICR or slip version looked like its nominal."""
    import html

    from odolab.cli import main
    from odolab.core.models import IcrModel
    from odolab.core.params import PRESETS, NoiseParams

    db = tmp_path / "lab.db"
    icr = PRESETS["jaguar-lite"].with_(
        model=IcrModel(0.3, -0.28, 0.04), noise=NoiseParams(1e-4, 2e-4, 0.01)
    )
    with Notebook(db) as nb:
        nb.add_params_version(icr, method="lsq")
    page = TestClient(create_app(ServeSettings(db=db)), base_url=LOCAL).get("/params").text
    assert main(["trials", "params-versions", "jaguar-lite", "--db", str(db)]) == 0
    line = capsys.readouterr().out
    words = icr.model_words()
    assert [label for label, _ in words] == ["model", "noise"]
    for label, text in words:
        assert f"; {label} {text}" in line.replace("\n", "")
        assert f"<dt>{label}</dt><dd>{html.escape(text)}</dd>" in page
    assert "icr (y_icr_left 0.3, y_icr_right -0.28, x_icr 0.04 m)" in page


def test_a_slip_version_is_summed_up_not_listed(tmp_path: Path) -> None:
    """34 numbers in a row filled a phone's screen; the file keeps them all."""
    from odolab.core.models import SlipModel
    from odolab.core.params import PRESETS

    slip = PRESETS["jaguar-lite"].with_(
        model=SlipModel(
            yaw_w=-0.154,
            fwd_v=-0.118,
            yaw_v=-0.0794,
            lat_w=0.01,
            k_yaw=0.115,
            q_fwd=6e-11,
            d_turn=0.0117,
        )
    )
    ((label, text),) = slip.model_words()
    assert label == "model"
    assert text.startswith("slip (24 coefficients, the largest yaw_w -0.154, fwd_v -0.118, yaw_v")
    assert "variance terms k_yaw 0.115, d_turn 0.0117, those under 1e-6 not shown" in text
    assert "lat_w" not in text and "q_fwd" not in text
    db = tmp_path / "lab.db"
    with Notebook(db) as nb:
        nb.add_params_version(slip, method="lsq")
    page = TestClient(create_app(ServeSettings(db=db)), base_url=LOCAL).get("/params").text
    assert "<dt>model</dt><dd>slip (24 coefficients, the largest yaw_w -0.154" in page

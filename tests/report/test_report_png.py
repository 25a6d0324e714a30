"""odolab's figures (the report's, the web pages', the fleet's) are PNGs of the pixels
Matplotlib's ``savefig`` draws, written as opaque RGB at zlib level 1
(odolab.core.writing.write_png: half the encoding time of savefig's RGBA at level 6, and
smaller)."""

from __future__ import annotations

import io
from pathlib import Path

import matplotlib as mpl
import numpy as np
import pytest
from matplotlib.figure import Figure
from PIL import Image

from odolab.core.writing import write_png


def _figure() -> Figure:
    rng = np.random.default_rng(3)
    fig = Figure(figsize=(4.8, 3.0), dpi=120)
    ax = fig.add_subplot()
    ax.plot(np.cumsum(rng.standard_normal(300)), label="a walk")
    ax.scatter(rng.random(50), rng.random(50), alpha=0.5)  # translucent marks on white
    ax.set_title("σ of the error, $10^{-3}$ m")
    ax.legend()
    return fig


def test_the_png_has_savefigs_pixels_without_the_alpha(tmp_path: Path) -> None:
    fig = _figure()
    buf = io.BytesIO()
    with mpl.rc_context(mpl.rcParamsDefault):  # savefig as Matplotlib's defaults draw it
        fig.savefig(buf, format="png")
    saved = Image.open(buf)
    drawn = np.asarray(saved)
    assert drawn.shape[2] == 4 and int(drawn[..., 3].min()) == 255  # opaque: alpha says nothing
    out = tmp_path / "fig.png"
    write_png(fig, out)
    img = Image.open(out)
    assert img.format == "PNG" and img.mode == "RGB" and img.size == (576, 360)
    assert np.array_equal(np.asarray(img), drawn[..., :3])
    assert img.info["dpi"] == pytest.approx(saved.info["dpi"])  # a document places it as sized
    # compressed: measured 31,056 bytes against 28,543 for the same pixels at level 6 (1.09x;
    # zlib 1.2.13; zlib-ng's level 1 may compress less); bound 1.5x, far below level 0 (20x)
    level6 = io.BytesIO()
    img.save(level6, format="PNG", compress_level=6)
    assert out.stat().st_size < 1.5 * len(level6.getvalue())


def test_at_another_dpi_it_is_savefigs_image_at_that_dpi() -> None:
    """The web pages draw each figure at their layout's dpi (odolab.serve.plots)."""
    fig = _figure()
    buf = io.BytesIO()
    with mpl.rc_context(mpl.rcParamsDefault):
        fig.savefig(buf, format="png", dpi=200)
    drawn = np.asarray(Image.open(buf))
    out = io.BytesIO()
    write_png(_figure(), out, dpi=200)
    img = Image.open(out)
    assert img.size == (960, 600)
    assert img.info["dpi"] == pytest.approx((200, 200), abs=0.01)  # (PNG keeps dots per metre)
    assert np.array_equal(np.asarray(img), drawn[..., :3])

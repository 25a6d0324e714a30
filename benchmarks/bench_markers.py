"""Marker PDFs as vector squares against the raster way they were written before (issue 36).

Both write the same markers at the same size in the same run: ``odolab markers``' own writer
(``write_marker_files``: the cells as one filled path) and, as the baseline, the marker's PNG
pixels embedded in the PDF through ``imshow`` (what ``odolab markers`` did until 2026-11-29).
Prints the best time of each, their ratio and the PDFs' sizes.

    PYTHONPATH=src python benchmarks/bench_markers.py [--ids 0 1 2 3 4] [--size 0.2] [--repeats 3]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from _timing import best  # benchmarks/_timing.py (run as python benchmarks/...)

from odolab.tracking.markers import marker_image, write_marker_files


def raster_pdf(marker_id: int, size: float, dpi: int, out: Path) -> Path:
    """The baseline: the marker's pixels at ``dpi``, embedded at true size, with a caption as
    odolab's sheet has."""
    from matplotlib.figure import Figure

    pixels = round(size / 0.0254 * dpi)
    img = marker_image(marker_id, pixels)
    total_in = size / 0.0254 * img.shape[0] / pixels
    fig = Figure(figsize=(total_in + 1.2, total_in + 1.6))
    w, h = fig.get_size_inches()
    ax = fig.add_axes((0.6 / w, 1.0 / h, total_in / w, total_in / h))
    ax.imshow(img, cmap="gray", vmin=0, vmax=255, interpolation="none")
    ax.set_axis_off()
    fig.text(0.5, 0.3 / h, f"DICT_4X4_50 id {marker_id}: black square", ha="center", fontsize=9)
    path = out / f"raster_{marker_id}.pdf"
    fig.savefig(path, format="pdf")
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ids", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    ap.add_argument("--size", type=float, default=0.2)
    ap.add_argument("--dpi", type=int, default=300)
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        out = Path(d)
        vector = best(lambda: write_marker_files(a.ids, a.size, out, dpi=a.dpi), a.repeats)
        png_only = best(
            lambda: write_marker_files(a.ids, a.size, out, dpi=a.dpi, pdf=False), a.repeats
        )
        raster = best(lambda: [raster_pdf(i, a.size, a.dpi, out) for i in a.ids], a.repeats)
        vec_kb = sum((out / f"marker_{i}.pdf").stat().st_size for i in a.ids) / 1e3 / len(a.ids)
        ras_kb = sum((out / f"raster_{i}.pdf").stat().st_size for i in a.ids) / 1e3 / len(a.ids)
    vector_pdf = vector - png_only  # the PNGs are written either way
    print(f"{len(a.ids)} markers of {a.size} m at {a.dpi} dpi, best of {a.repeats}")
    print(f"  PDFs, vector squares (odolab markers)   {vector_pdf:.3f} s   {vec_kb:.1f} kB a PDF")
    print(f"  PDFs, raster (the PNG's pixels, before) {raster:.3f} s   {ras_kb:.1f} kB a PDF")
    print(f"raster / vector: {raster / vector_pdf:.1f}x")


if __name__ == "__main__":
    main()

"""CLI commands for ground truth from one long-exposure photo of a flashing LED:
``odolab track-photo`` and ``odolab sim photo`` (a rendered photo of the virtual robot to try it
on). See docs/ground-truth.md."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from odolab.app.sim import SIM_PHOTO_TRUTH, sim_photo_legs
from odolab.cli._apps import app, sim_app
from odolab.cli._output import echo
from odolab.cli.options import EncodersFormatOpt, NominalParamsOpt, RunFormat

__all__ = ["SIM_PHOTO_TRUTH", "sim_photo_legs"]

PhotoFolderOpt = Annotated[Path, typer.Argument(help="Folder to write the photo and its files in.")]
PhotoSecondsOpt = Annotated[
    float, typer.Option(help="Length of the drive and the exposure (s), 1 to 20.")
]
#: the flashing LED of ``sim photo`` and ``track-photo``
LedHzOpt = Annotated[float, typer.Option(help="The LED's flashing frequency (Hz).")]
DutyOpt = Annotated[float, typer.Option(help="The LED's ON fraction.")]
PhotoPhaseOpt = Annotated[
    float, typer.Option(help="When the LED's first ON interval starts (s, run clock).")
]
PhotoJpegOpt = Annotated[
    int | None, typer.Option(help="Write photo.jpg at this JPEG quality instead of a PNG.")
]
PhotoNoiseOpt = Annotated[float, typer.Option(help="Sensor noise (grey levels).")]
PhotoSeedOpt = Annotated[int, typer.Option(min=0, help="Random seed (sensor noise).")]


@sim_app.command("photo")
def sim_photo_cmd(
    folder: PhotoFolderOpt,
    seconds: PhotoSecondsOpt = 20.0,
    led_hz: LedHzOpt = 2.0,
    duty: DutyOpt = 0.5,
    phase: PhotoPhaseOpt = 0.13,
    jpeg: PhotoJpegOpt = None,
    noise: PhotoNoiseOpt = 2.0,
    seed: PhotoSeedOpt = 0,
) -> None:
    """Photograph the virtual robot's LED: a 2000x1500 long exposure from a camera 3 m up,
    tilted 50 deg, while the robot drives; writes photo.png (or .jpg), the floor points
    points.csv (u,v,x,y: the floor tiles' corners, as you would click them), the encoder log
    run.csv and the true path truth.csv."""
    from odolab.app.sim import SIM_PHOTO_TRUTH, PhotoRequest, simulate_photo

    request = PhotoRequest(folder, seconds, led_hz, duty, phase, jpeg, noise, seed)
    photo, duration = simulate_photo(request)
    rl, rr, b = SIM_PHOTO_TRUTH
    echo(
        f"{duration:.1f} s drive, LED {led_hz:g} Hz duty {duty:g} -> {photo} "
        f"(2000x1500, camera 3 m up, tilted 50 deg), points.csv, run.csv, truth.csv; true "
        f"radii {rl} / {rr} m, track {b} m"
    )


TrackPhotoPhotoOpt = Annotated[
    Path, typer.Argument(help="Long-exposure photo of the flashing LED.")
]
TrackPhotoFloorPointsOpt = Annotated[
    Path,
    typer.Option(help="POINTS.csv u,v,x,y: four or more floor points clicked on the photo."),
]
TrackPhotoEncodersOpt = Annotated[
    Path, typer.Option(help="The run's encoder log (its clock is used).")
]
TrackPhotoOutputOpt = Annotated[
    Path, typer.Option("--output", "-o", help="Path CSV t,x,y,quality.")
]
TrackPhotoOverlayOpt = Annotated[
    Path | None, typer.Option(help="PNG: the photo with the dashes and the odometry drawn.")
]


@app.command("track-photo")
def track_photo_cmd(
    photo: TrackPhotoPhotoOpt,
    floor_points: TrackPhotoFloorPointsOpt,
    encoders: TrackPhotoEncodersOpt,
    params: NominalParamsOpt,
    output: TrackPhotoOutputOpt,
    led_hz: LedHzOpt = 2.0,
    duty: DutyOpt = 0.5,
    overlay: TrackPhotoOverlayOpt = None,
    fmt: EncodersFormatOpt = RunFormat.CSV,
) -> None:
    """A timed path from one long-exposure photo of an LED flashing at --led-hz on the robot:
    the dashes found, ordered from the robot's start and placed on the encoder log's clock by
    matching the distance driven. Writes t,x,y,quality (a row at each dash's start, centre and
    end; quality: the position's estimated 1-sigma error, m), position-only ground truth for
    evaluate and calibrate lsq (heading from the path's tangent)."""
    from odolab.app.groundtruth import PhotoRequest, track_photo_log
    from odolab.cli._output import check_output_path

    def check_outputs() -> None:
        check_output_path(output, "photo track CSV")
        if overlay is not None:
            check_output_path(overlay, "overlay PNG")

    request = PhotoRequest(
        photo, floor_points, encoders, params, output, led_hz, duty, overlay, fmt.value
    )
    track = track_photo_log(request, check_outputs)
    tm = track.timing
    n = len(tm.chain.dashes)
    echo(
        f"{photo}: {n} dashes in order ({n - track.untimed} timed), "
        f"{len(track.search.set_aside)} set aside; floor points fit to "
        f"{track.homography.rms * 1000:.1f} mm; first dash ON at {tm.t0:.3f} s +- "
        f"{tm.t0_std * 1000:.0f} ms (1 sigma) on the encoder clock; distance residual "
        f"{tm.rms * 1000:.1f} mm RMS, photo / odometry distance {tm.scale:.4f} -> {output}"
        + (f", {overlay}" if overlay is not None else "")
    )
    for reason, u, v in track.search.set_aside:
        echo(f"note: set aside at ({u:.0f}, {v:.0f}) px: {reason}")
    for k, gap in tm.chain.jumps:
        echo(
            f"note: between dashes {k - 1} and {k} a gap of {gap * 1000:.0f} mm: "
            f"{int(tm.chain.index[k] - tm.chain.index[k - 1]) - 1} ON interval(s) missing"
        )

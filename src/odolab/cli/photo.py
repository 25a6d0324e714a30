"""CLI commands for ground truth from one long-exposure photo of a flashing LED:
``odolab track-photo`` and ``odolab sim photo`` (a rendered photo of the virtual robot to try it
on). See docs/ground-truth.md."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer

from odolab.cli._apps import app, sim_app
from odolab.cli._output import echo
from odolab.cli.groundtruth import EncoderFormat, OptionError

__all__: list[str] = []

#: ``odolab sim photo``: the robot's true parameters (nominal jaguar-lite: 0.0835, 0.0835, 0.56)
SIM_PHOTO_TRUTH = (0.0850, 0.0820, 0.60)


def sim_photo_legs(seconds: float) -> list[tuple[float, float, float]]:
    """The drive of ``odolab sim photo``: from standing, straight lines and arcs of both signs at
    different speeds (the speed changes are what place the dashes in time), ``seconds`` long
    (20: the lab report's Fig. 2; 6: its Fig. 1)."""
    legs = [
        (0.25, 0.25, 2.0), (0.12, 0.22, 2.0), (0.38, 0.38, 2.0), (0.18, 0.34, 3.0),
        (0.34, 0.16, 4.0), (0.20, 0.20, 3.0), (0.30, 0.15, 4.0),
    ]  # fmt: skip
    out, left = [], seconds
    for vl, vr, d in legs:
        if left <= 1e-9:
            break
        out.append((vl, vr, min(d, left)))
        left -= d
    return out


@sim_app.command("photo")
def sim_photo_cmd(
    folder: Annotated[Path, typer.Argument(help="Folder to write the photo and its files in.")],
    seconds: Annotated[
        float, typer.Option(help="Length of the drive and the exposure (s), 1 to 20.")
    ] = 20.0,
    led_hz: Annotated[float, typer.Option(help="The LED's flashing frequency (Hz).")] = 2.0,
    duty: Annotated[float, typer.Option(help="The LED's ON fraction.")] = 0.5,
    phase: Annotated[
        float, typer.Option(help="When the LED's first ON interval starts (s, run clock).")
    ] = 0.13,
    jpeg: Annotated[
        int | None, typer.Option(help="Write photo.jpg at this JPEG quality instead of a PNG.")
    ] = None,
    noise: Annotated[float, typer.Option(help="Sensor noise (grey levels).")] = 2.0,
    seed: Annotated[int, typer.Option(min=0, help="Random seed (sensor noise).")] = 0,
) -> None:
    """Photograph the virtual robot's LED: a 2000x1500 long exposure from a camera 3 m up,
    tilted 50 deg, while the robot drives; writes photo.png (or .jpg), the floor points
    points.csv (u,v,x,y: the floor tiles' corners, as you would click them), the encoder log
    run.csv and the true path truth.csv."""
    import numpy as np

    from odolab.io import write_trajectory_csv
    from odolab.io.encoder_csv import write_encoder_csv
    from odolab.params import PRESETS
    from odolab.sim.drives import record_drive
    from odolab.sim.physics import TrueParams
    from odolab.tracking import CameraModel
    from odolab.tracking.photo_render import render_photo, tilted_camera
    from odolab.trajectory import Trajectory
    from odolab.trials import EncoderLog
    from odolab.writing import write_text_file

    if not (math.isfinite(seconds) and 1.0 <= seconds <= 20.0):
        raise OptionError(f"--seconds is {seconds!r}; expected 1 to 20 s")
    if not (math.isfinite(led_hz) and 0.2 <= led_hz <= 20.0):
        raise OptionError(f"--led-hz is {led_hz!r}; expected 0.2 to 20 Hz")
    if not (math.isfinite(duty) and 0.05 <= duty <= 0.95):
        raise OptionError(f"--duty is {duty!r}; expected the ON fraction, 0.05 to 0.95")
    if jpeg is not None and not 1 <= jpeg <= 100:
        raise OptionError(f"--jpeg is {jpeg!r}; expected a JPEG quality 1 to 100")
    if folder.exists() and not folder.is_dir():
        raise OptionError(f"{folder} is a file; expected a folder to write the photo in")
    rl, rr, b = SIM_PHOTO_TRUTH
    drive = record_drive(
        TrueParams(rl, rl, rr, rr, b), PRESETS["jaguar-lite"], sim_photo_legs(seconds), dt=0.002
    )
    tr = drive.truth
    # the path centred on the floor's origin
    cx = 0.5 * (tr.x.min() + tr.x.max())
    cy = 0.5 * (tr.y.min() + tr.y.max())
    truth = Trajectory.from_xyh(tr.t, tr.x - cx, tr.y - cy, tr.heading)
    camera = CameraModel(1400.0, 1400.0, 1000.0, 750.0, 2000, 1500)
    scene = tilted_camera(camera, 3.0, 50.0)
    name = "photo.png" if jpeg is None else "photo.jpg"
    folder.mkdir(parents=True, exist_ok=True)
    render_photo(
        folder / name, truth, scene, led_hz=led_hz, duty=duty, phase=phase, noise=noise,
        jpeg_quality=jpeg, seed=seed,
    )  # fmt: skip
    # the floor points: tile corners around the path, as a person clicks them (to 0.5 px)
    corners = [(x, y) for x in (-2.5, -1.0, 1.0, 2.5) for y in (-1.5, 0.0, 1.5)]
    xyz = np.array([(x, y, 0.0) for x, y in corners])
    uv = scene.project(xyz)
    rng = np.random.default_rng(seed + 1)
    uv = np.round(uv * 2.0 + rng.uniform(-0.5, 0.5, uv.shape)) / 2.0
    lines = ["u,v,x,y"] + [
        f"{u:g},{v:g},{x:g},{y:g}" for (u, v), (x, y) in zip(uv, corners, strict=True)
    ]
    write_text_file(folder / "points.csv", "\n".join(lines) + "\n", what="floor points")
    write_encoder_csv(
        folder / "run.csv", EncoderLog(drive.t, drive.counts_left, drive.counts_right)
    )
    write_trajectory_csv(folder / "truth.csv", truth)
    echo(
        f"{tr.t[-1]:.1f} s drive, LED {led_hz:g} Hz duty {duty:g} -> {folder / name} "
        f"(2000x1500, camera 3 m up, tilted 50 deg), points.csv, run.csv, truth.csv; true "
        f"radii {rl} / {rr} m, track {b} m"
    )


@app.command("track-photo")
def track_photo_cmd(
    photo: Annotated[Path, typer.Argument(help="Long-exposure photo of the flashing LED.")],
    floor_points: Annotated[
        Path,
        typer.Option(help="POINTS.csv u,v,x,y: four or more floor points clicked on the photo."),
    ],
    encoders: Annotated[Path, typer.Option(help="The run's encoder log (its clock is used).")],
    params: Annotated[str, typer.Option("--params", "-p", help="Nominal parameters.")],
    output: Annotated[Path, typer.Option("--output", "-o", help="Path CSV t,x,y,quality.")],
    led_hz: Annotated[float, typer.Option(help="The LED's flashing frequency (Hz).")] = 2.0,
    duty: Annotated[float, typer.Option(help="The LED's ON fraction.")] = 0.5,
    overlay: Annotated[
        Path | None, typer.Option(help="PNG: the photo with the dashes and the odometry drawn.")
    ] = None,
    fmt: Annotated[
        EncoderFormat, typer.Option("--format", "-f", help="Format of --encoders.")
    ] = EncoderFormat.csv,
) -> None:
    """A timed path from one long-exposure photo of an LED flashing at --led-hz on the robot:
    the dashes found, ordered from the robot's start and placed on the encoder log's clock by
    matching the distance driven. Writes t,x,y,quality (a row at each dash's start, centre and
    end; quality: the position's estimated 1-sigma error, m), position-only ground truth for
    evaluate and calibrate lsq (heading from the path's tangent)."""
    from odolab.cli._output import check_output_path
    from odolab.io.registry import read_run
    from odolab.io.run import ReadOptions
    from odolab.params import load_params
    from odolab.tracking.photo import (
        WheelTravel,
        draw_overlay,
        read_floor_points,
        read_photo,
        track_photo,
        write_photo_csv,
    )

    if not (math.isfinite(led_hz) and led_hz > 0):
        raise OptionError(f"--led-hz is {led_hz!r}; expected the LED's frequency, > 0 Hz")
    if not (math.isfinite(duty) and 0.05 <= duty <= 0.95):
        raise OptionError(f"--duty is {duty!r}; expected the LED's ON fraction, 0.05 to 0.95")
    check_output_path(output, "photo track CSV")
    if overlay is not None:
        check_output_path(overlay, "overlay PNG")
    points = read_floor_points(floor_points)
    nominal = load_params(params)
    run = read_run(
        encoders,
        fmt.value,
        ReadOptions(modulus=nominal.encoder_modulus, ticks_per_rev=nominal.ticks_per_rev),
    )
    odo = run.odometry(nominal)
    per_tick = 2.0 * math.pi / nominal.ticks_per_rev
    travel = WheelTravel.from_increments(
        run.t, run.dticks_left, run.dticks_right,
        nominal.left_wheel_radius * per_tick, nominal.right_wheel_radius * per_tick,
    )  # fmt: skip
    image = read_photo(photo)
    track = track_photo(image, points, travel, led_hz=led_hz, duty=duty, source=str(photo))
    write_photo_csv(output, track)
    if overlay is not None:
        draw_overlay(overlay, image, track, odo)
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

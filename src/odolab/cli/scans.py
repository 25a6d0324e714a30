"""CLI commands: ``odolab scans BAG`` (laser scans to the sensor's trajectory) and
``odolab sim scans OUT.mcap`` (a synthetic laser drive to try it on). See docs/ground-truth.md."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from odolab.cli._apps import app, sim_app
from odolab.cli._output import echo

__all__: list[str] = []


class _Format(StrEnum):
    csv = "csv"
    tum = "tum"


@app.command("scans")
def scans_cmd(
    bag: Annotated[
        Path, typer.Argument(help="ROS 1 bag, ROS 2 bag folder or .mcap file with LaserScans.")
    ],
    scan_topic: Annotated[
        str, typer.Option("--scan-topic", help="The sensor_msgs/LaserScan topic.")
    ] = "/scan",
    output: Annotated[
        Path,
        typer.Option("--output", "-o", help="Sensor trajectory to write (t,x,y,theta,heading)."),
    ] = Path("sensor.csv"),
    fmt: Annotated[_Format, typer.Option("--format", help="Output format.")] = _Format.csv,
    max_range: Annotated[
        float, typer.Option(min=0.0, help="Ignore readings farther than this (m).")
    ] = 30.0,
    voxel: Annotated[float, typer.Option(min=0.0, help="Downsampling grid (m).")] = 0.05,
    every: Annotated[
        int, typer.Option(min=1, help="Match every N-th scan (N > 1 for fast scanners).")
    ] = 1,
    max_correspondence: Annotated[
        float, typer.Option(min=0.0, help="Farthest two points may be to pair up (m).")
    ] = 0.5,
) -> None:
    """Match a bag's laser scans pairwise and write the sensor's trajectory (from its first pose),
    for "odolab calibrate sensor ENCODERS SENSOR.csv"."""
    from odolab.calibration.scanmatch import scan_motions
    from odolab.cli._output import check_output_path, term
    from odolab.io import write_trajectory
    from odolab.io.scans import read_scans

    check_output_path(output, "sensor trajectory")
    scans = read_scans(bag, scan_topic)
    result = scan_motions(
        scans, max_range=max_range, voxel=voxel, every=every, max_correspondence=max_correspondence
    )
    write_trajectory(output, result.trajectory, "tum" if fmt is _Format.tum else "csv")
    bad = result.outliers()
    end = result.trajectory.final
    echo(
        f"{len(scans)} scans, {len(result)} pairs matched -> {term(output)}; path "
        f"{result.trajectory.path_length():.3f} m, final x={end.x:.4f} m y={end.y:.4f} m "
        f"heading={end.heading:.4f} rad; median fitness {float(_median(result.fitness)):.3f}, "
        f"median residual {1000 * float(_median(result.residual)):.1f} mm"
    )
    if result.skipped:
        echo(f"skipped {len(result.skipped)} scans with too few valid ranges", err=True)
    if bad.any():
        first = [f"{result.trajectory.t[i + 1]:.3f}" for i in bad.nonzero()[0][:5]]
        echo(
            f"warning: {int(bad.sum())} of {len(result)} pairs look unmatched (low fitness or "
            f"large residual), at t = {', '.join(first)} s ...",
            err=True,
        )


def _median(values: object) -> float:
    import numpy as np

    return float(np.median(np.asarray(values, dtype=np.float64)))


@sim_app.command("scans")
def sim_scans_cmd(
    output: Annotated[Path, typer.Argument(help="MCAP file to write (/scan and /joint_states).")],
    seed: Annotated[int, typer.Option(min=0, help="Random seed (range noise).")] = 0,
    mount: Annotated[
        tuple[float, float, float],
        typer.Option(help="Laser mount on the robot DX DY DYAW (m, m, rad)."),
    ] = (0.15, -0.05, 0.1),
    truth_csv: Annotated[
        Path | None,
        typer.Option("--truth", help="Also write the laser's true trajectory (CSV)."),
    ] = None,
    calibration_drive: Annotated[
        bool,
        typer.Option(
            "--calibration-drive",
            help="The 48 s calibration drive (turns and arcs of both signs) in a 12 m x 8 m "
            "room, on a robot whose true radii are 0.085 / 0.082 m and track 0.60 m (nominal "
            "jaguar-lite: 0.0835, 0.56), instead of the 18 s drive of an ideal robot.",
        ),
    ] = False,
) -> None:
    """Drive the virtual Jaguar through a room with a 270 degree laser; write the bag."""
    from odolab.cli._output import check_output_path, term
    from odolab.core.trajectory import Trajectory
    from odolab.io import write_trajectory_csv
    from odolab.io.scans import LaserScans, write_scan_mcap
    from odolab.sim.drives import calibration_drive as legs
    from odolab.sim.laser import room_world, simulate_laser_drive
    from odolab.sim.physics import TrueParams

    check_output_path(output, "MCAP file")
    if calibration_drive:
        drive = simulate_laser_drive(
            world=room_world(12.0, 8.0),
            drive=legs(),
            truth=TrueParams(0.085, 0.085, 0.082, 0.082, 0.60),
            mount=mount,
            seed=seed,
        )
    else:
        drive = simulate_laser_drive(mount=mount, seed=seed)
    lz = drive.laser
    scans = LaserScans(
        drive.scan_t, drive.ranges, lz.angle_min, lz.angle_increment, lz.range_min, lz.range_max
    )
    counts = write_scan_mcap(output, scans, joint_t=drive.joint_t, wheel_angles=drive.wheel_angles)
    echo(
        f"{counts.get('/scan', 0)} scans, {counts.get('/joint_states', 0)} joint states "
        f"-> {term(output)}"
    )
    if truth_csv is not None:
        check_output_path(truth_csv, "truth CSV")
        s = drive.sensor
        truth = Trajectory.from_xyh(drive.scan_t, s[:, 0], s[:, 1], s[:, 2])
        write_trajectory_csv(truth_csv, truth)
        echo(f"true laser trajectory -> {term(truth_csv)}")

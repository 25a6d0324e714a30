"""Scan matching speed: scans matched per second against the scanner's own rate (real time).

Simulates the default laser drive (a 270 degree, 541-beam scanner at 10 Hz in a room with boxes),
writes it as an MCAP, then times reading it back (``read_scans``) and matching it
(``scan_motions``). Prints scans/s for each step and the ratio to real time (the recording's
duration / the processing time; > 1 means faster than the scanner delivers scans), and the same
for a 40 Hz scanner matched with ``--every 4`` (every 4th scan, 10 Hz).

Usage: python benchmarks/bench_scans.py [--repeats R] [--threads N]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from _timing import best  # benchmarks/_timing.py (run as python benchmarks/...)

from odolab.calibration.scanmatch import scan_motions
from odolab.io.scans import LaserScans, read_scans, write_scan_mcap
from odolab.sim.laser import simulate_laser_drive


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args()

    for rate, every in ((10.0, 1), (40.0, 4)):
        drive = simulate_laser_drive(seed=1, scan_rate=rate, joint_rate=max(50.0, rate))
        lz = drive.laser
        scans = LaserScans(
            drive.scan_t, drive.ranges, lz.angle_min, lz.angle_increment, lz.range_min, lz.range_max
        )
        duration = float(drive.scan_t[-1] - drive.scan_t[0])
        with tempfile.TemporaryDirectory() as tmp:
            bag = Path(tmp) / "drive.mcap"
            write_scan_mcap(bag, scans, joint_t=drive.joint_t, wheel_angles=drive.wheel_angles)
            t_read = best(lambda b=bag: read_scans(b), args.repeats)
        t_match = best(
            lambda s=scans, e=every: scan_motions(s, every=e, threads=args.threads), args.repeats
        )
        result = scan_motions(scans, every=every, threads=args.threads)
        n, matched = len(scans), len(result.index)
        print(
            f"{rate:4.0f} Hz scanner, {lz.beams} beams, {n} scans over {duration:.1f} s, "
            f"matching every {every}: "
        )
        print(f"  read   {n / t_read:9.0f} scans/s  = {duration / t_read:7.1f} x real time")
        print(
            f"  match  {matched / t_match:9.0f} scans/s  = {duration / t_match:7.1f} x real time "
            f"({1000 * t_match / max(matched - 1, 1):.2f} ms per pair, {args.threads} thread(s))"
        )
        print(f"  both   {duration / (t_read + t_match):7.1f} x real time")


if __name__ == "__main__":
    main()

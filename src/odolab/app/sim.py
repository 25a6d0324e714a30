"""The virtual Jaguar: ``odolab sim run`` calls :func:`simulate_protocol` (a protocol's trials)
and ``odolab sim explore`` calls :func:`simulate_exploration` (commands sampled inside a fence).

The rules live here once: a truth preset is one of :data:`odolab.sim.presets.TRUTH_PRESETS`;
an exploration's turn rate, when none is given, is 2 rad/s or a turn in place at the largest
wheel speed when that is less (and the outcome says so); an exploration keeps to the bounds
``robot explore`` has.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from odolab.core.defaults import DEFAULT_ROBOT, DEFAULT_TERRAIN, DEFAULT_TRUTH
from odolab.core.errors import opt

if TYPE_CHECKING:
    from odolab.core.trials import Trial
    from odolab.sim.drives import Drive
    from odolab.sim.explore import ExploreSettings
    from odolab.sim.physics import TrueParams

__all__ = [
    "SIM_PHOTO_TRUTH",
    "ExploreOutcome",
    "ExploreRequest",
    "PhotoRequest",
    "SimRunOutcome",
    "SimRunRequest",
    "sim_photo_legs",
    "simulate_exploration",
    "simulate_photo",
    "simulate_protocol",
]

#: progress(protocol name, trials done, trials in all)
ProtocolProgress = Callable[[str, int, int], None]


def _no_progress(name: str, done: int, total: int) -> None:
    return None


def _truth(truth: str) -> TrueParams:
    """The truth preset named ``truth``.

    Raises:
        SimError: no such preset.
    """
    from odolab.core.errors import SimError
    from odolab.sim.presets import TRUTH_PRESETS

    if truth not in TRUTH_PRESETS:
        raise SimError(
            f"{opt('truth')}: unknown preset {truth!r}; expected one of {', '.join(TRUTH_PRESETS)}"
        )
    return TRUTH_PRESETS[truth]


@dataclass(frozen=True)
class SimRunRequest:
    """What ``odolab sim run`` was asked: a protocol, its settings, where the trials go."""

    protocol: str
    output: Path
    seed: int
    terrain: str | None = None
    truth: str = DEFAULT_TRUTH
    params: str = DEFAULT_ROBOT
    encoder_dir: Path | None = None
    db: Path | None = None


@dataclass(frozen=True)
class SimRunOutcome:
    """The trials (written to the request's CSV, encoder folder and notebook) and the
    protocol's name."""

    protocol: str
    trials: list[Trial]

    @property
    def stalled(self) -> int:
        """Trials that stalled (excluded)."""
        return sum(t.exclusion_reason is not None for t in self.trials)


def simulate_protocol(
    req: SimRunRequest, progress: ProtocolProgress = _no_progress
) -> SimRunOutcome:
    """Run an experiment protocol on the virtual Jaguar; write the trials as CSV, each trial's
    encoder log (``req.encoder_dir``) and the trials into a notebook (``req.db``) where asked.

    Raises:
        SimError: an unknown truth preset, or an encoder folder that is a file.
        ProtocolError: a protocol that cannot be read.
    """
    from odolab.core.errors import SimError
    from odolab.core.params import load_params
    from odolab.sim.export import write_encoder_logs
    from odolab.sim.protocols import load_protocol, run_protocol
    from odolab.store.csvio import write_trials_csv

    true = _truth(req.truth)
    proto = load_protocol(req.protocol)
    nominal = load_params(req.params)
    enc_dir = req.encoder_dir
    if enc_dir is not None and enc_dir.exists() and not enc_dir.is_dir():
        raise SimError(f"{enc_dir}: is a file; expected a folder for {opt('encoder_dir')}")
    trials = run_protocol(
        proto,
        true,
        nominal,
        terrain=req.terrain,
        seed=req.seed,
        progress=lambda done, total, what: progress(proto.name, done, total),
    )
    write_trials_csv(req.output, [(t, None) for t in trials])
    if enc_dir is not None:
        write_encoder_logs(enc_dir, trials)
    if req.db is not None:
        from odolab.store import Notebook

        with Notebook(req.db) as nb:
            nb.add_trials(trials)
    return SimRunOutcome(proto.name, trials)


@dataclass(frozen=True)
class ExploreRequest:
    """What ``odolab sim explore`` was asked (``max_turn_rate`` None: chosen, see the module)."""

    output: Path
    seconds: float = 60.0
    max_speed: float = 1.0
    max_turn_rate: float | None = None
    fence: float = 4.0
    distribution: str = "uniform"
    terrain: str = DEFAULT_TERRAIN
    truth: str = "jaguar-lab-tracked"
    params: str = DEFAULT_ROBOT
    seed: int = 0
    name: str = "explore"


@dataclass(frozen=True)
class ExploreOutcome:
    """The exploration, its two files, and what was chosen for the user ("" when nothing)."""

    run: Drive
    settings: ExploreSettings
    log: Path
    ground_truth: Path
    chosen: str = ""

    @property
    def reach(self) -> float:
        """How far the robot went from its start (m)."""
        import numpy as np

        run = self.run
        return float(np.max(np.hypot(run.x - run.x[0], run.y - run.y[0])))


def _turn_rate(req: ExploreRequest, track_width: float) -> tuple[float, str]:
    """The largest turn rate, and the sentence saying it was chosen (when it was)."""
    if req.max_turn_rate is not None:
        return req.max_turn_rate, ""
    in_place = req.max_speed / (0.5 * track_width) if req.max_speed > 0 else 0.0
    rate = min(2.0, in_place) if math.isfinite(in_place) and in_place > 0 else 2.0
    if rate < 2.0:
        return rate, (
            f"{opt('max_turn_rate')} not given: {rate:.3g} rad/s, a turn in place at "
            f"{opt('max_speed')} {req.max_speed:g} m/s (the default 2 rad/s is beyond it)"
        )
    return rate, ""


def simulate_exploration(req: ExploreRequest) -> ExploreOutcome:
    """Drive commands sampled over speed and turn rate inside a geofence on the virtual robot;
    write the encoder log and its ground truth to ``req.output``.

    Raises:
        SimError: an unknown truth preset.
        RobotConfigError: an exploration outside the bounds ``robot explore`` has.
    """
    from odolab.core.params import load_params
    from odolab.core.text import safe_file_name
    from odolab.core.trials import Exploration as Plan
    from odolab.robot.config import BOUNDS, check_exploration
    from odolab.sim.explore import ExploreSettings, explore, write_exploration

    true = _truth(req.truth)
    stem = safe_file_name(req.name, what="run name", suffix=".csv")[: -len(".csv")]
    nominal = load_params(req.params)
    max_turn_rate, chosen = _turn_rate(req, nominal.track_width)
    # the bounds robot explore has (odolab.robot.config), up to the fastest wheel odolab drives
    check_exploration(
        Plan(req.seconds, req.max_speed, max_turn_rate, fence=req.fence,
             distribution=req.distribution),
        nominal,
        BOUNDS["max_wheel_speed"].hi,
        "the largest wheel speed odolab drives,",
    )  # fmt: skip
    settings = ExploreSettings(
        seconds=req.seconds,
        max_speed=req.max_speed,
        max_turn_rate=max_turn_rate,
        fence_radius=req.fence,
        distribution=req.distribution,
    )
    run = explore(true, nominal, settings, terrain=req.terrain, seed=req.seed)
    log, gt = write_exploration(req.output, run, stem)
    return ExploreOutcome(run, settings, log, gt, chosen)


# -- sim photo ------------------------------------------------------------------------------

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


@dataclass(frozen=True)
class PhotoRequest:
    """What ``odolab sim photo`` was asked: the folder, the drive's length, the LED's timing,
    the image's format and noise."""

    folder: Path
    seconds: float = 20.0
    led_hz: float = 2.0
    duty: float = 0.5
    phase: float = 0.13
    jpeg: int | None = None
    noise: float = 2.0
    seed: int = 0


def simulate_photo(req: PhotoRequest) -> tuple[Path, float]:
    """Photograph the virtual robot's LED: a 2000x1500 long exposure from a camera 3 m up,
    tilted 50 deg, while the robot drives; writes the photo, the floor points points.csv, the
    encoder log run.csv and the true path truth.csv into ``req.folder``. Returns the photo's
    path and the drive's length (s).

    Raises:
        OptionError: an option out of its range, or a folder that is a file.
    """
    import numpy as np

    from odolab.app.groundtruth import OptionError
    from odolab.core.params import PRESETS
    from odolab.core.trajectory import Trajectory
    from odolab.core.trials import EncoderLog
    from odolab.core.writing import write_text_file
    from odolab.io import write_trajectory_csv
    from odolab.io.encoder_csv import write_encoder_csv
    from odolab.sim.drives import record_drive
    from odolab.sim.physics import TrueParams
    from odolab.tracking import CameraModel
    from odolab.tracking.photo_render import render_photo, tilted_camera

    seconds, led_hz, duty, jpeg, folder = req.seconds, req.led_hz, req.duty, req.jpeg, req.folder
    if not (math.isfinite(seconds) and 1.0 <= seconds <= 20.0):
        raise OptionError(f"{opt('seconds')} is {seconds!r}; expected 1 to 20 s")
    if not (math.isfinite(led_hz) and 0.2 <= led_hz <= 20.0):
        raise OptionError(f"{opt('led_hz')} is {led_hz!r}; expected 0.2 to 20 Hz")
    if not (math.isfinite(duty) and 0.05 <= duty <= 0.95):
        raise OptionError(f"{opt('duty')} is {duty!r}; expected the ON fraction, 0.05 to 0.95")
    if jpeg is not None and not 1 <= jpeg <= 100:
        raise OptionError(f"{opt('jpeg')} is {jpeg!r}; expected a JPEG quality 1 to 100")
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
        folder / name, truth, scene, led_hz=led_hz, duty=duty, phase=req.phase, noise=req.noise,
        jpeg_quality=jpeg, seed=req.seed,
    )  # fmt: skip
    # the floor points: tile corners around the path, as a person clicks them (to 0.5 px)
    corners = [(x, y) for x in (-2.5, -1.0, 1.0, 2.5) for y in (-1.5, 0.0, 1.5)]
    xyz = np.array([(x, y, 0.0) for x, y in corners])
    uv = scene.project(xyz)
    rng = np.random.default_rng(req.seed + 1)
    uv = np.round(uv * 2.0 + rng.uniform(-0.5, 0.5, uv.shape)) / 2.0
    lines = ["u,v,x,y"] + [
        f"{u:g},{v:g},{x:g},{y:g}" for (u, v), (x, y) in zip(uv, corners, strict=True)
    ]
    write_text_file(folder / "points.csv", "\n".join(lines) + "\n", what="floor points")
    write_encoder_csv(
        folder / "run.csv", EncoderLog(drive.t, drive.counts_left, drive.counts_right)
    )
    write_trajectory_csv(folder / "truth.csv", truth)
    return folder / name, float(tr.t[-1])

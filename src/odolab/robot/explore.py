"""``odolab robot explore``: one exploration run by odometry, with its ground truth.

Issue 29, after DRIVE (Baril et al., ICRA 2024): drive commands sampled over the robot's input
space inside a geofence (:class:`~odolab.robot.explore_motion.Explore`, the hard fence included)
and record ONE run whose ground truth a slip model is fitted to (``odolab calibrate lsq
RUN/encoders.csv -f csv --model slip``). :func:`plan_exploration` checks everything before
anything is sent (the limits it chose said in :meth:`ExplorePlan.describe`); :meth:`ExplorePlan.run`
drives it over any link with every safety rule of the live stack (:func:`run_motion`), and
:meth:`ExplorePlan.simulate` drives the same driver and loop in simulated time.

Ground truth:

- on the virtual robot (``sim://``, or in simulated time) it is the plant's true path:
  :class:`TruthRecorder` wraps the plant and keeps its true pose at every sensor report, and
  each row of the encoder log gets the true pose of the very report whose counters it holds
  (exact, whatever the report's delay). Written as ``encoders_gt.csv`` (``t,x,y,theta,heading``,
  start frame, the encoder log's ``t``) beside ``encoders.csv``: the CSV run reader finds it.
- on a real robot the user names the source (``mocap``, ``track``: a filmed marker through
  ``odolab track``, ``laser``: the laser calibration's path); the run folder records it
  (``run.json`` ``"ground_truth"``) with a sentence saying how to attach it
  (:func:`attach_sentence`); no truth file is written.

An exploration is not a Table I trial: its command is a free motion carrying its settings
(:meth:`odolab.core.trials.Command.exploration`; the trial kinds are the notebook schema's, which
every analysis shares, and no analysis counts a free run), and :func:`notebook_trial` records it
in a notebook as a free run, excluded from the analysis with the exploration named in the reason
and its settings in the notes (:func:`odolab.core.trials.validate_trial` refuses a command that
carries the settings themselves: the notebook has no place for them).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from odolab.core.defaults import DEFAULT_SEED, DEFAULT_TERRAIN
from odolab.core.errors import NEUTRAL, Wording, opt
from odolab.core.params import RobotParams
from odolab.core.trajectory import Pose, Trajectory
from odolab.core.trials import Command, MotionKind, Trial, TrialStatus
from odolab.robot.config import RunConfig, check_motion
from odolab.robot.errors import RobotConfigError
from odolab.robot.explore_motion import Explore
from odolab.robot.loop import CycleInfo, CycleLog
from odolab.robot.plant import IdealPlant, Plant, PlantFactory
from odolab.robot.session import (
    TRUTH_FILE,
    AbortReport,
    Finish,
    RobotRun,
    run_motion,
    run_simulated,
)

__all__ = [
    "DEFAULT_MAX_SPEED",
    "DEFAULT_MAX_TURN_RATE",
    "GROUND_TRUTH_SOURCES",
    "ExplorePlan",
    "TruthRecorder",
    "attach_sentence",
    "notebook_trial",
    "plan_exploration",
    "truth_on_log",
]

#: The exploration's largest forward speed when none is given (m/s; at most --max-wheel-speed).
DEFAULT_MAX_SPEED = 0.5
#: Its largest turn rate when none is given (rad/s; at most a turn in place at that speed).
DEFAULT_MAX_TURN_RATE = 1.0

#: Where an exploration's ground truth comes from: ``virtual`` on the virtual robot, the others
#: named by the user on a real one.
GROUND_TRUTH_SOURCES: dict[str, str] = {
    "virtual": "the virtual robot's true path",
    "mocap": "a motion-capture log",
    "track": "a filmed marker on the robot (odolab track)",
    "laser": "the laser calibration's path (odolab calibrate sensor {{truth_out}})",
}


def is_virtual(url: str) -> bool:
    """Whether ``url`` (checked) is the virtual robot, whose truth is recorded."""
    return url.startswith("sim:")


def attach_sentence(source: str, folder: Path | str) -> str:
    """How to attach the ground truth ``source`` names to the run in ``folder`` afterwards."""
    run = Path(folder)
    log, gt = run / "encoders.csv", run / TRUTH_FILE
    lsq = f"`odolab calibrate lsq {log} -f csv {opt('ground_truth')} FILE`"
    if source == "mocap":
        return (
            f"attach the motion-capture log afterwards: the robot centre's path on the encoder "
            f"log's clock (t,x,y,theta CSV or TUM) as {gt}, or give it with {lsq}"
        )
    if source == "track":
        return (
            f"attach the filmed marker afterwards: `odolab track VIDEO {opt('floor')} FLOOR.csv "
            f"{opt('robot_marker')} ID ... {opt('encoders')} {log} -o {gt}` finds the video's clock offset and "
            "writes the path on the encoder log's clock (docs/ground-truth.md)"
        )
    if source == "laser":
        return (
            "attach the laser calibration's path afterwards: `odolab calibrate sensor ... "
            f"{opt('truth_out')} FILE` (docs/ground-truth.md), on the encoder log's clock, as {gt} or "
            f"with {lsq}"
        )
    return f"the virtual robot's true path is {gt}"


def _check_ground_truth(url: str, source: str | None) -> str:
    """The ground-truth source of a run on ``url``: ``virtual`` on the virtual robot, else the
    one the user named (required: an exploration without ground truth fits nothing)."""
    real = [s for s in GROUND_TRUTH_SOURCES if s != "virtual"]
    if is_virtual(url):
        if source not in (None, "virtual"):
            raise RobotConfigError(
                f"{opt('ground_truth')} is {source!r} but {opt('robot')} {url} is the virtual robot, whose "
                "true path is recorded; expected no {{ground_truth}} (or virtual)"
            )
        return "virtual"
    if source is None:
        raise RobotConfigError(
            f"{opt('ground_truth')} is missing: an exploration of the robot at {url} needs the source "
            f"of its ground truth; expected one of {', '.join(real)}"
        )
    if source not in real:
        raise RobotConfigError(
            f"{opt('ground_truth')} is {source!r} for the robot at {url}; expected one of "
            f"{', '.join(real)} (virtual is the virtual robot's, sim://)"
        )
    return source


def _choose_limits(
    command: Command, config: RunConfig, params: RobotParams
) -> tuple[Command, tuple[str, ...]]:
    """The command with its unset speed limits chosen (see the module constants), and what was
    chosen, said as options."""
    e = command.explore
    if e is None:
        raise RobotConfigError(f"a {command.describe()!r} command is not an exploration")
    chosen: list[str] = []
    v = e.max_speed
    if v is None:
        v = min(DEFAULT_MAX_SPEED, config.max_wheel_speed)
        chosen.append(f"{opt('max_speed')} {v:g} m/s")
    w = e.max_turn_rate
    if w is None and isinstance(v, int | float) and math.isfinite(v) and v > 0:
        w = min(DEFAULT_MAX_TURN_RATE, v / (0.5 * params.track_width))
        chosen.append(f"{opt('max_turn_rate')} {w:g} rad/s")
    return replace(command, explore=replace(e, max_speed=v, max_turn_rate=w)), tuple(chosen)


class TruthRecorder:
    """A plant that keeps its true pose at every sensor report (each call of
    ``encoder_counts``): (left count, right count, true pose) in :attr:`samples`. Everything
    else is the wrapped plant's."""

    def __init__(self, plant: Plant) -> None:
        self.plant = plant
        #: (left, right raw counters, true pose) at each report, in order
        self.samples: list[tuple[int, int, Pose]] = []

    @property
    def time(self) -> float:
        return self.plant.time

    def set_wheel_speeds(self, left_mps: float, right_mps: float) -> None:
        self.plant.set_wheel_speeds(left_mps, right_mps)

    def advance(self, duration: float) -> None:
        self.plant.advance(duration)

    def encoder_counts(self) -> tuple[int, int]:
        left, right = self.plant.encoder_counts()
        self.samples.append((int(left), int(right), self.plant.true_pose))
        return left, right

    @property
    def true_pose(self) -> Pose:
        return self.plant.true_pose

    @property
    def stalled(self) -> bool:
        return self.plant.stalled

    def reset(self, start: object = None) -> None:
        self.plant.reset(start)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.plant, name)


def truth_on_log(
    samples: list[tuple[int, int, Pose]], log: CycleLog, config: RunConfig, params: RobotParams
) -> Trajectory | None:
    """The true pose of every row of the encoder log, on its clock, in the start frame.

    Row ``k`` holds the counters of one sensor report (the newest when the cycle ran); its true
    pose is the one recorded at that report. Reports are matched in order by their counters as
    the Jaguar driver reads them (board channel 0 = left track; ``config``'s channels and signs;
    counters modulo the driver's modulus): a fresh row takes the next report with its counters,
    a repeated row the same report. None when a row matches no report (nothing to align)."""
    n = len(log)
    if n == 0 or not samples:
        return None
    m = min(params.encoder_modulus or 65536, 65536)  # the Jaguar driver's counter modulus

    def seen(raw: tuple[int, int]) -> tuple[int, int]:
        pos = (raw[0] % m, raw[1] % m)
        left, right = pos[config.left_channel], pos[config.right_channel]
        if config.left_encoder_sign < 0:
            left = (-left) % m
        if config.right_encoder_sign < 0:
            right = (-right) % m
        return left, right

    keys = [seen((a, b)) for a, b, _ in samples]
    j = -1
    poses: list[Pose] = []
    for k in range(n):
        want = (log.left_ticks[k] % m, log.right_ticks[k] % m)
        if j < 0 or log.fresh[k] or keys[j] != want:
            found = next((i for i in range(j + 1, len(keys)) if keys[i] == want), None)
            if found is None:
                if j < 0 or keys[j] != want:
                    return None
                found = j
            j = found
        poses.append(samples[j][2])
    x0, y0, h0 = poses[0].x, poses[0].y, poses[0].heading
    c, s = math.cos(h0), math.sin(h0)
    x = np.array([p.x - x0 for p in poses])
    y = np.array([p.y - y0 for p in poses])
    heading = np.array([p.heading - h0 for p in poses])
    return Trajectory.from_xyh(np.asarray(log.t), c * x + s * y, -s * x + c * y, heading)


@dataclass(frozen=True)
class ExplorePlan:
    """A checked exploration: the command (limits chosen), where its ground truth comes from
    (``virtual`` or a source the user named) and the nominal parameters' name (for the fit
    line)."""

    command: Command
    ground_truth: str
    params_name: str = "jaguar-lite"
    #: the limits not given and chosen here, the settings as marks (e.g. "{{max_speed}} 0.5 m/s")
    chosen: tuple[str, ...] = ()
    #: how what the run writes (run.json's attach line) names the settings: the face's words
    words: Wording = NEUTRAL

    def describe(self) -> str:
        """What it will drive, every choice said."""
        e = self.command.explore
        assert e is not None
        truth = GROUND_TRUTH_SOURCES[self.ground_truth]
        text = f"exploration: {e.describe()}; ground truth: {truth}"
        if self.chosen:
            text += f" (not given, so chosen: {', '.join(self.chosen)})"
        return text

    def _finish(
        self,
        motion: Explore,
        recorder: TruthRecorder | None,
        config: RunConfig,
        params: RobotParams,
    ) -> Finish:
        e = self.command.explore
        assert e is not None

        def finish(run: RobotRun) -> RobotRun:
            truth = None
            if recorder is not None:
                truth = truth_on_log(list(recorder.samples), run.loop.log, config, params)
            log = run.loop.log
            radius = 0.0  # the farthest the odometry went from the start (the fence's centre)
            if len(log) > 0:
                x, y = np.asarray(log.x), np.asarray(log.y)
                radius = float(np.max(np.hypot(x - x[0], y - y[0])))
            record: dict[str, object] = {
                "seconds": e.seconds,
                "max_speed": e.max_speed,
                "max_turn_rate": e.max_turn_rate,
                "hold": list(e.hold),
                "fence": e.fence,
                "distribution": e.distribution,
                "seed": e.seed,
                "fence_crossed": motion.fence_crossed,
                "crossed_at": list(motion.crossed_at) if motion.crossed_at else None,
                "largest_radius": radius,
                "commands": [list(c) for c in motion.commands],
                # the fence under the odometry's uncertainty (issue 39)
                "confidence": motion.confidence,
                "margin_source": motion.noise_source,
                "largest_margin": motion.largest_margin,
                "uncertainty_stop": (
                    list(motion.uncertainty_stop) if motion.uncertainty_stop else None
                ),
            }
            if truth is not None and len(truth) > 0:  # the virtual robot: where it truly went
                true_r = np.hypot(truth.x - truth.x[0], truth.y - truth.y[0])
                record["true_largest_radius"] = float(true_r.max())
                record["true_time_outside"] = _time_outside(truth.t, true_r, e.fence)
            source = self.ground_truth
            gt: dict[str, object] = {"source": source, "file": None, "attach": None}
            if source == "virtual":
                gt["file"] = TRUTH_FILE if truth is not None else None
                if truth is None:
                    gt["attach"] = "the true path could not be aligned with the encoder log"
            else:  # said from inside the run folder
                gt["attach"] = self.words.say(attach_sentence(source, "."))
            trial, loop = run.trial, run.loop
            if motion.fence_crossed and motion.crossed_at is not None:
                t, r = motion.crossed_at
                why = (
                    f"fence crossed: {r:.3f} m from the start by odometry at t={t:.2f} s "
                    f"(fence {e.fence:g} m); the robot was stopped there"
                )
                loop = replace(loop, completed=False, aborted=loop.aborted or why)
                reason = trial.exclusion_reason or why
                trial = replace(trial, status=TrialStatus.EXCLUDED, exclusion_reason=reason)
            trial = replace(trial, notes=f"exploration: {e.describe()}. {trial.notes}".strip())
            return replace(
                run,
                trial=trial,
                loop=loop,
                truth=truth,
                extra={**run.extra, "exploration": record, "ground_truth": gt},
            )

        return finish

    def run(
        self,
        *,
        config: RunConfig,
        robot: str,
        params: RobotParams,
        plant: PlantFactory | None = None,
        seed: int = DEFAULT_SEED,
        terrain: str = DEFAULT_TERRAIN,
        on_cycle: Callable[[CycleInfo], None] | None = None,
        on_event: Callable[[float, str], None] | None = None,
        realtime: bool = False,
        save_to: str | Path | None = None,
        on_abort: Callable[[AbortReport], object] | None = None,
        campaign: str = "robot",
    ) -> RobotRun:
        """Drive it in real time over the link ``robot`` names (:func:`run_motion`, every safety
        rule of the live stack); on the virtual robot, record its true path."""
        check_motion(self.command, config, params)
        motion = Explore.from_exploration(self.command)
        recorder: TruthRecorder | None = None
        factory = plant
        if is_virtual(robot):
            base: PlantFactory = plant if plant is not None else (lambda: IdealPlant(params))

            def factory() -> Plant:
                nonlocal recorder
                recorder = TruthRecorder(base())
                return recorder

        def finish(run: RobotRun) -> RobotRun:
            return self._finish(motion, recorder, config, params)(run)

        run = run_motion(
            self.command, config=config, robot=robot, params=params, motion=motion,
            plant=factory, seed=seed, terrain=terrain, campaign=campaign, on_cycle=on_cycle,
            on_event=on_event, realtime=realtime, save_to=save_to, on_abort=on_abort,
            finish=finish,
        )  # fmt: skip
        return run

    def simulate(
        self,
        plant: Plant,
        *,
        params: RobotParams,
        config: RunConfig | None = None,
        terrain: str = DEFAULT_TERRAIN,
        seed: int = DEFAULT_SEED,
        report_rate: float = 10.0,
        save_to: str | Path | None = None,
        on_cycle: Callable[[CycleInfo], None] | None = None,
    ) -> RobotRun:
        """The same exploration through the same driver and loop in simulated time
        (:func:`run_simulated`, the UDP Jaguar's board in-process over ``plant``), its true path
        recorded."""
        config = config or RunConfig()
        check_motion(self.command, config, params)
        motion = Explore.from_exploration(self.command)
        recorder = TruthRecorder(plant)
        return run_simulated(
            motion, None, params, terrain, seed,
            command=self.command, plant=recorder, config=config, report_rate=report_rate,
            max_duration=None, campaign="sim", on_cycle=on_cycle, save_to=save_to,
            finish=self._finish(motion, recorder, config, params),
        )  # fmt: skip

    def outcome(self, run: RobotRun) -> tuple[list[str], str | None]:
        """The lines that say what the exploration did and where its run and truth are, and the
        sentence of its failure (None when it stayed inside the fence)."""
        record = run.extra.get("exploration", {})
        gt = run.extra.get("ground_truth", {})
        e = self.command.explore
        assert e is not None
        n = len(record.get("commands", []))
        radius = float(record.get("largest_radius", math.nan))
        lines = [f"explored with {n} commands; largest distance from the start {radius:.2f} m "
                 f"by odometry (fence {e.fence:g} m)"]  # fmt: skip
        folder = run.saved_to
        if folder is not None:
            log = folder / "encoders.csv"
            if gt.get("file"):
                lines.append(
                    f"run: {log}; ground truth: {folder / gt['file']} "
                    f"({GROUND_TRUTH_SOURCES[self.ground_truth]})"
                )
                lines.append(
                    f"fit a slip model: odolab calibrate lsq {log} -f csv -p {self.params_name} "
                    f"{opt('model')} slip -o {folder / 'slip.toml'}"
                )
            elif self.ground_truth == "virtual":
                lines.append(f"run: {log}; no ground truth: {gt.get('attach')}")
            else:
                lines.append(
                    f"run: {log}; ground truth: {GROUND_TRUTH_SOURCES[self.ground_truth]}, not "
                    f"attached yet: {attach_sentence(self.ground_truth, folder)}"
                )
        lines.extend(_uncertainty_lines(record, e.fence, e.seconds))
        error = None
        kept = f"is kept{f' in {folder}' if folder is not None else ''}"
        if record.get("fence_crossed"):
            error = (
                f"the exploration left its {e.fence:g} m fence ({run.loop.aborted}): it ended "
                f"early and {kept}"
            )
        elif record.get("true_largest_radius", 0.0) > e.fence:
            error = (
                f"the virtual robot truly left the {e.fence:g} m fence, though its odometry did "
                f"not: {record['true_largest_radius']:.3f} m from the start at most, "
                f"{record['true_time_outside']:.1f} s outside (odometry said {radius:.3f} m at "
                f"most); the run {kept}"
            )
        return lines, error


def _time_outside(t: np.ndarray, r: np.ndarray, fence: float) -> float:
    """Seconds of the log the true robot spent beyond the fence (each row holds until the
    next)."""
    if t.size < 2:
        return 0.0
    return float(np.sum(np.diff(t)[r[:-1] > fence]))


def _uncertainty_lines(record: dict[str, Any], fence: float, seconds: float) -> list[str]:
    """What the fence under uncertainty did: its margin (and where its covariance came from),
    an early end for the uncertainty, where the virtual robot truly went."""
    lines = []
    confidence = float(record.get("confidence", 0.0))
    if confidence > 0:
        lines.append(
            f"fence kept at {confidence:.0%} confidence under the odometry's uncertainty: "
            f"margin up to {record.get('largest_margin', 0.0):.3f} m (covariance: "
            f"{record.get('margin_source') or 'none'})"
        )
    stop = record.get("uncertainty_stop")
    if stop:
        t, r, margin = stop
        lines.append(
            f"ended at t={t:.1f} s of its {seconds:g} s: {r:.3f} m from the start by odometry "
            f"with a margin of {margin:.3f} m left no room inside the {fence:g} m fence (the "
            "robot may be off by that much); a larger fence, or calibrated parameters with a "
            "[noise] table, let it explore longer"
        )
    if "true_largest_radius" in record:
        lines.append(
            f"the virtual robot's true path: {record['true_largest_radius']:.3f} m from the "
            f"start at most, {record.get('true_time_outside', 0.0):.1f} s outside the fence"
        )
    return lines


def plan_exploration(
    command: Command,
    config: RunConfig,
    params: RobotParams,
    url: str,
    ground_truth: str | None = None,
    *,
    params_name: str | None = None,
    words: Wording = NEUTRAL,
) -> ExplorePlan:
    """The checked plan of an exploration on the robot at ``url`` (checked): its unset speed
    limits chosen, every setting checked (:func:`check_motion`), the ground-truth source
    (``virtual`` on ``sim://``; required, and one of mocap/track/laser, on a real robot).
    Raises :class:`RobotConfigError` (one sentence naming the option); nothing is sent.
    ``words``: how the run's written record names the settings (the face's)."""
    filled, chosen = _choose_limits(command, config, params)
    check_motion(filled, config, params)
    source = _check_ground_truth(url, ground_truth)
    return ExplorePlan(filled, source, params_name or params.name, chosen, words)


def notebook_trial(trial: Trial) -> Trial:
    """``trial`` as the notebook keeps it: an exploration is not a Table I trial, so it becomes
    a free run, EXCLUDED from the analysis with the exploration named (its log and truth stay in
    the run folder); any other trial unchanged."""
    e = trial.command.explore
    if e is None:
        return trial
    why = f"an exploration ({e.describe()}), not a Table I trial"
    if trial.exclusion_reason:
        why = f"{why}; {trial.exclusion_reason}"
    return replace(
        trial,
        command=Command(MotionKind.FREE),
        status=TrialStatus.EXCLUDED,
        exclusion_reason=why,
    )

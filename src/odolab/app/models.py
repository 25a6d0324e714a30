"""Which model a robot needs: ``odolab calibrate compare`` and the lab's models step both call
this module, so that the terminal, ``--json`` and the report give the same numbers.

:func:`compare_runs` (runs in memory) and :func:`compare_files` (runs on disk) are the one call
to :func:`odolab.calibration.compare.compare_models`; a :class:`CompareRequest` says which
models, which seconds of a learning curve, which seed.

**The slip rule** (issue 29), used by the lab when its truth has speed-dependent slip
(:func:`exploration_reason` says when, or why not):

- drive one exploration of :data:`EXPLORE_SECONDS` (:func:`odolab.sim.explore.explore`, default
  limits: commands uniform over ``|v| <= 1 m/s``, ``|w| <= 2 rad/s``, held 1 to 3 s, inside a
  4 m fence) with the lab's seed;
- fit every model of :data:`SLIP_MODELS` on the *same* data, the exploration run alone (the
  minute of driving the slip model is meant to learn from), and score them on the held-out runs
  of the kinematic comparison;
- the learning curve (:data:`CURVE_SECONDS`): each model fitted on the first seconds of the
  exploration run alone, mean held-out end-point error (``compare_models(curve=...)``);
- the lab's speed question from the slip model's coefficients:
  :meth:`odolab.core.models.slip.SlipModel.speed_slip_gain` between two speeds with its 95 % interval.

:func:`slip_comparison` does all of it and returns a :class:`SlipComparison`, whose
:meth:`~SlipComparison.to_dict` is the report's ``slip`` entry (with the equivalent
``odolab calibrate compare`` command line when the runs were written to files).
"""

from __future__ import annotations

import math
import shlex
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from odolab.calibration.compare import DEFAULT_MODELS
from odolab.core.defaults import DEFAULT_TERRAIN
from odolab.core.errors import opt

if TYPE_CHECKING:
    from odolab.calibration.compare import ModelComparison
    from odolab.calibration.lsq import LsqOptions
    from odolab.core.params import RobotParams
    from odolab.core.progress import Progress
    from odolab.io.run import OdometryRun, ReadOptions
    from odolab.sim.explore import ExploreSettings
    from odolab.sim.physics import TrueParams

__all__ = [
    "CURVE_SECONDS",
    "EXPLORE_SECONDS",
    "SLIP_MODELS",
    "SPEEDS",
    "CompareRequest",
    "SlipComparison",
    "compare_files",
    "compare_runs",
    "exploration_reason",
    "slip_comparison",
    "slip_request",
]

#: The models of the slip comparison, simplest first (the recommendation prefers the left).
SLIP_MODELS = ("diff", "extended", "icr", "slip")
#: Seconds of the exploration run each point of the learning curve is fitted on.
CURVE_SECONDS = (10.0, 20.0, 30.0, 45.0, 60.0)
#: How long the lab explores (s).
EXPLORE_SECONDS = 60.0
#: The speed question's two speeds (m/s) when the lab has no speed experiment to take them from.
SPEEDS = (0.1, 0.5)
#: Length (s) of the pieces the slip model's predictive covariance is judged on (NEES) on the
#: held-out runs: a horizon its variance terms were fitted for (1 s and 3 s pieces).
NEES_PIECE_S = 3.0


@dataclass(frozen=True)
class CompareRequest:
    """What to compare: ``models`` (simplest first), ``curve`` the learning curve's seconds of
    the first training run (empty: none), ``seed`` of the bootstrap, ``n_boot`` resamples,
    ``options`` of the least-squares fits (None: the defaults)."""

    models: tuple[str, ...] = DEFAULT_MODELS
    curve: tuple[float, ...] = ()
    seed: int = 0
    n_boot: int = 2000
    options: LsqOptions | None = None


def slip_request(seed: int) -> CompareRequest:
    """The slip rule's request: :data:`SLIP_MODELS`, the curve over :data:`CURVE_SECONDS`."""
    return CompareRequest(models=SLIP_MODELS, curve=CURVE_SECONDS, seed=seed)


def compare_runs(
    train: Sequence[OdometryRun],
    held_out: Sequence[OdometryRun],
    nominal: RobotParams | None,
    request: CompareRequest,
) -> ModelComparison:
    """:func:`~odolab.calibration.compare.compare_models` of runs in memory."""
    from odolab.calibration.compare import compare_models

    return compare_models(
        train, held_out, nominal, models=request.models, options=request.options,
        n_boot=request.n_boot, seed=request.seed, curve=request.curve,
    )  # fmt: skip


def compare_files(
    paths: Sequence[str | Path],
    fmt: str,
    request: CompareRequest,
    *,
    validate: Sequence[str | Path] = (),
    nominal: RobotParams | None = None,
    read_options: ReadOptions | None = None,
    workers: int | None = None,
    progress: Progress | None = None,
    where: list[str] | None = None,
) -> ModelComparison:
    """:func:`compare_runs` of the runs found under ``paths`` (and held out: ``validate``);
    ``where`` (when given) gets where odolab chose to read them, and why."""
    if request.n_boot != 2000:  # the files' comparison has the default resampling only
        from odolab.core.errors import CalibrationError

        raise CalibrationError(
            f"n_boot is {request.n_boot}; comparing files uses 2000 bootstrap resamples"
        )
    from odolab.calibration.compare import compare_model_files  # looked up on each call

    return compare_model_files(
        paths, fmt, validate=validate, nominal=nominal, models=request.models,
        options=request.options, read_options=read_options, workers=workers,
        progress=progress, seed=request.seed, curve=request.curve, where=where,
    )  # fmt: skip


def exploration_reason(truth: TrueParams, truth_name: str) -> str | None:
    """None when the lab explores on this truth (it has speed-dependent slip); else one
    sentence saying why it does not."""
    if truth.speed_slip > 0:
        return None
    return (
        f"No exploration run: the truth preset {truth_name} has no speed-dependent slip "
        f"(speed_slip {truth.speed_slip:g} s/m), so the slip model has nothing to learn that the "
        "kinematic models miss; the demo on the truth preset jaguar-lab-tracked drives a "
        "one-minute exploration and compares the slip model with them."
    )


@dataclass(frozen=True)
class Invocation:
    """An ``odolab`` command line with its settings by their library names
    (:data:`odolab.core.errors.OPTION_NAMES`): each face writes them in its own flags."""

    #: the command's words and its positional arguments (``calibrate``, ``compare``, files...)
    words: tuple[str, ...]
    #: (setting, its values) in order; a switch has no values
    options: tuple[tuple[str, tuple[str, ...]], ...] = ()

    def __post_init__(self) -> None:
        for name, _ in self.options:
            opt(name)  # (a KeyError for a setting without words: one table of names)

    def line(self, flag: Callable[[str], str]) -> str:
        """The command line to type, quoted for a POSIX shell, with ``flag(setting)`` for each
        setting (``odolab.cli.wording.flag`` gives the CLI's)."""
        options = [w for name, values in self.options for w in (flag(name), *values)]
        return shlex.join(["odolab", *self.words, *options])


@dataclass(frozen=True)
class SlipComparison:
    """The slip rule's result (see the module)."""

    settings: ExploreSettings
    seed: int
    terrain: str
    comparison: ModelComparison
    train: tuple[str, ...]
    held_out: tuple[str, ...]
    speeds: tuple[float, float]
    #: slip(v_high) - slip(v_low) as a fraction, with its 95 % interval (None: no slip fit)
    speed_gain: tuple[float, float, float] | None
    speed_problem: str | None = None
    #: the run files (the exploration; then the held-out ones)
    files: tuple[Path, ...] = ()
    held_files: tuple[Path, ...] = ()
    #: the ``--params`` of :meth:`command`: a preset's name, or the file the nominal was written to
    params_arg: str = ""
    measured: dict[str, object] = field(default_factory=dict)
    #: :meth:`command`'s paths are relative to this folder (None: as they are)
    base: Path | None = None
    #: NEES of the slip fit's predictive covariance on the held-out runs (pieces of
    #: :data:`NEES_PIECE_S`): :meth:`odolab.metrics.consistency.NeesSummary.to_dict` and
    #: ``piece_s``, or ``{"problem": why}``; empty without a slip fit
    nees: dict[str, object] = field(default_factory=dict)
    #: where the slip fit's parameters were written (for :meth:`nees_command`), else None
    slip_params: Path | None = None

    def command(self) -> Invocation | None:
        """The ``odolab calibrate compare`` invocation that gives the same comparison from the
        written files (None without files); a face writes it with its flags
        (:meth:`Invocation.line`), and the tests run it from the demo's results.json."""
        if not self.files:
            return None
        req = slip_request(self.seed)
        params = (
            self._shown(Path(self.params_arg))
            if self.params_arg.endswith(".toml")
            else self.params_arg
        )
        return Invocation(
            ("calibrate", "compare", *map(self._shown, self.files)),
            (
                ("validate", tuple(map(self._shown, self.held_files))),
                ("format", ("csv",)),
                ("params", (params,)),
                ("models", (",".join(req.models),)),
                ("learning_curve", (",".join(f"{s:g}" for s in req.curve),)),
                ("seed", (str(self.seed),)),
                ("json", ("compare.json",)),
            ),
        )

    def nees_command(self) -> Invocation | None:
        """The ``odolab evaluate --nees`` invocation that gives :attr:`nees` from the written
        files (None without them)."""
        if not self.held_files or self.slip_params is None:
            return None
        return Invocation(
            ("evaluate", *map(self._shown, self.held_files)),
            (
                ("format", ("csv",)),
                ("params", (self._shown(self.slip_params),)),
                ("nees", ()),
                ("nees_segment", (f"{NEES_PIECE_S:g}",)),
            ),
        )

    def _shown(self, path: Path) -> str:
        if self.base is not None and path.is_relative_to(self.base):
            return str(path.relative_to(self.base))
        return str(path)

    def about(self) -> str:
        s = self.settings
        return (
            f"One exploration of {s.seconds:g} s on {self.terrain} (odolab sim explore, seed "
            f"{self.seed}): commands drawn {s.distribution} over |v| <= {s.max_speed:g} m/s and "
            f"|w| <= {s.max_turn_rate:g} rad/s (both tracks within {s.max_speed:g} m/s), each "
            f"held {s.hold[0]:g} to {s.hold[1]:g} s, inside a fence of {s.fence_radius:g} m. "
            f"Every model ({', '.join(SLIP_MODELS)}) is fitted on the same data, the exploration "
            f"alone, and scored on the {len(self.held_out)} held-out runs of the kinematic "
            f"comparison ({', '.join(self.held_out)}). The learning curve fits each model on the "
            "first seconds of the exploration."
        )

    def speed_dict(self) -> dict[str, object]:
        v_low, v_high = self.speeds
        out: dict[str, object] = {"v_low": v_low, "v_high": v_high}
        if self.speed_gain is None:
            out.update(gain_pct=None, ci95=[None, None], problem=self.speed_problem, answer="")
        else:
            g, lo, hi = (100.0 * x for x in self.speed_gain)
            more = "more" if g >= 0 else "less"
            ci = (
                f"95 % interval [{lo:+.1f}, {hi:+.1f}] percentage points"
                if math.isfinite(lo) and math.isfinite(hi)
                else "no interval: the fit has no posterior"
            )
            out.update(
                gain_pct=g,
                ci95=[lo, hi],
                problem=None,
                answer=(
                    f"the slip model says {v_high:g} m/s slips {abs(g):.1f} % {more} than "
                    f"{v_low:g} m/s driving straight ({ci}; from its coefficients "
                    "fwd_v, fwd_absv, fwd_v_absv and their posterior)"
                ),
            )
        if self.measured:
            out["measured"] = dict(self.measured)
        return out

    def to_dict(self, flag: Callable[[str], str] | None = None) -> dict[str, object]:
        """The report's ``slip`` entry; its command lines in the flags ``flag`` gives a setting
        (a face's words), or empty without it."""
        s = asdict(self.settings)
        command, nees_command = self.command(), self.nees_command()
        return {
            "exploration": {**s, "seed": self.seed, "terrain": self.terrain},
            "about": self.about(),
            "comparison": self.comparison.to_dict(),
            "speed_question": self.speed_dict(),
            "files": [self._shown(p) for p in (*self.files, *self.held_files)],
            "command": command.line(flag) if command and flag else "",
            "nees": dict(self.nees),
            "nees_command": nees_command.line(flag) if nees_command and flag else "",
        }


def _measured_answer(questions: Sequence[Any], speeds: tuple[float, float]) -> dict[str, object]:
    """The speed experiment's measured answer between the two speeds, when the questions have
    one (``speed-sweep``)."""
    for res in questions:
        if res.experiment.name != "speed-sweep":
            continue
        for e in res.effects:
            a, b = res.condition(e.a).condition.speed, res.condition(e.b).condition.speed
            if (min(a, b), max(a, b)) == speeds:
                sign = 1.0 if a > b else -1.0
                lo, hi = sorted((sign * e.low, sign * e.high))
                return {
                    "experiment": res.experiment.name,
                    "difference_pct": sign * e.difference,
                    "ci95": [lo, hi],
                    "answer": e.sentence(),
                }
    return {}


def speeds_of(questions: Sequence[Any]) -> tuple[float, float]:
    """The speed question's two speeds: those of the speed experiment's first effect, else
    :data:`SPEEDS`."""
    for res in questions:
        if res.experiment.name == "speed-sweep" and res.effects:
            e = res.effects[0]
            a, b = res.condition(e.a).condition.speed, res.condition(e.b).condition.speed
            if a > 0 and b > 0 and a != b:
                return (min(a, b), max(a, b))
    return SPEEDS


def _write_run(folder: Path, run: OdometryRun) -> Path:
    from odolab.io.tabular import write_columns
    from odolab.io.trajectory_csv import write_trajectory_csv

    path = write_columns(
        folder / f"{run.name}.csv",
        {"t": run.t, "dticks_left": run.dticks_left, "dticks_right": run.dticks_right},
        "encoder log",
    )
    write_trajectory_csv(folder / f"{run.name}_gt.csv", run.require_ground_truth())
    return path


def slip_comparison(
    truth: TrueParams,
    nominal: RobotParams,
    held_out: Sequence[OdometryRun],
    *,
    seed: int,
    terrain: str = DEFAULT_TERRAIN,
    questions: Sequence[Any] = (),
    folder: Path | None = None,
    base: Path | None = None,
) -> SlipComparison:
    """The slip rule (see the module): explore, compare, learning curve, speed question.

    ``questions``: the lab's open questions (their speed experiment gives the speeds and the
    measured answer); ``folder``: write every run there as CSV (``<name>.csv`` and
    ``<name>_gt.csv``) so that :meth:`SlipComparison.command` reproduces the comparison (run from
    ``base``, the folder its paths are relative to)."""
    from odolab.core.errors import ParamsError
    from odolab.core.models import timed_model
    from odolab.core.trajectory import Trajectory
    from odolab.io.run import OdometryRun
    from odolab.sim.explore import ExploreSettings, explore

    settings = ExploreSettings(seconds=EXPLORE_SECONDS)
    d = explore(truth, nominal, settings, terrain=terrain, seed=seed)
    gt = Trajectory.from_xyh(d.t, d.x, d.y, d.heading)
    exploration = OdometryRun("explore", "explore", d.t, d.dticks_left, d.dticks_right,
                              ground_truth=gt)  # fmt: skip
    runs = [exploration]
    comparison = compare_runs(runs, held_out, nominal, slip_request(seed))
    speeds = speeds_of(questions)
    gain: tuple[float, float, float] | None = None
    problem: str | None = None
    slip = next((s for s in comparison.scores if s.model == "slip"), None)
    if slip is None or slip.fit is None:
        problem = f"no slip model: {slip.problem if slip else 'not compared'}"
    elif (model := timed_model(slip.fit.params.model)) is None:
        problem = "no slip model: the fit gave another model"
    else:
        try:
            gain = model.speed_slip_gain(*speeds)
        except ParamsError as err:
            problem = str(err)
    nees: dict[str, object] = {}
    if slip is not None and slip.fit is not None:
        nees = _held_out_nees(slip.fit.params, held_out)
    files: tuple[Path, ...] = ()
    held_files: tuple[Path, ...] = ()
    params_arg = ""
    slip_params: Path | None = None
    if folder is not None:
        files = tuple(_write_run(folder, r) for r in runs)
        held_files = tuple(_write_run(folder, r) for r in held_out)
        params_arg = _params_arg(folder, nominal)
        if slip is not None and slip.fit is not None:
            from odolab.core.params import save_params

            slip_params = save_params(folder / "slip.toml", slip.fit.params)
    return SlipComparison(
        settings, seed, terrain, comparison, tuple(r.name for r in runs),
        tuple(r.name for r in held_out), speeds, gain, problem, files, held_files,
        params_arg, _measured_answer(questions, speeds), base, nees, slip_params,
    )  # fmt: skip


def _held_out_nees(params: RobotParams, held_out: Sequence[OdometryRun]) -> dict[str, object]:
    """NEES of a slip fit's predictive covariance on the held-out runs, as `odolab evaluate
    --nees --nees-segment` gives it (pieces of :data:`NEES_PIECE_S`)."""
    from odolab.core.errors import OdolabError
    from odolab.metrics.consistency import nees_summary, run_nees, runs_truth_noise

    truth = runs_truth_noise(held_out)  # (evaluate --nees's default: estimated from the truth)
    try:
        summary = nees_summary(
            [run_nees(r, params, segment_s=NEES_PIECE_S, truth=truth) for r in held_out]
        )
    except OdolabError as err:
        return {"piece_s": NEES_PIECE_S, "problem": str(err)}
    return {"piece_s": NEES_PIECE_S, **summary.to_dict()}


def _params_arg(folder: Path, nominal: RobotParams) -> str:
    """The preset's name when ``nominal`` is a preset, else the file it is written to."""
    from odolab.core.params import PRESETS, save_params

    if PRESETS.get(nominal.name) == nominal:
        return nominal.name
    return str(save_params(folder / "nominal.toml", nominal))

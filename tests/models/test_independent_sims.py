"""Issue 29's goals on simulators that odolab did not write (:mod:`.independent_sims`).

odolab is run on their files the way a user runs it: ``odolab calibrate compare`` (training: the
60 s exploration; held out: the square, arcs, spins and mixed runs) and ``odolab calibrate lsq
--model diff/icr/slip`` on the exploration, whose parameters files give the held-out end-point
errors (odometry from the ground truth's first pose, end against end) and the slip model's NEES.

Measured (held-out end-point error in m, mean over the four held-out runs; "n/i": the ICR model
refused as not identifiable; slip/best: slip over the best of diff, extended, icr; floor: the
same runs' end points with and without the simulator's noise, what no model can predict;
``pytest -s`` prints the table, the lsq files' errors and the NEES):

    sim                seed  diff   extended  icr    slip   slip/best  floor  recommends
    icr-speed             1  1.635  1.635     1.154  0.522  0.45       0.304  slip
    icr-speed             2  2.084  2.084     2.038  0.517  0.25       0.142  slip
    icr-speed             3  1.187  1.187     1.428  0.235  0.20       0.157  slip
    icr-speed             4  1.503  1.503     2.190  0.369  0.25       0.200  slip
    skid-dynamic          1  1.931  1.931     1.870  0.569  0.30       0.340  slip
    skid-dynamic          2  1.516  1.516     1.570  0.473  0.31       0.167  slip
    skid-dynamic          3  1.265  1.265     1.117  0.171  0.15       0.177  slip
    skid-dynamic          4  1.147  1.147     1.237  0.232  0.20       0.186  slip
    icr-speed-constant    1  0.497  0.497     0.367  0.574  1.56       0.344  icr
    icr-speed-constant    2  0.415  0.415     0.250  0.176  0.70       0.188  icr
    icr-speed-constant    3  0.261  0.261     0.173  0.167  0.97       0.185  icr
    icr-speed-constant    4  0.611  0.611     0.110  0.187  1.70       0.174  icr

(odolab at cc3ea73 and afb2c58: the slip fit on steady-state windows, its prior on the fitted ICR
model, ARD). Before: at 703892d the ICR model was refused on every speed-slip exploration
("x_icr is not identifiable without turns of both signs at speed") and slip/best read 0.14,
0.29, 0.20, 0.20 | 0.16, 0.50, 0.99, 0.61; at 32fba30 0.26, 0.21, 0.22, 0.14 | 0.42, 0.78,
0.87, 0.36. The skid-dynamic error then was bias, not data or noise: 180 s of exploration gave
0.90, 0.92, 0.86 m (seeds 2-4, fit as at 01:30 UTC), the noiseless simulator 0.61-0.77 of diff,
and without the simulator's yaw lag (a transient no function of the speeds describes) the ratio
fell to 0.23-0.40 on two of three seeds: what the steady-state windows fixed.

NEES of the slip model on the held-out runs (printed by ``-s``), at afb2c58 (the parameters file
carries the coefficients' posterior, so the file's NEES is the fit's): mean over 1 s pieces
2.4-4.0 (icr-speed), 1.7-3.0 (skid-dynamic) against the mean's bounds [2.58, 3.45], 77-97 % of
pieces inside one piece's [0.216, 9.35]; over 5 s pieces 3.8-6.8 (icr-speed, bounds [2.08,
4.08]) and 1.0-2.1 (skid-dynamic). At cc3ea73 the file (noise terms only) gave means of 2.5e4
and 5.4e3 on skid-dynamic seeds 2 and 3: its q_fwd, q_lat, q_yaw were about 1e-12, 1e-12,
9e-10, so on a straight (no commanded turn) the heading variance was almost zero (NEES up to
6e5 on the square's straights); the posterior now hides that, the noise terms still lack it.

The end-point and recommendation goals hold and are asserted below (the goal itself per seed,
the pooled ratio with a margin); the NEES is printed, not asserted.
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pytest

from fixture_cache import cached, slip_fits_once
from odolab.calibration.slipfit import nees_bounds, nees_pieces
from odolab.cli import main
from odolab.core.models import SlipModel
from odolab.core.odometry import integrate_increments
from odolab.core.params import PRESETS, load_params
from odolab.io.registry import read_run

from .independent_sims import (
    METRES_PER_TICK,
    TRACK_WIDTH,
    IcrSpeedSim,
    SkidDynamicSim,
    constant_slip,
    exploration,
    held_out_runs,
    simulate,
    write_run,
)

#: `make test-fast` leaves these out (80 s of fits on the independent simulators); `make test` and CI run them
pytestmark = pytest.mark.slow

SEEDS = (1, 2, 3, 4)
SIMS: dict[str, IcrSpeedSim | SkidDynamicSim] = {
    "icr-speed": IcrSpeedSim(),
    "skid-dynamic": SkidDynamicSim(),
}
CONTROL = constant_slip(IcrSpeedSim())
MODELS = ("diff", "extended", "icr", "slip")
KINEMATIC = ("diff", "extended", "icr")
NEES_PIECES = (1.0, 5.0)
LSQ = ("diff", "icr", "slip")
NOMINAL = PRESETS["jaguar-lite"]


@dataclass
class Measured:
    """One simulator and seed, as odolab's CLI reports it."""

    sim: str
    seed: int
    #: compare's held-out end-point error (mean over the runs), None where not fitted
    endpoint: dict[str, float | None]
    #: compare's per-run end-point errors
    per_run: dict[str, list[float]]
    problems: dict[str, str | None]
    recommended: str
    reason: str
    #: held-out end-point error from `calibrate lsq --model M -o file` (computed here)
    lsq_endpoint: dict[str, float | None] = field(default_factory=dict)
    #: NEES of the slip model on held-out pieces: piece_s -> values (the parameters file's)
    nees: dict[float, list[float]] = field(default_factory=dict)
    #: the same with `calibrate_lsq`'s result (its posterior; a file keeps it since afb2c58)
    #: held-out end-point distance between the noisy truth and the same run without noise
    floor: float = 0.0
    #: compare's segment error ratio to the best model, 95 % CI (None where not fitted)
    ratio_ci: dict[str, list[float] | None] = field(default_factory=dict)

    @property
    def best_kinematic(self) -> float:
        return min(v for m, v in self.endpoint.items() if m in KINEMATIC and v is not None)

    @property
    def ratio(self) -> float:
        slip = self.endpoint["slip"]
        assert slip is not None
        return slip / self.best_kinematic


def _cli(args: list[str]) -> int:
    return main([*args, "--format", "csv", "--params", "jaguar-lite", "--workers", "1"])


def _endpoint(log: Path, params_file: Path) -> float:
    """Odometry of a held-out run with a parameters file, from the ground truth's first pose:
    distance between its end and the ground truth's end."""
    run = read_run(log, "csv")
    gt = run.require_ground_truth()
    assert np.allclose(run.t, gt.t)  # written on the same stamps
    dl = np.asarray(run.dticks_left, dtype=np.float64)
    dr = np.asarray(run.dticks_right, dtype=np.float64)
    dl[0] = dr[0] = 0.0
    odo = integrate_increments(
        run.t, dl, dr, load_params(params_file),
        start=(float(gt.x[0]), float(gt.y[0]), float(gt.heading[0])),
    )  # fmt: skip
    return float(np.hypot(odo.x[-1] - gt.x[-1], odo.y[-1] - gt.y[-1]))


def _measure(
    sim: IcrSpeedSim | SkidDynamicSim, seed: int, folder: Path, *, lsq: tuple[str, ...] = ()
) -> Measured:
    ex = write_run(folder / "train", exploration(sim, seed))
    truth = held_out_runs(sim, seed)
    held = [write_run(folder / "held", r) for r in truth]
    quiet = held_out_runs(replace(sim, speed_noise=0.0, heading_walk=0.0), seed)
    floor = float(
        np.mean(
            [
                np.hypot(a.x[-1] - b.x[-1], a.y[-1] - b.y[-1])
                for a, b in zip(truth, quiet, strict=True)
            ]
        )
    )
    out = folder / "compare.json"
    code = _cli(["calibrate", "compare", str(ex), "--validate", *map(str, held),
                 "--models", ",".join(MODELS), "--json", str(out)])  # fmt: skip
    assert code == 0, (sim.name, seed)
    doc = json.loads(out.read_text())
    scores = {m["model"]: m for m in doc["models"]}
    m = Measured(
        sim.name,
        seed,
        endpoint={
            k: (s["held_out"]["endpoint_error"]["value"] if s["problem"] is None else None)
            for k, s in scores.items()
        },
        per_run={k: s["per_run"].get("endpoint_error", []) for k, s in scores.items()},
        problems={k: s["problem"] for k, s in scores.items()},
        recommended=doc["recommended"],
        reason=doc["reason"],
        floor=floor,
        ratio_ci={
            k: (s["ratio_to_best"]["ci95"] if s["ratio_to_best"] else None)
            for k, s in scores.items()
        },
    )
    for model in lsq:
        params = folder / f"{model}.toml"
        code = _cli(["calibrate", "lsq", str(ex), "--model", model, "-o", str(params)])
        m.lsq_endpoint[model] = (
            float(np.mean([_endpoint(h, params) for h in held])) if code == 0 else None
        )
        if model == "slip" and code == 0:
            runs = [read_run(h, "csv") for h in held]
            p = load_params(params)
            m.nees = {s: nees_pieces(runs, p, s).tolist() for s in NEES_PIECES}
            # the file carries the whole predictive variance: the coefficients' posterior and
            # the noise and drift terms the fit found (its NEES is the fit's own)
            assert isinstance(p.model, SlipModel) and p.model.posterior
            assert p.model.k_yaw > 0 or p.model.q_yaw > 0
    return m


#: what the measurements depend on besides odolab's source (tests/fixture_cache.py)
_DEPENDS = (Path(__file__), Path(__file__).with_name("independent_sims.py"))


def _measure_all(root: Path) -> dict[tuple[str, int], Measured]:
    out: dict[tuple[str, int], Measured] = {}
    with slip_fits_once():  # compare and lsq --model slip fit the same model
        for name, sim in SIMS.items():
            for seed in SEEDS:
                out[(name, seed)] = _measure(sim, seed, root / f"{name}-{seed}", lsq=LSQ)
    return out


def _measure_control(root: Path) -> dict[int, Measured]:
    return {seed: _measure(CONTROL, seed, root / f"control-{seed}") for seed in SEEDS}


@pytest.fixture(scope="module")
def measured(tmp_path_factory: pytest.TempPathFactory) -> dict[tuple[str, int], Measured]:
    """Built once for every test process (tests/fixture_cache.py): 80 s of fits."""
    dest = tmp_path_factory.mktemp("independent")
    return cached("independent-sims", _measure_all, dest, depends_on=_DEPENDS)


@pytest.fixture(scope="module")
def control(tmp_path_factory: pytest.TempPathFactory) -> dict[int, Measured]:
    dest = tmp_path_factory.mktemp("control")
    return cached("independent-control", _measure_control, dest, depends_on=_DEPENDS)


def _fmt(v: float | None) -> str:
    return "n/i" if v is None else f"{v:.3f}"


def test_the_simulators_are_independent_deterministic_and_on_the_preset() -> None:
    p = NOMINAL
    assert p.left_metres_per_tick == pytest.approx(METRES_PER_TICK)
    assert p.right_metres_per_tick == pytest.approx(METRES_PER_TICK)
    assert p.track_width == TRACK_WIDTH
    source = (Path(__file__).parent / "independent_sims.py").read_text()
    assert "import odolab" not in source and "from odolab" not in source
    for sim in (*SIMS.values(), CONTROL):
        a, b = exploration(sim, 3), exploration(sim, 3)
        assert np.array_equal(a.dticks_left, b.dticks_left) and np.array_equal(a.x, b.x)
        c = exploration(sim, 4)
        assert not np.array_equal(a.x, c.x)
        # 20 Hz, 60 s, integer counts, near the start (the fence is 3 m)
        assert a.t.size == 1201 and np.allclose(np.diff(a.t), 0.05)
        assert np.array_equal(a.dticks_left, np.round(a.dticks_left))
        # measured 2.25-3.22 over seed shifts 0-3 (3 cases); bound 4.5; at seed shift 0 it is 1.47x
        # the spread over seeds away
        assert float(np.max(np.hypot(a.x, a.y))) < 4.5
        runs = held_out_runs(sim, 1)
        assert [r.name for r in runs] == ["square", "arcs", "spins", "mixed"]
        # measured 36.0, 33.9, 26.25, 29.5 s (the protocols' lengths, the same for every sim)
        assert all(20.0 <= r.t[-1] <= 60.0 for r in runs)


def test_slip_grows_with_speed_only_where_it_is_meant_to() -> None:
    """Driving one turn rate at two speeds (no noise): the yaw achieved per commanded yaw falls
    with speed in both simulators and stays the same in the negative control."""

    def yaw_gain(sim: IcrSpeedSim | SkidDynamicSim, v: float) -> float:
        quiet = replace(sim, speed_noise=0.0, heading_walk=0.0)
        run = simulate(quiet, lambda t, x, y, h: (v, 0.6), 10.0, 1, "arc")
        dth = (run.dticks_right - run.dticks_left) * METRES_PER_TICK / TRACK_WIDTH
        return float(run.heading[-1] - run.heading[0]) / float(np.sum(dth))

    for sim in SIMS.values():
        # measured 0.646-0.725 over seed shifts 0-3 (2 cases); bound 0.669/0.765; at seed shift 0 it
        # is 85x the spread over seeds away
        assert yaw_gain(sim, 0.8) < 0.95 * yaw_gain(sim, 0.2), sim.name  # 0.92, 0.90
    # 1.02: the right track's 1.2 % larger radius turns the robot more at speed
    # measured |value - expected| 0.0182-0.0185 over seed shifts 0-3; tolerance 0.0258; at seed
    # shift 0 it is 19.8x the spread over seeds away
    assert yaw_gain(CONTROL, 0.8) == pytest.approx(yaw_gain(CONTROL, 0.2), rel=0.03)


def test_report(measured: dict[tuple[str, int], Measured], control: dict[int, Measured]) -> None:
    """Print the measurement (run with ``-s``); the goals are asserted in the tests below."""
    lines = [
        "sim                 seed  diff   extended  icr    slip   slip/best  floor  recommends",
    ]
    for m in [*measured.values(), *control.values()]:
        e = m.endpoint
        lines.append(
            f"{m.sim:19s} {m.seed:4d}  {_fmt(e['diff'])}  {_fmt(e['extended'])}     "
            f"{_fmt(e['icr']):5s}  {_fmt(e['slip'])}  {m.ratio:9.2f}  {m.floor:.3f}  "
            f"{m.recommended}"
        )
    for m in measured.values():
        if m.lsq_endpoint:
            lines.append(
                f"{m.sim} seed {m.seed}: from the lsq files: "
                + ", ".join(f"{k} {_fmt(v)}" for k, v in m.lsq_endpoint.items())
            )
    for m in measured.values():
        for label, nees in (("file", m.nees),):
            for s, v in nees.items():
                a = np.array(v)
                lo, hi = nees_bounds(1)
                glo, ghi = nees_bounds(a.size)
                lines.append(
                    f"{m.sim} seed {m.seed} NEES ({label}) {s:g} s pieces ({a.size}): mean "
                    f"{a.mean():.3g} (95 % bounds of the mean [{glo:.2f}, {ghi:.2f}]), median "
                    f"{np.median(a):.3g}, inside [{lo:.3f}, {hi:.2f}]: "
                    f"{np.mean((a >= lo) & (a <= hi)):.0%}"
                )
    for m in [*measured.values(), *control.values()]:
        lines.append(
            f"{m.sim} seed {m.seed}: segment error ratio to the best, 95 % CI: "
            + ", ".join(f"{k} {v[0]:.2f}-{v[1]:.2f}" for k, v in m.ratio_ci.items() if v)
        )
    for m in [*measured.values(), *control.values()]:
        if m.problems["icr"]:
            lines.append(f"{m.sim} seed {m.seed}: icr: {m.problems['icr']}")
    print("\n" + "\n".join(lines), file=sys.stderr)


def test_the_fit_files_give_the_end_point_errors_compare_reports(
    measured: dict[tuple[str, int], Measured],
) -> None:
    """`calibrate lsq -o file` then odometry with the file: the held-out end-point errors that
    `calibrate compare` reports for the same model (both fitted on the exploration)."""
    for m in measured.values():
        for model in LSQ:
            assert (m.lsq_endpoint[model] is None) == (m.endpoint[model] is None), (m.sim, model)
            if m.endpoint[model] is not None:
                # measured |value - expected| 0-4.44e-16 over seed shifts 0-3 (24 cases); tolerance
                # 19 bounds
                assert m.lsq_endpoint[model] == pytest.approx(m.endpoint[model], rel=1e-6)


def test_slip_halves_the_best_kinematic_error_on_the_icr_speed_robot(
    measured: dict[tuple[str, int], Measured],
) -> None:
    """Issue 29's goal on "icr-speed": from 60 s of exploration, held-out end-point error
    <= 0.5 x the best kinematic model's, on every seed (measured 0.45, 0.25, 0.20, 0.25 at
    cc3ea73; 0.26, 0.21, 0.22, 0.14 at 32fba30; 0.14, 0.29, 0.20, 0.20 at 703892d)."""
    ratios = [measured[("icr-speed", seed)].ratio for seed in SEEDS]
    # measured 0.452, 0.253, 0.198, 0.246 (seed 1: 10 % under the goal, which is the issue's own
    # number); every seed at or under 0.5 with the seeds shifted by 1-3 too (pooled 0.18-0.28)
    assert all(r <= 0.5 for r in ratios), ratios
    slip = sum(measured[("icr-speed", seed)].endpoint["slip"] or 0.0 for seed in SEEDS)
    best = sum(measured[("icr-speed", seed)].best_kinematic for seed in SEEDS)
    assert slip <= 0.35 * best, (slip, best)  # measured 0.28 (0.21 at 32fba30)


def test_slip_halves_the_best_kinematic_error_on_the_skid_dynamic_robot(
    measured: dict[tuple[str, int], Measured],
) -> None:
    """Issue 29's goal on "skid-dynamic" (measured per seed 0.30, 0.31, 0.15, 0.20 at cc3ea73,
    pooled 0.26; it did not hold before the fit kept steady-state windows: 0.42, 0.78, 0.87,
    0.36 at 32fba30, 0.16, 0.50, 0.99, 0.61 at 703892d)."""
    ratios = [measured[("skid-dynamic", seed)].ratio for seed in SEEDS]
    # measured 0.304, 0.311, 0.153, 0.202 (38 % under the goal at worst); every seed at or under
    # 0.5 with the seeds shifted by 1-3 too (pooled 0.21-0.26)
    assert all(r <= 0.5 for r in ratios), ratios
    slip = sum(measured[("skid-dynamic", seed)].endpoint["slip"] or 0.0 for seed in SEEDS)
    best = sum(measured[("skid-dynamic", seed)].best_kinematic for seed in SEEDS)
    # measured 1.36-1.59 over seed shifts 0-2; bound 1.98/2.19/2.24; at seed shift 0 it is 2.31x the
    # spread over seeds away
    assert slip <= 0.35 * best, (slip, best)


def test_compare_recommends_slip_where_held_out_data_support_it(
    measured: dict[tuple[str, int], Measured],
) -> None:
    """Both simulators with speed-dependent slip, every seed: slip is recommended (the
    differential drive's held-out segment error ratio to slip: 95 % CIs from [1.12, 1.39] up)."""
    for m in measured.values():
        assert m.recommended == "slip", (m.sim, m.seed, m.reason)


def test_predictive_covariance_from_the_file_is_not_overconfident(
    measured: dict[tuple[str, int], Measured],
) -> None:
    """NEES of the lsq file's predictive covariance on the held-out runs, pooled over the
    seeds (`odolab evaluate --nees`'s numbers): not grossly overconfident and not grossly
    cautious. The chi-square bounds take the covariance as known; it is fitted from a minute,
    and the pooled mean moves with the data and with the machine (issue 36: skid-dynamic at 5 s
    read 1.50 here and 1.24 on another machine of the same kind, against a bound of 1.26; the
    same four seeds shifted by 1-3 give 1.61, and icr-speed at 1 s 2.46-3.06 against the
    bounds [2.79, 3.22]). So the bounds here allow for that (issue 37 asks for bounds that
    account for the fit's own uncertainty): above 1.3x the upper bound is overconfident (the
    noise terms alone gave 2.5e4 at cc3ea73), below 0.3x the lower one far too cautious."""
    for name in SIMS:
        for piece in NEES_PIECES:
            v = np.concatenate(
                [np.array(m.nees[piece]) for (n, _), m in measured.items() if n == name]
            )
            low, high = nees_bounds(v.size)
            mean = float(np.mean(v))
            # measured mean / high 0.47-1.03 over seed shifts 0-3 (icr-speed 5 s: 3.61 and 3.41
            # against 3.52); bound 1.3: 21 % above the largest
            assert mean <= 1.3 * high, (name, piece, mean, high)
            # measured mean / low 0.59-1.30 over seed shifts 0-3 (skid-dynamic 5 s: 1.50, 1.61;
            # 1.24 = 0.49 on the machine of issue 36); bound 0.3: 63 % below the smallest
            assert mean >= 0.3 * low, (name, piece, mean, low)


def test_compare_stays_with_a_simpler_model_without_speed_dependent_slip(
    control: dict[int, Measured],
) -> None:
    """The negative control (constant ICRs and radii, the same noise): never slip."""
    for m in control.values():
        assert m.recommended != "slip", (m.seed, m.reason)
        assert m.problems["icr"] is None  # the ICR model fits where it is the truth


def test_icr_model_is_fitted_on_an_exploration_with_turns_of_both_signs(
    measured: dict[tuple[str, int], Measured],
) -> None:
    """Before 070a560 odolab refused it on every speed-slip exploration: "x_icr (standard error
    0.0035-0.0064) is not identifiable without turns of both signs at speed", though the runs
    have such turns (the misfit of constant ICRs inflated the standard error)."""
    for m in measured.values():
        assert m.problems["icr"] is None, (m.sim, m.seed, m.problems["icr"])


def test_odometry_covariance_uses_the_slip_models_predictive_variance(tmp_path: Path) -> None:
    """Issue 29: the slip model's predictive variance feeds the covariance of `odolab odometry
    --covariance` with the parameters file `calibrate lsq --model slip` wrote."""
    sim = SIMS["icr-speed"]
    ex = write_run(tmp_path, exploration(sim, 1))
    arcs = write_run(tmp_path / "held", held_out_runs(sim, 1)[1])
    params = tmp_path / "slip.toml"
    assert _cli(["calibrate", "lsq", str(ex), "--model", "slip", "-o", str(params)]) == 0
    out = tmp_path / "arcs_odometry.csv"
    code = main(["odometry", str(arcs), "--params", str(params), "--covariance", "-o", str(out)])
    assert code == 0 and out.is_file()  # before 32fba30: "... have no [noise] table"
    table = np.genfromtxt(out, delimiter=",", names=True)
    end = table[-1]
    cov = np.array([[end["cov_xx"], end["cov_xy"]], [end["cov_xy"], end["cov_yy"]]])
    assert np.all(np.linalg.eigvalsh(cov) > 0)
    half = table[table.size // 2]
    assert end["cov_xx"] + end["cov_yy"] > half["cov_xx"] + half["cov_yy"]  # it grows

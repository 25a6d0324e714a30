"""CLI: ``odolab calibrate noise`` (the ``--nees`` part of ``odolab evaluate`` is
:mod:`odolab.cli._nees`)."""

from __future__ import annotations

from typing import Annotated

import typer

from odolab.cli._apps import calibrate_app
from odolab.cli._output import echo
from odolab.cli.core import MethodChoice, MethodOpt
from odolab.cli.evaluate import (
    GtYawOffsetOpt,
    NeesSegmentOpt,
    ParamsOpt,
    RunsWithTruthArg,
    TruthSigmaOpt,
)
from odolab.cli.options import NewParamsOutputOpt, RunFormat

__all__: list[str] = []


NoiseFmtOpt = Annotated[RunFormat, typer.Option("--format", "-f", help="Run format.")]


@calibrate_app.command("noise")
def calibrate_noise_cmd(
    runs: RunsWithTruthArg,
    output: NewParamsOutputOpt,
    fmt: NoiseFmtOpt = RunFormat.OPTIODOM,
    params: ParamsOpt = None,
    method: MethodOpt = MethodChoice.midpoint,
    segment: NeesSegmentOpt = 10.0,
    gt_yaw_offset: GtYawOffsetOpt = None,
    truth_sigma: TruthSigmaOpt = None,
) -> None:
    """Fit the \\[noise] table to runs with ground truth: k_left, k_right, k_scrub by maximum
    likelihood over the runs' pieces; judge it on held-out runs."""
    from odolab.app.evaluate import read_runs
    from odolab.cli._output import check_not_the_input
    from odolab.core.errors import OdolabError
    from odolab.core.params import load_params, save_params
    from odolab.metrics.consistency import fit_noise
    from odolab.metrics.truthnoise import parse_truth_sigma

    check_not_the_input(output, params)
    truth = parse_truth_sigma(truth_sigma) if truth_sigma is not None else None
    robot = load_params(params) if params else None
    found = read_runs(runs, fmt.value, robot)
    base = robot or found[0].params
    if base is None:
        raise OdolabError("the runs carry no parameters; give --params")
    fit = fit_noise(
        found, base, method.value, segment_s=segment, fit_gt_yaw_offset=gt_yaw_offset,
        truth_sigma=truth,
    )  # fmt: skip
    noise = fit.noise
    new = base.with_(noise=noise)
    save_params(
        output,
        new,
        provenance={
            "method": "noise from ground truth",
            "runs": len(found),
            "segment_s": segment,
            "rule": (
                "k_left, k_right, k_scrub by maximum likelihood of the pieces' errors (each "
                "piece's covariance is linear in them); a constant no piece identifies stays "
                "unknown"
            ),
            "noise_fit": fit.provenance(),
        },
    )
    parts = []
    for key, unit in (("k_left", "m"), ("k_right", "m"), ("k_scrub", "rad")):
        if key in fit.unknown:
            parts.append(f"{key} unknown ({fit.unknown[key]}; written 0)")
        else:
            lo, hi = fit.ci95[key]
            parts.append(f"{key} = {getattr(noise, key):.3g} {unit} [{lo:.3g}, {hi:.3g}]")
    echo(
        f"[noise] {'; '.join(parts)} from {fit.n_pieces} pieces of {len(fit.runs)} runs "
        f"({fit.n_turning} turning) -> {output}; check it on held-out runs: odolab evaluate RUNS "
        f"--format {fmt.value} --params {output} --nees"
    )
    if fit.truth is not None:
        echo(
            f"note: {fit.truth.describe()}; its noise at each piece's two ends is a known part "
            "of the piece's covariance, so the constants are the wheels' own (--truth-sigma 0,0: "
            "taken as exact)"
        )

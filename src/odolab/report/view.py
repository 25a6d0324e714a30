"""What the report page shows, as text ready for the template: built from the analysis and
calibration objects (and the results dict for what only exists there), formatted by ONE rule
(:mod:`odolab.core.numfmt`: a number carries the digits its uncertainty supports).

The template only lays these out; it formats nothing and marks nothing as safe (autoescape on):
the one safe markup made here is :func:`collapsed`'s ``<details>``, whose text it escapes itself.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, TypeGuard

from odolab.analysis.core import MOTIONS, LabAnalysis
from odolab.analysis.table1 import growth_text
from odolab.calibration.ratios import CalibrationResult
from odolab.calibration.umbmark import UmbmarkResult
from odolab.core import numfmt

__all__ = [
    "MOTION_NAMES",
    "SIGN_CONVENTION",
    "Cell",
    "ParamRow",
    "Verdict",
    "extra_view",
    "fmt",
    "provenance_rows",
    "table1_rows",
    "validation_view",
    "verdict",
]

Calibration = CalibrationResult | UmbmarkResult

#: said once, at the top of the report
SIGN_CONVENTION = (
    "Every error in this report is predicted − actual: what odometry said minus what was "
    "measured (UMBmark's return errors too, which Borenstein & Feng write the other way round). "
    "Every ratio is actual / predicted, so 1 is perfect and 0.875 means the robot turned 12.5 % "
    "less than odometry said. Intervals are 95 %; a number carries the digits its interval "
    "supports."
)

MOTION_NAMES = {
    "rotation": "rotation in place",
    "pivot": "pivot turn",
    "x": "distance (x)",
    "y_forward": "sideways drift, forward",
    "y_reverse": "sideways drift, reverse",
}

_PARAM_LABELS = {
    "left_wheel_radius": "left wheel radius (m)",
    "right_wheel_radius": "right wheel radius (m)",
    "track_width": "track width (m)",
}


def fmt(v: object, sig: int = 4) -> str:
    """Any value without an uncertainty: numbers to ``sig`` significant digits, lists and
    pairs readable, None as -."""
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return numfmt.plain(v, sig, strip=True)
    if isinstance(v, Mapping):
        return "; ".join(f"{k}: {fmt(x, sig)}" for k, x in v.items())
    if isinstance(v, list | tuple):
        if v and all(
            isinstance(x, list | tuple) for x in v
        ):  # pairs: "concrete 1.016; grass 0.998"
            return "; ".join(" ".join(fmt(y, sig) for y in x) for x in v)
        return ", ".join(fmt(x, sig) for x in v)
    return str(v)


@dataclass(frozen=True)
class Cell:
    """A table cell: its text and the column's name (shown beside it on a narrow screen)."""

    label: str
    text: str
    cls: str = ""


@dataclass(frozen=True)
class ParamRow:
    name: str
    old: str
    new: str
    change: str


@dataclass
class Verdict:
    """The first screen: the new parameters, what improved, Table I beside the lab's."""

    calibrations: list[tuple[str, str, list[ParamRow]]] = field(default_factory=list)
    improvements: list[tuple[str, str, str, str]] = field(default_factory=list)
    headline: str = ""


def _pct(new: float, old: float) -> str:
    if old == 0:
        return "-"
    return f"{100.0 * (new / old - 1.0):+.1f} %"


def _calibration_rows(c: Calibration) -> tuple[str, list[ParamRow]]:
    cal = c.calibration if isinstance(c, UmbmarkResult) else c
    prov = cal.provenance
    cis = {  # the ratios give one interval for both wheels; UMBmark one each
        "left_wheel_radius": prov.get("left_wheel_radius_ci95", prov.get("wheel_radius_ci95")),
        "right_wheel_radius": prov.get("right_wheel_radius_ci95", prov.get("wheel_radius_ci95")),
        "track_width": prov.get("track_width_ci95"),
    }
    rows: list[ParamRow] = []
    for key, label in _PARAM_LABELS.items():
        old = float(getattr(cal.old_params, key))
        new = float(getattr(cal.params, key))
        ci = cis[key]
        new_text = (
            numfmt.with_ci(new, ci[0], ci[1])
            if isinstance(ci, list | tuple) and len(ci) == 2
            else numfmt.plain(new, 5)
        )
        if not isinstance(ci, list | tuple) and prov.get("ci95_note"):
            new_text += f" ({prov['ci95_note']})"  # why the column's interval is missing
        rows.append(ParamRow(label, numfmt.plain(old, 5, strip=True), new_text, _pct(new, old)))
    how = (
        "from the rotation and distance ratios (the lab's section VIII, done right)"
        if not isinstance(c, UmbmarkResult)
        else f"UMBmark on {c.n_cw} + {c.n_ccw} squares of {numfmt.plain(c.side, strip=True)} m"
        + (f"; 95 % intervals: {prov['ci95_includes']}" if prov.get("ci95_includes") else "")
    )
    return how, rows


def verdict(
    analysis: LabAnalysis,
    calibrations: Mapping[str, Calibration],
    rows: Sequence[Mapping[str, Any]],
    validation: Mapping[str, Any] | None,
    extra: Mapping[str, object] | None,
) -> Verdict:
    """The result a student needs first: old -> new parameters and what improved by how much."""
    v = Verdict()
    for name, c in calibrations.items():
        how, prows = _calibration_rows(c)
        v.calibrations.append((name, how, prows))
    by_key = {f"{r['motion']}_{r['terrain']}": r for r in rows}
    after = (extra or {}).get("after_calibration")
    if isinstance(after, Mapping) and isinstance(after.get("ratios"), Mapping):
        for key, ratio in after["ratios"].items():
            row = by_key.get(str(key))
            if row is None or not isinstance(ratio, int | float):
                continue
            what = f"{MOTION_NAMES.get(row['motion'], row['motion'])} on {row['terrain']}"
            before = float(row["ratio"])
            v.improvements.append(
                (
                    f"actual / predicted, {what} (the campaign re-run)",
                    numfmt.plain(before),
                    numfmt.plain(float(ratio)),
                    f"error {abs(1 - before) * 100:.1f} % → {abs(1 - float(ratio)) * 100:.1f} %",
                )
            )
    if validation and isinstance(validation.get("old"), Mapping):
        old = validation["old"].get("rms_error_rad")
        new = validation.get("new", {}).get("rms_error_rad")
        if isinstance(old, int | float) and isinstance(new, int | float):
            v.improvements.append(
                (
                    "RMS heading error against the phone IMU (rad)",
                    numfmt.plain(old, 3),
                    numfmt.plain(new, 3),
                    _pct(new, old),
                )
            )
    # "before" is the squares integrated with the parameters UMBmark started from (the report
    # chains it from the ratios calibration of the same trials): say which
    start = (extra or {}).get("umbmark_from")
    started = (
        str(start).split(" (")[0].split(", ")[0]
        if isinstance(start, str) and start
        else "the parameters UMBmark started from"
    )
    for name, c in calibrations.items():
        if isinstance(c, UmbmarkResult) and c.e_max_syst_after is not None:
            v.improvements.append(
                (
                    f"UMBmark E_max,syst, same squares ({name}; before: with {started}) (m)",
                    numfmt.plain(c.e_max_syst, 3),
                    numfmt.plain(c.e_max_syst_after, 3),
                    _pct(c.e_max_syst_after, c.e_max_syst),
                )
            )
    rot = next((r for r in rows if r["motion"] == "rotation"), None)
    x = next((r for r in rows if r["motion"] == "x" and r["terrain"] == "tile"), None) or next(
        (r for r in rows if r["motion"] == "x"), None
    )
    parts = []
    if rot is not None:
        parts.append(
            f"the robot turns {numfmt.with_ci(rot['ratio'], *rot['ratio_ci95'])} of the "
            f"rotation odometry reports ({rot['terrain']})"
        )
    if x is not None:
        parts.append(
            f"travels {numfmt.with_ci(x['ratio'], *x['ratio_ci95'])} of its distance "
            f"({x['terrain']})"
        )
    if parts:
        v.headline = "Before calibration, " + " and ".join(parts) + "."
    return v


def table1_rows(
    rows: Sequence[Mapping[str, Any]],
    reference: Mapping[tuple[str, str], tuple[float, float, list[tuple[float, float, float]]]]
    | None = None,
) -> list[list[Cell]]:
    """Table I as cells; with ``reference`` (the lab report's Table I) a column beside it."""
    out: list[list[Cell]] = []
    for r in rows:
        lo, hi = r["ratio_ci95"]
        sig = "; ".join(
            f"{numfmt.with_ci(s['sigma'], *s['sigma_ci95'])} {r['unit']} at "
            f"{numfmt.plain(float(s['commanded']), strip=True)} (n = {s['n']})"
            for s in r.get("sigmas", [])
        )
        cells = [
            Cell("motion", MOTION_NAMES.get(r["motion"], r["motion"]), "l"),
            Cell("terrain", str(r["terrain"]), "l"),
            Cell("n", str(r["n"])),
            Cell("ratio [95 % CI]", f"{numfmt.with_ci(r['ratio'], lo, hi)} {r['ratio_unit']}"),
        ]
        if reference is not None:
            ref = reference.get((str(r["motion"]), str(r["terrain"])))
            if ref is None:
                cells.append(Cell("lab report", "-"))
            else:
                agree = abs(float(r["ratio"]) - ref[0]) <= ref[1]
                cells.append(
                    Cell(
                        "lab report",
                        f"{numfmt.shortest(ref[0])} ± {numfmt.shortest(ref[1])}"
                        + (" ✓" if agree else " ✗"),
                        "yes" if agree else "no",
                    )
                )
        cells.append(Cell("σ at repeats [95 % CI]", sig or "-", "l"))
        if reference is not None:
            ref = reference.get((str(r["motion"]), str(r["terrain"])))
            lab_sig = (
                "; ".join(
                    f"{numfmt.shortest(s)} ± {numfmt.shortest(u)} at {numfmt.plain(at, strip=True)}"
                    for s, at, u in ref[2]
                )
                if ref and ref[2]
                else "-"
            )
            cells.append(Cell("lab σ", lab_sig, "l"))
        growth = growth_text(r)
        cells.append(Cell("growth p [95 % CI]", growth))
        out.append(cells)
    return out


def fits_rows(analysis: LabAnalysis) -> list[list[Cell]]:
    """The systematic fits: line with an intercept beside the proportional fit."""
    out: list[list[Cell]] = []
    for m in analysis.motions:
        u = MOTIONS[m.motion]["unit"]
        f = m.fit
        rf = m.ratio_fit
        norm = m.random.normality
        out.append(
            [
                Cell("fit", f"{m.motion} ({m.terrain})", "l"),
                Cell("slope [95 % CI]", numfmt.with_ci(f.slope, *f.slope_ci95)),
                Cell(
                    "intercept [95 % CI]", f"{numfmt.with_ci(f.intercept, *f.intercept_ci95)} {u}"
                ),
                Cell("R²", f"{f.r2:.4f}" if math.isfinite(f.r2) else "–"),
                Cell(
                    "ratio through the origin [95 % CI]",
                    "-" if rf is None else numfmt.with_ci(rf.slope, *rf.slope_ci95),
                    "ratio",
                ),
                Cell(
                    "residual σ [95 % CI]", f"{numfmt.with_ci(m.random.sd, *m.random.sd_ci95)} {u}"
                ),
                Cell(
                    "Shapiro–Wilk p",
                    "-" if norm is None else numfmt.p_value(norm.pvalue),
                ),
            ]
        )
    return out


_PROV_LABELS = {
    "method": "method",
    "created": "made",
    "source": "from",
    "terrain": "terrain",
    "from_params": "starting parameters",
    "distance_ratio": "distance ratio (actual/predicted)",
    "rotation_ratio": "rotation ratio (actual/predicted)",
    "convention": "convention",
    "e_d": "E_d (right/left diameter ratio)",
    "e_b": "E_b (track correction)",
    "n_iterations": "iterations",
    "side": "square side (m)",
}


#: a provenance cell longer than this (characters) is collapsed: its start shown, the whole
#: text a tap away (a list of 77 trial ids made the report 42,000 px tall on a phone)
COLLAPSE_AT = 240


def collapsed(text: str) -> str:
    """``text`` as it is when short; else an HTML ``<details>`` showing its start and how long
    it is, the whole (escaped) text inside: a safe :class:`markupsafe.Markup`."""
    from markupsafe import Markup, escape

    if len(text) <= COLLAPSE_AT:
        return text
    head = text[: COLLAPSE_AT // 3].rsplit(" ", 1)[0]
    return Markup(
        f'<details class="long"><summary>{escape(head)} … ({len(text):,} characters: show '
        f"all)</summary>{escape(text)}</details>"
    )


def provenance_rows(prov: Mapping[str, object]) -> tuple[list[tuple[str, str]], list[list[str]]]:
    """A calibration's provenance as readable rows, and its iterations (if any) as a table."""
    rows: list[tuple[str, str]] = []
    iterations: list[list[str]] = []
    ci_of = {k[: -len("_ci95")]: v for k, v in prov.items() if k.endswith("_ci95")}
    for k, v in prov.items():
        if k in ("old",) or k.endswith("_ci95"):
            continue
        if k == "iterations" and isinstance(v, list):
            # the columns of the first iterate for every row: the last iterate (the result)
            # has no step taken from it, and its cells were shifted under the step's columns
            cols = _iteration_columns(v)
            for i, it in enumerate(v):
                if isinstance(it, Mapping):
                    iterations.append(
                        [str(it.get("iteration", i))]
                        + [fmt(it[c], 5) if c in it else "–" for c in cols]
                    )
            continue
        label = _PROV_LABELS.get(k, k.replace("_", " "))
        ci = ci_of.get(k)
        if isinstance(v, int | float) and not isinstance(v, bool) and isinstance(ci, list):
            rows.append((label, numfmt.with_ci(float(v), ci[0], ci[1])))
        else:
            rows.append((label, collapsed(fmt(v, 6))))
    for k, ci in ci_of.items():
        if k not in prov and isinstance(ci, list) and len(ci) == 2:
            rows.append((f"{k.replace('_', ' ')}, 95 % CI", numfmt.interval(ci[0], ci[1])))
    return rows, iterations


def _iteration_columns(its: list[object]) -> list[str]:
    """The columns of the iterations table: every key of any iterate but its number, sorted."""
    keys = {c for it in its if isinstance(it, Mapping) for c in it}
    return sorted(keys - {"iteration"})


def iteration_header(prov: Mapping[str, object]) -> list[str]:
    """Column names of the iterations table: the iterate's number (0: the start, as the
    parameters file counts them) and the keys of the iterates, sorted."""
    its = prov.get("iterations")
    if isinstance(its, list) and its and isinstance(its[0], Mapping):
        return ["iterate"] + [c.replace("_", " ") for c in _iteration_columns(its)]
    return []


#: rows of the old/new validation table: (label, key in each parameter set's summary)
_SET_ROWS = (
    ("predicted rotation (rad)", "predicted_rotation_rad"),
    ("actual/predicted rotation (IMU)", "ratio_actual_over_predicted"),
    ("RMS heading error (rad)", "rms_error_rad"),
    ("final heading error (rad)", "final_error_rad"),
    ("max |heading error| (rad)", "max_abs_error_rad"),
)

_VALIDATION_SHOWN = {
    "encoder_log",
    "imu_log",
    "imu_heading_column",
    "method",
    "clock_offset_s",
    "clock_offset_meaning",
    "offset_correlation",
    "offset_search_s",
    "overlap_s",
    "samples",
    "imu_rotation_rad",
    "old",
    "new",
    "rms_ratio_new_over_old",
    "warnings",
    "series",
    "phone_runs",
}


def _num(v: object) -> TypeGuard[float]:
    """Whether ``v`` is a number (an int or a float, not a bool)."""
    return isinstance(v, int | float) and not isinstance(v, bool)


def validation_view(v: Mapping[str, Any]) -> dict[str, object]:
    """The Validation section: a summary, an old/new table, warnings, and any other key as a
    readable row (nothing is dropped)."""
    summary: list[tuple[str, str]] = []
    if _num(v.get("clock_offset_s")):
        s = f"{fmt(float(v['clock_offset_s']))} s"
        if v.get("clock_offset_meaning"):
            s += f" ({v['clock_offset_meaning']})"
        summary.append(("clock offset found", s))
        corr = v.get("offset_correlation")
        summary.append(
            (
                "yaw-rate correlation at that offset",
                fmt(corr, 3) if corr is not None else "- (offset fixed, not searched)",
            )
        )
        lo_hi = v.get("offset_search_s")
        if isinstance(lo_hi, list) and len(lo_hi) == 2:
            summary.append(("offsets searched", f"{fmt(lo_hi[0])} to {fmt(lo_hi[1])} s"))
    ov = v.get("overlap_s")
    if isinstance(ov, list) and len(ov) == 2 and all(_num(x) for x in ov):
        s = f"{fmt(float(ov[1] - ov[0]))} s (robot time {fmt(ov[0])} to {fmt(ov[1])} s"
        s += f", {v['samples']} IMU samples)" if _num(v.get("samples")) else ")"
        summary.append(("overlap of the two logs", s))
    if _num(v.get("imu_rotation_rad")):
        summary.append(("rotation measured by the IMU", f"{fmt(v['imu_rotation_rad'])} rad"))
    for key, label in (
        ("method", "integration method"),
        ("encoder_log", "encoder log"),
        ("imu_log", "IMU log"),
        ("imu_heading_column", "IMU heading column"),
    ):
        if isinstance(v.get(key), str):
            summary.append((label, v[key]))
    sets: list[tuple[str, list[str]]] | None = None
    other: dict[str, str] = {}
    old, new = v.get("old"), v.get("new")
    if isinstance(old, Mapping) and isinstance(new, Mapping):
        pair = (old, new)

        def param(d: Mapping[str, object], k: str) -> Any:
            p = d.get("params")
            return p.get(k) if isinstance(p, Mapping) else None

        sets = [("parameter set", [str(param(d, "name") or "-") for d in pair])]
        sets.append(
            (
                "left / right wheel radius (m)",
                [
                    f"{fmt(param(d, 'left_wheel_radius'), 6)} / "
                    f"{fmt(param(d, 'right_wheel_radius'), 6)}"
                    for d in pair
                ],
            )
        )
        sets.append(("track width (m)", [fmt(param(d, "track_width"), 6) for d in pair]))
        sets.extend((label, [fmt(d.get(k)) for d in pair]) for label, k in _SET_ROWS)
        if _num(v.get("rms_ratio_new_over_old")):
            summary.append(
                (
                    "RMS heading error, new / old",
                    f"{fmt(v['rms_ratio_new_over_old'], 3)} (below 1: the new parameters "
                    "follow the IMU better)",
                )
            )
    else:
        other.update({k: fmt(v[k]) for k in ("old", "new") if k in v})
    warnings = [str(x) for x in v.get("warnings") or []]
    other.update({k: fmt(x) for k, x in v.items() if k not in _VALIDATION_SHOWN})
    return {
        "summary": summary,
        "sets": sets,
        "warnings": warnings,
        "other": other,
        "runs": _runs_view(v.get("phone_runs")),
    }


def _runs_view(r: object) -> dict[str, object] | None:
    """Several phone runs (:class:`odolab.validation.runs.RunsSummary` as a dict)."""
    if not isinstance(r, Mapping) or not isinstance(r.get("final_error_new_rad"), list):
        return None
    rows = []
    for i, (a, o, n, s) in enumerate(
        zip(
            r.get("rotation_rad", []),
            r["final_error_old_rad"],
            r["final_error_new_rad"],
            r.get("predicted_sigma_rad", []),
            strict=False,
        ),
        start=1,
    ):
        inside = abs(n) <= 1.96 * s
        rows.append(
            [
                Cell("run", str(i), "l"),
                Cell("rotation (rad)", fmt(a, 4)),
                Cell("final error, old (rad)", fmt(o, 3)),
                Cell("final error, new (rad)", fmt(n, 3)),
                Cell("predicted ±1.96 σ (rad)", f"±{fmt(1.96 * s, 3)}"),
                Cell("new inside", "yes" if inside else "no", "yes" if inside else "no"),
            ]
        )
    return {"verdict": [str(x) for x in r.get("verdict", [])], "rows": rows}


_LIVE_LABELS = {
    "runs": "runs driven through the live loop",
    "cycles": "control cycles",
    "rate_hz": "loop rate (Hz)",
    "sensor_packets": "sensor packets decoded",
    "decode_errors": "decode errors",
    "overruns": "cycle overruns",
}
_RUN_LABELS = {
    "seed": "random seed",
    "truth": "simulated robot (truth preset)",
    "notebook": "lab notebook",
    "phone_log": "phone's SensorLog file",
    "phone_trial": "trial the phone rode on",
    "selection": "trials used",
}


def _split_key(key: str) -> tuple[str, str]:
    """``"y_forward_tile"`` -> ``("y_forward", "tile")`` (the longest known motion prefix)."""
    for motion in sorted(MOTIONS, key=len, reverse=True):
        if key.startswith(motion + "_"):
            return motion, key[len(motion) + 1 :].replace("_", " ")
    return key, "-"


def _flat(prefix: str, v: object, out: list[tuple[str, str]]) -> None:
    if isinstance(v, Mapping):
        for k, x in v.items():
            _flat(f"{prefix} › {k}" if prefix else str(k), x, out)
    else:
        out.append((prefix, fmt(v, 6)))


def extra_view(extra: Mapping[str, object]) -> dict[str, object]:
    """Additional results: known keys as labelled tables, any other key as readable rows."""
    view: dict[str, Any] = {
        "after": None,
        "run": [],
        "live": [],
        "true_params": [],
        "ground_truth": [],
        "other": [],
    }
    for k, v in extra.items():
        if (
            k == "after_calibration"
            and isinstance(v, Mapping)
            and isinstance(v.get("ratios"), Mapping)
        ):
            rows = []
            for key, r in v["ratios"].items():
                motion, terrain = _split_key(str(key))
                ok = "-" if not _num(r) else ("yes" if abs(r - 1.0) <= 0.01 else "no")
                rows.append((motion, terrain, fmt(r, 5), ok))
            rest: list[tuple[str, str]] = []
            for kk, vv in v.items():
                if kk not in ("method", "note", "ratios"):
                    _flat(str(kk), vv, rest)
            view["after"] = {
                "method": str(v.get("method", "-")),
                "note": str(v.get("note", "")),
                "rows": rows,
                "other": rest,
            }
        elif k in _RUN_LABELS and not isinstance(v, Mapping | list):
            view["run"].append((_RUN_LABELS[k], fmt(v, 6)))
        elif k == "live_runs" and isinstance(v, Mapping):
            view["live"] = [(_LIVE_LABELS.get(kk, kk), fmt(vv, 6)) for kk, vv in v.items()]
        elif k == "ground_truth" and isinstance(v, list):
            # odolab.report.ground_truth summaries: a title and (label, text) rows each, and a
            # photo's overlay as base64 PNG (escaped like any text where the page shows it)
            view["ground_truth"] = [
                {
                    "title": str(g.get("title", "")),
                    "rows": [(str(a), str(b)) for a, b in g["rows"]],
                    "image": str(g["image"]) if isinstance(g.get("image"), str) else None,
                }
                for g in v
                if isinstance(g, Mapping) and isinstance(g.get("rows"), list)
            ]
        elif k == "true_params" and isinstance(v, Mapping):
            view["true_params"] = [(kk.replace("_", " "), fmt(vv, 6)) for kk, vv in v.items()]
        else:
            _flat(str(k), v, view["other"])
    return view

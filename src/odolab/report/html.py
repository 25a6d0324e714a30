"""The lab report: one self-contained HTML file (figures embedded), the PNGs, and results.json.

Every number the HTML shows is read from the same dict that is written to ``results.json``, so
the text, the tables and the JSON agree by construction.
"""

from __future__ import annotations

import base64
import json
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from odolab.analysis.core import MOTIONS, LabAnalysis
from odolab.analysis.table1 import table1
from odolab.calibration.ratios import CalibrationResult
from odolab.calibration.umbmark import UmbmarkResult
from odolab.errors import OdolabError
from odolab.report import figures as F
from odolab.text import safe_file_name

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["build_results", "summary_sentences", "write_report"]

Calibration = CalibrationResult | UmbmarkResult
Progress = Callable[[str], None]


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, np.floating | float):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def _fmt(v: Any, digits: int = 4) -> str:
    if v is None:
        return "-"
    if isinstance(v, dict):
        return ", ".join(f"{k}: {_fmt(x, digits)}" for k, x in v.items())
    if isinstance(v, list | tuple) and v and all(isinstance(x, dict) for x in v):
        return "\n".join(_fmt(x, digits) for x in v)  # one line each (pre-line cell)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_fmt(x, digits) for x in v) + "]"
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, float):
        if v == 0 or 1e-3 <= abs(v) < 1e5:
            return f"{v:.{digits}g}"
        return f"{v:.3e}"
    return str(v)


def _fixed(v: Any, digits: int = 3) -> str:
    """A number with a fixed count of decimals (R² 0.9999 shows as 1.000, not 1); - for None."""
    return f"{v:.{digits}f}" if _num(v) else "-"


def _compact_json(v: Any) -> str:
    return json.dumps(v, separators=(", ", ": "), ensure_ascii=False)


def _num(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


#: the keys of a validation dict (``ValidationResult.to_dict``) the validation table shows
_VALIDATION_KEYS = {
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
}

#: rows of the old/new table: (label, key in each parameter set's summary, digits)
_SET_ROWS = (
    ("predicted rotation (rad)", "predicted_rotation_rad", 4),
    ("actual/predicted rotation (IMU)", "ratio_actual_over_predicted", 4),
    ("RMS heading error (rad)", "rms_error_rad", 4),
    ("final heading error (rad)", "final_error_rad", 4),
    ("max |heading error| (rad)", "max_abs_error_rad", 4),
)


def _validation_view(v: Mapping[str, Any]) -> dict[str, Any]:
    """What the Validation section shows, read from the results' ``validation`` dict.

    A dict in :meth:`ValidationResult.to_dict` form gives a summary table, an old/new table
    and the warnings; any other key is shown as compact JSON (nothing is dropped).
    """
    view: dict[str, Any] = {"summary": [], "sets": None, "warnings": [], "other": {}}
    summary: list[tuple[str, str]] = view["summary"]
    if _num(v.get("clock_offset_s")):
        s = f"{_fmt(v['clock_offset_s'], 4)} s"
        if v.get("clock_offset_meaning"):
            s += f" ({v['clock_offset_meaning']})"
        summary.append(("clock offset found", s))
        corr = v.get("offset_correlation")
        summary.append(
            (
                "yaw-rate correlation at that offset",
                _fmt(corr, 3) if corr is not None else "- (offset fixed, not searched)",
            )
        )
        lo_hi = v.get("offset_search_s")
        if isinstance(lo_hi, list) and len(lo_hi) == 2:
            summary.append(("offsets searched", f"{_fmt(lo_hi[0])} to {_fmt(lo_hi[1])} s"))
    ov = v.get("overlap_s")
    if isinstance(ov, list) and len(ov) == 2 and all(_num(x) for x in ov):
        s = f"{_fmt(ov[1] - ov[0], 4)} s (robot time {_fmt(ov[0])} to {_fmt(ov[1])} s"
        s += f", {v['samples']} IMU samples)" if _num(v.get("samples")) else ")"
        summary.append(("overlap of the two logs", s))
    if _num(v.get("imu_rotation_rad")):
        summary.append(("rotation measured by the IMU", f"{_fmt(v['imu_rotation_rad'])} rad"))
    for key, label in (
        ("method", "integration method"),
        ("encoder_log", "encoder log"),
        ("imu_log", "IMU log"),
        ("imu_heading_column", "IMU heading column"),
    ):
        if isinstance(v.get(key), str):
            summary.append((label, v[key]))
    old, new = v.get("old"), v.get("new")
    if isinstance(old, Mapping) and isinstance(new, Mapping):
        sets = [("old", old), ("new", new)]
        rows: list[tuple[str, list[str]]] = []

        def param(d: Mapping[str, Any], k: str) -> Any:
            p = d.get("params")
            return p.get(k) if isinstance(p, Mapping) else None

        rows.append(("parameter set", [str(param(d, "name") or "-") for _, d in sets]))
        for label, k in (
            ("left / right wheel radius (m)", None),
            ("track width (m)", "track_width"),
        ):
            if k is None:
                rows.append(
                    (
                        label,
                        [
                            f"{_fmt(param(d, 'left_wheel_radius'), 6)} / "
                            f"{_fmt(param(d, 'right_wheel_radius'), 6)}"
                            for _, d in sets
                        ],
                    )
                )
            else:
                rows.append((label, [_fmt(param(d, k), 6) for _, d in sets]))
        for label, k, digits in _SET_ROWS:
            rows.append((label, [_fmt(d.get(k), digits) for _, d in sets]))
        view["sets"] = rows
        if _num(v.get("rms_ratio_new_over_old")):
            summary.append(
                (
                    "RMS heading error, new / old",
                    f"{_fmt(v['rms_ratio_new_over_old'], 3)} (below 1: the new parameters "
                    "follow the IMU better)",
                )
            )
    elif old is not None or new is not None:
        view["other"].update({k: v[k] for k in ("old", "new") if k in v})
    w = v.get("warnings")
    if isinstance(w, list):
        view["warnings"] = [str(x) for x in w]
    view["other"].update({k: _compact_json(x) for k, x in v.items() if k not in _VALIDATION_KEYS})
    view["other"] = {
        k: (x if isinstance(x, str) else _compact_json(x)) for k, x in view["other"].items()
    }
    return view


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
}


def _split_key(key: str) -> tuple[str, str]:
    """``"y_forward_tile"`` -> ``("y_forward", "tile")`` (the longest known motion prefix)."""
    for motion in sorted(MOTIONS, key=len, reverse=True):
        if key.startswith(motion + "_"):
            return motion, key[len(motion) + 1 :].replace("_", " ")
    return key, "-"


def _extra_view(extra: Mapping[str, Any]) -> dict[str, Any]:
    """What the report shows of ``extra``: known keys as tables, the rest as compact JSON."""
    view: dict[str, Any] = {
        "after": None,
        "run": [],
        "live": [],
        "true_params": [],
        "other": {},
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
                rows.append((motion, terrain, _fmt(r, 5), ok))
            rest = {kk: vv for kk, vv in v.items() if kk not in ("method", "note", "ratios")}
            view["after"] = {
                "method": str(v.get("method", "-")),
                "note": str(v.get("note", "")),
                "rows": rows,
                "other": {kk: _compact_json(vv) for kk, vv in rest.items()},
            }
        elif k in _RUN_LABELS and not isinstance(v, Mapping | list):
            view["run"].append((_RUN_LABELS[k], _fmt(v, 6)))
        elif k == "live_runs" and isinstance(v, Mapping):
            view["live"] = [(_LIVE_LABELS.get(kk, kk), _fmt(vv, 6)) for kk, vv in v.items()]
        elif k == "true_params" and isinstance(v, Mapping):
            view["true_params"] = [(kk, _fmt(vv, 6)) for kk, vv in v.items()]
        else:
            view["other"][k] = _compact_json(v)
    return view


def _calib_dict(c: Calibration) -> dict[str, Any]:
    if isinstance(c, UmbmarkResult):
        d = c.to_dict()
        d["old_params"] = c.calibration.old_params.to_dict()
        d["method"] = "umbmark"
        return d
    return c.to_dict()


def summary_sentences(results: Mapping[str, Any]) -> list[str]:
    """Plain-language findings built from ``results`` (the numbers are the JSON's, formatted)."""
    out: list[str] = []
    for row in results["table1"]:
        lo, hi = row["ratio_ci95"]
        what = {
            "rotation": "actual/predicted rotation",
            "pivot": "actual/predicted pivot rotation",
            "x": "actual/predicted x",
            "y_forward": "y error per metre travelled forward",
            "y_reverse": "y error per metre travelled in reverse",
        }[row["motion"]]
        s = (
            f"{what} on {row['terrain']}: {_fmt(row['ratio'])} {row['ratio_unit']} "
            f"(95% CI {_fmt(lo)} to {_fmt(hi)}, n = {row['n']})"
        )
        if "sigma" in row:
            c0, c1 = row["sigma_ci95"]
            s += (
                f"; random error σ = {_fmt(row['sigma'])} {row['unit']} at "
                f"{_fmt(row['sigma_at'])} {row['unit']} (95% CI {_fmt(c0)} to {_fmt(c1)})"
            )
        out.append(s + ".")
    for m in results["analysis"]["motions"]:
        if m["growth"] is not None:
            out.append(
                f"Growth of σ with distance/angle, {m['motion']} on {m['terrain']}: "
                f"{m['growth']['verdict']}."
            )
    for t in results["analysis"]["terrain_tests"]:
        out.append(t["verdict"][0].upper() + t["verdict"][1:] + ".")
    for name, c in results["calibration"].items():
        p = c["params"]
        out.append(
            f"Calibration '{name}': left/right wheel radius {_fmt(p['left_wheel_radius'], 5)}/"
            f"{_fmt(p['right_wheel_radius'], 5)} m, track width {_fmt(p['track_width'], 5)} m."
        )
    return out


def build_results(
    analysis: LabAnalysis,
    calibrations: Mapping[str, Calibration],
    validation: Mapping[str, Any] | None = None,
    extra: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """The dict written to results.json: every number in the report."""
    res: dict[str, Any] = {
        "generated": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "table1": table1(analysis),
        "analysis": analysis.to_dict(),
        "calibration": {name: _calib_dict(c) for name, c in calibrations.items()},
        "validation": dict(validation) if validation is not None else None,
        "extra": dict(extra) if extra is not None else None,
    }
    res = _jsonable(res)
    res["summary"] = summary_sentences(res)
    return res


@dataclass
class _Figure:
    name: str
    title: str
    caption: str
    b64: str = ""


def _render(
    out: Path, fig_dir: Path, items: list[tuple[str, str, str, Callable[[Axes], Any]]]
) -> list[_Figure]:
    import matplotlib
    from matplotlib.figure import Figure

    done: list[_Figure] = []
    for raw_name, title, caption, draw in items:
        name = safe_file_name(raw_name, what="figure name")  # terrains are user text
        fig = Figure(figsize=(7.0, 4.6), dpi=110)
        # user text in titles and legends ("$" in a terrain) is text, never TeX to parse
        with matplotlib.rc_context({"text.parse_math": False}):
            ax = fig.add_subplot()
            draw(ax)
            fig.subplots_adjust(left=0.13, right=0.97, bottom=0.12, top=0.92)
            path = fig_dir / f"{name}.png"
            fig.savefig(path)
        done.append(
            _Figure(name, title, caption, base64.b64encode(path.read_bytes()).decode("ascii"))
        )
    return done


def write_report(
    out_dir: str | Path,
    analysis: LabAnalysis,
    calibrations: Mapping[str, Calibration] | None = None,
    validation: Mapping[str, Any] | None = None,
    *,
    validation_figure: Callable[[Axes], Axes] | None = None,
    extra: Mapping[str, Any] | None = None,
    progress: Progress | None = None,
) -> Path:
    """Write ``report.html``, ``figures/*.png`` and ``results.json`` to ``out_dir``.

    ``validation`` is any JSON-able mapping (e.g. an IMU comparison's ``to_dict()``);
    ``validation_figure`` draws its figure on a given axes. Returns the HTML path.
    """
    import jinja2

    say = progress or (lambda _: None)
    calibrations = dict(calibrations or {})
    out = Path(out_dir)
    fig_dir = out / "figures"
    try:
        fig_dir.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise OdolabError(f"{out}: cannot create the report folder ({err})") from err
    results = build_results(analysis, calibrations, validation, extra)
    items: list[tuple[str, str, str, Callable[[Axes], Any]]] = []
    for m in analysis.motions:
        key = f"{m.motion}_{m.terrain}".replace(" ", "_")
        unit = MOTIONS[m.motion]["unit"]
        items.append(
            (
                f"fit_{key}",
                f"{m.motion} on {m.terrain}: fit",
                "Trials, least-squares line with an intercept (slope with 95% CI) and "
                "the ideal line"
                + (
                    "; dashed: the proportional fit actual = ratio × predicted through the "
                    "origin, Table I's ratio."
                    if m.ratio_fit is not None
                    else "."
                ),
                partial(F.plot_fit, m),
            )
        )
        items.append(
            (
                f"residuals_{key}",
                f"{m.motion} on {m.terrain}: residuals",
                "Residuals of the fit with the fitted ±1.96 σ(d) band.",
                partial(F.plot_residuals, m),
            )
        )
        if m.groups:
            g = max(m.groups, key=lambda g: (g.n, g.at))
            items.append(
                (
                    f"histogram_{key}",
                    f"{m.motion} on {m.terrain}: error histogram",
                    f"Errors of the {g.n} trials at {g.at:.3g} {unit} with the fitted "
                    "Gaussian and its 95% interval.",
                    partial(F.plot_histogram, g, unit),
                )
            )
        if m.growth is not None:
            items.append(
                (
                    f"growth_{key}",
                    f"{m.motion} on {m.terrain}: growth of σ",
                    "σ at each repeated distance/angle (95% CI), the ML fit σ = a·d^p "
                    "and the candidate laws p = 0.5, 1, 1.5.",
                    partial(F.plot_growth, m),
                )
            )
    for terrain in analysis.terrains:
        if analysis.get("x", terrain) and (
            analysis.get("y_forward", terrain) or analysis.get("y_reverse", terrain)
        ):
            items.append(
                (
                    f"ellipses_{terrain}",
                    f"End-point errors on {terrain}",
                    "x and y errors of each trial, grouped by commanded distance, with "
                    "95% covariance ellipses where a distance was repeated at least 3 times.",
                    partial(F.plot_error_ellipses, analysis, terrain),
                )
            )
    for t in analysis.terrain_tests:
        items.append(
            (
                f"terrains_{t.motion}",
                f"{t.motion}: terrains side by side",
                "Each terrain's trials and its line with an intercept.",
                partial(F.plot_terrains, analysis, t.motion),
            )
        )
        items.append(
            (
                f"terrain_slopes_{t.motion}",
                f"{t.motion}: slope per terrain",
                t.verdict()
                + (
                    ". The F-test compares the slopes of the lines with an intercept; squares: "
                    "the ratios through the origin (Table I)."
                    if all(
                        m.ratio_fit is not None for m in analysis.motions if m.motion == t.motion
                    )
                    else "."
                ),
                partial(F.plot_terrain_slopes, analysis, t.motion),
            )
        )
    if analysis.params is not None:
        news = {n: c.params for n, c in calibrations.items()}
        used = [
            c.provenance.get("terrain")
            for c in calibrations.values()
            if isinstance(c, CalibrationResult)
        ]
        both = [
            t for t in analysis.terrains if analysis.get("rotation", t) and analysis.get("x", t)
        ]
        cal_terrain = next((t for t in used if t), both[0] if both else None)
        if news:
            for motion in ("rotation", "x"):
                if analysis.get(motion, cal_terrain) is not None:
                    items.append(
                        (
                            f"calibration_{motion}",
                            f"Old vs new parameters: {motion} ({cal_terrain})",
                            "Predictions of the same trials re-scaled with each new "
                            "parameter set (both wheels alike).",
                            partial(
                                F.plot_calibration_effect,
                                analysis,
                                analysis.params,
                                news,
                                motion,
                                terrain=cal_terrain,
                            ),
                        )
                    )
    for name, c in calibrations.items():
        if isinstance(c, UmbmarkResult):
            items.append(
                (
                    f"umbmark_{name}",
                    f"UMBmark ({name})",
                    f"Return-position errors and centres of gravity; E_max,syst = "
                    f"{c.e_max_syst:.4g} m"
                    + (
                        f", after correction {c.e_max_syst_after:.4g} m."
                        if c.e_max_syst_after is not None
                        else "."
                    ),
                    partial(F.plot_umbmark, c.cw_errors, c.ccw_errors, after=c.after),
                )
            )
    if validation_figure is not None:
        items.append(
            (
                "validation",
                "Validation",
                "The old and the new parameters against the IMU.",
                validation_figure,
            )
        )
    say(f"drawing {len(items)} figures")
    figs = _render(out, fig_dir, items)
    results["figures"] = {f.name: f"figures/{f.name}.png" for f in figs}
    (out / "results.json").write_text(json.dumps(results, indent=2), encoding="utf-8")
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("odolab.report", "templates"),
        # every template escaped (report.html.j2's ".j2" never matched select_autoescape(["html"]))
        autoescape=True,
        undefined=jinja2.StrictUndefined,
    )
    env.filters["fmt"] = _fmt
    env.filters["fixed"] = _fixed
    html = env.get_template("report.html.j2").render(
        r=results,
        figures=figs,
        motions=MOTIONS,
        val=_validation_view(results["validation"]) if results["validation"] else None,
        ext=_extra_view(results["extra"]) if results["extra"] else None,
    )
    path = out / "report.html"
    path.write_text(html, encoding="utf-8")
    say(f"report written to {path}")
    return path

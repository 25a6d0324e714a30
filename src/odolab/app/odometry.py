"""An encoder log integrated into a trajectory: ``odolab odometry``.

The rule for which parameters a log is integrated with: the ones the user names (``--params``),
else the ones the log names (a robot run folder's ``run.json`` beside its ``encoders.csv``; the
nominal parameters of a recorded run in another :class:`~odolab.core.defaults.LogFormat`, such as an
OptiOdom run's ``<id>_metadata.csv``), else the default preset (:data:`odolab.core.defaults.DEFAULT_ROBOT`), and then the result says so.
:class:`ParamsChoice` carries the choice (which file, which version, and why), and every face
prints :meth:`ParamsChoice.describe`.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from odolab.core.defaults import DEFAULT_CHUNK_ROWS, DEFAULT_ROBOT, LogFormat
from odolab.core.errors import OdolabError, ParamsError, opt
from odolab.core.models import own_covariance
from odolab.core.params import covariance_source

if TYPE_CHECKING:
    from odolab.core.params import RobotParams
    from odolab.core.progress import Progress
    from odolab.core.trajectory import Pose

__all__ = [
    "AUTO_CHUNK_BYTES",
    "AUTO_CHUNK_ROWS",
    "DEFAULT_CHUNK_ROWS",
    "OdometryOutcome",
    "OdometryRequest",
    "ParamsChoice",
    "auto_chunk_rows",
    "check_chunk_rows",
    "choose_params",
    "integrate_log",
    "many_logs",
    "resolve_formats",
]

#: Logs larger than this are integrated in chunks unless chunk_rows says otherwise.
AUTO_CHUNK_BYTES = 64 * 1024 * 1024
AUTO_CHUNK_ROWS = 3_000_000  #: the same for Parquet and IPC logs, by their row count
#: the file beside a robot run's encoders.csv that names its parameters (odolab robot ... -o)
RUN_JSON = "run.json"


@dataclass(frozen=True)
class ParamsChoice:
    """The parameters a log is integrated with, and where they came from."""

    params: RobotParams
    by: Literal["user", "log", "default"]
    source: str  #: a file, or "preset NAME"
    version: str | None = None  #: the notebook version (a TOML's [provenance]) or odolab's
    #: where a log's own parameters were found (said after them)
    found: str = "its run folder names them"

    def describe(self) -> str:
        """One sentence every face prints: which parameters, from which file and version."""
        p = self.params
        what = (
            f"parameters {p.name} (wheel radius L/R {p.left_wheel_radius:.6g}/"
            f"{p.right_wheel_radius:.6g} m, track {p.track_width:.6g} m) from {self.source}"
        )
        if self.version:
            what += f", {self.version}"
        if self.by == "log":
            return what + f" (the log's: {self.found})"
        if self.by == "default":
            return (
                what + " (the default: neither {{params}} nor the log named any; give {{params}} "
                "with your robot's parameters)"
            )
        return what

    def to_dict(self) -> dict[str, object]:
        return {
            "name": self.params.name,
            "by": self.by,
            "source": self.source,
            "version": self.version,
            "describe": self.describe(),
        }


def _file_version(path: Path) -> str | None:
    """A parameters TOML's version, from its [provenance] (notebook version, method)."""
    import tomllib

    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None
    prov = doc.get("provenance")
    if not isinstance(prov, dict):
        return None
    parts = []
    if isinstance(prov.get("notebook_version"), int):
        parts.append(f"notebook version {prov['notebook_version']}")
    if isinstance(prov.get("method"), str):
        parts.append(f"method {prov['method']}")
    return ", ".join(parts) or None


def _named(spec: str) -> ParamsChoice:
    from odolab import __version__
    from odolab.core.params import PRESETS, load_params

    params = load_params(spec)
    if spec in PRESETS and not Path(spec).exists():
        return ParamsChoice(params, "user", f"preset {spec}", f"built into odolab {__version__}")
    return ParamsChoice(params, "user", str(spec), _file_version(Path(spec)))


def _from_run_json(log: Path) -> ParamsChoice | None:
    """The parameters a robot run folder's ``run.json`` names for the log beside it."""
    from odolab.core.params import params_from_mapping

    doc_path = log.parent / RUN_JSON
    if not log.is_file() or not doc_path.is_file():
        return None
    try:
        doc = json.loads(doc_path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as err:
        raise ParamsError(
            f"{doc_path}: cannot read the run's parameters ({err}); expected the run.json that "
            "`odolab robot` writes, or give {{params}}"
        ) from err
    if not isinstance(doc, dict) or not isinstance(doc.get("params"), dict):
        return None
    model = doc.get("model") if isinstance(doc.get("model"), dict) else None
    noise = doc.get("noise") if isinstance(doc.get("noise"), dict) else None
    params = params_from_mapping(
        doc["params"], source=f"{doc_path}: params", model=model, noise=noise
    )
    return ParamsChoice(params, "log", str(doc_path))


def _from_run(log: Path, log_format: LogFormat) -> ParamsChoice | None:
    """The nominal parameters a recorded run carries (OptiOdom: its metadata file)."""
    from odolab import __version__
    from odolab.io.registry import read_run

    if not log.is_file():
        return None
    run = read_run(log, log_format)
    if run.params is None:
        return None
    source = str(run.meta.get("params_source", run.source))
    # a bag's wheel turns made from the robot's own odometry carry the parameters they were
    # made with: say that, not "nominal"
    made = run.meta.get("wheels")
    return ParamsChoice(
        run.params,
        "log",
        source,
        None if made else f"its nominal values, read by odolab {__version__}",
        found=str(made) if made else f"the {log_format.value} run's metadata names them",
    )


def resolve_formats(fmt: str, to: str | None) -> tuple[LogFormat, Literal["csv", "tum"]]:
    """The log's format and the output's from ``--format`` and ``--to``.

    ``--format`` names a :class:`~odolab.core.defaults.LogFormat`; ``tum`` there (odolab's older
    spelling) means a CSV encoder log written as TUM, the same as ``--to tum``."""
    if fmt == "tum":
        if to == "csv":
            raise OdolabError(
                "{{format}} tum with {{to}} csv: {{format}} tum (the older spelling) means a TUM "
                "output; expected {{format}} csv {{to}} csv, or {{to}} tum alone"
            )
        return LogFormat.CSV, "tum"
    try:
        log_format = LogFormat(fmt)
    except ValueError:
        names = ", ".join(f.value for f in LogFormat)
        raise OdolabError(
            f"{opt('format')} {fmt!r} is not a log format; expected one of {names}"
        ) from None
    if to not in (None, "csv", "tum"):
        raise OdolabError(f"{opt('to')} {to!r} is not an output format; expected csv or tum")
    return log_format, "tum" if to == "tum" else "csv"


def many_logs(logs: Sequence[Path], log_format: LogFormat) -> bool:
    """Whether ``logs`` are many (more than one, a folder, or a glob that names no file): each
    is then integrated on its own; only encoder log CSVs can be.

    Raises:
        OdolabError: many recorded runs of another format.
    """
    many = bool(
        len(logs) != 1
        or logs[0].is_dir()
        or (not logs[0].exists() and set("*?[") & set(str(logs[0])))
    )
    if many and log_format != LogFormat.CSV:
        raise OdolabError(
            f"{opt('format')} {log_format.value} integrates one run file at a time; expected one run "
            f"(for many runs against their ground truth: odolab evaluate {opt('format')} {log_format.value})"
        )
    return many


def choose_params(
    logs: Sequence[Path], params: str | None, log_format: LogFormat | str = LogFormat.CSV
) -> ParamsChoice:
    """Which parameters ``logs`` (in ``log_format``) are integrated with (the module's rule)."""
    from odolab.core.params import PRESETS

    if params is not None:
        return _named(params)
    if len(logs) == 1 and LogFormat(log_format) != LogFormat.CSV:
        found = _from_run(Path(logs[0]), LogFormat(log_format))
        if found is not None:
            return found
    elif len(logs) == 1:
        found = _from_run_json(Path(logs[0]))
        if found is not None:
            return found
    from odolab import __version__

    return ParamsChoice(
        PRESETS[DEFAULT_ROBOT],
        "default",
        f"preset {DEFAULT_ROBOT}",
        f"built into odolab {__version__}",
    )


def check_chunk_rows(chunk_rows: int | None) -> None:
    """Refuse rows per chunk below 0 (None: :func:`auto_chunk_rows`; 0: the file whole)."""
    if chunk_rows is not None and chunk_rows < 0:
        raise OdolabError(
            f"{opt('chunk_rows')} is {chunk_rows}; expected a number of rows >= 1 (or 0)",
            option="chunk_rows",
            value=chunk_rows,
            allowed="a number of rows >= 1 (or 0)",
        )


def auto_chunk_rows(*paths: Path) -> int:
    """Rows per chunk when the user gave none: :data:`DEFAULT_CHUNK_ROWS` when a file is big
    (CSV over :data:`AUTO_CHUNK_BYTES`, Parquet/IPC over :data:`AUTO_CHUNK_ROWS` rows), else 0
    (read whole)."""
    from odolab.io.tabular import row_count

    for path in paths:
        if not path.is_file():
            continue
        rows = row_count(path)
        if (rows or 0) > AUTO_CHUNK_ROWS or (
            rows is None and path.stat().st_size > AUTO_CHUNK_BYTES
        ):
            return DEFAULT_CHUNK_ROWS
    return 0


@dataclass(frozen=True)
class OdometryRequest:
    """One log to integrate into ``output`` (``fmt`` csv or tum), with the chosen parameters.

    ``chunk_rows``: rows per chunk (0: whole; None: :func:`auto_chunk_rows`). ``log_format``:
    an encoder log (``csv``) or one recorded run of another format, read by its registry
    reader and integrated from its increments (whole)."""

    log: Path
    output: Path
    params: ParamsChoice
    method: str = "midpoint"
    fmt: Literal["csv", "tum"] = "csv"
    start: tuple[float, float, float] | None = None
    max_dticks: int | None = None
    chunk_rows: int | None = None
    covariance: bool = False
    log_format: LogFormat = LogFormat.CSV

    def chunks(self) -> int:
        """Rows per chunk it will be integrated in (0: the whole log at once)."""
        if self.log_format != LogFormat.CSV:
            return 0
        rows = auto_chunk_rows(self.log) if self.chunk_rows is None else self.chunk_rows
        return rows if self.fmt == "csv" else 0


@dataclass(frozen=True)
class OdometryOutcome:
    """How many poses went where, the final pose, and the parameters used."""

    rows: int
    output: Path
    final: Pose
    params: ParamsChoice
    #: what the user should know of the result (where the first-order covariance stops holding)
    notes: tuple[str, ...] = ()

    def describe(self) -> str:
        e = self.final
        return (
            f"{self.rows} poses -> {self.output}; final x={e.x:.4f} m y={e.y:.4f} m "
            f"heading={e.heading:.4f} rad"
        )


def check_request(
    params: ParamsChoice,
    *,
    fmt: str,
    covariance: bool,
    chunk_rows: int | None,
    log_format: LogFormat | str = LogFormat.CSV,
    max_dticks: int | None = None,
) -> None:
    """Refuse options that cannot go together (one sentence each)."""
    lf = LogFormat(log_format)
    if lf != LogFormat.CSV and covariance:
        raise OdolabError(
            f"{opt('covariance')} with {opt('format')} {lf.value}: the covariance is propagated for encoder "
            "logs only; expected {{format}} csv (or leave out {{covariance}})"
        )
    if lf != LogFormat.CSV and max_dticks is not None:
        raise OdolabError(
            f"{opt('max_dticks')} with {opt('format')} {lf.value}: a {lf.value} run holds increments, not "
            "counters that wrap; expected it without {{max_dticks}}"
        )
    check_chunk_rows(chunk_rows)
    if covariance and fmt != "csv":
        raise OdolabError(
            f"{opt('covariance')} with {opt('format')} {fmt}: TUM has no covariance columns; expected "
            "{{format}} csv (a .csv, .parquet or .arrow output)"
        )
    if covariance and covariance_source(params.params) is None:
        raise ParamsError(
            f"{opt('covariance')}: the parameters {params.source} have no [noise] table; expected one "
            "with k_left and k_right (m), as `odolab calibrate noise RUNS -o P.toml` writes it"
        )


def integrate_log(req: OdometryRequest, progress: Progress | None = None) -> OdometryOutcome:
    """Integrate ``req.log`` into ``req.output``: chunk by chunk for a big log (bounded
    memory), else whole; ``progress(rows done, total, name)`` after each chunk."""
    check_request(
        req.params, fmt=req.fmt, covariance=req.covariance, chunk_rows=req.chunk_rows,
        log_format=req.log_format, max_dticks=req.max_dticks,
    )  # fmt: skip
    robot = req.params.params
    if req.log_format != LogFormat.CSV:
        return _integrate_run(req)
    if req.covariance and own_covariance(robot.model) is not None:
        return _integrate_own_covariance(req)
    chunk_rows = req.chunks()
    if chunk_rows > 0:
        from odolab.io.chunked import integrate_file

        res = integrate_file(
            req.log, req.output, robot, req.method, start=req.start, max_dticks=req.max_dticks,
            chunk_rows=chunk_rows, progress=progress, covariance=req.covariance,
        )  # fmt: skip
        return OdometryOutcome(res.rows, req.output, res.final, req.params)
    from odolab.core.odometry import (
        NUMPY_MAX_SAMPLES,
        integrate,
        integrate_with_covariance,
        warm_up,
    )
    from odolab.io import read_encoder_csv, write_trajectory

    if req.covariance or _may_have_rows(req.log, NUMPY_MAX_SAMPLES):
        warm_up(robot, req.method, covariance=req.covariance)  # they load while the log is read
    enc = read_encoder_csv(req.log, modulus=robot.encoder_modulus)
    args = (enc.t, enc.left_ticks, enc.right_ticks, robot, req.method)
    cov = None
    if req.covariance:
        traj, cov = integrate_with_covariance(
            *args, start=req.start, max_dticks=req.max_dticks, source=str(req.log)
        )
    else:
        traj = integrate(*args, start=req.start, max_dticks=req.max_dticks, source=str(req.log))
    del enc, args  # the input's memory is free before the output is written
    if cov is None:
        write_trajectory(req.output, traj, req.fmt)
    else:
        from odolab.io.chunked import OdometryChunk
        from odolab.io.tabular import write_columns

        write_columns(req.output, OdometryChunk(traj, cov).columns(), "trajectory table")
    notes: tuple[str, ...] = ()
    if cov is not None:
        from odolab.core.uncertainty import first_order_note

        note = first_order_note(traj, cov)
        notes = (note,) if note else ()
    return OdometryOutcome(len(traj), req.output, traj.final, req.params, notes)


def _integrate_own_covariance(req: OdometryRequest) -> OdometryOutcome:
    """An encoder log integrated with a model that carries its own covariance (the slip model),
    with the covariance its predictive variance gives
    (:func:`odolab.core.slip_uncertainty.propagate_covariance`: the model's white noise and
    drift terms, its coefficients' posterior where the model carries one, as the file
    ``calibrate lsq`` writes does, and the path's mean shortfall under heading uncertainty).
    The whole log at once: the drift's and the posterior's shares couple every cycle."""
    import numpy as np

    from odolab.core.encoders import default_max_dticks, dticks_from_ticks
    from odolab.core.odometry import integrate
    from odolab.core.uncertainty import first_order_note
    from odolab.io import read_encoder_csv
    from odolab.io.chunked import OdometryChunk
    from odolab.io.tabular import write_columns

    robot = req.params.params
    model = own_covariance(robot.model)
    assert model is not None
    enc = read_encoder_csv(req.log, modulus=robot.encoder_modulus)
    traj = integrate(
        enc.t, enc.left_ticks, enc.right_ticks, robot, req.method, start=req.start,
        max_dticks=req.max_dticks, source=str(req.log),
    )  # fmt: skip
    limit = req.max_dticks or default_max_dticks(robot.encoder_modulus)
    dl = dticks_from_ticks(enc.left_ticks, robot.encoder_modulus, limit, name="left_ticks")
    dr = dticks_from_ticks(enc.right_ticks, robot.encoder_modulus, limit, name="right_ticks")
    start = req.start or (0.0, 0.0, 0.0)
    _, cov = model.propagate_covariance(
        enc.t, np.concatenate(([0], dl)), np.concatenate(([0], dr)), robot, start
    )
    terms = cov[:, [0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]
    write_columns(req.output, OdometryChunk(traj, terms).columns(), "trajectory table")
    notes = [
        "covariance: "
        + model.describe_covariance()
        + (", the whole log at once ({{chunk_rows}} does not apply)" if req.chunk_rows else "")
    ]
    note = first_order_note(traj, terms)
    if note:
        notes.append(note)
    return OdometryOutcome(len(traj), req.output, traj.final, req.params, tuple(notes))


def _may_have_rows(path: Path, rows: int) -> bool:
    """Whether a CSV file may hold ``rows`` rows or more (each takes 6 bytes or more: ``0,0,0``
    and a line end), so that a short log does not load the compiled kernels it will not use."""
    try:
        return path.stat().st_size >= 6 * rows
    except OSError:  # the reader reports it
        return True


def _integrate_run(req: OdometryRequest) -> OdometryOutcome:
    """A recorded run of another format: its increments integrated with ``req.params``."""
    from odolab.core.odometry import integrate_increments
    from odolab.io import write_trajectory
    from odolab.io.registry import read_run
    from odolab.io.run import ReadOptions

    robot = req.params.params
    options = ReadOptions(ticks_per_rev=robot.ticks_per_rev, params=robot)
    run = read_run(req.log, req.log_format, options)
    traj = integrate_increments(
        run.t, run.dticks_left, run.dticks_right, robot, req.method, start=req.start,
        source=run.source,
    )  # fmt: skip
    write_trajectory(req.output, traj, req.fmt)
    return OdometryOutcome(len(traj), req.output, traj.final, req.params)

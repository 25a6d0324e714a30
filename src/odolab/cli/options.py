"""Options that several command modules share: each declared once, with one help text.

An option that only the commands of one module share stays in that module (``robot.py``'s
motion options, ``trials.py``'s filters); one tied to a module's own choices stays beside them
(``core.MethodOpt``, ``evaluate.RunFormatOpt``). This module registers no command and imports
nothing heavy: any command module may import it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from odolab.core.defaults import LogFormat

__all__ = [
    "BAG_GT_TOPIC",
    "BAG_JOINTS",
    "BAG_JOINT_TOPIC",
    "DEFAULT_DB",
    "CalibrationJsonOpt",
    "EncodersFormatOpt",
    "GtTopicOpt",
    "JointTopicOpt",
    "JointsOpt",
    "NewParamsOutputOpt",
    "NominalParamsOpt",
    "NotebookDbOpt",
    "RandomSeedOpt",
    "RunFormat",
    "SchedulerOpt",
    "VirtualTruthOpt",
    "WorkersOpt",
]


#: the formats of a recorded run (an encoder log and what came with it): the readers' own
RunFormat = LogFormat


#: the notebook file of the commands that need one (``trials``, ``notebook``, ``serve``)
NotebookDbOpt = Annotated[
    Path, typer.Option("--db", help="Notebook file (SQLite).", envvar="ODOLAB_DB")
]
DEFAULT_DB = Path("odolab.db")

#: ``calibrate ...``: where the calibrated parameters go
NewParamsOutputOpt = Annotated[Path, typer.Option("--output", "-o", help="New parameters TOML.")]
#: ``calibrate ratios|umbmark|imu``: the calibration as JSON too (``write_calibration_json``)
CalibrationJsonOpt = Annotated[
    Path | None,
    typer.Option("--json", help="Also write the calibration (what it started from too) as JSON."),
]

#: ``track``, ``track-photo``: the format of the run's encoder log (--encoders)
EncodersFormatOpt = Annotated[
    RunFormat, typer.Option("--format", "-f", help="Format of --encoders.")
]

#: ``sim explore``, ``sim questions``: the virtual robot's seed and true behaviour
RandomSeedOpt = Annotated[int, typer.Option(min=0, help="Random seed.")]
VirtualTruthOpt = Annotated[str, typer.Option(help="True-behaviour preset of the virtual robot.")]

#: ``robot ...``, ``sim run|explore``, ``calibrate sensor``, ``track-photo``: the nominal
#: parameters a run is driven, simulated or integrated with
NominalParamsOpt = Annotated[
    str, typer.Option("--params", "-p", help="Nominal parameters: TOML file or preset name.")
]

#: ``odometry``, ``evaluate``, ``calibrate lsq``, ``calibrate compare``: many runs on Dask
WorkersOpt = Annotated[
    int | None,
    typer.Option(
        help=(
            "Many runs or logs: Dask workers (default: none below 64 runs or logs, nor where the "
            "first 8 say all take under 30 s here; else 2)."
        )
    ),
]
SchedulerOpt = Annotated[
    str | None,
    typer.Option(
        help="Many runs or logs: Dask scheduler tcp://HOST:PORT (default: a local cluster)."
    ),
]

#: ``evaluate``, ``calibrate lsq``, ``calibrate compare``, ``calibrate sensor``: a bag's wheels
JointTopicOpt = Annotated[str, typer.Option(help="Bags: JointState topic.")]
JointsOpt = Annotated[
    tuple[str, str], typer.Option(help="Bags: LEFT RIGHT joint names in the JointState.")
]
BAG_JOINT_TOPIC = "/joint_states"
BAG_JOINTS = ("left_wheel_joint", "right_wheel_joint")
#: ``evaluate``, ``calibrate lsq``, ``calibrate compare``: a bag's ground truth
GtTopicOpt = Annotated[str, typer.Option(help="Bags: ground truth (PoseStamped/Odometry) topic.")]
BAG_GT_TOPIC = "/ground_truth"

"""Options that several command modules share: each declared once, with one help text.

An option that only the commands of one module share stays in that module (``robot.py``'s
motion options, ``trials.py``'s filters); one tied to a module's own choices stays beside them
(``core.MethodOpt``, ``evaluate.RunFormatOpt``). This module registers no command and imports
nothing heavy: any command module may import it.
"""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

__all__ = [
    "DEFAULT_DB",
    "EncodersFormatOpt",
    "NewParamsOutputOpt",
    "NotebookDbOpt",
    "RandomSeedOpt",
    "RunFormat",
    "VirtualTruthOpt",
]


class RunFormat(StrEnum):
    """The formats of a recorded run (an encoder log and what came with it)."""

    csv = "csv"
    optiodom = "optiodom"
    bag = "bag"
    drive = "drive"


#: the notebook file of the commands that need one (``trials``, ``notebook``, ``serve``)
NotebookDbOpt = Annotated[
    Path, typer.Option("--db", help="Notebook file (SQLite).", envvar="ODOLAB_DB")
]
DEFAULT_DB = Path("odolab.db")

#: ``calibrate ...``: where the calibrated parameters go
NewParamsOutputOpt = Annotated[Path, typer.Option("--output", "-o", help="New parameters TOML.")]

#: ``track``, ``track-photo``: the format of the run's encoder log (--encoders)
EncodersFormatOpt = Annotated[
    RunFormat, typer.Option("--format", "-f", help="Format of --encoders.")
]

#: ``sim explore``, ``sim questions``: the virtual robot's seed and true behaviour
RandomSeedOpt = Annotated[int, typer.Option(min=0, help="Random seed.")]
VirtualTruthOpt = Annotated[str, typer.Option(help="True-behaviour preset of the virtual robot.")]

"""Named defaults used across odolab (only ``enum`` imported, so the CLI can use them at no cost).

- :data:`DEFAULT_ROBOT`: the nominal parameter preset (:data:`odolab.core.params.PRESETS`).
- :data:`DEFAULT_TRUTH`: the virtual robot's true behaviour (:data:`odolab.sim.presets.TRUTH_PRESETS`).
- :data:`DEFAULT_TERRAIN`, :data:`DEFAULT_SEED`: the virtual robot's terrain and random seed
  (a robot run's virtual plant, ``robot sim-server``, the simulator's drives and exploration,
  the open questions); :data:`DEFAULT_MAX_WHEEL_SPEED`: a robot run's speeds
  (:class:`odolab.robot.config.RunConfig`, :data:`odolab.robot.registry.VIRTUAL_ONLY`).
- :data:`DEFAULT_CORNERS`: how ``odolab track`` refines marker corners
  (:data:`odolab.tracking.tracker.CORNER_METHODS`).
- :data:`DEFAULT_CHUNK_ROWS`: rows per chunk when a log is integrated in chunks and no size is
  given (:mod:`odolab.io.chunked`, :mod:`odolab.app.odometry`).
- :class:`LogFormat`: the formats of recorded runs, the keys of :data:`odolab.io.registry.READERS`
  (here so that the command line names them without importing the readers).
- :class:`DeltaUnit`, :class:`Alignment`, :class:`SyncMethod`: the metrics' choices (re-exported
  by :mod:`odolab.metrics.pose_error`, :mod:`odolab.metrics.alignment` and
  :mod:`odolab.metrics.association`), and :class:`TrialStatus` (re-exported by
  :mod:`odolab.core.trials`): here for the same reason, their modules load numpy.
"""

from __future__ import annotations

from enum import StrEnum

__all__ = [
    "DEFAULT_CHUNK_ROWS",
    "DEFAULT_CORNERS",
    "DEFAULT_MAX_WHEEL_SPEED",
    "DEFAULT_ROBOT",
    "DEFAULT_SEED",
    "DEFAULT_TERRAIN",
    "DEFAULT_TRUTH",
    "Alignment",
    "DeltaUnit",
    "LogFormat",
    "SyncMethod",
    "TrialStatus",
]

#: The nominal preset every command uses unless told otherwise (the lab's Jaguar Lite).
DEFAULT_ROBOT = "jaguar-lite"
#: The true robot every simulation uses unless told otherwise: derived from the lab report.
DEFAULT_TRUTH = "jaguar-lab"
#: The virtual robot's terrain and random seed unless told otherwise: the lab's floor, seed 0.
DEFAULT_TERRAIN = "tile"
DEFAULT_SEED = 0
#: A robot run's wheel speed (m/s) at full PWM, and its speed clip, unless told otherwise.
DEFAULT_MAX_WHEEL_SPEED = 1.0
#: The marker-corner refinement the tracker uses unless told otherwise: lines fitted to the
#: edges, steady under motion blur (docs/ground-truth.md).
DEFAULT_CORNERS = "contour"
#: Rows per chunk when none is given: about 100 MB of working memory.
DEFAULT_CHUNK_ROWS = 1_000_000


class LogFormat(StrEnum):
    """Formats of recorded runs (each has one reader in :data:`odolab.io.registry.READERS`)."""

    CSV = "csv"
    OPTIODOM = "optiodom"
    BAG = "bag"
    DRIVE = "drive"


class DeltaUnit(StrEnum):
    """Unit of the RPE step: poses (frames), path length (metres) or angle turned (degrees,
    radians)."""

    FRAMES = "frames"
    METRES = "m"
    DEGREES = "deg"
    RADIANS = "rad"


class Alignment(StrEnum):
    """How the estimate is moved onto the reference before APE."""

    NONE = "none"
    ORIGIN = "origin"
    SE2 = "se2"


class SyncMethod(StrEnum):
    """How two trajectories are paired in time."""

    NEAREST = "nearest"
    INTERPOLATE = "interpolate"


class TrialStatus(StrEnum):
    """Where a trial is in its life."""

    AWAITING = "awaiting"  #: driven, not yet measured
    MEASURED = "measured"
    EXCLUDED = "excluded"  #: kept, but left out of the analysis (with a reason)

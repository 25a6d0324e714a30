"""The Typer apps every CLI module adds its commands to (kept apart to avoid import cycles)."""

from __future__ import annotations

import typer

__all__ = [
    "app",
    "calibrate_app",
    "export_app",
    "params_app",
    "robot_app",
    "sim_app",
    "trials_app",
]


def _no_type_for_flags() -> None:
    """Typer 0.29's rich help shows a flag as ``--help <bool>``: a flag takes no value, so
    show no type for it (every other option keeps its ``<float>``, ``<path>`` ...)."""
    from typer import core

    option = getattr(core, "TyperOption", None)
    shown = getattr(option, "display_type_rich", None)
    if option is None or shown is None or getattr(shown, "_odolab", False):
        return

    def display_type_rich(self: object, ctx: object) -> str | None:
        if getattr(self, "is_flag", False) and not getattr(self, "count", False):
            return None
        return shown(self, ctx)  # type: ignore[no-any-return]

    display_type_rich._odolab = True  # type: ignore[attr-defined]
    option.display_type_rich = display_type_rich


_no_type_for_flags()

_SETTINGS = {"no_args_is_help": True, "pretty_exceptions_enable": False}

app = typer.Typer(
    help="odolab: honest wheel odometry - integrate, measure the error, calibrate, report.",
    add_completion=False,
    **_SETTINGS,  # type: ignore[arg-type]
)
params_app = typer.Typer(help="Robot parameter sets.", **_SETTINGS)  # type: ignore[arg-type]
sim_app = typer.Typer(help="The virtual Jaguar and experiment protocols.", **_SETTINGS)  # type: ignore[arg-type]
robot_app = typer.Typer(help="Drive a (virtual or real) Jaguar by odometry.", **_SETTINGS)  # type: ignore[arg-type]
trials_app = typer.Typer(help="The lab notebook: trials and measurements.", **_SETTINGS)  # type: ignore[arg-type]
calibrate_app = typer.Typer(help="Correct the kinematic model.", **_SETTINGS)  # type: ignore[arg-type]
_EXPORT_HELP = "Hand results to a robot's software: ROS 2 controller YAML, MCAP for Foxglove."
export_app = typer.Typer(help=_EXPORT_HELP, **_SETTINGS)  # type: ignore[arg-type]

app.add_typer(params_app, name="params")
app.add_typer(sim_app, name="sim")
app.add_typer(robot_app, name="robot")
app.add_typer(trials_app, name="trials")
app.add_typer(calibrate_app, name="calibrate")
app.add_typer(export_app, name="export")

"""Hand odolab's results to a robot's own software: ROS 2 controller parameters, MCAP files.

Layer: above calibration (it reads parameter sets, runs and notebook campaigns), below report.
"""

from __future__ import annotations

from odolab.export.ros2_controller import ControllerExport, diff_drive_controller_yaml

__all__ = ["ControllerExport", "diff_drive_controller_yaml"]

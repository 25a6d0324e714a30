"""The Jaguar lab report's own Table I, to set beside a campaign's (demo, terminal, report).

``LAB_REPORT_TABLE1``: (motion, terrain) -> (ratio, its stated uncertainty,
[(sigma, at, uncertainty), ...]); the y rows are the y error per metre travelled.
``LAB_REPORT_Y_SIGMA``: Table I's sigma of the y error, one figure for forward and reverse runs
together (the lab pooled its 5 + 5 runs at each distance): (sigma, distance, uncertainty). Its
1.1 m is the protocol's 1 m.
"""

from __future__ import annotations

import math

__all__ = ["LAB_REPORT_TABLE1", "LAB_REPORT_Y_SIGMA"]

LAB_REPORT_TABLE1: dict[tuple[str, str], tuple[float, float, list[tuple[float, float, float]]]] = {
    ("rotation", "tile"): (0.875, 0.005, [(2.94, 20 * math.pi, 0.05)]),
    ("x", "tile"): (0.905, 0.005, []),
    ("x", "concrete"): (0.920, 0.005, []),
    ("x", "grass"): (0.904, 0.005, []),
    ("y_forward", "tile"): (0.03, 0.01, []),
    ("y_reverse", "tile"): (0.09, 0.01, []),
}
LAB_REPORT_Y_SIGMA: list[tuple[float, float, float]] = [(0.03, 1.1, 0.01), (0.07, 2.5, 0.01)]

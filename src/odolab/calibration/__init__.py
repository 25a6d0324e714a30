"""odolab.calibration (filled in by its issue)."""

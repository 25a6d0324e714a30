"""odolab.robot (filled in by its issue)."""

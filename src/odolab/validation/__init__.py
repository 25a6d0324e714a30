"""odolab.validation (filled in by its issue)."""

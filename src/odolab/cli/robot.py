"""CLI commands: robot (filled in by its issue)."""

from __future__ import annotations

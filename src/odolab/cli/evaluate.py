"""CLI commands: evaluate (filled in by its issue)."""

from __future__ import annotations

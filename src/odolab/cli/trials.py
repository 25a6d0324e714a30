"""CLI commands: trials (filled in by its issue)."""

from __future__ import annotations

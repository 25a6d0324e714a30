"""The application layer: one function for each thing a user does.

A face (the CLI, the web notebook) parses its input into a request, calls one function of this
package, and renders the typed result. The rules that decide a number live here once: which trials
and campaigns count, which parameter version a calibration starts from, which parameters a log is
integrated with. When a function chooses for the user, its result says what it chose.

See docs/architecture.md ("The application layer").
"""

from __future__ import annotations

__all__: list[str] = []

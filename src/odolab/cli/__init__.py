"""The ``odolab`` command line: a thin shell over the library.

Each module below adds its commands to the apps in :mod:`odolab.cli._apps`. Heavy imports happen
inside the commands so that ``odolab --help`` stays instant. Every :class:`OdolabError` becomes
one line on stderr and exit code 1; no traceback.
"""

from __future__ import annotations

import sys

from odolab.cli import (  # noqa: F401  (register commands)
    consistency,
    core,
    demo,
    evaluate,
    export,
    groundtruth,
    lab,
    models,
    robot,
    scans,
    serve,
    sim,
    trials,
    validate,
)
from odolab.cli._apps import app
from odolab.errors import OdolabError
from odolab.text import safe_terminal

#: Longest error line printed (characters): a message echoing a huge input stays one line.
_MAX_ERROR_CHARS = 2000

__all__ = ["app", "main"]


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``odolab`` script; returns the exit code."""
    try:
        app(args=argv, prog_name="odolab", standalone_mode=True)
    except OdolabError as err:
        sys.stderr.write(f"odolab: error: {safe_terminal(err, limit=_MAX_ERROR_CHARS)}\n")
        return 1
    except OSError as err:  # a file the command could not read or write: one line, no traceback
        where = f"{err.filename}: " if err.filename else ""
        msg = safe_terminal(f"{where}{err.strerror or err}", limit=_MAX_ERROR_CHARS)
        sys.stderr.write(f"odolab: error: {msg}\n")
        return 1
    except SystemExit as exc:
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else 1)
    except KeyboardInterrupt:
        sys.stderr.write("odolab: interrupted\n")
        return 130
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

"""The ``odolab`` command line: a thin shell over the library.

Each module below adds its commands to the apps in :mod:`odolab.cli._apps`. Heavy imports happen
inside the commands so that ``odolab --help`` stays instant. Every :class:`OdolabError` becomes
one line on stderr and exit code 1; no traceback.
"""

from __future__ import annotations

import os
import sys

#: polars' allocator (jemalloc) keeps freed memory for seconds by default, so a whole log's read
#: stayed in memory beside the outputs (peak 2.0-2.4x the output arrays). The command line has it
#: hand memory back at once (1.6x; docs/scale.md). Set before polars loads. A value the user set
#: wins; the one a parent process's ``import polars`` leaves (its own defaults) does not.
POLARS_MALLOC_CONF = "dirty_decay_ms:0,muzzy_decay_ms:0"
_POLARS_OWN_CONF = "dirty_decay_ms:500,muzzy_decay_ms:1000"
if os.environ.get("_RJEM_MALLOC_CONF", _POLARS_OWN_CONF) == _POLARS_OWN_CONF:
    os.environ["_RJEM_MALLOC_CONF"] = POLARS_MALLOC_CONF

from odolab.cli import (  # noqa: E402, F401  (register commands)
    consistency,
    core,
    demo,
    evaluate,
    export,
    fleet,
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
from odolab.cli._apps import app  # noqa: E402
from odolab.errors import OdolabError  # noqa: E402
from odolab.text import safe_terminal  # noqa: E402

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

"""The ``odolab`` command line: a thin shell over the library.

Each module below adds its commands to the apps in :mod:`odolab.cli._apps`. Heavy imports happen
inside the commands so that ``odolab --help`` stays instant. Every :class:`OdolabError` becomes
one line on stderr and exit code 1; no traceback.
"""

from __future__ import annotations

import os
import sys

#: Settings of the native libraries, for a command that runs seconds, not hours. Each is set
#: before the library loads; a value the user set wins (docs/scale.md measures each):
#: - numba's OpenMP threads spin after each parallel loop by default, against polars' threads
#:   on the same cores (chunked odometry of 10 M rows: 0.5 s of CPU); here they sleep.
#: - numpy's and scipy's OpenBLAS threads spin for about 0.1 s after loading and after each
#:   call; here they sleep after 2**4 cycles (0.2 s of CPU a command: numba loads scipy's).
NATIVE_SETTINGS = {"OMP_WAIT_POLICY": "passive", "OPENBLAS_THREAD_TIMEOUT": "4"}
for _name, _value in NATIVE_SETTINGS.items():
    os.environ.setdefault(_name, _value)

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

"""Run odolab commands in this process as on a core-only install: the top-level modules named
in ODOLAB_BLOCKED (comma-separated) are unimportable, as if not installed (``import`` raises
ModuleNotFoundError, ``importlib.util.find_spec`` answers None).

Usage: ``python extras_blocked.py --odolab ARGS...`` runs one command; ``python
extras_blocked.py JSON``, with JSON a list of argument lists, run one after the
other by ``odolab.cli.main``; the last line printed is a JSON list of
``{"args", "code", "out", "err"}``. Special argument lists:

- ``["robot", "sim-server", ...]`` starts that board in a child process (blocked alike) and
  gives later ``robot`` commands ``--robot udp://127.0.0.1:PORT``;
- ``["--import-all"]`` imports every odolab module but the web server's (``err``: the failures);
- ``["--pandas"]`` asks an empty notebook for ``trials_frame`` (``err``: the error's message).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import signal
import subprocess
import sys

for _name in filter(None, os.environ.get("ODOLAB_BLOCKED", "").split(",")):
    sys.modules[_name] = None  # type: ignore[assignment]  # "import of NAME halted"


def _import_all() -> str:
    import importlib
    import pkgutil

    import odolab

    failed = []
    for m in pkgutil.walk_packages(odolab.__path__, "odolab."):
        if m.name.endswith("__main__") or m.name.startswith("odolab.serve"):
            continue
        try:
            importlib.import_module(m.name)
        except Exception as err:
            failed.append(f"{m.name}: {err!r}")
    return "\n".join(failed)


def _pandas() -> str:
    from odolab.core.errors import OdolabError
    from odolab.store import Notebook

    with Notebook("empty.db") as nb:
        try:
            nb.trials_frame()
        except OdolabError as err:
            return str(err)
    return ""


def main() -> None:
    from odolab.cli import main as odolab

    results: list[dict[str, object]] = []
    board: subprocess.Popen[str] | None = None
    robot: list[str] = []
    try:
        for args in json.loads(sys.argv[1]):
            if args[:2] == ["robot", "sim-server"]:
                board = subprocess.Popen(
                    [sys.executable, __file__, "--odolab", *args],
                    stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                )  # fmt: skip
                assert board.stderr is not None
                line, found = "", None
                for _ in range(3):  # its address, after the note of a core without numba
                    line = board.stderr.readline()
                    found = re.search(r"udp://127\.0\.0\.1:(\d+)", line)
                    if found:
                        break
                assert found, line
                robot = ["--robot", found.group(0)]
                results.append({"args": args, "code": 0, "out": line, "err": ""})
                continue
            out, err = io.StringIO(), io.StringIO()
            code: int = 0
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                if args == ["--import-all"]:
                    err.write(_import_all())
                elif args == ["--pandas"]:
                    err.write(_pandas())
                else:
                    extra = robot if args[0] == "robot" and "--robot" not in args else []
                    code = odolab([*args, *extra])
            results.append(
                {"args": args, "code": code, "out": out.getvalue(), "err": err.getvalue()}
            )
    finally:
        if board is not None:
            board.send_signal(signal.SIGTERM)
            try:
                board.wait(timeout=10)
            except subprocess.TimeoutExpired:  # pragma: no cover - a hung board
                board.kill()
    print(json.dumps(results))


if __name__ == "__main__":
    if sys.argv[1] == "--odolab":  # one command, as the odolab script runs it
        from odolab.cli import main as odolab

        sys.exit(odolab(sys.argv[2:]))
    main()

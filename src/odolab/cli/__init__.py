"""The ``odolab`` command line: a thin shell over the library.

Each module in :data:`COMMAND_MODULES` adds its commands to the apps in :mod:`odolab.cli._apps`;
a command imports only the modules its first word needs (:data:`COMMAND_WORDS`). Heavy imports
happen inside the commands so that ``odolab --help`` stays instant. Every :class:`OdolabError` and
every usage error (missing argument, wrong count, bad choice, unknown option) becomes one line on
stderr and exit code 1; no traceback, no box. ``--help`` written to a pipe is wide enough that no
option name is cut (:func:`odolab.cli._console.wide_help_when_piped`).
"""

from __future__ import annotations

import gc
import importlib
import os
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, Protocol

#: Settings of the native libraries, for a command that runs seconds, not hours. Each is set
#: before the library loads; a value the user set wins (docs/scale.md measures each):
#: - numba's OpenMP threads spin after each parallel loop by default, against polars' threads
#:   on the same cores (chunked odometry of 10 M rows: 0.5 s of CPU); here they sleep.
#: - numpy's and scipy's OpenBLAS threads spin for about 0.1 s after loading and after each
#:   call; here they sleep after 2**4 cycles (0.2 s of CPU a command: numba loads scipy's).
NATIVE_SETTINGS = {"OMP_WAIT_POLICY": "passive", "OPENBLAS_THREAD_TIMEOUT": "4"}
for _name, _value in NATIVE_SETTINGS.items():
    os.environ.setdefault(_name, _value)

from odolab.core.errors import OdolabError  # noqa: E402
from odolab.core.extras import (  # noqa: E402
    COMMAND_PREFERS,
    MissingExtraError,
    command_extra,
    extra_of_missing,
    require,
)
from odolab.core.text import safe_terminal  # noqa: E402

if TYPE_CHECKING:
    import typer

#: The modules that add commands, in the order a full load imports them (their commands are
#: listed in this order, as before lazy loading).
COMMAND_MODULES: tuple[str, ...] = (
    "consistency", "core", "demo", "evaluate", "export", "fleet", "groundtruth", "imu", "lab",
    "models", "photo", "robot", "scans", "serve", "sim", "trials", "validate",
)  # fmt: skip

#: For each top-level word, the modules that add its command or its group's commands. A
#: command imports only these (0.15 s less start-up than all of them; docs/scale.md); a test
#: checks the table against the commands each module registers.
COMMAND_WORDS: dict[str, tuple[str, ...]] = {
    "analyze": ("lab",),
    "calibrate": ("consistency", "evaluate", "groundtruth", "imu", "lab", "models"),
    "camera": ("groundtruth",),
    "demo": ("demo",),
    "evaluate": ("evaluate",),
    "export": ("export",),
    "fleet": ("fleet",),
    "markers": ("groundtruth",),
    "notebook": ("trials",),
    "odometry": ("core",),
    "params": ("core",),
    "report": ("lab",),
    "robot": ("robot",),
    "scans": ("scans",),
    "serve": ("serve",),
    "sim": ("groundtruth", "models", "photo", "scans", "sim"),
    "track": ("groundtruth",),
    "track-photo": ("photo",),
    "trials": ("trials",),
    "validate": ("validate",),
}


def load_commands(args: Sequence[str] = ()) -> typer.Typer:
    """Import the command modules that ``odolab ARGS`` needs (all of them for top-level help, an
    option first, or an unknown word, whose error lists every command) and return the app."""
    wanted = COMMAND_MODULES
    if args and not args[0].startswith("-"):
        wanted = COMMAND_WORDS.get(args[0], COMMAND_MODULES)
    for name in COMMAND_MODULES:
        if name in wanted:
            importlib.import_module(f"odolab.cli.{name}")
    from odolab.cli._apps import app

    if _may_show_help(args):  # typer's help renderer imports rich.markdown and pygments: 8 MB
        from odolab.cli._console import wide_help_when_piped

        wide_help_when_piped()
    _add_version(app)
    return app


def _may_show_help(args: Sequence[str]) -> bool:
    """Whether ``odolab ARGS`` may print typer's help: ``--help``, or command words alone (a
    group without its subcommand prints its help)."""
    if not args or any(a in ("--help", "-h") for a in args):
        return True
    return len(args) <= 2 and not any(a.startswith("-") for a in args)


def _add_version(app: Any) -> None:
    """``odolab --version``: the program's version, then exit 0."""
    if getattr(app, "_odolab_version", False):
        return
    import typer

    def show_version(value: bool) -> None:
        if value:
            from odolab import __version__

            typer.echo(f"odolab {__version__}")
            raise typer.Exit()

    def root(
        version: bool = typer.Option(
            False,
            "--version",
            callback=show_version,
            is_eager=True,
            help="Show the version and exit.",
        ),
    ) -> None:
        """odolab: honest wheel odometry - integrate, measure the error, calibrate, report."""

    app.callback()(root)
    app._odolab_version = True


def _click() -> Any:
    """The click that typer runs on (typer 0.29 carries its own copy)."""
    try:
        from typer import _click as vendored  # type: ignore[attr-defined,unused-ignore]

        return vendored
    except ImportError:  # pragma: no cover - typer < 0.29: click itself
        import click

        return click


def _abort() -> type[BaseException]:
    """The exception of an aborted prompt (typer's own since 0.29)."""
    from typer import Abort

    return Abort


def usage_sentence(err: Any, app: Any = None, args: Sequence[str] = ()) -> str:
    """A click usage error (missing argument, wrong count, bad choice, unknown option) as one
    sentence: the command, what is wrong, where the help is. The command is the error's, or
    else the command words at the start of ``args`` (of ``app``)."""
    message = " ".join(str(err.format_message()).split()).rstrip(".")
    ctx = getattr(err, "ctx", None)
    path = ctx.command_path if ctx is not None else _command_path(app, args)
    return f"{path}: {message}; see '{path} --help'"


def _command_path(app: typer.Typer, args: Sequence[str]) -> str:
    """``odolab`` and the command and group names that start ``args``."""
    words = ["odolab"]
    if app is None:
        return words[0]
    command: Any = built(app)
    for word in args:
        sub = getattr(command, "commands", {}).get(word)
        if sub is None:
            break
        words.append(word)
        command = sub
    return " ".join(words)


class _Command(Protocol):
    """What :func:`main` calls of a click command."""

    def __call__(self, *, args: list[str] | None, prog_name: str, standalone_mode: bool) -> object:
        """Parse ``args`` in a new context and run the command they name."""


#: The click command typer makes of an app, by the app and the number of commands and groups
#: registered in it (a command module imported later adds some: then it is made anew).
_BUILT: dict[tuple[int, int], tuple[typer.Typer, _Command]] = {}


def _registered(app: typer.Typer) -> int:
    """How many commands, groups and callbacks ``app`` and its groups hold."""
    n = len(app.registered_commands) + (app.registered_callback is not None)
    for group in app.registered_groups:
        n += 1 + (0 if group.typer_instance is None else _registered(group.typer_instance))
    return n


def built(app: typer.Typer) -> _Command:
    """The click command of ``app``, made once per set of registered commands.

    Calling a typer app makes its click command anew each time, from every command function's
    signature and type hints: 60-90 ms with all of odolab's commands loaded. ``odolab`` runs it
    once, but a process that calls :func:`main` again (a notebook, a script, the test suite)
    paid it on every call. A click command keeps no state between calls: each call parses into
    a new context. The app's ``pretty_exceptions_enable`` is off, so typer's own call added
    nothing else."""
    import typer.main

    key = (id(app), _registered(app))
    kept = _BUILT.get(key)
    if kept is not None and kept[0] is app:  # (the app itself: an id is reused once freed)
        return kept[1]
    _BUILT.clear()
    command = typer.main.get_command(app)
    _BUILT[key] = (app, command)
    return command


#: Modules a data command imports anyway, loaded before it runs, in :func:`_start_up`.
PRELOAD: dict[str, tuple[str, ...]] = {
    "odometry": ("polars", "odolab.io", "odolab.io.chunked", "odolab.core.odometry"),
    "evaluate": ("polars", "odolab.io", "odolab.io.chunked", "odolab.metrics"),
}


_BINARY_TABLES = (".parquet", ".pq", ".arrow", ".feather", ".ipc")


def preloaded(args: Sequence[str]) -> tuple[str, ...]:
    """The modules of :data:`PRELOAD` that the command in ``args`` loads before it runs.

    ``odometry`` between Parquet or Arrow IPC files (an input and ``-o``/``--output`` of those
    formats, no CSV named, no ``--format`` or ``--to``) reads and writes with pyarrow alone:
    polars (0.2-0.4 s to import) is not loaded for it. A guess from the words alone: a command
    that needs a module not loaded here still imports it when it uses it."""
    names = PRELOAD.get(args[0] if args else "", ())
    if not args or args[0] != "odometry":
        return names
    words = list(args[1:])
    out = None
    for i, word in enumerate(words):
        if word in ("-o", "--output") and i + 1 < len(words):
            out = words[i + 1]
        elif word.startswith("--output="):
            out = word.partition("=")[2]
    binary = [w for w in words if w.lower().endswith(_BINARY_TABLES)]
    if (
        out is not None
        and out.lower().endswith(_BINARY_TABLES)
        and len(binary) >= 2
        and not any(w.lower().endswith(".csv") for w in words)
        and not any(w.split("=")[0] in ("-f", "--format", "--to") for w in words)
    ):
        return tuple(n for n in names if n != "polars")
    return names


@contextmanager
def _start_up(freeze: bool) -> Iterator[None]:
    """The garbage collector waits while a command's modules load.

    Imports make some 150,000 objects that live as long as the process; collecting while they
    are made cost 0.12-0.17 s a command, a tenth of a short command (docs/scale.md). In the
    ``odolab`` program (``freeze``; not a library call, which must not keep its caller's
    garbage) they are then frozen, so later collections skip them too."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if freeze:
            gc.freeze()
        if enabled:
            gc.enable()


def __getattr__(name: str) -> Any:
    """``odolab.cli.app``: the app with every command (imported on first use)."""
    if name == "app":
        return load_commands()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _words_of(args: Sequence[str]) -> list[str]:
    """The command's words (``calibrate sensor``): the arguments before the first option, at
    most two, those that name a command group and its command."""
    words: list[str] = []
    for a in args[:2]:
        if a.startswith("-") or (words and words[0] not in _GROUPS):
            break
        words.append(a)
    return words


#: The top-level words that are groups of commands (their second word is the command).
_GROUPS = frozenset(
    {"calibrate", "camera", "export", "fleet", "notebook", "params", "robot", "sim", "trials"}
)

#: Longest error line printed (characters): a message echoing a huge input stays one line.
_MAX_ERROR_CHARS = 2000

__all__ = ["app", "main"]


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``odolab`` script; returns the exit code."""
    args = sys.argv[1:] if argv is None else list(argv)
    asks_help = any(a in ("--help", "-h") for a in args)
    needed = None if asks_help else command_extra(_words_of(args))
    try:
        if needed is not None:  # before the command runs: nothing written
            require(needed, f"odolab {' '.join(_words_of(args))}")
        with _start_up(freeze=argv is None):
            app = load_commands(args)
            if "--help" not in args:
                for name in preloaded(args):
                    importlib.import_module(name)
        # (the program's own arguments as None: click expands wildcards itself on Windows)
        code = built(app)(
            args=None if argv is None else args, prog_name="odolab", standalone_mode=False
        )
    except _click().exceptions.UsageError as err:
        if type(err).__name__ == "NoArgsIsHelpError":  # `odolab`, `odolab calibrate`: the help
            err.ctx.get_help()
            return 1
        line = usage_sentence(err, app, args)
        sys.stderr.write(f"odolab: error: {safe_terminal(line, limit=_MAX_ERROR_CHARS)}\n")
        return 1
    except _click().exceptions.ClickException as err:  # (a file click could not open)
        line = " ".join(str(err.format_message()).split())
        sys.stderr.write(f"odolab: error: {safe_terminal(line, limit=_MAX_ERROR_CHARS)}\n")
        return 1
    except _abort():
        sys.stderr.write("odolab: aborted\n")
        return 1
    except OdolabError as err:  # the library's sentence, its settings named by their flags
        from odolab.cli.wording import worded

        sys.stderr.write(f"odolab: error: {safe_terminal(worded(err), limit=_MAX_ERROR_CHARS)}\n")
        return 1
    except ImportError as err:  # an extra's package, first asked for by this input
        extra = extra_of_missing(err, needed or command_extra(_words_of(args), COMMAND_PREFERS))
        if extra is None:
            raise
        words = " ".join(_words_of(args))
        line = str(MissingExtraError(extra, f"odolab {words}".strip()))
        sys.stderr.write(f"odolab: error: {safe_terminal(line, limit=_MAX_ERROR_CHARS)}\n")
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
    if code == 130:  # typer turns Ctrl-C (and a run's SIGTERM) into exit 130 without a word
        sys.stderr.write("odolab: interrupted\n")
    return code if isinstance(code, int) else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

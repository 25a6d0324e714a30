"""The command line's face when it is used wrongly or read through a pipe: ``--help`` never cuts
an option name or a list of choices, every usage error is one sentence with exit code 1 (no
box), and ``odolab --version``."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
import typer
from typer.testing import CliRunner

from odolab import __version__
from odolab.cli import app, main


def _commands(command: Any, path: tuple[str, ...] = ()) -> Iterator[tuple[tuple[str, ...], Any]]:
    yield path, command
    for name, sub in sorted(getattr(command, "commands", {}).items()):
        yield from _commands(sub, (*path, name))


ROOT = typer.main.get_command(app)
COMMANDS = list(_commands(ROOT))


def test_every_command_is_walked() -> None:
    paths = {p for p, _ in COMMANDS}
    assert ("evaluate",) in paths and ("calibrate", "lsq") in paths and len(paths) > 40


def test_piped_help_never_cuts_a_name_or_a_choice(monkeypatch: pytest.MonkeyPatch) -> None:
    """Through the runner (not a terminal, as a pipe): rich's default 80 columns cut
    ``--pairs-from-re…`` and split ``<csv|optiodom|b`` / ``ag>``."""
    import typer.testing

    monkeypatch.setattr(typer.testing, "_get_command", lambda _app: ROOT)  # built once
    runner = CliRunner()
    checked: set[str] = set()
    for path, command in COMMANDS:
        result = runner.invoke(app, [*path, "--help"], env={"COLUMNS": "", "TERMINAL_WIDTH": ""})
        where = " ".join(("odolab", *path))
        assert result.exit_code == 0, (where, result.output)
        out = result.output
        assert "…" not in out, where
        for param in command.params:
            for name in [*param.opts, *getattr(param, "secondary_opts", [])]:
                if name.startswith("--"):
                    assert name in out, (where, name)
            choices = getattr(getattr(param, "type", None), "choices", None)  # typer 0.28
            display = getattr(param, "display_type_rich", None)  # typer 0.29
            if choices:
                shown: str | None = "<" + "|".join(map(str, choices)) + ">"
            else:
                shown = display(None) if display is not None else None
            if shown and "|" in shown:  # a list of choices, <csv|optiodom|bag>: on one line
                assert shown in out, (where, shown)
                checked.add(shown)
    assert {"<csv|optiodom|bag|drive>", "<frames|m|deg|rad>"} <= checked


@pytest.mark.parametrize(
    ("args", "sentence"),
    [
        (
            ["odometry", "log.csv", "--start", "1", "2"],
            "odolab odometry: Option '--start' requires 3 arguments; see 'odolab odometry --help'",
        ),
        (["evaluate"], "odolab evaluate: Missing argument 'paths'; see 'odolab evaluate --help'"),
        (
            ["evaluate", "a", "b", "--delta-unit", "yards"],
            "odolab evaluate: Invalid value for '--delta-unit'",
        ),
        (["evaluate", "a", "b", "--no-such"], "odolab evaluate: No such option: --no-such"),
        (["calibrate", "lsq", "r", "--joints", "a"], "odolab calibrate lsq: Option '--joints'"),
        (["odometri"], "odolab: No such command 'odometri'. Did you mean 'odometry'?"),
    ],
)
def test_usage_errors_are_one_sentence_and_exit_1(
    args: list[str], sentence: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(args) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"odolab: error: {sentence}")
    assert err.count("\n") == 1
    assert "╭" not in err and "Usage:" not in err


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--version"]) == 0
    assert capsys.readouterr().out == f"odolab {__version__}\n"

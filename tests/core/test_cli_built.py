"""`odolab.cli.main` makes typer's click command once per set of commands (issue 36)."""

from __future__ import annotations

import pytest
import typer
import typer.main

from odolab import cli
from odolab.cli import built, main


def test_main_makes_the_click_command_once_and_each_call_parses_anew(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    made: list[object] = []
    real = typer.main.get_command
    monkeypatch.setattr(typer.main, "get_command", lambda app: made.append(app) or real(app))
    monkeypatch.setattr(cli, "_BUILT", {})
    assert main(["params", "list"]) == 0
    first = capsys.readouterr().out
    assert main(["params", "show", "nope"]) == 1  # a failed call leaves nothing behind
    capsys.readouterr()
    assert main(["params", "list"]) == 0
    assert capsys.readouterr().out == first
    assert len(made) == 1


def test_a_command_added_later_makes_it_anew() -> None:
    app = typer.Typer()

    @app.command()
    def one() -> None:
        """One."""

    first = built(app)
    assert built(app) is first
    sub = typer.Typer()

    @sub.command()
    def two() -> None:
        """Two."""

    app.add_typer(sub, name="more")
    again = built(app)
    assert again is not first
    assert set(again.commands) == {"one", "more"}  # type: ignore[attr-defined]

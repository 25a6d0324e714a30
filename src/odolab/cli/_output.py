"""Writing the CLI's output: files (a path that cannot be written is one sentence, not a
traceback) and user text on the terminal (escape sequences shown, never obeyed)."""

from __future__ import annotations

from pathlib import Path

from odolab.core.errors import OdolabError
from odolab.core.text import safe_terminal

__all__ = [
    "OutputError",
    "check_output_path",
    "echo",
    "markup_text",
    "term",
    "write_calibration_json",
    "write_json",
    "write_output_text",
]


def term(text: object) -> str:
    """User text (a trial id, a campaign, a terrain, a reason) for ``typer.echo``."""
    return safe_terminal(text)


def echo(message: object, *, err: bool = False) -> None:
    """``typer.echo`` for a message that carries user text (a path, a name, an error): each line
    goes through :func:`term`, so an escape sequence in a file name is shown, never obeyed."""
    import typer

    from odolab.cli.wording import said

    typer.echo("\n".join(term(line) for line in said(message).split("\n")), err=err)


def markup_text(text: object) -> str:
    """User text inside a string that a rich console reads as markup (``[yellow]...``)."""
    from rich.markup import escape

    return escape(safe_terminal(text))


class OutputError(OdolabError):
    """An output file cannot be written (a folder, no permission, a full disk)."""


def check_output_path(path: Path, what: str) -> None:
    """Refuse a path that is a folder, and create the parent folder."""
    if path.is_dir():
        raise OutputError(f"{path}: is a folder; expected a file name for the {what}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise OutputError(f"{path}: cannot create its folder for the {what} ({err})") from err


def check_not_the_input(output: Path, params: str | None) -> None:
    """Refuse writing new parameters over the ``--params`` file they start from: the result
    would replace what the calibration was made from (nothing already recorded is lost)."""
    if params is None:
        return
    source = Path(params)
    try:
        same = source.is_file() and output.exists() and source.samefile(output)
    except OSError:
        same = False
    if same:
        raise OutputError(
            f"{output}: is the --params file this calibration starts from; writing the new "
            "parameters there would replace it; expected another file name for -o"
        )


def write_output_text(path: Path, text: str, what: str) -> None:
    """Write ``text`` to ``path`` (UTF-8), creating its folder; the settings the library's
    text names (its marks) written as the flags (:mod:`odolab.cli.wording`)."""
    from odolab.cli.wording import said
    from odolab.core.writing import write_text_file

    check_output_path(path, what)
    write_text_file(path, said(text), what=what, error=OutputError)


def write_json(doc: object, path: Path | None) -> None:
    """A command's ``--json``: ``doc`` as strict JSON and a newline at ``path``; nothing
    without a path."""
    if path is not None:
        from odolab.core.writing import strict_json

        write_output_text(path, strict_json(doc) + "\n", "JSON result")


def write_calibration_json(doc: object, path: Path | None) -> None:
    """A ``calibrate ...`` command's ``--json``: ``doc`` as strict JSON at ``path``, and a line
    saying so; nothing without a path."""
    if path is not None:
        from odolab.core.writing import strict_json

        write_output_text(path, strict_json(doc), "calibration JSON")
        echo(f"calibration written to {path}")

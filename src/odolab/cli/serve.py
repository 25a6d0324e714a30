"""CLI command: ``odolab serve``, the lab notebook in the browser."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

import typer

from odolab.cli._apps import app
from odolab.cli._output import echo
from odolab.cli.options import DEFAULT_DB, NotebookDbOpt

if TYPE_CHECKING:
    from odolab.serve import ServerInfo

__all__: list[str] = []


@app.command("serve")
def serve_cmd(
    db: NotebookDbOpt = DEFAULT_DB,
    host: Annotated[
        str,
        typer.Option(help="Address to listen on; any but 127.0.0.1/localhost needs the token."),
    ] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="Port (0: any free one).")] = 8000,
) -> None:
    """Serve the notebook as web pages (enter measurements on a phone) and a JSON API."""
    from odolab.cli.trials import _open
    from odolab.serve import serve, settings_for

    with _open(db):  # the CLI's sentence for a missing notebook; migrates an old one
        pass
    settings = settings_for(db, host)

    def ready(info: ServerInfo) -> None:
        echo(f"odolab notebook {db} served at:\n\n    {info.url}\n")
        if info.token:
            echo(
                "Open that address (it carries the access token) on the phone; every request "
                "without the token is refused. Ctrl-C stops the server."
            )
        else:
            echo(
                "Only this computer can reach it (--host 0.0.0.0 to serve the phone, with a "
                "token). Ctrl-C stops the server."
            )

    serve(settings, host, port, ready=ready)

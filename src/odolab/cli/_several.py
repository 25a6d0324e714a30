"""Options that take several values: ``--validate D E F`` (what a shell glob gives).

click gives an option one value per occurrence: ``--validate D E F`` holds out D, and E and F
become positional arguments, fitted without a word. A command made with
:func:`several_values_command` reads every value after such an option, up to the next option
(or ``--``), as that option's: ``--validate D --validate E --validate F``.
"""

from __future__ import annotations

from typing import Any

from typer.core import TyperCommand

__all__ = ["several_values_command", "spread_option_values"]


def spread_option_values(args: list[str], option: str) -> list[str]:
    """``args`` with each value after ``option`` (up to the next option, or ``--``) given its
    own ``option``: ``[--validate, D, E]`` -> ``[--validate, D, --validate, E]``."""
    out: list[str] = []
    taking = False  # the previous value belonged to ``option``
    i = 0
    while i < len(args):
        a = args[i]
        if a == "--":
            out.extend(args[i:])
            break
        if a == option and i + 1 < len(args):
            out.extend((a, args[i + 1]))
            taking = True
            i += 2
            continue
        if a.startswith(option + "="):
            out.append(a)
            taking = True
        elif taking and not (a.startswith("-") and len(a) > 1):
            out.extend((option, a))
        else:
            taking = False
            out.append(a)
        i += 1
    return out


def several_values_command(*options: str) -> type[TyperCommand]:
    """A command class (``@app.command(cls=...)``) whose ``options`` take every value up to the
    next option."""

    class SeveralValues(TyperCommand):
        def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
            for option in options:
                args = spread_option_values(args, option)
            return super().parse_args(ctx, args)

    SeveralValues.__doc__ = f"A command whose {', '.join(options)} take several values."
    return SeveralValues

"""The CLI imports only the command modules a command needs: the table it uses is true, and a
command run that way behaves as with every module loaded."""

from __future__ import annotations

import subprocess
import sys
from typing import Any

import odolab.cli as cli


def _word_modules(app: Any) -> dict[str, set[str]]:
    """Each top-level word of ``app``, with the modules whose functions its commands run."""

    def modules(group: Any) -> set[str]:
        found = {info.callback.__module__ for info in group.registered_commands}
        for sub in group.registered_groups:
            found |= modules(sub.typer_instance)
        return found

    words: dict[str, set[str]] = {}
    for info in app.registered_commands:
        name = info.name or info.callback.__name__.replace("_", "-")
        words.setdefault(name, set()).add(info.callback.__module__)
    for sub in app.registered_groups:
        words.setdefault(sub.name, set()).update(modules(sub.typer_instance))
    return {w: {m.removeprefix("odolab.cli.") for m in ms} for w, ms in words.items()}


def test_the_table_names_every_word_and_its_modules() -> None:
    found = _word_modules(cli.app)  # every module loaded
    assert set(found) == set(cli.COMMAND_WORDS)
    for word, mods in found.items():
        assert set(cli.COMMAND_WORDS[word]) == mods, word
    assert {m for ms in found.values() for m in ms} == set(cli.COMMAND_MODULES)


def _fresh(code: str) -> str:
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    )
    return proc.stdout


def test_a_command_loads_only_its_modules() -> None:
    out = _fresh(
        "import sys\n"
        "from odolab.cli import main\n"
        "assert main(['params', 'list']) == 0\n"
        "print(sorted(m for m in sys.modules if m.startswith('odolab.cli.')))\n"
    )
    assert "jaguar-lite" in out
    assert "'odolab.cli.core'" in out
    for other in ("trials", "robot", "groundtruth", "lab", "serve", "evaluate"):
        assert f"'odolab.cli.{other}'" not in out, other


def test_help_lazily_is_the_help_with_everything() -> None:
    show = (
        "from odolab.cli import main{extra}\n"
        "try:\n"
        "    main(['calibrate', '--help'])\n"
        "except SystemExit:\n"
        "    pass\n"
    )
    lazy = _fresh(show.format(extra=""))
    full = _fresh(show.format(extra="\nimport odolab.cli\nodolab.cli.app"))
    assert "umbmark" in lazy and "sensor" in lazy and "noise" in lazy
    assert lazy == full


def test_an_unknown_word_still_gets_the_suggestion() -> None:
    proc = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys\nfrom odolab.cli import main\nsys.exit(main(['odometri']))",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 1  # a usage error: one sentence, exit 1 (issue 25.9)
    assert "Did you mean 'odometry'?" in proc.stderr


def test_the_collector_runs_again_after_start_up() -> None:
    """A library call of main() leaves the collector on and freezes nothing of its caller's."""
    import gc

    frozen = gc.get_freeze_count()
    assert cli.main(["params", "list"]) == 0
    assert gc.isenabled()
    assert gc.get_freeze_count() == frozen


def test_the_program_freezes_its_start_up_and_collects_after() -> None:
    out = _fresh(
        "import gc, sys\n"
        "from odolab.cli import main\n"
        "sys.argv = ['odolab', 'params', 'list']\n"
        "assert gc.get_freeze_count() == 0\n"
        "code = main()\n"
        "print(code, gc.isenabled(), gc.get_freeze_count() > 10_000)\n"
    )
    assert out.splitlines()[-1] == "0 True True"

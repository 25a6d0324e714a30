"""The README's "session by hand", run line by line as a new user would type it.

Each line runs in a shell in an empty folder with only the installed ``odolab`` put on the PATH
(what the README's ``export PATH=...`` line does). The one question-asking step
(``trials measure``) gets the answers the README tells a user of the virtual Jaguar to give:
the virtual instruments' readings ``robot rotate`` printed, as typed from a compass.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

#: `make test-fast` leaves these out (the README's hand session, in real time); `make test` and CI run them
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"


def hand_session() -> list[str]:
    text = README.read_text(encoding="utf-8")
    start = text.index("<!-- hand-session")
    fence = text.index("```", start)
    body = text[text.index("\n", fence) + 1 : text.index("```", fence + 3)]
    return [line for line in body.splitlines() if line.strip()]


def user_env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "ODOLAB_DB")}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["MPLBACKEND"] = "Agg"
    return env


def compass_answers(robot_output: str) -> str:
    """What the README says to answer for a virtual run: what its virtual instruments show,
    typed as printed (no arithmetic by hand)."""
    m = re.search(
        r"the virtual instruments show: compass (\S+) -> (\S+) deg, (\d+) whole turn", robot_output
    )
    assert m, robot_output
    return f"{m.group(1)}\n{m.group(2)}\n{m.group(3)}\n"


def test_readme_hand_session_reaches_a_report(tmp_path: Path) -> None:
    lines = hand_session()
    commands = [ln.split("#")[0].strip() for ln in lines]
    assert commands[0] == "odolab notebook init --db lab.db"
    assert any(c.startswith("odolab report") for c in commands)
    outputs: dict[str, str] = {}
    robot_out = ""
    for line in lines:
        stdin = compass_answers(robot_out) if line.startswith("odolab trials measure") else None
        proc = subprocess.run(
            ["bash", "-c", line],
            cwd=tmp_path,
            env=user_env(),
            input=stdin,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert proc.returncode == 0, f"{line}\n{proc.stdout}\n{proc.stderr}"
        outputs[line.split("#")[0].strip()] = proc.stdout
        if line.startswith("odolab robot"):
            robot_out = proc.stdout
    analyze = next(v for k, v in outputs.items() if k.startswith("odolab analyze"))
    # 37 + 20 simulated trials and the user's own run, said in words, then Table I
    assert (
        "using 58 measured trials from rotation-indoor (37), translation-indoor (20), robot (1)"
        in analyze
    )
    assert re.search(r"rotation\s+.*tile\s+.*38", analyze), analyze
    report = tmp_path / "report" / "report.html"
    assert report.exists() and (tmp_path / "report" / "results.json").exists()
    assert (tmp_path / "jaguar-calibrated.toml").exists()


@pytest.mark.parametrize("line", ['export PATH="$PWD/.venv/bin:$PATH"'])
def test_readme_says_how_to_reach_the_installed_command(line: str) -> None:
    text = README.read_text(encoding="utf-8")
    assert line in text
    # and the command it puts on the PATH is the one the Makefile installs
    make = (ROOT / "Makefile").read_text(encoding="utf-8")
    assert "VENV := .venv" in make and "BIN := $(VENV)/bin" in make and "$(BIN)/odolab" in make

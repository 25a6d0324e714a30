"""``odolab calibrate compare RUN... --validate HELD_OUT...`` (issue 30): every path a shell glob
gives after --validate is held out, as in ``calibrate lsq`` (E and F were fitted before)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import odolab.calibration.compare as compare
from odolab.cli import main
from odolab.core.errors import OdolabError


class _Seen(OdolabError):
    pass


def test_compare_holds_out_a_shell_glob(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    seen: dict[str, Any] = {}

    def fake(paths: list[Path], fmt: str, **kw: Any) -> None:
        seen["fit"] = [str(p) for p in paths]
        seen["held"] = [str(p) for p in kw["validate"]]
        raise _Seen("stop here")

    monkeypatch.setattr(compare, "compare_model_files", fake)
    args = ["calibrate", "compare", "A.csv", "--validate", "D.csv", "E.csv", "F.csv"]
    assert main([*args, "--workers", "1"]) == 1
    assert "stop here" in capsys.readouterr().err
    assert seen == {"fit": ["A.csv"], "held": ["D.csv", "E.csv", "F.csv"]}

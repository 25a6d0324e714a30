"""`odolab sim run --encoder-dir`: whatever the campaign, every log lands inside the folder."""

from __future__ import annotations

from pathlib import Path

import pytest

from odolab.cli import main

PROTOCOL = """
[protocol]
campaign = {campaign!r}

[[trials]]
motion = "rotation"
angle_pi = [1, 2]
"""


def _run(tmp_path: Path, campaign: str) -> tuple[int, Path]:
    work = tmp_path / "work"
    enc = work / "logs"
    proto = work / "p.toml"
    work.mkdir()
    proto.write_text(PROTOCOL.format(campaign=campaign), encoding="utf-8")
    rc = main(["sim", "run", str(proto), "-o", str(work / "t.csv"), "--encoder-dir", str(enc)])
    return rc, enc


@pytest.mark.parametrize(
    "campaign",
    [
        "../../x",
        "../../../../../../../../tmp/odolab-escape",
        "/TMP/outside/abs",
        "a/b",
        "C:\\x",
        "<s>",
        "..",
        "\x1b[2J",
    ],
)
def test_a_hostile_campaign_cannot_write_outside_the_encoder_dir(
    tmp_path: Path, campaign: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # "/tmp/" and "/TMP/" stand for this test's folder: an escape would land beside "work"
    rc, enc = _run(
        tmp_path, campaign.replace("/tmp/", f"{tmp_path}/").replace("/TMP", f"{tmp_path}")
    )
    assert rc == 0, capsys.readouterr().err
    everything = {p for p in tmp_path.rglob("*") if p.is_file()}
    logs = sorted(p for p in everything if p.suffix == ".csv" and p.name != "t.csv")
    assert len(logs) == 2 and all(p.parent == enc for p in logs)
    assert everything == {*logs, tmp_path / "work" / "t.csv", tmp_path / "work" / "p.toml"}


def test_a_hostile_protocol_name_is_printed_as_text(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    proto = tmp_path / "p.toml"
    body = PROTOCOL.format(campaign="c")
    proto.write_text(body.replace("[protocol]\n", '[protocol]\nname = "[/]\\u001b[2J<b>"\n'))
    assert main(["sim", "run", str(proto), "-o", str(tmp_path / "t.csv")]) == 0
    out = capsys.readouterr().out
    assert "2 trials of [/]\\x1b[2J<b> (jaguar-lab" in out

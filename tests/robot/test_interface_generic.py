"""The robot interface knows no link (issue 27): readings in wheel terms, per-link records typed
by the link, links built through the registry, and registry and links not importing each other."""

from __future__ import annotations

import ast
import dataclasses
from pathlib import Path

import pytest

from odolab.robot import interface
from odolab.robot.errors import RobotUrlError
from odolab.robot.registry import LINKS, check_robot_url

SRC = Path(interface.__file__).resolve().parent


def _imports(path: Path) -> set[str]:
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


def test_the_interface_has_no_link_field() -> None:
    reading = {f.name for f in dataclasses.fields(interface.EncoderReading)}
    assert reading == {"t", "left_ticks", "right_ticks", "link"}
    stats = {f.name for f in dataclasses.fields(interface.DriverStats)}
    assert not stats & {"pings_answered", "acks_received", "datagrams"}
    text = (SRC / "interface.py").read_text(encoding="utf-8")
    for word in ("left_rate", "direction", "Datagram", "PING", "ACK"):
        assert word not in text, word


def test_the_session_builds_links_only_through_the_registry() -> None:
    assert not any("jaguar" in m for m in _imports(SRC / "session.py"))
    assert not any("jaguar" in m for m in _imports(SRC / "loop.py"))


def test_links_never_import_the_registry() -> None:
    for package in ("jaguar", "jaguar2014"):
        folder = SRC / package
        if not folder.exists():
            continue
        for path in folder.glob("*.py"):
            assert "odolab.robot.registry" not in _imports(path), path


def test_an_unknown_scheme_is_refused_naming_every_scheme() -> None:
    with pytest.raises(RobotUrlError) as err:
        check_robot_url("http://127.0.0.1:1")
    for scheme in LINKS:
        assert f"{scheme}://" in str(err.value)

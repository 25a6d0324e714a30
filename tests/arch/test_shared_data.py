"""Missing real data fails CI instead of skipping every real-data test (shared_data.require)."""

from __future__ import annotations

from pathlib import Path

import pytest

import shared_data


def test_require_skips_on_a_developer_machine(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("CI", raising=False)
    monkeypatch.delenv("ODOLAB_REQUIRE_TEST_DATA", raising=False)
    monkeypatch.setenv("ODOLAB_TEST_DATA", str(tmp_path / "nowhere"))
    with pytest.raises(pytest.skip.Exception, match="nowhere"):
        shared_data.require("optiodom")


@pytest.mark.parametrize(("var", "value"), [("CI", "true"), ("ODOLAB_REQUIRE_TEST_DATA", "1")])
def test_require_fails_when_data_is_required(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, var: str, value: str
) -> None:
    monkeypatch.delenv("CI", raising=False)
    monkeypatch.delenv("ODOLAB_REQUIRE_TEST_DATA", raising=False)
    monkeypatch.setenv(var, value)
    monkeypatch.setenv("ODOLAB_TEST_DATA", str(tmp_path / "nowhere"))
    with pytest.raises(pytest.fail.Exception, match="ODOLAB_TEST_DATA"):
        shared_data.require("evo-testdata")


def test_the_setting_names_the_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "optiodom").mkdir()
    monkeypatch.setenv("ODOLAB_TEST_DATA", str(tmp_path))
    assert shared_data.require("optiodom") == tmp_path / "optiodom"

"""A notebook JSON file from a newer odolab is refused for its schema (it was refused as
"missing key 'params_versions'", a web review found)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from odolab.core.errors import StoreError
from odolab.store.jsonio import read_notebook_json


@pytest.mark.parametrize("schema", [99, "3", 0, True])
def test_an_unknown_schema_is_named(tmp_path: Path, schema: object) -> None:
    p = tmp_path / "nb.json"
    p.write_text(json.dumps({"format": "odolab-notebook", "schema": schema}), encoding="utf-8")
    with pytest.raises(StoreError, match=rf"schema is {schema!r}; expected 1 to 3"):
        read_notebook_json(p)


def test_a_file_without_its_lists_still_says_which_key(tmp_path: Path) -> None:
    p = tmp_path / "nb.json"
    p.write_text(json.dumps({"format": "odolab-notebook", "schema": 3}), encoding="utf-8")
    with pytest.raises(StoreError, match="missing key 'params_versions'"):
        read_notebook_json(p)

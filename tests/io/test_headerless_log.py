"""A log without a header line is refused naming the file, line 1 and the header expected
(issue 30: it was "column '0' appears twice")."""

from __future__ import annotations

from pathlib import Path

import pytest
from tests.worded import raises_worded

from odolab.core.errors import LogFormatError
from odolab.io import read_encoder_csv
from odolab.io.chunked import iter_encoder_chunks

EXPECTED = "expected the header line t,left_ticks,right_ticks (raw counters) or t,dticks_left"


def test_headerless_increments_name_the_header(tmp_path: Path) -> None:
    log = tmp_path / "run-01_odo.csv"
    log.write_text("\ufeff2858.85,0,0\n2858.9,0,0\n2858.95,0,22\n", encoding="utf-8")
    with pytest.raises(LogFormatError) as err:
        read_encoder_csv(log)
    msg = str(err.value)
    assert msg.startswith(f"{log}: line 1 (2858.85,0,0) is data, not a header;")
    assert EXPECTED in msg and "appears twice" not in msg
    with pytest.raises(LogFormatError, match="is data, not a header"):
        list(iter_encoder_chunks(log, chunk_rows=2))


def test_optiodom_run_points_to_its_format(tmp_path: Path) -> None:
    log = tmp_path / "231220200121_run-01.csv"
    log.write_text("0,0,0,0,0,0\n0.05,0.002,0.0004,0.017,0,0\n")
    with raises_worded(LogFormatError, match=r"\(an OptiOdom run: give --format optiodom\)$"):
        read_encoder_csv(log)


def test_a_header_is_still_read(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    log.write_text("t,dticks_left,dticks_right\n0,0,0\n0.05,3,4\n")
    assert read_encoder_csv(log).right_ticks.tolist() == [0, 4]

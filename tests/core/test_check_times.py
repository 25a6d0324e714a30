"""check_times names file lines only when it refuses: the line numbers of a file with comments
come from a scan of its lines (0.3 s for a 100,000-pose TUM file, which `odolab evaluate` paid
twice a file on clean input for a while)."""

from __future__ import annotations

import numpy as np
import pytest

from odolab.core.errors import LogFormatError
from odolab.core.trajectory import check_times


def _no_scan(i: int) -> int:
    raise AssertionError(f"line {i} looked up for a clean input")


def test_clean_times_look_up_no_line() -> None:
    check_times(np.arange(100_000) * 0.01, "clean.tum", line_of=_no_scan)


def test_times_that_never_advance_name_their_lines() -> None:
    with pytest.raises(LogFormatError, match=r"at every line from 7 to 9; expected times"):
        check_times(np.full(3, 2.0), "still.tum", line_of=lambda i: i + 7)

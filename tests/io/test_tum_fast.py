"""TUM text through the fast reader: every layout the careful reader took gives the same values,
and every bad cell the same message naming its line and column."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from odolab.core.errors import LogFormatError
from odolab.io._table import _careful_whitespace, _fast_headerless
from odolab.io.trajectory_csv import TUM_COLUMNS, read_tum

POSES = "1 0.5 2 0 0 0 0 1\n2 1.5 3 0 0 0 0.0998334166 0.9950041653\n"

READ = {
    "single spaces": POSES,
    "tabs and runs of spaces": "1\t0.5  2 0 0 0 0 1\n  2 1.5 3 0 0 0 0.0998334166 0.9950041653  \n",
    "comments": "# t tx ty tz qx qy qz qw\n1 0.5 2 0 0 0 0 1 # start\n"
    "2 1.5 3 0 0 0 0.0998334166 0.9950041653\n",
    "CRLF": POSES.replace("\n", "\r\n"),
    "bare CR": POSES.replace("\n", "\r"),
    "BOM": "\ufeff" + POSES,
    "blank lines": "\n \n" + POSES.replace("\n", "\n\t\n", 1),
    "a ninth column": POSES.replace("\n", " 7\n"),
    "signs and exponents": "+1 5e-1 2. 0 0 0 0 1\n2 1.5 3 0 0 0 0.0998334166 0.9950041653\n",
    "underscores": "1 0.5 2 0 0 0 0 1\n2 1_5e-1_0 3 0 0 0 0.0998334166 0.9950041653\n",
}


@pytest.mark.parametrize("name", sorted(READ))
def test_layouts_read_the_same(tmp_path: Path, name: str) -> None:
    p = tmp_path / "a.tum"
    p.write_bytes(READ[name].encode())
    traj = read_tum(p)
    np.testing.assert_array_equal(traj.t, [1.0, 2.0])
    want_x = 1.5 if name != "underscores" else 1.5e-9
    np.testing.assert_array_equal(traj.x, [0.5, want_x])
    np.testing.assert_allclose(traj.theta, [0.0, 0.2], atol=1e-9)


BAD = {
    "a word": ("1 0 0 0 0 0 0 1\n2 x 0 0 0 0 0 1\n", "line 2, column 'tx' is 'x'"),
    "commas": ("1,0,0,0,0,0,0,1\n", "line 1, column 't' is '1,0,0,0,0,0,0,1'"),
    "a short line": ("1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0\n", "line 2, column 'qw' is empty"),
    "nan": ("# c\n1 nan 0 0 0 0 0 1\n", "line 2, column 'tx' is 'nan'"),
    "hex": ("1 0x10 0 0 0 0 0 1\n", "line 1, column 'tx' is '0x10'"),
    "quotes": ('"1" 0 0 0 0 0 0 1\n', "line 1, column 't' is '\"1\"'"),
    "400 digits": ("1 0 0 " + "9" * 400 + " 0 0 0 1\n", "line 1, column 'tz' is '999"),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_cells_name_their_line(tmp_path: Path, name: str) -> None:
    text, message = BAD[name]
    p = tmp_path / "a.tum"
    p.write_text(text)
    with pytest.raises(LogFormatError, match=f"{p}: " + message.replace("(", r"\(")):
        read_tum(p)


def test_the_fast_path_reads_what_the_careful_one_reads(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    rows = rng.normal(0.0, 100.0, (500, 8))
    p = tmp_path / "a.tum"
    p.write_text("".join(" ".join(repr(float(v)) for v in r) + "\n" for r in rows))
    names = list(TUM_COLUMNS)
    fast = _fast_headerless(p, names, names, r"\s+")
    careful = _careful_whitespace(p, names, names, False, has_header=False)
    assert fast is not None
    for c in names:
        np.testing.assert_array_equal(fast[c], careful[c])
        np.testing.assert_array_equal(fast[c], rows[:, names.index(c)])

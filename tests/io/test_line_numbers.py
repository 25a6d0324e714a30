"""Error messages name the file's physical line, even with blank and comment lines around."""

from __future__ import annotations

from pathlib import Path

import pytest

from odolab.core.errors import LogFormatError
from odolab.io.encoder_csv import read_encoder_csv
from odolab.io.trajectory_csv import read_trajectory_csv, read_tum


def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_nan_after_blank_lines_names_its_line(tmp_path: Path) -> None:
    # line 1 header, 2 data, 3 and 4 blank, 5 data, 6 the bad cell
    p = _write(tmp_path, "log.csv", "t,left_ticks,right_ticks\n0,0,0\n\n\n0.05,1,1\n0.1,nan,2\n")
    with pytest.raises(LogFormatError, match=r"line 6, column 'left_ticks' is 'nan'"):
        read_encoder_csv(p)


def test_text_cell_after_blank_line(tmp_path: Path) -> None:
    p = _write(tmp_path, "log.csv", "t,left_ticks,right_ticks\n\n0,0,0\n0.1,x,2\n")
    with pytest.raises(LogFormatError, match=r"line 4, column 'left_ticks' is 'x'"):
        read_encoder_csv(p)


def test_fractional_ticks_name_the_line_not_an_index(tmp_path: Path) -> None:
    p = _write(tmp_path, "log.csv", "t,left_ticks,right_ticks\n0,0,0\n\n0.05,10.5,12\n")
    with pytest.raises(LogFormatError, match=r"line 4, column 'left_ticks' is 10.5") as err:
        read_encoder_csv(p)
    assert "index" not in str(err.value)


def test_counter_out_of_range_after_blank_line(tmp_path: Path) -> None:
    p = _write(tmp_path, "log.csv", "t,left_ticks,right_ticks\n\n0,0,0\n0.05,40000,1\n")
    with pytest.raises(LogFormatError, match=r"line 4, column 'left_ticks' is 40000"):
        read_encoder_csv(p, modulus=32768)


def test_time_backwards_after_blank_line(tmp_path: Path) -> None:
    p = _write(tmp_path, "log.csv", "t,left_ticks,right_ticks\n0,0,0\n\n0.05,1,1\n0.04,2,2\n")
    with pytest.raises(LogFormatError, match=r"backwards at line 5"):
        read_encoder_csv(p)
    q = _write(tmp_path, "traj.csv", "t,x,y,theta\n0,0,0,0\n\n1,0,0,0\n0.5,0,0,0\n")
    with pytest.raises(LogFormatError, match=r"backwards at line 5"):
        read_trajectory_csv(q)


def test_tum_with_comment_header_names_its_line(tmp_path: Path) -> None:
    p = _write(
        tmp_path, "a.tum", "# timestamp tx ty tz qx qy qz qw\n1 0 0 0 0 0 0 1\n0.5 0 0 0 0 0 0 1\n"
    )
    with pytest.raises(LogFormatError, match=r"backwards at line 3"):
        read_tum(p)


@pytest.mark.parametrize("reader", [read_encoder_csv, read_trajectory_csv, read_tum])
def test_a_folder_is_refused_in_one_sentence(tmp_path: Path, reader: object) -> None:
    with pytest.raises(LogFormatError, match="not a file"):
        reader(tmp_path)  # type: ignore[operator]


def test_writing_to_a_folder_is_one_sentence(tmp_path: Path) -> None:
    import numpy as np

    from odolab.core.errors import ParamsError
    from odolab.core.params import PRESETS, save_params
    from odolab.core.trajectory import Trajectory
    from odolab.io.trajectory_csv import write_trajectory_csv, write_tum

    traj = Trajectory.from_xyh(np.array([0.0, 1.0]), np.zeros(2), np.zeros(2), np.zeros(2))
    with pytest.raises(
        LogFormatError, match="is a folder; expected a file name for the trajectory CSV"
    ):
        write_trajectory_csv(tmp_path, traj)
    with pytest.raises(LogFormatError, match="is a folder; expected a file name for the TUM traj"):
        write_tum(tmp_path, traj)
    with pytest.raises(ParamsError, match="is a folder; expected a file name for the parameters"):
        save_params(tmp_path, PRESETS["jaguar-lite"])


def test_a_line_of_empty_cells_is_a_row_not_a_blank_line(tmp_path: Path) -> None:
    p = _write(tmp_path, "log.csv", "t,left_ticks,right_ticks\n0,0,0\n\n,,\n0.1,2,2\n")
    with pytest.raises(LogFormatError, match=r"line 4, column 't' is empty"):
        read_encoder_csv(p)
    q = _write(tmp_path, "t.csv", "t,x,y,theta\n0,0,0,0\n,,,\n\n1,0,0,0\n0.5,0,0,0\n")
    with pytest.raises(LogFormatError, match=r"line 3, column 't' is empty"):
        read_trajectory_csv(q)


def test_a_header_after_blank_lines_is_the_header(tmp_path: Path) -> None:
    """The header is the first non-blank line (as pandas read it); lines keep their numbers."""
    from odolab.io._table import data_line_numbers, read_numeric_columns
    from odolab.io.tabular import read_columns
    from odolab.tracking.camera import read_floor_csv

    floor = _write(tmp_path, "floor.csv", "\n\nid,x,y,yaw,size\n1,0,0,0,0.1\n\n2,1,0,0,0.1\n")
    assert [m.id for m in read_floor_csv(floor)] == [1, 2]
    assert data_line_numbers(floor).tolist() == [4, 6]
    got = read_numeric_columns(floor, ("id", "size"))
    assert got["id"].tolist() == [1.0, 2.0]
    # a quoted cell: polars refuses the file, the careful reader reads it
    quoted = _write(tmp_path, "q.csv", '\n t,x\n0,"1.5"\n\n1,2\n')
    assert read_columns(quoted, ("t", "x"))["x"].tolist() == [1.5, 2.0]
    bad = _write(tmp_path, "bad.csv", "\nt,x\n0,1\n\n1,oops\n")
    with pytest.raises(LogFormatError, match=r"bad.csv: line 5, column 'x' is 'oops'"):
        read_columns(bad, ("t", "x"))
    with pytest.raises(LogFormatError, match=r"bad.csv: line 5, column 'x' is 'oops'"):
        read_numeric_columns(bad, ("t", "x"))
    spaced = _write(tmp_path, "s.txt", "\n\nt x\n0 1\n1 2 # a comment\n")
    assert read_numeric_columns(spaced, ("t", "x"), sep=r"\s+")["x"].tolist() == [1.0, 2.0]

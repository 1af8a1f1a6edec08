"""Weld lists read as spreadsheets write them (byte-order mark, ';' or ',', CRLF), everything else refused naming
the row and column, and every expansion bounded before it is made."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import station_with_weld_csv

from dresspack_gym import ConfigError

HEADER = ["name", "x", "y", "z", "approach_x", "approach_y", "approach_z", "spin_min_deg", "spin_max_deg"]
ROWS = [["stud_a", "1085", "0", "1100", "1", "0", "0", "", ""],
        ["stud_b", "1150.5", "-600", "675", "0.3", "0", "-1", "0", "90"]]




def _text(rows, sep=",", end="\n", header=HEADER) -> str:
    return "".join(sep.join(r) + end for r in [header, *rows])


def test_what_spreadsheets_write_reads_as_the_plain_file(tmp_path):
    plain = station_with_weld_csv(tmp_path, _text(ROWS).encode()).weld_points
    european = [[c.replace(".", ",") for c in r] for r in ROWS]  # decimal commas where ';' separates
    for data in (b"\xef\xbb\xbf" + _text(ROWS).encode(),  # "CSV UTF-8": a byte-order mark first
                 _text(ROWS, end="\r\n").encode(),  # CRLF
                 b"\xef\xbb\xbf" + _text(european, sep=";", end="\r\n").encode(),
                 _text(ROWS + [[""] * 9, [""] * 9]).encode()):  # trailing empty rows of a spreadsheet
        got = station_with_weld_csv(tmp_path, data).weld_points
        assert [w.name for w in got] == [w.name for w in plain]
        for a, b in zip(got, plain):
            np.testing.assert_allclose(a.pos, b.pos, atol=1e-12)
            np.testing.assert_allclose(a.spin, b.spin, atol=1e-12)
    assert plain[1].pos[0] == pytest.approx(1.1505)


@pytest.mark.parametrize("data,field,match", [
    ("stud_a,1085,0,1100,1,0,0,,\nstud_\xe9,1,1,1,0,0,-1,,\n".encode("latin-1"),
     "weld_points_csv[welds.csv:row 3]", "byte 0xe9 in cell 1 is not UTF-8"),
    (b"", "weld_points_csv", "no weld rows"),  # header only
    (b"stud_a,1085,0,1100,1,0,0,,,7\n", "weld_points_csv[welds.csv:row 2]", "has 10 cells, the header 9"),
    (b"stud_a,1085,0,1100\n", "weld_points_csv[welds.csv:row 2]", "has 4 cells, the header 9"),
    (b",1085,0,1100,1,0,0,,\n", "weld_points_csv[welds.csv:row 2].name", "is empty"),
    (b"stud_a,nan,0,1100,1,0,0,,\n", "weld_points_csv[welds.csv:row 2].x", "not a finite number"),
    (b"stud_a,1085,0,1100,1,0,0,0,1e9\n", "weld_points_csv[welds.csv:row 2].spin_max_deg", "outside [-360, 360]"),
])
def test_bad_csv_is_refused_naming_row_and_column(tmp_path, data, field, match):
    """Each file is the header row followed by ``data``."""
    data = _text([]).encode() + data
    with pytest.raises(ConfigError) as err:
        station_with_weld_csv(tmp_path, data)
    assert err.value.field == field and match in str(err.value), str(err.value)


def test_a_spin_range_is_bounded_before_it_is_made(tmp_path):
    """0..360 deg in steps of 1e-3 deg would be 360 001 spins, each solved for every IK branch: refused from its
    count; 0..1e9 deg (7.28 TiB of spins in steps of 1e-3) from its range."""
    with pytest.raises(ConfigError) as err:
        station_with_weld_csv(tmp_path, _text([["a", "1085", "0", "1100", "1", "0", "0", "0", "360", "0.001"]],
                                 header=HEADER + ["spin_step_deg"]).encode())
    assert err.value.field == "weld_points_csv[welds.csv:row 2].spin_step_deg"
    assert "360001 candidate spins, more than 721" in str(err.value)
    with pytest.raises(ConfigError, match="outside"):
        station_with_weld_csv(tmp_path, _text([["a", "1085", "0", "1100", "1", "0", "0", "0", "1e9", "0.001"]],
                                 header=HEADER + ["spin_step_deg"]).encode())
    assert station_with_weld_csv(tmp_path, _text([["a", "1085", "0", "1100", "1", "0", "0", "-360", "360", "1"]],
                                    header=HEADER + ["spin_step_deg"]).encode()).weld_points[0].spin[-1] == \
        pytest.approx(np.radians(360))

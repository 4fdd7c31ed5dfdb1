"""Samples that contradict the sensor or the manifest are refused with file, line and column, never
solved: counts beyond the sensor's range, non-integer gyroscope counts, a step's rows duplicated or
lost, absurd temperatures."""

from __future__ import annotations

import shutil

import pytest

from rig.errors import SessionFormatError
from rig.session import load_session
from rig.workflow.run import run_procedure

from conftest import REPO


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    out = tmp_path_factory.mktemp("rec")
    return run_procedure(str(REPO / "procedures" / "six_position.yaml"), out_dir=out, seed=5,
                         time_scale=0).session_dir


def _copy(recorded, tmp_path, edit):
    d = tmp_path / "s"
    shutil.copytree(recorded, d)
    lines = (d / "samples.csv").read_text().splitlines(keepends=True)
    (d / "samples.csv").write_text("".join(edit(lines)))
    return d


def _cell(lines, row, column, value):
    header = lines[0].strip().split(",")
    cells = lines[row].rstrip("\n").split(",")
    cells[header.index(column)] = value
    lines[row] = ",".join(cells) + "\n"
    return lines


@pytest.mark.parametrize("column, value, expected", [
    ("ax", "40000000", "beyond the 4 g range"),
    ("ay", "32768", "beyond the 4 g range"),
    ("wz", "nan", "empty or NaN gyro count"),
    ("az", "1e19", "raw counts beyond"),
    ("wx", "1.5", "raw counts must be integers"),
    ("temp_c", "1e300", "expected a temperature in C"),
])
def test_absurd_cells_are_refused_with_their_line(recorded, tmp_path, column, value, expected):
    d = _copy(recorded, tmp_path, lambda lines: _cell(lines, 5, column, value))
    with pytest.raises(SessionFormatError, match=expected) as err:
        load_session(d)
    assert err.value.line == 6 or "range" in str(err.value)


def test_a_step_recorded_twice_is_refused(recorded, tmp_path):
    def duplicate_step_2(lines):
        rows = [ln for ln in lines[1:] if ln.split(",")[1] == "1"]
        return lines + rows
    with pytest.raises(SessionFormatError, match=r"step 2 \(index 1 in samples.csv\): 2000 rows, but the manifest recorded 1000"):
        load_session(_copy(recorded, tmp_path, duplicate_step_2))


def test_a_step_whose_rows_are_gone_is_refused(recorded, tmp_path):
    with pytest.raises(SessionFormatError, match=r"step 6 \(index 5 in samples.csv\): 0 rows"):
        load_session(_copy(recorded, tmp_path, lambda lines: [ln for ln in lines if ln.split(",")[1] != "5"]))


def test_the_untouched_session_loads(recorded):
    assert len(load_session(recorded).samples["t_s"]) == 6000

"""samples.csv written by other tools: CRLF, a byte-order mark, quoted fields, columns in another order
with extra columns all solve to the identical calibration; bad rows are refused with file and line."""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest

from conftest import PROCEDURES, unseal
from rig.analysis.solve import calibrate_session
from rig.errors import SessionFormatError
from rig.session import load_session

try:  # where the run lifecycle lives moves with the architecture change
    from rig.workflow.run import run_procedure
except ImportError:
    from rig.execution.lifecycle import run_procedure


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    out = tmp_path_factory.mktemp("rec")
    result = run_procedure(str(PROCEDURES / "six_position.yaml"), time_scale=0, seed=3, out_dir=out)
    assert (result.session_dir / "calibration.yaml").is_file()
    return result.session_dir


def _copy(recorded, tmp_path):
    d = tmp_path / recorded.name
    shutil.copytree(recorded, d)
    (d / "calibration.yaml").unlink()
    return unseal(d)  # another tool's dialect of the recording: a session without a seal


def _reordered(text: str) -> str:
    rows = [r.split(",") for r in text.splitlines()]
    order = list(reversed(range(len(rows[0]))))
    out = [[r[i] for i in order] + [note] for r, note in zip(rows, ["note"] + ['"pose, as placed"'] * len(rows))]
    return "\n".join(",".join(r) for r in out) + "\n"


def _quoted(text: str) -> str:
    return "\n".join(",".join(f'"{c}"' for c in r.split(",")) for r in text.splitlines()) + "\n"


DIALECTS = {
    "crlf": lambda t: t.replace("\n", "\r\n"),
    "bom": lambda t: "\ufeff" + t,
    "bom_crlf": lambda t: "\ufeff" + t.replace("\n", "\r\n"),
    "reordered_with_extra_column": _reordered,
    "quoted": _quoted,
    "blank_lines": lambda t: t.replace("\n", "\n\n", 3),
}


def _same(a, b, where=""):
    if dataclasses.is_dataclass(a):
        assert type(a) is type(b), where
        for f in dataclasses.fields(a):
            _same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for k in a:
            _same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{where}[{i}]")
    elif isinstance(a, np.ndarray):
        assert np.array_equal(a, b, equal_nan=True), where
    elif isinstance(a, float) and np.isnan(a):
        assert isinstance(b, float) and np.isnan(b), where
    else:
        assert a == b, where


@pytest.mark.parametrize("dialect", sorted(DIALECTS))
def test_other_dialects_of_samples_csv_solve_to_the_identical_calibration(recorded, tmp_path, dialect):
    plain = load_session(recorded)
    reference = calibrate_session(recorded)
    d = _copy(recorded, tmp_path)
    path = d / "samples.csv"
    path.write_bytes(DIALECTS[dialect](path.read_text()).encode())
    s = load_session(d)
    assert not s.warnings
    for key, value in plain.samples.items():
        assert value.dtype == s.samples[key].dtype and np.array_equal(value, s.samples[key], equal_nan=True), key
    cal = calibrate_session(d)
    _same(cal.accelerometer, reference.accelerometer, "accelerometer")
    _same(cal.gyroscope, reference.gyroscope, "gyroscope")
    _same(cal.magnetometer, reference.magnetometer, "magnetometer")
    assert cal.sensor == reference.sensor and cal.session == reference.session


def test_a_torn_last_line_of_a_crlf_file_is_dropped_and_said(recorded, tmp_path):
    d = _copy(recorded, tmp_path)
    path = d / "samples.csv"
    text = path.read_text().replace("\n", "\r\n")
    path.write_bytes((text + "12.5,5,1,2").encode())
    s = load_session(d)
    n_lines = text.count("\n")
    assert len(s.samples["t_s"]) == n_lines - 1 and f"samples.csv:{n_lines + 1}: dropped a torn last line" in s.warnings[0]


def _replace_cell(path, line: int, column: str, value: str, crlf: bool = False) -> None:
    rows = path.read_text().splitlines()
    j = rows[0].split(",").index(column)
    cells = rows[line - 1].split(",")
    cells[j] = value
    rows[line - 1] = ",".join(cells)
    path.write_bytes(("\r\n" if crlf else "\n").join(rows).encode() + (b"\r\n" if crlf else b"\n"))


@pytest.mark.parametrize("column,value,expect", [
    ("step", "1.5", "step: step indices must be integers, got 1.5"),
    ("step", "0.9", "step: step indices must be integers, got 0.9"),
    ("step", "", "step: expected a number, got an empty field or NaN"),
    ("t_s", "nan", "t_s: expected a number, got an empty field or NaN"),
    ("ax", "12.25", "ax: raw counts must be integers"),
    ("az", "", "az: expected a number, got an empty field or NaN"),
    ("ay", "x1", "ay: expected a number, got 'x1'"),
    ("step", "9", "step: index 9 is no step of the manifest (its 6 steps are indices 0..5: step 1 is index 0)"),
])
@pytest.mark.parametrize("crlf", [False, True])
def test_bad_cells_are_refused_with_file_line_and_column(recorded, tmp_path, column, value, expect, crlf):
    d = _copy(recorded, tmp_path)
    _replace_cell(d / "samples.csv", 1234, column, value, crlf)
    with pytest.raises(SessionFormatError) as e:
        load_session(d)
    assert str(e.value) == f"{d / 'samples.csv'}:1234: {expect}"


def test_a_ragged_row_is_refused_with_its_line_even_when_quoted(recorded, tmp_path):
    d = _copy(recorded, tmp_path)
    path = d / "samples.csv"
    rows = path.read_text().splitlines()
    n = len(rows[0].split(","))
    rows[99] += ",7"
    path.write_text("\n".join(rows) + "\n")
    with pytest.raises(SessionFormatError, match=rf"samples.csv:100: expected {n} comma-separated fields"):
        load_session(d)
    path.write_text(_quoted("\n".join(rows)))
    with pytest.raises(SessionFormatError, match=rf"samples.csv:100: expected {n} comma-separated fields"):
        load_session(d)


@pytest.mark.parametrize("header,expect", [
    ("t_s,step,ax,ay,ax", "samples.csv:1: header has empty or repeated column names"),
    ("t_s,,ax,ay,az", "samples.csv:1: header has empty or repeated column names"),
    ("t_s,ax,ay,az,temp_c", "samples.csv:1: step: missing column"),
])
def test_a_bad_header_is_refused_on_line_1(recorded, tmp_path, header, expect):
    d = _copy(recorded, tmp_path)
    (d / "samples.csv").write_text(header + "\n1,2,3,4,5\n")
    with pytest.raises(SessionFormatError, match=expect):
        load_session(d)

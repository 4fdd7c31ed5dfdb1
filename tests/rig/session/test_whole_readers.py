"""The two C readers of the common samples.csv (numpy's, and pandas' where pandas is loaded already) give the
identical session: the same arrays to the bit, the same calibration, the same refusal for the same bad cell."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import PROCEDURES
from rig.analysis.solve import calibrate_session
from rig.errors import SessionFormatError
from rig.session import load_session, reader
from rig.session.reader import read_samples
from rig.workflow.run import run_procedure

pytest.importorskip("pandas", minversion="3")


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    out = tmp_path_factory.mktemp("rec")
    return run_procedure(str(PROCEDURES / "six_position.yaml"), time_scale=0, seed=11, out_dir=out).session_dir


def _with(monkeypatch, which: str):
    monkeypatch.setattr(reader, "WHOLE_READER", which)


def test_both_readers_load_the_recording_to_the_bit(recorded, monkeypatch):
    loaded = {}
    for which in ("numpy", "pandas"):
        _with(monkeypatch, which)
        loaded[which] = load_session(recorded).samples
    assert loaded["numpy"].keys() == loaded["pandas"].keys()
    for key, v in loaded["numpy"].items():
        assert v.dtype == loaded["pandas"][key].dtype, key
        assert np.array_equal(v, loaded["pandas"][key], equal_nan=True), key


def test_both_readers_give_the_same_calibration(recorded, monkeypatch):
    out = {}
    for which in ("numpy", "pandas"):
        _with(monkeypatch, which)
        out[which] = calibrate_session(recorded).accelerometer
    assert out["numpy"].model_dump() == out["pandas"].model_dump()


def test_a_process_with_pandas_3_loaded_uses_pandas_and_one_without_numpy(monkeypatch):
    import sys

    assert reader._whole_reader() == "pandas"  # the test process has pandas 3 loaded
    monkeypatch.delitem(sys.modules, "pandas")
    assert reader._whole_reader() == "numpy"


def _read_alike(path, monkeypatch) -> None:
    """Both readers read ``path`` to the same arrays, or refuse it with the same line."""
    out = {}
    for which in ("numpy", "pandas"):
        _with(monkeypatch, which)
        try:
            out[which] = read_samples(path, n_steps=1)[0]
        except SessionFormatError as exc:
            out[which] = str(exc)
    a, b = out["numpy"], out["pandas"]
    assert type(a) is type(b), (a, b)
    if isinstance(a, str):
        assert a == b
    else:
        for key in a:
            assert np.array_equal(a[key], b[key], equal_nan=True), key


#: cells a tool other than ours might write: each is read the same way by both readers, or refused the same way
ODD_CELLS = ["12", "-7", "+5", "1e3", "1E3", "12.0", " 12", "12 ", "1.", ".5", "nan", "NaN", "inf", "-inf",
             "1_0", "0x10", "1.5e", "", "TRUE", "1d3", "\u0661\u0662", "12\r", "1e400", "-0", "0012", "1,5"]


@pytest.mark.parametrize("cell", ODD_CELLS, ids=repr)
def test_an_odd_cell_reads_or_is_refused_alike(tmp_path, monkeypatch, cell):
    path = tmp_path / "samples.csv"
    path.write_bytes(("t_s,step,ax,ay,az,temp_c\n0.0,0,1,2,3,25.0\n"
                      f"0.01,0,{cell},2,3,25.0\n0.02,0,1,2,3,{cell}\n").encode())
    _read_alike(path, monkeypatch)


#: rows another tool might write: a short row, a long one, a line of spaces (refused: not blank), a blank line
#: (skipped), CRLF line ends, a short first row
ODD_ROWS = {"short": "0.01,0,1,2\n", "long": "0.01,0,1,2,3,25.0,9\n", "spaces": "   \n", "blank": "\n",
            "crlf": "0.01,0,1,2,3,25.0\r\n"}


@pytest.mark.parametrize("row", ODD_ROWS, ids=str)
@pytest.mark.parametrize("first", [True, False], ids=["first", "later"])
def test_an_odd_row_reads_or_is_refused_alike(tmp_path, monkeypatch, row, first):
    path = tmp_path / "samples.csv"
    rows = ["0.0,0,1,2,3,25.0\n", "0.02,0,1,2,3,25.0\n"]
    rows.insert(0 if first else 1, ODD_ROWS[row])
    path.write_bytes(("t_s,step,ax,ay,az,temp_c\n" + "".join(rows)).encode())
    _read_alike(path, monkeypatch)

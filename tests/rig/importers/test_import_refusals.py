"""An import that cannot be what it claims is refused with one line naming the file (and the line):
a step of one sample, values no accelerometer reads, data contradicting their pose label, ragged
rows, a field too large to read; a gyroscope file imported as accelerometer data is not solved."""

from __future__ import annotations

import pytest

from rig.cli import main

from conftest import DATASETS, NO_DATASETS

HEAD = "# units: g\nt_s,ax,ay,az,label\n"


@pytest.mark.parametrize("body, expected", [
    ("0.0,0,0,1,+Z up\n", "needs at least 10"),
    ("0.0,0,0,1,+Z up\n0.01,0,0,1,+Z up\n", "a static step needs at least 10"),
    ("0.0,0,0,1,+Z up\n0.01,0,0,1,+Z up\n0.02,0,0,1e300,+Z up\n", "beyond 64 g"),
    ("0.0,0,0,1,-Z up\n0.01,0,0,1,-Z up\n0.02,0,0,1,-Z up\n", "mislabelled"),
    ("0.0,0,0,1,+Z up,5\n0.01,0,0,1,+Z up\n", "expected 5 fields"),
    ("0.0,0,0,1," + "x" * 200_000 + "\n", "cannot read this line"),
])
def test_impossible_csv_imports_are_refused(tmp_path, capsys, body, expected):
    (tmp_path / "r.csv").write_text(HEAD + body)
    assert main(["import", "--from", "csv", str(tmp_path / "r.csv"), "-o", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(tmp_path / "r.csv") in err[0] and expected in err[0], err


def test_a_gyroscope_file_imported_as_accelerometer_data_is_not_solved(tmp_path, capsys):
    gyro = DATASETS / "imu_tk-xsens" / "xsens_gyro.txt"
    if not gyro.is_file():
        pytest.skip(NO_DATASETS)
    assert main(["import", "--from", "imu_tk", str(gyro), "-o", str(tmp_path), "--id", "g"]) == 0
    out = capsys.readouterr().out
    assert "rig solve" not in out  # the import suggests no solve that would not work
    assert main(["solve", str(tmp_path / "g"), "--method", "magnitude"]) == 2
    assert "not this accelerometer's data" in capsys.readouterr().err


def test_an_imu_tk_field_of_megabytes_is_one_line_not_a_memory_error(tmp_path, capsys):
    """The campaign's `import: imu_tk: 3 MB field`: the fast reader held every field at the widest one's width
    (35 GiB for 12,000 rows) and died of a MemoryError; such a block is read line by line and refused there."""
    rows = [f"{i * 0.01:.3f} {33000 + i % 7} 33000 37000" for i in range(12000)]
    rows[30] = "0.300 " + "7" * (3 * 1024 * 1024) + " 33000 37000"
    src = tmp_path / "big_field.txt"
    src.write_text("\n".join(rows) + "\n")
    assert main(["import", "--from", "imu_tk", str(src), "-o", str(tmp_path / "out")]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line == f"rig import: {src}:31: expected finite numbers (t x y z)"

"""``rig import --from csv`` takes every column a recording has (issue 32 item 1): accelerometer, gyroscope,
magnetometer and temperature in any subset, counts or physical units; the time from a column, ``--rate`` or
a preamble line (``Fs,100``); a column map for other names; a summary naming every input column and what
became of it; a file in g without its units line gets the hint ``# units: g``."""

from __future__ import annotations

import numpy as np
import pytest

from rig.cli import main
from rig.session import SessionManifest, load_session

RATE_HZ = 50.0


def _rows(n: int, seed: int = 0) -> dict[str, np.ndarray]:
    """Two rests of ``n`` samples each: +Z up then -Z up (g), a small rotation rate (deg/s), a field (uT)."""
    rng = np.random.default_rng(seed)
    acc = np.vstack([np.tile([0.01, -0.02, 1.0], (n, 1)), np.tile([0.01, -0.02, -1.0], (n, 1))])
    return {"acc": acc + rng.normal(0, 1e-3, acc.shape),
            "gyro": np.tile([0.5, -0.25, 0.125], (2 * n, 1)) + rng.normal(0, 0.05, acc.shape),
            "mag": np.tile([20.0, -5.0, 40.0], (2 * n, 1)) + rng.normal(0, 0.2, acc.shape)}


def _write(path, header: str, cols: list[str], n: int = 100, *, head: str = "", time: bool = True, scale=None,
           label: bool = True):
    """Columns ``cols`` of :func:`_rows` under ``header`` (``label``: a last column, ``+Z up`` then ``-Z up``)."""
    d = _rows(n)
    scale = scale or {}
    lines = [head + header + (",label" if label else "")]
    for i in range(2 * n):
        vals = ([f"{i / RATE_HZ:.4f}"] if time else [])
        for key in cols:
            vals += [f"{v * scale.get(key, 1.0):.6f}" for v in d[key][i]]
        lines.append(",".join(vals + (["+Z up" if i < n else "-Z up"] if label else [])))
    path.write_text("\n".join(lines) + "\n")
    return path


def _import(tmp_path, src, *extra) -> int:
    return main(["import", "--from", "csv", str(src), "-o", str(tmp_path / "s"), "--id", "r", *extra])


def test_gyroscope_and_magnetometer_columns_are_imported_in_their_units(tmp_path, capsys):
    src = _write(tmp_path / "r.csv", "t_s,ax,ay,az,gx,gy,gz,mx,my,mz", ["acc", "gyro", "mag"],
                 head="# units: g\n# gyro_units: rad/s\n# mag_units: gauss\n",
                 scale={"gyro": np.pi / 180.0, "mag": 0.01})
    assert _import(tmp_path, src) == 0
    s = load_session(tmp_path / "s" / "r")
    assert s.info.columns[:9] == ["t_s", "step", "ax", "ay", "az", "temp_c", "wx", "wy", "wz"]
    gyro_dps = s.samples["gyro_counts"] / s.info.rig.sensor.gyro_lsb_per_dps
    mag_ut = s.samples["mag_counts"] / s.info.rig.sensor.magnetometer.mag_lsb_per_ut
    np.testing.assert_allclose(gyro_dps.mean(axis=0), [0.5, -0.25, 0.125], atol=0.02)
    np.testing.assert_allclose(mag_ut.mean(axis=0), [20.0, -5.0, 40.0], atol=0.1)
    out = capsys.readouterr().out
    assert "columns gx,gy,gz: gyroscope, rad/s stored as 1000 counts per deg/s" in out
    assert "columns mx,my,mz: magnetometer, gauss stored as 100 counts per uT" in out


def test_a_magnetometer_only_file_imports_without_an_accelerometer(tmp_path, capsys):
    src = _write(tmp_path / "m.csv", "t_s,mx,my,mz", ["mag"], head="# mag_units: uT\n")
    assert _import(tmp_path, src) == 0
    info, _ = SessionManifest.load(tmp_path / "s" / "r")
    assert info.import_.units == "accelerometer none; gyroscope none; magnetometer uT"
    s = load_session(tmp_path / "s" / "r")
    assert not np.any(s.samples["accel_counts"])  # no accelerometer: stored as 0 counts, named in the units
    assert "mag_counts" in s.samples


def test_a_magnetometer_in_unknown_units_is_kept_as_counts(tmp_path, capsys):
    src = _write(tmp_path / "m.csv", "t_s,mx,my,mz", ["mag"], head="# mag_units: unknown\n")
    assert _import(tmp_path, src) == 0
    info, _ = SessionManifest.load(tmp_path / "s" / "r")
    assert info.rig.sensor.magnetometer.mag_lsb_per_ut == 1.0 and "unknown" in info.rig.sensor.magnetometer.model
    assert "units unknown: counts kept and reported as counts" in capsys.readouterr().out


@pytest.mark.parametrize("head, extra", [("Fs,50\n", []), ("# rate_hz: 50\n", []), ("", ["--rate", "50"])])
def test_without_a_time_column_the_rate_gives_the_times(tmp_path, capsys, head, extra):
    src = _write(tmp_path / "r.csv", "ax,ay,az", ["acc"], head="# units: g\n" + head, time=False)
    assert _import(tmp_path, src, *extra) == 0
    s = load_session(tmp_path / "s" / "r")
    assert s.info.rig.sensor.sample_rate_hz == 50.0
    np.testing.assert_allclose(s.samples["t_s"][:3], [0.0, 0.02, 0.04])
    assert "no time column: times from the rate 50 Hz" in capsys.readouterr().out


def test_no_time_and_no_rate_is_one_line_naming_the_ways_to_give_it(tmp_path, capsys):
    src = _write(tmp_path / "r.csv", "ax,ay,az", ["acc"], head="# units: g\n", time=False, label=False)
    assert _import(tmp_path, src) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "r.csv:2: no time" in err[0] and "--rate HZ" in err[0] and "Fs,100" in err[0]


def test_a_file_in_g_without_its_units_line_gets_the_hint(tmp_path, capsys):
    src = _write(tmp_path / "r.csv", "t_s,ax,ay,az", ["acc"])
    assert _import(tmp_path, src) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'# lsb_per_g: N'" in err[0] and "'# units: g'" in err[0], err


def test_a_column_map_renames_other_names_and_every_input_column_is_summarised(tmp_path, capsys):
    src = _write(tmp_path / "r.csv", "time,AccX,AccY,AccZ,GyrX,GyrY,GyrZ", ["acc", "gyro"],
                 head="# units: g\n# gyro_units: deg/s\n")
    text = src.read_text().replace("GyrZ,label\n", "GyrZ,label,note\n", 1)
    src.write_text("\n".join(r + ("" if i < 3 else ",x") for i, r in enumerate(text.splitlines())) + "\n")
    assert _import(tmp_path, src, "--columns", "t_s=time,ax=AccX,ay=AccY,az=AccZ,gx=GyrX,gy=GyrY,gz=GyrZ") == 0
    out = capsys.readouterr().out
    for line in ("column time: time, s", "columns AccX,AccY,AccZ: accelerometer", "columns GyrX,GyrY,GyrZ: gyroscope",
                 "column note: ignored (not a known column; map it with --columns NAME=note)"):
        assert line in out, out
    assert "wx" in load_session(tmp_path / "s" / "r").info.columns


@pytest.mark.parametrize("header, extra, expected", [
    ("t_s,ax,ay", [], "the accelerometer needs all of ax, ay, az; missing az"),
    ("t_s,foo,bar", [], "expected the columns of at least one sensor"),
    ("t_s,ax,ay,az", ["--columns", "ax=AccX"], "the column map names 'AccX' for ax"),
    ("t_s,ax,ay,az", ["--columns", "qq=ax"], "expected OURS=THEIRS pairs"),
])
def test_bad_columns_are_one_line(tmp_path, capsys, header, extra, expected):
    (tmp_path / "r.csv").write_text(f"# units: g\n{header}\n" + "0,0,0,1\n" * 20)
    assert _import(tmp_path, tmp_path / "r.csv", *extra) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and expected in err[0], err


def test_rate_and_columns_apply_to_the_generic_csv_only(tmp_path, capsys):
    (tmp_path / "x.txt").write_text("0 1 2 3\n")
    assert main(["import", "--from", "imu_tk", str(tmp_path / "x.txt"), "-o", str(tmp_path / "s"), "--rate", "9"]) == 2
    assert "--rate applies to --from csv only" in capsys.readouterr().err

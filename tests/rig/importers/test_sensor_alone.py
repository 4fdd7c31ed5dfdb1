"""Each sensor solvable alone (issue 32 item 2): a magnetometer-only or gyroscope-only recording solves the
sensors it has and names the absent accelerometer in one line, never "singular Jacobian"; the gyroscope's
zero-rate output comes with its sigma from the rest intervals."""

from __future__ import annotations

import json

import numpy as np

from rig.analysis.solve import calibrate_session
from rig.cli import main
from rig.session import load_session
from tumble_csv import tumble_poses

import pytest

RATE_HZ = 50.0
HARD_IRON_UT = np.array([12.0, -30.0, 7.5])
SOFT_IRON = np.array([[1.05, 0.02, -0.01], [0.0, 0.97, 0.03], [0.0, 0.0, 1.02]])
FIELD_UT = 48.0
GYRO_BIAS_DPS = np.array([0.31, -0.12, 0.05])


def _rests(path, header: str, values, *, head: str, n: int = 100, seed: int = 3):
    """One labelled rest of ``n`` samples per row of ``values()`` output, noise added by ``values``."""
    rng = np.random.default_rng(seed)
    lines = [head + header + ",label"]
    t = 0.0
    for k, rows in enumerate(values(rng, n)):
        for r in rows:
            lines.append(f"{t:.4f}," + ",".join(f"{v:.5f}" for v in r) + f",rest {k + 1}")
            t += 1.0 / RATE_HZ
    path.write_text("\n".join(lines) + "\n")
    return path


def _mag_rests(rng, n):
    for d in tumble_poses():
        h = FIELD_UT * d
        m = SOFT_IRON @ h + HARD_IRON_UT
        yield m + rng.normal(0, 0.3, (n, 3))


def _gyro_rests(rng, n):
    for _ in range(12):
        yield GYRO_BIAS_DPS + rng.normal(0, 0.05, (n, 3))


def test_a_magnetometer_only_recording_solves_the_magnetometer(tmp_path, capsys):
    src = _rests(tmp_path / "m.csv", "t_s,mx,my,mz", _mag_rests, head="# mag_units: uT\n")
    assert main(["import", "--from", "csv", str(src), "-o", str(tmp_path / "s"), "--id", "m"]) == 0
    assert f"next: rig solve {tmp_path / 's' / 'm'}" in capsys.readouterr().out
    assert main(["solve", str(tmp_path / "s" / "m"), "--json"]) == 0
    out, err = capsys.readouterr()
    doc = json.loads(out)
    assert doc["absent"] == ["accelerometer", "gyroscope"] and doc["calibration"] is None
    assert "the session has no accelerometer data" in err and "singular" not in err
    mag = doc["magnetometer"]
    # the field magnitude is unknown to the session (no site): the ellipsoid is |h| = 1, so A scales by |h|
    hard = np.array(mag["hard_iron_ut"])
    sig = np.array([mag["sigma"][f"hard_iron_{a}"] for a in "xyz"])
    assert np.all(np.abs(hard - HARD_IRON_UT) < 3 * sig), (hard, sig)


def test_a_gyroscope_only_recording_gives_the_zero_rate_output_with_its_sigma(tmp_path, capsys):
    src = _rests(tmp_path / "g.csv", "t_s,gx,gy,gz", _gyro_rests, head="# gyro_units: deg/s\n")
    assert main(["import", "--from", "csv", str(src), "-o", str(tmp_path / "s"), "--id", "g"]) == 0
    capsys.readouterr()
    assert main(["solve", str(tmp_path / "s" / "g"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    z = doc["gyroscope_zero_rate_dps"]
    assert z["n_steps"] == 12 and doc["absent"] == ["accelerometer", "magnetometer"]
    bias, sigma = np.array(z["bias"]), np.array(z["sigma"])
    assert np.all(sigma > 0) and np.all(sigma < 0.01) and np.all(np.abs(bias - GYRO_BIAS_DPS) < 3 * sigma)


def test_the_accelerometer_asked_of_a_session_without_one_is_named_in_one_line(tmp_path):
    src = _rests(tmp_path / "g.csv", "t_s,gx,gy,gz", _gyro_rests, head="# gyro_units: deg/s\n")
    main(["import", "--from", "csv", str(src), "-o", str(tmp_path / "s"), "--id", "g"])
    with pytest.raises(Exception, match="the session has no accelerometer data"):
        calibrate_session(tmp_path / "s" / "g")


def test_a_recording_with_an_accelerometer_prints_the_static_gyro_bias(tmp_path, capsys):
    rng = np.random.default_rng(5)
    lines = ["# units: g\n# gyro_units: deg/s\nt_s,ax,ay,az,gx,gy,gz,label"]
    t = 0.0
    for face, f in (("+X up", [1, 0, 0]), ("-X up", [-1, 0, 0]), ("+Y up", [0, 1, 0]), ("-Y up", [0, -1, 0]),
                    ("+Z up", [0, 0, 1]), ("-Z up", [0, 0, -1])):
        for _ in range(100):
            a = np.array(f, float) + rng.normal(0, 1e-3, 3)
            g = GYRO_BIAS_DPS + rng.normal(0, 0.05, 3)
            lines.append(f"{t:.3f}," + ",".join(f"{v:.6f}" for v in (*a, *g)) + f",{face}")
            t += 0.02
    (tmp_path / "r.csv").write_text("\n".join(lines) + "\n")
    assert main(["import", "--from", "csv", str(tmp_path / "r.csv"), "-o", str(tmp_path / "s"), "--id", "r"]) == 0
    capsys.readouterr()
    assert main(["solve", str(tmp_path / "s" / "r")]) == 0
    out = capsys.readouterr().out
    (line,) = [x for x in out.splitlines() if "gyroscope zero-rate output (6 rest intervals): x " in x]
    # in counts, as the gyro bias is everywhere else (issue 33 item 4): the session's sensitivity times deg/s
    lsb = load_session(tmp_path / "s" / "r").info.rig.sensor.gyro_lsb_per_dps
    x = float(line.split(" x ")[1].split()[0])
    assert line.split(" +- ")[-1].split()[1].rstrip(";") == "counts", line
    assert abs(x / lsb - GYRO_BIAS_DPS[0]) < 0.02, (line, lsb)

"""rig.importers: real recordings of other tools as rig-session/1 sessions, and bad inputs."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from rig.errors import RigInputError
from rig.importers import COUNTS_PER_G_EQUIVALENT, SOURCES, import_recording
from rig.session import load_session

IMUCAL = "imucal/annotated_session.csv"
IMU_TK = "imu_tk-xsens/xsens_acc.txt"
TOFU = "tofupilot-thermal/imu_raw_data.csv"


@pytest.fixture(scope="module")
def imported(datasets, tmp_path_factory):
    """Each real dataset imported once (module scope: the imports take about 2 s together)."""
    root = tmp_path_factory.mktemp("sessions")
    return {src: load_session(import_recording(src, datasets / f, root))
            for src, f in (("imucal", IMUCAL), ("imu_tk", IMU_TK), ("tofupilot", TOFU))}


def _common(s, source, datasets, rel):
    m = s.manifest
    assert m["status"] == "complete" and m["rig"]["kind"] == "import"
    assert m["id"] == f"import-{source}-{(datasets / rel).stem}"
    assert m["procedure"]["name"] == f"import-{source}"
    assert m["procedure"]["file"] == str(datasets / rel) and len(m["procedure"]["sha256"]) == 64
    assert m["import"]["source"] == source and m["import"]["g_ms2"] == pytest.approx(9.80665)
    assert all(st["status"] == "complete" and st["stats"]["n_samples"] > 1 for st in m["steps"])
    assert not s.warnings


def test_sources():
    assert SOURCES == ("imucal", "imu_tk", "tofupilot", "csv")


def test_imucal(imported, datasets):
    s = imported["imucal"]
    _common(s, "imucal", datasets, IMUCAL)
    m = s.manifest
    static = [st for st in m["steps"] if st["kind"] == "static"]
    rot = [st for st in m["steps"] if st["kind"] == "rotation"]
    want = {"x_p": [1, 0, 0], "x_a": [-1, 0, 0], "y_p": [0, 1, 0], "y_a": [0, -1, 0], "z_p": [0, 0, 1],
            "z_a": [0, 0, -1]}
    assert {st["name"]: st["f_nominal"] for st in static} == want
    assert sorted(st["name"] for st in rot) == ["x_rot", "y_rot", "z_rot"]
    assert all(st["f_nominal"] is None for st in rot)
    assert m["rig"]["sensor"]["sample_rate_hz"] == pytest.approx(204.8)
    assert m["rig"]["sensor"]["accel_lsb_per_g"] == 2048 and m["import"]["lsb_per_g"] == 2048
    assert m["import"]["units"] == "counts" and m["import"]["steps_from"] == "labels"
    # counts unchanged: the first row of the CSV is the first sample of its part
    with open(datasets / IMUCAL) as fh:
        row = next(csv.DictReader(fh))
    k = next(st["index"] for st in m["steps"] if st["name"] == row["part"])
    ss = s.step_samples(k)
    i = int(np.argmin(np.abs(ss["t_s"] - (float(row["samples"]) / 204.8 - s.samples["t_s"].min()))))
    assert ss["accel_counts"][i].tolist() == [int(float(row[c])) for c in ("acc_x", "acc_y", "acc_z")]
    assert ss["gyro_counts"][i].tolist() == [int(float(row[c])) for c in ("gyr_x", "gyr_y", "gyr_z")]
    assert len(s.samples["t_s"]) == 9414
    means = s.step_means()  # the six poses solve like our own
    assert len(means.names) == 6


def test_imu_tk(imported, datasets):
    s = imported["imu_tk"]
    _common(s, "imu_tk", datasets, IMU_TK)
    m = s.manifest
    steps = m["steps"]
    assert 25 <= len(steps) <= 45
    assert all(st["kind"] == "static" and st["f_nominal"] is None for st in steps)
    assert steps[0]["name"] == "static 1"
    assert m["rig"]["sensor"]["sample_rate_hz"] == pytest.approx(100.0, rel=1e-3)
    assert m["rig"]["sensor"]["accel_lsb_per_g"] == pytest.approx(415 * 9.80665)
    assert m["import"]["steps_from"] == "static detection"
    first = np.loadtxt(datasets / IMU_TK, max_rows=1)
    assert np.all(s.samples["accel_counts"] > 20000)  # raw unsigned counts kept, offset near 32768
    assert s.samples["accel_counts"].dtype.kind == "i" and first.shape == (4,)


def test_tofupilot(imported, datasets):
    s = imported["tofupilot"]
    _common(s, "tofupilot", datasets, TOFU)
    m = s.manifest
    assert m["rig"]["sensor"]["has_temperature"] is True
    assert m["rig"]["sensor"]["sample_rate_hz"] == pytest.approx(2.0, rel=0.05)
    assert m["import"]["timestamp_unit"] == "us" and m["import"]["units"] == "m/s^2"
    assert m["import"]["lsb_per_g"] == COUNTS_PER_G_EQUIVALENT == m["rig"]["sensor"]["accel_lsb_per_g"]
    temps = [st["stats"]["temp_c"] for st in m["steps"]]
    assert min(temps) < -15 and max(temps) > 70
    assert all(st["pose_group"] == 0 and st["f_nominal"] is None for st in m["steps"])
    dur = [st["stats"]["t_end_s"] - st["stats"]["t_start_s"] for st in m["steps"]]
    assert max(dur) < 180 and np.median(dur) == pytest.approx(119.5, abs=1.5)
    norm = np.linalg.norm(s.samples["accel_counts"], axis=1)
    assert np.median(norm) == pytest.approx(100000, rel=0.03)
    assert np.median(s.samples["accel_counts"][:, 2]) < -90000  # z down
    assert np.isfinite(s.samples["temp_c"]).all()


def test_g_is_used_and_recorded(datasets, tmp_path):
    s = load_session(import_recording("tofupilot", datasets / TOFU, tmp_path, "t-g", g_ms2=9.81))
    assert s.manifest["import"]["g_ms2"] == 9.81 and s.id == "t-g"


def _write(path, text):
    path.write_text(text)
    return path


def test_csv_round_trip_labels(tmp_path):
    rows = ["# units: counts", "# lsb_per_g: 16384", "t_s,ax,ay,az,temp_c,label"]
    rng = np.random.default_rng(0)
    want = []
    for k, (lab, f) in enumerate((("+Z up", (0, 0, 1)), ("-X up", (-1, 0, 0)), ("", (0, 1, 0)), ("pose A", (0, 1, 0)),
                                  ("x rot", (0, 0, 1)))):
        for i in range(50):
            a = (np.array(f) * 16384 + rng.integers(-20, 20, 3)).astype(int)
            rows.append(f"{(k * 50 + i) * 0.01:.2f},{a[0]},{a[1]},{a[2]},25.0,{lab}")
            if lab:
                want.append(a.tolist())
    src = _write(tmp_path / "small.csv", "\n".join(rows) + "\n")
    s = load_session(import_recording("csv", src, tmp_path / "out"))
    m = s.manifest
    assert m["id"] == "import-csv-small" and m["import"]["steps_from"] == "labels"
    assert [st["name"] for st in m["steps"]] == ["+Z up", "-X up", "pose A", "x rot"]
    assert [st["kind"] for st in m["steps"]] == ["static", "static", "static", "rotation"]
    assert m["steps"][0]["f_nominal"] == [0, 0, 1] and m["steps"][1]["f_nominal"] == [-1, 0, 0]
    assert m["steps"][2]["f_nominal"] is None and m["steps"][2]["pose_group"] == 0
    assert s.samples["accel_counts"].tolist() == want  # unlabelled rows are not imported
    assert m["rig"]["sensor"]["accel_lsb_per_g"] == 16384 and m["rig"]["sensor"]["sample_rate_hz"] == 100
    assert np.allclose(s.samples["temp_c"], 25.0)


def test_csv_physical_units_and_static_detection(tmp_path):
    rows = ["# units: m/s^2", "t_s,ax,ay,az"]
    rng = np.random.default_rng(1)
    t = 0.0
    for seg in range(3):
        f = np.array([[0, 0, 9.80665], [0, 9.80665, 0], [9.80665, 0, 0]][seg])
        for _ in range(4000 if seg == 0 else 1000):
            a = f + rng.normal(0, 0.002, 3)
            rows.append(f"{t:.3f},{a[0]:.5f},{a[1]:.5f},{a[2]:.5f}")
            t += 0.01
        for i in range(300):  # a tumble between poses
            a = rng.normal(0, 5, 3)
            rows.append(f"{t:.3f},{a[0]:.5f},{a[1]:.5f},{a[2]:.5f}")
            t += 0.01
    src = _write(tmp_path / "phys.csv", "\n".join(rows) + "\n")
    s = load_session(import_recording("csv", src, tmp_path / "out"))
    m = s.manifest
    assert m["import"]["steps_from"] == "static detection" and m["import"]["units"] == "m/s^2"
    assert len(m["steps"]) == 3 and m["rig"]["sensor"]["accel_lsb_per_g"] == COUNTS_PER_G_EQUIVALENT
    mean0 = s.step_samples(0)["accel_counts"].mean(axis=0)
    assert mean0 == pytest.approx([0, 0, 100000], abs=50)


# -- bad inputs: one RigInputError naming the file (and the line where there is one) ----------------
def _raises(source, src, tmp_path, line=None, match=None):
    with pytest.raises(RigInputError) as exc:
        import_recording(source, src, tmp_path / "out")
    msg = str(exc.value)
    assert "\n" not in msg
    if src is not None:
        assert str(src) in msg
    if line is not None:
        assert exc.value.line == line and f"{src}:{line}:" in msg
    if match:
        assert match in msg
    return exc.value


def test_unknown_source(tmp_path):
    f = _write(tmp_path / "a.csv", "t_s,ax,ay,az\n")
    err = _raises("matlab", None, tmp_path, match="unknown source 'matlab'")
    assert err.key == "--from"
    with pytest.raises(RigInputError, match="unknown source"):
        import_recording("matlab", f, tmp_path / "out")


@pytest.mark.parametrize("source", SOURCES)
def test_missing_file(source, tmp_path):
    _raises(source, tmp_path / "nope.csv", tmp_path, match="no such file")


@pytest.mark.parametrize("source", SOURCES)
def test_empty_file(source, tmp_path):
    _raises(source, _write(tmp_path / "empty.txt", ""), tmp_path, line=1, match="empty file")


@pytest.mark.parametrize("source, text, line, key", [
    ("imucal", "part,samples,acc_x,acc_y,gyr_x,gyr_y,gyr_z\nx_p,1,1,2,3,4,5\n", 1, "acc_z"),
    ("tofupilot", "timestamp\timu.acc.x\timu.acc.y\timu.acc.z\n1\t0\t0\t-9.8\n", 1, "imu.temperature"),
    ("csv", "# units: g\nt_s,ax,ay,z\n0,0,0,1\n", 2, "az"),
    ("imu_tk", "0.01 1 2 3\n0.02 1 2\n", 2, None),
])
def test_wrong_columns(source, text, line, key, tmp_path):
    err = _raises(source, _write(tmp_path / f"cols-{source}.txt", text), tmp_path, line=line)
    assert err.key == key


@pytest.mark.parametrize("source, text, line, key", [
    ("imucal", "part,samples,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z\nx_p,1,2040,0,0,0,0,0\nx_p,2,20x0,0,0,0,0,0\n",
     3, "acc_x"),
    ("tofupilot", "timestamp\timu.acc.x\timu.acc.y\timu.acc.z\timu.temperature\n1\t0\t0\t-9.8\t20\n"
                  "500001\t0\tnan\t-9.8\t20\n", 3, "imu.acc.y"),
    ("csv", "# units: g\nt_s,ax,ay,az\n0,0,0,1\n0.01,0,0,one\n", 4, "az"),
    ("imu_tk", "0.01 1 2 3\n0.02 1 2 abc\n", 2, "z"),
])
def test_non_numeric_cells(source, text, line, key, tmp_path):
    err = _raises(source, _write(tmp_path / f"num-{source}.txt", text), tmp_path, line=line, match="expected a number")
    assert err.key == key


def _imucal_rows(parts, flip=None):
    poses = {"x_p": (1, 0, 0), "x_a": (-1, 0, 0), "y_p": (0, 1, 0), "y_a": (0, -1, 0), "z_p": (0, 0, 1),
             "z_a": (0, 0, -1), "x_rot": (0, 0, 1), "y_rot": (0, 0, 1), "z_rot": (1, 0, 0)}
    out = ["part,samples,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z"]
    n = 0
    for p in parts:
        f = poses.get(flip.get(p, p) if flip else p, (0, 0, 1))
        for _ in range(10):
            out.append(f"{p},{n},{f[0] * 2040 + n % 3},{f[1] * 2040},{f[2] * 2040},0,0,0")
            n += 1
    return "\n".join(out) + "\n"


ALL_PARTS = ("x_p", "x_a", "y_p", "y_a", "z_p", "z_a", "x_rot", "y_rot", "z_rot")


def test_imucal_synthetic_ok(tmp_path):
    s = load_session(import_recording("imucal", _write(tmp_path / "ok.csv", _imucal_rows(ALL_PARTS)), tmp_path / "o"))
    assert [st["f_nominal"] for st in s.manifest["steps"][:2]] == [[1, 0, 0], [-1, 0, 0]]


def test_imucal_unlabelled_part(tmp_path):
    text = _imucal_rows(ALL_PARTS).replace("\ny_a,", "\n,", 1)
    err = _raises("imucal", _write(tmp_path / "unl.csv", text), tmp_path, line=32, match="got ''")
    assert err.key == "part"


def test_imucal_unknown_and_missing_part(tmp_path):
    _raises("imucal", _write(tmp_path / "unk.csv", _imucal_rows(ALL_PARTS + ("w_p",))), tmp_path, line=92,
            match="'w_p'")
    _raises("imucal", _write(tmp_path / "miss.csv", _imucal_rows(ALL_PARTS[1:])), tmp_path, match="missing part(s) x_p")


def test_imucal_mislabelled_parts(tmp_path):
    # y_a recorded with x vertical: the dominant axis contradicts the label
    _raises("imucal", _write(tmp_path / "axis.csv", _imucal_rows(ALL_PARTS, {"y_a": "x_p"})), tmp_path, line=32,
            match="dominant axis is x")
    # z_p and z_a swapped: the sign contradicts the convention of the other parts
    _raises("imucal", _write(tmp_path / "sign.csv", _imucal_rows(ALL_PARTS, {"z_p": "z_a", "z_a": "z_p"})), tmp_path,
            match="mislabelled part")


def test_csv_units_comments(tmp_path):
    body = "t_s,ax,ay,az\n0,0,0,1\n0.01,0,0,1\n"
    _raises("csv", _write(tmp_path / "nounits.csv", body), tmp_path, line=1, match="# units:")
    _raises("csv", _write(tmp_path / "badunits.csv", "# units: furlongs\n" + body), tmp_path, line=1)
    _raises("csv", _write(tmp_path / "nolsb.csv", "# units: counts\n" + body), tmp_path, line=1, match="lsb_per_g")
    _raises("csv", _write(tmp_path / "frac.csv", "# units: counts\n# lsb_per_g: 1000\n" + body.replace(",1\n0.01", ",1.5\n0.01")),
            tmp_path, line=4, match="integer counts")


def test_csv_decreasing_time(tmp_path):
    _raises("csv", _write(tmp_path / "back.csv", "# units: g\nt_s,ax,ay,az\n0,0,0,1\n0.02,0,0,1\n0.01,0,0,1\n"),
            tmp_path, line=5, match="increasing")


def test_bad_g_and_id(datasets, tmp_path):
    with pytest.raises(RigInputError, match="--g"):
        import_recording("imucal", datasets / IMUCAL, tmp_path, g_ms2=98.0665)
    with pytest.raises(RigInputError, match="invalid session id"):
        import_recording("imucal", datasets / IMUCAL, tmp_path, session_id="../x")

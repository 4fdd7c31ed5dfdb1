"""A solved calibration applied to its own simulated session (``CalibrationFile.apply`` on the
Recording ``rig.analysis.apply`` builds, and ``rig apply``): |f| = 1 g within noise on every static
step, the commanded rates on the rate steps, the site's field; and the refusals of ``rig apply`` are one
line naming the calibration file."""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest
import yaml

from calib.file import calibration as calfile
from rig.analysis.apply import recording_from_session
from rig.cli import main
from rig.session import load_session
from rig.workflow.run import run_procedure

#: the magnetometer's eight positions (the accelerometer's faces among them), then rate steps about each axis
PROCEDURE = """format: rig-procedure/1
name: apply_all_sections
sensor: {model: MPU-9150, accel_range_g: 4, sample_rate_hz: 100, magnetometer: true, mag_samples: 50}
dwell: {seconds: 3}
steps:
  - {pose: "+X up"}
  - {pose: "-X up"}
  - {pose: "+Y up"}
  - {pose: "-Y up"}
""" + "".join(f'  - {{pose: "{face} up", a1_deg: {yaw}}}\n' for face in ("+Z", "-Z") for yaw in (0, 90, 180, 270)) + \
    "".join(f"  - {{rate: {{axis: {a}, rate_deg_s: {r}, seconds: 10}}}}\n" for a in ("a1", "a2", "a3")
            for r in (30, -30)) + "solve: {model: triangular, method: pinv, magnetometer: positions}\n"


@pytest.fixture(scope="module")
def solved(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("apply")
    proc = tmp / "apply_all_sections.yaml"
    proc.write_text(PROCEDURE)
    session_dir = run_procedure(str(proc), out_dir=tmp / "sessions", seed=4, time_scale=0).session_dir
    return session_dir, load_session(session_dir), calfile.read(session_dir / "calibration.yaml")


def test_a_calibration_applied_to_its_own_session_gives_one_g_on_every_static_step(solved):
    _, session, cal = solved
    out = cal.apply(recording_from_session(session))
    assert out.applied == ("accelerometer", "gyroscope", "magnetometer")
    steps, d = session.info.steps, session.samples
    static = [s for s in steps if s.is_static]
    assert len(static) == 12
    for st in static:
        norm = np.linalg.norm(out.f_g[d["step"] == st.index], axis=1)
        sem = norm.std() / np.sqrt(len(norm))
        assert abs(norm.mean() - 1.0) < max(5 * sem, 1e-3), (st.name, norm.mean(), sem)
        np.testing.assert_allclose(np.linalg.norm(out.f_ms2[d["step"] == st.index], axis=1).mean(),
                                   9.80665 * norm.mean())
        h = out.h_ut[d["step"] == st.index]
        h = h[np.all(np.isfinite(h), axis=1)]
        assert abs(np.linalg.norm(h, axis=1).mean() - session.info.rig.site.field_ut) < 0.6, st.name
    means = [np.linalg.norm(out.f_g[d["step"] == st.index], axis=1).mean() for st in static]
    assert abs(np.mean(means) - 1.0) < 3e-4
    for st in (s for s in steps if s.kind == "rate"):
        w = out.w_dps[d["step"] == st.index].mean(axis=0)
        np.testing.assert_allclose(w, st.rate_nominal_dps, atol=0.01, err_msg=st.name)


def test_rig_apply_writes_what_the_entry_point_gives(solved, tmp_path):
    session_dir, session, cal = solved
    csv = tmp_path / "applied.csv"
    assert main(["apply", str(session_dir / "calibration.yaml"), str(session_dir), "-o", str(csv)]) == 0
    rows = csv.read_text().splitlines()
    assert rows[0].split(",") == ["t_s", "step", "fx", "fy", "fz", "temp_c", "wx_dps", "wy_dps", "wz_dps",
                                  "mx_ut", "my_ut", "mz_ut"]
    assert len(rows) - 1 == len(session.samples["t_s"])
    table = np.array([[float(x) if x else np.nan for x in r.split(",")] for r in rows[1:]])
    out = cal.apply(recording_from_session(session))
    np.testing.assert_allclose(table[:, 2:5], out.f_g, atol=1e-7)
    np.testing.assert_allclose(table[:, 6:9], out.w_dps, atol=1e-5)
    np.testing.assert_allclose(table[:, 9:12], out.h_ut, atol=1e-5)


def _apply_edited(session_dir, tmp_path, edit) -> tuple[int, list[str], str]:
    doc = yaml.safe_load((session_dir / "calibration.yaml").read_text())
    edit(doc)
    path = tmp_path / "edited.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["apply", str(path), str(session_dir), "-o", str(tmp_path / "x.csv")])
    assert not (tmp_path / "x.csv").exists()
    return code, err.getvalue().strip().splitlines(), str(path)


@pytest.mark.parametrize("edit, words", [
    (lambda d: d["sensor"].update(model="ADXL345"), ("calibrates the ADXL345", "of the MPU-9150",
                                                     "another sensor model")),
    (lambda d: d["accelerometer"].update(lsb_per_g=16384.0), ("16384 counts/g", "at 8192 counts/g, its +-4 g range",
                                                              "another full-scale range")),
    (lambda d: d["gyroscope"].update(lsb_per_dps=65.5), ("65.5 counts/(deg/s)", "131 counts/(deg/s)",
                                                         "another full-scale range")),
])
def test_rig_apply_refuses_a_session_of_another_sensor_or_range_in_one_line(solved, tmp_path, edit, words):
    session_dir, _, _ = solved
    code, lines, path = _apply_edited(session_dir, tmp_path, edit)
    assert code == 2 and len(lines) == 1, lines
    assert path in lines[0] and f"session {session_dir}" in lines[0], lines[0]
    for w in words:
        assert w in lines[0], (w, lines[0])

"""Procedure features end to end on the simulated rig: sem-based dwell, temperature steps (chamber and
operator), the joint thermal solve, hidden effects from a rig file, and sessions written by other tools."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from calib.file import calibration as calfile
from rig.cli import main
from rig.session import load_session

from conftest import RIGS


def _write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


def _session(root):
    (d,) = [p for p in root.iterdir() if p.is_dir()]
    return d


SEM = """format: rig-procedure/1
name: sem_dwell
sensor: {accel_range_g: 4, sample_rate_hz: 100}
dwell: {sem_g: 2.0e-4, max_seconds: 30}
steps:
  - pose: "+Z up"
  - {pose: "-Z up", dwell: {sem_g: 1.0e-4, max_seconds: 30}}
solve: null
"""


def test_dwell_until_the_standard_error_reaches_the_target(tmp_path):
    p = _write(tmp_path, "sem.yaml", SEM)
    assert main(["run", str(p), "--out", str(tmp_path / "s"), "--time-scale", "0", "--quiet"]) == 0
    s = load_session(_session(tmp_path / "s"))
    for i, target in ((0, 2.0e-4), (1, 1.0e-4)):
        a = s.step_samples(i)["accel_counts"] / 8192.0
        n = len(a)
        sem = a.std(axis=0, ddof=1) / np.sqrt(n)
        assert np.all(sem <= target)
        # and it stopped soon after: ten samples fewer would not have been enough on some axis
        b = a[: n - 10]
        assert np.any(b.std(axis=0, ddof=1) / np.sqrt(len(b)) > target * 0.97)
    assert len(s.step_samples(1)["t_s"]) > 3 * len(s.step_samples(0)["t_s"])  # half the sem: ~4x the samples


THERMAL = """format: rig-procedure/1
name: mini_thermal
sensor: {model: MPU-9150, accel_range_g: 4, sample_rate_hz: 100}
dwell: {seconds: 3}
steps:
  - temperature: {target_c: 25.0, tolerance_c: 0.3, hold_s: 20, mode: wait}
  - pose: "+Z up"
  - pose: "-Z up"
  - pose: "+X up"
  - pose: "-X up"
  - pose: "+Y up"
  - pose: "-Y up"
  - temperature: {target_c: 35.0, tolerance_c: 0.3, hold_s: 20, mode: operator}
  - pose: "+Z up"
  - pose: "-Z up"
  - pose: "+X up"
  - pose: "-X up"
  - pose: "+Y up"
  - pose: "-Y up"
solve: {model: triangular, method: pinv, thermal: auto}
"""


def test_temperature_steps_wait_for_the_thermometer_and_the_thermal_model_is_solved(tmp_path):
    p = _write(tmp_path, "t.yaml", THERMAL)
    # the operator step needs a confirmation: without a terminal and without --yes it stops clearly
    assert main(["run", str(p), "--out", str(tmp_path / "no"), "--time-scale", "0", "--quiet"]) == 2
    assert main(["run", str(p), "--out", str(tmp_path / "s"), "--time-scale", "0", "--quiet", "--yes"]) == 0
    d = _session(tmp_path / "s")
    s = load_session(d)
    temps = [st["stats"]["temp_c"] for st in s.info.to_dict()["steps"] if st["kind"] == "static"]
    assert np.allclose(temps[:6], 25.0, atol=0.35) and np.allclose(temps[6:], 35.0, atol=0.35)
    cal = calfile.read(d / "calibration.yaml").accelerometer
    truth = yaml.safe_load((d / "sim_truth.yaml").read_text())["accelerometer"]
    true_tc = np.asarray(truth["bias_tempco_g_per_c"]) * 8192.0
    sig = np.asarray(cal.sigma["temperature"]["coefficients"])[:, 0]
    assert cal.temperature is not None
    assert np.all(np.abs(cal.temperature.coefficients[:, 0] - true_tc) < 5 * sig + 0.05)


def test_hidden_effects_switch_on_from_a_rig_file_and_land_in_the_truth(tmp_path):
    base = (RIGS / "sim.yaml").read_text().replace("time_scale: 10", "time_scale: 0")
    six = (RIGS.parent / "procedures" / "six_position.yaml")
    x = {}
    for name, effects in (("on", "  effects: {scale_nonlinearity: [0.002, 0.0, 0.0], table_tilt: [0.1, -0.05]}\n"),
                          ("off", "")):
        rig = _write(tmp_path, f"{name}.yaml", base + effects)
        assert main(["run", str(six), "--rig", str(rig), "--out", str(tmp_path / name), "--quiet"]) == 0
        s = load_session(_session(tmp_path / name))
        x[name] = np.array([s.step_samples(i)["accel_counts"][:, 0].mean() for i in range(6)])  # +Z +X -Z -X +Y -Y
    truth = yaml.safe_load((_session(tmp_path / "on") / "sim_truth.yaml").read_text())
    assert truth["accelerometer"]["scale_nonlinearity"] == [0.002, 0.0, 0.0]
    assert truth["table_tilt_deg"] == [0.1, -0.05]
    # the quadratic term adds 2 mg to x at +X up and at -X up and nothing at +-Z up (where the
    # misalignment and tilt terms cancel between the two): the difference of the pair means shows it. The
    # same seed without the effects has the same noise and bias wander (the effects draw nothing), so the
    # change of that difference is the effect alone, to the rounding of the counts
    pair = {k: (v[1] + v[3]) / 2 - (v[0] + v[2]) / 2 for k, v in x.items()}
    assert pair["on"] - pair["off"] == pytest.approx(0.002 * 8192, abs=0.1)


def test_a_session_written_by_another_tool_solves_like_our_own(tmp_path, capsys):
    d = tmp_path / "other"
    d.mkdir()
    faces = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]
    manifest = {"format": "rig-session/1", "id": "other", "created": "2026-01-01T00:00:00Z", "status": "complete",
                "procedure": {"name": "by-hand", "text": ""}, "software": {"name": "someone-elses-logger"},
                "rig": {"sensor": {"model": "ADXL345", "accel_lsb_per_g": 256, "sample_rate_hz": 100,
                                   "has_temperature": False}},
                "steps": [{"index": i, "name": f"face{i}", "kind": "static", "f_nominal": f, "status": "complete"}
                          for i, f in enumerate(faces)]}
    (d / "session.yaml").write_text(yaml.safe_dump(manifest))
    rng = np.random.default_rng(0)
    lines = ["step,t_s,az,ay,ax,temp_c,comment"]  # columns in another order, an extra column
    for i, f in enumerate(faces):
        for k in range(200):
            a = np.round(np.asarray(f) * [260, 250, 255] + [5, -3, 8] + rng.normal(0, 1.2, 3)).astype(int)
            lines.append(f"{i},{i * 3 + k * 0.01:.2f},{a[2]},{a[1]},{a[0]},,x")
    (d / "samples.csv").write_text("\n".join(lines) + "\n")
    assert main(["solve", str(d), "--thermal", "off"]) == 0
    cal = calfile.read(d / "calibration.yaml").accelerometer
    np.testing.assert_allclose(cal.scale_counts_per_g, [260, 250, 255], atol=0.5)
    np.testing.assert_allclose(cal.bias_counts, [5, -3, 8], atol=0.5)

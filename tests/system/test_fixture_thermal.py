"""A fixture runs temperature set-points and prompts too (issue 30): the chamber is set once for every slot, the
wait reads a live slot's thermometer, each slot's session records the step with its own reading, and each unit's
thermal calibration recovers its own hidden bias tempco."""

from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import yaml

from calib.file import calibration as calfile
from rig.cli import main

from conftest import RIGS

FACES = '  - pose: "+Z up"\n  - pose: "+X up"\n  - pose: "-Z up"\n  - pose: "-X up"\n  - pose: "+Y up"\n  - pose: "-Y up"\n'
PROCEDURE = ("format: rig-procedure/1\nname: fixture_thermal\nsensor: {model: MPU-9150, accel_range_g: 4, "
             "sample_rate_hz: 100}\ndwell: {seconds: 4}\nsteps:\n  - prompt: Close the chamber\n"
             + "".join(f"  - temperature: {{target_c: {t}, tolerance_c: 0.3, hold_s: 20, timeout_s: 3600, "
                       f"mode: wait}}\n" + FACES for t in (27.6, 37.6, 47.6))
             + "solve: {model: triangular, method: pinv, thermal: auto}\n")


def test_a_thermal_procedure_on_a_fixture_calibrates_each_units_tempco(tmp_path):
    (tmp_path / "proc.yaml").write_text(PROCEDURE)
    rig = yaml.safe_load((RIGS / "sim-fixture.yaml").read_text())
    rig["fixture"]["slots"] = rig["fixture"]["slots"][:3]
    rig["sim"]["time_scale"] = 0
    (tmp_path / "rig.yaml").write_text(yaml.safe_dump(rig))
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        code = main(["run", str(tmp_path / "proc.yaml"), "--rig", str(tmp_path / "rig.yaml"), "--out",
                     str(tmp_path / "o"), "--seed", "3", "--time-scale", "0", "--yes"])
    assert code == 0, out.getvalue()
    (batch,) = [p for p in (tmp_path / "o").iterdir() if p.is_dir()]
    record = json.loads((batch / "batch.json").read_text())
    assert [s["outcome"] for s in record["slots"]] == ["NO LIMITS"] * 3
    for s in record["slots"]:
        session = batch / s["session"]
        steps = yaml.safe_load((session / "session.yaml").read_text())["steps"]
        temps = [st for st in steps if st["kind"] == "thermal"]
        assert len(temps) == 3 and all(st["status"] == "complete" for st in temps)
        # each slot's own thermometer, in the band the wait held (0.3 C) plus its reading noise
        assert np.allclose([st["stats"]["temp_c"] for st in temps], [27.6, 37.6, 47.6], atol=0.5), temps
        assert steps[0]["kind"] == "prompt" and steps[0]["status"] == "complete"
        cal = calfile.read(session / "calibration.yaml").accelerometer
        truth = yaml.safe_load((session / "sim_truth.yaml").read_text())["accelerometer"]
        tempco = np.asarray(cal.temperature.coefficients, float)[:, 0]  # counts/C per axis
        sigma = np.asarray(cal.sigma["temperature"]["coefficients"], float)[:, 0]
        true = np.asarray(truth["bias_tempco_g_per_c"]) * cal.lsb_per_g
        assert np.all(np.abs(tempco - true) < 4 * sigma), (s["slot"], tempco, true, sigma)


def test_a_reversal_on_a_fixture_is_refused_before_anything_moves(tmp_path, capsys):
    from conftest import PROCEDURES
    code = main(["run", str(PROCEDURES / "characterize_reversal.yaml"), "--rig", str(RIGS / "sim-fixture.yaml"),
                 "--time-scale", "0", "--yes", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and "a fixture's slots keep their mountings" in err and not (tmp_path / "o").exists()

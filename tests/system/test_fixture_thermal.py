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
from fixture_runs import CtrlCAt

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


def test_a_thermal_ramp_on_a_fixture_captures_every_unit_on_the_move_in_temperature(tmp_path):
    """procedures/thermal_ramp.yaml, shortened (27.6 -> 33.6 -> 27.6 C at 3 C/min, 3 s dwells: the six faces
    cycled while each leg lasts), on 3 slots: the chamber set ramping once per leg, each slot's session records
    each ramp start with its own thermometer and each pose with the rate its own thermometer saw (up, then down),
    and each unit's calibration carries the ramp's thermal terms, its bias tempco within 4 sigma of its hidden one."""
    from conftest import PROCEDURES
    text = (PROCEDURES / "thermal_ramp.yaml").read_text()
    for old, new in {"dwell: {seconds: 10}": "dwell: {seconds: 3}", "to_c: 52.6": "to_c: 33.6",
                     "rate_c_per_min: 4}": "rate_c_per_min: 3}"}.items():
        assert old in text, old
        text = text.replace(old, new)
    (tmp_path / "ramp.yaml").write_text(text)
    rig = yaml.safe_load((RIGS / "sim-fixture.yaml").read_text())
    rig["fixture"]["slots"] = rig["fixture"]["slots"][:3]
    rig["sim"]["time_scale"] = 0
    (tmp_path / "rig.yaml").write_text(yaml.safe_dump(rig))
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["run", str(tmp_path / "ramp.yaml"), "--rig", str(tmp_path / "rig.yaml"), "--out",
                     str(tmp_path / "o"), "--seed", "4", "--time-scale", "0", "--yes"])
    assert code == 0, out.getvalue() + err.getvalue()
    assert "(ramp 1 to 33.6 C" in err.getvalue()  # the progress names the ramp
    (batch,) = [p for p in (tmp_path / "o").iterdir() if p.is_dir()]
    record = json.loads((batch / "batch.json").read_text())
    assert [s["outcome"] for s in record["slots"]] == ["NO LIMITS"] * 3
    starts = []
    for s in record["slots"]:
        session = batch / s["session"]
        steps = yaml.safe_load((session / "session.yaml").read_text())["steps"]
        ramp_starts = [st for st in steps if st["kind"] == "thermal" and st["stats"].get("ramp")]
        assert len(ramp_starts) == 2 and all(st["status"] == "complete" for st in ramp_starts)
        starts.append([st["stats"]["temp_c"] for st in ramp_starts])
        poses = [st for st in steps if st["kind"] == "static"]
        assert len(poses) >= 12 and all(st["status"] == "complete" for st in poses)
        rates = {leg: np.array([st["stats"]["ramp"]["temp_rate_c_per_min"] for st in poses
                                if st["stats"]["ramp"]["leg"] == leg]) for leg in (1, 2)}
        assert rates[1].max() > 1.0 and rates[2].min() < -1.0, rates  # captured on the move, up then down
        assert np.median(rates[1]) > 0.5 and np.median(rates[2]) < -0.5, rates
        cal = calfile.read(session / "calibration.yaml").accelerometer
        assert cal.temperature is not None and {e["name"] for e in cal.effects} == {"thermal_gradient",
                                                                                   "scale_tempco"}
        tempco = np.asarray(cal.temperature.coefficients, float)[:, 0]  # each unit's own, counts/C per axis
        sigma = np.asarray(cal.sigma["temperature"]["coefficients"], float)[:, 0]
        truth = yaml.safe_load((session / "sim_truth.yaml").read_text())["accelerometer"]
        true = np.asarray(truth["bias_tempco_g_per_c"]) * cal.lsb_per_g
        assert np.all(np.abs(tempco - true) < 4 * sigma), (s["slot"], tempco, true, sigma)
    # every slot read its own thermometer at each ramp's start: the same chamber, each its own chip's reading
    assert np.allclose(starts, starts[0], atol=1.0) and len({tuple(s) for s in starts}) == 3


def test_a_fixture_batch_stopped_inside_a_ramp_resumes_it_from_the_legs_last_capture(tmp_path):
    """Stopped by Ctrl-C at the 7th pose of the first leg, the batch resumes: the chamber brought back to the
    temperature of the leg's last capture (the first live slot's record) and ramping on, every slot's session says
    so (a restored ``temperature`` event) and ends complete."""
    from rig.execution.context import RunAborted
    from rig.workflow.run import run_procedure
    from conftest import PROCEDURES

    text = (PROCEDURES / "thermal_ramp.yaml").read_text()
    for old, new in {"dwell: {seconds: 10}": "dwell: {seconds: 3}", "to_c: 52.6": "to_c: 30.6",
                     "rate_c_per_min: 4}": "rate_c_per_min: 3}"}.items():
        text = text.replace(old, new)
    (tmp_path / "ramp.yaml").write_text(text)
    rig = yaml.safe_load((RIGS / "sim-fixture.yaml").read_text())
    rig["fixture"]["slots"] = rig["fixture"]["slots"][:2]
    rig["sim"]["time_scale"] = 0
    (tmp_path / "rig.yaml").write_text(yaml.safe_dump(rig))
    try:
        run_procedure(str(tmp_path / "ramp.yaml"), rig_spec=str(tmp_path / "rig.yaml"), out_dir=tmp_path / "o", seed=4,
                      time_scale=0, ui=CtrlCAt(8), history=str(tmp_path / "h.sqlite"))
        raise AssertionError("not stopped")
    except RunAborted as stopped:
        batch = stopped.session_dir
    run_procedure(None, resume_dir=str(batch), time_scale=0, history=str(tmp_path / "h.sqlite"))
    record = json.loads((batch / "batch.json").read_text())
    assert record["status"] == "complete" and [s["outcome"] for s in record["slots"]] == ["NO LIMITS"] * 2
    for s in record["slots"]:
        session = batch / s["session"]
        events = [json.loads(line) for line in (session / "events.jsonl").read_text().splitlines()]
        (restored,) = [e for e in events if e.get("kind") == "temperature" and e.get("restored")]
        last_c = yaml.safe_load((session / "session.yaml").read_text())["steps"][7]["stats"]["temp_c"]
        assert abs(restored["temp_c"] - last_c) < 0.5, (restored, last_c)
        steps = yaml.safe_load((session / "session.yaml").read_text())["steps"]
        assert all(st["status"] == "complete" for st in steps)

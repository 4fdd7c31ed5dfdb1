"""The main job end to end, on the simulated rig, through the `rig` command a technician uses.

A six-position run moves the emulated turntable over the real Standa protocol, records the
simulated MPU-9150 over the simulated I2C bus, writes a session, solves it and writes a
calibration file that recovers the simulator's hidden parameters.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from calib.file import calibration as calfile
from rig.cli import main
from rig.session import load_session

from conftest import PROCEDURES


def _run(tmp_path, *extra, procedure="six_position.yaml", seed=7):
    out = tmp_path / "sessions"
    code = main(["run", str(PROCEDURES / procedure), "--out", str(out), "--seed", str(seed),
                 "--time-scale", "0", "--quiet", *extra])
    sessions = sorted(out.iterdir()) if out.exists() else []
    return code, sessions


@pytest.fixture(scope="module")
def six_position_session(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("six")
    code, sessions = _run(tmp)
    assert code == 0
    assert len(sessions) == 1
    return sessions[0]


def test_six_position_run_writes_a_complete_session(six_position_session):
    d = six_position_session
    for name in ("session.yaml", "samples.csv", "events.jsonl", "calibration.yaml", "sim_truth.yaml"):
        assert (d / name).is_file(), name
    manifest = yaml.safe_load((d / "session.yaml").read_text())
    assert manifest["format"] == "rig-session/1"
    assert manifest["status"] == "complete"
    static = [s for s in manifest["steps"] if s["kind"] == "static"]
    assert len(static) == 6 and all(s["status"] == "complete" for s in static)
    # every device identified into the session
    axes = manifest["rig"]["turntable"]["axes"]
    assert set(axes) == {"a1", "a2", "a3"} and all(a["serial"] for a in axes.values())
    assert manifest["rig"]["sensor"]["model"] == "MPU-9150"
    assert manifest["rig"]["sensor"]["accel_lsb_per_g"] == pytest.approx(8192.0)
    events = [json.loads(line) for line in (d / "events.jsonl").read_text().splitlines()]
    kinds = {e["kind"] for e in events}
    assert {"move", "settle", "capture"} <= kinds


def test_each_step_has_exactly_the_dwell_samples_and_sits_at_its_pose(six_position_session):
    s = load_session(six_position_session)
    rate = s.info.to_dict()["rig"]["sensor"]["sample_rate_hz"]
    for step in s.info.to_dict()["steps"]:
        if step["kind"] != "static":
            continue
        d = s.step_samples(step["index"])
        assert len(d["t_s"]) == round(10 * rate)  # six_position.yaml dwells 10 s
        assert np.all(np.diff(d["t_s"]) > 0)  # no duplicates, in order
        mean_g = d["accel_counts"].mean(axis=0) / 8192.0
        # within a few percent + offsets of the nominal specific force
        assert np.allclose(mean_g, step["f_nominal"], atol=0.15)


def test_calibration_recovers_the_hidden_sensor(six_position_session):
    truth = yaml.safe_load((six_position_session / "sim_truth.yaml").read_text())["accelerometer"]
    cal = calfile.read(six_position_session / "calibration.yaml").accelerometer
    lsb = 8192.0
    true_m = np.asarray(truth["matrix"]) * lsb
    true_b = np.asarray(truth["bias_g"]) * lsb
    sig_b = np.asarray(cal.sigma["bias_counts"])
    sig_k = np.asarray(cal.sigma["scale_counts_per_g"])
    # the seed's model is triangular: compare the diagonal and the bias
    temp_c = float(np.mean(load_session(six_position_session).samples["temp_c"]))
    true_b = true_b + np.asarray(truth["bias_tempco_g_per_c"]) * lsb * (temp_c - truth["t_ref_c"])
    assert np.all(np.abs(np.asarray(cal.bias_counts) - true_b) < 5 * sig_b + 1.0)
    assert np.all(np.abs(np.asarray(cal.scale_counts_per_g) - np.diag(true_m)) < 5 * sig_k + 2.0)
    assert np.all(sig_b > 0) and np.all(sig_b < 5)


def test_apply_and_evaluate_from_the_command_line(six_position_session, tmp_path, capsys):
    d = six_position_session
    out = tmp_path / "applied.csv"
    assert main(["apply", str(d / "calibration.yaml"), str(d), "-o", str(out)]) == 0
    rows = out.read_text().splitlines()
    assert rows[0] == "t_s,step,fx,fy,fz,temp_c"
    f = np.array([[float(x) for x in r.split(",")[2:5]] for r in rows[1:]])
    assert np.abs(np.linalg.norm(f, axis=1).mean() - 1.0) < 1e-3
    capsys.readouterr()
    assert main(["evaluate", str(d / "calibration.yaml"), str(d), "--json"]) == 0
    ev = json.loads(capsys.readouterr().out)
    assert ev  # per-step rows are there
    assert main(["solve", str(d), "-o", str(tmp_path / "c.yaml"), "--json"]) == 0


def test_replay_gives_the_identical_calibration(six_position_session, tmp_path):
    assert main(["replay", str(six_position_session), "--out", str(tmp_path)]) == 0
    replayed = [p for p in tmp_path.iterdir() if p.is_dir()]
    assert len(replayed) == 1
    a = calfile.read(six_position_session / "calibration.yaml").accelerometer
    b = calfile.read(replayed[0] / "calibration.yaml").accelerometer
    np.testing.assert_array_equal(np.asarray(a.matrix_counts_per_g), np.asarray(b.matrix_counts_per_g))
    np.testing.assert_array_equal(np.asarray(a.bias_counts), np.asarray(b.bias_counts))


def test_missing_procedure_is_one_line_and_exit_2(tmp_path, capsys):
    code = main(["run", str(tmp_path / "nope.yaml"), "--out", str(tmp_path), "--time-scale", "0"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and "nope.yaml" in err[0]


def test_procedure_with_an_unknown_key_names_file_line_and_key(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    text = (PROCEDURES / "six_position.yaml").read_text() + "\ncolour: blue\n"
    bad.write_text(text)
    code = main(["run", str(bad), "--out", str(tmp_path / "s"), "--time-scale", "0"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "bad.yaml" in err[0] and "colour" in err[0]
    assert not (tmp_path / "s").exists() or not any((tmp_path / "s").iterdir())


def test_solve_of_a_missing_session_is_exit_2(tmp_path, capsys):
    assert main(["solve", str(tmp_path / "none")]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_run_and_solve_print_the_gyroscopes_zero_rate_output_alike_and_say_it_is_not_stored(tmp_path, capsys):
    code, (session,) = _run(tmp_path)
    run_out = capsys.readouterr().out
    assert code == 0
    assert main(["solve", str(session), "-o", str(tmp_path / "again.yaml")]) == 0
    solve_out = capsys.readouterr().out
    lines = [[x for x in out.splitlines() if "gyroscope zero-rate output" in x] for out in (run_out, solve_out)]
    assert lines[0] == lines[1] and len(lines[0]) == 1, lines
    assert "printed only: the calibration file's gyroscope section comes from rate steps" in lines[0][0]
    assert calfile.read(session / "calibration.yaml").gyroscope is None

"""procedures/six_position_rapid.yaml end to end, through the `rig` command, on the simulated rig.

The shipped accuracy-targeted procedure runs from the CLI (``rig.cli.main`` in this process; the emulated
controllers in process too, the tests' ``sim.transport: memory``; the simulated MPU-9150 over the
simulated I2C bus, virtual time), shows its prediction against the target while it captures, ends with
the verdict, takes a fraction of the seed procedure's rig time, and a replay of its recording stops
every pose where the run stopped.
"""

from __future__ import annotations

import io
import json
import sys

import numpy as np
import pytest
import yaml

from rig.cli import main
from rig.analysis.target import calibration_record
from rig.session import load_session

from conftest import PROCEDURES


@pytest.fixture(scope="module")
def rapid(tmp_path_factory):
    """(exit code, session directory, stderr) of ``rig run six_position_rapid.yaml``."""
    out = tmp_path_factory.mktemp("rapid") / "sessions"
    capture = pytest.MonkeyPatch()
    err = io.StringIO()
    capture.setattr(sys, "stderr", err)
    try:
        code = main(["run", str(PROCEDURES / "six_position_rapid.yaml"), "--out", str(out), "--seed", "5",
                     "--time-scale", "0", "--yes"])
    finally:
        capture.undo()
    (session,) = sorted(out.iterdir())
    return code, session, err.getvalue()


def test_the_rapid_procedure_runs_from_the_cli_and_meets_its_target(rapid):
    code, session, _ = rapid
    assert code == 0
    assert (session / "calibration.yaml").is_file()
    (done,) = [e for e in map(json.loads, (session / "events.jsonl").read_text().splitlines()) if e["kind"] == "target"]
    assert done["met"] and done["predicted_attitude_error_deg"] <= 0.03
    # the calibration's own prediction, from the recorded steps, is the one the run stopped on
    s = load_session(session)
    record = calibration_record(s, s.step_means())
    assert record["met"] and record["attitude_error_deg"] == 0.03 and record["confidence"] == 0.95
    assert record["poses"] == "seed_table" and record["max_seconds"] == 90
    assert record["predicted_attitude_error_deg"] == pytest.approx(done["predicted_attitude_error_deg"], rel=1e-6)


def test_progress_shows_the_prediction_against_the_target_and_the_run_ends_with_the_verdict(rapid):
    _, _, stderr = rapid
    captures = [line for line in stderr.splitlines() if ": capture" in line]
    assert len(captures) == 6 and all(" predicted 0.0" in line and "0.03 deg" in line for line in captures)
    assert ">0.03 deg" in captures[0]  # the first pose alone cannot promise the target
    assert any(line.startswith("target met: max roll/pitch error") and "of max_seconds 90" in line
               for line in stderr.splitlines())


def test_it_takes_less_than_half_the_seed_procedures_rig_time_moving_through_the_least_travel(rapid):
    _, session, _ = rapid
    steps = load_session(session).info.steps
    assert [s.name for s in steps] == ["+Z up", "-Y up", "-X up", "+Y up", "+X up", "-Z up"]  # 90-degree moves only
    rig_time = max(s.stats.t_end_s for s in steps)
    assert rig_time < 0.5 * 95.7  # six_position.yaml: 95.7 s on this rig
    assert all(s.stats.target["stop"] for s in steps)


def test_a_replay_stops_every_pose_where_the_run_stopped(rapid, tmp_path):
    _, session, _ = rapid
    assert main(["replay", str(session), "--out", str(tmp_path)]) == 0
    (replayed,) = [d for d in tmp_path.iterdir() if d.is_dir()]
    original, again = load_session(session), load_session(replayed)
    assert [s.stats.n_samples for s in again.info.steps] == [s.stats.n_samples for s in original.info.steps]
    a = yaml.safe_load((session / "calibration.yaml").read_text())["accelerometer"]
    b = yaml.safe_load((replayed / "calibration.yaml").read_text())["accelerometer"]
    assert np.array_equal(a["bias_counts"], b["bias_counts"])

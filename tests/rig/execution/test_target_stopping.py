"""A procedure with an accuracy target (``target:``): the stopping rule, on in-process devices.

The rig is the simulated world (its default noise model) reached in memory through the real stage
and sensor drivers, in virtual time, as in test_engine.py. The predictions are checked against the
calibration's own: the session's steps, solved, give the prediction the run stopped on.
"""

from __future__ import annotations

import json

import pytest

import calib
from rig.analysis import target
from rig.cli.console import plain_progress_line
from rig.config.procedure import load_procedure_text
from rig.errors import RigInputError
from rig.execution.context import RunError
from rig.execution.engine import Engine
from rig.execution.executors import targeted
from rig.execution.executors.target_policy import BLOCK_S, MIN_DWELL_S
from rig.execution.operator import SilentOperator
from rig.planning.kinematics import STAGE_AXES
from rig.session import SessionWriter, load_session

from conftest import SIX_FACES_STEPS
from engine_rig import make_rig, start as start_engine  # noqa: F401 - make_rig is a fixture

TEXT = """format: rig-procedure/1
name: unit_target
sensor: {{accel_range_g: 4, sample_rate_hz: 200}}
settle: {{window_s: 0.25, threshold_g: 0.01, timeout_s: 10}}
order: fastest
target: {target}
steps:
{six_faces}solve: {{model: triangular, method: pinv, thermal: auto}}
"""


class Recorder(SilentOperator):
    """A silent operator that keeps what it was shown."""

    def __init__(self) -> None:
        super().__init__()
        self.shown, self.lines = [], []

    def progress(self, progress) -> None:
        self.shown.append(progress)

    def info(self, message: str) -> None:
        self.lines.append(message)


def start(proc, rig, tmp_path, operator=None, **kw) -> tuple[Engine, SessionWriter]:
    return start_engine(proc, rig, tmp_path, operator or Recorder(), **kw)


def target_procedure(target: str):
    return load_procedure_text(TEXT.format(target=target, six_faces=SIX_FACES_STEPS), "unit.yaml")


def events(writer, kind: str) -> list[dict]:
    lines = (writer.session_dir / "events.jsonl").read_text().splitlines()
    return [e for e in map(json.loads, lines) if e["kind"] == kind]


def test_the_run_stops_when_the_target_is_predicted_met_and_not_much_later(make_rig, tmp_path):
    eng, writer = start(target_procedure("{attitude_error_deg: 0.03, max_seconds: 90}"), make_rig(), tmp_path)
    eng.prepare(resuming=False)
    eng.run()
    (done,) = events(writer, "target")
    assert done["met"] and 0.85 * 0.03 <= done["predicted_attitude_error_deg"] <= 0.03
    session = load_session(writer.session_dir)
    steps = [s.stats for s in session.info.steps]
    assert steps[-1].target["stop"] == "target met"
    assert all(s.target["stop"].startswith("its share of the plan") for s in steps[:-1])
    assert all(s.n_samples % round(BLOCK_S * 200) == 0 and s.n_samples >= MIN_DWELL_S * 200 for s in steps)
    assert sum(s.n_samples for s in steps) / 200 < 30  # the seed's fixed 10 s per pose would be 60 s
    # what the run stopped on is the calibration's own prediction from the recorded steps
    record = target.calibration_record(session, session.step_means())
    assert record["met"] and record["predicted_attitude_error_deg"] == pytest.approx(
        done["predicted_attitude_error_deg"], rel=1e-6)  # sample times as written to the CSV
    # a re-solve by another method is not what was predicted: its record says so instead of a verdict
    other = target.calibration_record(session, session.step_means(), method="flip")
    assert not other["met"] and other["summary"].startswith("not evaluated: the target is predicted for the pinv")


def test_each_pose_dwells_by_what_it_is_worth_to_the_target(make_rig, tmp_path):
    eng, writer = start(target_procedure("{attitude_error_deg: 0.03, max_seconds: 90}"), make_rig(), tmp_path)
    eng.prepare(resuming=False)
    eng.run()
    dwell = {s.name: s.stats.n_samples / 200 for s in load_session(writer.session_dir).info.steps}
    # the seed's verification poses lie above the horizon: +Z matters to all of them, -Z to few
    assert dwell["+Z up"] > 3 * dwell["-Z up"]


def test_progress_shows_the_prediction_against_the_target(make_rig, tmp_path):
    operator = Recorder()
    eng, _ = start(target_procedure("{attitude_error_deg: 0.03, max_seconds: 90}"), make_rig(), tmp_path, operator)
    eng.prepare(resuming=False)
    eng.run()
    shown = [p for p in operator.shown if p.phase == "capture"]
    assert shown and all(p.target == 0.03 and p.target_unit == "deg" and p.predicted > 0 for p in shown)
    assert shown[0].predicted > 0.03 >= shown[-1].predicted
    assert "predicted 0.0" in plain_progress_line(shown[0]) and ">0.03 deg" in plain_progress_line(shown[0])
    assert any(line.startswith("target met: max roll/pitch error") for line in operator.lines)


def test_a_per_parameter_sigma_target_is_met(make_rig, tmp_path):
    proc = target_procedure("{sigma: {accel.bias_*: 1.5, accel.alpha_*: 2.0e-4}, max_seconds: 90}")
    eng, writer = start(proc, make_rig(), tmp_path)
    eng.prepare(resuming=False)
    eng.run()
    record = target.calibration_record(load_session(writer.session_dir), load_session(writer.session_dir).step_means())
    assert record["met"] and len(record["sigma"]) == 6, record["summary"]
    assert all(s["predicted"] <= s["target"] for s in record["sigma"])
    assert max(s["predicted"] / s["target"] for s in record["sigma"]) > 0.85  # stopped when met, not later
    # what was predicted is what the solver reports: its GLS with the chip's wander between the poses
    cal = calib.solve(load_session(writer.session_dir).step_means(), thermal="off")
    predicted = {s["parameter"]: s["predicted"] for s in record["sigma"]}
    for j, a in enumerate("xyz"):
        assert predicted[f"accel.bias_{a}"] == pytest.approx(cal.sigma["bias_counts"][j], rel=1e-6)


def test_a_target_out_of_reach_even_at_the_datasheet_noise_is_refused_before_anything_moves(make_rig, tmp_path):
    rig = make_rig()
    eng, writer = start(target_procedure("{attitude_error_deg: 0.001, max_seconds: 60}"), rig, tmp_path)
    with pytest.raises(RigInputError, match=r"out of reach within max_seconds 60: even at the MPU-9150's datasheet") as exc:
        eng.prepare(resuming=False)
    assert exc.value.key == "target"
    assert [rig.axes[n].stage.get_position_deg() for n in STAGE_AXES] == [0.0, 0.0, 0.0]
    assert load_session(writer.session_dir).info.steps[0].status == "pending"


def test_a_time_cap_shorter_than_the_moves_is_refused_before_anything_moves(make_rig, tmp_path):
    eng, _ = start(target_procedure("{attitude_error_deg: 0.03, max_seconds: 20}"), make_rig(), tmp_path)
    with pytest.raises(RigInputError, match=r"20 s is less than the moves, settling and least dwell alone") as exc:
        eng.prepare(resuming=False)
    assert exc.value.key == "target.max_seconds"


def test_a_target_the_measured_noise_puts_out_of_reach_stops_at_the_first_pose_with_the_numbers(make_rig, tmp_path):
    rig = make_rig(errors={"noise_density_g_per_rthz": [1.2e-3] * 3})  # three times the datasheet noise
    eng, writer = start(target_procedure("{attitude_error_deg: 0.03, max_seconds: 45}"), rig, tmp_path)
    eng.prepare(resuming=False)  # the datasheet noise lets it through
    with pytest.raises(RunError) as exc:
        eng.run()
    message = str(exc.value)
    assert message.startswith("target cannot be met within max_seconds 45: with the noise measured so far")
    assert "the best reachable is max roll/pitch error" in message and "it needs about" in message
    assert "Stopped at the first pose" in message
    assert [rig.axes[n].stage.get_position_deg() for n in STAGE_AXES] == [0.0, 0.0, 0.0]  # nothing moved after +Z
    assert all(s.status == "pending" for s in load_session(writer.session_dir).info.steps)


def test_a_time_cap_a_little_short_of_the_target_is_respected_and_the_shortfall_said(make_rig, tmp_path):
    # seed 2: the first pose's first block estimates the noise within REFUSE_FACTOR of what the whole run
    # finds; for 3 of seeds 1-8 the estimate of 0.5 s of data is pessimistic enough that the first look
    # refuses the cap instead (that path is the test above)
    eng, writer = start(target_procedure("{attitude_error_deg: 0.03, max_seconds: 90}"), make_rig(seed=2), tmp_path / "a")
    eng.prepare(resuming=False)
    eng.run()
    needed = eng.session_time()
    cap = round(needed - 1.5, 2)
    operator = Recorder()
    eng, writer = start(target_procedure(f"{{attitude_error_deg: 0.03, max_seconds: {cap}}}"), make_rig(seed=2),
                        tmp_path / "b", operator)
    eng.prepare(resuming=False)
    eng.run()
    assert eng.session_time() <= cap
    (warning,) = operator.warnings
    assert warning.startswith(f"target cannot be met within max_seconds {cap:g}: with the noise measured so far")
    assert "going on as far as the cap allows" in warning
    (done,) = events(writer, "target")
    assert not done["met"] and done["predicted_attitude_error_deg"] > 0.03
    assert done["rig_time_s"] <= cap


def test_a_resumed_run_plans_from_the_poses_already_recorded(make_rig, tmp_path):
    proc = target_procedure("{attitude_error_deg: 0.03, max_seconds: 90}")
    eng, writer = start(proc, make_rig(), tmp_path)
    eng.prepare(resuming=False)
    for step in eng.steps[:3]:  # as if killed after the third pose
        targeted.execute(eng.ctx, step)
    t_stop = eng.session_time()
    writer.close()
    writer, first_step = SessionWriter.resume(writer.session_dir)
    assert first_step == 3
    again = make_rig()
    again.sensor.configure(proc.sensor_settings())
    eng = Engine(proc, again, writer, Recorder(), first_step=3, time_offset_s=t_stop + 1.0)
    eng.prepare(resuming=True)
    eng.run()
    (done,) = events(writer, "target")
    session = load_session(writer.session_dir)
    record = target.calibration_record(session, session.step_means())
    assert done["met"] and record["predicted_attitude_error_deg"] == pytest.approx(
        done["predicted_attitude_error_deg"], rel=1e-6)  # sample times as written to the CSV


@pytest.mark.parametrize("target, key, message", [
    ("{max_seconds: 60}", "target", "give attitude_error_deg or sigma"),
    ("{attitude_error_deg: 0.03}", "target.max_seconds", "missing required field"),
    ("{attitude_error_deg: 0.03, confidence: 1, max_seconds: 60}", "target.confidence", "expected < 1"),
    ("{attitude_error_deg: 0, max_seconds: 60}", "target.attitude_error_deg", "expected a number > 0"),
    ("{attitude_error_deg: 0.03, max_seconds: 0}", "target.max_seconds", "expected a number > 0"),
    ("{sigma: {gyro.bias_x: 1}, max_seconds: 60}", "target.sigma.gyro.bias_x", "unknown parameter"),
    ("{attitude_error_deg: 0.03, poses: [[0, 1]], max_seconds: 60}", "target.poses[0]", r"expected \[a1, a2, a3\]"),
])
def test_a_bad_target_is_one_line_naming_the_key(target, key, message):
    with pytest.raises(RigInputError, match=message) as exc:
        target_procedure(target)
    assert exc.value.key == key and exc.value.line == 6


@pytest.mark.parametrize("edit, key, message", [
    (("steps:\n", "dwell: {seconds: 2}\nsteps:\n"), "dwell", "dwell: and target: exclude each other"),
    (("solve: {model: triangular, method: pinv, thermal: auto}", "solve: {method: flip}"), "target",
     "predicted for the pinv solve"),
    (("solve: {model: triangular, method: pinv, thermal: auto}", "solve: null"), "target", "needs solve:"),
    (("  - pose: \"-Y up\"\n", "  - prompt: check the cable\n"), "steps: prompt", "has pose steps only"),
    (("{attitude_error_deg: 0.03, max_seconds: 90}", "{sigma: {accel.alpha_*: 1.0e-4}, max_seconds: 90}"
      "\n# full model\n"), None, None),
])
def test_a_target_the_rest_of_the_procedure_contradicts_is_refused(edit, key, message):
    text = TEXT.format(target="{attitude_error_deg: 0.03, max_seconds: 90}", six_faces=SIX_FACES_STEPS).replace(*edit)
    if key is None:  # the sigma names a parameter the full model lacks
        text = text.replace("model: triangular", "model: full")
        key, message = "target.sigma", "names no parameter of the full model"
    with pytest.raises(RigInputError, match=message) as exc:
        load_procedure_text(text, "unit.yaml")
    assert exc.value.key == key

"""The engine and each step executor, on in-process devices.

The rig here is the simulated world (emulated controllers, a register-level MPU-9150 or ADXL345,
the world model) with its controllers reached in memory (``ximcsim://`` URLs) through the real
``Stage`` and sensor drivers, in virtual time: every test runs in milliseconds through the code
that drives hardware. Sessions are real session directories in ``tmp_path``.
"""

from __future__ import annotations

import numpy as np
import pytest

from rig.config.procedure import load_procedure_text
from rig.config.rigfile import AxisConfig
from rig.errors import RigInputError
from rig.execution.context import EngineOptions, RunAborted, RunError
from rig.execution.engine import Engine
from rig.execution.executors import temperature
from rig.execution.operator import OperatorAbsent, SilentOperator
from rig.planning.kinematics import STAGE_AXES
from rig.session import SessionWriter, load_session
from rig.simulation.world import ChamberConfig

from engine_rig import make_rig, start as start_engine  # noqa: F401 - make_rig is a fixture

HEAD = """format: rig-procedure/1
name: unit
sensor: {{accel_range_g: 4, sample_rate_hz: 100{extra}}}
dwell: {{seconds: 1}}
settle: {{window_s: 0.3, threshold_g: 0.01, timeout_s: 20}}
steps:
"""


def procedure(steps: str, extra: str = ""):
    return load_procedure_text(HEAD.format(extra=extra) + steps, "unit.yaml")


def start(proc, rig, tmp_path, operator=None, **kw) -> tuple[Engine, SessionWriter]:
    """An engine on a fresh session; the manifest records no procedure text."""
    return start_engine(proc, rig, tmp_path, operator, text="", **kw)


def moving(rig) -> list[str]:
    return [n for n in STAGE_AXES if rig.axes[n].stage.get_status().running]


def test_static_steps_are_captured_checked_and_recorded_with_their_pose(make_rig, tmp_path):
    rig = make_rig()
    eng, writer = start(procedure('  - pose: "+Z up"\n  - pose: "+X up"\n'), rig, tmp_path)
    eng.prepare(resuming=False)
    outcomes = eng.run()
    assert [(o.status, o.n_samples) for o in outcomes] == [("complete", 100), ("complete", 100)]
    session = load_session(writer.session_dir)
    means = session.step_means()
    f = means.mean_counts / means.lsb_per_g
    assert np.allclose(f[0], [0, 0, 1], atol=0.1) and np.allclose(f[1], [1, 0, 0], atol=0.1)
    assert session.info.to_dict()["steps"][1]["stats"]["angles_measured_deg"] == pytest.approx([0, 0, -90], abs=0.02)


def test_an_unreachable_pose_is_refused_before_anything_moves(make_rig, tmp_path):
    rig = make_rig()
    a2 = rig.axes["a2"]
    a2.config = AxisConfig(port=a2.config.port, soft_limits_deg=(-100.0, 100.0), cable_wrap_deg=100.0)
    eng, writer = start(procedure('  - pose: "+Z up"\n  - angles_deg: [0, 150, 0]\n'), rig, tmp_path)
    with pytest.raises(RigInputError, match="a2"):
        eng.prepare(resuming=False)
    assert "move" not in (writer.session_dir / "events.jsonl").read_text()


def test_any_error_stops_every_motor(make_rig, tmp_path):
    rig = make_rig()
    class TerminalLost(SilentOperator):  # someone was there when the run started, then the terminal went
        def confirm(self, question):
            raise OperatorAbsent("the terminal went away")

    proc = procedure('  - angles_deg: [170, 80, 170]\n  - prompt: "Nobody will answer this"\n')
    eng, _ = start(proc, rig, tmp_path, operator=TerminalLost(answer=True))
    eng.prepare(resuming=False)
    for axis in rig.axes.values():  # start a long move so the motors run when the error comes
        axis.stage.move_deg(-170.0)
    with pytest.raises(OperatorAbsent):
        eng.run()
    assert moving(rig) == []


def test_an_interrupt_aborts_the_run_and_stops_the_motors(make_rig, tmp_path):
    rig = make_rig()

    class Interrupting(SilentOperator):
        def progress(self, p):
            if p.phase == "capture":
                raise KeyboardInterrupt

    eng, _ = start(procedure('  - pose: "+Z up"\n'), rig, tmp_path, operator=Interrupting())
    eng.prepare(resuming=False)
    with pytest.raises(RunAborted, match="interrupted"):
        eng.run()
    assert moving(rig) == []


def test_a_prompt_waits_for_the_operator_and_an_abort_ends_the_run(make_rig, tmp_path):
    eng, writer = start(procedure('  - prompt: "Mount the sensor"\n  - pose: "+Z up"\n'), make_rig(), tmp_path / "yes",
                        operator=SilentOperator(answer=True))
    eng.prepare(resuming=False)
    eng.run()
    assert load_session(writer.session_dir).info.to_dict()["steps"][0]["status"] == "complete"
    eng, _ = start(procedure('  - prompt: "Mount the sensor"\n  - pose: "+Z up"\n'), make_rig(), tmp_path / "no",
                   operator=SilentOperator(answer=False))
    eng.prepare(resuming=False)
    with pytest.raises(RunAborted, match="operator aborted at step 1"):
        eng.run()


def test_a_rate_step_captures_only_the_constant_rate_part_and_renumbers_the_axis(make_rig, tmp_path):
    rig = make_rig()
    proc = procedure('  - pose: "+Z up"\n  - {rate: {axis: a1, rate_deg_s: 40, seconds: 2}, name: "z +40"}\n')
    eng, writer = start(proc, rig, tmp_path)
    eng.prepare(resuming=False)
    outcome = eng.run()[-1]
    assert outcome.status == "complete" and outcome.n_samples == 200
    stats = load_session(writer.session_dir).info.to_dict()["steps"][1]["stats"]
    assert stats["stage_rate_deg_s"] == pytest.approx([40, 40], abs=0.05)
    assert -180 < rig.axes["a1"].stage.get_position_deg() <= 180
    assert moving(rig) == []


def test_a_spin_beyond_the_cable_wrap_is_refused_before_anything_moves(make_rig, tmp_path):
    rig = make_rig()  # in-process axes have no slip ring and a 400 deg cable wrap
    eng, writer = start(procedure('  - pose: "+Z up"\n  - {rate: {axis: a1, rate_deg_s: 40, seconds: 20}}\n'),
                        rig, tmp_path)
    with pytest.raises(RigInputError, match="slip_ring: true"):
        eng.prepare(resuming=False)
    assert "move" not in (writer.session_dir / "events.jsonl").read_text()


def test_a_temperature_step_sets_the_chamber_and_waits_until_the_sensor_holds_it(make_rig, tmp_path):
    rig = make_rig(chamber=ChamberConfig(initial_c=25.0, tau_s=30.0))
    proc = procedure("  - temperature: {target_c: 30, tolerance_c: 0.3, hold_s: 10, timeout_s: 900, mode: wait}\n"
                     '  - pose: "+Z up"\n')
    eng, writer = start(proc, rig, tmp_path)
    eng.prepare(resuming=False)
    eng.run()
    session = load_session(writer.session_dir)
    assert session.info.to_dict()["steps"][0]["stats"]["temp_c"] == pytest.approx(30, abs=0.3)
    assert np.nanmean(session.step_samples(1)["temp_c"]) == pytest.approx(30, abs=0.5)
    assert '"start_c"' in (writer.session_dir / "events.jsonl").read_text()


def test_a_temperature_step_on_a_sensor_without_thermometer_is_refused_up_front(make_rig, tmp_path):
    proc = procedure("  - temperature: {target_c: 30, tolerance_c: 0.3, hold_s: 10, timeout_s: 900}\n"
                     '  - pose: "+Z up"\n')
    eng, _ = start(proc, make_rig(model="ADXL345"), tmp_path)
    with pytest.raises(RunError, match="has none"):
        eng.prepare(resuming=False)


def test_a_resume_after_a_temperature_step_restores_its_set_point(make_rig, tmp_path):
    proc = procedure("  - temperature: {target_c: 35, tolerance_c: 0.3, hold_s: 5, timeout_s: 1800, mode: wait}\n"
                     '  - pose: "+Z up"\n')
    first = make_rig(chamber=ChamberConfig(initial_c=25.0, tau_s=30.0))
    eng, writer = start(proc, first, tmp_path)
    eng.prepare(resuming=False)
    temperature.execute(eng.ctx, eng.steps[0])  # only the temperature step, as if killed after it
    writer.close()
    writer, first_step = SessionWriter.resume(writer.session_dir)
    assert first_step == 1
    again = make_rig(chamber=ChamberConfig(initial_c=25.0, tau_s=30.0))  # the chamber cooled while stopped
    again.sensor.configure(proc.sensor_settings())
    eng = Engine(proc, again, writer, SilentOperator(), first_step=1, time_offset_s=1000.0)
    eng.prepare(resuming=True)
    eng.run()
    temps = load_session(writer.session_dir).step_samples(1)["temp_c"]
    assert np.nanmean(temps) == pytest.approx(35, abs=0.5)


def test_a_rig_that_needs_no_settling_captures_from_the_first_sample(make_rig, tmp_path):
    rig = make_rig()
    rig.settle = "none"
    eng, writer = start(procedure('  - pose: "+Z up"\n'), rig, tmp_path, options=EngineOptions())
    eng.prepare(resuming=False)
    eng.run()
    assert '"settle"' not in (writer.session_dir / "events.jsonl").read_text()

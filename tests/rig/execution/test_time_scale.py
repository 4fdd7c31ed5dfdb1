"""Samples lost because a time-scaled simulated clock outran this machine are said to be that, not the
sensor's fault; a time scale the machine cannot keep up with is refused before recording, and one
that loses samples during the run stops it (resumable) instead of leaving a hole in the session.

The rigs here are the in-process simulated rig (``open_in_process_rig``). Overflow is made certain,
not likely: a 1 kHz MPU-9150 at time scale 1000 produces a million samples per wall second into a
FIFO of 73, which no machine drains through a Python I2C model (tens of microseconds a transfer).
A rig whose clock keeps wall time loses samples deterministically through a sensor whose reads
report an overflow.
"""

from __future__ import annotations

import json
import re

import pytest

from drivers.clock import VirtualClock
from rig.config.procedure import load_procedure_text
from rig.errors import RigInputError
from rig.execution.capture import SamplesLost
from rig.execution.engine import Engine, check_before_recording
from rig.execution.operator import SilentOperator
from rig.planning.kinematics import STAGE_AXES
from rig.session import SessionWriter, load_session
from rig.simulation.simrig import SimSettings, SimulatedRig
from rig.simulation.simulated import ScaledClock, nice_below, open_in_process_rig
from rig.workflow.lifecycle import session_columns

HEAD = """format: rig-procedure/1
name: unit
sensor: {{accel_range_g: 4, sample_rate_hz: {rate}}}
dwell: {{seconds: 1}}
settle: {{window_s: 0.3, threshold_g: 0.01, timeout_s: 20}}
steps:
"""
REFUSAL = re.compile(r"^--time-scale 1000: this machine keeps up with about [0-9.]+x for a 1 kHz MPU-9150; "
                     r"use --time-scale (?:[0-9.]+ or 0|0) \(virtual time\)$")
OUTRAN = "the simulated clock (--time-scale 1000) outran this machine"


def procedure(steps: str, rate: int = 1000):
    return load_procedure_text(HEAD.format(rate=rate) + steps, "unit.yaml")


@pytest.fixture
def make_rig(request):
    rigs = []

    def make(time_scale: float, seed: int = 1):
        sim = SimulatedRig(SimSettings(time_scale=time_scale, clock="strict"), seed=seed)
        rig = open_in_process_rig(sim, name=f"{request.node.name}-{len(rigs)}")
        rigs.append(rig)
        return sim, rig

    yield make
    for rig in rigs:
        rig.close()


def start(proc, rig, tmp_path, first_step: int = 0) -> tuple[Engine, SessionWriter]:
    rig.sensor.configure(proc.sensor_settings())
    manifest = {"procedure": {"name": proc.name, "text": "", "file": None}, "rig": rig.describe(),
                "software": {"name": "test"}, "steps": [s.to_manifest() for s in proc.expanded_steps()]}
    writer = SessionWriter.create(tmp_path, "unit", manifest, columns=session_columns(proc, rig))
    return Engine(proc, rig, writer, SilentOperator(), first_step=first_step), writer


def moving(rig) -> list[str]:
    return [n for n in STAGE_AXES if rig.axes[n].stage.get_status().running]


def test_samples_lost_to_the_scaled_clock_stop_the_run_and_say_the_clock_outran_the_machine(make_rig, tmp_path):
    _, rig = make_rig(1000)
    eng, writer = start(procedure('  - pose: "+Z up"\n  - pose: "-Z up"\n'), rig, tmp_path)
    eng.prepare(resuming=False, preflight=False)  # as if the machine had kept up when the run started
    with pytest.raises(SamplesLost) as caught:
        eng.run()
    line = str(caught.value)
    assert "\n" not in line and line.startswith("step 1 (+Z up): sensor FIFO overflowed ")
    assert OUTRAN in line and "the simulated sensor itself lost nothing" in line
    assert "use --time-scale " in line and "or 0 (virtual time)" in line
    assert re.search(rf"resume with: rig run --resume {re.escape(str(writer.session_dir))} --time-scale [0-9.]+$", line)
    assert moving(rig) == []
    steps = load_session(writer.session_dir).info.to_dict()["steps"]
    assert [s["status"] for s in steps] == ["pending", "pending"]  # nothing recorded with a hole
    events = [json.loads(x) for x in (writer.session_dir / "events.jsonl").read_text().splitlines()]
    again = [e for e in events if e["kind"] == "warning" and e.get("source") == "clock"]
    assert len(again) == 2 and all(OUTRAN in e["message"] for e in again)  # measured again, then stopped


def test_a_moments_loss_at_a_time_scale_is_measured_again_and_leaves_no_flag(make_rig, tmp_path):
    _, rig = make_rig(2)  # a 100 Hz sensor at twice real time: any machine keeps up
    sensor = rig.sensor
    read, hiccups = sensor.read, [1]

    def read_after_one_hiccup():  # once, the machine came back too late (another process, a GC pause)
        if hiccups and sensor.stats.received:
            hiccups.pop()
            sensor.stats.overflows += 1
            sensor.stats.dropped += 3
        return read()

    eng, writer = start(procedure('  - pose: "+Z up"\n', rate=100), rig, tmp_path)
    eng.prepare(resuming=False, preflight=False)
    sensor.read = read_after_one_hiccup
    outcomes = eng.run()
    assert [(o.status, o.n_samples, o.problems) for o in outcomes] == [("complete", 100, [])]
    events = (writer.session_dir / "events.jsonl").read_text()
    assert "measuring step 1 again" in events and "outran this machine" in events


def test_a_rate_step_that_loses_samples_to_the_scaled_clock_stops_the_run_too(make_rig, tmp_path):
    _, rig = make_rig(1000)
    proc = procedure('  - pose: "+Z up"\n  - {rate: {axis: a1, rate_deg_s: 20, seconds: 2}, name: "z +20"}\n')
    eng, writer = start(proc, rig, tmp_path, first_step=1)  # the rate step alone (a pose step would stop first)
    eng.prepare(resuming=False, preflight=False)
    with pytest.raises(SamplesLost, match=re.escape("step 2 (z +20): sensor FIFO overflowed")) as caught:
        eng.run()
    assert OUTRAN in str(caught.value)
    assert moving(rig) == []
    assert load_session(writer.session_dir).info.to_dict()["steps"][1]["status"] == "pending"


def test_a_wall_clock_rig_that_loses_samples_blames_this_computer_flags_the_step_and_goes_on(make_rig, tmp_path):
    _, rig = make_rig(0)
    sensor = rig.sensor
    read = sensor.read

    def read_after_an_overflow():  # the host came back too late: the driver found the FIFO overflowed
        sensor.stats.overflows += 1
        sensor.stats.dropped += 3
        return read()

    eng, writer = start(procedure('  - pose: "+Z up"\n  - pose: "-Z up"\n', rate=100), rig, tmp_path)
    eng.prepare(resuming=False)
    sensor.read = read_after_an_overflow
    outcomes = eng.run()
    assert [o.status for o in outcomes] == ["flagged", "flagged"]
    problem = outcomes[0].problems[0]
    assert re.fullmatch(r"sensor FIFO overflowed \d+ time\(s\), \d+ samples lost: this computer did not read the "
                        r"sensor's FIFO before it filled \(was it busy\?\)", problem), problem
    assert "simulated clock" not in problem


def test_a_time_scale_far_beyond_the_machine_is_refused_before_anything_moves(make_rig, tmp_path):
    _, rig = make_rig(1000)
    with pytest.raises(RigInputError) as caught:
        check_before_recording(procedure('  - pose: "+Z up"\n'), rig, SilentOperator())
    assert REFUSAL.match(str(caught.value)), str(caught.value)
    assert moving(rig) == []


def test_a_time_scale_the_machine_keeps_up_with_passes_and_is_measured(make_rig):
    _, rig = make_rig(1)  # a 100 Hz sensor in real time: 100 samples a wall second
    check_before_recording(procedure('  - pose: "+Z up"\n', rate=100), rig, SilentOperator())
    assert isinstance(rig.clock, ScaledClock) and rig.clock.keeps_up_x > 1
    assert rig.clock.sensor == "100 Hz MPU-9150"


def test_virtual_time_is_neither_probed_nor_wrapped(make_rig):
    sim, rig = make_rig(0)
    assert isinstance(rig.clock, VirtualClock) and rig.clock is sim.clock
    transfers = sim.bus.transfers
    check_before_recording(procedure('  - pose: "+Z up"\n'), rig, SilentOperator())
    assert sim.bus.transfers == transfers  # the sensor was not touched: the random draws stay the recorded ones


def test_suggested_time_scales_are_round_and_not_above_what_the_machine_keeps_up_with():
    assert [nice_below(x) for x in (37, 120, 10, 9.99, 1.3, 0.5, 0.12, 0.05)] == [20, 100, 10, 5, 1, 0.5, 0.1, None]

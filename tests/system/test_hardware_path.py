"""The code a lab runs on real stages is the code CI runs: a rig file of kind ``hardware``.

The simulated world is started in this process (three emulated controllers on pseudo-terminals,
a simulated MPU-9150 on an in-process I2C bus that the world publishes as ``bus: simbus``). The rig
file names those pseudo-terminals as its controllers' ports, exactly as a lab names
``/dev/ximc/...``, and ``rig run --rig`` opens it through the hardware opener (a wall clock,
pyserial stages, the bus by name). Nothing in the run knows it is simulated.

Time: a hardware rig keeps wall time (``MonotonicClock``), so the simulated world behind the ports
must run at the same pace as the runner's clock. At time scale 1 the six faces took 23-25 s, nearly
all of it the stages turning at 48 deg/s and the 1 s dwells, in wall time. Both clocks run
``TIME_SCALE`` times faster here instead (the hardware opener's ``MonotonicClock`` with that scale,
the simulated world at that scale): the same opener, pyserial over the same pseudo-terminals, the
same named bus and the same samples per pose (1 s of the sensor's time at 100 Hz), half the wall time
(issue 26). Not faster: like hardware, the world does not wait for a late reader, and at 2x the FIFO
(73 samples, read when a quarter is full) still leaves 0.27 s of wall time for a busy CI machine.
"""

from __future__ import annotations

import pytest
import yaml

from calib.file import calibration as calfile
from drivers.clock import MonotonicClock
from rig.cli import main
from rig.devices import hardware
from rig.simulation.simrig import SimSettings, SimulatedRig
from rig.simulation.simulated import publish_bus, withdraw_bus

from conftest import SIX_FACES_STEPS

PROCEDURE = """format: rig-procedure/1
name: six_position_quick
description: The six faces, 1 s each (real time).
sensor: {accel_range_g: 4, sample_rate_hz: 100}
dwell: {seconds: 1}
settle: {window_s: 0.3, threshold_g: 0.01, timeout_s: 10}
steps:
""" + SIX_FACES_STEPS + """solve: {model: triangular, method: pinv, thermal: off}
"""
#: simulated seconds per wall second of both the simulated world and the hardware rig's clock
TIME_SCALE = 2.0

pytestmark = [pytest.mark.pty, pytest.mark.realtime]


def test_a_hardware_rig_file_on_emulator_ports_and_a_named_bus_runs_end_to_end(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(hardware, "MonotonicClock", lambda: MonotonicClock(time_scale=TIME_SCALE))
    # strict: hardware never waits for its reader, so neither may the world behind the ports
    sim = SimulatedRig(SimSettings(time_scale=TIME_SCALE, clock="strict"), seed=11)
    ports = sim.start()
    publish_bus(sim, "simbus")
    try:
        axis = {"sign": 1, "speed_deg_s": 48, "accel_deg_s2": 200, "soft_limits_deg": [-400, 400],
                "cable_wrap_deg": 400}
        rig_file = {"format": "rig-file/1", "name": "lab-table-on-emulators", "kind": "hardware", "home": "zero",
                    "turntable": {"axes": {n: {"port": ports[n], "serial": sim.emulators[i].serial_number, **axis}
                                           for i, n in enumerate(("a1", "a2", "a3"))}},
                    "sensor": {"model": "MPU-9150", "bus": "simbus", "address": 0x68}}
        (tmp_path / "lab.yaml").write_text(yaml.safe_dump(rig_file, sort_keys=False))
        (tmp_path / "quick.yaml").write_text(PROCEDURE)
        code = main(["run", str(tmp_path / "quick.yaml"), "--rig", str(tmp_path / "lab.yaml"),
                     "--out", str(tmp_path / "sessions"), "--quiet"])
        assert code == 0, capsys.readouterr().err
    finally:
        withdraw_bus("simbus")
        sim.stop()
    (session,) = (tmp_path / "sessions").iterdir()
    manifest = yaml.safe_load((session / "session.yaml").read_text())
    assert manifest["status"] == "complete"
    assert manifest["rig"]["turntable"]["kind"] == "standa-8smc"
    assert [manifest["rig"]["turntable"]["axes"][n]["port"] for n in ("a1", "a2", "a3")] == \
        [ports[n] for n in ("a1", "a2", "a3")]
    assert not (session / "sim_truth.yaml").exists()  # a hardware rig has no hidden truth to attach
    cal = calfile.read(session / "calibration.yaml").accelerometer
    truth = sim.truth()["accelerometer"]
    lsb = cal.lsb_per_g
    for j in range(3):  # 1 s per pose: the bias is within a few sigma of the simulator's
        true_bias = truth["bias_g"][j] * lsb
        assert abs(cal.bias_counts[j] - true_bias) < 6 * cal.sigma["bias_counts"][j] + 2.0

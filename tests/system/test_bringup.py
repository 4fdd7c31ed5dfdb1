"""Bringing up a rig (issue 33, item 6): ``rig check`` reaches every controller and the sensor and says who
answers, one line each, moving nothing; ``rig jog`` turns one axis by a few confirmed degrees and Ctrl-C stops
it; ``rig ports`` says what its columns mean. Against the simulated rig: the emulated controllers (here in
process, ``ximcsim://``, or on pseudo-terminals) and the simulated chip on a named bus, reached through the
hardware code path from a ``kind: hardware`` rig file."""

from __future__ import annotations

import _thread
import os
import re
import signal
import subprocess
import sys

import pytest
import yaml

from drivers.ximc.sim.protocol_ximcsim import attach, detach
from rig.cli import main
from rig.config.rigfile import load_rig_file
from rig.devices.bringup import open_axis, rig_file_path
from rig.devices.jog import jog, plan_jog
from rig.simulation.simrig import SimSettings, SimulatedRig
from rig.simulation.simulated import publish_bus, withdraw_bus

from conftest import REPO, RIGS

AXIS = {"sign": 1, "speed_deg_s": 20, "accel_deg_s2": 40, "soft_limits_deg": [-400, 400], "cable_wrap_deg": 400}


@pytest.fixture
def lab():
    """Three emulated controllers reachable as ``ximcsim://`` ports and a simulated MPU-9150 on ``bus: checkbus``."""
    sim = SimulatedRig(SimSettings(time_scale=1, clock="strict"), seed=5)  # the wall time of hardware
    ports = {n: attach(f"check-{n}", emu.controller) for n, emu in zip(("a1", "a2", "a3"), sim.emulators)}
    publish_bus(sim, "checkbus")
    yield sim, ports
    withdraw_bus("checkbus")
    for n in ports:
        detach(f"check-{n}")


def _hardware_rig(tmp_path, sim, ports, **change) -> str:
    axes = {n: {"port": ports[n], "serial": sim.emulators[i].serial_number, **AXIS} for i, n in enumerate(ports)}
    doc = {"format": "rig-file/1", "name": "bench", "kind": "hardware", "home": "zero", "turntable": {"axes": axes},
           "sensor": {"model": "MPU-9150", "bus": "checkbus", "address": 0x68}}
    for path, value in change.items():  # a2__serial=1 -> turntable.axes.a2.serial
        *parents, key = path.split("__")
        where = doc["sensor"] if parents == ["sensor"] else doc["turntable"]["axes"][parents[0]]
        where[key] = value
    p = tmp_path / "bench.yaml"
    p.write_text(yaml.safe_dump(doc, sort_keys=False))
    return str(p)


def test_check_of_the_simulated_rig_reads_every_part_in_one_line_each(capsys):
    assert main(["check", "sim"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [ln.split()[:2] for ln in lines[:4]] == [["ok", "a1"], ["ok", "a2"], ["ok", "a3"], ["ok", "sensor"]]
    for ln in lines[:3]:
        assert re.search(r"serial \d+  firmware \d+\.\d+\.\d+ .* at 0\.000 deg \(inside soft limits -400\.\.400\)"
                         r"  speed limit 48 deg/s \(rig file 20\)  limit switch free", ln), ln
    assert "MPU-9150 at 0x68 on bus sim: WHO_AM_I 0x68 (register 0x75), as expected" in lines[3]
    assert lines[4] == "all 4 parts answer (a1, a2, a3, sensor); nothing moved"
    assert rig_file_path("sim") == (RIGS / "sim.yaml").resolve()  # the rig `rig run --rig sim` opens


def test_check_of_a_hardware_rig_file_names_each_failure_and_moves_nothing(lab, tmp_path, capsys):
    sim, ports = lab
    rig = _hardware_rig(tmp_path, sim, ports, a2__serial=99, a3__port=str(tmp_path / "ttyACM9"), sensor__address=0x69)
    settings_before = [emu.controller.move_settings for emu in sim.emulators]
    assert main(["check", rig]) == 2
    said = capsys.readouterr()
    out = said.out.splitlines()
    assert out[0].startswith(f"ok    a1  {ports['a1']}  serial {sim.emulators[0].serial_number}  firmware ")
    assert out[1].startswith("FAIL  a2") and out[1].endswith(
        f"; serial {sim.emulators[1].serial_number}, the rig file expects 99 (another controller on this port: "
        "swapped cables or port names?)")
    assert out[2].startswith(f"FAIL  a3  {tmp_path / 'ttyACM9'}: cannot open (no such file or directory): is the "
                             "controller plugged in")
    assert out[3].startswith("FAIL  sensor  MPU-9150 at 0x69 on bus checkbus: no answer")
    assert len(out) == 4
    assert said.err.splitlines() == [f"rig check: {rig}: 3 of 4 parts failed (a2, a3, sensor); nothing moved"]
    for emu, before in zip(sim.emulators, settings_before):  # queries only: nothing moved, nothing written
        now = sim.clock.now()
        assert emu.position_deg_at(now) == 0.0 and emu.speed_deg_s_at(now) == 0.0
        assert emu.controller.move_settings == before


def test_check_names_a_bus_that_is_not_there(lab, tmp_path, capsys):
    sim, ports = lab
    assert main(["check", _hardware_rig(tmp_path, sim, ports, sensor__bus="nosuchbus")]) == 2
    (sensor,) = [ln for ln in capsys.readouterr().out.splitlines() if "sensor" in ln]
    assert sensor.startswith("FAIL  sensor  I2C bus nosuchbus: ") and "no I2C bus named 'nosuchbus'" in sensor


def test_check_of_a_simulated_rig_that_does_not_open_is_one_failed_part(tmp_path, capsys):
    rig = yaml.safe_load((RIGS / "sim.yaml").read_text())
    rig["faults"] = {"ximc": {"a2": {"error_answer_rate": 1.0, "error_answer": "errc"}}}  # a2 refuses everything
    (tmp_path / "mute.yaml").write_text(yaml.safe_dump(rig))
    assert main(["check", str(tmp_path / "mute.yaml")]) == 2
    said = capsys.readouterr()
    (line,) = said.out.splitlines()
    assert line.startswith(f"FAIL  rig  {tmp_path / 'mute.yaml'}: the simulated rig did not open: a2 ") and "errc" in line
    assert said.err.splitlines() == [f"rig check: {tmp_path / 'mute.yaml'}: 1 of 1 parts failed (rig); nothing moved"]


def test_check_of_a_file_that_is_not_a_rig_file_is_one_line_exit_2(tmp_path, capsys):
    bad = tmp_path / "r.yaml"
    bad.write_text("format: rig-file/1\nname: x\nkind: hardwre\n")
    assert main(["check", str(bad)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(f"rig check: {bad}:3: kind: "), err


def test_jog_turns_one_axis_by_the_kinematic_step_in_the_rig_files_direction(lab, tmp_path, capsys):
    sim, ports = lab
    rig = _hardware_rig(tmp_path, sim, ports, a2__sign=-1, a2__home_offset_deg=10)
    assert main(["jog", rig, "a2", "5", "--yes"]) == 0
    said = capsys.readouterr()
    assert said.out.strip() == "moved a2 by +5 deg: a2 at -5.000 deg on the controller (kinematic 15.000 deg)"
    assert "rig jog: moving a2 by +5 deg (Ctrl-C stops it)" in said.err
    now = sim.clock.now()
    assert [round(e.position_deg_at(now), 6) for e in sim.emulators] == [0.0, -5.0, 0.0]


@pytest.mark.parametrize("argv, says", [
    (["a1", "11", "--yes"], "rig jog: DEG: expected a non-zero step of at most 10 deg either way, got 11"),
    (["a1", "0", "--yes"], "rig jog: DEG: expected a non-zero step"),
    (["a1", "nan", "--yes"], "rig jog: DEG: expected a non-zero step"),
    (["a4", "1", "--yes"], "rig: argument axis: invalid choice: 'a4'"),
    (["a3", "-6", "--yes"], "rig jog: turntable.axes.a3.soft_limits_deg: a jog to -6.000 deg leaves the soft limits "
                            "[-5, 5] deg (the controller is at 0.000 deg)"),
    (["a1", "2"], "needs a confirmation: run it on a terminal or add --yes"),
])
def test_jog_refuses_a_step_too_large_beyond_the_soft_limits_or_unconfirmed(lab, tmp_path, capsys, argv, says):
    sim, ports = lab
    rig = _hardware_rig(tmp_path, sim, ports, a3__soft_limits_deg=[-5, 5])
    assert main(["jog", rig, *argv]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and says in err[0], err
    now = sim.clock.now()
    assert [e.position_deg_at(now) for e in sim.emulators] == [0.0, 0.0, 0.0]


def test_ctrl_c_during_a_jog_stops_the_motor_where_it_is(tmp_path):
    rig = yaml.safe_load((RIGS / "sim.yaml").read_text())
    rig["sim"]["time_scale"] = 1
    rig["turntable"]["axes"]["a1"]["speed_deg_s"] = 2  # 10 deg take 5 s
    (tmp_path / "slow.yaml").write_text(yaml.safe_dump(rig))
    rig_file = load_rig_file(tmp_path / "slow.yaml")
    stage, close = open_axis(rig_file, "a1")
    try:
        plan = plan_jog("a1", rig_file.axes["a1"], stage, 10)
        result = jog(plan, rig_file.axes["a1"], stage, on_start=_thread.interrupt_main)
        assert result.interrupted and 0 <= result.at_deg < 1
        stage.clock.sleep(0.3)
        assert stage.get_position_deg() == result.at_deg  # stopped, not coasting on
    finally:
        close()


def test_sigint_to_the_rig_jog_program_stops_the_motor_and_says_where(tmp_path):
    rig = yaml.safe_load((RIGS / "sim.yaml").read_text())
    rig["sim"]["time_scale"] = 1
    rig["turntable"]["axes"]["a1"]["speed_deg_s"] = 2
    (tmp_path / "slow.yaml").write_text(yaml.safe_dump(rig))
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen([sys.executable, "-m", "rig.cli", "jog", str(tmp_path / "slow.yaml"), "a1", "10", "--yes"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path)
    try:
        assert proc.stderr.readline().startswith("rig jog: moving a1 by +10 deg")
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 1, err
    m = re.fullmatch(r"rig jog: interrupted by the operator; motor stopped: a1 at (\S+) deg on the controller "
                     r"\(kinematic \S+ deg\)\n", err)
    assert m and 0 <= float(m[1]) < 9, err
    assert out == ""


def test_ports_says_what_its_columns_mean(capsys):
    assert main(["ports"]) == 0
    out = capsys.readouterr().out
    assert "columns: serial DEVICE  DESCRIPTION  VID:PID  WHAT ANSWERED" in out
    assert "n/a: the port has no USB description (a built-in serial port such as /dev/ttyS0" in out
    assert "Standa 8SMC4/8SMC5 controllers are 1CBE:0007" in out
    assert "MPU-9150 at 0x68" in out and "ADXL345 at 0x53" in out

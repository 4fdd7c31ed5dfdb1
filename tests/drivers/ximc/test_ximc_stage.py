"""The Stage driver against the emulator over a pseudo-terminal: units, motion, faults."""

from __future__ import annotations

import pytest

from drivers.clock import VirtualClock
from drivers.ximc import protocol as P
from drivers.ximc.sim.emulator import ControllerEmulator, XimcFaults
from drivers.ximc.stage import Stage, TurntableError


def _rig(faults=None, **kw):
    clock = VirtualClock()
    emu = ControllerEmulator(1234, clock=clock, faults=faults)
    path = emu.start()
    events = []
    stage = Stage(path, clock=clock, name="a2", on_event=lambda k, d: events.append((k, d)), **kw)
    return clock, emu, stage, events


@pytest.fixture
def rig():
    clock, emu, stage, events = _rig()
    stage.open()
    yield clock, emu, stage, events
    stage.close()
    emu.stop()


def test_degrees_map_to_full_steps_and_microsteps(rig):
    clock, emu, stage, _ = rig
    stage.move_deg(12.345678)
    stage.command_wait_for_stop()
    pos = stage.get_position()
    # 0.01 deg per full step, 256 microsteps per step
    assert pos.Position * 256 + pos.uPosition == round(12.345678 / 0.01 * 256)
    assert stage.get_position_deg() == pytest.approx(12.345678, abs=0.01 / 256)
    assert emu.position_deg_at(clock.now()) == pytest.approx(stage.get_position_deg(), abs=1e-12)


def test_motion_is_a_trapezoid_with_running_flags(rig):
    clock, emu, stage, _ = rig
    stage.set_speed_deg_s(20.0, accel_deg_s2=40.0)
    t0 = clock.now()
    stage.move_deg(90.0)
    st = stage.get_status()
    assert st.running and st.MvCmdSts & P.MVCMD_NAME_MASK == P.MVCMD_MOVE
    clock.sleep(2.0)
    assert stage.get_status().MoveSts & P.MOVE_STATE_TARGET_SPEED
    assert emu.speed_deg_s_at(clock.now()) == pytest.approx(20.0)
    stage.command_wait_for_stop()
    # 0.5 s up to speed, 4 s cruise, 0.5 s down: 5 s in all
    assert clock.now() - t0 == pytest.approx(5.0, abs=0.03)
    assert not stage.get_status().running


def test_continuous_rotation_and_soft_stop(rig):
    clock, emu, stage, _ = rig
    stage.set_speed_deg_s(25.0, accel_deg_s2=50.0)
    stage.rotate_continuous(-25.0)
    clock.sleep(3.0)
    assert emu.speed_deg_s_at(clock.now()) == pytest.approx(-25.0)
    stage.command_sstp()
    stage.command_wait_for_stop()
    assert emu.speed_deg_s_at(clock.now()) == 0.0


def test_speed_above_the_stage_limit_is_refused(rig):
    _, _, stage, _ = rig
    with pytest.raises(TurntableError, match="48 deg/s"):
        stage.set_speed_deg_s(60.0)


def test_identify(rig):
    _, _, stage, _ = rig
    ident = stage.identify()
    assert ident.serial_number == 1234 and ident.firmware == "4.3.8" and ident.device["manufacturer"] == "XIMC"


@pytest.mark.parametrize("faults", [XimcFaults(crc_corrupt_rate=0.05, seed=1), XimcFaults(truncate_rate=0.05, seed=2),
                                    XimcFaults(drop_rate=0.05, seed=3), XimcFaults(error_answer_rate=0.05, seed=4)])
def test_recoverable_faults_are_recovered_and_reported(faults):
    clock, emu, stage, events = _rig(faults, timeout_s=0.05)
    try:
        stage.open()
        for i in range(30):
            stage.move_deg(i * 0.5)
            stage.command_wait_for_stop()
            assert stage.get_position_deg() == pytest.approx(i * 0.5, abs=1e-9)
        assert stage.recovered > 0
        assert any(k == "recovered" for k, _ in events)
    finally:
        stage.close()
        emu.stop()


def test_permanent_silence_raises_one_line_naming_axis_port_and_command():
    clock, emu, stage, _ = _rig(XimcFaults(drop_rate=1.0), timeout_s=0.05, retries=3)
    try:
        with pytest.raises(TurntableError) as e:
            stage.open()
        msg = str(e.value)
        assert msg.startswith(f"a2 {stage.port}: geng: no valid answer after 3 tries")
        assert "\n" not in msg
    finally:
        emu.stop()


def test_stall_short_of_target_is_an_error_not_a_silent_position():
    clock, emu, stage, _ = _rig(XimcFaults(stall_at_deg=30.0))
    try:
        stage.open()
        stage.move_deg(90.0)
        with pytest.raises(TurntableError, match="stalled"):
            stage.command_wait_for_stop()
        assert stage.get_position_deg() == pytest.approx(30.0, abs=1e-6)
    finally:
        stage.close()
        emu.stop()


def test_limit_switch_stops_the_move_with_an_edge_flag():
    clock, emu, stage, _ = _rig(XimcFaults(limit_deg=-10.0))
    try:
        stage.open()
        stage.move_deg(-45.0)
        with pytest.raises(TurntableError, match="limit switch"):
            stage.command_wait_for_stop()
        assert stage.get_status().GPIOFlags & P.STATE_LEFT_EDGE
    finally:
        stage.close()
        emu.stop()


def test_port_that_vanishes_mid_move_and_comes_back_is_reopened_by_its_stable_path():
    clock = VirtualClock()
    emu = ControllerEmulator(77, clock=clock, faults=XimcFaults(vanish_at_s=1.0, vanish_for_s=0.5))
    emu.start()
    events = []
    stage = Stage(emu.stable_path, clock=clock, name="a1", on_event=lambda k, d: events.append(k),
                  timeout_s=0.05, reopen_s=3.0)
    try:
        stage.open()
        stage.move_deg(45.0)
        stage.command_wait_for_stop()  # the port disappears at t=1 s and returns at 1.5 s
        assert stage.get_position_deg() == pytest.approx(45.0)
        assert emu.replugged  # the pty really went away and a new one was made
        assert "reconnected" in events
    finally:
        stage.close()
        emu.stop()


def test_port_that_never_comes_back_raises():
    clock = VirtualClock()
    emu = ControllerEmulator(78, clock=clock, faults=XimcFaults(vanish_at_s=0.5, vanish_for_s=1e9))
    emu.start()
    stage = Stage(emu.stable_path, clock=clock, name="a3", timeout_s=0.05, reopen_s=0.5)
    try:
        stage.open()
        stage.move_deg(45.0)
        with pytest.raises(TurntableError, match="a3 .*did not come back"):
            stage.command_wait_for_stop()
    finally:
        stage.close()
        emu.stop()


def test_unknown_command_and_bad_crc_get_controller_error_answers(rig):
    clock, emu, stage, _ = rig
    ser = stage._ser
    ser.write(b"abcd")
    assert ser.read(4) == b"errc"
    bad = bytearray(P.encode_request(b"move", P.Move(1, 0)))
    bad[-1] ^= 0xFF
    ser.write(bytes(bad))
    assert ser.read(4) == b"errd"


def test_set_position_deg_renumbers_the_current_position_without_moving(rig):
    clock, emu, stage, _ = rig
    stage.move_deg(30.0)
    stage.command_wait_for_stop()
    stage.set_position_deg(-12.5)
    assert stage.get_position_deg() == pytest.approx(-12.5, abs=1e-12)
    assert emu.position_deg_at(clock.now()) == pytest.approx(30.0, abs=1e-12)
    assert not stage.get_status().running
    with pytest.raises(TurntableError, match="a2 .*: spos: angle nan is not a finite number"):
        stage.set_position_deg(float("nan"))


def test_get_speed_deg_s_reads_the_signed_current_speed(rig):
    clock, emu, stage, _ = rig
    assert stage.get_speed_deg_s() == 0.0
    stage.set_speed_deg_s(12.345, accel_deg_s2=40.0)
    stage.rotate_continuous(-12.345)
    clock.sleep(2.0)
    assert stage.get_speed_deg_s() == pytest.approx(emu.speed_deg_s_at(clock.now()), abs=0.01 / 256)
    assert stage.get_speed_deg_s() == pytest.approx(-12.345, abs=0.01 / 256)
    stage.command_stop()

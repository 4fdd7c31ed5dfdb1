"""Conformance: Standa's own libximc (a client nobody here wrote) drives the emulator over its pty.

libximc 3.1.1 is pinned in pyproject (3.1.2 does not import on Linux: its loader does not find the
bundled shared library). The test is skipped only where libximc cannot be loaded on the machine.
"""

from __future__ import annotations

import pytest

from drivers.clock import MonotonicClock
from drivers.ximc.sim.emulator import ControllerEmulator

try:
    import libximc.highlevel as ximc
except Exception as exc:  # noqa: BLE001 - any failure to load the vendor library
    ximc = None
    REASON = f"libximc cannot be loaded here: {exc}"
else:
    REASON = ""

pytestmark = [pytest.mark.skipif(ximc is None, reason=REASON or "libximc missing"), pytest.mark.pty]


@pytest.fixture
def emulator():
    emu = ControllerEmulator(0x3A5C, clock=MonotonicClock(time_scale=20.0))
    path = emu.start()
    yield emu, path
    emu.stop()


def test_libximc_reads_identity_settings_and_status(emulator):
    emu, path = emulator
    axis = ximc.Axis("xi-com:" + path)
    axis.open_device()
    try:
        assert axis.get_serial_number() == 0x3A5C
        assert tuple(axis.get_firmware_version()) == (4, 3, 8)
        info = axis.get_device_information()
        assert info.Manufacturer == "XIMC"
        eng = axis.get_engine_settings()
        assert eng.MicrostepMode == ximc.MicrostepMode.MICROSTEP_MODE_FRAC_256
        assert eng.StepsPerRev == 200 and eng.NomSpeed == 4800
        ms = axis.get_move_settings()
        assert (ms.Speed, ms.Accel, ms.Decel) == (2000, 2000, 5000)
        st = axis.get_status()
        assert st.CurPosition == 0 and not st.MvCmdSts & ximc.MvcmdStatus.MVCMD_RUNNING
    finally:
        axis.close_device()


def test_libximc_moves_with_microsteps_and_waits(emulator):
    emu, path = emulator
    axis = ximc.Axis("xi-com:" + path)
    axis.open_device()
    try:
        ms = axis.get_move_settings()
        ms.Speed = 4000
        axis.set_move_settings(ms)
        assert axis.get_move_settings().Speed == 4000
        axis.command_move(9000, 128)  # 90.005 deg on an 8MR191
        st = axis.get_status()
        assert st.MvCmdSts & ximc.MvcmdStatus.MVCMD_RUNNING
        axis.command_wait_for_stop(10)
        pos = axis.get_position()
        assert (pos.Position, pos.uPosition) == (9000, 128)
        assert emu.position_deg_at(emu.clock.now()) == pytest.approx(90.005, abs=1e-9)
        axis.command_movr(-100, -64)
        axis.command_wait_for_stop(10)
        pos = axis.get_position()
        assert pos.Position * 256 + pos.uPosition == 9000 * 256 + 128 - 100 * 256 - 64
        axis.command_zero()
        assert axis.get_position().Position == 0
        # the physical angle did not move when the counter was zeroed
        assert emu.position_deg_at(emu.clock.now()) == pytest.approx(89.0025, abs=1e-9)
    finally:
        axis.close_device()

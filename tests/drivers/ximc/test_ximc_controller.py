"""The sans-I/O controller in memory: protocol encoder in, answer bytes out, no pty, no thread.

In the style of caproto's tests/test_core.py: every test wires the host side of
``drivers.ximc.protocol`` (``encode_request`` / ``decode_answer``) to a
:class:`~drivers.ximc.sim.controller.Controller` and checks the bytes that come back.
"""

from __future__ import annotations

import struct

import pytest

from drivers.clock import VirtualClock
from drivers.ximc import protocol as P
from drivers.ximc.sim.controller import REQUEST_GAP_S, Controller
from drivers.ximc.sim.faults import XimcFaults
from drivers.ximc.stage_spec import MR191


@pytest.fixture
def clock():
    return VirtualClock()


@pytest.fixture
def ctrl(clock):
    return Controller(0x3A5C, clock=clock)


def ask(ctrl: Controller, cmd: bytes, obj=None):
    """One request through the encoder, the controller and the decoder."""
    answer = ctrl.receive(P.encode_request(cmd, obj))
    return P.decode_answer(cmd, answer)


# -- byte for byte -------------------------------------------------------------------------------
def test_serial_number_answer_byte_for_byte(ctrl):
    assert ctrl.receive(b"gser") == bytes.fromhex("67 73 65 72 5c 3a 00 00 32 79")


def test_move_request_is_echoed_and_the_position_answer_is_byte_exact(ctrl, clock):
    request = bytes.fromhex("6d 6f 76 65 28 23 00 00 80 00 00 00 00 00 00 00 a8 86")
    assert request == P.encode_request(b"move", P.Move(9000, 128))  # 90.005 deg on an 8MR191
    assert ctrl.receive(request) == b"move"
    clock.sleep(60.0)
    assert ctrl.receive(b"gpos") == bytes.fromhex(
        "67 70 6f 73 28 23 00 00 80 00 80 28 23 00 00 00 00 00 00 00 00 00 00 00 88 c5")


def test_every_protocol_command_has_a_handler(ctrl):
    assert set(Controller.HANDLERS) == set(P.COMMANDS)


@pytest.mark.parametrize("cmd", sorted(c for c, spec in P.COMMANDS.items() if spec[0] is None))
def test_every_dataless_request_gets_a_well_formed_answer(cmd, ctrl):
    answer = ctrl.receive(cmd)
    assert len(answer) == P.answer_size(cmd)
    P.decode_answer(cmd, answer)  # echo, size and CRC all check out


def test_answers_for_requests_split_anywhere_come_when_the_request_is_complete(ctrl):
    frame = P.encode_request(b"smov", P.MoveSettings(3000, 0, 1000, 1000, 2000, 0, 0))
    assert [ctrl.receive(frame[i:i + 1]) for i in range(len(frame) - 1)] == [b""] * (len(frame) - 1)
    assert ctrl.receive(frame[-1:]) == b"smov"
    assert ask(ctrl, b"gmov").Speed == 3000


def test_two_requests_in_one_chunk_get_both_answers_in_order(ctrl):
    out = ctrl.receive(b"gser" + b"gfwv")
    assert out[:10] == P.encode_answer(b"gser", P.SerialNumber(0x3A5C))
    assert P.decode_answer(b"gfwv", out[10:]) == P.FirmwareVersion(4, 3, 8)


# -- wire errors -----------------------------------------------------------------------------------
def test_a_zero_byte_is_echoed_for_resynchronisation(ctrl):
    assert ctrl.receive(b"\x00\x00") == b"\x00\x00"


def test_unknown_command_answers_errc_and_sets_the_flag(ctrl):
    assert ctrl.receive(b"abcd") == b"errc"
    assert ask(ctrl, b"gets").Flags & P.STATE_ERRC


def test_bad_data_crc_answers_errd_and_sets_the_flag(ctrl):
    bad = bytearray(P.encode_request(b"move", P.Move(1, 0)))
    bad[-1] ^= 0xFF
    assert ctrl.receive(bytes(bad)) == b"errd"
    assert ask(ctrl, b"gets").Flags & P.STATE_ERRD


def test_microsteps_beyond_one_full_step_answer_errv(ctrl):
    data = struct.pack("<ih6x", 10, 256)  # uPosition must be -255..255 at 256 microsteps/step
    frame = b"move" + data + struct.pack("<H", P.crc16(data))
    assert ctrl.receive(frame) == b"errv"
    assert ask(ctrl, b"gets").Flags & P.STATE_ERRV
    assert ask(ctrl, b"gpos").Position == 0


def test_move_settings_out_of_range_are_clamped_and_answer_errv(ctrl):
    data = struct.pack("<IBHHIBB9x", 200000, 0, 0, 10, 2000, 0, 0)
    assert ctrl.receive(b"smov" + data + struct.pack("<H", P.crc16(data))) == b"errv"
    ms = ask(ctrl, b"gmov")
    assert (ms.Speed, ms.Accel, ms.Decel) == (100000, 1, 10)


def test_a_partial_request_is_forgotten_after_the_request_gap(ctrl):
    frame = P.encode_request(b"move", P.Move(100, 0))
    assert ctrl.receive(frame[:7], arrival_s=10.0) == b""
    assert ctrl.receive(b"gser", arrival_s=10.0 + REQUEST_GAP_S + 0.1)[:4] == b"gser"


def test_a_short_gap_inside_a_request_is_tolerated(ctrl):
    frame = P.encode_request(b"move", P.Move(100, 0))
    assert ctrl.receive(frame[:7], arrival_s=10.0) == b""
    assert ctrl.receive(frame[7:], arrival_s=10.1) == b"move"


# -- motion from the injected clock -----------------------------------------------------------------
def test_motion_follows_the_clock_and_the_status_reports_it(ctrl, clock):
    ask(ctrl, b"smov", P.MoveSettings(2000, 0, 4000, 4000, 2000, 0, 0))
    ask(ctrl, b"move", P.Move(1000, 0))  # 10 deg at 20 deg/s, 40 deg/s^2: done after 1 s
    st = ask(ctrl, b"gets")
    assert st.running and st.MvCmdSts & P.MVCMD_NAME_MASK == P.MVCMD_MOVE
    clock.sleep(0.5)
    st = ask(ctrl, b"gets")
    assert (st.CurSpeed, st.uCurSpeed) == (2000, 0) and st.MoveSts & P.MOVE_STATE_TARGET_SPEED
    assert ctrl.position_deg_at(clock.now()) == pytest.approx(5.0)
    clock.sleep(0.6)
    st = ask(ctrl, b"gets")
    assert not st.running and (st.CurPosition, st.uCurPosition, st.CurSpeed) == (1000, 0, 0)
    assert ctrl.speed_deg_s_at(clock.now()) == 0.0


def test_relative_move_during_a_move_adds_to_its_target(ctrl, clock):
    ask(ctrl, b"move", P.Move(1000, 0))
    clock.sleep(0.1)
    ask(ctrl, b"movr", P.Move(500, 0))
    clock.sleep(30.0)
    assert ask(ctrl, b"gpos").Position == 1500


def test_zero_and_set_position_renumber_without_moving(ctrl, clock):
    ask(ctrl, b"move", P.Move(2000, 0))
    clock.sleep(30.0)
    ask(ctrl, b"zero")
    assert ask(ctrl, b"gpos").Position == 0
    assert ctrl.position_deg_at(clock.now()) == pytest.approx(20.0)
    ask(ctrl, b"spos", P.SetPosition(-500, 12))
    pos = ask(ctrl, b"gpos")  # full steps truncate toward zero; microsteps carry the remainder's sign
    assert (pos.Position, pos.uPosition) == (-499, -244) and pos.Position * 256 + pos.uPosition == -500 * 256 + 12
    assert ctrl.position_deg_at(clock.now()) == pytest.approx(20.0)


def test_continuous_rotation_is_limited_to_the_stage_nominal_speed(ctrl, clock):
    ask(ctrl, b"smov", P.MoveSettings(10000, 0, 2000, 2000, 2000, 0, 0))
    ask(ctrl, b"left")
    clock.sleep(10.0)
    assert ctrl.speed_deg_s_at(clock.now()) == pytest.approx(-MR191.max_speed_deg_s)
    ask(ctrl, b"stop")
    assert not ask(ctrl, b"gets").running and ctrl.speed_deg_s_at(clock.now()) == 0.0


def test_engine_settings_describe_the_8mr191(ctrl):
    es = ask(ctrl, b"geng")
    assert (es.NomSpeed, es.StepsPerRev, es.MicrostepMode) == (MR191.nom_speed_steps_s, MR191.steps_per_rev,
                                                               P.MICROSTEP_MODE_FRAC_256)


def test_a_stall_ends_the_move_with_a_command_error(clock):
    ctrl = Controller(1, clock=clock, faults=XimcFaults(stall_at_deg=3.0))
    ask(ctrl, b"move", P.Move(1000, 0))
    clock.sleep(30.0)
    st = ask(ctrl, b"gets")
    assert not st.running and st.command_error and (st.CurPosition, st.uCurPosition) == (300, 0)


# -- answer faults -----------------------------------------------------------------------------------
def test_dropped_answers_are_empty(clock):
    ctrl = Controller(1, clock=clock, faults=XimcFaults(drop_rate=1.0))
    assert ctrl.receive(b"gser") == b""
    assert ctrl.requests_seen == 1


def test_error_answer_fault_replaces_the_answer(clock):
    ctrl = Controller(1, clock=clock, faults=XimcFaults(error_answer_rate=1.0, error_answer="errv"))
    assert ctrl.receive(b"gpos") == b"errv"


def test_corrupted_answers_fail_the_crc_and_truncated_ones_are_short(clock):
    ctrl = Controller(1, clock=clock, faults=XimcFaults(crc_corrupt_rate=1.0))
    with pytest.raises(P.CrcError):
        P.decode_answer(b"gser", ctrl.receive(b"gser"))
    ctrl = Controller(1, clock=clock, faults=XimcFaults(truncate_rate=1.0))
    assert ctrl.receive(b"gser") == b"gser\x01"

"""The XIMC codec, byte for byte against the frames of the reference sheet (ximc.md section 8)."""

from __future__ import annotations

import pytest

from drivers.ximc import protocol as P


def h(s: str) -> bytes:
    return bytes.fromhex(s.replace(" ", ""))


def test_crc_check_values():
    assert P.crc16(b"123456789") == 0x4B37
    assert P.crc16(b"") == 0xFFFF


def test_get_status_request_is_the_bare_command():
    assert P.encode_request(b"gets") == h("67 65 74 73")


def test_move_to_36000_steps():
    assert P.encode_request(b"move", P.Move(36000, 0)) == h("6D 6F 76 65 A0 8C 00 00 00 00 00 00 00 00 00 00 71 51")


def test_crc_covers_reserved_bytes_as_libximc_sends_them():
    data = h("A0 8C 00 00 00 00 CC CC CC CC CC CC")
    assert P.crc16(data) == 0xB7DA


def test_relative_move_negative_with_microsteps():
    assert P.encode_request(b"movr", P.Move(-100, 128)) == h("6D 6F 76 72 9C FF FF FF 80 00 00 00 00 00 00 00 FC E3")


def test_set_move_settings_frame():
    frame = P.encode_request(b"smov", P.MoveSettings(2000, 0, 2000, 5000, 2000, 0, 0))
    assert frame == h("73 6D 6F 76 D0 07 00 00 00 D0 07 88 13 D0 07 00 00 00 00") + bytes(9) + h("B0 66")
    assert len(frame) == 30


def test_position_answer_decodes():
    frame = h("67 70 6F 73 A0 8C 00 00 00 00") + bytes(14) + h("86 2D")
    assert P.encode_answer(b"gpos", P.Position(36000, 0, 0)) == frame
    assert P.decode_answer(b"gpos", frame) == P.Position(36000, 0, 0)


@pytest.mark.parametrize("cmd,size", [(b"gets", 54), (b"gpos", 26), (b"gmov", 30), (b"geng", 34),
                                      (b"ghom", 33), (b"gfwv", 10), (b"gser", 10), (b"geti", 36)])
def test_answer_sizes_match_protocol_xi(cmd, size):
    assert P.answer_size(cmd) == size


@pytest.mark.parametrize("cmd,size", [(b"move", 18), (b"movr", 18), (b"spos", 26), (b"smov", 30), (b"seng", 34),
                                      (b"shom", 33), (b"stop", 4), (b"sstp", 4), (b"rigt", 4), (b"left", 4)])
def test_request_sizes_match_protocol_xi(cmd, size):
    assert P.request_size(cmd) == size


@pytest.mark.parametrize("cmd,obj", [
    (b"gets", P.Status(3, 0x81, 3, 0, 0x33, -12345, -77, 99, 200, 5, 300, 1200, 0, 500, 366, 0x30, 0x1, 0)),
    (b"gmov", P.MoveSettings(2000, 10, 2000, 5000, 2000, 0, 0)),
    (b"geng", P.EngineSettings(360, 670, 4800, 0, 0x90, 1800, 9, 200, 0)),
    (b"ghom", P.HomeSettings(100, 0, 10, 0, -1000, 0, 0x170)),
    (b"gfwv", P.FirmwareVersion(4, 3, 8)),
    (b"gser", P.SerialNumber(0x3A5C)),
    (b"geti", P.DeviceInformation("XIMC", "SM", "8SMC5", 2, 3, 0)),
])
def test_every_answer_round_trips(cmd, obj):
    assert P.decode_answer(cmd, P.encode_answer(cmd, obj)) == obj


@pytest.mark.parametrize("cmd,obj", [
    (b"move", P.Move(-5, -255)), (b"spos", P.SetPosition(7, 3, 11, P.SETPOS_IGNORE_ENCODER)),
    (b"smov", P.MoveSettings(1, 0, 1, 1, 0, 0, 0)), (b"seng", P.EngineSettings(0, 15, 1, 0, 0, 0, 1, 1, 0)),
    (b"shom", P.HomeSettings(100, 0, 10, 0, -1000, 0, 0x170)), (b"zero", None), (b"rigt", None),
])
def test_every_request_round_trips_through_the_controller_side(cmd, obj):
    assert P.decode_request(P.encode_request(cmd, obj)) == (cmd, obj)


def test_corrupted_answer_crc_is_detected():
    frame = bytearray(P.encode_answer(b"gpos", P.Position(1, 2, 3)))
    frame[-1] ^= 1
    with pytest.raises(P.CrcError):
        P.decode_answer(b"gpos", bytes(frame))


def test_error_answers_and_wrong_echo():
    for code in (b"errc", b"errd", b"errv"):
        with pytest.raises(P.ErrorAnswer) as e:
            P.decode_answer(b"move", code)
        assert e.value.code == code
    with pytest.raises(P.EchoError):
        P.decode_answer(b"move", b"movr")
    with pytest.raises(P.EchoError):
        P.decode_answer(b"gpos", P.encode_answer(b"gpos", P.Position(1, 2, 3))[:-3])


def test_values_outside_the_protocol_range_are_refused_before_sending():
    with pytest.raises(P.ValueRangeError):
        P.encode_request(b"move", P.Move(0, 256))  # FRAC_256: |uPosition| <= 255
    with pytest.raises(P.ValueRangeError):
        P.encode_request(b"smov", P.MoveSettings(200000, 0, 1, 1, 0, 0, 0))
    with pytest.raises(P.ValueRangeError):
        P.encode_request(b"move", P.Move(2**31, 0))
    with pytest.raises(P.ValueRangeError):
        P.encode_request(b"zero", P.Move(0, 0))


def test_answer_parser_skips_resync_zeros_and_takes_any_chunking():
    frame = P.encode_answer(b"gpos", P.Position(-1, -2, -3))
    parser = P.AnswerParser(b"gpos")
    stream = b"\x00\x00\x00" + frame
    done = False
    for i in range(len(stream)):
        done, out = parser.feed(stream[i:i + 1])
        if done:
            break
    assert done and out == frame


def test_request_parser_answers_zeros_and_flags_unknown_commands():
    p = P.RequestParser()
    events = p.feed(b"\x00" + b"xxxx" + P.encode_request(b"move", P.Move(1, 0)) + b"gets")
    assert events[0] == ("zero",)
    assert events[1] == ("unknown", b"xxxx")
    assert events[2] == ("request", P.encode_request(b"move", P.Move(1, 0)))
    assert events[3] == ("request", b"gets")

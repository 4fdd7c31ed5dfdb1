"""Sans-I/O codec of Standa's XIMC binary protocol (8SMC4-USB / 8SMC5-USB).

Pure functions and small parsers, no ports. Facts and sources: docs/turntable.md
and ../shared/reference/ximc.md (libximc protocol.xi, checked against the
libximc 3.1.x header and the vendor manual).

Frames: 4 ASCII command bytes, then for commands with data a little-endian
data section and a CRC-16/MODBUS of the data section (low byte first).
Dataless frames have no CRC. Answers echo the command; ``errc``/``errd``/
``errv`` are 4-byte error answers. Both directions are here: the host side
(encode requests, decode answers) used by :mod:`drivers.ximc.stage`, and the
controller side (decode requests, encode answers) used by the emulator.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, fields

# -- CRC ---------------------------------------------------------------------------------


def _crc16_table() -> tuple[int, ...]:
    """The CRC of each byte value alone (the bitwise definition, eight shifts), for the table-driven loop."""
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
        table.append(crc)
    return tuple(table)


_CRC16_TABLE = _crc16_table()


def crc16(data: bytes) -> int:
    """CRC-16/MODBUS (reflected poly 0xA001, init 0xFFFF) of ``data``: one table lookup per byte (the bitwise
    loop, eight shifts per byte, was the controller link's largest cost in a simulated run)."""
    crc = 0xFFFF
    table = _CRC16_TABLE
    for byte in data:
        crc = (crc >> 8) ^ table[(crc ^ byte) & 0xFF]
    return crc


# -- flags -------------------------------------------------------------------------------
MOVE_STATE_MOVING = 0x01
MOVE_STATE_TARGET_SPEED = 0x02
MOVE_STATE_ANTIPLAY = 0x04
MVCMD_UKNWN, MVCMD_MOVE, MVCMD_MOVR, MVCMD_LEFT, MVCMD_RIGHT, MVCMD_STOP, MVCMD_HOME, MVCMD_LOFT, MVCMD_SSTP = range(9)
MVCMD_NAME_MASK = 0x3F
MVCMD_ERROR = 0x40
MVCMD_RUNNING = 0x80
PWR_STATE_OFF, PWR_STATE_NORM, PWR_STATE_REDUCT, PWR_STATE_MAX = 1, 3, 4, 5
STATE_ERRC, STATE_ERRD, STATE_ERRV = 0x1, 0x2, 0x4
STATE_EEPROM_CONNECTED = 0x10
STATE_IS_HOMED = 0x20
STATE_ALARM = 0x40
STATE_RIGHT_EDGE, STATE_LEFT_EDGE = 0x1, 0x2
ENGINE_REVERSE, ENGINE_MAX_SPEED, ENGINE_ANTIPLAY, ENGINE_ACCEL_ON, ENGINE_LIMIT_RPM = 0x1, 0x4, 0x8, 0x10, 0x80
SETPOS_IGNORE_POSITION, SETPOS_IGNORE_ENCODER = 0x01, 0x02
MICROSTEP_MODE_FRAC_256 = 9

ERROR_ANSWERS = {b"errc": "unknown command", b"errd": "data CRC mismatch", b"errv": "value out of range"}


# -- messages ----------------------------------------------------------------------------
@dataclass(frozen=True)
class Status:
    MoveSts: int
    MvCmdSts: int
    PWRSts: int
    EncSts: int
    WindSts: int
    CurPosition: int
    uCurPosition: int
    EncPosition: int
    CurSpeed: int
    uCurSpeed: int
    Ipwr: int
    Upwr: int
    Iusb: int
    Uusb: int
    CurT: int
    Flags: int
    GPIOFlags: int
    CmdBufFreeSpace: int

    @property
    def running(self) -> bool:
        return bool(self.MvCmdSts & MVCMD_RUNNING)

    @property
    def command_error(self) -> bool:
        return bool(self.MvCmdSts & MVCMD_ERROR)


@dataclass(frozen=True)
class Position:
    Position: int
    uPosition: int
    EncPosition: int = 0


@dataclass(frozen=True)
class SetPosition:
    Position: int
    uPosition: int
    EncPosition: int = 0
    PosFlags: int = 0


@dataclass(frozen=True)
class Move:
    Position: int
    uPosition: int = 0


@dataclass(frozen=True)
class MoveSettings:
    Speed: int
    uSpeed: int
    Accel: int
    Decel: int
    AntiplaySpeed: int
    uAntiplaySpeed: int
    MoveFlags: int = 0


@dataclass(frozen=True)
class EngineSettings:
    NomVoltage: int
    NomCurrent: int
    NomSpeed: int
    uNomSpeed: int
    EngineFlags: int
    Antiplay: int
    MicrostepMode: int
    StepsPerRev: int
    PeakCurrent: int = 0


@dataclass(frozen=True)
class HomeSettings:
    FastHome: int
    uFastHome: int
    SlowHome: int
    uSlowHome: int
    HomeDelta: int
    uHomeDelta: int
    HomeFlags: int


@dataclass(frozen=True)
class FirmwareVersion:
    Major: int
    Minor: int
    Release: int


@dataclass(frozen=True)
class SerialNumber:
    SerialNumber: int


@dataclass(frozen=True)
class DeviceInformation:
    Manufacturer: str
    ManufacturerId: str
    ProductDescription: str
    Major: int
    Minor: int
    Release: int


# command -> (request data struct, request type, answer data struct, answer type)
_S = struct.Struct
COMMANDS: dict[bytes, tuple] = {
    b"gets": (None, None, _S("<5BihqihhhhhhIIB4x"), Status),
    b"gpos": (None, None, _S("<ihq6x"), Position),
    b"spos": (_S("<ihqB5x"), SetPosition, None, None),
    b"move": (_S("<ih6x"), Move, None, None),
    b"movr": (_S("<ih6x"), Move, None, None),
    b"stop": (None, None, None, None),
    b"sstp": (None, None, None, None),
    b"home": (None, None, None, None),
    b"zero": (None, None, None, None),
    b"left": (None, None, None, None),
    b"rigt": (None, None, None, None),
    b"loft": (None, None, None, None),
    b"pwof": (None, None, None, None),
    b"save": (None, None, None, None),
    b"read": (None, None, None, None),
    b"gmov": (None, None, _S("<IBHHIBB9x"), MoveSettings),
    b"smov": (_S("<IBHHIBB9x"), MoveSettings, None, None),
    b"geng": (None, None, _S("<HHIBHhBHH10x"), EngineSettings),
    b"seng": (_S("<HHIBHhBHH10x"), EngineSettings, None, None),
    b"ghom": (None, None, _S("<IBIBihH9x"), HomeSettings),
    b"shom": (_S("<IBIBihH9x"), HomeSettings, None, None),
    b"gfwv": (None, None, _S("<BBH"), FirmwareVersion),
    b"gser": (None, None, _S("<I"), SerialNumber),
    b"geti": (None, None, _S("<4s2s8sBBH12x"), DeviceInformation),
}


class ProtocolError(Exception):
    """A frame that does not decode."""


class CrcError(ProtocolError):
    pass


class EchoError(ProtocolError):
    pass


class ErrorAnswer(ProtocolError):
    """The controller answered errc / errd / errv."""

    def __init__(self, code: bytes) -> None:
        self.code = code
        super().__init__(f"{code.decode()} ({ERROR_ANSWERS[code]})")


class ValueRangeError(ValueError):
    """A request value is outside the range the protocol allows (caught before it is sent)."""


def request_size(cmd: bytes) -> int:
    req = COMMANDS[cmd][0]
    return 4 + (req.size + 2 if req else 0)


def answer_size(cmd: bytes) -> int:
    ans = COMMANDS[cmd][2]
    return 4 + (ans.size + 2 if ans else 0)


def _frame(cmd: bytes, data: bytes | None) -> bytes:
    if data is None:
        return cmd
    return cmd + data + struct.pack("<H", crc16(data))


def _pack(st: struct.Struct, obj) -> bytes:
    # the fields' values as they are (flat: numbers and strings), not dataclasses.astuple's deep copy of each
    values = [v.encode("ascii") if isinstance(v, str) else v for v in (getattr(obj, f.name) for f in fields(obj))]
    try:
        return st.pack(*values)
    except struct.error as exc:
        raise ValueRangeError(f"{type(obj).__name__}: {exc}") from None


def _unpack(st: struct.Struct, cls, data: bytes):
    values = st.unpack(data)
    out = []
    for f, v in zip(fields(cls), values):
        out.append(v.rstrip(b"\x00").decode("ascii", "replace") if isinstance(v, bytes) else v)
    return cls(*out)


# -- host side ---------------------------------------------------------------------------
def check_range(cmd: bytes, obj, microstep_mode: int = MICROSTEP_MODE_FRAC_256) -> None:
    """Reject values the controller would refuse (errv), before anything is sent."""
    usteps = 1 << (microstep_mode - 1)
    if isinstance(obj, (Move, SetPosition)):
        if not -(2**31) <= obj.Position < 2**31:
            raise ValueRangeError(f"{cmd.decode()}: position {obj.Position} outside int32")
        if abs(obj.uPosition) >= usteps:
            raise ValueRangeError(f"{cmd.decode()}: uPosition {obj.uPosition} outside -{usteps - 1}..{usteps - 1}")
    if isinstance(obj, MoveSettings):
        if not 0 <= obj.Speed <= 100000:
            raise ValueRangeError(f"smov: Speed {obj.Speed} outside 0..100000 steps/s")
        if not 1 <= obj.Accel <= 65535 or not 1 <= obj.Decel <= 65535:
            raise ValueRangeError(f"smov: Accel/Decel {obj.Accel}/{obj.Decel} outside 1..65535 steps/s^2")
        if not 0 <= obj.uSpeed < min(usteps, 256):
            raise ValueRangeError(f"smov: uSpeed {obj.uSpeed} outside 0..{min(usteps, 256) - 1}")
    if isinstance(obj, EngineSettings):
        if not 1 <= obj.MicrostepMode <= 9:
            raise ValueRangeError(f"seng: MicrostepMode {obj.MicrostepMode} outside 1..9")
        if not 1 <= obj.NomSpeed <= 100000:
            raise ValueRangeError(f"seng: NomSpeed {obj.NomSpeed} outside 1..100000")
        if obj.StepsPerRev < 1:
            raise ValueRangeError("seng: StepsPerRev must be >= 1")


def encode_request(cmd: bytes, obj=None, microstep_mode: int = MICROSTEP_MODE_FRAC_256) -> bytes:
    """The bytes of a request frame (CRC included when the command has data)."""
    if cmd not in COMMANDS:
        raise ValueRangeError(f"unknown command {cmd!r}")
    req, req_type = COMMANDS[cmd][0], COMMANDS[cmd][1]
    if req is None:
        if obj is not None:
            raise ValueRangeError(f"{cmd.decode()} takes no data")
        return cmd
    if not isinstance(obj, req_type):
        raise ValueRangeError(f"{cmd.decode()} needs a {req_type.__name__}")
    check_range(cmd, obj, microstep_mode)
    return _frame(cmd, _pack(req, obj))


def decode_answer(cmd: bytes, frame: bytes):
    """Decode a complete answer frame to ``cmd``: the dataclass, or None for echo-only answers.

    Raises ErrorAnswer (errc/errd/errv), EchoError (wrong echo or size), CrcError.
    """
    head = bytes(frame[:4])
    if head in ERROR_ANSWERS:
        raise ErrorAnswer(head)
    if head != cmd:
        raise EchoError(f"expected echo {cmd!r}, got {head!r}")
    if len(frame) != answer_size(cmd):
        raise EchoError(f"{cmd.decode()}: answer of {len(frame)} bytes, expected {answer_size(cmd)}")
    ans, ans_type = COMMANDS[cmd][2], COMMANDS[cmd][3]
    if ans is None:
        return None
    data, crc = frame[4:-2], struct.unpack("<H", frame[-2:])[0]
    if crc16(data) != crc:
        raise CrcError(f"{cmd.decode()}: answer CRC {crc:#06x} != computed {crc16(data):#06x}")
    return _unpack(ans, ans_type, data)


class AnswerParser:
    """Incremental parser of the answer to one request (bytes arrive in any chunks).

    Leading 0x00 bytes (resynchronisation echoes) are skipped. ``feed`` returns
    ``(done, frame)``; an error answer completes after 4 bytes.
    """

    def __init__(self, cmd: bytes) -> None:
        self.cmd = cmd
        self.buf = bytearray()
        self.need = answer_size(cmd)

    def feed(self, data: bytes) -> tuple[bool, bytes | None]:
        for b in data:
            if not self.buf and b == 0:
                continue
            self.buf.append(b)
        if len(self.buf) >= 4 and bytes(self.buf[:4]) in ERROR_ANSWERS:
            return True, bytes(self.buf[:4])
        if len(self.buf) >= 4 and bytes(self.buf[:4]) != self.cmd:
            return True, bytes(self.buf[:4])  # wrong echo: let decode_answer say so
        if len(self.buf) >= self.need:
            return True, bytes(self.buf[:self.need])
        return False, None

    def missing(self) -> int:
        if len(self.buf) >= 4 and bytes(self.buf[:4]) in ERROR_ANSWERS:
            return 0
        return max(self.need - len(self.buf), 0)


# -- controller side ---------------------------------------------------------------------
def encode_answer(cmd: bytes, obj=None) -> bytes:
    ans = COMMANDS[cmd][2]
    if ans is None:
        return cmd
    return _frame(cmd, _pack(ans, obj))


def decode_request(frame: bytes):
    """Decode a complete request frame: (cmd, dataclass or None). Raises CrcError / ProtocolError."""
    cmd = bytes(frame[:4])
    if cmd not in COMMANDS:
        raise ProtocolError(f"unknown command {cmd!r}")
    req, req_type = COMMANDS[cmd][0], COMMANDS[cmd][1]
    if req is None:
        return cmd, None
    if len(frame) != request_size(cmd):
        raise ProtocolError(f"{cmd.decode()}: request of {len(frame)} bytes, expected {request_size(cmd)}")
    data, crc = frame[4:-2], struct.unpack("<H", frame[-2:])[0]
    if crc16(data) != crc:
        raise CrcError(f"{cmd.decode()}: request CRC mismatch")
    return cmd, _unpack(req, req_type, data)


class RequestParser:
    """Incremental controller-side parser: bytes in, events out.

    ``feed`` returns a list of events: ``("zero",)`` for a resync zero byte (answer 0x00),
    ``("request", frame)`` for a complete request, ``("unknown", code)`` for an
    unknown 4-byte command (answer errc; the buffer is cleared).
    """

    def __init__(self) -> None:
        self.buf = bytearray()

    def clear(self) -> None:
        self.buf.clear()

    def feed(self, data: bytes) -> list[tuple]:
        events: list[tuple] = []
        for b in data:
            if not self.buf and b == 0:
                events.append(("zero",))
                continue
            self.buf.append(b)
            if len(self.buf) == 4:
                cmd = bytes(self.buf)
                if cmd not in COMMANDS:
                    events.append(("unknown", cmd))
                    self.buf.clear()
                    continue
            if len(self.buf) >= 4:
                cmd = bytes(self.buf[:4])
                if len(self.buf) == request_size(cmd):
                    events.append(("request", bytes(self.buf)))
                    self.buf.clear()
        return events

"""Sans-I/O policy of a request/answer transaction with one 8SMC4/8SMC5 controller.

In the style of h11's ``Connection``: :class:`Transaction` owns no port, clock or thread. It is
told what happened (``start``, ``received`` bytes, ``resume`` after its actions ran,
``port_failed``), each time with the current time, and answers with the actions to carry out
next, in order: port effects (:class:`Write`, :class:`ResetInput`, :class:`Receive`,
:class:`Close`, :class:`Open`), :class:`Wait`, events (:class:`Recovered`,
:class:`Reconnected`) and at the end one outcome (:class:`Done` or :class:`Failed`). The shell
that owns the port and the wall clock is :class:`drivers.ximc.link.XimcLink`.

The policy: write the request and read its answer (per-read window ``timeout_s``, answer
deadline ``max(3 * timeout_s, 1 s)``); on a bad CRC, a wrong echo, an error answer or a
timeout, resynchronise (send 64 zero bytes, wait up to 0.5 s for a zero echo, settle 5 ms,
empty the input) and try again, ``retries`` attempts in all; ``errv`` (the controller refused a
value) fails at once, since asking again gets the same answer; a port error (the port vanished,
e.g. a USB replug) closes the port and reopens it (:class:`Reopen`: every 50 ms for
``reopen_s``). What each fault leads to is the table :data:`ON_FAULT`; which input each phase
accepts is the table ``TRANSITIONS`` of each machine.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Any, Callable

from drivers.ximc import protocol as P

#: the resynchronisation: zero bytes sent, bytes read at a time, window for their echo, settle, s
RESYNC_ZEROS = b"\x00" * 64
RESYNC_READ = 64
RESYNC_WINDOW_S = 0.5
SETTLE_S = 0.005
#: pause between two attempts to reopen a vanished port, s
REOPEN_PAUSE_S = 0.05
#: an answer is complete within max(ANSWER_READS * timeout_s, ANSWER_MIN_S) of its request
ANSWER_READS = 3
ANSWER_MIN_S = 1.0


# -- actions: what the shell does next, in order -------------------------------------------------
@dataclass(frozen=True)
class Write:
    """Write these bytes to the port."""

    data: bytes


@dataclass(frozen=True)
class ResetInput:
    """Discard whatever the port has received and not yet read."""


@dataclass(frozen=True)
class Receive:
    """Read up to ``max_bytes``, waiting no later than ``until``; then call ``received``.

    Always the last action of its list. An empty read means the wait ended: a shell whose port
    returns nothing before ``until`` (an in-memory port) reports the time as ``until``.
    """

    max_bytes: int
    until: float


@dataclass(frozen=True)
class Wait:
    """Do nothing until ``until``."""

    until: float


@dataclass(frozen=True)
class Close:
    """Close the port (errors ignored: it may be gone already)."""


@dataclass(frozen=True)
class Open:
    """Open the port again and discard its input."""


@dataclass(frozen=True)
class Recovered:
    """Event: the transaction succeeded after ``attempts`` attempts; ``fault`` is the last failure."""

    command: str
    attempts: int
    fault: str


@dataclass(frozen=True)
class Reconnected:
    """Event: a vanished port was opened again."""


@dataclass(frozen=True)
class Done:
    """Outcome: the decoded answer (None for echo-only commands, and for a reopened port)."""

    result: Any = None


@dataclass(frozen=True)
class Failed:
    """Outcome: the transaction gave up; ``reason`` is the detail of the TurntableError."""

    reason: str


class Phase(Enum):
    IDLE = "idle"  # not started
    ANSWER = "answer"  # request written, reading its answer
    RESYNC = "resync"  # zeros written, reading until one is echoed
    SETTLE = "settle"  # resync ending: 5 ms pause, input emptied
    REOPEN = "reopen"  # the port vanished; a Reopen runs
    OPENING = "opening"  # an Open was asked for
    PAUSE = "pause"  # between two Opens
    FINISHED = "finished"  # Done or Failed given


class PolicyError(RuntimeError):
    """An input the policy does not expect in its phase (a bug of the shell driving it)."""


class _Machine:
    """Inputs dispatched by the table ``TRANSITIONS``: (phase, input name) -> handler(self, now, *args)."""

    TRANSITIONS: dict[tuple[Phase, str], Callable] = {}
    phase = Phase.IDLE

    def start(self, now: float) -> list:
        """Begin at time ``now``."""
        return self._input("start", now)

    def received(self, data: bytes, now: float) -> list:
        """The bytes a :class:`Receive` read (empty: none came before its ``until``)."""
        return self._input("received", now, bytes(data))

    def resume(self, now: float) -> list:
        """The actions given last ran through (the last was not a :class:`Receive`)."""
        return self._input("resume", now)

    def port_failed(self, reason: str, now: float) -> list:
        """An action of the last list raised a port error (``reason``); the ones after it did not run."""
        return self._input("port_failed", now, reason)

    def _input(self, name: str, now: float, *args) -> list:
        handler = self.TRANSITIONS.get((self.phase, name))
        if handler is None:
            raise PolicyError(f"{type(self).__name__}: no {name!r} expected in phase {self.phase.value}")
        return handler(self, now, *args)

    def _finish(self, outcome: Done | Failed) -> list:
        self.phase = Phase.FINISHED
        return [outcome]


class Reopen(_Machine):
    """Reopening a vanished port: close it, then try to open it every 50 ms for ``reopen_s`` seconds.

    Outcomes: ``[Reconnected(), Done()]``, or ``Failed("port did not come back within ... s (last error)")``.
    """

    def __init__(self, reopen_s: float) -> None:
        self.reopen_s = reopen_s
        self.last_error: str | None = None
        self._deadline = 0.0

    def _begin(self, now: float) -> list:
        self._deadline = now + self.reopen_s
        return [Close()] + self._try(now)

    def _try(self, now: float) -> list:
        if now < self._deadline:
            self.phase = Phase.OPENING
            return [Open()]
        return self._finish(Failed(f"port did not come back within {self.reopen_s:g} s ({self.last_error})"))

    def _opened(self, now: float) -> list:
        return [Reconnected()] + self._finish(Done())

    def _open_failed(self, now: float, reason: str) -> list:
        self.last_error = reason
        self.phase = Phase.PAUSE
        return [Wait(now + REOPEN_PAUSE_S)]

    TRANSITIONS = {
        (Phase.IDLE, "start"): _begin,
        (Phase.OPENING, "resume"): _opened,
        (Phase.OPENING, "port_failed"): _open_failed,
        (Phase.PAUSE, "resume"): _try,
    }


class AnswerTimeout(Exception):
    """No complete answer in time (a fault value, never raised)."""


class Transaction(_Machine):
    """One request and its decoded answer, with retries, resynchronisation and reopening.

    Parameters
    ----------
    cmd : bytes
        The 4-byte command (``b"gpos"``).
    obj
        The request's data (a protocol dataclass) or None; encoded at once (ValueRangeError).
    microstep_mode : int
        The controller's microstep mode (range check of microstep values).
    timeout_s : float
        Per-read window, s.
    retries : int
        Attempts before giving up.
    reopen_s : float
        How long to keep trying to reopen a vanished port, s.
    """

    def __init__(self, cmd: bytes, obj=None, *, microstep_mode: int = P.MICROSTEP_MODE_FRAC_256,
                 timeout_s: float = 0.3, retries: int = 4, reopen_s: float = 5.0) -> None:
        self.cmd = cmd
        self.frame = P.encode_request(cmd, obj, microstep_mode)
        self.timeout_s = timeout_s
        self.retries = retries
        self.reopen_s = reopen_s
        self.attempt = 0
        self.last_fault = ""
        self._parser = P.AnswerParser(cmd)
        self._read_until = self._deadline = 0.0
        self._reopen: Reopen | None = None

    # -- the request and its answer ----------------------------------------------------------
    def _next_attempt(self, now: float) -> list:
        if self.attempt >= self.retries:
            return self._finish(Failed(f"no valid answer after {self.retries} tries (last: {self.last_fault})"))
        self.attempt += 1
        self.phase = Phase.ANSWER
        self._parser = P.AnswerParser(self.cmd)
        self._deadline = now + max(ANSWER_READS * self.timeout_s, ANSWER_MIN_S)
        self._read_until = now + self.timeout_s
        return [Write(self.frame), self._receive(max(self._parser.missing(), 1))]

    def _receive(self, max_bytes: int) -> Receive:
        return Receive(max_bytes, min(self._read_until, self._deadline))

    def _answer_bytes(self, now: float, data: bytes) -> list:
        if data:
            done, frame = self._parser.feed(data)
            if done:
                return self._decode(frame, now)
            self._read_until = now + self.timeout_s
        if now >= min(self._read_until, self._deadline):
            got = bytes(self._parser.buf)
            return self._fault(AnswerTimeout(f"no complete answer (got {len(got)} bytes: {got[:12].hex(' ')})"), now)
        return [self._receive(max(self._parser.missing(), 1))]

    def _decode(self, frame: bytes, now: float) -> list:
        try:
            result = P.decode_answer(self.cmd, frame)
        except (P.ErrorAnswer, P.CrcError, P.EchoError) as exc:
            return self._fault(exc, now)
        recovered = [Recovered(self.cmd.decode(), self.attempt, self.last_fault)] if self.attempt > 1 else []
        return recovered + self._finish(Done(result))

    def _fault(self, fault: Exception, now: float) -> list:
        key = fault.code if isinstance(fault, P.ErrorAnswer) else type(fault)
        return ON_FAULT[key](self, fault, now)

    def _reject(self, fault: Exception, now: float) -> list:
        return self._finish(Failed(f"controller rejected a value ({fault})"))

    # -- resynchronisation: zeros until one is echoed (the controller's input is then empty) -----
    def _resync(self, fault: Exception, now: float) -> list:
        self.last_fault = str(fault)
        self.phase = Phase.RESYNC
        self._deadline = now + RESYNC_WINDOW_S
        self._read_until = now + self.timeout_s
        return [ResetInput(), Write(RESYNC_ZEROS), self._receive(RESYNC_READ)]

    def _resync_bytes(self, now: float, data: bytes) -> list:
        if 0 in data or now >= self._deadline:
            self.phase = Phase.SETTLE
            return [Wait(now + SETTLE_S), ResetInput()]
        if data or now >= self._read_until:  # that read ended: the next one gets a whole window
            self._read_until = now + self.timeout_s
        return [self._receive(RESYNC_READ)]

    def _resync_abandoned(self, now: float, reason: str) -> list:
        """A port error while resynchronising: give the resync up (the next write will tell)."""
        return self._next_attempt(now)

    # -- the port vanished: reopen it, then go on with the next attempt ----------------------------
    def _port_lost(self, now: float, reason: str) -> list:
        self.last_fault = f"port error ({reason})"
        self.phase = Phase.REOPEN
        self._reopen = Reopen(self.reopen_s)
        return self._through_reopen(self._reopen.start(now), now)

    def _reopen_resumed(self, now: float) -> list:
        return self._through_reopen(self._reopen.resume(now), now)

    def _reopen_failed(self, now: float, reason: str) -> list:
        return self._through_reopen(self._reopen.port_failed(reason, now), now)

    def _through_reopen(self, actions: list, now: float) -> list:
        """The Reopen's actions, its outcome replaced by what follows it here."""
        *before, last = actions
        follow = {
            Done: lambda: self._next_attempt(now),
            Failed: lambda: self._finish(Failed(f"port vanished and did not come back ({last.reason})")),
        }.get(type(last))
        return before + follow() if follow else actions

    def _begin(self, now: float) -> list:
        return self._next_attempt(now)

    TRANSITIONS = {
        (Phase.IDLE, "start"): _begin,
        (Phase.ANSWER, "received"): _answer_bytes,
        (Phase.ANSWER, "port_failed"): _port_lost,
        (Phase.RESYNC, "received"): _resync_bytes,
        (Phase.RESYNC, "port_failed"): _resync_abandoned,
        (Phase.SETTLE, "resume"): _next_attempt,
        (Phase.SETTLE, "port_failed"): _resync_abandoned,
        (Phase.REOPEN, "resume"): _reopen_resumed,
        (Phase.REOPEN, "port_failed"): _reopen_failed,
    }


#: what a failed attempt leads to, by fault (error answers by their code): retry after a resync,
#: or give up at once when asking again cannot help (errv: the controller refused the value)
ON_FAULT: dict[object, Callable[[Transaction, Exception, float], list]] = {
    P.CrcError: Transaction._resync,
    P.EchoError: Transaction._resync,
    AnswerTimeout: Transaction._resync,
    b"errc": Transaction._resync,
    b"errd": Transaction._resync,
    b"errv": Transaction._reject,
}

"""The link's policy without a port: what a transaction writes, reads, waits for and concludes.

:class:`~drivers.ximc.transaction.Transaction` is sans-I/O (h11's ``Connection`` style): it is
told what came back and what time it is, and answers with the next actions. The first tests
script that conversation step by step; the next wire the policy to the emulated controller
(:class:`~drivers.ximc.sim.controller.Controller`) as two in-memory endpoints on a virtual clock,
in the style of caproto's tests; the last run :class:`~drivers.ximc.link.XimcLink`, the shell, on
the in-memory ``ximcsim://`` port, for the messages and events it makes of the policy's outcomes.
"""

from __future__ import annotations

import pytest

from drivers.clock import VirtualClock
from drivers.ximc import protocol as P
from drivers.ximc.errors import TurntableError
from drivers.ximc.link import RECOVERABLE, XimcLink
from drivers.ximc.sim.controller import Controller
from drivers.ximc.sim.faults import XimcFaults
from drivers.ximc.sim.protocol_ximcsim import attach, detach
from drivers.ximc.stage import Stage
from drivers.ximc.transaction import (Close, Done, Failed, Open, PolicyError, Receive, Reconnected, Recovered, Reopen,
                                      ResetInput, Transaction, Wait, Write)

ZEROS = b"\x00" * 64
POSITION = P.Position(9000, 128, 2304128)  # 90.005 deg on an 8MR191
GPOS_ANSWER = bytes.fromhex("67 70 6f 73 28 23 00 00 80 00 80 28 23 00 00 00 00 00 00 00 00 00 00 00 88 c5")
CRC_FLIPPED = GPOS_ANSWER[:-1] + bytes([GPOS_ANSWER[-1] ^ 0x01])
#: the serial number answer "67 73 65 72 5c 3a 00 00 32 79" with the last bit flipped
GSER_CRC_FAULT = "gser: answer CRC 0x7832 != computed 0x7932"


def gpos(**kw) -> Transaction:
    """A position query with a 0.25 s read window (binary-exact times below)."""
    return Transaction(b"gpos", **{"timeout_s": 0.25, **kw})


def resync_from(t: float, timeout_s: float = 0.25) -> list:
    """What any recoverable fault at time ``t`` leads to: empty the input, 64 zeros, read their echo."""
    return [ResetInput(), Write(ZEROS), Receive(64, t + timeout_s)]


# -- step by step ---------------------------------------------------------------------------------
def test_a_move_request_is_written_byte_for_byte_and_its_echo_completes_it():
    move = Transaction(b"move", P.Move(9000, 128), timeout_s=0.25)
    assert move.start(10.0) == [Write(bytes.fromhex("6d 6f 76 65 28 23 00 00 80 00 00 00 00 00 00 00 a8 86")),
                                Receive(4, 10.25)]
    assert move.received(b"move", 10.01) == [Done(None)]


def test_a_query_reads_its_whole_answer_and_returns_it_decoded():
    query = gpos()
    assert query.start(0.0) == [Write(b"gpos"), Receive(26, 0.25)]
    assert query.received(GPOS_ANSWER, 0.01) == [Done(POSITION)]


def test_a_crc_corrupted_answer_is_resynchronised_retried_and_reported_recovered():
    query = gpos()
    query.start(0.0)
    assert query.received(CRC_FLIPPED, 0.125) == resync_from(0.125)
    assert query.received(b"\x00", 0.25) == [Wait(0.25 + 0.005), ResetInput()]  # the echo: settle 5 ms
    assert query.resume(0.375) == [Write(b"gpos"), Receive(26, 0.625)]
    assert query.received(GPOS_ANSWER, 0.5) == [
        Recovered(command="gpos", attempts=2, fault="gpos: answer CRC 0xc488 != computed 0xc588"), Done(POSITION)]


def test_an_answer_echoing_another_command_is_retried():
    query = gpos()
    query.start(0.0)
    assert query.received(b"gser", 0.125) == resync_from(0.125)
    query.received(ZEROS, 0.25)
    query.resume(0.375)
    assert query.received(GPOS_ANSWER, 0.5) == [
        Recovered(command="gpos", attempts=2, fault="expected echo b'gpos', got b'gser'"), Done(POSITION)]


def test_nothing_by_the_end_of_the_read_window_is_a_timeout():
    query = gpos()
    assert query.start(0.0) == [Write(b"gpos"), Receive(26, 0.25)]
    assert query.received(b"", 0.125) == [Receive(26, 0.25)]  # an early empty read: the window still runs
    assert query.received(b"", 0.25) == resync_from(0.25)
    assert query.last_fault == "no complete answer (got 0 bytes: )"


def test_a_partial_answer_then_silence_times_out_naming_what_came():
    query = gpos()
    query.start(0.0)
    assert query.received(GPOS_ANSWER[:10], 0.125) == [Receive(16, 0.375)]  # each byte opens a new window
    assert query.received(b"", 0.375) == resync_from(0.375)
    assert query.last_fault == "no complete answer (got 10 bytes: 67 70 6f 73 28 23 00 00 80 00)"


def test_an_answer_still_trickling_at_its_deadline_times_out():
    """Bytes keep each read window open, but the whole answer must come within max(3 x 0.25 s, 1 s)."""
    query = gpos()
    query.start(0.0)
    for i, t in enumerate([0.25, 0.5, 0.75]):
        assert query.received(GPOS_ANSWER[i:i + 1], t) == [Receive(25 - i, min(t + 0.25, 1.0))]
    assert query.received(GPOS_ANSWER[3:4], 1.0) == resync_from(1.0)
    assert query.last_fault == "no complete answer (got 4 bytes: 67 70 6f 73)"


def test_errv_fails_at_once_with_the_controllers_refusal():
    move = Transaction(b"move", P.Move(9000, 128))
    move.start(0.0)
    assert move.received(b"errv", 0.01) == [Failed("controller rejected a value (errv (value out of range))")]
    assert move.attempt == 1


@pytest.mark.parametrize("code", [b"errc", b"errd"])
def test_the_other_error_answers_are_retried(code):
    move = Transaction(b"move", P.Move(9000, 128), timeout_s=0.25)
    move.start(0.0)
    assert move.received(code, 0.125) == resync_from(0.125)
    assert move.last_fault == str(P.ErrorAnswer(code))


def test_after_the_last_attempt_it_resynchronises_and_gives_up_naming_the_last_fault():
    query = gpos(retries=2)
    assert query.start(0.0) == [Write(b"gpos"), Receive(26, 0.25)]
    assert query.received(b"", 0.25) == resync_from(0.25)
    assert query.received(b"\x00", 0.375) == [Wait(0.375 + 0.005), ResetInput()]
    assert query.resume(0.5) == [Write(b"gpos"), Receive(26, 0.75)]
    assert query.received(b"", 0.75) == resync_from(0.75)
    assert query.received(b"\x00", 0.875) == [Wait(0.875 + 0.005), ResetInput()]
    assert query.resume(1.0) == [Failed("no valid answer after 2 tries (last: no complete answer (got 0 bytes: ))")]


def test_a_resync_without_a_zero_echo_ends_after_half_a_second():
    query = gpos()
    query.start(0.0)
    assert query.received(b"", 0.25) == resync_from(0.25)
    assert query.received(b"", 0.5) == [Receive(64, 0.75)]
    assert query.received(b"junk", 0.625) == [Receive(64, 0.75)]  # bytes, but no zero among them
    assert query.received(b"", 0.75) == [Wait(0.75 + 0.005), ResetInput()]


def test_a_port_error_while_resynchronising_gives_the_resync_up_not_the_transaction():
    query = gpos()
    query.start(0.0)
    query.received(b"", 0.25)
    assert query.port_failed("[Errno 5] Input/output error", 0.25) == [Write(b"gpos"), Receive(26, 0.5)]


def test_a_vanished_port_is_closed_reopened_every_50_ms_and_the_request_sent_again():
    query = gpos()
    query.start(0.0)
    assert query.port_failed("write failed: [Errno 5] Input/output error", 0.0) == [Close(), Open()]
    assert query.port_failed("[Errno 2] could not open port", 0.0) == [Wait(0.05)]
    assert query.resume(0.05) == [Open()]
    assert query.resume(0.0625) == [Reconnected(), Write(b"gpos"), Receive(26, 0.3125)]
    assert query.received(GPOS_ANSWER, 0.125) == [
        Recovered("gpos", 2, "port error (write failed: [Errno 5] Input/output error)"), Done(POSITION)]


def test_a_port_that_stays_away_past_the_reopen_window_fails_the_transaction():
    query = gpos(reopen_s=0.125)
    query.start(0.0)
    assert query.port_failed("[Errno 5] Input/output error", 0.0) == [Close(), Open()]
    assert query.port_failed("[Errno 2] No such file or directory", 0.0625) == [Wait(0.0625 + 0.05)]
    assert query.resume(0.125) == [Failed(
        "port vanished and did not come back (port did not come back within 0.125 s ([Errno 2] No such file or directory))")]


def test_reopening_on_its_own_is_what_reconnect_does():
    reopen = Reopen(reopen_s=0.25)
    assert reopen.start(0.0) == [Close(), Open()]
    assert reopen.resume(0.01) == [Reconnected(), Done()]
    never = Reopen(reopen_s=0.0)
    assert never.start(0.0) == [Close(), Failed("port did not come back within 0 s (None)")]


def test_an_input_out_of_turn_is_a_policy_error():
    query = gpos()
    with pytest.raises(PolicyError, match="no 'received' expected in phase idle"):
        query.received(GPOS_ANSWER, 0.0)
    query.start(0.0)
    query.received(GPOS_ANSWER, 0.01)
    with pytest.raises(PolicyError, match="phase finished"):
        query.resume(0.02)


def test_a_value_out_of_range_is_refused_before_anything_is_sent():
    with pytest.raises(P.ValueRangeError, match="uPosition 300"):
        Transaction(b"move", P.Move(0, 300))


# -- wired to the emulated controller ---------------------------------------------------------------
class Line:
    """An in-memory serial line from the policy to a sans-I/O controller, on the controller's virtual clock.

    ``run`` carries out the policy's actions as a shell would; the line keeps what the host wrote, the
    size of every read and the events. ``chunk`` splits what the controller sends; ``garble`` are
    functions applied in transit to the next answers (zero echoes pass untouched); ``unplug`` makes
    the port vanish (I/O fails) until a reopen after ``for_s``.
    """

    def __init__(self, controller: Controller, *, chunk: int | None = None, garble=()) -> None:
        self.controller, self.clock = controller, controller.clock
        self.chunk, self.garble = chunk, list(garble)
        self.pending = bytearray()
        self.written: list[bytes] = []
        self.reads: list[int] = []
        self.events: list = []
        self.dead, self.back_at = False, 0.0

    def unplug(self, for_s: float) -> None:
        self.dead, self.back_at = True, self.clock.now() + for_s

    def run(self, policy):
        """The policy's outcome (Done or Failed) once its actions are carried out."""
        actions = policy.start(self.clock.now())
        while True:
            for action in actions:
                if isinstance(action, (Done, Failed)):
                    return action
                try:
                    following = self._carry_out(policy, action)
                except OSError as exc:
                    following = policy.port_failed(str(exc), self.clock.now())
                if following is not None:
                    break
            else:
                following = policy.resume(self.clock.now())
            actions = following

    def _carry_out(self, policy, action):
        if isinstance(action, (Recovered, Reconnected)):
            return self.events.append(action)
        if isinstance(action, Wait):
            return self.clock.advance(max(action.until - self.clock.now(), 0.0))
        if isinstance(action, Close):
            return None  # closing a dead port does not fail
        if isinstance(action, Open):
            return self._open()
        if self.dead:
            raise OSError(5, "Input/output error")
        if isinstance(action, Write):
            self.written.append(action.data)
            answer = self.controller.receive(action.data)
            self.pending += self.garble.pop(0)(answer) if self.garble and answer.strip(b"\x00") else answer
        elif isinstance(action, ResetInput):
            self.pending.clear()
        elif isinstance(action, Receive):
            return policy.received(self._read(action), self.clock.now())

    def _read(self, action: Receive) -> bytes:
        n = min(action.max_bytes, self.chunk or action.max_bytes, len(self.pending))
        if n == 0:
            self.clock.advance(max(action.until - self.clock.now(), 0.0))  # the whole window, in silence
        data = bytes(self.pending[:n])
        del self.pending[:n]
        self.reads.append(n)
        return data

    def _open(self) -> None:
        if self.clock.now() < self.back_at:
            raise OSError(2, "No such file or directory")
        self.dead = False
        self.controller.clear_input()


@pytest.fixture
def controller():
    return Controller(0x3A5C, clock=VirtualClock(yields=False))


def test_a_move_then_the_position_it_reached(controller):
    line = Line(controller)
    assert line.run(Transaction(b"move", P.Move(9000, 128))) == Done(None)
    controller.clock.sleep(60.0)
    assert line.run(Transaction(b"gpos")) == Done(POSITION)
    assert line.written == [bytes.fromhex("6d 6f 76 65 28 23 00 00 80 00 00 00 00 00 00 00 a8 86"), b"gpos"]
    assert line.events == []


def test_an_answer_in_one_byte_chunks_is_read_whole(controller):
    line = Line(controller, chunk=1)
    assert line.run(Transaction(b"gser")) == Done(P.SerialNumber(0x3A5C))
    assert line.reads == [1] * 10 and line.written == [b"gser"]


def test_zero_echoes_left_before_an_answer_are_skipped(controller):
    line = Line(controller)
    line.pending += b"\x00\x00\x00"  # late echoes of an earlier resynchronisation
    assert line.run(Transaction(b"gser")) == Done(P.SerialNumber(0x3A5C))
    assert line.events == []


def test_garbage_before_an_answer_costs_one_resynchronised_retry(controller):
    line = Line(controller)
    line.pending += b"\xff\xfe"
    assert line.run(Transaction(b"gpos")) == Done(P.Position(0, 0, 0))
    assert line.written == [b"gpos", ZEROS, b"gpos"]
    assert line.events == [Recovered("gpos", 2, "expected echo b'gpos', got b'\\xff\\xfegp'")]


def test_a_bit_flipped_on_the_wire_is_recovered_on_the_second_attempt(controller):
    line = Line(controller, garble=[lambda answer: answer[:-1] + bytes([answer[-1] ^ 0x01])])
    assert line.run(Transaction(b"gser")) == Done(P.SerialNumber(0x3A5C))
    assert line.written == [b"gser", ZEROS, b"gser"]
    assert line.events == [Recovered("gser", 2, GSER_CRC_FAULT)]


def test_a_silent_controller_exhausts_the_retries_in_bounded_time():
    controller = Controller(1, clock=VirtualClock(yields=False), faults=XimcFaults(drop_rate=1.0))
    line = Line(controller)
    outcome = line.run(Transaction(b"gpos", timeout_s=0.25, retries=3))
    assert outcome == Failed("no valid answer after 3 tries (last: no complete answer (got 0 bytes: ))")
    assert line.written == [b"gpos", ZEROS] * 3
    # each attempt: a 0.25 s read window, the zeros' echo at once, a 5 ms settle
    assert controller.clock.now() == pytest.approx(3 * (0.25 + 0.005))


def test_an_unplugged_port_is_reopened_when_it_comes_back(controller):
    line = Line(controller)
    line.unplug(for_s=0.12)
    assert line.run(Transaction(b"gser", reopen_s=1.0)) == Done(P.SerialNumber(0x3A5C))
    assert line.events == [Reconnected(), Recovered("gser", 2, "port error ([Errno 5] Input/output error)")]
    assert controller.clock.now() == pytest.approx(0.15)  # opens at 0, 50 and 100 ms fail, at 150 ms it works


def test_a_port_gone_for_longer_than_the_reopen_window_fails(controller):
    line = Line(controller)
    line.unplug(for_s=10.0)
    outcome = line.run(Transaction(b"gser", reopen_s=0.2))
    assert outcome == Failed("port vanished and did not come back "
                             "(port did not come back within 0.2 s ([Errno 2] No such file or directory))")
    assert line.written == []


# -- the shell: XimcLink (under Stage) on the in-memory ximcsim:// port -------------------------------
class Wire:
    """What ``ximcsim://`` connects to: a controller behind a wire that can flip a bit of the next answer
    or make the next write fail as if the port were unplugged."""

    def __init__(self, controller: Controller) -> None:
        self.controller = controller
        self.flip_next = False
        self.fail_next_write = False

    def receive(self, data: bytes) -> bytes:
        if self.fail_next_write:
            self.fail_next_write = False
            raise OSError(5, "Input/output error")
        answer = self.controller.receive(data)
        if self.flip_next and answer.strip(b"\x00"):
            self.flip_next = False
            answer = answer[:-1] + bytes([answer[-1] ^ 0x01])
        return answer

    def clear_input(self) -> None:
        self.controller.clear_input()


@pytest.fixture
def shell(request, controller):
    name = f"policy-{request.node.name}"
    wire = Wire(controller)
    events = []
    link = Stage(attach(name, wire), name="a1", timeout_s=0.05, reopen_s=0.2,
                 on_event=lambda kind, detail: events.append((kind, detail))).open()
    assert isinstance(link, XimcLink) and RECOVERABLE == (P.CrcError, P.EchoError)
    yield link, wire, events, name
    link.close()
    detach(name)


def test_the_shell_counts_and_reports_a_recovered_fault(shell):
    link, wire, events, _ = shell
    wire.flip_next = True
    assert link.transact(b"gser") == P.SerialNumber(0x3A5C)
    assert link.recovered == 1
    assert events == [("recovered", {"command": "gser", "attempts": 2, "fault": GSER_CRC_FAULT, "axis": "a1",
                                     "port": link.port})]


def test_the_shell_reopens_a_port_that_failed_and_reports_it(shell):
    link, wire, events, _ = shell
    wire.fail_next_write = True
    assert link.transact(b"gser") == P.SerialNumber(0x3A5C)
    assert events == [("reconnected", {"port": link.port, "axis": "a1"}),
                      ("recovered", {"command": "gser", "attempts": 2,
                                     "fault": "port error ([Errno 5] Input/output error)", "axis": "a1",
                                     "port": link.port})]
    link.reconnect()  # on its own: the same Reopen policy, its own event
    assert events[-1] == ("reconnected", {"port": link.port, "axis": "a1"})
    assert link.transact(b"gser") == P.SerialNumber(0x3A5C)


def test_the_shell_raises_the_policys_failures_word_for_word(shell, controller):
    link, wire, _, name = shell
    controller.faults = XimcFaults(error_answer_rate=1.0, error_answer="errv")
    with pytest.raises(TurntableError) as refused:
        link.transact(b"gpos")
    assert str(refused.value) == f"a1 ximcsim://{name}: gpos: controller rejected a value (errv (value out of range))"
    controller.faults = XimcFaults()
    wire.fail_next_write = True
    detach(name)
    with pytest.raises(TurntableError) as gone:
        link.transact(b"gpos")
    assert str(gone.value) == (f"a1 ximcsim://{name}: gpos: port vanished and did not come back (port did not come "
                               f"back within 0.2 s (no in-process controller named '{name}'))")
    with pytest.raises(TurntableError, match=f"^a1 ximcsim://{name}: gpos: port is not open$"):
        link.transact(b"gpos")

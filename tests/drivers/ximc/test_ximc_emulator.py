"""The emulator on its pty: several side by side, the 400 ms request gap, and its physical state."""

from __future__ import annotations

import os
import re
import tempfile
import time

import numpy as np
import pytest
import serial

from drivers.clock import VirtualClock
from drivers.ximc import protocol as P
from drivers.ximc.sim.emulator import ControllerEmulator


def test_emulators_side_by_side_each_answer_on_their_own_pty():
    """What ``rig sim`` (the one command line that starts emulators) relies on: N emulators,
    N distinct pty paths and stable paths, each answering with its own serial number."""
    emus = [ControllerEmulator(100 + i, clock=VirtualClock()) for i in range(2)]
    try:
        paths = [e.start() for e in emus]
        assert all(re.fullmatch(r"/dev/pts/\d+", p) for p in paths) and len(set(paths)) == 2
        assert [os.path.realpath(e.stable_path) for e in emus] == [os.path.realpath(p) for p in paths]
        for e, path in zip(emus, paths):
            with serial.Serial(path, 115200, stopbits=2, timeout=1) as s:
                s.write(b"gser")
                assert P.decode_answer(b"gser", s.read(10)).SerialNumber == e.serial_number
    finally:
        for e in emus:
            e.stop()


@pytest.fixture
def emu():
    clock = VirtualClock()
    e = ControllerEmulator(7, clock=clock)
    path = e.start()
    port = serial.Serial(path, 115200, stopbits=2, timeout=2.0)
    yield clock, e, port
    port.close()
    e.stop()


def test_a_partial_request_is_dropped_after_a_400_ms_gap(emu):
    _, _, port = emu
    frame = P.encode_request(b"move", P.Move(100, 0))
    port.write(frame[:7])
    time.sleep(0.5)  # longer than the controller's 400 ms byte-gap limit
    port.write(b"gser")  # a fresh request, not the tail of the dropped one
    assert port.read(4) == b"gser"


def test_a_short_gap_inside_a_request_is_tolerated(emu):
    _, _, port = emu
    frame = P.encode_request(b"move", P.Move(100, 0))
    port.write(frame[:7])
    time.sleep(0.1)
    port.write(frame[7:])
    assert port.read(4) == b"move"


def test_true_angle_and_rate_for_arrays_of_times(emu):
    clock, e, port = emu
    port.write(P.encode_request(b"smov", P.MoveSettings(2000, 0, 4000, 4000, 2000, 0, 0)))
    assert port.read(4) == b"smov"
    t0 = clock.now()
    # 10 deg at 20 deg/s max and 40 deg/s^2: 5 deg up to 20 deg/s in 0.5 s, 5 deg back down, done at 1 s
    port.write(P.encode_request(b"move", P.Move(1000, 0)))
    assert port.read(4) == b"move"
    t = t0 + np.array([0.0, 0.25, 0.5, 1.0, 5.0])
    ang = e.position_deg_at(t)
    rate = e.speed_deg_s_at(t)
    assert ang.shape == rate.shape == (5,)
    np.testing.assert_allclose(ang, [0.0, 1.25, 5.0, 10.0, 10.0], atol=1e-9)
    np.testing.assert_allclose(rate, [0.0, 10.0, 20.0, 0.0, 0.0], atol=1e-6)
    assert np.all(np.diff(ang) >= 0)


def test_an_emulator_leaves_nothing_on_disk_served_or_not(tmp_path, monkeypatch):
    """In-process rigs and the keep-up probe build emulators they never serve: those make no directory;
    a served one removes its stable path's directory when it stops."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    ControllerEmulator(1, clock=VirtualClock())
    assert list(tmp_path.iterdir()) == []
    served = ControllerEmulator(2, clock=VirtualClock())
    served.start()
    assert os.path.realpath(served.stable_path) == os.path.realpath(served.path)
    served.stop()
    assert list(tmp_path.iterdir()) == []

"""The emulator on its own: the command that starts it, the 400 ms request gap, and its physical state."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import serial

from drivers.clock import VirtualClock
from drivers.ximc import protocol as P
from drivers.ximc.sim.emulator import ControllerEmulator

from conftest import REPO


def test_the_command_starts_n_emulators_and_prints_their_paths():
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen([sys.executable, "-m", "drivers.ximc.sim.emulator", "--count", "2", "--serial-base", "100"],
                            cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        lines = [proc.stdout.readline() for _ in range(2)]
        paths = [re.search(r"(/dev/pts/\d+)", line).group(1) for line in lines]
        assert [re.search(r"serial (\d+)", line).group(1) for line in lines] == ["100", "101"]
        with serial.Serial(paths[1], 115200, stopbits=2, timeout=1) as s:
            s.write(b"gser")
            assert P.decode_answer(b"gser", s.read(10)).SerialNumber == 101
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=10)
    assert proc.returncode == 0


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

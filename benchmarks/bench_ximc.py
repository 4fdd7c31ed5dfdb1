"""Command round trip over the pseudo-terminal: our Stage driver <-> the emulated 8SMC5 (real time),
and, for comparison, the same requests through the sans-I/O controller in memory (no pty, no thread)."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from drivers.ximc import protocol as P
from drivers.ximc.sim.controller import Controller
from drivers.ximc.sim.emulator import ControllerEmulator
from drivers.ximc.stage import Stage


def in_memory(n: int = 20000) -> None:
    """Encode, controller ``receive``, decode: the protocol and emulation cost alone."""
    ctrl = Controller(1)
    for cmd, obj in ((b"gets", None), (b"gpos", None), (b"move", P.Move(0, 0))):
        frame = P.encode_request(cmd, obj)
        t0 = time.perf_counter()
        for _ in range(n):
            P.decode_answer(cmd, ctrl.receive(frame))
        dt = (time.perf_counter() - t0) / n * 1e3
        print(f"in memory {cmd.decode()} (encode, receive, decode)  n={n}  mean {dt:.4f} ms")


def main(n: int = 2000) -> None:
    emu = ControllerEmulator(1)
    stage = Stage(emu.start(), name="bench").open()
    try:
        for name, fn in (("gets (status, 54 B answer)", stage.get_status),
                         ("gpos (position, 26 B answer)", stage.get_position),
                         ("move (18 B request, 4 B echo)", lambda: stage.transact(b"move", P.Move(0, 0)))):
            dt = []
            for _ in range(n):
                t0 = time.perf_counter()
                fn()
                dt.append(time.perf_counter() - t0)
            dt = np.array(dt) * 1e3
            print(f"{name:32s} n={n}  median {np.median(dt):.3f} ms  p99 {np.percentile(dt, 99):.3f} ms  "
                  f"max {dt.max():.3f} ms")
    finally:
        stage.close()
        emu.stop()


if __name__ == "__main__":
    main()
    in_memory()

"""Clocks shared by the drivers, the simulators and the runner.

Every component that waits or timestamps takes a :class:`Clock`, so the same
code runs in real time against hardware, in scaled real time against the
emulators (``MonotonicClock(time_scale=20)``), or in virtual time where
``sleep`` advances time instantly (``VirtualClock``) for fast, deterministic
tests. Simulators compute their state lazily from ``clock.now()``.
"""

from __future__ import annotations

import threading
import time
from typing import Protocol, runtime_checkable


@runtime_checkable
class Clock(Protocol):
    """A monotonic time source in seconds, and a way to wait on it."""

    def now(self) -> float:
        """Current time in seconds (monotonic; origin is arbitrary)."""
        ...

    def sleep(self, dt_s: float) -> None:
        """Wait ``dt_s`` seconds of this clock's time."""
        ...


class MonotonicClock:
    """Real time, optionally sped up.

    Parameters
    ----------
    time_scale : float
        Clock seconds per wall second; 1.0 is real time, 20.0 runs 20x faster.
    """

    def __init__(self, time_scale: float = 1.0) -> None:
        if not time_scale > 0:
            raise ValueError(f"time_scale must be > 0, got {time_scale!r}")
        self.time_scale = float(time_scale)
        self._t0 = time.monotonic()

    def now(self) -> float:
        return (time.monotonic() - self._t0) * self.time_scale

    def sleep(self, dt_s: float) -> None:
        if dt_s > 0:
            time.sleep(dt_s / self.time_scale)

    def __repr__(self) -> str:
        return f"MonotonicClock(time_scale={self.time_scale:g})"


class VirtualClock:
    """Simulated time that advances only when somebody sleeps.

    ``sleep(dt)`` advances the shared time by ``dt`` at once (and yields the
    GIL briefly so emulator threads can answer). Thread-safe. Used for the
    simulated rig in tests and benchmarks: a 10 s dwell costs no wall time.
    """

    def __init__(self, start_s: float = 0.0) -> None:
        self._t = float(start_s)
        self._lock = threading.Lock()

    def now(self) -> float:
        with self._lock:
            return self._t

    def sleep(self, dt_s: float) -> None:
        if dt_s > 0:
            with self._lock:
                self._t += float(dt_s)
        time.sleep(0)

    def advance(self, dt_s: float) -> None:
        """Advance time without yielding (for simulators and tests)."""
        with self._lock:
            self._t += float(dt_s)

    def __repr__(self) -> str:
        return f"VirtualClock(t={self.now():.6f})"

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

    ``sleep(dt)`` advances the shared time by ``dt`` at once (and, while
    ``yields`` is true, yields the GIL briefly so emulator threads serving
    pseudo-terminals can answer; with no such threads, as when the emulated
    controllers run in process, the yield only loses the CPU on a busy machine).
    Thread-safe. Used for the simulated rig in tests and benchmarks: a 10 s
    dwell costs no wall time.
    """

    def __init__(self, start_s: float = 0.0, *, yields: bool = True) -> None:
        self._t = float(start_s)
        self._lock = threading.Lock()
        self.yields = yields

    def now(self) -> float:
        with self._lock:
            return self._t

    def sleep(self, dt_s: float) -> None:
        if dt_s > 0:
            with self._lock:
                self._t += float(dt_s)
        if self.yields:
            time.sleep(0)

    def advance(self, dt_s: float) -> None:
        """Advance time without yielding (for simulators and tests)."""
        with self._lock:
            self._t += float(dt_s)

    def __repr__(self) -> str:
        return f"VirtualClock(t={self.now():.6f})"


class ElasticClock:
    """Simulated time at ``time_scale`` times wall time that waits for its reader.

    The simulated world (emulated controllers, chamber, sensor) reads this clock; a simulated sensor
    whose FIFO is running *holds* it (:meth:`hold`) at the moment its FIFO would be full. When the
    program reading the sensor falls behind (a busy machine, a pause), simulated time stops there
    until the FIFO is read and the hold moves on, then goes on at ``time_scale`` from where it
    stopped: the run slows down instead of losing samples, and motion, temperature and samples stay
    consistent because every part of the world reads the same clock.

    A hold that nobody lifts for ``max_stall_wall_s`` of wall time (the reader is gone, not late:
    the run is stopping on an error, say) is dropped, so time never stops for good; samples lost
    after that are the reader's, as on hardware.

    Parameters
    ----------
    time_scale : float
        Simulated seconds per wall second while nobody holds the clock (> 0).
    max_stall_wall_s : float
        Wall seconds a hold may stop time before it is dropped.
    """

    def __init__(self, time_scale: float = 1.0, max_stall_wall_s: float = 5.0) -> None:
        if not time_scale > 0:
            raise ValueError(f"time_scale must be > 0, got {time_scale!r}")
        self.time_scale = float(time_scale)
        self.max_stall_wall_s = float(max_stall_wall_s)
        self._wall0 = time.monotonic()
        self._sim0 = 0.0  # simulated time at wall time _wall0 (moved whenever a hold stops time)
        self._holds: dict[object, float] = {}
        self._held_since: float | None = None  # wall time at which the current stall began
        self._last = 0.0  # the latest time returned: a hold below it never turns time back
        self._lock = threading.Lock()
        #: simulated time is behind scaled wall time by this much, s of wall time (all stalls so far)
        self.stalled_wall_s = 0.0
        #: holds dropped because nobody lifted them within max_stall_wall_s
        self.dropped_holds = 0

    def now(self) -> float:
        with self._lock:
            return self._now(time.monotonic())

    def _now(self, wall: float) -> float:
        free = self._sim0 + (wall - self._wall0) * self.time_scale
        limit = max(min(self._holds.values()), self._last) if self._holds else free
        if free <= limit:
            self._held_since = None
            self._last = free
            return free
        if self._held_since is None:
            self._held_since = wall
        elif wall - self._held_since > self.max_stall_wall_s:
            self._holds.clear()
            self._held_since = None
            self.dropped_holds += 1
        self.stalled_wall_s += (free - limit) / self.time_scale
        self._sim0, self._wall0 = limit, wall  # time stands at the hold, and resumes from it
        self._last = limit
        return limit

    def sleep(self, dt_s: float) -> None:
        """Wait ``dt_s / time_scale`` wall seconds (less simulated time passes while the clock is held)."""
        if dt_s > 0:
            time.sleep(dt_s / self.time_scale)

    def hold(self, owner: object, until_s: float) -> None:
        """Simulated time does not pass ``until_s`` while ``owner``'s hold stands (replaces its last one)."""
        with self._lock:
            self._now(time.monotonic())  # settle the time before the hold moves
            self._holds[owner] = float(until_s)
            self._held_since = None

    def hold_now(self, owner: object) -> float:
        """Stop time where it is for ``owner`` (until its next :meth:`hold` or :meth:`release`); return it."""
        with self._lock:
            t = self._now(time.monotonic())
            self._holds[owner] = t
            self._held_since = None
            return t

    def release(self, owner: object) -> None:
        """Lift ``owner``'s hold (if any)."""
        with self._lock:
            self._now(time.monotonic())
            self._holds.pop(owner, None)

    def __repr__(self) -> str:
        return f"ElasticClock(time_scale={self.time_scale:g})"

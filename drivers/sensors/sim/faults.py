"""Sensor fault injection for the simulated chips (all off by default; times in clock seconds)."""

from __future__ import annotations

import errno
import random
from dataclasses import dataclass


@dataclass
class SensorFaults:
    """
    Attributes
    ----------
    oserror_rate : probability that one bus transfer fails with EREMOTEIO.
    oserror_window_s : [start, end] clock times during which every transfer fails (a burst).
    dead_after_s : the chip stops answering for good after this clock time.
    stuck_after_s : the output registers freeze after this clock time.
    saturate_after_s : outputs are forced to the rails after this clock time.
    thermometer_fail_after_s : the temperature register reads an absurd value after this time.
    seed : seeds the random faults.
    failed_self_test : the MPU-9150's self-test response is 45 % of its factory trim (the test fails).
    """

    oserror_rate: float = 0.0
    oserror_window_s: list | None = None
    dead_after_s: float | None = None
    stuck_after_s: float | None = None
    saturate_after_s: float | None = None
    thermometer_fail_after_s: float | None = None
    seed: int = 0
    failed_self_test: bool = False


class FaultInjector:
    def __init__(self, faults: SensorFaults | None, clock) -> None:
        self.f = faults or SensorFaults()
        self.clock = clock
        self.rng = random.Random(self.f.seed)

    def check_access(self) -> None:
        now = self.clock.now()
        f = self.f
        if f.dead_after_s is not None and now >= f.dead_after_s:
            raise OSError(errno.EREMOTEIO, "Remote I/O error")
        if f.oserror_window_s and f.oserror_window_s[0] <= now < f.oserror_window_s[1]:
            raise OSError(errno.EREMOTEIO, "Remote I/O error")
        if f.oserror_rate and self.rng.random() < f.oserror_rate:
            raise OSError(errno.EREMOTEIO, "Remote I/O error")

    def active(self, name: str, t) -> bool:
        v = getattr(self.f, name)
        return v is not None and t >= v

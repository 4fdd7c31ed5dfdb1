"""Common types of the I2C sensor drivers (the ``AccelSensor`` interface the runner uses)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


class SensorError(Exception):
    """A sensor failed; one line: chip, bus address, what went wrong."""


class SensorAbsent(SensorError):
    """No chip answered at the sensor's address when its identity was read: not there, not powered or not
    wired (a fixture slot left empty is ABSENT, not a failed unit)."""


@dataclass(frozen=True)
class SensorSettings:
    accel_range_g: int = 4
    sample_rate_hz: float = 100.0
    gyro_range_dps: int = 250


@dataclass(frozen=True)
class SensorIdentity:
    model: str
    address: int
    identity_register: int | None
    identity_value: int | None
    bus: str = ""

    def to_dict(self) -> dict:
        return {"model": self.model, "address": self.address, "identity_register": self.identity_register,
                "identity_value": self.identity_value, "bus": self.bus}


@dataclass
class CaptureStats:
    """Counters of a capture (they stay 0 when nothing goes wrong)."""

    received: int = 0
    dropped: int = 0  # samples known lost (FIFO overflow)
    duplicated: int = 0
    overflows: int = 0
    io_retries: int = 0


@dataclass(frozen=True)
class SampleBlock:
    """Samples read in one go, or of one capture: times (clock seconds), raw accelerometer counts (N, 3),
    temperature (C, NaN: none) and raw gyroscope counts (N, 3; None: no gyroscope)."""

    t_s: np.ndarray
    accel_counts: np.ndarray
    temp_c: np.ndarray
    gyro_counts: np.ndarray | None = None

    @classmethod
    def empty(cls, with_gyro: bool) -> "SampleBlock":
        """No samples (with an empty gyroscope array when ``with_gyro``)."""
        return cls(np.empty(0), np.empty((0, 3), np.int64), np.empty(0),
                   np.empty((0, 3), np.int64) if with_gyro else None)

    def __len__(self) -> int:
        return len(self.t_s)


@dataclass(frozen=True)
class SelfTestAxis:
    """One axis of a self-test: the factory trim, the measured response (output with the self-test
    on minus output without, counts at the trim's range) and their relative deviation."""

    sensor: str  # "accel" or "gyro"
    axis: str  # "x", "y", "z"
    code: int  # the factory-trim code read from the chip (0: no trim)
    factory_trim: float  # counts
    response: float  # counts
    deviation_pct: float  # 100 (response - trim) / trim
    passed: bool


@dataclass(frozen=True)
class SelfTestResult:
    """A chip's self-test: every axis within ``tolerance_pct`` of its factory trim passes."""

    model: str
    address: int
    axes: tuple[SelfTestAxis, ...]
    tolerance_pct: float

    @property
    def passed(self) -> bool:
        return all(a.passed for a in self.axes)

    def failures(self) -> list[str]:
        """One entry per failing axis ("accel x: response -55.0 % from factory trim")."""
        return [f"{a.sensor} {a.axis}: response {a.deviation_pct:+.1f} % from factory trim" for a in self.axes
                if not a.passed]

    def summary(self) -> str:
        """One line: passed, or which axes failed."""
        head = f"{self.model} at 0x{self.address:02x}: self-test"
        if self.passed:
            return f"{head} passed (every axis within {self.tolerance_pct:g} % of its factory trim)"
        return f"{head} FAILED ({'; '.join(self.failures())}; limit {self.tolerance_pct:g} %)"

    def to_dict(self) -> dict:
        return {"model": self.model, "address": self.address, "passed": self.passed,
                "tolerance_pct": self.tolerance_pct, "axes": [dict(a.__dict__) for a in self.axes]}


class AccelSensor(Protocol):
    model: str
    address: int
    has_temperature: bool
    has_gyro: bool
    accel_lsb_per_g: float
    gyro_lsb_per_dps: float | None
    sample_rate_hz: float
    accel_range_g: int
    #: samples the sensor's FIFO holds: how long the host may leave it unread (the poll interval's measure)
    fifo_samples: int
    stats: CaptureStats

    def identify(self) -> SensorIdentity: ...
    def configure(self, settings: SensorSettings) -> None: ...
    def start(self) -> None: ...
    def read(self) -> SampleBlock: ...
    def stop(self) -> None: ...


def check_identity(bus, address: int, model: str, register: int, register_name: str, expected: int,
                   hint: str = "check wiring and address") -> SensorIdentity:
    """Read an identity register; SensorError (one line) on no answer or a wrong value."""
    try:
        value = bus.read_byte_data(address, register)
    except OSError as exc:
        raise SensorAbsent(f"{model} at 0x{address:02x}: no answer on the I2C bus ({exc.strerror or exc}); "
                           f"{hint}") from None
    if value != expected:
        raise SensorError(f"{model} at 0x{address:02x}: {register_name} reads 0x{value:02x}, expected "
                          f"0x{expected:02x} (wrong chip at this address?)")
    return SensorIdentity(model, address, register, value, str(getattr(bus, "bus", "")))


class BusRetry:
    """Bounded retries of transient bus errors (EREMOTEIO bursts), counted in ``stats``."""

    def __init__(self, bus, address: int, model: str, stats: CaptureStats, attempts: int = 4) -> None:
        self.bus, self.address, self.model, self.stats, self.attempts = bus, address, model, stats, attempts

    def __call__(self, method: str, *args):
        last = None
        for i in range(self.attempts):
            try:
                return getattr(self.bus, method)(self.address, *args)
            except OSError as exc:
                last = exc
                if i + 1 < self.attempts:
                    self.stats.io_retries += 1
        raise SensorError(f"{self.model} at 0x{self.address:02x}: I2C {method} failed {self.attempts} times "
                          f"({last.strerror or last})")

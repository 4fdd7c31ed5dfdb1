"""The I2C bus budget of a fixture: how much wire time reading N slots at a rate takes (pure arithmetic).

docs/fixture.md, "Bus budget", derives the formula. In short, at bus clock f (400 kHz, Fast-mode)
every byte on the wire takes 9 bit times (8 bits and the acknowledge) and every START, repeated
START, STOP and the bus-free time before a START one bit time each:

- a register read of n bytes (S, address+W, register, Sr, address+R, n bytes, P, free):
  ``9 (n + 3) + 4`` bits (:func:`read_bits`);
- a multiplexer select, the driver's send byte and its read-back (S, address, byte, P, free):
  ``2 (9 * 2 + 3) = 42`` bits (:data:`MUX_SELECT_BITS`).

Per slot and poll of its FIFO the host selects the slot's channel (when it is behind a multiplexer;
once more to deselect the other multiplexer when its bus has several), reads the chip's status
registers, then the new samples in block reads of at most 32 bytes (:class:`ReadPlan`, one per chip
model: what its driver reads). The host polls when a quarter of the FIFO has filled, at most every
0.25 s (:func:`poll_interval_s`, the capture's rule), so per second a slot costs::

    polls_hz * (select + status reads + FIFO blocks of ceil(rate / polls_hz) samples)

and a bus carries its slots when their sum is at most :data:`MAX_BUS_SHARE` of ``f``: the other half
is for what the wire count leaves out (the host's gaps between transfers, clock stretching, retries,
the magnetometer).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from drivers.sensors.adxl345 import Adxl345
from drivers.sensors.mpu9150 import SAMPLE_BYTES as MPU9150_SAMPLE_BYTES
from drivers.sensors.mpu9150 import Mpu9150

I2C_FAST_MODE_HZ = 400_000
#: bit times of one byte on the wire: 8 data bits and the acknowledge
BYTE_BITS = 9
#: bit times of a START, repeated START or STOP condition, and of the bus-free time before a START
CONDITION_BITS = 1
#: the share of the wire time a fixture may plan to use
MAX_BUS_SHARE = 0.5
#: the capture's poll rule (rig.execution.capture.poll_interval_s; a test keeps them equal): read the FIFO
#: when this share of it has filled, and at least every POLL_MAX_S seconds
POLL_FIFO_SHARE, POLL_MAX_S = 0.25, 0.25
#: the largest SMBus block read
SMBUS_BLOCK_MAX = 32


def read_bits(n: int) -> int:
    """Bit times of a register read of ``n`` bytes: S, address+W, register, Sr, address+R, n bytes, P, free."""
    return BYTE_BITS * (n + 3) + 4 * CONDITION_BITS


def byte_transfer_bits() -> int:
    """Bit times of an SMBus send byte or receive byte (S, address, one byte, P, free): 21."""
    return BYTE_BITS * 2 + 3 * CONDITION_BITS


#: a multiplexer select as the driver does it: the send byte and its read-back (42 bit times)
MUX_SELECT_BITS = 2 * byte_transfer_bits()


@dataclass(frozen=True)
class ReadPlan:
    """How the driver of a chip reads it, in bytes.

    Attributes
    ----------
    sample_bytes : int
        One FIFO sample.
    block_bytes : int
        The largest FIFO block read (whole samples, at most 32).
    poll_reads : tuple of int
        The register reads before the samples at every poll (status, FIFO count), bytes each.
    fifo_samples : int
        Samples the FIFO holds (sets the poll interval).
    """

    sample_bytes: int
    block_bytes: int
    poll_reads: tuple[int, ...]
    fifo_samples: int


#: per chip model, what its driver reads (drivers/sensors/mpu9150.py, adxl345.py ``read``)
READ_PLANS: dict[str, ReadPlan] = {
    # INT_STATUS (1), FIFO_COUNTH/L (2), then FIFO_R_W in blocks of two 14-byte samples
    "MPU-9150": ReadPlan(MPU9150_SAMPLE_BYTES, 2 * MPU9150_SAMPLE_BYTES, (1, 2), Mpu9150.fifo_samples),
    # INT_SOURCE (1), FIFO_STATUS (1), then DATAX0..DATAZ1 (6) once per FIFO entry
    "ADXL345": ReadPlan(6, 6, (1, 1), Adxl345.fifo_samples),
}


def poll_interval_s(plan: ReadPlan, rate_hz: float) -> float:
    """Seconds between two reads of a FIFO at ``rate_hz`` (Hz): a quarter of it filled, at most 0.25 s."""
    return min(POLL_MAX_S, POLL_FIFO_SHARE * plan.fifo_samples / rate_hz)


def fifo_read_bits(plan: ReadPlan, samples: int) -> int:
    """Bit times of reading ``samples`` samples in block reads of at most ``plan.block_bytes``."""
    per_block = plan.block_bytes // plan.sample_bytes
    full, rest = divmod(samples, per_block)
    return full * read_bits(plan.block_bytes) + (read_bits(rest * plan.sample_bytes) if rest else 0)


def slot_bits_per_s(model: str, rate_hz: float, *, selects: int = 0) -> float:
    """Wire time one slot takes, in bit times per second.

    Parameters
    ----------
    model : str
        The slot's chip (a key of :data:`READ_PLANS`).
    rate_hz : float
        Its output rate, Hz.
    selects : int
        Multiplexer selects per poll: 0 (on the bus itself), 1 (behind a multiplexer), 2 (behind one
        of several multiplexers on its bus: the other one is deselected first).
    """
    plan = READ_PLANS[model]
    interval = poll_interval_s(plan, rate_hz)
    samples = math.ceil(rate_hz * interval - 1e-9)
    per_poll = selects * MUX_SELECT_BITS + sum(read_bits(n) for n in plan.poll_reads) + fifo_read_bits(plan, samples)
    return per_poll / interval


@dataclass(frozen=True)
class BusLoad:
    """The wire time the slots of one bus take.

    Attributes
    ----------
    bits_per_s : tuple of float
        Per slot, in the order given, bit times per second.
    clock_hz : float
        The bus clock, Hz (bit times per second).
    """

    bits_per_s: tuple[float, ...]
    clock_hz: float

    @property
    def total_bits_per_s(self) -> float:
        return float(sum(self.bits_per_s))

    @property
    def share(self) -> float:
        """Used share of the wire time (1.0: all of it)."""
        return self.total_bits_per_s / self.clock_hz

    def first_over(self, limit: float = MAX_BUS_SHARE) -> int | None:
        """Index of the first slot whose cumulative load exceeds ``limit`` of the wire time (None: all fit)."""
        total = 0.0
        for i, bits in enumerate(self.bits_per_s):
            total += bits
            if total > limit * self.clock_hz:
                return i
        return None


def bus_load(slots, rate_hz: float, clock_hz: float = I2C_FAST_MODE_HZ) -> BusLoad:
    """The load of one bus.

    Parameters
    ----------
    slots : sequence of (model, mux)
        Each slot's chip model and its multiplexer address (None: on the bus itself).
    rate_hz : float
        Every slot's output rate, Hz.
    clock_hz : float
        The bus clock, Hz.
    """
    muxes = {mux for _, mux in slots if mux is not None}
    selects = 2 if len(muxes) > 1 else 1
    return BusLoad(tuple(slot_bits_per_s(model, rate_hz, selects=0 if mux is None else selects)
                         for model, mux in slots), float(clock_hz))


def max_slots(model: str, rate_hz: float, *, muxed: bool = True, clock_hz: float = I2C_FAST_MODE_HZ,
              limit: float = MAX_BUS_SHARE) -> int:
    """How many slots of ``model`` one bus (behind one multiplexer, when ``muxed``) carries at ``rate_hz``."""
    return int(limit * clock_hz // slot_bits_per_s(model, rate_hz, selects=1 if muxed else 0))

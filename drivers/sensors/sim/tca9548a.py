"""Register-level model of the TCA9548A 8-channel I2C switch on the simulated bus.

One register, the control register (TI SCPS207, section 8.6): an SMBus *send byte* writes it, a
*receive byte* reads it; when a transfer carries several bytes the last one is kept (a
``write_byte_data(0x70, reg, value)`` leaves ``value``). Bit n connects channel n: devices attached
to :meth:`Tca9548aModel.channel` ``(n)`` answer on the upstream bus only while bit n is set
(:meth:`~drivers.sensors.sim.bus.I2CDevice.downstream`); several channels may be connected at once,
and two devices at one address on connected channels answer together (wired AND). Power-up and
:meth:`Tca9548aModel.reset` (the RESET pin): 0x00, nothing connected.

Faults (:class:`MuxFaults`, all off by default, times in clock seconds): a stuck control register
(selections acknowledged and ignored, one channel stays connected) and NACKs (the switch stops
acknowledging its own address, for good or at random); what is behind it keeps the last selection.
"""

from __future__ import annotations

import errno
import random
from dataclasses import dataclass

from drivers.sensors.sim.bus import I2CDevice, SimulatedI2CBus
from drivers.sensors.tca9548a import CHANNELS, CONTROL_RESET, DEFAULT_ADDRESS, channels_of, control_byte


@dataclass
class MuxFaults:
    """
    Attributes
    ----------
    stuck_channel : the control register is stuck connecting this channel (0..7): every write is
        acknowledged and ignored, every read gives ``1 << stuck_channel``.
    nack_after_s : from this clock time on the switch no longer acknowledges its address (EREMOTEIO).
    nack_rate : probability that one transfer to the switch is not acknowledged (EREMOTEIO).
    seed : seeds the random NACKs.
    """

    stuck_channel: int | None = None
    nack_after_s: float | None = None
    nack_rate: float = 0.0
    seed: int = 0


class Tca9548aModel(I2CDevice):
    """Simulated TCA9548A.

    Parameters
    ----------
    clock : Clock or None
        Needed only for ``faults.nack_after_s``.
    faults : MuxFaults or None
    """

    is_switch = True

    def __init__(self, *, clock=None, faults: MuxFaults | None = None) -> None:
        self.faults = faults or MuxFaults()
        if self.faults.nack_after_s is not None and clock is None:
            raise ValueError("MuxFaults.nack_after_s needs a clock")
        self.clock = clock
        self._rng = random.Random(self.faults.seed)
        self._channels = tuple(SimulatedI2CBus(f"channel {n}") for n in range(CHANNELS))
        self.control = CONTROL_RESET
        self._stuck = None if self.faults.stuck_channel is None else control_byte(self.faults.stuck_channel)
        self.reset()

    def attach(self, bus: SimulatedI2CBus, address: int = DEFAULT_ADDRESS) -> "Tca9548aModel":
        """Plug into ``bus`` at ``address`` (0x70..0x77); names the channel segments after it."""
        bus.add_device(address, self)
        for n, seg in enumerate(self._channels):
            seg.bus = f"{bus.bus}/0x{address:02x}/{n}"
        return self

    def channel(self, n: int) -> SimulatedI2CBus:
        """The downstream segment of channel ``n``: attach devices to it as to any simulated bus."""
        if not 0 <= n < CHANNELS:
            raise ValueError(f"TCA9548A: channel {n} is not 0..{CHANNELS - 1}")
        return self._channels[n]

    def reset(self) -> None:
        """The RESET pin: control register 0x00 (a stuck register stays stuck)."""
        self.control = CONTROL_RESET if self._stuck is None else self._stuck

    def connected(self) -> tuple[int, ...]:
        """The channels connected now."""
        return channels_of(self.control)

    # -- I2CDevice -----------------------------------------------------------------------------
    def check_access(self) -> None:
        f = self.faults
        if f.nack_after_s is not None and self.clock.now() >= f.nack_after_s:
            raise OSError(errno.EREMOTEIO, "Remote I/O error")
        if f.nack_rate and self._rng.random() < f.nack_rate:
            raise OSError(errno.EREMOTEIO, "Remote I/O error")

    def _write(self, value: int) -> None:
        if self._stuck is None:
            self.control = value & 0xFF

    def send_byte(self, value: int) -> None:
        self._write(value)

    def receive_byte(self) -> int:
        return self.control

    def read_registers(self, register: int, length: int) -> bytes:
        """A read of any length returns the control register in every byte (there is no pointer)."""
        return bytes([self.control] * length)

    def write_registers(self, register: int, data: bytes) -> None:
        """The 'register' byte is the first data byte: the last byte of the transfer is kept."""
        self._write((bytes([register & 0xFF]) + bytes(data))[-1])

    def downstream(self, address: int) -> list[I2CDevice]:
        found: list[I2CDevice] = []
        for n in channels_of(self.control):
            found.extend(self._channels[n].answering(address))
        return found

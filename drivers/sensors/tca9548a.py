"""TCA9548A 8-channel I2C switch over an smbus2-compatible bus: select a channel, check it took.

The TCA9548A (TI data sheet SCPS207) has no register address: its one register, the control
register, is written by an SMBus *send byte* (``write_byte(address, value)``) and read by a *receive
byte* (``read_byte(address)``). Bit n set connects downstream channel n (SDn/SCn) to the upstream
bus; several bits may be set; 0x00 (the power-up and reset value) connects none. When several bytes
are written in one transfer, the last one is kept.

The pure part is :func:`control_byte` and :func:`channels_of` (the byte for a selection and back);
:class:`Tca9548a` writes the byte, reads it back and raises :class:`MuxError` (one line naming the bus,
the address and the channel) when the switch does not answer or did not take the selection.
"""

from __future__ import annotations

from drivers.sensors.base import CaptureStats, SensorError

MODEL = "TCA9548A"
#: 7-bit addresses: 0x70 + (A2 A1 A0)
ADDRESSES: tuple[int, ...] = tuple(range(0x70, 0x78))
DEFAULT_ADDRESS = 0x70
CHANNELS = 8
#: the control register after power-up or a reset (RESET pin low): no channel connected
CONTROL_RESET = 0x00
#: attempts of one transfer before a select fails (transient EREMOTEIO, as the sensor drivers retry)
ATTEMPTS = 4


class MuxError(SensorError):
    """The multiplexer failed; one line: model, address, bus, channel, what went wrong."""


def control_byte(channels) -> int:
    """The control-register byte that connects ``channels``.

    Parameters
    ----------
    channels : int, iterable of int or None
        One channel (0..7), several, or None / empty for none.

    Returns
    -------
    int
        The byte, bit n for channel n (0x00: none).
    """
    if channels is None:
        return CONTROL_RESET
    chans = tuple(channels) if isinstance(channels, (tuple, list, range, set, frozenset)) else (channels,)
    byte = 0
    for ch in chans:
        if isinstance(ch, bool) or not isinstance(ch, int) or not 0 <= ch < CHANNELS:
            raise ValueError(f"{MODEL}: channel {ch!r} is not 0..{CHANNELS - 1}")
        byte |= 1 << ch
    return byte


def channels_of(byte: int) -> tuple[int, ...]:
    """The channels a control-register byte connects, in increasing order (() for 0x00)."""
    return tuple(ch for ch in range(CHANNELS) if byte >> ch & 1)


def _named(channels) -> str:
    if channels is None or channels == ():
        return "no channel"
    chans = (channels,) if isinstance(channels, int) else tuple(channels)
    return f"channel{'s' if len(chans) > 1 else ''} {', '.join(map(str, chans))}"


class Tca9548a:
    """One TCA9548A on an I2C bus.

    Parameters
    ----------
    bus : smbus2.SMBus or SimulatedI2CBus
        The upstream bus.
    address : int
        0x70..0x77 (A2 A1 A0 strapping).
    bus_name : str or None
        How errors name the bus (``/dev/i2c-1``); default the bus object's ``bus`` attribute (a
        ``SimulatedI2CBus`` has one, ``smbus2.SMBus`` does not: give it).
    """

    model = MODEL
    channels = CHANNELS

    def __init__(self, bus, address: int = DEFAULT_ADDRESS, *, bus_name: str | None = None) -> None:
        if address not in ADDRESSES:
            raise MuxError(f"{MODEL}: address 0x{address:02x} is not one of 0x70..0x77")
        self.bus = bus
        self.address = address
        self.bus_name = bus_name if bus_name is not None else _bus_label(bus)
        self.stats = CaptureStats()

    def _where(self) -> str:
        return f"{MODEL} at 0x{self.address:02x} on bus {self.bus_name}"

    def _transfer(self, method: str, *args, doing: str):
        last = None
        for i in range(ATTEMPTS):
            try:
                return getattr(self.bus, method)(self.address, *args)
            except OSError as exc:
                last = exc
                if i + 1 < ATTEMPTS:
                    self.stats.io_retries += 1
        raise MuxError(f"{self._where()}: no answer {doing} ({last.strerror or last}, {ATTEMPTS} attempts); "
                       "check wiring, the A0-A2 address pins and the RESET line")

    def read_control(self) -> int:
        """The control register as the switch reports it (receive byte)."""
        return self._transfer("read_byte", doing="reading the control register")

    def selected(self) -> tuple[int, ...]:
        """The channels the switch reports connected."""
        return channels_of(self.read_control())

    def select(self, channels) -> None:
        """Connect ``channels`` (one channel, several, or None for none) and check the switch took it.

        Raises
        ------
        MuxError
            The switch does not answer, or its control register reads back something else (a stuck
            switch, a second device at this address).
        """
        try:
            byte = control_byte(channels)
        except ValueError as exc:
            raise MuxError(f"{self._where()}: {exc}") from None
        self._transfer("write_byte", byte, doing=f"selecting {_named(channels)}")
        back = self._transfer("read_byte", doing=f"reading back the selection of {_named(channels)}")
        if back != byte:
            raise MuxError(f"{self._where()}: selecting {_named(channels)} did not take (control register reads "
                           f"0x{back:02x} = {_named(channels_of(back))}, expected 0x{byte:02x})")

    def disable(self) -> None:
        """Connect no channel (control 0x00), checked like :meth:`select`."""
        self.select(None)


def _bus_label(bus) -> str:
    name = getattr(bus, "bus", None)
    if isinstance(name, int) and not isinstance(name, bool):
        return f"/dev/i2c-{name}"
    return str(name) if name not in (None, "") else "?"

"""A simulated I2C bus with smbus2's ``SMBus`` method signatures.

Register-level device models plug in at addresses; the drivers (ours and
third-party ones) talk to it exactly as to ``smbus2.SMBus(1)``.

An I2C switch (a multiplexer such as the TCA9548A, :mod:`drivers.sensors.sim.tca9548a`) is a device
with ``is_switch = True`` whose :meth:`I2CDevice.downstream` lists the devices its selected channels
connect: a transfer reaches every device that answers at its address, on the bus itself or behind a
switch. When several answer (two chips at one address on connected segments), they answer together as
on real wires (:class:`WiredAnd`: writes reach all, read bytes are ANDed, the open-drain line).
"""

from __future__ import annotations

import errno


class I2CDevice:
    """Interface of a device on the simulated bus (register-addressed)."""

    def read_registers(self, register: int, length: int) -> bytes:  # pragma: no cover - interface
        raise NotImplementedError

    def write_registers(self, register: int, data: bytes) -> None:  # pragma: no cover - interface
        raise NotImplementedError

    def check_access(self) -> None:
        """Raise OSError to simulate a failing transfer (faults)."""

    #: a switch connects further devices (:meth:`downstream`); the bus asks only switches
    is_switch = False

    def send_byte(self, value: int) -> None:
        """SMBus *send byte* (no register address): a register-addressed chip takes it as its pointer."""
        self.pointer = value & 0xFF

    def receive_byte(self) -> int:
        """SMBus *receive byte*: the register at the pointer."""
        return self.read_registers(getattr(self, "pointer", 0), 1)[0]

    def downstream(self, address: int) -> list["I2CDevice"]:
        """The devices this one connects to its bus that answer at ``address`` (a switch; others: none)."""
        return []


class WiredAnd(I2CDevice):
    """Several devices answering one address at once: writes reach every one, reads are the bitwise AND
    of their bytes (open-drain SDA: a 0 wins); a transfer fails only if every device fails."""

    def __init__(self, devices: list) -> None:
        self.devices = devices

    @property
    def pointer(self) -> int:
        return getattr(self.devices[0], "pointer", 0)

    @pointer.setter
    def pointer(self, value: int) -> None:
        for d in self.devices:
            d.pointer = value

    def check_access(self) -> None:
        errors = []
        for d in self.devices:
            try:
                d.check_access()
            except OSError as exc:
                errors.append(exc)
        if len(errors) == len(self.devices):
            raise errors[0]

    def read_registers(self, register: int, length: int) -> bytes:
        out = [0xFF] * length
        for d in self.devices:
            out = [a & b for a, b in zip(out, d.read_registers(register, length))]
        return bytes(out)

    def write_registers(self, register: int, data: bytes) -> None:
        for d in self.devices:
            d.write_registers(register, data)

    def send_byte(self, value: int) -> None:
        for d in self.devices:
            _send_byte(d, value)

    def receive_byte(self) -> int:
        out = 0xFF
        for d in self.devices:
            out &= _receive_byte(d)
        return out


def _send_byte(dev, value: int) -> None:
    send = getattr(dev, "send_byte", None)
    if send is None:  # a device model that is not an I2CDevice: a register pointer
        dev.pointer = value & 0xFF
    else:
        send(value)


def _receive_byte(dev) -> int:
    receive = getattr(dev, "receive_byte", None)
    return dev.read_registers(getattr(dev, "pointer", 0), 1)[0] if receive is None else receive()


class SimulatedI2CBus:
    """smbus2.SMBus look-alike. Absent addresses raise OSError(ENXIO) as Linux does."""

    def __init__(self, bus: int | str | None = 1, force: bool = False) -> None:
        self.bus = bus
        self._devices: dict[int, I2CDevice] = {}
        self._switches: dict[int, I2CDevice] = {}  # the devices with is_switch, by address
        self.transfers = 0
        self.closed = False

    def add_device(self, address: int, device: I2CDevice) -> None:
        self._devices[address] = device
        if getattr(device, "is_switch", False):
            self._switches[address] = device
        else:
            self._switches.pop(address, None)

    def remove_device(self, address: int) -> None:
        self._devices.pop(address, None)
        self._switches.pop(address, None)

    def answering(self, address: int) -> list[I2CDevice]:
        """Every device that answers at ``address``: the one on this bus and those behind selected switch
        channels (recursively)."""
        found = [self._devices[address]] if address in self._devices else []
        for switch in self._switches.values():
            found.extend(switch.downstream(address))
        return found

    def open(self, bus) -> None:
        self.bus = bus
        self.closed = False

    def close(self) -> None:
        self.closed = True

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _dev(self, addr: int) -> I2CDevice:
        self.transfers += 1
        if self._switches:
            found = self.answering(addr)
            dev = found[0] if len(found) == 1 else WiredAnd(found) if found else None
        else:
            dev = self._devices.get(addr)
        if dev is None:
            raise OSError(errno.ENXIO, f"No such device or address (0x{addr:02x})")
        dev.check_access()
        return dev

    def read_byte_data(self, i2c_addr: int, register: int, force=None) -> int:
        return self._dev(i2c_addr).read_registers(register, 1)[0]

    def write_byte_data(self, i2c_addr: int, register: int, value: int, force=None) -> None:
        self._dev(i2c_addr).write_registers(register, bytes([value & 0xFF]))

    def read_word_data(self, i2c_addr: int, register: int, force=None) -> int:
        b = self._dev(i2c_addr).read_registers(register, 2)
        return b[0] | (b[1] << 8)

    def write_word_data(self, i2c_addr: int, register: int, value: int, force=None) -> None:
        self._dev(i2c_addr).write_registers(register, bytes([value & 0xFF, (value >> 8) & 0xFF]))

    def read_i2c_block_data(self, i2c_addr: int, register: int, length: int, force=None) -> list[int]:
        if not 0 < length <= 32:
            raise ValueError("Desired block length over 32 bytes")
        return list(self._dev(i2c_addr).read_registers(register, length))

    def write_i2c_block_data(self, i2c_addr: int, register: int, data, force=None) -> None:
        if len(data) > 32:
            raise ValueError("Data length cannot exceed 32 bytes")
        self._dev(i2c_addr).write_registers(register, bytes(data))

    def read_byte(self, i2c_addr: int, force=None) -> int:
        return _receive_byte(self._dev(i2c_addr))

    def write_byte(self, i2c_addr: int, value: int, force=None) -> None:
        _send_byte(self._dev(i2c_addr), value)

    def write_quick(self, i2c_addr: int, force=None) -> None:
        self._dev(i2c_addr)

    def i2c_rdwr(self, *i2c_msgs) -> None:
        """Combined transfers: a write of a register address then a read (smbus2.i2c_msg)."""
        pointer: dict[int, int] = {}
        for msg in i2c_msgs:
            addr = msg.addr
            is_read = bool(msg.flags & 0x0001)
            if is_read:
                dev = self._dev(addr)
                data = dev.read_registers(pointer.get(addr, getattr(dev, "pointer", 0)), msg.len)
                for i, b in enumerate(data):
                    msg.buf[i] = bytes([b])
            else:
                raw = bytes(list(msg))
                dev = self._dev(addr)
                if raw:
                    pointer[addr] = raw[0]
                    if len(raw) > 1:
                        dev.pointer = raw[0]
                        dev.write_registers(raw[0], raw[1:])
                    else:
                        _send_byte(dev, raw[0])

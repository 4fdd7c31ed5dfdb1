"""A simulated I2C bus with smbus2's ``SMBus`` method signatures.

Register-level device models plug in at addresses; the drivers (ours and
third-party ones) talk to it exactly as to ``smbus2.SMBus(1)``.
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


class SimulatedI2CBus:
    """smbus2.SMBus look-alike. Absent addresses raise OSError(ENXIO) as Linux does."""

    def __init__(self, bus: int | str | None = 1, force: bool = False) -> None:
        self.bus = bus
        self._devices: dict[int, I2CDevice] = {}
        self.transfers = 0
        self.closed = False

    def add_device(self, address: int, device: I2CDevice) -> None:
        self._devices[address] = device

    def remove_device(self, address: int) -> None:
        self._devices.pop(address, None)

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
        dev = self._dev(i2c_addr)
        return dev.read_registers(getattr(dev, "pointer", 0), 1)[0]

    def write_byte(self, i2c_addr: int, value: int, force=None) -> None:
        dev = self._dev(i2c_addr)
        dev.pointer = value & 0xFF

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
                    dev.pointer = raw[0]
                    if len(raw) > 1:
                        dev.write_registers(raw[0], raw[1:])

"""``rig ports``: list serial ports and I2C buses, and what answers on them."""

from __future__ import annotations

import glob

import smbus2
from serial.tools import list_ports as lp

from drivers.sensors.chips import CHIPS
from drivers.ximc.stage import Stage

STANDA_VID_PID = (0x1CBE, 0x0007)
#: (address, identity register, expected value, model), from the chip registry
SENSOR_PROBES = [(address, chip.identity_register, chip.identity_value, chip.model)
                 for chip in CHIPS.values() for address in chip.addresses]


def list_ports() -> list[str]:
    """One line per serial port and per I2C bus, saying what answered."""
    lines: list[str] = []
    try:
        ports = list(lp.comports())
    except Exception as exc:  # noqa: BLE001 - report, don't crash
        ports = []
        lines.append(f"serial: cannot list ports ({exc})")
    if not ports:
        lines.append("serial: no ports found")
    for p in ports:
        what = ""
        if (p.vid, p.pid) == STANDA_VID_PID:
            what = _probe_ximc(p.device)
        lines.append(f"serial {p.device}  {p.description or ''}  "
                     f"{'%04X:%04X' % (p.vid, p.pid) if p.vid else ''}  {what}".rstrip())
    buses = sorted(glob.glob("/dev/i2c-*"))
    if not buses:
        lines.append("i2c: no /dev/i2c-* buses (the simulated rig needs none)")
    for dev in buses:
        lines.append(f"i2c {dev}  {_probe_i2c(int(dev.rsplit('-', 1)[1]))}")
    return lines


def _probe_ximc(device: str) -> str:
    try:
        with Stage(device, name="probe") as st:
            ident = st.identify()
        return f"Standa controller, serial {ident.serial_number}, firmware {ident.firmware}"
    except Exception as exc:  # noqa: BLE001
        return f"Standa USB id but no answer ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})"


def _probe_i2c(bus_no: int) -> str:
    try:
        bus = smbus2.SMBus(bus_no)
    except Exception as exc:  # noqa: BLE001
        return f"cannot open ({exc})"
    found = []
    try:
        for addr, reg, expect, model in SENSOR_PROBES:
            try:
                if bus.read_byte_data(addr, reg) == expect:
                    found.append(f"{model} at 0x{addr:02x}")
            except OSError:
                continue
    finally:
        bus.close()
    return ", ".join(found) if found else "no known sensor answers"

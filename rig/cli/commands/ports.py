"""``rig ports``: list serial ports and I2C buses and what answers on them, then what the columns mean."""

from __future__ import annotations

from rig.cli.codes import EXIT_OK
from rig.devices.ports import SENSOR_PROBES, STANDA_VID_PID, list_ports


def add_parser(sub) -> None:
    sub.add_parser("ports", help="list serial ports and I2C buses and what answers on them")


def legend() -> list[str]:
    """What the columns of :func:`rig.devices.ports.list_ports` mean (docs/cli.md, ``rig ports``)."""
    standa = "%04X:%04X" % STANDA_VID_PID
    probes = ", ".join(f"{model} at 0x{address:02x}" for address, _, _, model in SENSOR_PROBES)
    return [
        "columns: serial DEVICE  DESCRIPTION  VID:PID  WHAT ANSWERED;  i2c DEVICE  WHAT ANSWERED",
        "  DESCRIPTION: what the port's USB device calls itself; n/a: the port has no USB description "
        "(a built-in serial port such as /dev/ttyS0, never a Standa controller)",
        f"  VID:PID: the USB vendor:product id (empty: not USB); Standa 8SMC4/8SMC5 controllers are {standa}, "
        "and only those ports are asked for their serial number and firmware",
        f"  i2c: each bus is asked for the identity register of {probes}; nothing is written",
    ]


def run(args) -> int:
    for line in list_ports() + legend():
        print(line)
    return EXIT_OK

"""``rig ports``: list serial ports and I2C buses and what answers on them."""

from __future__ import annotations

from rig.cli.common import EXIT_OK
from rig.devices.ports import list_ports


def add_parser(sub) -> None:
    sub.add_parser("ports", help="list serial ports and I2C buses and what answers on them")


def run(args) -> int:
    for line in list_ports():
        print(line)
    return EXIT_OK

"""I2C buses by the name a rig file gives them: a Linux bus number or device path, or a named
bus that another part of this program provides (the simulated rig's in-process bus).

A rig file of kind ``hardware`` may put its sensor on ``bus: sim``: the same hardware code path
then reads a simulated chip, which is how CI exercises the code a lab runs (the simulated world
registers its bus here with :func:`register_bus`).
"""

from __future__ import annotations

from typing import Any, Callable

import smbus2

from rig.errors import RigInputError

#: bus name -> factory returning an smbus2.SMBus-compatible object
NAMED_BUSES: dict[str, Callable[[], Any]] = {}


def register_bus(name: str, factory: Callable[[], Any]) -> None:
    """Provide the bus ``name`` (a string that is not a number or a /dev path)."""
    NAMED_BUSES[name] = factory


def unregister_bus(name: str) -> None:
    NAMED_BUSES.pop(name, None)


def open_bus(spec: int | str, *, where: str | None = None) -> Any:
    """Open an I2C bus: ``1`` or ``"/dev/i2c-1"`` through smbus2, a registered name otherwise."""
    if isinstance(spec, int) or (isinstance(spec, str) and (spec.isdigit() or spec.startswith("/dev/"))):
        return smbus2.SMBus(int(spec) if str(spec).isdigit() else spec)
    factory = NAMED_BUSES.get(str(spec))
    if factory is None:
        raise RigInputError(where, None, "sensor.bus", f"no I2C bus named {spec!r} in this program (expected a bus "
                            f"number such as 1, a path such as /dev/i2c-1, or one of: "
                            f"{', '.join(sorted(NAMED_BUSES)) or 'none running'})")
    return factory()

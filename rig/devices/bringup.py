"""Bringing up a rig: reach each controller and the sensor, say who answers, move nothing (``rig check``);
one axis for one small move (``rig jog``). docs/hardware.md.

A hardware rig is reached part by part: each controller on its own port and the sensor on its bus, so one
that does not answer is named and the others are still read (a run opens everything at once and stops at
the first). A simulated rig is opened whole (its world starts the emulators) and then read the same way.
Every reading is a query: no move, no setting written, no zero or home (the controller's counter stays).
"""

from __future__ import annotations

import errno
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from drivers.clock import MonotonicClock
from drivers.sensors.chips import chip_spec
from drivers.ximc import protocol as P
from drivers.ximc.stage import Stage
from rig.config.rigfile import AxisConfig, RigFile
from rig.devices.buses import open_bus
from rig.devices.registry import open_rig_file
from rig.planning.kinematics import STAGE_AXES

#: the embedded simulated rig, ``sim`` on the command line (the file ``rig run --rig sim`` opens)
SIM_RIG_FILE = Path(__file__).resolve().parents[2] / "rigs" / "sim.yaml"
#: (serial port or I2C bus, why it cannot be opened) -> what to do about it (docs/hardware.md)
OPEN_HINTS = {
    ("serial", errno.ENOENT): "is the controller plugged in and powered, and the udev rule installed (its "
                              "/dev/ximc/SERIAL link)? `rig ports` lists what answers",
    ("serial", errno.EACCES): "install rigs/udev/99-standa-8smc.rules, or join the dialout group and log in again "
                              "(docs/hardware.md, 'Permissions')",
    ("serial", errno.EBUSY): "another program has the port (a rig run, a libximc program, ModemManager)",
    ("i2c", errno.ENOENT): "the I2C bus is not enabled, or has another number: `ls /dev/i2c-*` (docs/hardware.md, "
                           "'Enabling the I2C bus')",
    ("i2c", errno.EACCES): "join the i2c group and log in again (docs/hardware.md, 'Permissions')",
}
_ERRNO = re.compile(r"\[Errno (\d+)\] ([^:'\])]+)")


def rig_file_path(spec: str) -> Path:
    """``sim`` means the embedded simulated rig (:data:`SIM_RIG_FILE`); anything else is a rig file's path."""
    return SIM_RIG_FILE if spec == "sim" else Path(spec)


@dataclass(frozen=True)
class PartCheck:
    """What one part of the rig said: ``part`` (a1, a2, a3, sensor), ``ok``, and its one line."""

    part: str
    ok: bool
    line: str


def hint_for(exc: BaseException, kind: str = "serial") -> str:
    """Why a ``kind`` device ("serial", "i2c") did not answer, in one line without the driver's own prefix
    (the check's line names the part and its port), with what to do for the known reasons."""
    text = getattr(exc, "detail", None) or (str(exc).strip().splitlines() or [type(exc).__name__])[0]
    found = _ERRNO.findall(text)  # the innermost OS error of a wrapped one
    code = int(found[-1][0]) if found else getattr(exc, "errno", None)
    if found:
        text = f"cannot open ({found[-1][1].strip().lower()})"
    hint = OPEN_HINTS.get((kind, code))
    return f"{text}: {hint}" if hint else text


def check_axis(name: str, config: AxisConfig, stage) -> PartCheck:
    """Read one controller (identity, firmware, status, position, speed limit) against its rig-file entry."""
    try:
        ident = stage.identify()
        status = stage.get_status()
        position_deg = stage.get_position_deg()
        limit_deg_s = stage.get_engine_settings().NomSpeed * stage.deg_per_step
    except Exception as exc:  # noqa: BLE001 - a part that does not answer is a line, not the end of the check
        return PartCheck(name, False, f"{name}  {config.port}: {hint_for(exc)}")
    problems = []
    if config.serial is not None and ident.serial_number != config.serial:
        problems.append(f"serial {ident.serial_number}, the rig file expects {config.serial} (another controller "
                        "on this port: swapped cables or port names?)")
    if status.Flags & P.STATE_ALARM:
        problems.append("the controller is in alarm (over-current, over-heat or a limit): power-cycle it")
    if config.speed_deg_s > limit_deg_s + 1e-9:
        problems.append(f"speed_deg_s {config.speed_deg_s:g} is above the controller's limit {limit_deg_s:g} deg/s")
    low, high = config.soft_limits_deg
    where = "inside" if low <= position_deg <= high else "OUTSIDE"
    device = ident.device
    line = (f"{name}  {config.port}  serial {ident.serial_number}  firmware {ident.firmware}  "
            f"{device.get('manufacturer', '')} {device.get('product', '')} hw {device.get('hardware', '')}  "
            f"at {position_deg:.3f} deg ({where} soft limits {low:g}..{high:g})  "
            f"speed limit {limit_deg_s:g} deg/s (rig file {config.speed_deg_s:g})  "
            f"limit switch {_edges(status.GPIOFlags)}")
    return PartCheck(name, not problems, line + "".join(f"; {p}" for p in problems))


def _edges(gpio_flags: int) -> str:
    names = [n for n, bit in (("left", P.STATE_LEFT_EDGE), ("right", P.STATE_RIGHT_EDGE)) if gpio_flags & bit]
    return " and ".join(names) if names else "free"


def check_sensor(model: str, address: int, bus, bus_name) -> PartCheck:
    """Read the sensor's identity register (WHO_AM_I, DEVID) at ``address`` on ``bus``; nothing is written."""
    spec = chip_spec(model)
    where = f"{model} at 0x{address:02x} on bus {bus_name}"
    try:
        value = bus.read_byte_data(address, spec.identity_register)
    except OSError as exc:
        return PartCheck("sensor", False, f"sensor  {where}: no answer ({exc.strerror or exc}); check the wiring "
                         "(SDA, SCL, 3.3 V, ground), the address pin and the pull-ups (docs/hardware.md)")
    register = "WHO_AM_I" if model == "MPU-9150" else "DEVID"
    if value != spec.identity_value:
        return PartCheck("sensor", False, f"sensor  {where}: {register} reads 0x{value:02x}, expected "
                         f"0x{spec.identity_value:02x} (another chip at this address?)")
    return PartCheck("sensor", True, f"sensor  {where}: {register} 0x{value:02x} (register 0x"
                     f"{spec.identity_register:02x}), as expected")


def check_hardware(rig_file: RigFile) -> list[PartCheck]:
    """Reach each part of a hardware rig on its own (see the module docstring); close everything."""
    checks = []
    for name in STAGE_AXES:
        config = rig_file.axes[name]
        stage = Stage(config.port, clock=MonotonicClock(), name=name)
        try:
            stage.open()
            checks.append(check_axis(name, config, stage))
        except Exception as exc:  # noqa: BLE001 - named, then the next part
            checks.append(PartCheck(name, False, f"{name}  {config.port}: {hint_for(exc)}"))
        finally:
            stage.close()
    checks.append(_check_bus(rig_file))
    return checks


def _check_bus(rig_file: RigFile) -> PartCheck:
    sensor = rig_file.sensor
    address = sensor.address if sensor.address is not None else chip_spec(sensor.model).default_address
    try:
        bus = open_bus(sensor.bus, where=str(rig_file.path))
    except Exception as exc:  # noqa: BLE001
        return PartCheck("sensor", False, f"sensor  I2C bus {sensor.bus}: {hint_for(exc, 'i2c')}")
    try:
        return check_sensor(sensor.model, address, bus, sensor.bus)
    finally:
        close = getattr(bus, "close", None)
        if close is not None:
            close()


def check_open_rig(rig, rig_file: RigFile) -> list[PartCheck]:
    """Read every part of a rig that is open already (a simulated rig opened whole)."""
    checks = [check_axis(name, axis.config, axis.stage) for name, axis in rig.axes.items()]
    sensor = rig.sensor
    checks.append(check_sensor(sensor.model, sensor.address, sensor.bus, rig_file.sensor.bus))
    return checks


def check_simulated(rig_file: RigFile) -> list[PartCheck]:
    """Open a simulated rig (its emulators and chip) and read it; close it. A rig that does not open (a
    ``faults:`` section that silences a controller) is one failed part, ``rig``."""
    try:
        rig = open_rig_file(rig_file, seed=0)
    except Exception as exc:  # noqa: BLE001 - named in one line like any part that does not answer
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]  # names the axis and port
        return [PartCheck("rig", False, f"rig  {rig_file.path}: the simulated rig did not open: {first}")]
    try:
        return check_open_rig(rig, rig_file)
    finally:
        rig.close()


#: rig kind -> how ``rig check`` reaches its parts
CHECKS: dict[str, Callable[[RigFile], list[PartCheck]]] = {"hardware": check_hardware, "sim": check_simulated}


def open_axis(rig_file: RigFile, name: str) -> tuple[Any, Callable[[], None]]:
    """One axis's stage, opened, and what closes it: a hardware controller alone (no sensor needed: ``rig
    jog`` turns a table before the sensor is mounted), a simulated rig whole."""
    if rig_file.kind == "hardware":
        stage = Stage(rig_file.axes[name].port, clock=MonotonicClock(), name=name)
        stage.open()
        return stage, stage.close
    rig = open_rig_file(rig_file, seed=0)
    return rig.axes[name].stage, rig.close

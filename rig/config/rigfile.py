"""Rig files (``rig-file/1``): which port drives which axis, limits, speeds, the sensor.

See docs/rig-file.md. ``rigs/sim.yaml`` is the embedded simulated rig.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from rig.errors import RigInputError
from rig.config.yamlload import load_located

FORMAT = "rig-file/1"
STAGE_MAX_SPEED_DEG_S = 48.0  # 8MR191: NomSpeed 4800 full steps/s at 0.01 deg/step
AXES = ("a1", "a2", "a3")
AXIS_KEYS = {"port", "serial", "sign", "home_offset_deg", "speed_deg_s", "accel_deg_s2", "soft_limits_deg",
             "cable_wrap_deg", "slip_ring"}
FAULT_KEYS = {"ximc", "sensor"}


@dataclass(frozen=True)
class AxisConfig:
    port: str | None
    serial: int | None = None
    sign: int = 1
    home_offset_deg: float = 0.0
    speed_deg_s: float = 20.0
    accel_deg_s2: float = 40.0
    soft_limits_deg: tuple[float, float] = (-400.0, 400.0)
    cable_wrap_deg: float = 400.0
    slip_ring: bool = False  # the axis may spin without limit (rate steps)


@dataclass(frozen=True)
class SiteConfig:
    """The local geomagnetic field at the rig (for the magnetometer's position method)."""

    field_ut: float = 50.0
    inclination_deg: float = 65.0
    declination_deg: float = 0.0


@dataclass(frozen=True)
class SensorConfig:
    model: str = "MPU-9150"
    bus: int | str = "sim"
    address: int | None = None


@dataclass(frozen=True)
class RigFile:
    path: str
    name: str
    kind: str  # sim | hardware
    home_policy: str
    axes: dict[str, AxisConfig]
    sensor: SensorConfig
    sim: dict | None = None
    faults: dict | None = field(default=None)
    site: SiteConfig | None = None

    @property
    def is_simulated(self) -> bool:
        return self.kind == "sim"


def load_rig_file(path) -> RigFile:
    p = Path(path)
    try:
        text = p.read_text()
    except FileNotFoundError:
        raise RigInputError(str(p), None, None, "no such rig file (use --rig sim for the simulated rig)") from None
    except IsADirectoryError:
        raise RigInputError(str(p), None, None, "is a directory, expected a rig file") from None
    return parse_rig_file(text, str(p))


def check_fields(mapping, allowed: set[str], where: str, path: str | None = None, loc=None) -> None:
    """Raise a located RigInputError for the first key of ``mapping`` not in ``allowed``."""
    if not isinstance(mapping, dict):
        raise RigInputError(path, loc.line_of(mapping) if loc else None, where, "expected a mapping")
    for k in mapping:
        if k not in allowed:
            line = loc.line_of(mapping, k) if loc else None
            raise RigInputError(path, line, f"{where}.{k}" if where else str(k),
                                f"unknown key (allowed: {', '.join(sorted(allowed))})")


def parse_rig_file(text: str, path: str = "<rig>") -> RigFile:
    doc, loc = load_located(text, path)

    def fail(container, key, where, message):
        raise RigInputError(path, loc.line_of(container, key) if isinstance(container, (dict, list)) else None,
                            where, message)

    if not isinstance(doc, dict):
        raise RigInputError(path, 1, None, "expected a mapping with format, name, turntable, sensor")
    check_fields(doc, {"format", "name", "kind", "home", "turntable", "sensor", "sim", "faults", "description",
                       "site"},
                 "", path, loc)
    for req in ("format", "turntable", "sensor"):
        if req not in doc:
            fail(doc, None, req, f"missing required key {req!r}")
    if doc["format"] != FORMAT:
        fail(doc, "format", "format", f"expected {FORMAT!r}, got {doc['format']!r}")
    kind = doc.get("kind", "hardware")
    if kind not in ("sim", "hardware"):
        fail(doc, "kind", "kind", f"expected sim or hardware, got {kind!r}")
    home = doc.get("home", "zero")
    if home not in ("none", "zero", "home"):
        fail(doc, "home", "home", f"expected none, zero or home, got {home!r}")
    tt = doc["turntable"]
    check_fields(tt, {"axes"}, "turntable", path, loc)
    axes_m = tt.get("axes")
    if not isinstance(axes_m, dict):
        fail(tt, "axes", "turntable.axes", "expected a mapping a1, a2, a3")
    check_fields(axes_m, set(AXES), "turntable.axes", path, loc)
    axes = {}
    for name in AXES:
        if name not in axes_m:
            fail(axes_m, None, f"turntable.axes.{name}", "missing axis")
        axes[name] = _axis(axes_m[name], f"turntable.axes.{name}", kind, fail, path, loc)
    sensor_m = doc["sensor"]
    check_fields(sensor_m, {"model", "bus", "address"}, "sensor", path, loc)
    model = sensor_m.get("model", "MPU-9150")
    if model not in ("MPU-9150", "ADXL345"):
        fail(sensor_m, "model", "sensor.model", f"expected MPU-9150 or ADXL345, got {model!r}")
    bus = sensor_m.get("bus", "sim" if kind == "sim" else 1)
    if kind == "hardware" and (isinstance(bus, bool) or not isinstance(bus, int) or bus < 0):
        fail(sensor_m, "bus", "sensor.bus", f"expected an I2C bus number (/dev/i2c-N), got {bus!r}")
    address = sensor_m.get("address")
    allowed_addr = {"MPU-9150": (0x68, 0x69), "ADXL345": (0x53, 0x1D)}[model]
    if address is not None and address not in allowed_addr:
        fail(sensor_m, "address", "sensor.address",
             f"expected one of {', '.join(hex(a) for a in allowed_addr)} for the {model}, got {address!r}")
    sim = doc.get("sim")
    if sim is not None and kind != "sim":
        fail(doc, "sim", "sim", "a sim section belongs only in a rig file with kind: sim")
    if sim is not None and not isinstance(sim, dict):
        fail(doc, "sim", "sim", "expected a mapping")
    faults = doc.get("faults")
    if faults is not None:
        check_fields(faults, FAULT_KEYS, "faults", path, loc)
        if "ximc" in faults:
            check_fields(faults["ximc"], set(AXES), "faults.ximc", path, loc)
            for a, fm in faults["ximc"].items():
                check_fields(fm, _ximc_fault_fields(), f"faults.ximc.{a}", path, loc)
        if "sensor" in faults:
            check_fields(faults["sensor"], _sensor_fault_fields(), "faults.sensor", path, loc)
    site = None
    if doc.get("site") is not None:
        sm = doc["site"]
        if not isinstance(sm, dict):
            fail(doc, "site", "site", "expected a mapping {field_ut, inclination_deg, declination_deg}")
        check_fields(sm, {"field_ut", "inclination_deg", "declination_deg"}, "site", path, loc)
        vals = {}
        for key, lo, hi in (("field_ut", 1.0, 100.0), ("inclination_deg", -90.0, 90.0),
                            ("declination_deg", -180.0, 180.0)):
            v = sm.get(key, getattr(SiteConfig(), key))
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not lo <= v <= hi:
                fail(sm, key, f"site.{key}", f"expected a number in [{lo:g}, {hi:g}], got {v!r}")
            vals[key] = float(v)
        site = SiteConfig(**vals)
    return RigFile(path=path, name=str(doc.get("name", Path(path).stem)), kind=kind, home_policy=home, axes=axes,
                   sensor=SensorConfig(model=model, bus=bus, address=address), sim=sim, faults=faults, site=site)


def _ximc_fault_fields() -> set[str]:
    import dataclasses
    from drivers.ximc.sim.emulator import XimcFaults
    return {f.name for f in dataclasses.fields(XimcFaults)}


def _sensor_fault_fields() -> set[str]:
    import dataclasses
    from drivers.sensors.sim.faults import SensorFaults
    return {f.name for f in dataclasses.fields(SensorFaults)}


def _flag(m, key, where, fail) -> bool:
    v = m.get(key, False)
    if not isinstance(v, bool):
        fail(m, key, f"{where}.{key}", f"expected true or false, got {v!r}")
    return v


def _axis(m, where, kind, fail, path, loc) -> AxisConfig:
    check_fields(m, AXIS_KEYS, where, path, loc)
    port = m.get("port")
    if kind == "hardware" and (not isinstance(port, str) or not port):
        fail(m, "port", f"{where}.port", "expected the controller's serial port, e.g. /dev/ximc/00003A5C")

    def num(key, default, *, positive=False, maximum=None):
        if key not in m:
            return default
        v = m[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            fail(m, key, f"{where}.{key}", f"expected a number, got {v!r}")
        if positive and v <= 0:
            fail(m, key, f"{where}.{key}", f"expected a number > 0, got {v!r}")
        if maximum is not None and v > maximum:
            fail(m, key, f"{where}.{key}", f"expected at most {maximum:g} (the stage's limit), got {v!r}")
        return float(v)

    sign = m.get("sign", 1)
    if sign not in (1, -1) or isinstance(sign, bool):
        fail(m, "sign", f"{where}.sign", f"expected 1 or -1, got {sign!r}")
    serial = m.get("serial")
    if serial is not None and (isinstance(serial, bool) or not isinstance(serial, int) or serial < 0):
        fail(m, "serial", f"{where}.serial", f"expected the controller serial number (integer), got {serial!r}")
    limits = m.get("soft_limits_deg", [-400.0, 400.0])
    if not (isinstance(limits, list) and len(limits) == 2
            and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in limits)
            and limits[0] < limits[1]):
        fail(m, "soft_limits_deg", f"{where}.soft_limits_deg", f"expected [low, high] in degrees with low < high, got {limits!r}")
    return AxisConfig(port=port, serial=serial, sign=int(sign),
                      home_offset_deg=num("home_offset_deg", 0.0),
                      speed_deg_s=num("speed_deg_s", 20.0, positive=True, maximum=STAGE_MAX_SPEED_DEG_S),
                      accel_deg_s2=num("accel_deg_s2", 40.0, positive=True),
                      soft_limits_deg=(float(limits[0]), float(limits[1])),
                      cable_wrap_deg=num("cable_wrap_deg", 400.0, positive=True),
                      slip_ring=_flag(m, "slip_ring", where, fail))

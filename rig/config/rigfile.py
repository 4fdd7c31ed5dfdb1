"""Rig files (``rig-file/1``): which port drives which axis, limits, speeds, the sensor.

See docs/rig-file.md. ``rigs/sim.yaml`` is the embedded simulated rig. The schema is pydantic
(``docs/schemas/rig-file.schema.json`` is generated from it); :class:`AxisConfig`,
:class:`SensorConfig` and :class:`SiteConfig` are frozen pydantic dataclasses, so they are both
the schema of their mapping and the values the rest of the code reads (``dataclasses.replace``
works and re-validates). Sections owned by others (``sim:``, ``faults:``) are validated through
:mod:`rig.config.sections`; the optional ``fixture:`` (many sensor slots) by :mod:`rig.config.fixture`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, ClassVar, Optional

from pydantic import BeforeValidator, ConfigDict, WithJsonSchema, model_validator
from pydantic.dataclasses import dataclass as schema_dataclass
from pydantic.json_schema import SkipJsonSchema

from calib.file.fields import Strict, check_mapping, choice, fail, flag, label, number
from calib.numerics import gravity as gravity_
from drivers.sensors.chips import CHIPS, SENSOR_MODELS
from drivers.ximc.stage_spec import MR191
from rig.config.fixture import FixtureConfig
from rig.config.sections import SectionUnavailable, section
from rig.config.validate import validate_document, validate_located
from rig.config.yamlload import read_source
from rig.errors import RigInputError
from rig.planning.approach import APPROACHES
from rig.planning.kinematics import STAGE_AXES

FORMAT = "rig-file/1"
STAGE_MAX_SPEED_DEG_S = MR191.max_speed_deg_s  # 8MR191: NomSpeed 4800 full steps/s at 0.01 deg/step
STAGE_MAX_ACCEL_DEG_S2 = 65535 * MR191.deg_per_step  # the controller's largest Accel (steps/s^2)
LIMIT_DEG = 1e6  # far beyond any real table (the replay rig uses it as "no limit")
SIM_GEOMETRY_ENABLED = True  # a simulated table has its own errors unless its sim.geometry says enabled: false


def simulated_table(sim: dict | None) -> dict | None:
    """A simulated rig file's ``sim.geometry`` section (its classes and ``table_seed``; ``{}``: every default) when
    its table has its own errors, on unless ``enabled: false`` (:data:`SIM_GEOMETRY_ENABLED`); None when it lands
    where commanded. The one reading of that switch outside the simulator (the budget, the digital twin)."""
    section = (sim or {}).get("geometry") or {}
    return section if section.get("enabled", SIM_GEOMETRY_ENABLED) else None
_DATACLASS_CONFIG = ConfigDict(extra="forbid")


def _limits(v):
    if not (isinstance(v, (list, tuple)) and len(v) == 2
            and all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
                    and abs(x) <= LIMIT_DEG for x in v) and v[0] < v[1]):
        raise fail(f"expected [low, high] in degrees with low < high (within +-{LIMIT_DEG:g}), got {v!r}")
    return (float(v[0]), float(v[1]))


SoftLimits = Annotated[tuple[float, float], BeforeValidator(_limits), WithJsonSchema({
    "type": "array", "minItems": 2, "maxItems": 2, "description": "[low, high] allowed stage positions, deg",
    "prefixItems": [{"type": "number", "minimum": -LIMIT_DEG, "maximum": LIMIT_DEG}] * 2})]


@schema_dataclass(frozen=True, config=_DATACLASS_CONFIG)
class AxisConfig:
    """One turntable axis: its controller and how far and fast it may go (the one axis type).

    ``name`` is the axis key (a1, a2, a3), set by the loader; a file cannot give it.
    Derive a copy with :meth:`with_port` or ``dataclasses.replace``.
    """

    internal_keys: ClassVar[frozenset] = frozenset({"name"})
    name: SkipJsonSchema[str] = ""
    port: Optional[str] = None
    serial: Optional[number(ge=0, le=2**32 - 1, integer=True)] = None
    sign: choice((1, -1), "expected 1 or -1, got {got}") = 1
    home_offset_deg: number(ge=-3600, le=3600, description="stage angle at kinematic zero") = 0.0
    speed_deg_s: number(gt=0, le=STAGE_MAX_SPEED_DEG_S, too_big="expected at most {le} (the stage's limit), got {got}") = 20.0
    accel_deg_s2: number(gt=0, le=STAGE_MAX_ACCEL_DEG_S2,
                         too_big="expected at most {le} (the controller's limit), got {got}") = 40.0
    soft_limits_deg: SoftLimits = (-400.0, 400.0)
    cable_wrap_deg: number(gt=0, le=LIMIT_DEG) = 400.0
    slip_ring: flag("the axis may spin without limit (rate steps)") = False
    approach: choice(tuple(APPROACHES), "expected none, positive or negative, got {got}") = "none"
    overshoot_deg: number(gt=0, le=10, description="planned overshoot of a move that arrives the other way, deg") = 0.5

    @model_validator(mode="before")
    @classmethod
    def _known_keys(cls, data, info):
        data = check_mapping(cls, data, info)
        if isinstance(data, dict) and "serial" in data and not (
                isinstance(data["serial"], int) and not isinstance(data["serial"], bool) and data["serial"] >= 0):
            raise fail(f"expected the controller serial number (integer), got {data['serial']!r}", at=("serial",))
        if isinstance(data, dict) and "port" in data and data["port"] is not None and not isinstance(data["port"], str):
            raise fail(f"expected the controller's serial port (a path), got {data['port']!r}", at=("port",))
        return data

    def with_port(self, port: str, serial: int | None = None) -> "AxisConfig":
        """The same axis on another port (and controller serial, when given)."""
        return dataclasses.replace(self, port=port, serial=self.serial if serial is None else serial)


@schema_dataclass(frozen=True, config=_DATACLASS_CONFIG)
class SiteConfig:
    """The local geomagnetic field at the rig (for the magnetometer's position method)."""

    mapping_hint: ClassVar[str] = "expected a mapping {field_ut, inclination_deg, declination_deg}"
    field_ut: number(ge=1.0, le=100.0, in_range=True) = 50.0
    inclination_deg: number(ge=-90.0, le=90.0, in_range=True) = 65.0
    declination_deg: number(ge=-180.0, le=180.0, in_range=True) = 0.0

    @model_validator(mode="before")
    @classmethod
    def _known_keys(cls, data, info):
        return check_mapping(cls, data, info)


@schema_dataclass(frozen=True, config=_DATACLASS_CONFIG)
class GravityConfig:
    """Local gravity at the rig (docs/rig-file.md, docs/uncertainty.md): measured (``g_m_s2``, with its
    standard uncertainty ``u_m_s2``), or from ``latitude_deg`` and ``height_m`` by the normal gravity formula;
    absent: standard gravity with the spread of gravity over the Earth as its uncertainty."""

    mapping_hint: ClassVar[str] = "expected a mapping {g_m_s2, u_m_s2} or {latitude_deg, height_m}"
    g_m_s2: Optional[number(ge=9.7, le=9.9, in_range=True, description="measured local gravity, m/s^2")] = None
    u_m_s2: Optional[number(gt=0, le=0.1, description="its standard uncertainty, m/s^2")] = None
    latitude_deg: Optional[number(ge=-90, le=90, in_range=True, description="geodetic latitude, deg")] = None
    height_m: number(ge=-500, le=9000, description="ellipsoidal height, m (with latitude_deg)") = 0.0

    @model_validator(mode="before")
    @classmethod
    def _known_keys(cls, data, info):
        data = check_mapping(cls, data, info)
        if isinstance(data, dict):
            if "g_m_s2" in data and ("latitude_deg" in data or "height_m" in data):
                raise fail("expected either g_m_s2 (measured) or latitude_deg and height_m (normal gravity), "
                           "not both", at=("g_m_s2",))
            if "g_m_s2" not in data and "latitude_deg" not in data:
                raise fail("expected g_m_s2 (measured) or latitude_deg (normal gravity)")
        return data

    def resolve(self) -> gravity_.Gravity:
        """The stated gravity with its standard uncertainty."""
        if self.g_m_s2 is not None:
            return gravity_.measured(self.g_m_s2, self.u_m_s2)
        return gravity_.from_site(self.latitude_deg, self.height_m, self.u_m_s2)


def _bus(v):
    if v is None or (isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= 1_000_000) or (
            isinstance(v, str) and v.strip()):
        return v
    raise fail(f"expected an I2C bus number (/dev/i2c-N) or a registered bus name, got {v!r}")


Bus = Annotated[Any, BeforeValidator(_bus), WithJsonSchema({
    "anyOf": [{"type": "integer", "minimum": 0}, {"type": "string", "minLength": 1}],
    "description": "I2C bus number (/dev/i2c-N); default 1 (hardware) or the simulated bus"})]


@schema_dataclass(frozen=True, config=_DATACLASS_CONFIG)
class SensorConfig:
    model: choice(SENSOR_MODELS, f"expected {' or '.join(SENSOR_MODELS)}, got {{got}}") = SENSOR_MODELS[0]
    bus: Bus = "sim"
    address: Optional[number(ge=0, le=0x7F, integer=True)] = None

    @model_validator(mode="before")
    @classmethod
    def _known_keys(cls, data, info):
        return check_mapping(cls, data, info)

    @model_validator(mode="after")
    def _address_of_the_chip(self):
        allowed = CHIPS[self.model].addresses
        if self.address is not None and self.address not in allowed:
            raise fail(f"expected one of {', '.join(hex(a) for a in allowed)} for the {self.model}, "
                       f"got {self.address!r}", at=("address",))
        return self


class Axes(Strict):
    mapping_hint: ClassVar[str] = "expected a mapping a1, a2, a3"
    a1: AxisConfig
    a2: AxisConfig
    a3: AxisConfig

    @model_validator(mode="before")
    @classmethod
    def _known_keys(cls, data, info):
        data = check_mapping(cls, data, info)
        for name in STAGE_AXES:
            if isinstance(data, dict) and name not in data:
                raise fail("missing axis", at=(name,))
        return data


class Turntable(Strict):
    axes: Axes


class RigFileDoc(Strict):
    """A ``rig-file/1`` file (docs/rig-file.md); ``sim`` and ``faults`` are validated by their sections."""

    model_config = Strict.model_config | {"title": FORMAT}
    mapping_hint: ClassVar[str] = "expected a mapping with format, name, turntable, sensor"
    format: choice((FORMAT,), f"expected {FORMAT!r}, got {{got}}")
    name: Optional[label(blank=False)] = None
    description: Optional[label(2000)] = None
    kind: choice(("sim", "hardware"), "expected sim or hardware, got {got}") = "hardware"
    home: choice(("none", "zero", "home"), "expected none, zero or home, got {got}") = "zero"
    turntable: Turntable
    sensor: SensorConfig
    site: Optional[SiteConfig] = None
    gravity: Optional[GravityConfig] = None
    fixture: Optional[FixtureConfig] = None
    sim: Optional[dict] = None
    faults: Optional[dict] = None

    @model_validator(mode="after")
    def _hardware_needs_ports(self):
        if self.kind != "hardware":
            return self
        for name in STAGE_AXES:
            port = getattr(self.turntable.axes, name).port
            if not isinstance(port, str) or not port:
                raise fail("expected the controller's serial port, e.g. /dev/ximc/00003A5C",
                           at=("turntable", "axes", name, "port"))
        return self


@dataclass(frozen=True)
class RigFile:
    path: str
    name: str
    kind: str  # sim | hardware
    home_policy: str
    axes: dict[str, AxisConfig]
    sensor: SensorConfig
    sim: dict | None = None  # the validated sim: section as given (see rig.simulation.settings)
    faults: dict | None = field(default=None)  # the validated faults: section as given
    site: SiteConfig | None = None
    #: local gravity as the calibration assumes it, with its standard uncertainty (default: standard gravity)
    gravity: gravity_.Gravity = field(default_factory=gravity_.standard_gravity)
    sections: dict[str, Any] = field(default_factory=dict, repr=False)  # section name -> validated model
    #: the sensor slots of a multi-sensor fixture (docs/fixture.md); None: the one ``sensor``
    fixture: FixtureConfig | None = None

    @property
    def is_simulated(self) -> bool:
        return self.kind == "sim"


def load_rig_file(path, *, sim_hint: str = "--rig sim") -> RigFile:
    """Load and validate a rig file; ``sim_hint`` is how the command at hand names the simulated rig, for the
    one line when ``path`` does not exist (``--rig sim`` for rig run, ``rig check sim`` for rig check)."""
    text = read_source(path, "rig", f"no such rig file (use {sim_hint} for the simulated rig)")
    return parse_rig_file(text, str(Path(path)))


def parse_rig_file(text: str, path: str = "<rig>") -> RigFile:
    doc, loc, spec = validate_document(RigFileDoc, text, path,
                                       "expected a mapping with format, name, turntable, sensor")
    sections = {name: _section(name, spec.kind, doc, path, loc) for name in ("sim", "faults")
                if doc.get(name) is not None}
    axes = {n: dataclasses.replace(getattr(spec.turntable.axes, n), name=n) for n in STAGE_AXES}
    sensor = spec.sensor
    if "bus" not in doc["sensor"]:
        sensor = dataclasses.replace(sensor, bus="sim" if spec.kind == "sim" else 1)
    dumped = {k: m.model_dump(exclude_unset=True, by_alias=True) for k, m in sections.items()}
    return RigFile(path=path, name=spec.name if spec.name is not None else Path(path).stem, kind=spec.kind,
                   home_policy=spec.home, axes=axes, sensor=sensor, sim=dumped.get("sim"),
                   faults=dumped.get("faults"), site=spec.site, sections=sections, fixture=spec.fixture,
                   gravity=spec.gravity.resolve() if spec.gravity is not None else gravity_.standard_gravity())


def _section(name: str, kind: str, doc: dict, path: str, loc):
    """Validate the top-level section ``name`` with the schema its owner registered."""
    line = loc.line_of(doc, name)
    try:
        sec = section(name)
    except SectionUnavailable as exc:
        raise RigInputError(path, line, name, str(exc)) from None
    if sec.kinds is not None and kind not in sec.kinds:
        raise RigInputError(path, line, name,
                            f"a {name} section belongs only in a rig file with kind: {' or '.join(sec.kinds)}")
    return validate_located(sec.model, doc[name], path=path, loc=loc, doc=doc, prefix=(name,))

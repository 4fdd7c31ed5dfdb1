"""The simulated rig's sections of a rig file, ``sim:`` and ``faults:`` (pydantic v2 schemas), and
:class:`SimSettings`, the validated ``sim:`` settings the simulated rig is built from.

Importing this module registers both schemas with :mod:`rig.config.sections`, so
``load_rig_file`` validates them on load (file, line, key) although ``rig.config`` imports no
simulator. The fault schemas mirror the simulators' own dataclasses
(``drivers.ximc.sim.emulator.XimcFaults``, ``drivers.sensors.sim.faults.SensorFaults``) field for
field, with bounds; ``tests/rig/config/test_sim_sections.py`` checks they cannot drift apart.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar, Optional

import numpy as np
from pydantic import BeforeValidator, Field, WithJsonSchema, create_model

from calib.discovery.effects import LIBRARY
from calib.file.fields import Strict, array, choice, fail, flag, integer, number
from drivers.sensors.sim.error_model import (
    AccelErrorModel,
    GyroErrorModel,
    MagErrorModel,
)
from drivers.sensors.sim.noise import NOISE_MODELS
from rig.config.rigfile import SIM_GEOMETRY_ENABLED
from rig.config.sections import register_section
from rig.config.validate import validate_plain
from rig.simulation.geometry import G0_M_S2, GeometryClass
from rig.simulation.world import ChamberConfig, FieldConfig, RingingConfig

#: how a time-scaled simulated clock treats a reader that falls behind (docs/simulated-rig.md, "Clocks")
CLOCKS = ("elastic", "strict")
#: how the runner reaches the emulated controllers: pseudo-terminals, or in process (``ximcsim://``)
TRANSPORTS = ("pty", "memory")

#: Canonical names of hidden effects a rig file may switch on (``sim: effects:``) -> the sensor error-model
#: field each sets: the effect library's own map (calib.discovery.effects, ``Effect.sim_field``), so a
#: hidden effect and its estimate by ``rig discover`` are the same quantity in the same unit.
EFFECT_FIELDS: dict[str, str] = {name: e.sim_field for name, e in LIBRARY.items() if e.sim_field is not None}
#: parameters of an effect that are not magnitudes (error-model field), e.g. when the bias jump happens
EFFECT_PARAMS: dict[str, str] = {"bias_jump_t_s": "bias_jump_t_s"}
#: the library's effects without an error-model field, which the simulated world injects (:mod:`rig.simulation.simrig`)
WORLD_EFFECTS = ("table_tilt", "full_misalignment", "pose_error")
MAX_MAGNITUDE = 1e6  # no error-model term or effect is anywhere near this


def _finite_tree(v, depth: int = 0):
    if isinstance(v, list) and depth < 2 and v:
        return [_finite_tree(x, depth + 1) for x in v]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or abs(v) > MAX_MAGNITUDE:
        raise fail(f"expected a finite number (|x| <= {MAX_MAGNITUDE:g}), a list or a 3x3 list of them, got {v!r}")
    return float(v)


_NUMBER = {"type": "number", "minimum": -MAX_MAGNITUDE, "maximum": MAX_MAGNITUDE}
_MAGNITUDE_SCHEMA = WithJsonSchema({"anyOf": [
    _NUMBER, {"type": "array", "minItems": 1, "items": _NUMBER},
    {"type": "array", "minItems": 1, "items": {"type": "array", "minItems": 1, "items": _NUMBER}}]})
Magnitude = Annotated[Any, BeforeValidator(_finite_tree), _MAGNITUDE_SCHEMA]


def _fits(shape: tuple, target: tuple, rule: str) -> bool:
    """Whether a value of ``shape`` may stand for a field of shape ``target`` under ``rule``: "exact";
    "scalar" (a number for any shape, else exact); "broadcast" (numpy broadcasting, as the simulator does)."""
    if shape == target or (rule in ("scalar", "broadcast") and shape == ()):
        return True
    if rule != "broadcast":
        return False
    try:
        return np.broadcast_shapes(shape, target) == target
    except ValueError:
        return False


def _expected(target: tuple, rule: str) -> str:
    exact = {(): "a number", (1,): "a list of one number", (3, 3): "a 3x3 list of numbers"}.get(
        target, f"{target[0] if target else 1} numbers")
    return exact if target == () or rule == "exact" else f"a number or {exact}"


def shaped(target: tuple, rule: str = "broadcast", nonnegative: bool = False):
    """A finite number or (nested) list of them that fits a simulator field of shape ``target`` (see
    :func:`_fits`), kept as written; every other shape is refused here, on load, with the file's line,
    never later in the simulator."""

    def check(v):
        v = _finite_tree(v)
        try:
            shape = np.shape(np.asarray(v, float))
        except ValueError:  # a ragged list
            shape = None
        if shape is None or not _fits(shape, target, rule):
            raise fail(f"expected {_expected(target, rule)}, got {v!r}")
        if nonnegative and np.any(np.asarray(v, float) < 0):
            raise fail(f"expected numbers >= 0, got {v!r}")
        return v

    return Annotated[Any, BeforeValidator(check), _MAGNITUDE_SCHEMA]


def _default_shapes(cls) -> dict[str, tuple]:
    """Each field of an error-model dataclass and the shape of its default (scalar, vector, 3x3)."""
    return {f.name: np.shape(f.default if f.default is not dataclasses.MISSING else f.default_factory())
            for f in dataclasses.fields(cls)}


def _overrides(name: str, fields: dict[str, Any], doc: str):
    """A mapping of the given keys, each of its field type (None: not given)."""
    model = create_model(name, __base__=Strict, __doc__=doc, **{f: (t, None) for f, t in fields.items()})
    model.mapping_hint = "expected a mapping of error-model fields"
    return model


def _error_fields(cls, vectors: str) -> dict[str, Any]:
    """Field types of an error model's overrides: matrices exactly 3x3 or (``vectors`` "broadcast") as
    numpy broadcasts them, vectors a number or 3 numbers, scalars a number; noise levels >= 0."""
    def rule(shape: tuple) -> str:
        if vectors == "broadcast":
            return "broadcast"
        return "scalar" if len(shape) == 1 else "exact"
    return {name: shaped(shape, rule(shape), nonnegative=name.startswith("noise"))
            for name, shape in _default_shapes(cls).items()}


def _field_names(cls) -> list[str]:
    return [f.name for f in dataclasses.fields(cls)]


_ACCEL_SHAPES = _default_shapes(AccelErrorModel)
#: the effects' field types: as the simulator applies them (rig.simulation.simrig)
EFFECT_TYPES: dict[str, Any] = {
    **{name: shaped(_ACCEL_SHAPES[f], "broadcast") for name, f in EFFECT_FIELDS.items()},
    "table_tilt": shaped((2,), "scalar"),  # [tilt_x_deg, tilt_y_deg], or one number: about x
    "full_misalignment": shaped((1,), "scalar"),  # deg, a rotation about the sensor's x axis
    "pose_error": shaped((1,), "scalar"),  # deg: each pose placed off its nominal one, repeatably (rig.simulation.world)
    **{name: shaped(_ACCEL_SHAPES[f], "exact") for name, f in EFFECT_PARAMS.items()},
}
AccelOverrides = _overrides("AccelOverrides", _error_fields(AccelErrorModel, "scalar"),
                            "Overrides of AccelErrorModel fields.")
GyroOverrides = _overrides("GyroOverrides", _error_fields(GyroErrorModel, "broadcast"),
                           "Overrides of GyroErrorModel fields.")
MagOverrides = _overrides("MagOverrides", _error_fields(MagErrorModel, "broadcast"), "Overrides of MagErrorModel fields.")
Effects = _overrides("Effects", {name: EFFECT_TYPES[name] for name in [*EFFECT_FIELDS, *WORLD_EFFECTS, *EFFECT_PARAMS]},
                     "Hidden effects by canonical name, magnitudes.")
Effects.mapping_hint = "expected a mapping of effect name to magnitude"


class ChamberSection(Strict):
    initial_c: number(ge=-100, le=200, description="sensor temperature at the start, C") = ChamberConfig.initial_c
    tau_s: number(gt=0, le=1e6, description="time constant of the sensor temperature, s") = ChamberConfig.tau_s


class RingingSection(Strict):
    amplitude_g: number(ge=0, le=16) = RingingConfig.amplitude_g
    freq_hz: number(gt=0, le=1000) = RingingConfig.freq_hz
    tau_s: number(gt=0, le=1e4) = RingingConfig.tau_s


class FieldSection(Strict):
    magnitude_ut: number(ge=0, le=1000) = FieldConfig.magnitude_ut
    inclination_deg: number(ge=-90, le=90) = FieldConfig.inclination_deg
    declination_deg: number(ge=-360, le=360) = FieldConfig.declination_deg


def _tilt(v):
    if not (isinstance(v, (list, tuple)) and len(v) == 2):
        raise fail("expected [tilt_x_deg, tilt_y_deg]")
    return v


Tilt = number(ge=-45, le=45, description="deg")
TableTilt = Annotated[tuple[Tilt, Tilt], BeforeValidator(_tilt)]


def _factor_range(v):
    ok = (isinstance(v, (list, tuple)) and len(v) == 2 and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                      and math.isfinite(x) and 0.01 <= x <= 100 for x in v))
    if not ok or v[0] > v[1]:
        raise fail(f"expected [lo, hi] factors with 0.01 <= lo <= hi <= 100, got {v!r}")
    return (float(v[0]), float(v[1]))


FactorRange = Annotated[Optional[tuple[float, float]], BeforeValidator(_factor_range), WithJsonSchema({
    "type": "array", "minItems": 2, "maxItems": 2, "items": {"type": "number", "minimum": 0.01, "maximum": 100}})]


class NoiseFiguresSection(Strict):
    """``sim.noise_figures``: this unit's own accelerometer bias wander per axis (x, y, z), in place of its family's:
    what a digital twin of a characterised unit carries (its noise profile, docs/noise.md; docs/twin.md)."""

    accel_bias_instability_g: Optional[array(3, nonneg=True, as_list=True)] = None
    accel_random_walk_g_per_rts: Optional[array(3, nonneg=True, as_list=True)] = None


class NoiseSpreadSection(Strict):
    """``sim.noise_spread``: each simulated unit's noise figures drawn about its family's, a factor per axis and
    term, log-uniform in [lo, hi] (drivers.sensors.sim.unit_noise; docs/noise.md)."""

    white: FactorRange = None
    bias_instability: FactorRange = None
    random_walk: FactorRange = None


_GC = GeometryClass()


class GeometrySection(Strict):
    """``sim.geometry``: the turntable's own errors, drawn per seed from these datasheet-class magnitudes
    (rig.simulation.geometry; docs/simulated-rig.md, "The turntable's own errors"). On unless ``enabled: false``."""

    enabled: flag("the simulated table has its own errors (angular, lost motion, wobble, non-orthogonality, "
                  "sensor mounting, local gravity)") = SIM_GEOMETRY_ENABLED
    zero_offset_deg: number(ge=0, le=10, description="stage zero offsets, half-width, deg") = _GC.zero_offset_deg
    periodic_deg: number(ge=0, le=10, description="worm-gear periodic error amplitude, half-width, deg") = _GC.periodic_deg
    period_deg: number(gt=0, le=360, description="period of the worm-gear error (one worm turn), deg") = _GC.period_deg
    accumulated_deg: number(ge=0, le=10, description="once-per-revolution error amplitude, half-width, deg") = \
        _GC.accumulated_deg
    lost_motion_deg: number(ge=0, le=10, description="lost motion on reversal, largest, deg") = _GC.lost_motion_deg
    wobble_deg: number(ge=0, le=10, description="axis wobble, largest, deg") = _GC.wobble_deg
    non_orthogonality_deg: number(ge=0, le=10, description="inter-axis non-orthogonality, half-width, deg") = \
        _GC.non_orthogonality_deg
    mounting_deg: number(ge=0, le=45, description="sensor mounting misalignment, half-width, deg") = _GC.mounting_deg
    gravity_m_s2: number(ge=9.7, le=9.9, description="local gravity at the simulated site, m/s^2") = G0_M_S2
    table_seed: integer(0, 2**31 - 1, description="which hidden table: its errors are drawn from this, the same for "
                        "every run and unit on this rig file (the run's --seed draws the unit)") = 0


class SimSection(Strict):
    """The ``sim:`` section of a ``kind: sim`` rig file (docs/rig-file.md, docs/simulated-rig.md)."""

    time_scale: number(ge=0, le=1e6, description="1 real time, K times faster, 0 virtual time") = 1.0
    clock: choice(CLOCKS, description="elastic: simulated time waits for a late reader (no lost samples); "
                  "strict: it keeps K x wall time and a late reader loses samples, as on hardware") = "elastic"
    transport: choice(TRANSPORTS, description="pty: the controllers on pseudo-terminals (serial ports); "
                      "memory: in process (ximcsim:// URLs), same protocol bytes, no threads") = "pty"
    sensor: Optional[dict] = None  # reserved, ignored
    chamber: ChamberSection = ChamberSection()
    ringing: RingingSection = RingingSection()
    field: FieldSection = FieldSection()
    table_tilt_deg: TableTilt = (0.0, 0.0)
    effects: Optional[Effects] = None
    errors: AccelOverrides = AccelOverrides()
    gyro_errors: GyroOverrides = GyroOverrides()
    mag_errors: MagOverrides = MagOverrides()
    noise: Optional[choice(NOISE_MODELS)] = None  # None: the chips' default (drivers.sensors.sim.noise)
    noise_spread: Optional[NoiseSpreadSection] = None  # None: every unit has its family's figures
    noise_figures: Optional[NoiseFiguresSection] = None  # None: the family's (or the spread's) figures
    geometry: GeometrySection = GeometrySection()  # the turntable's own errors (on unless enabled: false)
    serial_base: number(ge=1, le=2**31 - 1, integer=True) = 0x5A00
    repeat: number(ge=0, le=2**31 - 1, integer=True,
                   description="run number of a repeatability study: 0 the seed's own noise draws; another number "
                               "draws the noise (and the bias wander) anew for the same hidden sensor, turntable "
                               "and chamber") = 0


# -- faults: -----------------------------------------------------------------------------------------
Probability = number(ge=0, le=1, description="probability per answer or transfer")
ClockTime = Optional[number(ge=0, le=1e9, description="clock seconds")]
Seed = number(ge=-(2**63), le=2**63 - 1, integer=True)
Angle = Optional[number(ge=-1e6, le=1e6, description="deg")]


class XimcFaultsSection(Strict):
    """``faults.ximc.<axis>``: fields of drivers.ximc.sim.emulator.XimcFaults."""

    crc_corrupt_rate: Probability = 0.0
    drop_rate: Probability = 0.0
    truncate_rate: Probability = 0.0
    latency_s: number(ge=0, le=60) = 0.0
    error_answer_rate: Probability = 0.0
    error_answer: choice(("errc", "errd", "errv")) = "errd"
    vanish_at_s: ClockTime = None
    vanish_for_s: number(ge=0, le=3600) = 1.0
    stall_at_deg: Angle = None
    limit_deg: Angle = None
    seed: Seed = 0


def _window(v):
    if v is None:
        return v
    ok = isinstance(v, list) and len(v) == 2 and all(
        isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and 0 <= x <= 1e9 for x in v)
    if not ok or v[0] > v[1]:
        raise fail(f"expected [start_s, end_s] clock times with 0 <= start <= end, got {v!r}")
    return [float(x) for x in v]


Window = Annotated[Optional[list], BeforeValidator(_window), WithJsonSchema({"anyOf": [
    {"type": "array", "minItems": 2, "maxItems": 2, "items": {"type": "number", "minimum": 0}}, {"type": "null"}]})]


class SensorFaultsSection(Strict):
    """``faults.sensor``: fields of drivers.sensors.sim.faults.SensorFaults."""

    oserror_rate: Probability = 0.0
    oserror_window_s: Window = None
    dead_after_s: ClockTime = None
    stuck_after_s: ClockTime = None
    saturate_after_s: ClockTime = None
    thermometer_fail_after_s: ClockTime = None
    seed: Seed = 0
    failed_self_test: flag("the MPU-9150's self-test response falls short (the chip fails its self-test)") = False


class XimcAxesFaults(Strict):
    mapping_hint: ClassVar[str] = "expected a mapping a1, a2, a3"
    a1: XimcFaultsSection = None
    a2: XimcFaultsSection = None
    a3: XimcFaultsSection = None


class FaultsSection(Strict):
    """The ``faults:`` section: fault injection into the simulated controllers and sensor."""

    ximc: XimcAxesFaults = None
    sensor: SensorFaultsSection = None
    #: a fixture's slots (rig file ``fixture:``): slot number -> the faults of that slot's chip (docs/fixture.md)
    slots: Optional[dict[Annotated[int, Field(ge=0, lt=64)], SensorFaultsSection]] = None


# -- the settings the simulated rig is built from -------------------------------------------------------
@dataclass
class SimSettings:
    """The ``sim:`` section of a rig file, validated."""

    time_scale: float = 1.0  # 0 = virtual time
    clock: str = "elastic"  # CLOCKS: how a time-scaled clock treats a late reader
    transport: str = "pty"  # TRANSPORTS: how the runner reaches the emulated controllers
    chamber: ChamberConfig = dataclasses.field(default_factory=ChamberConfig)
    ringing: RingingConfig = dataclasses.field(default_factory=RingingConfig)
    magnetic_field: FieldConfig = dataclasses.field(default_factory=FieldConfig)
    table_tilt_deg: tuple[float, float] = (0.0, 0.0)
    effects: dict[str, Any] = dataclasses.field(default_factory=dict)
    errors: dict[str, Any] = dataclasses.field(default_factory=dict)  # AccelErrorModel overrides
    gyro_errors: dict[str, Any] = dataclasses.field(default_factory=dict)  # GyroErrorModel overrides
    mag_errors: dict[str, Any] = dataclasses.field(default_factory=dict)  # MagErrorModel overrides
    noise: str | None = None  # "white" | "dlpf" | None (the chip models' DEFAULT_NOISE_MODEL)
    noise_spread: dict[str, tuple[float, float]] | None = None  # term -> factor range (drivers.sensors.sim.unit_noise)
    noise_figures: dict[str, list] | None = None  # NoiseConfig field -> this unit's figures (x, y, z)
    geometry: GeometryClass | None = None  # the table's own error classes; None: a perfect table
    gravity_m_s2: float = G0_M_S2  # local gravity of the simulated site (with geometry only)
    table_seed: int = 0  # the hidden table's draw (with geometry only): the rig's, not the run's seed
    serial_base: int = 0x5A00
    repeat: int = 0  # 0: the seed's own noise draws; N: new draws for the same hidden sensor (repeatability)

    @classmethod
    def from_mapping(cls, m, where: str = "sim") -> "SimSettings":
        """From a ``sim:`` mapping (or an already validated :class:`SimSection`); errors name ``where``."""
        s = m if isinstance(m, SimSection) else validate_plain(SimSection, dict(m or {}), where)
        given = lambda model: model.model_dump(exclude_unset=True)
        return cls(time_scale=s.time_scale, clock=s.clock, transport=s.transport, chamber=ChamberConfig(**s.chamber.model_dump()),
                   ringing=RingingConfig(**s.ringing.model_dump()),
                   magnetic_field=FieldConfig(**s.field.model_dump()),
                   table_tilt_deg=(float(s.table_tilt_deg[0]), float(s.table_tilt_deg[1])),
                   effects=given(s.effects) if s.effects is not None else {}, errors=given(s.errors),
                   gyro_errors=given(s.gyro_errors), mag_errors=given(s.mag_errors), noise=s.noise,
                   noise_spread=given(s.noise_spread) if s.noise_spread is not None else None,
                   noise_figures={k: v for k, v in given(s.noise_figures).items() if v is not None}
                   if s.noise_figures is not None else None,
                   serial_base=s.serial_base, repeat=int(s.repeat), **_geometry(s.geometry))


def _geometry(section: GeometrySection) -> dict:
    """SimSettings' geometry fields of a ``sim.geometry`` section (no classes when it is not enabled)."""
    if not section.enabled:
        return {}
    classes = section.model_dump(exclude={"enabled", "gravity_m_s2", "table_seed"})
    return {"geometry": GeometryClass(**classes), "gravity_m_s2": float(section.gravity_m_s2),
            "table_seed": int(section.table_seed)}


register_section("sim", SimSection, kinds=("sim",), doc="the simulated rig (docs/simulated-rig.md)")
register_section("faults", FaultsSection, kinds=("sim",), doc="fault injection into the simulated rig")

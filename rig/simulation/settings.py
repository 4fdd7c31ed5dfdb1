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

from pydantic import BeforeValidator, WithJsonSchema, create_model

from drivers.sensors.sim.error_model import AccelErrorModel, GyroErrorModel, MagErrorModel
from drivers.sensors.sim.noise import NOISE_MODELS
from rig.config.schema import Strict, choice, fail, flag, number, validate_plain
from rig.config.sections import register_section
from rig.simulation.world import ChamberConfig, FieldConfig, RingingConfig

#: Canonical names of hidden effects a rig file may switch on, and how each
#: maps onto the sensor error model (field, shape) or the world model.
EFFECT_FIELDS: dict[str, str] = {
    "bias_tempco": "bias_tempco_g_per_c",
    "bias_tempco_quadratic": "bias_tempco2_g_per_c2",
    "scale_tempco": "scale_tempco_per_c",
    "scale_nonlinearity": "scale_nonlinearity",
    "cross_axis_nonlinearity": "cross_axis_nonlinearity",
    "bias_drift": "bias_drift_g_per_s",
    "thermal_hysteresis": "thermal_hysteresis_g",
    "bias_tempco_cubic": "bias_tempco3_g_per_c3",
    "thermal_gradient": "thermal_gradient_g_per_c_per_s",
    "bias_jump": "bias_jump_g",
}
#: parameters of an effect that are not magnitudes (error-model field), e.g. when the bias jump happens
EFFECT_PARAMS: dict[str, str] = {"bias_jump_t_s": "bias_jump_t_s"}
WORLD_EFFECTS = ("table_tilt", "full_misalignment")
MAX_MAGNITUDE = 1e6  # no error-model term or effect is anywhere near this


def _finite_tree(v, depth: int = 0):
    if isinstance(v, list) and depth < 2 and v:
        return [_finite_tree(x, depth + 1) for x in v]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or abs(v) > MAX_MAGNITUDE:
        raise fail(f"expected a finite number (|x| <= {MAX_MAGNITUDE:g}), a list or a 3x3 list of them, got {v!r}")
    return float(v)


_NUMBER = {"type": "number", "minimum": -MAX_MAGNITUDE, "maximum": MAX_MAGNITUDE}
Magnitude = Annotated[Any, BeforeValidator(_finite_tree), WithJsonSchema({"anyOf": [
    _NUMBER, {"type": "array", "minItems": 1, "items": _NUMBER},
    {"type": "array", "minItems": 1, "items": {"type": "array", "minItems": 1, "items": _NUMBER}}]})]


def _overrides(name: str, fields: list[str], doc: str):
    """A mapping of the given keys, each a number or a list of numbers (None: not given)."""
    model = create_model(name, __base__=Strict, __doc__=doc, **{f: (Magnitude, None) for f in fields})
    model.mapping_hint = "expected a mapping of error-model fields"
    return model


def _field_names(cls) -> list[str]:
    return [f.name for f in dataclasses.fields(cls)]


AccelOverrides = _overrides("AccelOverrides", _field_names(AccelErrorModel), "Overrides of AccelErrorModel fields.")
GyroOverrides = _overrides("GyroOverrides", _field_names(GyroErrorModel), "Overrides of GyroErrorModel fields.")
MagOverrides = _overrides("MagOverrides", _field_names(MagErrorModel), "Overrides of MagErrorModel fields.")
Effects = _overrides("Effects", [*EFFECT_FIELDS, *WORLD_EFFECTS, *EFFECT_PARAMS], "Hidden effects by canonical name, magnitudes.")
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


class SimSection(Strict):
    """The ``sim:`` section of a ``kind: sim`` rig file (docs/rig-file.md, docs/simulated-rig.md)."""

    time_scale: number(ge=0, le=1e6, description="1 real time, K times faster, 0 virtual time") = 1.0
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
    serial_base: number(ge=1, le=2**31 - 1, integer=True) = 0x5A00


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


# -- the settings the simulated rig is built from -------------------------------------------------------
@dataclass
class SimSettings:
    """The ``sim:`` section of a rig file, validated."""

    time_scale: float = 1.0  # 0 = virtual time
    chamber: ChamberConfig = dataclasses.field(default_factory=ChamberConfig)
    ringing: RingingConfig = dataclasses.field(default_factory=RingingConfig)
    magnetic_field: FieldConfig = dataclasses.field(default_factory=FieldConfig)
    table_tilt_deg: tuple[float, float] = (0.0, 0.0)
    effects: dict[str, Any] = dataclasses.field(default_factory=dict)
    errors: dict[str, Any] = dataclasses.field(default_factory=dict)  # AccelErrorModel overrides
    gyro_errors: dict[str, Any] = dataclasses.field(default_factory=dict)  # GyroErrorModel overrides
    mag_errors: dict[str, Any] = dataclasses.field(default_factory=dict)  # MagErrorModel overrides
    noise: str | None = None  # "white" | "dlpf" | None (the chip models' DEFAULT_NOISE_MODEL)
    serial_base: int = 0x5A00

    @classmethod
    def from_mapping(cls, m, where: str = "sim") -> "SimSettings":
        """From a ``sim:`` mapping (or an already validated :class:`SimSection`); errors name ``where``."""
        s = m if isinstance(m, SimSection) else validate_plain(SimSection, dict(m or {}), where)
        given = lambda model: model.model_dump(exclude_unset=True)  # noqa: E731 - the keys the file set
        return cls(time_scale=s.time_scale, chamber=ChamberConfig(**s.chamber.model_dump()),
                   ringing=RingingConfig(**s.ringing.model_dump()),
                   magnetic_field=FieldConfig(**s.field.model_dump()),
                   table_tilt_deg=(float(s.table_tilt_deg[0]), float(s.table_tilt_deg[1])),
                   effects=given(s.effects) if s.effects is not None else {}, errors=given(s.errors),
                   gyro_errors=given(s.gyro_errors), mag_errors=given(s.mag_errors), noise=s.noise,
                   serial_base=s.serial_base)


register_section("sim", SimSection, kinds=("sim",), doc="the simulated rig (docs/simulated-rig.md)")
register_section("faults", FaultsSection, kinds=("sim",), doc="fault injection into the simulated rig")

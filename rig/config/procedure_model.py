"""The ``rig-procedure/1`` schema (pydantic v2): what a procedure file may say, with its bounds.

The leaf specs (:class:`Dwell`, :class:`Settle`, :class:`TemperatureTarget`, :class:`SensorSpec`,
:class:`SolveSpec`) are the values the runner reads; the step models and :class:`ProcedureDoc`
describe the file and are expanded into ``PlannedStep`` by :mod:`rig.config.procedure`.
``docs/schemas/procedure.schema.json`` is generated from here (``python -m rig.cli.schemas``).
"""

from __future__ import annotations

import fnmatch
import math
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar, Optional, Union

from pydantic import (
    BeforeValidator,
    Discriminator,
    Field,
    Tag,
    WithJsonSchema,
    model_validator,
)

from calib.accel.predict import Goal, parameter_names, seed_table_f
from calib.acceptance import AcceptanceLimits, known_pattern
from calib.file.fields import Strict, choice, did_you_mean, fail, flag, label, number, text
from drivers.sensors.chips import CHIPS, SENSOR_MODELS
from drivers.ximc.stage_spec import MR191
from rig.config.rotations import AXIS_NAMES, CUBE_ROTATIONS, about_axis, describe, name_of
from rig.planning.kinematics import f_nominal
from rig.planning.poses import POSE_NAMES

FORMAT = "rig-procedure/1"
GYRO_RANGES_DPS = (250, 500, 1000, 2000)
ADXL345_RATES_HZ = CHIPS["ADXL345"].sample_rates_hz
ACCEL_RANGES_G = tuple(sorted({r for c in CHIPS.values() for r in c.accel_ranges_g}))
MODELS = ("triangular", "full")
METHODS = ("pinv", "flip", "combinations")
RATE_MAX_DEG_S = MR191.max_speed_deg_s  # 8MR191: 4800 full steps/s at 0.01 deg/step
DAY_S = 86400.0
MAX_SAMPLES = 86_400_000  # a day at 1 kHz
MIN_DWELL_SAMPLES = 2
#: steps of one procedure, listed or expanded (repeat:, ramps) alike: a session of this many steps costs the same
#: per step as a short one (the steps journal, docs/session-format.md) and its manifest (about 5 MB) is read
MAX_STEPS = 10_000
MAX_REPEAT = 1000
STEPS_LIMIT = (f"at most {MAX_STEPS} steps in a procedure, listed or after expanding repeat: and ramps; "
               "split it into several procedures")

Angle = number(ge=-3600, le=3600, description="degrees")
Seconds = number(gt=0, le=DAY_S, description="seconds")


def _pose(v):
    if v not in POSE_NAMES:
        raise fail(f"unknown pose {v!r} (allowed: {', '.join(POSE_NAMES[:6])}, "
                   f"or any cube direction such as '+X+Y up', '-X+Y+Z up'){did_you_mean(v, POSE_NAMES)}")
    return v


PoseName = Annotated[str, BeforeValidator(_pose), WithJsonSchema({
    "enum": list(POSE_NAMES), "description": "the sensor axis (or cube direction) that points up"})]


def _angles(v):
    if not (isinstance(v, (list, tuple)) and len(v) == 3):
        raise fail("expected [a1, a2, a3] in degrees")
    return v


Angles = Annotated[tuple[Angle, Angle, Angle], BeforeValidator(_angles)]


class Dwell(Strict):
    """How long to capture at a pose: exactly one of seconds, samples, sem_g."""

    mapping_hint: ClassVar[str] = "expected a mapping with one of seconds, samples, sem_g"
    seconds: Optional[Seconds] = None
    samples: Optional[number(gt=0, ge=MIN_DWELL_SAMPLES, le=MAX_SAMPLES, integer=True)] = None
    sem_g: Optional[number(gt=0, le=1.0, description="standard error of the mean to reach, g")] = None
    max_seconds: Optional[Seconds] = None  # cap for sem_g

    @model_validator(mode="after")
    def _exactly_one(self):
        given = [k for k in ("seconds", "samples", "sem_g") if getattr(self, k) is not None]
        if len(given) != 1:
            raise fail(f"give exactly one of seconds, samples, sem_g (got {', '.join(given) or 'none'})")
        if self.sem_g is not None and self.max_seconds is None:
            raise fail("a sem_g dwell needs max_seconds too (the cap)", at=("max_seconds",))
        return self

    def max_duration_s(self, rate_hz: float) -> float | None:
        """Longest capture in seconds at ``rate_hz`` (None: unknown)."""
        if self.samples is not None:
            return self.samples / rate_hz
        return self.seconds if self.seconds is not None else self.max_seconds


class Settle(Strict):
    """Settle rule (see rig.execution.settle.SettleRule); a step's ``settle`` overrides single keys."""

    window_s: number(gt=0, le=3600) = 0.5
    threshold_g: number(gt=0, le=16) = 0.01
    mean_tol_sigma: number(gt=0, le=1000) = 4.0
    timeout_s: number(gt=0, le=DAY_S) = 30.0
    min_s: number(ge=0, le=3600) = 0.0


class TemperatureTarget(Strict):
    mapping_hint: ClassVar[str] = "expected a mapping with target_c (tolerance_c, hold_s, timeout_s, mode)"
    target_c: number(ge=-40, le=85)
    tolerance_c: number(gt=0, le=50) = 0.3
    hold_s: number(ge=0, le=DAY_S) = 60.0
    timeout_s: number(gt=0, le=7 * DAY_S) = 3600.0
    mode: choice(("wait", "operator"), "expected wait or operator, got {got}") = "wait"

    @model_validator(mode="after")
    def _hold_fits(self):
        if self.hold_s > self.timeout_s:
            raise fail(f"hold_s {self.hold_s:g} s is longer than timeout_s {self.timeout_s:g} s: the hold "
                       "could never complete", at=("hold_s",))
        return self


class SensorSpec(Strict):
    mapping_hint: ClassVar[str] = "expected a mapping (model, accel_range_g, sample_rate_hz, gyro_range_dps)"
    model: Optional[choice(SENSOR_MODELS, f"expected {' or '.join(SENSOR_MODELS)}, got {{got}}")] = None  # None: any
    accel_range_g: choice(ACCEL_RANGES_G) = 4
    sample_rate_hz: number(gt=0, le=100_000) = 100.0
    gyro_range_dps: choice(GYRO_RANGES_DPS) = 250
    magnetometer: flag("read the AK8975 at every static step") = False
    mag_samples: number(gt=0, le=1000, integer=True) = 20  # magnetometer readings per static step

    @model_validator(mode="after")
    def _fits_the_chip(self):
        chip = CHIPS[self.model or "MPU-9150"]
        if not chip.accepts_rate(self.sample_rate_hz):
            rates = chip.sample_rates_hz
            told = (", ".join(f"{r:g}" for r in sorted(rates)) if len(rates) <= 12 else
                    f"1000/(1+n), {min(rates):g}..{max(rates):g}")
            raise fail(f"the {chip.model} runs at {told} Hz; got {self.sample_rate_hz:g}", at=("sample_rate_hz",))
        if self.accel_range_g not in chip.accel_ranges_g:
            raise fail(f"the {chip.model} has ranges {', '.join(map(str, chip.accel_ranges_g))} g", at=("accel_range_g",))
        if self.magnetometer and self.model is not None and not chip.has_magnetometer:
            raise fail(f"the {chip.model} has no magnetometer (the AK8975 sits behind the MPU-9150)",
                       at=("magnetometer",))
        return self


def _thermal(v):
    if v is False:
        return "off"
    if v in ("auto", "off") or (isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= 3):
        return v
    raise fail(f"expected auto, off or an order 1..3, got {v!r}")


Thermal = Annotated[Any, BeforeValidator(_thermal), WithJsonSchema({"anyOf": [
    {"enum": ["auto", "off", False]}, {"type": "integer", "minimum": 1, "maximum": 3}]})]


class SolveSpec(Strict):
    mapping_hint: ClassVar[str] = "expected a mapping (model, method, thermal) or null"
    model: choice(MODELS) = "triangular"
    method: choice(METHODS) = "pinv"
    thermal: Thermal = "auto"  # auto | off | int
    magnetometer: Optional[choice(("positions", "ellipsoid"), "expected positions or ellipsoid, got {got}")] = None

    def get(self, key, default=None):
        return getattr(self, key, default)


def _pattern(v):
    if not isinstance(v, str) or not known_pattern(v):
        raise fail(f"unknown parameter {v!r} (names such as accel.bias_x, accel.scale_*, accel.alpha_yz, "
                   "gyro.bias_*, mag.hard_iron_*; see docs/procedures.md)")
    return v


ParameterPattern = Annotated[str, BeforeValidator(_pattern), WithJsonSchema({
    "type": "string", "description": "parameter name or shell-style pattern (accel.bias_*)"})]
Bound = number(ge=-1e12, le=1e12)


def _range(v):
    if not (isinstance(v, (list, tuple)) and len(v) == 2):
        raise fail("expected [low, high] in the parameter's unit")
    return v


class AcceptSpec(Strict):
    """``accept:``: limits the calibration must meet (docs/procedures.md); a failed limit fails the run."""

    mapping_hint: ClassVar[str] = ("expected a mapping (ranges, max_sigma, max_chi2_per_dof, max_residual_g, "
                                   "max_attitude_error_deg, max_drift_sigma)")
    ranges: dict[ParameterPattern, Annotated[tuple[Bound, Bound], BeforeValidator(_range)]] = {}
    max_sigma: dict[ParameterPattern, number(gt=0, le=1e12)] = {}
    max_chi2_per_dof: Optional[number(gt=0, le=1e9)] = None
    max_residual_g: Optional[number(gt=0, le=16)] = None
    max_attitude_error_deg: Optional[number(gt=0, le=180)] = None
    max_drift_sigma: Optional[number(gt=0, le=1e6)] = None

    @model_validator(mode="after")
    def _sane(self):
        for pattern, (lo, hi) in self.ranges.items():
            if not lo < hi:
                raise fail(f"expected low < high, got [{lo:g}, {hi:g}]", at=("ranges", pattern))
        if not (self.ranges or self.max_sigma or any(v is not None for v in (
                self.max_chi2_per_dof, self.max_residual_g, self.max_attitude_error_deg, self.max_drift_sigma))):
            raise fail("no limits given (an empty accept: would pass anything)")
        return self

    def limits(self) -> AcceptanceLimits:
        """The limits for :func:`calib.acceptance.evaluate`."""
        return AcceptanceLimits(ranges={k: (float(lo), float(hi)) for k, (lo, hi) in self.ranges.items()},
                                max_sigma={k: float(v) for k, v in self.max_sigma.items()},
                                max_chi2_per_dof=self.max_chi2_per_dof, max_residual_g=self.max_residual_g,
                                max_attitude_error_deg=self.max_attitude_error_deg,
                                max_drift_sigma=self.max_drift_sigma)


ACCEL_PARAMETERS = tuple(dict.fromkeys(parameter_names("triangular") + parameter_names("full")))


def _accel_pattern(v):
    if not isinstance(v, str) or not any(fnmatch.fnmatchcase(n, v) for n in ACCEL_PARAMETERS):
        raise fail(f"unknown parameter {v!r} (accelerometer parameters: {', '.join(ACCEL_PARAMETERS)}; "
                   "shell patterns such as accel.bias_* allowed)")
    return v


AccelPattern = Annotated[str, BeforeValidator(_accel_pattern), WithJsonSchema({
    "type": "string", "description": "accelerometer parameter name or shell-style pattern (accel.bias_*)"})]


def _verification_poses(v):
    if v == "seed_table":
        return v
    if not (isinstance(v, list) and 1 <= len(v) <= 100):
        raise fail("expected seed_table or a list of 1 to 100 poses [a1, a2, a3] in degrees")
    for i, pose in enumerate(v):
        if not (isinstance(pose, (list, tuple)) and len(pose) == 3 and all(
                isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and abs(x) <= 3600
                for x in pose)):
            raise fail(f"expected [a1, a2, a3] in degrees (|angle| <= 3600), got {pose!r}", at=(i,))
    return [tuple(float(x) for x in pose) for pose in v]


VerificationPoses = Annotated[Any, BeforeValidator(_verification_poses), WithJsonSchema({"anyOf": [
    {"const": "seed_table"}, {"type": "array", "minItems": 1, "maxItems": 100, "items": {
        "type": "array", "minItems": 3, "maxItems": 3, "items": {"type": "number", "minimum": -3600, "maximum": 3600}}}],
    "description": "the verification poses of attitude_error_deg: the seed's roll/pitch table or [a1, a2, a3] lists"})]


class TargetSpec(Strict):
    """``target:``: what the calibration must achieve; the dwell at every pose follows from it
    (docs/procedures.md, "Accuracy targets")."""

    mapping_hint: ClassVar[str] = "expected a mapping (attitude_error_deg, confidence, poses, sigma, max_seconds)"
    attitude_error_deg: Optional[number(gt=0, le=90, description="largest |roll| or |pitch| error over the "
                                        "verification poses, deg")] = None
    confidence: number(gt=0, lt=1, description="probability of the attitude bound") = 0.95
    poses: VerificationPoses = "seed_table"
    sigma: dict[AccelPattern, number(gt=0, le=1e12)] = {}
    max_seconds: number(gt=0, le=DAY_S, description="time cap of the whole run (session time), s")

    @model_validator(mode="after")
    def _something_to_reach(self):
        if self.attitude_error_deg is None and not self.sigma:
            raise fail("give attitude_error_deg or sigma (or both): a target without either would stop at once")
        return self

    def goal(self, model: str = "triangular") -> Goal:
        """The target as :class:`calib.accel.predict.Goal` for a session solved with ``model``
        (CalibError when a sigma pattern names no parameter of that model)."""
        poses = seed_table_f() if self.poses == "seed_table" else f_nominal(list(self.poses))
        return Goal(attitude_error_deg=self.attitude_error_deg, confidence=self.confidence,
                    poses_f=poses, sigma=dict(self.sigma), model=model)

    def poses_record(self):
        """The verification poses as the calibration file records them."""
        return self.poses if self.poses == "seed_table" else [list(p) for p in self.poses]


# -- steps -------------------------------------------------------------------------------------------
StepName = Optional[label(description="the step's name in the session (default: from the pose)", blank=False)]


class PoseStep(Strict):
    pose: PoseName
    a1_deg: Angle = 0.0
    name: StepName = None
    dwell: Optional[Dwell] = None
    settle: Optional[Settle] = None


class AnglesStep(Strict):
    refused_keys: ClassVar[dict[str, str]] = {"a1_deg": "a1_deg goes with pose; angles_deg already gives a1"}
    angles_deg: Angles
    name: StepName = None
    dwell: Optional[Dwell] = None
    settle: Optional[Settle] = None


class RateSpec(Strict):
    mapping_hint: ClassVar[str] = "expected a mapping {axis, rate_deg_s, seconds}"
    axis: choice(("a1", "a2", "a3"), "expected a1, a2 or a3, got {got}")
    rate_deg_s: number(description=f"non-zero, at most {RATE_MAX_DEG_S:g} deg/s either way")
    seconds: Optional[number(gt=0, le=3600)] = None  # default: the procedure's dwell seconds
    spin_up_s: number(ge=0, le=60) = 0.5

    @model_validator(mode="after")
    def _within_the_stage(self):
        if self.rate_deg_s == 0 or abs(self.rate_deg_s) > RATE_MAX_DEG_S:
            raise fail(f"expected a non-zero rate within the 8MR191's limit of +-{RATE_MAX_DEG_S:g} deg/s, "
                       f"got {self.rate_deg_s:g}", at=("rate_deg_s",))
        return self


class RateStep(Strict):
    rate: RateSpec
    pose: Optional[PoseName] = None
    angles_deg: Optional[Angles] = None
    a1_deg: Angle = 0.0
    name: StepName = None


class TemperatureStep(Strict):
    temperature: TemperatureTarget
    name: StepName = None


@dataclass(frozen=True)
class Mount:
    """The sensor's turn in its fixture relative to the reference mounting (a prompt step's ``mount:``):
    ``turn`` (rows of the 3x3 rotation, sensor frame -> fixture frame, as :mod:`rig.config.rotations`), its
    cube-rotation ``name`` (None for another turn)."""

    name: Optional[str]
    turn: tuple[tuple[float, float, float], ...]

    @classmethod
    def of(cls, matrix) -> "Mount":
        m = [[float(x) for x in row] for row in matrix]
        return cls(name_of(m), tuple(tuple(row) for row in m))

    def words(self) -> str:
        """``180 deg about z (x-z+)``: the turn as the technician is told it."""
        text = describe(self.turn)
        return f"{text} ({self.name})" if self.name and self.name != "x+z+" else text

    def to_manifest(self) -> dict:
        return {"name": self.name, "turn": [list(row) for row in self.turn]}


MOUNT_HINT = ("expected a cube-rotation name such as x+z+ (as placed), x-z+ (180 deg about z), x+z- (180 deg about "
              "x), or {axis: x|y|z, deg: N}")


def _mount(v):
    if isinstance(v, Mount):
        return v
    if isinstance(v, str):
        if v in CUBE_ROTATIONS:
            return Mount.of(CUBE_ROTATIONS[v])
        raise fail(f"{MOUNT_HINT}, got {v!r}{did_you_mean(v, CUBE_ROTATIONS)}")
    if not isinstance(v, dict):
        raise fail(f"{MOUNT_HINT}, got {v!r}")
    unknown = [k for k in v if k not in ("axis", "deg")]
    if unknown:
        raise fail(f"unknown key {unknown[0]!r} (expected axis and deg){did_you_mean(unknown[0], ('axis', 'deg'))}",
                   at=(unknown[0],))
    if v.get("axis") not in AXIS_NAMES:
        raise fail(f"expected x, y or z (the fixture's axis the sensor turns about), got {v.get('axis')!r}",
                   at=("axis",))
    deg = v.get("deg")
    if isinstance(deg, bool) or not isinstance(deg, (int, float)) or not math.isfinite(deg) or abs(deg) > 360:
        raise fail(f"expected the turn in degrees, -360..360, got {deg!r}", at=("deg",))
    return Mount.of(about_axis(v["axis"], deg))


MountField = Annotated[Any, BeforeValidator(_mount), WithJsonSchema({"anyOf": [
    {"enum": list(CUBE_ROTATIONS), "type": "string"},
    {"type": "object", "additionalProperties": False, "required": ["axis", "deg"],
     "properties": {"axis": {"enum": list(AXIS_NAMES)}, "deg": {"type": "number", "minimum": -360, "maximum": 360}}}],
    "description": "the sensor's turn in its fixture relative to the reference mounting (the steps before the "
                   "first mount:): a cube-rotation name (where its +x and +z point; x+z+ as placed) or axis and deg"})]


class PromptStep(Strict):
    prompt: text()
    name: StepName = None
    mount: Optional[MountField] = None  # the operator turns the sensor in its fixture (docs/procedures.md)


RAMP_MAX_C_PER_MIN = 20.0  # climate chambers ramp at 1-15 C/min


class RampSpec(Strict):
    """``ramp:``: the chamber ramps from ``from_c`` (default: where the previous temperature or ramp step
    left it) to ``to_c`` at ``rate_c_per_min`` while the ramp's poses are cycled and captured on the move
    in temperature (docs/procedures.md, "Thermal ramps")."""

    mapping_hint: ClassVar[str] = "expected a mapping with to_c and rate_c_per_min (from_c, cycles, move_settle_s)"
    to_c: number(ge=-40, le=85, description="temperature the chamber ramps to, C")
    rate_c_per_min: number(gt=0, le=RAMP_MAX_C_PER_MIN, description="ramp rate of the chamber, C/min")
    from_c: Optional[number(ge=-40, le=85, description="temperature the ramp starts from, C (default: the "
                                                       "previous temperature or ramp step's)")] = None
    cycles: Optional[number(gt=0, le=1000, integer=True, description="cycles of the poses (default: as many "
                                                                     "as fill the ramp)")] = None
    move_settle_s: number(ge=0, le=600, description="time each pose takes beyond its dwell (move and settle), "
                                                   "s, for planning the cycles") = 6.0


STEP_KINDS = ("pose", "angles_deg", "repeat", "temperature", "prompt", "rate", "ramp")
_TAGS = {"pose": "pose step", "angles_deg": "angles step", "repeat": "repeat step",
         "temperature": "temperature step", "prompt": "prompt step", "rate": "rate step", "ramp": "ramp step"}


def step_kind(item) -> str | None:
    """Which kind of step a mapping is (None when it is not exactly one)."""
    if not isinstance(item, dict):
        return None
    kinds = [k for k in STEP_KINDS if k in item]
    if "rate" in kinds and len(kinds) == 2 and ("pose" in kinds or "angles_deg" in kinds):
        return "rate"  # a rate step may give the pose it spins from
    return kinds[0] if len(kinds) == 1 else None


def _one_kind(item):
    if not isinstance(item, dict):
        raise fail("expected a mapping: a pose, angles_deg, repeat, temperature, prompt, rate or ramp step")
    if step_kind(item) is None:
        kinds = [k for k in STEP_KINDS if k in item]
        meant = "" if kinds else next(filter(None, (did_you_mean(k, STEP_KINDS) for k in item)), "")
        raise fail("each step needs exactly one of pose, angles_deg, repeat, temperature, prompt, rate, ramp"
                   + (f" (got {', '.join(kinds)})" if kinds else meant))
    return item


def _tag(item):
    kind = step_kind(item) if isinstance(item, dict) else None
    return _TAGS[kind] if kind else None


Step = Annotated[Union[
    Annotated[PoseStep, Tag(_TAGS["pose"])], Annotated[AnglesStep, Tag(_TAGS["angles_deg"])],
    Annotated["RepeatStep", Tag(_TAGS["repeat"])], Annotated[TemperatureStep, Tag(_TAGS["temperature"])],
    Annotated[PromptStep, Tag(_TAGS["prompt"])], Annotated[RateStep, Tag(_TAGS["rate"])],
    Annotated["RampStep", Tag(_TAGS["ramp"])],
], Discriminator(_tag), BeforeValidator(_one_kind)]


def _step_list(v):
    if not isinstance(v, list) or not v:
        raise fail("expected a non-empty list of steps")
    if len(v) > MAX_STEPS:  # refused before 10,000s of steps are validated one by one
        raise fail(f"{len(v)} steps listed: {STEPS_LIMIT}")
    return v


Steps = Annotated[list[Step], BeforeValidator(_step_list), Field(min_length=1)]


class RepeatStep(Strict):
    repeat: number(gt=0, le=MAX_REPEAT, integer=True)
    steps: Steps


class RampStep(Strict):
    """``ramp:`` with the pose ``steps:`` cycled while the chamber ramps."""

    ramp: RampSpec
    steps: Steps
    name: StepName = None


RepeatStep.model_rebuild()
RampStep.model_rebuild()


class ProcedureDoc(Strict):
    """A ``rig-procedure/1`` file (docs/procedures.md)."""

    model_config = Strict.model_config | {"title": FORMAT}
    mapping_hint: ClassVar[str] = "expected a mapping with format, name, steps, ..."
    format: choice((FORMAT,), f"expected {FORMAT!r}, got {{got}}")
    name: text(100, "letters, digits, _ and -")
    description: Optional[text()] = None
    sensor: Optional[SensorSpec] = None
    dwell: Dwell = Dwell(seconds=10.0)
    settle: Settle = Settle()
    order: choice(("as_written", "shortest", "fastest"), "expected as_written, shortest or fastest, got {got}") = \
        "as_written"
    steps: Steps
    solve: Optional[SolveSpec] = None
    accept: Optional[AcceptSpec] = None
    target: Optional[TargetSpec] = None
    report: flag("write SESSION/report.html at the end of the run (rig report)") = False

    @model_validator(mode="after")
    def _plain_name(self):
        if not self.name.replace("_", "").replace("-", "").isalnum():
            raise fail("use letters, digits, '_' and '-' only", at=("name",))
        return self

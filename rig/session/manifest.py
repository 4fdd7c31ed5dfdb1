"""The ``session.yaml`` manifest of ``rig-session/1`` as a typed model (docs/session-format.md).

:class:`SessionManifest` validates a loaded manifest (every problem is one
:class:`rig.errors.SessionFormatError` line naming the file and the key path, e.g.
``steps[3].status``, in the field dialect of every format, :mod:`calib.file.fields`) and is what a
writer builds a new session from. ``session.yaml`` is read by the one guarded YAML loader
(:mod:`calib.file.yamlsafe`). Keys the
model does not know are kept (forward compatible): ``model_extra`` holds them and
:meth:`SessionManifest.to_dict` writes them back.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import math
import re
from datetime import date, datetime, timezone
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, field_validator, model_validator

from calib.file import yamlsafe
from calib.file.fields import Index, describe, fail, number
from rig import __version__
from rig.config.yamlload import input_error, read_source
from rig.errors import RigInputError, SessionFormatError
from rig.session import journal

FORMAT = "rig-session/1"
STATUSES = ("running", "complete", "aborted")
STEP_STATUSES = ("pending", "complete", "failed", "flagged")
#: the columns of samples.csv: always these, then optional ones (readers accept others too)
#: magnetometer readings are stored as integers of 0.01 uT in the mx, my, mz columns
MAG_COUNTS_PER_UT = 100.0
BASE_COLUMNS = ("t_s", "step", "ax", "ay", "az", "temp_c")
OPTIONAL_COLUMNS = ("wx", "wy", "wz", "mx", "my", "mz", "a1_deg", "a2_deg", "a3_deg")
SOFTWARE_NAME = "rig-calibration"
#: keys a manifest on disk must have (a new one gets defaults for created, status and software)
REQUIRED = ("id", "created", "status", "procedure", "rig", "software", "steps")


#: session.yaml may be larger than the files a person writes (yamlsafe.MAX_BYTES): about 500 bytes a step (a rate
#: or ramp step up to about 1 kB) plus the recorded procedure (at most 1 MiB). A procedure may have 10,000 steps
#: (rig.config.procedure_model.MAX_STEPS), about 5 MB of manifest; this leaves room for larger steps
MAX_BYTES = 16 * 1024 * 1024


def load_yaml(text: str, path: str):
    """The plain value of YAML ``text`` by the one guarded loader (:func:`calib.file.yamlsafe.load`: libyaml's
    speed for the documents the writer writes); its refusals as one RigInputError naming ``path``."""
    try:
        return yamlsafe.load(text)
    except yamlsafe.HostileYaml as exc:
        raise input_error(exc, path) from None


def utc_now() -> str:
    """The current UTC time, ISO 8601 with milliseconds (the manifest's time stamps)."""
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")


def _iso(v):
    """YAML turns an unquoted time stamp into a datetime: keep it as the ISO text it was."""
    return v.isoformat() if isinstance(v, (date, datetime)) else v


def _finite3(v):
    if v is None:
        return v
    if not (isinstance(v, (list, tuple)) and len(v) == 3 and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v)):
        raise fail("expected [x, y, z] (three finite numbers), or null")
    return [float(x) for x in v]


# numbers are kept as they are (an int stays an int: a manifest read and written again is unchanged)
Timestamp = Annotated[str, BeforeValidator(_iso)]
Vec3 = Annotated[list[float] | None, BeforeValidator(_finite3)]
Number = number(keep_type=True, optional=True, finite=False)
RequiredNumber = number(keep_type=True, finite=False)
PositiveNumber = number(keep_type=True, optional=True, gt=0)
RequiredPositive = number(keep_type=True, gt=0)


class _Section(BaseModel):
    """A manifest section: unknown keys are kept, numbers are accepted where text is expected."""

    model_config = ConfigDict(extra="allow", coerce_numbers_to_str=True, populate_by_name=True,
                              validate_assignment=True)

    def mark_set(self, *names: str) -> None:
        """Always write these fields (even when left at their default)."""
        self.model_fields_set.update(names)


class ProcedureInfo(_Section):
    """``procedure``: the procedure that was run, with its full text (a session replays without the file)."""

    name: str | None = None
    file: str | None = None
    sha256: str | None = None
    text: str | None = None

    @classmethod
    def from_text(cls, name: str, file, text: str | None) -> "ProcedureInfo":
        digest = hashlib.sha256(text.encode()).hexdigest() if text is not None else None
        return cls(name=name, file=None if file is None else str(file), sha256=digest, text=text)

    def solve_spec(self) -> dict | None:
        """The procedure's ``solve:`` section, or None (no text, not YAML, no such section)."""
        return self.section("solve")

    def section(self, key: str) -> dict | None:
        """A top-level mapping of the recorded procedure (``solve``, ``accept``), or None."""
        spec = self.value(key)
        return spec if isinstance(spec, dict) else None

    def value(self, key: str):
        """A top-level value of the recorded procedure (``report: true``), or None (a copy: the text is
        parsed once per text)."""
        if not self.text:
            return None
        try:  # the recorded procedure was validated when it ran: hostile YAML here means tampering
            doc = _procedure_document(self.text)
        except RigInputError as exc:
            raise SessionFormatError(None, None, "procedure.text", exc.message) from None
        return copy.deepcopy(doc.get(key)) if isinstance(doc, dict) else None


@functools.lru_cache(maxsize=8)
def _procedure_document(text: str):
    """A recorded procedure's text parsed (once per text: a solve asks for several of its sections)."""
    return load_yaml(text, "session.yaml: procedure.text")


class SoftwareInfo(_Section):
    """``software``: what wrote the session."""

    name: str | None = SOFTWARE_NAME
    version: str | None = __version__

    @model_validator(mode="after")
    def _always_written(self):
        self.mark_set("name", "version")
        return self


class AxisInfo(_Section):
    """``rig.turntable.axes.a1..a3``: one rotation stage."""

    port: str | None = None
    serial: int | str | None = None
    firmware: str | None = None
    device: Any = None
    sign: Number = None
    home_offset_deg: Number = None


class TurntableInfo(_Section):
    kind: str | None = None
    axes: dict[str, AxisInfo] | None = None


class MagnetometerInfo(_Section):
    """``rig.sensor.magnetometer``: the AK8975 when it was read."""

    model: str | None = None
    address: int | None = None
    asa_factor: Vec3 = None
    mag_lsb_per_ut: PositiveNumber = None


class SensorInfo(_Section):
    """``rig.sensor``: the sensor's identity and settings."""

    model: str | None = None
    address: int | None = None
    serial: int | str | None = None
    identity: Any = None
    accel_range_g: Number = None
    accel_lsb_per_g: RequiredPositive
    sample_rate_hz: RequiredPositive
    has_temperature: bool = False
    gyro_range_dps: Number = None
    gyro_lsb_per_dps: PositiveNumber = None
    magnetometer: MagnetometerInfo | None = None
    self_test: dict | None = None


class SiteInfo(_Section):
    """``rig.site``: the local geomagnetic field."""

    field_ut: RequiredNumber
    inclination_deg: RequiredNumber
    declination_deg: RequiredNumber


class RigInfo(_Section):
    """``rig``: the turntable, the sensor, the site and the rig file (``kind: import`` for imports)."""

    kind: str | None = None
    turntable: TurntableInfo | None = None
    sensor: SensorInfo
    rig_file: str | None = None
    rig_file_sha256: str | None = None
    site: SiteInfo | None = None


class StepStats(_Section):
    """``steps[].stats``: what the capture measured (all optional; unknown keys kept)."""

    n_samples: Number = None
    t_start_s: Number = None
    t_end_s: Number = None
    temp_c: Number = None
    noise_g: list[Number] | None = None
    settle_s: Number = None
    attempts: int | None = None
    problems: list[Any] | None = None
    angles_measured_deg: list[Number] | None = None
    stage_rate_deg_s: list[Number] | None = None


def _turn(v):
    if not (isinstance(v, (list, tuple)) and len(v) == 3 and all(isinstance(r, (list, tuple)) and len(r) == 3 and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in r) for r in v)):
        raise fail("expected a 3x3 list of finite numbers (rows of the turn, sensor frame -> fixture frame)")
    return [[float(x) for x in r] for r in v]


class MountRecord(_Section):
    """``steps[].mount``: the sensor's turn in its fixture relative to the reference mounting (a prompt's, or the
    one in force at a step) in a procedure whose prompts turn it (``mount:``, docs/procedures.md): its cube-rotation
    ``name`` (null for another turn) and ``turn`` (rows, sensor frame -> fixture frame)."""

    name: str | None = None
    turn: Annotated[list[list[float]], BeforeValidator(_turn)]


class StepRecord(_Section):
    """``steps[i]``: one step, planned (``status: pending``) then recorded."""

    index: int
    name: str | None = None
    kind: str = "static"
    angles_deg: Vec3 = None
    f_nominal: Vec3 = None
    status: Literal["pending", "complete", "failed", "flagged"] = "pending"
    stats: StepStats | None = None
    target_c: Number = None
    prompt: str | None = None
    axis: str | None = None
    rate_deg_s: Number = None
    rate_nominal_dps: Vec3 = None
    pose_group: int | None = None
    mount: MountRecord | None = None

    @model_validator(mode="after")
    def _always_written(self):
        self.mark_set("index", "name", "kind", "angles_deg", "f_nominal", "status")
        return self

    @property
    def label(self) -> str:
        return self.name if self.name is not None else f"step {self.index + 1}"

    @property
    def is_static(self) -> bool:
        return self.kind == "static"

    @property
    def has_pose(self) -> bool:
        return self.f_nominal is not None


class ImportInfo(_Section):
    """``import``: where an imported session came from (``rig import``)."""

    source: str | None = None
    file: str | None = None
    units: str | None = None
    g_ms2: Number = None
    lsb_per_g: Number = None
    steps_from: str | None = None
    notes: list[str] = Field(default_factory=list)


class SessionManifest(_Section):
    """``session.yaml``. Build one for a new session; :meth:`load` validates one on disk."""

    format: Literal["rig-session/1"] = FORMAT
    id: str
    created: Timestamp = Field(default_factory=utc_now)
    status: Literal["running", "complete", "aborted"] = "running"
    seed: int | None = None
    replay_of: str | None = None
    procedure: ProcedureInfo
    software: SoftwareInfo = Field(default_factory=SoftwareInfo)
    steps: list[StepRecord]
    rig: RigInfo
    import_: ImportInfo | None = Field(default=None, alias="import")
    columns: list[str] | None = None
    samples_committed_bytes: int | None = Field(default=None, ge=0)
    ended: Timestamp | None = None

    @field_validator("steps")
    @classmethod
    def _indexed(cls, steps):
        """Each step's index is its place (checked when the steps are validated, not at every assignment of
        another field: a writer sets ``samples_committed_bytes`` once a step, which must not cost O(steps))."""
        for i, s in enumerate(steps):
            if s.index != i:
                raise fail(f"expected a step mapping with index {i}, got index {s.index}", at=(Index(i),))
        return steps

    @model_validator(mode="after")
    def _checked(self):
        self.mark_set("format", "id", "created", "status", "procedure", "software", "steps", "rig")
        return self

    # -- views used by the readers ----------------------------------------------------------------
    @property
    def sensor(self) -> SensorInfo:
        return self.rig.sensor

    def step(self, index: int) -> StepRecord:
        return self.steps[index]

    def to_dict(self) -> dict:
        """The plain mapping written to ``session.yaml`` (fields left unset are not written)."""
        return self.model_dump(mode="python", by_alias=True, exclude_unset=True)

    # -- loading ----------------------------------------------------------------------------------
    @classmethod
    def from_mapping(cls, doc, path=None) -> "SessionManifest":
        """Validate a parsed manifest; every problem is one SessionFormatError line."""
        where = str(path) if path is not None else None
        if not isinstance(doc, dict):
            raise SessionFormatError(where, None, None, "expected a mapping")
        if doc.get("format") != FORMAT:
            raise SessionFormatError(where, None, "format", f"expected {FORMAT!r}, got {doc.get('format')!r}")
        for key in REQUIRED:
            if key not in doc:
                raise SessionFormatError(where, None, key, "missing required field")
        try:
            return cls.model_validate(doc)
        except ValidationError as exc:
            _, key, message = describe(exc, doc)
            raise SessionFormatError(where, None, key, message) from None

    @classmethod
    def load(cls, session_dir) -> tuple["SessionManifest", dict]:
        """Read and validate ``SESSION/session.yaml`` with the steps journal (``steps.jsonl``, left by a session
        that is being recorded or was killed) folded in: the model and the plain mapping as read and folded."""
        d = Path(session_dir)
        path = d / "session.yaml"
        if not d.is_dir():
            raise SessionFormatError(str(d), None, None, "no such session directory")
        if not path.is_file():
            raise SessionFormatError(str(path), None, None, "missing: not a rig-session/1 directory")
        try:  # the one guarded loader: size, depth, aliases, tags, duplicate keys, digits
            doc = load_yaml(read_source(path, "session manifest", "missing", MAX_BYTES), str(path))
        except RigInputError as exc:
            raise SessionFormatError(exc.path, exc.line, exc.key, exc.message) from None
        journal.fold(doc, journal.read(d)[0], d)
        manifest = cls.from_mapping(doc, path)
        validate_session_id(manifest.id, path)
        return manifest, doc


_ID_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.\-]{0,127}$")


def validate_session_id(session_id: str, path=None) -> str:
    """A session id is one path component: letters, digits, '_', '-', '.'; never '..'."""
    if not isinstance(session_id, str) or not _ID_RE.match(session_id) or ".." in session_id:
        raise SessionFormatError(None if path is None else str(path), None, "id", f"invalid session id "
                                 f"{session_id!r} (letters, digits, '_', '-', '.'; no path separators or '..')")
    return session_id


def as_manifest(manifest, path=None) -> SessionManifest:
    """A :class:`SessionManifest` from a model or a plain mapping (validated)."""
    if isinstance(manifest, SessionManifest):
        return manifest
    return SessionManifest.from_mapping(manifest, path)

"""The ``session.yaml`` manifest of ``rig-session/1`` as a typed model (docs/session-format.md).

:class:`SessionManifest` validates a loaded manifest (every problem is one
:class:`rig.errors.SessionFormatError` line naming the file and the key path, e.g.
``steps[3].status``) and is what a writer builds a new session from. Keys the
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

import yaml
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, model_validator
from yaml.cyaml import CParser

from rig import __version__
from rig.config.yamlload import MAX_DEPTH, MAX_INT_DIGITS, load_located, read_source
from rig.errors import RigInputError, SessionFormatError

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


# -- reading the manifest's YAML fast ------------------------------------------------------------------
# ``rig.config.yamlload.load_located`` (pure-Python scanner, located values, every hostile-YAML guard) is
# the one YAML reader; a session.yaml is read on every solve and it took most of the solve's time. The
# manifest needs no line marks, so :func:`load_yaml` takes libyaml's events (``yaml.cyaml.CParser``: the
# scanner and parser in C, one event at a time, nothing recursive) and builds the plain values itself,
# for the documents ``yaml.safe_dump`` writes: printable text, mappings, lists and scalars, no anchors,
# aliases or tags, no duplicate keys, at most ``MAX_DEPTH`` deep, integers of at most ``MAX_INT_DIGITS``
# digits. Anything else (or anything libyaml refuses) goes to ``load_located``, whose value or one-line
# error is then the answer: the fast path only ever answers what ``load_located`` answers the same
# (tests/rig/session/test_manifest_yaml.py).

_INT, _FLOAT, _STR = "tag:yaml.org,2002:int", "tag:yaml.org,2002:float", "tag:yaml.org,2002:str"
_RESOLVERS = yaml.SafeLoader.yaml_implicit_resolvers
_SIMPLE_INT = re.compile(r"[-+]?(?:0|[1-9][0-9]*)\Z")
_SIMPLE_FLOAT = re.compile(r"[-+]?[0-9][0-9.eE+-]*\Z")
#: where a plain scalar in a flow collection ends at one of these, libyaml and PyYAML differ
_FLOW_INDICATORS = re.compile(r"[?:#,\[\]{}]")
#: the fast path reads newlines and printable characters only (no tabs, carriage returns, control characters,
#: byte-order marks or the Unicode line and paragraph separators: libyaml and PyYAML differ on some of them)
_NOT_PLAIN_TEXT = re.compile("[^\n\x20-\x7e\xa0-\u2027\u202a-\ud7ff\ue000-\ufefe\uff00-\ufffd]")


class _NotPlain(Exception):
    """The document is not one the fast path reads: ``load_located`` decides."""


def load_yaml(text: str, path: str):
    """The plain value of YAML ``text`` (dict, list, str, int, float, bool, None), as
    :func:`rig.config.yamlload.load_located` gives it (and its errors, naming ``path``), faster."""
    try:
        return _load_plain(text)
    except (_NotPlain, yaml.YAMLError, ValueError, TypeError, RecursionError, MemoryError):
        return load_located(text, path)[0]


def _load_plain(text: str):
    """``text``'s value by the fast path (:class:`_NotPlain` or libyaml's error when it does not read it)."""
    if _NOT_PLAIN_TEXT.search(text):
        raise _NotPlain
    parser = CParser(text)
    constructor = yaml.SafeLoader("")  # scalar constructors of the tags other than int, float and str
    try:
        return _build_events(parser, constructor)
    finally:
        parser.dispose()


def _build_events(parser, constructor):
    """The single document's value from the parser's events (:class:`_NotPlain` for anything else)."""
    stack: list = []  # [container, pending key or _NO_KEY, flow style]
    root = _NO_KEY
    seen: dict = {}  # (text, plain) -> value: keys and repeated values resolved once (all immutable)
    flows = 0  # flow collections open
    while True:
        event = parser.get_event()
        kind = type(event)
        if kind is yaml.ScalarEvent:
            if event.anchor is not None or event.tag is not None or len(stack) >= MAX_DEPTH or (
                    flows and event.implicit[0] and _FLOW_INDICATORS.search(event.value)):
                raise _NotPlain
            memo = (event.value, event.implicit[0])
            value = seen[memo] if memo in seen else seen.setdefault(memo, _scalar(event, constructor))
        elif kind is yaml.MappingStartEvent or kind is yaml.SequenceStartEvent:
            if event.anchor is not None or event.tag is not None or len(stack) >= MAX_DEPTH:
                raise _NotPlain
            stack.append([{} if kind is yaml.MappingStartEvent else [], _NO_KEY, bool(event.flow_style)])
            flows += stack[-1][2]
            continue
        elif kind is yaml.MappingEndEvent or kind is yaml.SequenceEndEvent:
            value, _, flow = stack.pop()
            flows -= flow
        elif kind is yaml.StreamEndEvent:
            return None if root is _NO_KEY else root
        elif kind is yaml.StreamStartEvent or kind is yaml.DocumentEndEvent:
            continue
        elif kind is yaml.DocumentStartEvent:
            if root is not _NO_KEY or event.explicit or event.version or event.tags:
                raise _NotPlain  # a second document, directives: load_located decides
            continue
        else:  # an alias
            raise _NotPlain
        if not stack:
            root = value
        else:
            _add(stack[-1], value)


_NO_KEY = object()


def _add(top: list, value) -> None:
    """Put ``value`` into the open container ``top`` ([container, pending key, flow style])."""
    container = top[0]
    if isinstance(container, list):
        container.append(value)
    elif top[1] is _NO_KEY:
        if isinstance(value, (dict, list)) or value in container:
            raise _NotPlain  # a key that is a collection, a duplicate key
        top[1] = value
    else:
        container[top[1]] = value
        top[1] = _NO_KEY


def _scalar(event, constructor):
    """A scalar's value as SafeLoader resolves and constructs it (int, float and str directly)."""
    value = event.value
    tag = _STR
    if event.implicit[0]:
        for tag_, regexp in _RESOLVERS.get(value[:1], []) + _RESOLVERS.get(None, []):
            if regexp.match(value):
                tag = tag_
                break
    if tag is _STR or tag == _STR:
        return value
    if tag == _INT:
        if len(value.replace("_", "").lstrip("+-")) > MAX_INT_DIGITS:
            raise _NotPlain
        if _SIMPLE_INT.match(value):
            return int(value)
    elif tag == _FLOAT and _SIMPLE_FLOAT.match(value):
        return float(value)
    return constructor.construct_object(yaml.ScalarNode(tag, value, event.start_mark, event.end_mark), deep=True)


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
        raise ValueError("expected [x, y, z] (three finite numbers), or null")
    return [float(x) for x in v]


def _number(v):
    """An int or a float kept as it is (so a manifest read and written again is unchanged)."""
    if v is None:
        return v
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ValueError(f"expected a number, got {_short(v)}")
    return v


def _positive(v):
    if v is None:
        return v
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0 or not math.isfinite(v):
        raise ValueError(f"expected a positive number, got {_short(v)}")
    return v


def _required(check):
    def strict(v):
        if v is None:
            raise ValueError("expected a number, got None")
        return check(v)
    return strict


Timestamp = Annotated[str, BeforeValidator(_iso)]
Vec3 = Annotated[list[float] | None, BeforeValidator(_finite3)]
Number = Annotated[float | int | None, BeforeValidator(_number)]
RequiredNumber = Annotated[float | int, BeforeValidator(_required(_number))]
PositiveNumber = Annotated[float | int | None, BeforeValidator(_positive)]
RequiredPositive = Annotated[float | int, BeforeValidator(_required(_positive))]


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

    @model_validator(mode="after")
    def _checked(self):
        for i, s in enumerate(self.steps):
            if s.index != i:
                raise ValueError(f"steps[{i}]: expected a step mapping with index {i}, got index {s.index}")
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
            key, message = describe_error(exc)
            raise SessionFormatError(where, None, key, message) from None

    @classmethod
    def load(cls, session_dir) -> tuple["SessionManifest", dict]:
        """Read and validate ``SESSION/session.yaml``: the model and the plain mapping as read."""
        d = Path(session_dir)
        path = d / "session.yaml"
        if not d.is_dir():
            raise SessionFormatError(str(d), None, None, "no such session directory")
        if not path.is_file():
            raise SessionFormatError(str(path), None, None, "missing: not a rig-session/1 directory")
        try:  # the hostile-YAML guards of every other loader: size, depth, aliases, duplicate keys, digits
            doc = load_yaml(read_source(path, "session manifest", "missing"), str(path))
        except RigInputError as exc:
            raise SessionFormatError(exc.path, exc.line, exc.key, exc.message) from None
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


_TYPE_TAGS = {"int", "str", "float", "bool", "none", "list", "dict"}
_MESSAGES = {
    "missing": "missing required field",
    "literal_error": None,  # replaced by the allowed values
    "model_type": "expected a mapping",
    "model_attributes_type": "expected a mapping",
    "dict_type": "expected a mapping",
    "list_type": "expected a list",
    "greater_than": "expected a positive number",
    "greater_than_equal": "expected a number >= 0",
    "string_type": "expected text",
    "int_type": "expected an integer",
    "int_from_float": "expected an integer",
    "int_parsing": "expected an integer",
    "float_type": "expected a number",
    "bool_type": "expected true or false",
    "bool_parsing": "expected true or false",
}


def describe_error(exc: ValidationError) -> tuple[str | None, str]:
    """(key path, one-line message) of a validation error's first problem."""
    err = exc.errors(include_url=False)[0]
    key = ""
    for part in err["loc"]:
        if isinstance(part, str) and (part in _TYPE_TAGS or "[" in part or "(" in part):
            continue  # a union member's or a validator's tag, not a key
        if isinstance(part, int):
            key += f"[{part}]"
        else:
            key += ("." if key else "") + str(part)
    kind = err["type"]
    got = _short(err.get("input"))
    if kind == "literal_error":
        allowed = STEP_STATUSES if key.endswith("].status") else STATUSES if key == "status" else None
        message = f"expected one of {', '.join(allowed)}, got {got}" if allowed else f"{err['msg']}, got {got}"
    elif kind == "value_error":
        message = str(err["msg"]).removeprefix("Value error, ")
        if message.startswith("steps["):  # the step check of the whole manifest names its own key
            key, _, message = message.partition(": ")
    elif kind in _MESSAGES:
        message = _MESSAGES[kind] + ("" if kind == "missing" else f", got {got}")
    else:
        message = f"{err['msg']}, got {got}"
    return key or None, " ".join(message.split())


def _short(v) -> str:
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."

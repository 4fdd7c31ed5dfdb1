"""The calibration file (``rig-calibration/1``, YAML). See docs/calibration-file.md.

:class:`CalibrationFile` is the file's schema: a pydantic model whose sections are
:class:`calib.file.section.CalibrationSection` subclasses (:class:`AccelCalibration`,
:class:`GyroCalibration`, :class:`MagCalibration`). ``write`` is atomic (temp file + rename).
``read`` validates the format and every field, raising :class:`CalibrationFileError` that names the
file, the field and what was expected: a tampered or truncated file never yields numbers.
:func:`json_schema` is the file's JSON Schema (``docs/schemas/calibration.schema.json``).
:meth:`CalibrationFile.apply` applies every section to a :class:`calib.file.apply.Recording` (raw counts in,
physical units out), refusing a recording the file is not for.
"""

from __future__ import annotations

import json
import os
import stat
import tempfile
from pathlib import Path
from typing import Any, ClassVar, Iterable, Optional

import yaml
from pydantic import (BeforeValidator, ConfigDict, Field, FiniteFloat, NonNegativeInt, StrictBool, field_validator,
                      with_config)
from pydantic.json_schema import SkipJsonSchema
from typing_extensions import Annotated, NotRequired, TypedDict

from calib.file import yamlsafe
from calib.file.apply import CalibratedRecording, Recording, apply_calibration
from calib.accel.result import AccelCalibration
from calib.accel.target_record import TargetRecord
from calib.errors import CalibrationFileError
from calib.gyro.result import GyroCalibration
from calib.mag.result import MagCalibration
from calib.file.section import CalibrationSection

FORMAT = "rig-calibration/1"
SCHEMA_ID = "https://rig-calibration.invalid/schemas/calibration.schema.json"

#: a string; YAML may have read an unquoted time stamp or id as another type
Text = Annotated[str, BeforeValidator(lambda v: v if isinstance(v, str) else str(v))]
OptionalText = Annotated[Optional[str], BeforeValidator(lambda v: v if v is None or isinstance(v, str) else str(v))]


@with_config(ConfigDict(extra="allow"))
class SoftwareInfo(TypedDict, total=False):
    """The software that wrote the file."""

    name: OptionalText
    version: OptionalText


@with_config(ConfigDict(extra="allow"))
class SensorInfo(TypedDict, total=False):
    """The sensor calibrated: ``model``, ``address`` (I2C, null when none), ``serial`` (null when the chip has none)."""

    model: OptionalText
    address: Any
    serial: Any


@with_config(ConfigDict(extra="forbid"))
class LimitRecord(TypedDict):
    """One acceptance limit applied (:class:`calib.acceptance.LimitCheck`)."""

    name: Text
    limit: Text
    value: Optional[FiniteFloat]
    passed: StrictBool
    line: Text


@with_config(ConfigDict(extra="forbid"))
class AcceptanceRecord(TypedDict):
    """The procedure's acceptance limits and the verdict: ``passed`` only when every limit passed."""

    passed: StrictBool
    limits: list[LimitRecord]


@with_config(ConfigDict(extra="forbid"))
class CoverageRecord(TypedDict):
    """Written only when the session solved was incomplete: what was planned and what was missing."""

    complete: StrictBool
    status: Text
    steps_planned: NonNegativeInt
    steps_recorded: NonNegativeInt
    pending_steps: list[Text]


@with_config(ConfigDict(extra="forbid"))
class NoiseUsed(TypedDict):
    """One sensor's bias-wander figures the solve used (docs/noise.md): the flicker's B (the registry's convention,
    ``sqrt(2)`` times the Allan floor) and the random walk K, their RMS over the axes and each axis's (x, y, z),
    and the flicker corner, in ``unit``."""

    unit: Text
    bias_instability: FiniteFloat
    random_walk: FiniteFloat
    flicker_corner_s: FiniteFloat
    bias_instability_xyz: list[FiniteFloat]
    random_walk_xyz: list[FiniteFloat]


@with_config(ConfigDict(extra="forbid"))
class NoiseRecord(TypedDict):
    """Written only when the unit's own figures replaced the chip family's (docs/noise.md). ``source``: either
    ``unit profile`` (its newest ``rig-noise/1`` profile: ``measured_at`` its date, ``session`` the session
    characterised) or ``recording`` (no profile: the solved session's own static steps, the family's figures as
    the prior: ``measured_at`` and ``session`` the solved session's, ``steps`` and ``seconds`` what they rest on)."""

    source: Text
    sensor_key: Text
    measured_at: Text
    session: OptionalText
    sensors: dict[str, NoiseUsed]
    steps: NotRequired[NonNegativeInt]
    seconds: NotRequired[FiniteFloat]


class CalibrationFile(CalibrationSection):
    """One ``rig-calibration/1`` file: header fields and the typed sensor sections.

    Attributes
    ----------
    format : always ``rig-calibration/1``.
    created : UTC ISO-8601 time of the solve.
    software : {name, version}.
    session : id of the session solved, or None.
    sensor : {model, address, serial}.
    accelerometer : :class:`AccelCalibration` (counts <-> g, sensor frame).
    gyroscope : :class:`GyroCalibration` (counts <-> deg/s) or None; a dict is validated into one.
    magnetometer : :class:`MagCalibration` (uT) or None; a dict is validated into one.
    coverage : :class:`CoverageRecord` when the session solved was incomplete, else None (not written).
    acceptance : :class:`AcceptanceRecord` when the procedure has ``accept:`` limits, else None (not written).
    extra : not written (kept for callers that attach data in memory).
    """

    CAL_TYPE: ClassVar[str] = ""
    FILE_REQUIRED: ClassVar[tuple[str, ...]] = ("format",)
    model_config = ConfigDict(frozen=True, extra="forbid",
                              json_schema_extra={"$schema": "https://json-schema.org/draft/2020-12/schema",
                                                 "$id": SCHEMA_ID})

    format: str = Field(FORMAT, description="file format and version")
    created: Text = Field(description="UTC ISO-8601 time of the solve")
    software: SoftwareInfo = Field(description="software that wrote the file")
    session: OptionalText = Field(None, description="id of the session solved")
    sensor: SensorInfo = Field(description="the sensor calibrated")
    accelerometer: AccelCalibration
    gyroscope: Optional[GyroCalibration] = None
    magnetometer: Optional[MagCalibration] = None
    coverage: Optional[CoverageRecord] = Field(
        None, description="present only when the session was incomplete: steps planned, recorded, still pending")
    target: Optional[TargetRecord] = Field(
        None, description="the procedure's accuracy target, its prediction from the recorded steps and whether it is met")
    acceptance: Optional[AcceptanceRecord] = Field(
        None, description="the procedure's accept: limits, each check and the verdict (absent: no limits)")
    noise: Optional[NoiseRecord] = Field(
        None, description="the unit's own noise figures the sigmas used instead of the family's: its noise profile or "
        "its recording's static steps (absent: the family's)")
    extra: SkipJsonSchema[dict] = Field(default_factory=dict, exclude=True)

    #: written only when present (files without them are the common case and stay as they were)
    OMITTED_WHEN_NONE: ClassVar[tuple[str, ...]] = ("coverage", "target", "acceptance", "noise")

    def to_dict(self) -> dict:
        d = super().to_dict()
        for key in self.OMITTED_WHEN_NONE:
            if d.get(key) is None:
                d.pop(key, None)
        return d

    def apply(self, recording: Recording, sensors: str | Iterable[str] | None = None,
              source: str | None = None) -> CalibratedRecording:
        """The one way to apply a calibration file: raw counts of ``recording`` in, physical units out.

        Parameters
        ----------
        recording : :class:`calib.file.apply.Recording`: data per sensor (N, 3), ``t_s``, ``temp_c``, and
            what they were recorded as (sensor model, sensitivity of the range, unit).
        sensors : the sections to apply (``"accelerometer"``, ``"gyroscope"``, ``"magnetometer"``); default
            every section of the file for which the recording has data.
        source : how refusals name the file (its path); default the session it was solved from.

        Returns
        -------
        :class:`calib.file.apply.CalibratedRecording`: ``f_g`` (g; ``f_ms2`` m/s^2), ``w_dps`` (deg/s),
        ``h_ut`` (uT), sensor frame, with ``units()`` and the sections ``applied``.

        Raises
        ------
        calib.file.apply.RecordingMismatch (a CalibError), one line naming the file, what it is for and
        what the recording is: another sensor model, another sensitivity (full-scale range), another
        unit, no section for the data, no temperature for a thermal model. docs/calibration-file.md.
        """
        return apply_calibration(self, recording, sensors, source)

    @field_validator("format", mode="before")
    @classmethod
    def _format(cls, v: Any) -> str:
        if v != FORMAT:
            raise ValueError(f"expected {FORMAT!r}, got {v!r}")
        return v


def json_schema() -> dict:
    """JSON Schema (draft 2020-12) of a ``rig-calibration/1`` file as parsed from YAML.

    Field types, shapes, signs and units (``unit``); the cross-field rules (scale equal to the matrix
    diagonal, triangular zeros, invertibility, effect terms) are checked by :func:`read` only.
    """
    schema = _drop_nan_defaults(CalibrationFile.json_schema())
    schema["properties"]["format"]["const"] = FORMAT
    schema["title"] = FORMAT
    return schema


def _drop_nan_defaults(node: Any) -> Any:
    """JSON has no NaN: leave out in-memory NaN defaults (the file must carry those fields anyway)."""
    if isinstance(node, dict):
        return {k: _drop_nan_defaults(v) for k, v in node.items()
                if not (k == "default" and isinstance(v, float) and v != v)}
    if isinstance(node, list):
        return [_drop_nan_defaults(v) for v in node]
    return node


def write_json_schema(path=None) -> Path:
    """Write :func:`json_schema` to ``path`` (default ``docs/schemas/calibration.schema.json``)."""
    p = Path(path) if path is not None else Path(__file__).resolve().parents[2] / "docs/schemas/calibration.schema.json"
    p.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(p, json.dumps(json_schema(), indent=2, allow_nan=False) + "\n")
    return p


def atomic_write_text(path, text: str | bytes) -> None:
    """Write ``text`` (or bytes) to ``path`` atomically: temp file in the same directory, fsync, rename, fsync
    the directory. A crash leaves either the old file or the new one, never a torn one.

    The file gets the mode of the regular file it replaces, else ``0o666 & ~umask`` (what ``open`` would
    give; ``mkstemp`` alone gives 0600). Any OSError names ``path``, never the temporary file. ``path`` is
    replaced whatever it is (a link is replaced, not followed): callers that take a path from a user check
    it first (``rig.cli.outputs``).
    """
    path = Path(path)
    target = os.fspath(path)
    try:
        mode = _mode_for(path)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror or str(exc), target) from exc
    try:
        with os.fdopen(fd, "wb" if isinstance(text, bytes) else "w") as fh:
            os.fchmod(fh.fileno(), mode)
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
        dfd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):  # named after the file asked for, never the temporary one
            raise OSError(exc.errno, exc.strerror or str(exc), target) from exc
        raise


def _mode_for(path: Path) -> int:
    """The permission bits a file written at ``path`` gets: those of the regular file there, else
    ``0o666 & ~umask``."""
    try:
        st = os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):
        st = None
    if st is not None and stat.S_ISREG(st.st_mode):
        return stat.S_IMODE(st.st_mode)
    return 0o666 & ~_umask()


def _umask() -> int:
    """The process umask, read without changing it (``/proc/self/status`` on Linux; elsewhere set and restored)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write(path, cal: CalibrationFile) -> Path:
    """Write ``cal`` as YAML ``rig-calibration/1`` atomically (:func:`atomic_write_text`); returns the path."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    # libyaml's emitter when there is one: the same text as yaml.safe_dump's Python emitter, a fifth of the time
    dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
    atomic_write_text(p, yaml.dump(cal.to_dict(), Dumper=dumper, sort_keys=False, default_flow_style=None))
    return p


def read(path) -> CalibrationFile:
    """Read and validate a calibration file.

    Raises
    ------
    CalibrationFileError naming the file, the field and what was expected.
    """
    p = str(path)
    try:
        doc = yamlsafe.load(yamlsafe.read_text(path))
    except FileNotFoundError:
        raise CalibrationFileError(p, None, "no such calibration file") from None
    except IsADirectoryError:
        raise CalibrationFileError(p, None, "is a directory, expected a calibration YAML file") from None
    except yamlsafe.HostileYaml as exc:
        raise CalibrationFileError(p, f"line {exc.line}" if exc.line else None, str(exc)) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise CalibrationFileError(p, f"line {mark.line + 1}" if mark else None, "not valid YAML") from None
    return from_dict(doc, p)


def from_dict(doc: Any, path: str = "<calibration>") -> CalibrationFile:
    """Validate a parsed calibration file; :class:`CalibrationFileError` names ``path`` and the field."""
    if not isinstance(doc, dict):
        raise CalibrationFileError(path, None, "expected a mapping")
    return CalibrationFile.from_dict(doc, path)

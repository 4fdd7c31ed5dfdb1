"""Applying a calibration file to a recording: raw counts in, physical units out.

The one way to do it is :meth:`calib.file.calibration.CalibrationFile.apply` (which calls
:func:`apply_calibration`): every section of the file for which the recording has data, in one call,
after checking that the recording is one the file is for (the shape of imucal's
``CalibrationInfo.calibrate``, which refuses data in another unit). docs/calibration-file.md, "Applying
a calibration".

- :class:`Recording`: what is applied to: raw data per sensor (N, 3), time and temperature (N,), and
  what the data were recorded as (sensor model, sensitivity of the range, unit), built by the caller
  (``rig.analysis.apply.recording_from_session`` for a session);
- :class:`CalibratedRecording`: what comes out: specific force in g (and m/s^2), rate in deg/s,
  field in uT, in the sensor frame, with its units and the sections applied (their type tags).

A recording the file is not for is refused with one :class:`RecordingMismatch` line (a
:class:`calib.errors.CalibError`) naming the file, what it is for, and what the recording is: another
sensor model, another sensitivity (full-scale range), another unit, no section for the data, no
temperature for a thermal model.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import ClassVar, Iterable

import numpy as np

from calib.accel.result import AccelCalibration
from calib.errors import CalibError
from calib.file.section import CalibrationSection
from calib.gyro.result import GyroCalibration
from calib.mag.result import MagCalibration

#: standard gravity, m/s^2 per g (the file's g: specific force in units of g0; PX4, ArduPilot, imucal)
G_MS2 = 9.80665
#: the sensors a calibration file may hold a section for, in the order they are applied
SENSORS = ("accelerometer", "gyroscope", "magnetometer")
#: the units a recording's magnetometer data may be in (raw counts are divided by its counts per uT first); the
#: accelerometer's and the gyroscope's must be their section's INPUT_UNIT (raw counts)
MAG_UNITS = ("counts", "uT")


class RecordingMismatch(CalibError):
    """The recording is not one the calibration file is for (another sensor model, sensitivity or unit,
    no section for its data, no temperature for a thermal model): one line naming both."""


def _vectors(name: str, value, n: int | None) -> np.ndarray | None:
    if value is None:
        return None
    a = np.asarray(value, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3 or (n is not None and len(a) != n):
        want = f"({n}, 3)" if n is not None else "(N, 3)"
        raise CalibError(f"Recording.{name}: expected an array of shape {want}, got {list(a.shape)}")
    return a


def _series(name: str, value, n: int) -> np.ndarray | None:
    if value is None:
        return None
    a = np.broadcast_to(np.asarray(value, dtype=float), (n,)) if np.ndim(value) == 0 else np.asarray(value, float)
    if a.shape != (n,):
        raise CalibError(f"Recording.{name}: expected {n} values (one per sample), got shape {list(a.shape)}")
    return a


def _sensitivity(name: str, value) -> float | None:
    if value is None:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise CalibError(f"Recording.{name}: expected a number > 0, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise CalibError(f"Recording.{name}: expected a finite number > 0, got {value!r}")
    return v


@dataclass(frozen=True, eq=False)
class Recording:
    """A recording to calibrate: raw data per sensor and what they were recorded as.

    Attributes
    ----------
    sensor_model : the chip recorded (``"MPU-9150"``); None only when it is not known (then not checked).
    label : what the recording is, named in refusals (``"session sessions/six_position-..."``).
    t_s : (N,) s from the start of the recording (time effects), or None.
    temp_c : (N,) sensor temperature, C (thermal model, temperature effects), or None.
    accel : (N, 3) accelerometer data in ``accel_unit``, or None.
    accel_unit : "counts" (the raw output; the only unit the accelerometer section takes).
    lsb_per_g : sensitivity of the range recorded, counts/g (must equal the file's).
    accel_range_g : the range, +-g (named in refusals only), or None.
    gyro, gyro_unit, lsb_per_dps, gyro_range_dps : the same for the gyroscope (counts per deg/s).
    mag : (N, 3) magnetometer data in ``mag_unit`` ("counts", divided by ``mag_lsb_per_ut``, or "uT").
    mag_lsb_per_ut : counts per uT of the magnetometer's raw output (needed when ``mag_unit`` is counts).

    NaN rows (a sample without a reading of that sensor) give NaN rows in the result.
    """

    sensor_model: str | None
    label: str = "the recording"
    t_s: np.ndarray | None = None
    temp_c: np.ndarray | None = None
    accel: np.ndarray | None = None
    accel_unit: str = "counts"
    lsb_per_g: float | None = None
    accel_range_g: float | None = None
    gyro: np.ndarray | None = None
    gyro_unit: str = "counts"
    lsb_per_dps: float | None = None
    gyro_range_dps: float | None = None
    mag: np.ndarray | None = None
    mag_unit: str = "counts"
    mag_lsb_per_ut: float | None = None

    def __post_init__(self) -> None:
        n = None
        for name in ("accel", "gyro", "mag"):
            a = _vectors(name, getattr(self, name), n)
            object.__setattr__(self, name, a)
            n = len(a) if a is not None and n is None else n
        if n is None:
            raise CalibError(f"{self.label}: a Recording needs the data of at least one sensor (accel, gyro or mag)")
        for name in ("t_s", "temp_c"):
            object.__setattr__(self, name, _series(name, getattr(self, name), n))
        for name in ("lsb_per_g", "lsb_per_dps", "mag_lsb_per_ut"):
            object.__setattr__(self, name, _sensitivity(name, getattr(self, name)))

    def __len__(self) -> int:
        return len(next(a for a in (self.accel, self.gyro, self.mag) if a is not None))

    @property
    def sensors(self) -> tuple[str, ...]:
        """The sensors the recording has data of (``SENSORS`` names)."""
        return tuple(s for s, a in zip(SENSORS, (self.accel, self.gyro, self.mag)) if a is not None)

    @property
    def has_temperature(self) -> bool:
        return self.temp_c is not None and bool(np.any(np.isfinite(self.temp_c)))


@dataclass(frozen=True, eq=False)
class CalibratedRecording:
    """A recording in physical units, sensor frame (the result of :meth:`CalibrationFile.apply`).

    Attributes
    ----------
    TYPE : the type tag, ``"calibrated-recording"``.
    applied : type tags (``CAL_TYPE``) of the sections applied, in order.
    label : the recording's.
    t_s, temp_c : as given (s, C), or None.
    f_g : (N, 3) specific force, g, or None; :attr:`f_ms2` the same in m/s^2 (``G_MS2`` per g).
    w_dps : (N, 3) angular rate, deg/s, or None.
    h_ut : (N, 3) magnetic field, uT, or None (an ellipsoid calibration: up to one fixed rotation).
    """

    TYPE: ClassVar[str] = "calibrated-recording"
    FRAME: ClassVar[str] = "sensor"
    UNITS: ClassVar[dict[str, str]] = {"t_s": "s", "temp_c": "C", "f_g": "g", "f_ms2": "m/s^2", "w_dps": "deg/s",
                                       "h_ut": "uT"}

    applied: tuple[str, ...]
    label: str
    t_s: np.ndarray | None = None
    temp_c: np.ndarray | None = None
    f_g: np.ndarray | None = None
    w_dps: np.ndarray | None = None
    h_ut: np.ndarray | None = None

    @property
    def f_ms2(self) -> np.ndarray | None:
        """Specific force (N, 3) in m/s^2 (``f_g`` times standard gravity)."""
        return None if self.f_g is None else self.f_g * G_MS2

    def units(self) -> dict[str, str]:
        """Unit of every quantity the result holds (``{"f_g": "g", "f_ms2": "m/s^2", ...}``)."""
        return {k: u for k, u in self.UNITS.items() if getattr(self, k) is not None}


# ---------------------------------------------------------------------------------------------- refusals

def _norm_model(model: str) -> str:
    return re.sub(r"[^0-9a-z]", "", str(model).casefold())


def _join(names: Iterable[str]) -> str:
    names = list(names)
    return " and ".join(names) if len(names) < 3 else ", ".join(names[:-1]) + " and " + names[-1]


def _plain(x: float) -> str:
    return f"{x:g}"


def _range(rng: float | None, unit: str) -> str:
    return f", its +-{_plain(rng)} {unit} range" if rng else ""


def _check_model(cal: CalibrationSection, rec: Recording, name: str) -> None:
    model = (cal.sensor or {}).get("model")
    if not model:
        return  # a file that does not say: nothing to compare (docs/calibration-file.md)
    if rec.sensor_model is None:
        raise RecordingMismatch(f"{name}: calibrates the {model}; {rec.label} does not say which sensor it recorded "
                                "(give its sensor model)")
    if _norm_model(model) != _norm_model(rec.sensor_model):
        raise RecordingMismatch(f"{name}: calibrates the {model}; {rec.label} is a recording of the {rec.sensor_model}: "
                                "another sensor model (solve a calibration of that sensor)")


def _check_unit(name: str, rec: Recording, sensor: str, want: Iterable[str], got: str) -> None:
    want = tuple(want)
    if got not in want:
        takes = " or ".join("raw counts" if u == "counts" else u for u in want)
        raise RecordingMismatch(f"{name}: its {sensor} section takes {takes}; {rec.label} gives its {sensor} data "
                                f"in {got}: another unit (give the {sensor}'s {takes})")


def _check_sensitivity(name: str, rec: Recording, sensor: str, file_value: float, rec_value: float | None,
                       unit: str, field_name: str, rng: float | None, rng_unit: str) -> None:
    if rec_value is None:
        raise RecordingMismatch(f"{name}: calibrates the {sensor} at {_plain(file_value)} {unit}; {rec.label} does not "
                                f"state the {sensor}'s sensitivity ({field_name}), so its range is unknown")
    if not math.isclose(file_value, rec_value, rel_tol=1e-9):
        raise RecordingMismatch(f"{name}: calibrates the {sensor} at {_plain(file_value)} {unit}; {rec.label} recorded it "
                                f"at {_plain(rec_value)} {unit}{_range(rng, rng_unit)}: another full-scale range "
                                "(calibrate at that range)")


def _sections_to_apply(cal: CalibrationSection, rec: Recording, sensors, name: str) -> list[str]:
    held = [s for s in SENSORS if getattr(cal, s) is not None]
    have = rec.sensors
    if sensors is None:
        use = [s for s in held if s in have]
        if not use:
            raise RecordingMismatch(f"{name}: holds the {_join(held)} section{'s' * (len(held) > 1)}; {rec.label} has "
                                    f"{_join(have)} data only: no section of the file for its data")
        return use
    use = list(dict.fromkeys([sensors] if isinstance(sensors, str) else sensors))
    for s in use:
        if s not in SENSORS:
            raise CalibError(f"apply(): unknown sensor {s!r} (expected {', '.join(SENSORS)})")
        if s not in held:
            raise RecordingMismatch(f"{name}: has no {s} section (it holds {_join(held)}); {rec.label}'s {s} data "
                                    "were asked for: no section of the file for the data")
        if s not in have:
            raise RecordingMismatch(f"{name}: its {s} section was asked for; {rec.label} has no {s} data "
                                    f"(it has {_join(have)})")
    return [s for s in SENSORS if s in use]


def _check(cal: CalibrationSection, rec: Recording, use: list[str], name: str) -> None:
    _check_model(cal, rec, name)
    if "accelerometer" in use:
        acc: AccelCalibration = cal.accelerometer
        _check_unit(name, rec, "accelerometer", (acc.INPUT_UNIT,), rec.accel_unit)
        _check_sensitivity(name, rec, "accelerometer", float(acc.lsb_per_g), rec.lsb_per_g, "counts/g", "lsb_per_g",
                           rec.accel_range_g, "g")
        needs = acc.apply_needs()
        if "temp_c" in needs and not rec.has_temperature:
            what = (f"a thermal bias model (t0 {_plain(acc.temperature.t0_c)} C, order {acc.temperature.order})"
                    if acc.temperature is not None else "temperature effects")
            raise RecordingMismatch(f"{name}: its accelerometer section has {what}; {rec.label} has no temperature "
                                    "(temp_c): refusing to apply the bias at t0 instead")
        if "t_s" in needs and rec.t_s is None:
            raise RecordingMismatch(f"{name}: its accelerometer section has time effects (bias drift, jump or thermal "
                                    f"gradient); {rec.label} has no time stamps (t_s)")
    if "gyroscope" in use:
        gyro: GyroCalibration = cal.gyroscope
        _check_unit(name, rec, "gyroscope", (gyro.INPUT_UNIT,), rec.gyro_unit)
        _check_sensitivity(name, rec, "gyroscope", float(gyro.lsb_per_dps), rec.lsb_per_dps, "counts/(deg/s)",
                           "lsb_per_dps", rec.gyro_range_dps, "deg/s")
        if gyro.g_sensitivity and "accelerometer" not in use:
            raise RecordingMismatch(f"{name}: its gyroscope section corrects the g-sensitivity (G f), which needs the "
                                    f"specific force; {rec.label} is calibrated without the accelerometer "
                                    "(apply the accelerometer section too)")
    if "magnetometer" in use:
        mag: MagCalibration = cal.magnetometer
        _check_unit(name, rec, "magnetometer", MAG_UNITS, rec.mag_unit)
        if rec.mag_unit == "counts" and rec.mag_lsb_per_ut is None:
            raise RecordingMismatch(f"{name}: its magnetometer section takes {mag.INPUT_UNIT}; {rec.label} gives raw "
                                    "counts without their counts per uT (mag_lsb_per_ut)")


# ---------------------------------------------------------------------------------------------- applying

def apply_calibration(cal: CalibrationSection, rec: Recording, sensors: str | Iterable[str] | None = None,
                      source: str | None = None) -> CalibratedRecording:
    """:meth:`CalibrationFile.apply`: the sections of ``cal`` applied to ``rec`` after every check.

    ``cal`` is a :class:`calib.file.calibration.CalibrationFile` (annotated by its base class: that module
    imports this one)."""
    if not isinstance(rec, Recording):
        raise CalibError(f"apply(): expected a calib.file.apply.Recording, got {type(rec).__name__}")
    name = source or (f"calibration (session {cal.session})" if cal.session else "calibration")
    use = _sections_to_apply(cal, rec, sensors, name)
    _check(cal, rec, use, name)
    out: dict = {}
    try:
        if "accelerometer" in use:
            out["f_g"] = cal.accelerometer.apply(rec.accel, temp_c=rec.temp_c if rec.has_temperature else None,
                                                 t_s=rec.t_s)
        if "gyroscope" in use:
            out["w_dps"] = cal.gyroscope.apply(rec.gyro, f_g=out.get("f_g"))
        if "magnetometer" in use:
            m_ut = rec.mag / rec.mag_lsb_per_ut if rec.mag_unit == "counts" else rec.mag
            out["h_ut"] = cal.magnetometer.apply(m_ut)
    except CalibError as exc:  # a section's own refusal (NaN temperatures, unordered time stamps): say where
        raise CalibError(f"{name}, applied to {rec.label}: {exc}") from None
    return CalibratedRecording(applied=tuple(use), label=rec.label, t_s=rec.t_s, temp_c=rec.temp_c, **out)

"""A unit's noise profile (``rig-noise/1``): its Allan-variance figures, stored under the unit's identity
and used, when present, instead of the chip family's (docs/noise.md, "The profile").

Storage: one JSON file per characterisation in a folder beside the calibration history database
(``history.sqlite`` -> ``history.noise/``; ``--history PATH``, else ``$RIG_HISTORY``, else the user's),
``<folder>/<sensor key>/<measured_at>.json`` (the key made a safe file name). The history database is
not touched. :func:`latest_profile` gives the newest profile of a sensor key;
:func:`unit_stabilities` turns one into the solvers' :class:`calib.numerics.stability.BiasStability`
per sensor.
"""

from __future__ import annotations

import json
import math
import os
import re
from datetime import datetime, timezone
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING, Literal, Optional

from pydantic import BaseModel, ConfigDict, Field

from calib.noise.terms import REGISTRY_B_FLOOR, UNITS
from calib.numerics.stability import AxisStability, BiasStability
from drivers.sensors.chips import CHIPS
from rig.config.validate import validate_plain
from rig.errors import RigInputError
from rig.lab.history import default_path
from rig.lab.identity import sensor_identity

if TYPE_CHECKING:  # type hints only: the fit (scipy.optimize) loads with rig characterize, not with every solve
    from calib.noise.characterize import Characterisation

FORMAT = "rig-noise/1"
SCHEMA_FILE = "noise.schema.json"
SCHEMA_ID = "https://rig.example/schemas/noise.schema.json"
#: sensor -> the chip registry's flicker corner field (a profile cannot measure the corner: the family's is kept)
CORNERS = {"accel": "accel_flicker_corner_s", "gyro": "gyro_flicker_corner_s", "mag": "mag_flicker_corner_s"}


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Term(_Model):
    value: float = Field(ge=0, description="the figure, in the sensor's unit (N per sqrt(Hz), K per sqrt(s), R per s)")
    sigma: float = Field(ge=0, description="1-sigma uncertainty of the figure")
    ci95: tuple[float, float] = Field(description="95 % confidence interval [lo, hi]")


class AxisNoise(_Model):
    N: Term = Field(description="white noise density, unit/sqrt(Hz)")
    B: Optional[Term] = Field(None, description="bias instability: the Allan deviation's floor, unit")
    K: Optional[Term] = Field(None, description="random walk, unit/sqrt(s)")
    R: Optional[Term] = Field(None, description="rate ramp, unit/s (only where the fit saw one)")
    tau_floor_s: Optional[float] = Field(None, description="averaging time of the fitted curve's minimum, s")
    chi2_dof: float = Field(ge=0, description="chi-squared per degree of freedom of the fit")


class SensorNoise(_Model):
    unit: Literal["g", "deg/s", "uT"]
    x: AxisNoise
    y: AxisNoise
    z: AxisNoise


class SensorRef(_Model):
    key: str = Field(description="the unit's identity, as the calibration history keys it (docs/history.md)")
    model: Optional[str] = None
    serial: Optional[str] = None


class NoiseProfile(_Model):
    """``rig-noise/1``: one characterisation of one unit (docs/noise.md)."""

    model_config = ConfigDict(extra="forbid", frozen=True, json_schema_extra={
        "$schema": "https://json-schema.org/draft/2020-12/schema", "$id": SCHEMA_ID})
    format: Literal["rig-noise/1"] = FORMAT
    sensor: SensorRef
    measured_at: str = Field(description="UTC ISO-8601 time the session characterised was created")
    session: Optional[str] = Field(None, description="id of the session characterised")
    step: Optional[int] = None
    duration_s: float = Field(gt=0)
    rate_hz: float = Field(gt=0)
    temperature_c: Optional[float] = Field(None, description="mean sensor temperature over the record, C")
    accel: SensorNoise
    gyro: Optional[SensorNoise] = None
    mag: Optional[SensorNoise] = None

    def sensors(self) -> dict[str, SensorNoise]:
        return {s: getattr(self, s) for s in UNITS if getattr(self, s) is not None}


def _term(fit) -> dict:
    return {"value": fit.value, "sigma": fit.sigma, "ci95": (fit.lo, fit.hi)}


def profile_from(session, result: "Characterisation", step: int) -> NoiseProfile:
    """The profile of ``session``'s unit from its characterisation ``result`` of step ``step``."""
    ident = sensor_identity(session.info.to_dict(), SimpleNamespace(sensor=None))
    rows = session.samples["step"] == step
    temp = session.samples.get("temp_c")
    temp_c = float(temp[rows].mean()) if temp is not None and bool(rows.any()) and math.isfinite(temp[rows].mean()) \
        else None
    sensors = {}
    for sensor, fits in result.fits.items():
        sensors[sensor] = {"unit": UNITS[sensor], **{axis: {
            **{t: _term(f) for t, f in fit.terms.items()}, "tau_floor_s": fit.tau_floor_s, "chi2_dof": fit.chi2_dof}
            for axis, fit in fits.items()}}
    return validate_plain(NoiseProfile, {
        "sensor": {"key": ident["key"], "model": ident["model"], "serial": ident["serial"]},
        "measured_at": str(session.info.created or datetime.now(timezone.utc).isoformat(timespec="seconds")),
        "session": session.id, "step": step, "duration_s": result.duration_s, "rate_hz": result.rate_hz,
        "temperature_c": temp_c, **sensors}, "rig-noise/1")


def profiles_dir(history=None) -> Path:
    """The folder of the profiles beside the history database (``history.sqlite`` -> ``history.noise``)."""
    db = default_path(history)
    return db.with_name(db.stem + ".noise")


def _safe(key: str) -> str:
    return re.sub(r"[^A-Za-z0-9._@#+-]", "_", key)[:120]


def record_profile(profile: NoiseProfile, history=None) -> Path:
    """Store ``profile`` under its unit's key; returns the file written (atomically)."""
    folder = profiles_dir(history) / _safe(profile.sensor.key)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / (re.sub(r"[^0-9T]", "", profile.measured_at)[:15] + ".json")
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(profile.model_dump_json(indent=2) + "\n")
    os.replace(tmp, path)
    return path


def load_profile(path) -> NoiseProfile:
    """A profile file, validated; RigInputError (one line naming the file and key) when it is not one."""
    p = Path(path)
    try:
        data = json.loads(p.read_text())
    except (OSError, ValueError) as exc:
        raise RigInputError(str(p), None, None, f"not a rig-noise/1 profile: {exc}") from None
    return validate_plain(NoiseProfile, data, str(p))


def latest_profile(key: str, history=None) -> NoiseProfile | None:
    """The newest valid profile stored for sensor ``key`` (by ``measured_at``), or None. A file that is not a
    profile (damaged, edited, half-written by another tool) is passed over: it never hides the valid ones."""
    folder = profiles_dir(history) / _safe(key)
    found = []
    for path in sorted(folder.glob("*.json")) if folder.is_dir() else ():
        try:
            found.append(load_profile(path))
        except RigInputError:
            continue
    found = [p for p in found if p.sensor.key == key]
    return max(found, key=lambda p: p.measured_at) if found else None


def unit_stabilities(profile: NoiseProfile) -> dict[str, tuple[BiasStability, ...]]:
    """Per sensor, one :class:`BiasStability` per axis (x, y, z) from the profile: its floor B in the registry's
    convention (``/`` :data:`calib.noise.terms.REGISTRY_B_FLOOR`), its K, and the family's flicker corner."""
    spec = CHIPS.get(profile.sensor.model or "")
    out = {}
    for sensor, noise in profile.sensors().items():
        corner = getattr(spec, CORNERS[sensor], None) if spec else None
        corner = corner or (spec.accel_flicker_corner_s if spec else 5000.0)
        out[sensor] = tuple(BiasStability((a.B.value if a.B else 0.0) / REGISTRY_B_FLOOR,
                                          a.K.value if a.K else 0.0, float(corner), UNITS[sensor])
                            for a in (noise.x, noise.y, noise.z))
    return out


def schema() -> dict:
    return NoiseProfile.model_json_schema()


def render_schema() -> str:
    return json.dumps(schema(), indent=2, sort_keys=True) + "\n"


def _unit_noise(manifest: dict, history=None) -> tuple[str, NoiseProfile, dict] | None:
    """(sensor key, the newest noise profile of the unit ``manifest`` records, its figures per sensor with any
    wander) or None: no profile, none with wander figures, or a history folder that cannot be read."""
    key = sensor_identity(manifest, SimpleNamespace(sensor=None))["key"]
    try:
        profile = latest_profile(key, history)
    except (OSError, RigInputError):
        return None
    if profile is None:
        return None
    used = {sensor: AxisStability.of(axes) for sensor, axes in unit_stabilities(profile).items() if any(
        s.bias_instability > 0 or s.random_walk_per_rts > 0 for s in axes)}
    return (key, profile, used) if used else None


def unit_accel_stability(manifest: dict, history=None) -> tuple[object, NoiseProfile] | None:
    """The accelerometer's :class:`~calib.numerics.stability.AxisStability` from the newest noise profile of the unit
    a session manifest (``manifest``: its plain mapping) records, and that profile; None without one (or without
    accelerometer figures in it, or when the history's folder cannot be read)."""
    found = _unit_noise(manifest, history)
    if found is None or "accel" not in found[2]:
        return None
    return found[2]["accel"], found[1]


def use_unit_profile(session, history=None) -> dict | None:
    """Attach the newest noise profile of ``session``'s unit (its identity as the history keys it) to the session
    (``Session.unit_noise``: the solvers' bias stability per sensor) and return the calibration file's ``noise``
    record; None (nothing attached) when the unit has no profile or the history's folder cannot be read."""
    found = _unit_noise(session.info.to_dict(), history)
    if found is None:
        return None
    key, profile, used = found
    session.unit_noise = used
    return {"source": "unit profile", "sensor_key": key, "measured_at": profile.measured_at,
            "session": profile.session, "sensors": figures_used(used)}


def figures_used(used: dict) -> dict:
    """The calibration file's ``noise.sensors``: per sensor of ``used`` (sensor -> its
    :class:`~calib.numerics.stability.AxisStability`) its unit, B (registry convention) and K as the RMS over the axes
    and per axis (x, y, z), and the flicker corner (s)."""
    return {s: {"unit": b.unit, "bias_instability": b.bias_instability, "random_walk": b.random_walk_per_rts,
                "flicker_corner_s": b.flicker_corner_s, "bias_instability_xyz": [a.bias_instability for a in b.axes],
                "random_walk_xyz": [a.random_walk_per_rts for a in b.axes]} for s, b in used.items()}

"""The calibration file (``rig-calibration/1``, YAML). See docs/calibration-file.md.

``write`` is atomic (temp file + rename). ``read`` validates the format and
every field, raising :class:`CalibrationFileError` that names the file, the
field and what was expected: a tampered or truncated file never yields numbers.
"""

from __future__ import annotations

import math
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from calib.errors import CalibrationFileError
from calib.models import MODELS, AccelCalibration, FitSummary, ThermalModel

FORMAT = "rig-calibration/1"


@dataclass(frozen=True)
class CalibrationFile:
    created: str
    software: dict
    session: str | None
    sensor: dict
    accelerometer: AccelCalibration
    gyroscope: dict | None = None
    magnetometer: dict | None = None
    format: str = FORMAT
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"format": self.format, "created": self.created, "software": dict(self.software),
                "session": self.session, "sensor": dict(self.sensor),
                "accelerometer": accel_to_dict(self.accelerometer),
                "gyroscope": self.gyroscope, "magnetometer": self.magnetometer}


def _l(v):
    return np.asarray(v, float).tolist()


def accel_to_dict(a: AccelCalibration) -> dict:
    return {
        "model": a.model,
        "lsb_per_g": float(a.lsb_per_g),
        "bias_counts": _l(a.bias_counts),
        "scale_counts_per_g": _l(a.scale_counts_per_g),
        "misalignment": None if a.misalignment is None else {k: float(v) for k, v in a.misalignment.items()},
        "misalignment_unit": "rad",
        "matrix_counts_per_g": _l(a.matrix_counts_per_g),
        "temperature": None if a.temperature is None else {
            "t0_c": float(a.temperature.t0_c), "order": int(a.temperature.order),
            "bias_coefficients": _l(a.temperature.coefficients)},
        "effects": [dict(e) for e in a.effects],
        "sigma": _plain(a.sigma),
        "fit": {"steps": int(a.fit.steps), "samples": int(a.fit.samples),
                "residual_rms_g": float(a.fit.residual_rms_g), "chi2_per_dof": _f(a.fit.chi2_per_dof),
                "method": a.fit.method},
    }


def _f(x):
    x = float(x)
    return None if math.isnan(x) else x


def _plain(v):
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_plain(x) for x in np.asarray(v, dtype=object).tolist()] if not isinstance(v, list) else [_plain(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


def atomic_write_text(path, text: str) -> None:
    """Write ``text`` to ``path`` atomically: temp file in the same directory, fsync, rename, fsync the directory.

    A crash leaves either the old file or the new one, never a torn one.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    dfd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dfd)
    finally:
        os.close(dfd)


def write(path, cal: CalibrationFile) -> Path:
    """Write atomically; returns the path."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(p, yaml.safe_dump(cal.to_dict(), sort_keys=False, default_flow_style=None))
    return p


def read(path) -> CalibrationFile:
    """Read and validate a calibration file."""
    p = str(path)
    try:
        text = Path(path).read_text()
    except FileNotFoundError:
        raise CalibrationFileError(p, None, "no such calibration file") from None
    except IsADirectoryError:
        raise CalibrationFileError(p, None, "is a directory, expected a calibration YAML file") from None
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise CalibrationFileError(p, f"line {mark.line + 1}" if mark else None, "not valid YAML") from None
    return from_dict(doc, p)


def from_dict(doc, path: str = "<calibration>") -> CalibrationFile:
    v = _V(path)
    if not isinstance(doc, dict):
        v.fail(None, "expected a mapping")
    if doc.get("format") != FORMAT:
        v.fail("format", f"expected {FORMAT!r}, got {doc.get('format')!r}")
    for k in ("created", "software", "sensor", "accelerometer"):
        if k not in doc:
            v.fail(k, "missing required field")
    if not isinstance(doc["software"], dict):
        v.fail("software", "expected a mapping with name and version")
    if not isinstance(doc["sensor"], dict):
        v.fail("sensor", "expected a mapping with model, address, serial")
    a = doc["accelerometer"]
    if not isinstance(a, dict):
        v.fail("accelerometer", "expected a mapping")
    model = a.get("model")
    if model not in MODELS:
        v.fail("accelerometer.model", f"expected one of {', '.join(MODELS)}, got {model!r}")
    lsb = v.number(a, "lsb_per_g", "accelerometer", positive=True)
    bias = v.vector(a, "bias_counts", "accelerometer", (3,))
    scale = v.vector(a, "scale_counts_per_g", "accelerometer", (3,), positive=True)
    matrix = v.vector(a, "matrix_counts_per_g", "accelerometer", (3, 3))
    if not np.allclose(np.diag(matrix), scale, rtol=1e-9, atol=1e-9):
        v.fail("accelerometer.scale_counts_per_g", "must equal the diagonal of matrix_counts_per_g")
    if abs(np.linalg.det(matrix)) < 1e-12 * np.prod(np.abs(np.diag(matrix))):
        v.fail("accelerometer.matrix_counts_per_g", "matrix is singular")
    mis = a.get("misalignment")
    if model == "triangular":
        if not isinstance(mis, dict) or set(mis) != {"alpha_yz", "alpha_zy", "alpha_zx"}:
            v.fail("accelerometer.misalignment", "expected {alpha_yz, alpha_zy, alpha_zx} in radians for the triangular model")
        for k in mis:
            v.number(mis, k, "accelerometer.misalignment")
        if np.any(np.abs(np.tril(matrix, -1)) > 0):
            v.fail("accelerometer.matrix_counts_per_g", "the triangular model has zeros below the diagonal")
    elif mis is not None:
        v.fail("accelerometer.misalignment", f"expected null for the {model} model")
    temp = a.get("temperature")
    thermal = None
    if temp is not None:
        if not isinstance(temp, dict):
            v.fail("accelerometer.temperature", "expected a mapping {t0_c, order, bias_coefficients} or null")
        t0 = v.number(temp, "t0_c", "accelerometer.temperature")
        order = temp.get("order")
        if not isinstance(order, int) or isinstance(order, bool) or not 1 <= order <= 3:
            v.fail("accelerometer.temperature.order", f"expected 1, 2 or 3, got {order!r}")
        coef = v.vector(temp, "bias_coefficients", "accelerometer.temperature", (3, order))
        thermal = ThermalModel(t0, order, coef)
    effects = a.get("effects", [])
    if not isinstance(effects, list) or not all(isinstance(e, dict) and "name" in e for e in effects):
        v.fail("accelerometer.effects", "expected a list of effects, each a mapping with a name")
    if effects:
        try:
            from calib.effects import validate_effect
        except ImportError:
            v.fail("accelerometer.effects", "this version cannot apply added effects")
        for i, e in enumerate(effects):
            problem = validate_effect(e)
            if problem:
                v.fail(f"accelerometer.effects[{i}]", problem)
    sigma = a.get("sigma")
    if not isinstance(sigma, dict):
        v.fail("accelerometer.sigma", "expected a mapping of 1-sigma values")
    sb = v.vector(sigma, "bias_counts", "accelerometer.sigma", (3,), nonneg=True)
    ss = v.vector(sigma, "scale_counts_per_g", "accelerometer.sigma", (3,), nonneg=True)
    sm = v.vector(sigma, "matrix_counts_per_g", "accelerometer.sigma", (3, 3), nonneg=True)
    fit = a.get("fit")
    if not isinstance(fit, dict):
        v.fail("accelerometer.fit", "expected {steps, samples, residual_rms_g, chi2_per_dof, method}")
    fs = FitSummary(steps=int(v.number(fit, "steps", "accelerometer.fit", positive=True)),
                    samples=int(v.number(fit, "samples", "accelerometer.fit", positive=True)),
                    residual_rms_g=v.number(fit, "residual_rms_g", "accelerometer.fit", nonneg=True),
                    chi2_per_dof=float("nan") if fit.get("chi2_per_dof") is None
                    else v.number(fit, "chi2_per_dof", "accelerometer.fit", nonneg=True),
                    method=str(fit.get("method", "")))
    sigma_out = dict(sigma)
    sigma_out.update(bias_counts=sb.tolist(), scale_counts_per_g=ss.tolist(), matrix_counts_per_g=sm.tolist())
    accel = AccelCalibration(model=model, lsb_per_g=lsb, bias_counts=bias, scale_counts_per_g=scale,
                             misalignment=None if mis is None else {k: float(x) for k, x in mis.items()},
                             matrix_counts_per_g=matrix, temperature=thermal, sigma=sigma_out, fit=fs,
                             effects=list(effects))
    gyro, mag = doc.get("gyroscope"), doc.get("magnetometer")
    if gyro is not None:
        from calib.gyro import GyroCalibration
        if not isinstance(gyro, dict):
            v.fail("gyroscope", "expected a mapping or null")
        GyroCalibration.from_dict(gyro, path)  # validates; raises CalibrationFileError naming the field
    if mag is not None:
        from calib.magnetometer import MagCalibration
        if not isinstance(mag, dict):
            v.fail("magnetometer", "expected a mapping or null")
        MagCalibration.from_dict(mag, path)
    return CalibrationFile(created=str(doc["created"]), software=doc["software"], session=doc.get("session"),
                           sensor=doc["sensor"], accelerometer=accel, gyroscope=doc.get("gyroscope"),
                           magnetometer=doc.get("magnetometer"), format=FORMAT)


class _V:
    def __init__(self, path: str) -> None:
        self.path = path

    def fail(self, fld, expected):
        raise CalibrationFileError(self.path, fld, expected)

    def number(self, m, key, where, positive=False, nonneg=False):
        val = m.get(key) if isinstance(m, dict) else None
        if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val):
            self.fail(f"{where}.{key}", f"expected a finite number, got {val!r}")
        if positive and val <= 0:
            self.fail(f"{where}.{key}", f"expected a number > 0, got {val!r}")
        if nonneg and val < 0:
            self.fail(f"{where}.{key}", f"expected a number >= 0, got {val!r}")
        return float(val)

    def vector(self, m, key, where, shape, positive=False, nonneg=False):
        val = m.get(key) if isinstance(m, dict) else None
        try:
            arr = np.asarray(val, dtype=float)
        except (TypeError, ValueError):
            self.fail(f"{where}.{key}", f"expected numbers of shape {list(shape)}")
        if val is None or arr.shape != tuple(shape):
            self.fail(f"{where}.{key}", f"expected numbers of shape {list(shape)}, got {val!r}"[:200])
        if isinstance(val, list) and any(isinstance(x, bool) for x in np.asarray(val, dtype=object).ravel()):
            self.fail(f"{where}.{key}", "expected numbers, got true/false")
        if not np.all(np.isfinite(arr)):
            self.fail(f"{where}.{key}", "expected finite numbers (no NaN or infinity)")
        if positive and np.any(arr <= 0):
            self.fail(f"{where}.{key}", "expected positive numbers")
        if nonneg and np.any(arr < 0):
            self.fail(f"{where}.{key}", "expected numbers >= 0")
        return arr

"""Session -> calibration file: the one path used by ``rig run``, ``rig solve`` and ``rig replay``."""

from __future__ import annotations

from datetime import datetime, timezone
from pathlib import Path

import numpy as np

import calib
from calib import calfile
from calib.errors import CalibError, ObservabilityError
from calib.gyro import solve_gyro
from calib.magnetometer import solve_mag_ellipsoid, solve_mag_positions
from rig import __version__
from rig.session import Session, load_session, mag_step_means, rate_step_means, step_means

SOFTWARE = {"name": "rig-calibration", "version": __version__}


def solve_session(session_dir, *, model: str | None = None, method: str | None = None,
                  thermal=None, out=None, session=None):
    """Solve a recorded session and write its calibration file.

    Parameters
    ----------
    session_dir : path of a ``rig-session/1`` directory.
    model, method, thermal : override the procedure's ``solve:`` settings
        (defaults: triangular, pinv, auto).
    out : path of the calibration file (default ``SESSION/calibration.yaml``).

    Returns
    -------
    (calib.CalibrationFile, pathlib.Path)
    """
    session = session or load_session(session_dir)
    spec = session.solve_spec or {}
    model = model or spec.get("model") or "triangular"
    method = method or spec.get("method") or "pinv"
    thermal = thermal if thermal is not None else spec.get("thermal", "auto")
    if method == "magnitude":
        steps = step_means(session, session.static_step_indices(unknown_pose=True))
    else:
        steps = step_means(session)
    accel = calib.solve(steps, model=model, method=method, thermal=thermal)
    check_plausible(accel, steps.lsb_per_g)
    gyro, mag = solve_gyro_and_mag(session, spec, accel)
    cal = calib.CalibrationFile(
        created=datetime.now(timezone.utc).isoformat(timespec="seconds"),
        software=dict(SOFTWARE),
        session=session.id,
        sensor=sensor_section(session),
        accelerometer=accel,
        gyroscope=gyro,
        magnetometer=mag,
    )
    path = Path(out) if out is not None else Path(session_dir) / "calibration.yaml"
    calfile.write(path, cal)
    return cal, path


#: a fitted scale further than this factor from the sensor's nominal counts/g is not this sensor's data
SCALE_FACTOR_LIMIT = 1.5


def check_plausible(accel, lsb_per_g: float) -> None:
    """Refuse a calibration whose scale factors are far from the declared sensor's nominal sensitivity:
    the data are not this accelerometer's (a gyroscope file imported as accelerometer data, another
    range), and the numbers would be wrong however well they fit."""
    ratio = np.asarray(accel.scale_counts_per_g, float) / float(lsb_per_g)
    bad = ~((ratio > 1 / SCALE_FACTOR_LIMIT) & (ratio < SCALE_FACTOR_LIMIT))
    if bad.any():
        j = int(np.argmax(bad))
        raise CalibError(f"the fitted {'xyz'[j]} scale of {accel.scale_counts_per_g[j]:.4g} counts/g is "
                         f"{ratio[j]:.3g} times the sensor's nominal {lsb_per_g:g} counts/g: these are not this "
                         "accelerometer's data at this range (wrong file, wrong column, or another sensor)")


def sensor_section(session: Session) -> dict:
    """The calibration file's ``sensor`` section: which sensor the session recorded."""
    sensor = session.info.rig.sensor
    return {"model": sensor.model, "address": sensor.address, "serial": sensor.serial}


def solve_gyro_and_mag(session: Session, spec: dict, accel=None) -> tuple[dict | None, dict | None]:
    """The gyroscope (rate steps) and magnetometer sections, when the session has their data."""
    gyro = mag = None
    if any(s.kind == "rate" for s in session.info.steps):
        gyro = solve_gyro(rate_step_means(session, accel)).to_dict()
    mag_steps = mag_step_means(session)
    if mag_steps is not None:
        method = spec.get("magnetometer") or ("positions" if mag_steps.field_nominal_ut is not None else "ellipsoid")
        if method == "positions":
            if mag_steps.field_nominal_ut is None:
                raise ObservabilityError("the magnetometer position method needs the local field: add a site: "
                                         "section to the rig file, or use solve: {magnetometer: ellipsoid}")
            mag = solve_mag_positions(mag_steps).to_dict()
        else:
            site = session.info.rig.site
            mag = solve_mag_ellipsoid(mag_steps, float(site.field_ut if site is not None else 1.0)).to_dict()
    return gyro, mag

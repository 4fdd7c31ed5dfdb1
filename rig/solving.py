"""Session -> calibration file: the one path used by ``rig run``, ``rig solve`` and ``rig replay``."""

from __future__ import annotations

from datetime import datetime, timezone
from pathlib import Path

import calib
from calib import calfile
from rig import __version__
from rig.session import load_session

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
    steps = session.step_means()
    accel = calib.solve(steps, model=model, method=method, thermal=thermal)
    sensor = session.manifest["rig"]["sensor"]
    cal = calib.CalibrationFile(
        created=datetime.now(timezone.utc).isoformat(timespec="seconds"),
        software=dict(SOFTWARE),
        session=session.id,
        sensor={"model": sensor.get("model"), "address": sensor.get("address"),
                "serial": sensor.get("serial")},
        accelerometer=accel,
    )
    path = Path(out) if out is not None else Path(session_dir) / "calibration.yaml"
    calfile.write(path, cal)
    return cal, path

"""The procedure's ``accept:`` limits applied to a solved session (docs/procedures.md).

:func:`judge` is the one call made after every solve (``rig run``, ``solve``, ``replay``): it reads
the limits from the procedure recorded in the session, computes the figures that need more than the
calibration (the largest roll/pitch error over the session's poses, the drift since the sensor's
previous calibration in the history), applies :func:`calib.acceptance.evaluate` and writes the
verdict into the calibration file (``acceptance:``). Sessions whose procedure has no limits are
left as they are.
"""

from __future__ import annotations

import math

import numpy as np

from calib.file import calibration as calfile
from calib.acceptance import Acceptance, Drift, evaluate, largest_drift
from calib.evaluation import evaluate as evaluate_poses
from calib.file.parameters import at_common_temperature
from rig.config.procedure_schema import AcceptSpec
from rig.config.schema import validate_plain
from rig.lab.drift import sensor_history
from rig.lab.history import HistoryError, calibration_row, open_history
from rig.session import load_session
from rig.session.manifest import SessionManifest


def recorded_limits(session_dir) -> AcceptSpec | None:
    """The ``accept:`` section of the procedure recorded in the session, validated, or None."""
    info, _raw = SessionManifest.load(session_dir)
    spec = info.procedure.section("accept")
    if spec is None:
        return None
    return validate_plain(AcceptSpec, spec, "session.yaml: procedure.text: accept")


def judge(session_dir, calibration_path, *, history=None, session=None) -> Acceptance | None:
    """Apply the session's acceptance limits to its calibration file and record the verdict in it.

    Parameters
    ----------
    session_dir : the solved session.
    calibration_path : its ``rig-calibration/1`` file (rewritten atomically with ``acceptance:``).
    history : history database for ``max_drift_sigma`` (default: ``$RIG_HISTORY`` or the user's).
    session : the session already loaded by the caller (loaded here when None).

    Returns
    -------
    :class:`calib.acceptance.Acceptance`, or None when the procedure has no ``accept:`` limits.
    """
    spec = recorded_limits(session_dir)
    if spec is None:
        return None
    limits = spec.limits()
    cal = calfile.read(calibration_path)
    attitude = (largest_attitude_error_deg(session_dir, cal, session=session)
                if limits.max_attitude_error_deg is not None else None)
    previous = previous_calibration(session_dir, calibration_path, history) if limits.max_drift_sigma else None
    acceptance = evaluate(cal, limits, attitude_error_deg=attitude, drift=previous)
    calfile.write(calibration_path, cal.model_copy(update={"acceptance": acceptance.to_dict()}))
    return acceptance


def largest_attitude_error_deg(session_dir, cal, *, session=None) -> float | None:
    """The largest |roll| or |pitch| error (deg) of the calibration over the session's static poses."""
    steps = (session or load_session(session_dir)).step_means()
    if len(steps) == 0:
        return None
    ev = evaluate_poses(cal.accelerometer, steps)
    worst = np.nanmax([ev.max_abs("roll_error_deg"), ev.max_abs("pitch_error_deg")])
    return float(worst) if math.isfinite(worst) else None


def previous_calibration(session_dir, calibration_path, history=None) -> Drift | None:
    """How far this calibration moved from the sensor's latest one in the history (None: unreadable)."""
    try:
        row = calibration_row(session_dir, calibration_path)
        with open_history(history) as h:
            records = sensor_history(h, row["sensor"]["key"])
    except HistoryError:
        return None
    if not records:
        return Drift(None)
    last = records[-1]
    current = {name: (v, s, u) for name, v, s, u in row["parameters"]}
    previous, current, _ = at_common_temperature(last.parameters, last.info.get("temp_mean_c"), current,
                                                 row["calibration"]["temp_mean_c"])
    return largest_drift([(n, *vsu) for n, vsu in current.items()], previous, str(last.info.get("calibrated_at")))


def as_lines(acceptance: Acceptance) -> list[str]:
    """``PASS (n limits)`` or ``FAIL: k of n limits`` followed by one line per failed limit."""
    n = len(acceptance.checks)
    if acceptance.passed:
        return [f"acceptance: PASS ({n} limit{'s' if n != 1 else ''} met)"]
    failed = acceptance.failed()
    return [f"acceptance: FAIL ({len(failed)} of {n} limits)"] + [f"  FAIL {c.line}" for c in failed]


__all__ = ["as_lines", "judge", "largest_attitude_error_deg", "previous_calibration", "recorded_limits"]

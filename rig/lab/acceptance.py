"""The procedure's ``accept:`` limits applied to a solved session (docs/procedures.md).

:func:`judge` is the step of the pipeline tail (:func:`rig.workflow.conclude.conclude`, after every
solve: ``rig run``, ``solve``, ``replay``, ``run_procedure``) that takes the limits from the procedure
recorded in the session, computes the figures that need more than the calibration (the largest
roll/pitch error over the session's poses, the drift since the sensor's previous calibration in the
history) and applies :func:`calib.acceptance.evaluate`, in memory; the verdict goes into the
calibration file (``acceptance:``) when it is written, once. Sessions whose procedure has no limits
get no verdict.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from calib.acceptance import Acceptance, Drift, evaluate, largest_drift
from calib.evaluation import evaluate as evaluate_poses
from calib.file.parameters import at_common_temperature
from rig.lab.drift import fit_label, like_previous, sensor_history
from rig.lab.history import HistoryError, calibration_row, open_history
from rig.lab.units import shown_scale
from rig.session import Session

if TYPE_CHECKING:  # type hints only: the procedure's models load when a procedure is validated
    from rig.config.procedure_model import AcceptSpec


def recorded_limits(session: Session) -> "AcceptSpec | None":
    """The ``accept:`` section of the procedure recorded in the session (validated with it), or None."""
    return session.procedure_asks("accept")


def judge(session: Session, cal, *, calibration_path=None, history=None) -> Acceptance | None:
    """The session's acceptance limits applied to its calibration, in memory (nothing is read again or
    written: :func:`rig.workflow.conclude.conclude` writes the file once, verdict included).

    Parameters
    ----------
    session : the solved session (loaded).
    cal : its calibration (:class:`calib.CalibrationFile`).
    calibration_path : where the calibration is (or will be) written: what the history row names.
    history : history database for ``max_drift_sigma`` (default: ``$RIG_HISTORY`` or the user's).

    Returns
    -------
    :class:`calib.acceptance.Acceptance`, or None when the procedure has no ``accept:`` limits.
    """
    spec = recorded_limits(session)
    if spec is None:
        return None
    limits = spec.limits()
    attitude = largest_attitude_error_deg(session, cal) if limits.max_attitude_error_deg is not None else None
    previous = previous_calibration(session, cal, calibration_path, history) if limits.max_drift_sigma else None
    return evaluate(cal, limits, attitude_error_deg=attitude, drift=previous, shown=shown_scale)  # mrad, as printed


def largest_attitude_error_deg(session: Session, cal) -> float | None:
    """The largest |roll| or |pitch| error (deg) of the calibration over the session's static poses."""
    steps = session.step_means()
    if len(steps) == 0:
        return None
    ev = evaluate_poses(cal.accelerometer, steps)
    worst = np.nanmax([ev.max_abs("roll_error_deg"), ev.max_abs("pitch_error_deg")])
    return float(worst) if math.isfinite(worst) else None


def previous_calibration(session: Session, cal, calibration_path=None, history=None) -> Drift | None:
    """How far this calibration moved from the sensor's latest one of another session in the history, fitted the
    same way when that session has one (:func:`rig.lab.drift.like_previous`: a re-solve of this session is the same
    data, not drift); None: the history is unreadable."""
    try:
        row = calibration_row(session.path, calibration_path or session.path / "calibration.yaml",
                              manifest=session.info.to_dict(), calibration=cal)
        with open_history(history) as h:
            records = sensor_history(h, row["sensor"]["key"])
    except HistoryError:
        return None
    c = row["calibration"]
    j = like_previous(records, c["session_id"], fit_label(c))  # a re-solve of this session is the same data
    if j is None:
        return Drift(None)
    last = records[j]
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

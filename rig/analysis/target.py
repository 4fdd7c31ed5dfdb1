"""The calibration file's ``target`` section: whether a solved session met the accuracy target its
procedure set (``target:``, docs/procedures.md), predicted from the session itself."""

from __future__ import annotations

import numpy as np

from calib.accel.predict import Predictor, target_record
from calib.errors import CalibError


def calibration_record(session, steps, model: str | None = None, method: str | None = None) -> dict | None:
    """The calibration file's ``target`` section for a solved session, or None when its recorded
    procedure has no target (or the session has no recorded procedure: an import).

    ``session`` a loaded session (``rig.session.load_session``), ``steps`` the StepMeans the solve
    used, ``model`` and ``method`` what it solved with (default the procedure's; the prediction is
    that of the pinv solve: another method's record says it was not evaluated). The prediction is made from the
    steps' own standard errors and the chip's bias stability, as the solver's sigmas are, so it is
    the calibration's whether the session was run, resumed, replayed or re-solved.
    """
    spec = session.procedure_asks("target")
    if spec is None:
        return None
    procedure = session.procedure
    model = model or (procedure.solve.model if procedure.solve is not None else "triangular")
    ends = [s.stats.t_end_s for s in session.info.steps if s.stats is not None and s.stats.t_end_s is not None]
    rig_time = max(ends) if ends else None
    method = method or (procedure.solve.method if procedure.solve is not None else "pinv")
    try:
        if method != "pinv" or not np.all(np.isfinite(steps.f_nominal_g)):
            raise CalibError(f"the target is predicted for the pinv solve of known poses, not method {method}")
        goal = spec.goal(model)
    except CalibError as exc:  # re-solved another way, or with the full model, which has no misalignment angles
        return {"met": False, "attitude_error_deg": spec.attitude_error_deg, "confidence": spec.confidence,
                "poses": spec.poses_record(), "predicted_attitude_error_deg": None, "sigma": [],
                "max_seconds": float(spec.max_seconds), "rig_time_s": rig_time,
                "summary": f"not evaluated: {exc}"}
    predictor = Predictor(goal, float(steps.lsb_per_g), steps.bias_stability_counts(), stability=steps.bias_stability)
    if steps.duration_s is not None:  # the solver's own covariance: GLS with the wander between the steps
        predictor.timeline = (steps.t_s, steps.duration_s)
    prediction = predictor.predict(steps.f_nominal_g, steps.sem_counts)
    return target_record(goal, prediction, poses=spec.poses_record(), max_seconds=spec.max_seconds,
                         rig_time_s=rig_time)

"""What part of its plan a session recorded: the calibration file's ``coverage`` section."""

from __future__ import annotations

from rig.session import Session

#: step statuses that mean the step was captured (flagged steps were recorded, then left out of the solve)
RECORDED = ("complete", "flagged")


def session_coverage(session: Session) -> dict | None:
    """``{complete, status, steps_planned, steps_recorded, pending_steps}`` when steps of the session's
    plan were never recorded (an interrupted run solved as it is), else None (nothing to record)."""
    steps = session.info.steps
    pending = [f"{s.index + 1} ({s.name})" for s in steps if s.status == "pending"]
    if not pending:
        return None
    return {"complete": False, "status": str(session.info.status), "steps_planned": len(steps),
            "steps_recorded": sum(s.status in RECORDED for s in steps), "pending_steps": pending}

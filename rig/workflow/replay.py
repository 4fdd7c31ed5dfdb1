"""``rig replay``: re-run a recorded session's procedure on the replay rig into a new session."""

from __future__ import annotations

from datetime import datetime, timezone
from pathlib import Path

from calib.errors import CalibError
from rig.devices import open_rig
from rig.errors import RigInputError
from rig.execution.operator import Operator, SilentOperator
from rig.session import load_session
from rig.workflow import kinds  # noqa: F401 - registers the "replay" rig kind (the simulator loads when it opens)
from rig.workflow.batch import steps_in_frame
from rig.workflow.lifecycle import NewSession, RunResult, execute, finish, start_session


def replay_session(session_dir, *, out_dir=None, ui: Operator | None = None, history=None) -> RunResult:
    """Replay a session into a new session directory (beside the original by default) and take it through
    the pipeline tail (:func:`rig.workflow.conclude.conclude`; ``history``: the history database)."""
    original = load_session(session_dir)
    recorded = original.info.procedure
    if not recorded.text or original.info.rig.turntable is None:
        raise RigInputError(str(session_dir), None, "procedure", "the session has no recorded procedure to replay "
                            "(an imported recording: solve or discover it instead)")
    procedure = original.procedure
    rig = open_rig("replay", original)
    try:
        stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ")
        new = NewSession(Path(out_dir) if out_dir is not None else Path(session_dir).resolve().parent,
                         f"{original.id}-replay-{stamp}", recorded.text, recorded.file,
                         extra={"replay_of": original.id, "seed": original.info.seed})
        # a fixture slot's session: its steps as the slot saw them, through its recorded mounting (docs/fixture.md)
        fixture = (original.info.rig.sensor.model_extra or {}).get("fixture")
        rotation = fixture.get("rotation_matrix") if isinstance(fixture, dict) else None
        writer = start_session(procedure, rig, new, steps=None if rotation is None else steps_in_frame(procedure, rotation),
                               sensor_info=None if rotation is None else {"fixture": fixture})
        # recorded sample times are session times: the session clock starts at 0 now
        outcomes = execute(procedure, rig, writer, ui or SilentOperator(answer=True),
                           time_offset_s=rig.clock.now())
    finally:
        rig.close()
    try:
        return finish(procedure, writer, outcomes, history=history)
    except CalibError as exc:  # a solve refusal names no file: say which session's replay it was
        raise CalibError(f"{session_dir}: the replay ({writer.session_dir}) cannot be solved: {exc}") from None

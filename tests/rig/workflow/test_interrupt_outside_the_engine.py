"""A Ctrl-C outside the engine's step loop (while the session is being created, while homing, while the
pipeline tail solves) still leaves an aborted, resumable session and says where it is (issue 34)."""

from __future__ import annotations

import pytest

from rig.execution.context import RunAborted
from rig.session import SessionManifest
from rig.workflow import lifecycle
from rig.workflow.run import run_procedure

from conftest import PROCEDURES


def test_a_ctrl_c_while_the_tail_solves_aborts_the_session_and_a_resume_finishes_it(tmp_path, monkeypatch):
    def interrupt(*args, **kwargs):  # the operator presses Ctrl-C while the calibration is computed
        raise KeyboardInterrupt

    monkeypatch.setattr(lifecycle, "conclude", interrupt)
    with pytest.raises(RunAborted) as exc:
        run_procedure(str(PROCEDURES / "six_position.yaml"), seed=2, time_scale=0, out_dir=tmp_path,
                      history=tmp_path / "h.sqlite")
    session = exc.value.session_dir
    info, _ = SessionManifest.load(session)
    assert info.status == "aborted" and all(s.status == "complete" for s in info.steps)
    monkeypatch.undo()
    result = run_procedure(None, resume_dir=session, time_scale=0, history=tmp_path / "h.sqlite")
    assert result.status == "complete" and result.conclusion.calibration_path.is_file()
    assert SessionManifest.load(session)[0].status == "complete"

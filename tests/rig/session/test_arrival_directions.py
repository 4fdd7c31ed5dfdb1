"""The direction each stage arrived in at each pose, from a session's recorded stage positions (issue 29: the
budget's lost motion with its recorded signs, tests/calib/test_lost_motion_arrival.py).

The samples' ``a1_deg``.. columns are the controllers' counts, not mod 360, so the sign of a move between two
captures is the direction the stage turned in; before a stage's first recorded move, and after a resume (where the
stages stood meanwhile is not recorded), it is unknown (0).
"""

from __future__ import annotations

import numpy as np

from rig.session import SessionWriter, load_session
from rig.session.adapter import arrival_directions, step_means, with_arrival

from written_sessions import faces_manifest

FACES = [[0, 0, 1], [1, 0, 0], [0, 0, -1], [-1, 0, 0], [0, 1, 0], [0, -1, 0]]
#: the stage positions of the six captures, as the planner moves the table (a1 at 0; a3 turned on past -180)
POSITIONS = [[0, 0, 0], [0, 0, -90], [0, 0, -180], [0, 0, -270], [0, 90, -360], [0, -90, -360]]


def _session(tmp_path, positions=POSITIONS, resume_at: int | None = None, record_positions: bool = True):
    writer = SessionWriter.create(tmp_path, "s", faces_manifest(FACES, {"name": "six", "file": "six.yaml", "text": ""}))
    rng = np.random.default_rng(0)
    for i, (f, at) in enumerate(zip(FACES, positions)):
        if resume_at == i:
            writer.event("resume", t_s=i * 10.0, first_step=i)
        counts = np.round(np.array(f) * 8192 + rng.normal(0, 20, (50, 3))).astype(int)
        writer.append_samples(i, i * 10 + np.arange(50) * 0.01, counts, temp_c=np.full(50, 25.0),
                              angles_deg=np.tile(np.asarray(at, float), (50, 1)) if record_positions else None)
        writer.complete_step(i, {"n_samples": 50})
    writer.set_status("complete")
    return load_session(tmp_path / "s")


def test_each_stage_arrives_in_the_direction_of_its_last_move_and_unknown_before_its_first(tmp_path):
    d = arrival_directions(_session(tmp_path), list(range(6)))
    assert d.tolist() == [[0, 0, 0], [0, 0, -1], [0, 0, -1], [0, 0, -1], [0, 1, -1], [0, -1, -1]]


def test_the_budgets_steps_carry_them_for_the_steps_they_use(tmp_path):
    session = _session(tmp_path)
    assert step_means(session, [5, 1, 4]).arrival_direction is None  # read only when a budget needs them
    steps = with_arrival(session, step_means(session, [5, 1, 4]), [5, 1, 4])
    assert steps.arrival_direction.tolist() == [[0, -1, -1], [0, 0, -1], [0, 1, -1]]


def test_a_resume_forgets_where_the_stages_came_from(tmp_path):
    d = arrival_directions(_session(tmp_path, resume_at=4), list(range(6)))
    assert d[4].tolist() == [0, 0, 0]  # the first capture after the resume: unknown
    assert d[5].tolist() == [0, -1, 0]  # a2 moved again since; a3 did not


def test_a_session_without_stage_positions_has_none(tmp_path):
    assert arrival_directions(_session(tmp_path, record_positions=False), list(range(6))) is None
    session = load_session(tmp_path / "s")
    assert with_arrival(session, step_means(session), list(range(6))).arrival_direction is None

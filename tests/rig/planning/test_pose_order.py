"""Pose order: `order: shortest` (greedy) and `order: fastest` (least total travel) reorder only the
pose steps between temperature and prompt steps, which stay where the procedure put them."""

from dataclasses import dataclass

import numpy as np

from rig.planning.poses import pose_angles_deg
from rig.planning.targets import _angular_distance, reorder_fastest, reorder_for_travel

SEED_FACES = ["+Z up", "+X up", "-Z up", "-X up", "+Y up", "-Y up"]


@dataclass(frozen=True)
class Step:
    name: str
    kind: str
    angles_deg: tuple = (0.0, 0.0, 0.0)


def faces():
    return [Step(n, "static", tuple(pose_angles_deg(n))) for n in SEED_FACES]


def travel_deg(steps) -> float:
    pos, total = np.zeros(3), 0.0
    for s in steps:
        if s.kind == "static":
            total += _angular_distance(pos, s.angles_deg)
            pos = np.asarray(s.angles_deg)
    return total


def test_the_fastest_order_of_the_six_faces_needs_only_quarter_turns():
    order = reorder_fastest(faces())
    assert sorted(s.name for s in order) == sorted(SEED_FACES)
    assert travel_deg(order) <= 450.0 + 1e-9 < travel_deg(faces())


def test_the_greedy_order_never_travels_further_than_the_written_one():
    assert travel_deg(reorder_for_travel(faces())) <= travel_deg(faces())


def test_temperature_steps_bound_the_segments_and_stay_in_place():
    steps = faces()[:3] + [Step("heat", "thermal")] + faces()[3:]
    for reorder in (reorder_for_travel, reorder_fastest):
        out = reorder(steps)
        assert out[3].name == "heat"
        assert {s.name for s in out[:3]} == set(SEED_FACES[:3])
        assert {s.name for s in out[4:]} == set(SEED_FACES[3:])

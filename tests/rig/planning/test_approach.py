"""Every pose approached from the same direction (issue 29 item 2): an axis with ``approach: positive`` (or
``negative``) reaches every target moving that way, a planned overshoot first when the direct move would
arrive the other way; so a pose's lost motion is the same whichever pose came before."""

from __future__ import annotations

import json

import pytest

from rig.cli import main
from rig.planning.approach import pre_target

from conftest import PROCEDURES


@pytest.mark.parametrize("current, target, approach, expected", [
    (0.0, -90.0, "positive", -90.5),   # would arrive moving down: go past, come back up
    (-90.0, 0.0, "positive", None),    # arrives moving up already
    (0.0, 90.0, "negative", 90.5),
    (0.0, 0.0, "positive", None),      # no move, nothing to approach
    (0.0, -90.0, "none", None),
    (0.0, -399.8, "positive", None),   # the overshoot would leave the soft limits: reached directly
])
def test_the_planned_overshoot_goes_past_the_target_on_the_side_it_is_approached_from(current, target, approach,
                                                                                       expected):
    assert pre_target(current, target, approach, 0.5, (-400.0, 400.0)) == expected


RIG = """format: rig-file/1
kind: sim
turntable:
  axes:
    a1: {approach: %(a)s, slip_ring: true}
    a2: {approach: %(a)s, slip_ring: true}
    a3: {approach: %(a)s, slip_ring: true}
sensor: {model: MPU-9150}
sim: {time_scale: 0, geometry: {enabled: true}}
"""


def _final_moves(tmp_path, approach: str) -> list[dict]:
    rig = tmp_path / f"rig-{approach}.yaml"
    rig.write_text(RIG % {"a": approach})
    out = tmp_path / approach
    assert main(["run", str(PROCEDURES / "six_position.yaml"), "--rig", str(rig), "--out", str(out),
                 "--seed", "3", "--quiet"]) == 0
    (session,) = out.iterdir()
    moves = [e for e in map(json.loads, (session / "events.jsonl").read_text().splitlines()) if e["kind"] == "move"]
    last = {}
    for m in moves:  # the last move of each axis in each step is the one that arrives
        last[(m["step"], m["axis"])] = m
    return list(last.values())


def test_a_six_position_run_with_approach_positive_arrives_at_every_pose_moving_up(tmp_path):
    direct = _final_moves(tmp_path, "none")
    assert any(m["to_deg"] < m["from_deg"] for m in direct)  # without it some poses are reached moving down
    arrivals = _final_moves(tmp_path, "positive")
    assert arrivals and all(m["to_deg"] > m["from_deg"] for m in arrivals)

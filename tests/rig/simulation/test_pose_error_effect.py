"""The ``pose_error`` effect of the simulated world (``sim: effects: {pose_error: DEG}``): every pose is placed
off its nominal one, repeatably, as a hand placement is; the discovery library's candidate of the same name
(calib.discovery.effects) finds such sessions among recordings without turntable angles."""

from __future__ import annotations

import numpy as np

from rig.planning.poses import pose_angles_deg
from rig.simulation.settings import SimSettings
from rig.simulation.simrig import SimulatedRig


def _specific_force(rig: SimulatedRig, angles_deg) -> np.ndarray:
    world = rig.world
    deg = np.atleast_2d(np.asarray(angles_deg, float))
    links = world.axes
    world.axes = [type(ax)(lambda t, v=v: np.full(np.shape(t), v), lambda t: np.zeros(np.shape(t)), 1.0, 0.0)
                  for ax, v in zip(links, deg[0])]
    try:
        return world(np.array([0.0])).specific_force_g[0]
    finally:
        world.axes = links


def _angle_deg(a, b) -> float:
    return float(np.degrees(np.arccos(np.clip(np.dot(a, b) / np.linalg.norm(a) / np.linalg.norm(b), -1, 1))))


def test_each_pose_is_placed_off_nominal_by_up_to_the_effect_and_the_same_way_each_visit():
    plain = SimulatedRig(SimSettings(time_scale=0), seed=3)
    placed = SimulatedRig(SimSettings(time_scale=0, effects={"pose_error": 3.0}), seed=3)
    offsets = []
    for name in ("+X up", "-X up", "+Y up", "-Y up", "+Z up", "-Z up"):
        angles = pose_angles_deg(name)
        a, b = _specific_force(plain, angles), _specific_force(placed, angles)
        offsets.append(_angle_deg(a, b))
        assert np.allclose(b, _specific_force(placed, angles))  # the same placement on every visit
        assert abs(np.linalg.norm(b) - np.linalg.norm(a)) < 1e-12  # a rotation: gravity's magnitude kept
    assert max(offsets) <= 3.0 * np.sqrt(2) + 1e-9 and max(offsets) > 0.5 and len(set(np.round(offsets, 6))) > 3


def test_without_the_effect_the_world_is_unchanged():
    a = SimulatedRig(SimSettings(time_scale=0), seed=3)
    b = SimulatedRig(SimSettings(time_scale=0, effects={"pose_error": 0.0}), seed=3)
    for name in ("+X up", "+Y up", "-Z up"):
        assert np.array_equal(_specific_force(a, pose_angles_deg(name)), _specific_force(b, pose_angles_deg(name)))

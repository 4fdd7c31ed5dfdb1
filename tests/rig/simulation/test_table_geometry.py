"""The simulated turntable as imperfect as hardware (issue 29 item 1): its own errors live in the world model
(``rig.simulation.geometry``), the emulated controllers keep the protocol, ``sim.geometry`` switches them on
(off by default), and ``sim_truth.yaml`` records every hidden value."""

from __future__ import annotations

import numpy as np
import pytest

from drivers.clock import VirtualClock
from drivers.ximc import protocol as P
from drivers.ximc.sim.controller import Controller
from rig.config.rigfile import parse_rig_file
from rig.errors import RigInputError
from rig.planning.kinematics import f_nominal
from rig.simulation.geometry import G0_M_S2, StageErrors, TableGeometry
from rig.simulation.settings import SimSettings
from rig.simulation.simrig import SimulatedRig
from rig.simulation.world import AxisLink, SimChamber, WorldModel

POSES_DEG = np.array([[0, 0, 0], [0, 0, -90], [0, 90, 0], [30, -40, 120], [200, 10, -170.0]])
NO_DIRECTION = np.ones((len(POSES_DEG), 3))


def f_of(geometry: TableGeometry, angles_deg, directions=None) -> np.ndarray:
    angles = np.atleast_2d(np.asarray(angles_deg, float))
    d = np.ones_like(angles) if directions is None else np.atleast_2d(np.asarray(directions, float))
    r = geometry.sensor_to_world(np.eye(3), angles, d)
    return geometry.gravity_g0() * np.transpose(r, (0, 2, 1)) @ np.array([0, 0, 1.0])


def test_a_table_without_errors_is_the_kinematics_contract():
    geometry = TableGeometry()
    assert np.allclose(f_of(geometry, POSES_DEG), f_nominal(POSES_DEG), atol=1e-14)
    rates = np.array([[1.0, 2.0, 3.0]] * len(POSES_DEG))
    w = geometry.body_rate(POSES_DEG, NO_DIRECTION, rates)
    # body rate of the nominal chain: Ry^T Rx^T e_z a1' + Ry^T e_x a2' + e_y a3'
    a = np.radians(POSES_DEG)
    expected = np.stack([
        -np.sin(a[:, 2]) * np.cos(a[:, 1]) * 1 + np.cos(a[:, 2]) * 2,
        np.sin(a[:, 1]) * 1 + 3,
        np.cos(a[:, 2]) * np.cos(a[:, 1]) * 1 + np.sin(a[:, 2]) * 2], axis=1)
    assert np.allclose(w, expected, atol=1e-12)


def test_a2_axis_tilted_towards_z_puts_its_non_orthogonality_into_x_at_y_up():
    delta = 0.05
    f = f_of(TableGeometry(non_orthogonality_deg=(delta, 0.0, 0.0)), [0, 90, 0])[0]
    d = np.radians(delta)
    assert f[0] == pytest.approx(np.sin(d) * np.cos(d), rel=1e-9)
    assert f[1] == pytest.approx(np.cos(d), rel=1e-12)


def test_mounting_and_gravity_and_zero_offsets_enter_the_specific_force():
    g = 9.81
    f = f_of(TableGeometry(gravity_m_s2=g), [0, 0, 0])[0]
    assert f == pytest.approx([0, 0, g / G0_M_S2])
    f = f_of(TableGeometry(mounting_deg=(0.0, 0.1, 0.0)), [0, 0, 0])[0]
    assert f[0] == pytest.approx(-np.sin(np.radians(0.1)), rel=1e-9)  # sensor turned about y: as a3 by +0.1 deg
    stages = (StageErrors(), StageErrors(), StageErrors(zero_offset_deg=0.1))
    assert f_of(TableGeometry(stages=stages), [0, 0, 0])[0] == pytest.approx(f)


def _controller_world(geometry: TableGeometry):
    clock = VirtualClock()
    ctrl = Controller(0x3A5C, clock=clock)
    links = [AxisLink(ctrl.position_deg_at, ctrl.speed_deg_s_at, 1.0, 0.0, ctrl.direction_at)]
    for _ in range(2):
        links.append(AxisLink(lambda t: np.zeros_like(np.asarray(t, float)), lambda t: 0.0 * np.asarray(t)))
    return clock, ctrl, WorldModel(axes=links, chamber=SimChamber(clock), geometry=geometry)


def _move_deg(clock, ctrl, deg: float) -> None:
    ctrl.receive(P.encode_request(b"move", P.Move(int(round(deg / 0.01)), 0)))
    clock.sleep(60.0)


def test_lost_motion_follows_the_direction_the_motor_last_turned_and_the_wire_does_not_see_it():
    lost = 0.04
    stages = (StageErrors(lost_motion_deg=lost), StageErrors(), StageErrors())
    clock, ctrl, world = _controller_world(TableGeometry(stages=stages, non_orthogonality_deg=(0, 0, 0)))
    a1_true = lambda: float(world.geometry.true_angles_deg(world.angles_deg_at(clock.now()),
                                                           world.directions_at(clock.now()))[0, 0])
    _move_deg(clock, ctrl, 10.0)  # approached from below
    from_below = a1_true()
    gpos_below = P.decode_answer(b"gpos", ctrl.receive(b"gpos"))
    _move_deg(clock, ctrl, 20.0)
    _move_deg(clock, ctrl, 10.0)  # approached from above
    from_above = a1_true()
    assert from_below == pytest.approx(10.0 - lost / 2, abs=1e-12)
    assert from_above - from_below == pytest.approx(lost, abs=1e-12)
    assert P.decode_answer(b"gpos", ctrl.receive(b"gpos")) == gpos_below  # the controller reports the same


def test_geometry_is_on_by_default_and_off_leaves_every_other_draw_of_the_seed_alone():
    on = SimulatedRig(SimSettings.from_mapping({"time_scale": 0}), seed=5)
    off = SimulatedRig(SimSettings.from_mapping({"time_scale": 0, "geometry": {"enabled": False}}), seed=5)
    assert off.geometry is None and "geometry" not in off.truth()
    assert on.geometry is not None and "geometry" in on.truth()
    assert off.world(np.array([0.0])).specific_force_g.tolist() == [[0.0, 0.0, 1.0]]
    assert on.accel_errors.to_dict() == off.accel_errors.to_dict()
    assert not np.allclose(on.world(np.array([0.0])).specific_force_g, [[0, 0, 1.0]], atol=1e-6)


def test_sim_truth_records_every_hidden_value_and_its_class():
    on = SimulatedRig(SimSettings.from_mapping({"time_scale": 0, "geometry": {
        "enabled": True, "lost_motion_deg": 0.05, "gravity_m_s2": 9.81}}), seed=2)
    truth = on.truth()["geometry"]
    assert truth["classes"]["lost_motion_deg"] == 0.05
    assert set(truth["stages"]) == {"a1", "a2", "a3"}
    assert set(truth["stages"]["a2"]) >= {"zero_offset_deg", "periodic_deg", "accumulated_deg", "lost_motion_deg",
                                          "wobble_deg"}
    assert set(truth["non_orthogonality_deg"]) == {"a1_a2", "a2_a3", "a1_a3"}
    assert set(truth["mounting_deg"]) == {"x", "y", "z"} and truth["gravity_m_s2"] == 9.81
    assert all(0 <= s["lost_motion_deg"] <= 0.05 for s in truth["stages"].values())


RIG = """format: rig-file/1
kind: sim
turntable:
  axes: {a1: {}, a2: {}, a3: {}}
sensor: {model: MPU-9150}
sim:
  geometry:
    enabled: true
    lost_motion_deg: %s
"""


def test_rig_file_geometry_keys_are_validated_with_their_line():
    rig = parse_rig_file(RIG % "0.03", "r.yaml")
    settings = SimSettings.from_mapping(rig.sim)
    assert settings.geometry.lost_motion_deg == 0.03 and settings.geometry.mounting_deg == 0.1
    with pytest.raises(RigInputError) as exc:
        parse_rig_file(RIG % "-1", "r.yaml")
    assert "r.yaml:9" in str(exc.value) and "lost_motion_deg" in str(exc.value)

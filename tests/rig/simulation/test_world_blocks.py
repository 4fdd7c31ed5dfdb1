"""The world model gives every sample what it would give it alone: a block of samples at rest is computed once
(the same attitude for all), a block through a move sample by sample, and samples nobody sees (a chip only counts
them) still carry the ringing's memory of the last motion (issue 26: the simulator's per-read cost)."""

from __future__ import annotations

import numpy as np
import pytest

from drivers.sensors.sim.physics import StaticPhysics, advance, temperature_at
from rig.simulation.geometry import StageErrors, TableGeometry
from rig.simulation.world import AxisLink, RingingConfig, SimChamber, WorldModel
from drivers.clock import VirtualClock


def _axis(start_s: float, stop_s: float, from_deg: float, to_deg: float) -> AxisLink:
    """One stage at ``from_deg`` until ``start_s``, turning at constant speed to ``to_deg`` at ``stop_s``."""
    speed = (to_deg - from_deg) / (stop_s - start_s)

    def position(t):
        return np.clip(from_deg + speed * (np.asarray(t) - start_s), min(from_deg, to_deg), max(from_deg, to_deg))

    def rate(t):
        t = np.asarray(t)
        return np.where((t > start_s) & (t < stop_s), speed, 0.0)
    return AxisLink(position, rate)


def _world(geometry=None, ringing=RingingConfig()) -> WorldModel:
    axes = [_axis(1.0, 2.0, 0.0, 30.0), _axis(1.0, 2.0, 10.0, 100.0), _axis(1.5, 2.5, -20.0, 45.0)]
    return WorldModel(axes, SimChamber(VirtualClock()), table_tilt_deg=(0.02, -0.01), geometry=geometry,
                      ringing=ringing)


def _one_by_one(world: WorldModel, t: np.ndarray):
    parts = [world(np.array([x])) for x in t]
    return {k: np.concatenate([getattr(p, k) for p in parts]) for k in
            ("specific_force_g", "angular_rate_dps", "magnetic_field_ut", "temp_c")}


@pytest.mark.parametrize("geometry", [None, TableGeometry(stages=(StageErrors(), StageErrors(zero_offset_deg=0.05),
                                                                  StageErrors()), non_orthogonality_deg=(0.01, 0, 0))])
@pytest.mark.parametrize("block", [(0.0, 0.9), (0.5, 1.4), (2.6, 3.0), (1.2, 2.8)], ids=["rest", "start", "after",
                                                                                       "move"])
def test_a_block_gives_each_sample_what_it_gives_the_sample_alone(geometry, block):
    t = np.linspace(*block, 40)
    ringing = RingingConfig(amplitude_g=0.0)  # the ringing remembers the previous call: compared below
    whole, alone = _world(geometry, ringing)(t), _one_by_one(_world(geometry, ringing), t)
    for key, value in alone.items():
        np.testing.assert_allclose(getattr(whole, key), value, rtol=0, atol=1e-15, err_msg=key)


def test_samples_nobody_sees_still_set_the_ringing_after_the_move():
    seen, skimmed = _world(), _world()
    moving = np.arange(0.0, 2.6, 0.05)  # the move, seen sample by sample in one world, only counted in the other
    seen(moving)
    temp_c = advance(skimmed, moving)
    np.testing.assert_array_equal(temp_c, seen.chamber.temp_at(moving))
    after = np.linspace(2.6, 3.0, 20)  # the table rests and rings
    a, b = seen(after).specific_force_g, skimmed(after).specific_force_g
    np.testing.assert_array_equal(a, b)
    assert np.abs(a - a.mean(axis=0)).max() > 1e-4  # there is ringing to compare


def test_a_source_without_a_temperature_of_its_own_gives_its_batch_temperature():
    class Plain:  # only a PhysicsSource: callable on times
        def __call__(self, t):
            return StaticPhysics(temp_c=31.5)(t)
    t = np.array([0.0, 1.0, 2.0])
    assert list(temperature_at(Plain(), t)) == [31.5] * 3 == list(advance(Plain(), t))
    assert list(temperature_at(StaticPhysics(temp_c=31.5), t)) == [31.5] * 3


def _controllers_world(rest_shortcut: bool):
    """Three emulated controllers (their real motion profiles) under a table with its own errors; the links
    give the stages' word of rest (``rest_pose``) and their state from one evaluation (``state_at``), or
    neither."""
    from drivers.ximc.sim.controller import Controller
    clock = VirtualClock()
    ctrls = [Controller(0x3A5C + i, clock=clock) for i in range(3)]
    links = [AxisLink(c.position_deg_at, c.speed_deg_s_at, sign, home, c.direction_at,
                      c.rest_pose if rest_shortcut else None, c.state_at if rest_shortcut else None)
             for c, sign, home in zip(ctrls, (1.0, -1.0, 1.0), (0.0, 2.5, -1.0))]
    geometry = TableGeometry(stages=(StageErrors(lost_motion_deg=0.03), StageErrors(zero_offset_deg=0.05),
                                     StageErrors(wobble_deg=0.01)), non_orthogonality_deg=(0.01, 0.02, 0.0))
    return clock, ctrls, WorldModel(links, SimChamber(clock), table_tilt_deg=(0.02, -0.01), geometry=geometry)


def test_stages_that_say_they_rest_or_give_their_state_at_once_give_every_sample_what_evaluating_their_motion_gives():
    from drivers.ximc import protocol as P
    worlds = [_controllers_world(shortcut) for shortcut in (True, False)]
    out = {True: [], False: []}
    rest_blocks = 0
    for (clock, ctrls, world), shortcut in zip(worlds, (True, False)):
        t0 = 0.0
        for target_deg in (10.0, 25.0, 10.0, 10.0, -5.0, 10.0):  # a pose from above, then below: lost motion differs
            for i, c in enumerate(ctrls):
                c.receive(P.encode_request(b"move", P.Move(int(round((target_deg + 3 * i) / 0.01)), 0)))
            for _ in range(60):  # reads every 0.25 s through the move and the rest after it
                clock.sleep(0.25)
                t = np.arange(t0, clock.now(), 0.01)
                t0 = t[-1] + 0.01
                out[shortcut].append(world(t))
                rest_blocks += shortcut and world._resting_key(float(t[0])) is not None
    assert rest_blocks > 100  # most blocks took the shortcut
    for a, b in zip(out[True], out[False]):
        for key in ("specific_force_g", "angular_rate_dps", "magnetic_field_ut", "temp_c"):
            np.testing.assert_array_equal(getattr(a, key), getattr(b, key), err_msg=key)

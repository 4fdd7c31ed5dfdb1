"""The fixture's slots as the engine reads them (rig.devices.fixture) on register-level models: every call to a
slot's chip connects its channel first, one channel of one multiplexer at a time; a slot feels the table's force
through its mounting rotation (rig.simulation.fixture); each slot of a seed is its own hidden sensor."""

from __future__ import annotations

import numpy as np

from drivers.clock import VirtualClock
from drivers.sensors.base import SensorSettings
from drivers.sensors.sim.bus import SimulatedI2CBus
from drivers.sensors.sim.error_model import AccelErrorModel
from drivers.sensors.sim.mpu9150 import Mpu9150Model
from drivers.sensors.sim.physics import StaticPhysics
from drivers.sensors.sim.tca9548a import Tca9548aModel
from rig.config.fixture import FixtureConfig
from rig.devices.fixture import attach_fixture
from rig.simulation.fixture import RotatedPhysics, slot_seed

CONFIG = FixtureConfig.model_validate({"slots": [
    {"bus": "b", "mux": 0x70, "channel": 2, "rotation": "x+z+", "serial": "U1"},
    {"bus": "b", "mux": 0x71, "channel": 2, "rotation": "z+x+"},
]})


def _bus(clock):
    bus = SimulatedI2CBus("b")
    muxes = {a: Tca9548aModel(clock=clock).attach(bus, a) for a in (0x70, 0x71)}
    errors = AccelErrorModel(noise_density_g_per_rthz=[0.0] * 3)
    for a, slot in ((0x70, CONFIG.slots[0]), (0x71, CONFIG.slots[1])):
        physics = RotatedPhysics(StaticPhysics((0.0, 0.0, 1.0)), slot.rotation.as_array())
        Mpu9150Model(physics, errors, clock=clock, seed=a).attach(muxes[a].channel(2), 0x68)
    return bus, muxes


def test_each_call_connects_the_slots_channel_and_disconnects_the_other_switch():
    clock = VirtualClock()
    bus, muxes = _bus(clock)
    fixture = attach_fixture(CONFIG, lambda name: bus, clock=clock)
    a, b = fixture.slots
    assert (a.serial, b.serial) == ("U1", "slot-1")
    a.sensor.identify()
    assert muxes[0x70].connected() == (2,) and muxes[0x71].connected() == ()
    b.sensor.identify()
    assert muxes[0x70].connected() == () and muxes[0x71].connected() == (2,)


def test_a_slot_feels_the_tables_force_through_its_mounting():
    clock = VirtualClock()
    bus, _ = _bus(clock)
    fixture = attach_fixture(CONFIG, lambda name: bus, clock=clock)
    means = []
    for slot in fixture.slots:
        slot.sensor.configure(SensorSettings(accel_range_g=4, sample_rate_hz=100))
        slot.sensor.start()
    clock.sleep(0.5)
    for slot in fixture.slots:
        block = slot.sensor.read()
        means.append(block.accel_counts.mean(axis=0) / slot.sensor.accel_lsb_per_g)
        assert np.allclose(slot.to_slot_frame([0.0, 0.0, 1.0]), np.round(means[-1]), atol=1e-9)
    assert np.allclose(means[0], [0, 0, 1], atol=0.01)  # x+z+: as the one-sensor rig's sensor
    assert np.allclose(means[1], [1, 0, 0], atol=0.01)  # z+x+: its +x points up


def test_each_slot_of_a_seed_is_its_own_unit_and_the_same_in_every_run():
    seeds = [slot_seed(3, i) for i in range(8)]
    assert len(set(seeds)) == 8
    assert seeds == [slot_seed(3, i) for i in range(8)]
    assert slot_seed(4, 0) != seeds[0]

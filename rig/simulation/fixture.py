"""The simulated fixture: a rig file's ``fixture:`` slots as register-level chips behind simulated TCA9548As.

Every distinct ``bus`` name of the slots is a :class:`~drivers.sensors.sim.bus.SimulatedI2CBus` of its own (not
the one-sensor rig's bus: its chip would answer with every channel); every ``mux`` address on it a
:class:`~drivers.sensors.sim.tca9548a.Tca9548aModel`; every slot an MPU-9150 or ADXL345 model on its channel (or on
the bus itself). The rig then opens them through :func:`rig.devices.fixture.attach_fixture`, the hardware code
path: the engine cannot tell a simulated fixture from a wired one.

Each slot is its own hidden sensor: its error model and noise are drawn from the rig's seed and the slot number
(:func:`slot_seed`), so slot 3 of seed 3 is the same unit in every run and a different one from slot 4. Its
world is the table's, seen through the slot's mounting rotation R (slot frame to turntable frame): the chip
feels ``R^T f`` of the specific force ``f`` the turntable frame feels (and so the body rate and the field).
``faults.slots.N`` (the fields of ``faults.sensor``) puts faults into slot N's chip. Not applied per slot: the
rig file's ``sim.errors`` / ``sim.effects`` overrides and ``sim.noise_spread`` (they describe the one ``sensor:``).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import yaml

from drivers.sensors.chips import chip_spec
from drivers.sensors.sim.adxl345 import Adxl345Model
from drivers.sensors.sim.bus import SimulatedI2CBus
from drivers.sensors.sim.error_model import AccelErrorModel, GyroErrorModel, MagErrorModel
from drivers.sensors.sim.faults import SensorFaults
from drivers.sensors.sim.mpu9150 import Mpu9150Model
from drivers.sensors.sim.physics import PhysicsBatch, SeenThrough
from drivers.sensors.sim.tca9548a import Tca9548aModel
from rig.devices.fixture import Fixture, attach_fixture
from rig.devices.rig import Rig

#: the seed's own stream for the slots' hidden sensors (no other draw of the seed changes with it)
SLOT_STREAM = 0x5107


def slot_seed(seed: int, slot: int) -> int:
    """The seed of slot ``slot``'s hidden sensor (error model, noise, self-test trim) in a rig seeded ``seed``."""
    return int(np.random.default_rng([int(seed) % 2**63, int(slot), SLOT_STREAM]).integers(2**31))


@dataclasses.dataclass
class RotatedPhysics(SeenThrough):
    """A physics source seen from a slot: every vector of ``physics`` (turntable frame) taken to the slot frame.

    Parameters
    ----------
    physics : PhysicsSource
        The turntable frame's physics (the world model: specific force g, body rate deg/s, field uT).
    rotation : (3, 3) array
        R, slot frame to turntable frame; a vector goes to the slot frame as ``R^T v``.
    """

    physics: object
    rotation: np.ndarray

    def __call__(self, t_s: np.ndarray) -> PhysicsBatch:
        p = self.physics(t_s)
        r = np.asarray(self.rotation, float)
        return PhysicsBatch(specific_force_g=p.specific_force_g @ r, angular_rate_dps=p.angular_rate_dps @ r,
                            magnetic_field_ut=p.magnetic_field_ut @ r, temp_c=p.temp_c)


@dataclasses.dataclass
class SimulatedSlot:
    """One slot's hidden sensor: its seed and error models (what ``sim_truth.yaml`` records)."""

    index: int
    seed: int
    model: str
    accel_errors: AccelErrorModel
    gyro_errors: GyroErrorModel | None
    mag_errors: MagErrorModel | None
    chip: object = None


class SimulatedFixture:
    """The register-level models of a fixture's buses, multiplexers and slot chips, in ``sim``'s world.

    Parameters
    ----------
    sim : rig.simulation.simrig.SimulatedRig
        The world (clock, stages, chamber) the fixture sits in; its seed draws the slots.
    config : rig.config.fixture.FixtureConfig
    slot_faults : dict, optional
        Slot number -> ``SensorFaults`` fields (the rig file's ``faults.slots``).
    """

    def __init__(self, sim, config, slot_faults: dict | None = None) -> None:
        self.sim = sim
        self.config = config
        self.buses: dict[str, SimulatedI2CBus] = {}
        self.muxes: dict[tuple[str, int], Tca9548aModel] = {}
        self.slots: list[SimulatedSlot] = []
        slot_faults = slot_faults or {}
        for i, sc in enumerate(config.slots):
            bus = self.buses.setdefault(sc.bus, SimulatedI2CBus(sc.bus))
            segment = bus
            if sc.mux is not None:
                key = (sc.bus, int(sc.mux))
                if key not in self.muxes:
                    self.muxes[key] = Tca9548aModel(clock=sim.clock).attach(bus, int(sc.mux))
                segment = self.muxes[key].channel(sc.channel)
            faults = slot_faults.get(i) or slot_faults.get(str(i))
            self.slots.append(self._make_slot(i, sc, segment, SensorFaults(**faults) if faults else None))

    def _make_slot(self, i: int, sc, segment: SimulatedI2CBus, faults) -> SimulatedSlot:
        seed = slot_seed(self.sim.seed, i)
        rng = np.random.default_rng(seed)
        chip_info = chip_spec(sc.model)
        slot = SimulatedSlot(i, seed, sc.model, AccelErrorModel.draw(rng, sc.model),
                             GyroErrorModel.draw(rng, sc.model) if chip_info.has_gyro else None,
                             MagErrorModel.draw(rng, sc.model) if chip_info.has_magnetometer else None)
        world = RotatedPhysics(dataclasses.replace(self.sim.world), sc.rotation.as_array())  # its own ringing state
        noise = self.sim.settings.noise
        if sc.model == "ADXL345":
            slot.chip = Adxl345Model(world, slot.accel_errors, clock=self.sim.clock, seed=seed, faults=faults,
                                     noise=noise)
            segment.add_device(sc.address, slot.chip)
        else:
            slot.chip = Mpu9150Model(world, slot.accel_errors, clock=self.sim.clock, seed=seed,
                                     gyro_errors=slot.gyro_errors, mag_errors=slot.mag_errors, faults=faults,
                                     noise=noise, unit_seed=seed)
            slot.chip.attach(segment, sc.address)
        return slot

    def bus(self, name: str) -> SimulatedI2CBus:
        """The simulated bus a slot names (what :func:`attach_fixture` opens)."""
        return self.buses[name]

    def truth(self, i: int) -> dict:
        """Slot ``i``'s hidden parameters (its ``sim_truth.yaml``; tests and benchmarks only), in its own frame."""
        s, sc, sim = self.slots[i], self.config.slots[i], self.sim
        return {
            "seed": s.seed, "rig_seed": sim.seed, "slot": i, "serial": sc.serial,
            "rotation": sc.rotation.name if sc.rotation.name is not None else [list(r) for r in sc.rotation.matrix],
            "repeat": sim.settings.repeat, "sensor_model": s.model,
            "accelerometer": s.accel_errors.to_dict(),
            "gyroscope": s.gyro_errors.to_dict() if s.gyro_errors else None,
            "magnetometer": s.mag_errors.to_dict() if s.mag_errors else None,
            "table_tilt_deg": list(sim.world.table_tilt_deg),
            "chamber": dataclasses.asdict(sim.settings.chamber),
            "time_scale": sim.settings.time_scale,
            "clock": sim.settings.clock if sim.settings.time_scale else "virtual",
        }


def attach_simulated_fixture(rig: Rig, sim, rig_file) -> Fixture:
    """Build the fixture's simulated chips in ``sim``'s world and open them on ``rig`` as hardware would be
    (``rig.fixture``; ``rig.sensor`` and ``rig.magnetometer`` the first slot's)."""
    faults = (rig_file.faults or {}).get("slots") or {}
    model = SimulatedFixture(sim, rig_file.fixture, faults)
    fixture = attach_fixture(rig_file.fixture, model.bus, clock=rig.clock,
                             attachments=lambda i: {"sim_truth.yaml": yaml.safe_dump(model.truth(i), sort_keys=False)})
    rig.fixture = fixture
    rig.sensor = fixture.slots[0].sensor
    rig.magnetometer = fixture.slots[0].magnetometer
    return fixture

"""The simulated rig: three emulated Standa controllers on pseudo-terminals and a
simulated I2C sensor, coupled by a world model.

Nothing here is an API-level fake: the runner talks to the emulators through
the same pyserial ``Stage`` driver it uses on hardware, and to the sensor
through the same smbus-level driver. The simulator's hidden parameters (the
sensor's true error model, table tilt, chamber) are drawn from ``seed`` and
exposed through :meth:`SimulatedRig.truth` for ``sim_truth.yaml``; nothing that
solves or searches may read them.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from drivers.clock import ElasticClock, MonotonicClock, VirtualClock
from drivers.sensors.chips import SENSOR_MODELS, chip_spec
from drivers.sensors.sim.adxl345 import Adxl345Model
from drivers.sensors.sim.bus import SimulatedI2CBus
from drivers.sensors.sim.error_model import AccelErrorModel, GyroErrorModel, MagErrorModel
from drivers.sensors.sim.faults import SensorFaults
from drivers.sensors.sim.mpu9150 import Mpu9150Model
from drivers.sensors.sim.noise import resolve_noise
from drivers.sensors.sim.unit_noise import draw_unit_noise
from drivers.ximc.sim.emulator import ControllerEmulator, XimcFaults
from rig.errors import RigInputError
from rig.planning.kinematics import STAGE_AXES
from rig.simulation.mounting import MountedPhysics
from rig.simulation.settings import EFFECT_FIELDS, EFFECT_PARAMS, SimSettings
from rig.simulation.world import AxisLink, SimChamber, WorldModel

#: the stream the noise seed of a repeated run (``sim.repeat``) is drawn from
REPEAT_STREAM = 0x5E9
#: the stream of the turntable's hidden geometry, drawn from ``sim.geometry.table_seed`` (no other draw changes with it)
GEOMETRY_STREAM = 0x6E0


class SimulatedRig:
    """Emulators + simulated sensor + world model, ready for the runner.

    Parameters
    ----------
    settings : SimSettings
    seed : int
        Draws the sensor's hidden error model and noise.
    sensor_model : str
        "MPU-9150" or "ADXL345".
    sensor_address : int
    axis_signs, home_offsets_deg : per-axis rig-file values (kinematic angle =
        sign * (stage angle - home offset)).
    ximc_faults : dict axis -> XimcFaults fields; sensor_faults : SensorFaults fields.
    """

    def __init__(self, settings: SimSettings, *, seed: int, sensor_model: str = SENSOR_MODELS[0],
                 sensor_address: int | None = None, axis_signs=(1, 1, 1), home_offsets_deg=(0, 0, 0),
                 ximc_faults: dict | None = None, sensor_faults: dict | None = None) -> None:
        self.settings = settings
        self.seed = int(seed)
        #: the seed of the chip's noise draws: the rig's own, or (``sim.repeat``) one of its own per run number, so that
        #: the same hidden sensor can be recorded again with other noise (a repeatability study)
        self.noise_seed = self.seed if not settings.repeat else int(
            np.random.default_rng([self.seed % 2**63, int(settings.repeat), REPEAT_STREAM]).integers(2**62))
        self.sensor_model = sensor_model
        self.clock = make_clock(settings)
        rng = np.random.default_rng(self.seed)
        self.accel_errors = self._draw_accel_errors(rng)
        chip = chip_spec(sensor_model)
        self.gyro_errors = GyroErrorModel.draw(rng, sensor_model) if chip.has_gyro else None
        self.mag_errors = MagErrorModel.draw(rng, sensor_model) if chip.has_magnetometer else None
        for obj, over in ((self.gyro_errors, self.settings.gyro_errors), (self.mag_errors, self.settings.mag_errors)):
            for k, v in (over.items() if obj is not None else ()):
                setattr(obj, k, _broadcast_like(v, getattr(obj, k), k))
        self.unit_noise = None
        self.noise = settings.noise  # what the chip is built with: the model's name, or this unit's NoiseConfig
        if settings.noise_spread:
            errors = {"accel": self.accel_errors, "gyro": self.gyro_errors, "mag": self.mag_errors}
            self.unit_noise = draw_unit_noise(self.seed, resolve_noise(settings.noise, sensor_model), errors,
                                              settings.noise_spread)
            self.noise = self.unit_noise.noise
        if settings.noise_figures:  # this unit's own figures (a twin of a characterised unit)
            self.noise = dataclasses.replace(resolve_noise(self.noise, sensor_model), **settings.noise_figures)
        self.chamber = SimChamber(self.clock, settings.chamber)
        ximc_faults = ximc_faults or {}
        self.emulators: list[ControllerEmulator] = []
        for i, name in enumerate(STAGE_AXES):
            faults = XimcFaults(**ximc_faults[name]) if name in ximc_faults else None
            emu = ControllerEmulator(settings.serial_base + i, clock=self.clock, faults=faults,
                                     seed=self.seed * 10 + i)
            self.emulators.append(emu)
        self.ports: dict[str, str] = {}
        # the table is the rig's: its hidden errors come from the rig file's table_seed, the same for every run and
        # unit on it (as a real table's are), while the run's seed draws the unit (a characterisation made with one
        # unit serves the next, docs/simulated-rig.md)
        self.geometry = (settings.geometry.draw(np.random.default_rng([settings.table_seed, GEOMETRY_STREAM]),
                                                settings.gravity_m_s2) if settings.geometry is not None else None)
        self.world = WorldModel(
            axes=[AxisLink(e.position_deg_at, e.speed_deg_s_at, float(s), float(h), e.direction_at, e.rest_pose,
                           e.state_at)
                  for e, s, h in zip(self.emulators, axis_signs, home_offsets_deg)],
            chamber=self.chamber,
            table_tilt_deg=self._tilt(),
            magnetic_field=settings.magnetic_field,
            ringing=settings.ringing,
            geometry=self.geometry,
            pose_error_deg=float(np.ravel(self.settings.effects.get("pose_error", 0.0))[0]),
        )
        #: what the chip feels: the world through the sensor's turn in its fixture (:meth:`remount`)
        self.physics = MountedPhysics(self.world)
        self.bus = SimulatedI2CBus(1)
        self.sensor_address = sensor_address
        self.chip = self._make_chip(sensor_faults)

    # -- construction -------------------------------------------------------------------
    def _draw_accel_errors(self, rng) -> AccelErrorModel:
        errors = AccelErrorModel.draw(rng, self.sensor_model)
        d = errors.to_dict()
        d.update(self.settings.errors)
        for name, value in self.settings.effects.items():
            if name in EFFECT_FIELDS or name in EFFECT_PARAMS:
                key = EFFECT_FIELDS.get(name) or EFFECT_PARAMS[name]
                d[key] = _broadcast_like(value, d.get(key), name)
            elif name == "full_misalignment":
                # a small mounting rotation about the sensor's x axis couples y and z
                # beyond what the triangular model allows (below-diagonal terms)
                ang = float(np.radians(value if np.isscalar(value) else value[0]))
                m = np.asarray(d["matrix"], float)
                rot = np.array([[1, 0, 0], [0, np.cos(ang), -np.sin(ang)], [0, np.sin(ang), np.cos(ang)]])
                d["matrix"] = (m @ rot).tolist()
        return AccelErrorModel.from_dict(d)

    def _tilt(self) -> tuple[float, float]:
        tilt = self.settings.table_tilt_deg
        if "table_tilt" in self.settings.effects:
            v = self.settings.effects["table_tilt"]
            tilt = (float(v[0]), float(v[1])) if not np.isscalar(v) else (float(v), 0.0)
        return tilt

    def _make_chip(self, sensor_faults):
        """The register-level chip of ``sensor_model`` on the simulated bus (``SIM_CHIPS``)."""
        faults = SensorFaults(**sensor_faults) if sensor_faults else None
        spec = chip_spec(self.sensor_model)
        self.sensor_address = self.sensor_address or spec.default_address
        return SIM_CHIPS[spec.model](self, faults)

    def remount(self, turn) -> None:
        """The simulated operator turns the sensor in its fixture, now: ``turn`` (3x3, sensor frame -> fixture
        frame) relative to the reference mounting (a prompt step's ``mount:``; ``Rig.remount``)."""
        self.physics.turn_at(self.clock.now(), turn)

    # -- lifecycle ----------------------------------------------------------------------
    def start(self) -> dict[str, str]:
        """Start the emulators; return axis -> device path."""
        for name, emu in zip(STAGE_AXES, self.emulators):
            self.ports[name] = emu.start()
        return dict(self.ports)

    def stop(self) -> None:
        for emu in self.emulators:
            try:
                emu.stop()
            except Exception:  # noqa: BLE001 - shutting down, nothing to report to
                pass

    def __enter__(self) -> "SimulatedRig":
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def truth(self) -> dict:
        """Hidden simulator parameters (for sim_truth.yaml; tests and benchmarks only)."""
        return {
            "seed": self.seed,
            "repeat": self.settings.repeat,
            "sensor_model": self.sensor_model,
            "accelerometer": self.accel_errors.to_dict(),
            "gyroscope": self.gyro_errors.to_dict() if self.gyro_errors else None,
            "magnetometer": self.mag_errors.to_dict() if self.mag_errors else None,
            "table_tilt_deg": list(self.world.table_tilt_deg),
            "chamber": dataclasses.asdict(self.settings.chamber),
            "field": dataclasses.asdict(self.settings.magnetic_field),
            "effects": {k: _plain(v) for k, v in self.settings.effects.items()},
            "time_scale": self.settings.time_scale,
            "clock": self.settings.clock if self.settings.time_scale else "virtual",
            **({"noise": self.chip.noise.to_dict()} if self.settings.noise or self.unit_noise
               or self.settings.noise_figures else {}),
            **({"unit_noise": self.unit_noise.truth()} if self.unit_noise else {}),
            **({"geometry": {"classes": dataclasses.asdict(self.settings.geometry), **self.geometry.truth()}}
               if self.geometry is not None else {}),
        }


#: sim.clock (one per name of rig.simulation.settings.CLOCKS) -> the clock of a time-scaled simulated world (time scale 0 is always virtual time)
SCALED_CLOCKS = {"elastic": ElasticClock, "strict": MonotonicClock}


def make_clock(settings: SimSettings):
    """The simulated world's clock: virtual time at time scale 0, else ``SCALED_CLOCKS[settings.clock]``."""
    if settings.time_scale == 0:
        return VirtualClock()
    return SCALED_CLOCKS[settings.clock](settings.time_scale)


def _broadcast_like(value, like, name):
    v = np.asarray(value, float)
    shape = np.shape(like) if like is not None else (3,)
    try:
        return np.broadcast_to(v, shape).tolist()
    except ValueError:
        raise RigInputError(None, None, f"sim.effects.{name}", f"expected a number or shape {list(shape)}") from None


def _plain(v):
    return np.asarray(v).tolist() if not isinstance(v, (int, float, str)) else v


def _mpu9150(sim: "SimulatedRig", faults):
    """The MPU-9150 attaches itself and the AK8975 behind its I2C bypass."""
    chip = Mpu9150Model(sim.physics, sim.accel_errors, clock=sim.clock, seed=sim.noise_seed, gyro_errors=sim.gyro_errors,
                        mag_errors=sim.mag_errors, faults=faults, noise=sim.noise, unit_seed=sim.seed)
    chip.attach(sim.bus, sim.sensor_address)
    return chip


def _adxl345(sim: "SimulatedRig", faults):
    chip = Adxl345Model(sim.physics, sim.accel_errors, clock=sim.clock, seed=sim.noise_seed, faults=faults,
                        noise=sim.noise)
    sim.bus.add_device(sim.sensor_address, chip)
    return chip


#: sensor model -> builder of its simulated chip on the rig's bus
SIM_CHIPS = {"MPU-9150": _mpu9150, "ADXL345": _adxl345}

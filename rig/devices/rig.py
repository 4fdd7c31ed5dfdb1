"""Open a rig: hardware from a rig file, the simulated rig, or a replay rig.

Whatever the kind, the runner gets the same :class:`RigHandles`: a clock,
three ``Stage`` drivers on serial ports, an ``AccelSensor`` on an I2C bus,
and optionally a chamber it can set. Only the simulated rig has hidden truth.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

from drivers.clock import Clock, MonotonicClock
from drivers.sensors import open_sensor
from drivers.ximc.stage import Stage

AXES = ("a1", "a2", "a3")


@dataclass
class AxisSetup:
    """Per-axis values from the rig file (angles in the kinematic frame, deg)."""

    name: str
    port: str
    serial: int | None = None
    sign: float = 1.0
    home_offset_deg: float = 0.0
    speed_deg_s: float = 20.0
    accel_deg_s2: float = 20.0
    soft_limits_deg: tuple[float, float] = (-720.0, 720.0)
    cable_wrap_deg: float = 720.0
    slip_ring: bool = False


@dataclass
class RigHandles:
    """Everything the runner drives."""

    kind: str  # "sim" | "hardware" | "replay"
    clock: Clock
    stages: dict[str, Stage]
    axes: dict[str, AxisSetup]
    sensor: Any  # AccelSensor
    sensor_model: str
    sensor_address: int
    home_policy: str = "zero"  # none | zero | home
    chamber: Any | None = None  # has set_target_c(target_c)
    truth: dict | None = None
    is_replay: bool = False
    on_step_begin: Callable[[int], None] | None = None
    rig_file: str | None = None
    magnetometer: Any | None = None  # has read_field_ut() -> (3,) uT
    site_field: dict | None = None  # {field_ut, inclination_deg, declination_deg}
    _closers: list[Callable[[], None]] = field(default_factory=list)

    def close(self) -> None:
        for stage in self.stages.values():
            try:
                stage.close()
            except Exception:  # noqa: BLE001 - closing; nothing more to do
                pass
        for closer in reversed(self._closers):
            try:
                closer()
            except Exception:  # noqa: BLE001
                pass

    def stage_angle_deg(self, axis: str, kinematic_deg: float) -> float:
        """Stage (controller) angle that puts the kinematic axis at ``kinematic_deg``."""
        a = self.axes[axis]
        return a.sign * kinematic_deg + a.home_offset_deg

    def kinematic_angle_deg(self, axis: str, stage_deg: float) -> float:
        a = self.axes[axis]
        return a.sign * (stage_deg - a.home_offset_deg)


def open_rig(rig_file, *, seed: int = 0, time_scale: float | None = None,
             on_stage_event: Callable[[str, dict], None] | None = None) -> RigHandles:
    """Open the rig described by a loaded rig file.

    Parameters
    ----------
    rig_file : rig.config.rigfile.RigFile
    seed : int
        Simulated rigs only: draws the hidden sensor parameters and noise.
    time_scale : float, optional
        Simulated rigs only: override the rig file's time scale (0 = virtual time).
    on_stage_event : callable
        Receives recovered-fault events from the stage drivers.
    """
    axes = {name: _axis_setup(rig_file, name) for name in AXES}
    if rig_file.is_simulated:
        return _open_sim(rig_file, axes, seed, time_scale, on_stage_event)
    return _open_hardware(rig_file, axes, on_stage_event)


def _axis_setup(rig_file, name: str) -> AxisSetup:
    ax = rig_file.axes[name]
    return AxisSetup(name=name, port=ax.port, serial=ax.serial, sign=float(ax.sign),
                     home_offset_deg=float(ax.home_offset_deg), speed_deg_s=float(ax.speed_deg_s),
                     accel_deg_s2=float(ax.accel_deg_s2), soft_limits_deg=tuple(ax.soft_limits_deg),
                     cable_wrap_deg=float(ax.cable_wrap_deg), slip_ring=bool(ax.slip_ring))


def _open_stages(ports: dict[str, str], clock: Clock, on_event) -> dict[str, Stage]:
    stages = {}
    try:
        for name in AXES:
            st = Stage(ports[name], clock=clock, name=name, on_event=on_event)
            st.open()
            stages[name] = st
    except Exception:
        for st in stages.values():
            st.close()
        raise
    return stages


def _open_hardware(rig_file, axes, on_event) -> RigHandles:
    clock = MonotonicClock()
    stages = _open_stages({n: a.port for n, a in axes.items()}, clock, on_event)
    try:
        import smbus2
        bus = smbus2.SMBus(rig_file.sensor.bus)
        sensor = open_sensor(rig_file.sensor.model, bus, rig_file.sensor.address, clock=clock)
    except Exception:
        for st in stages.values():
            st.close()
        raise
    h = RigHandles(kind="hardware", clock=clock, stages=stages, axes=axes, sensor=sensor,
                   sensor_model=rig_file.sensor.model, sensor_address=rig_file.sensor.address,
                   home_policy=rig_file.home_policy, rig_file=str(rig_file.path))
    h._closers.append(bus.close)
    if rig_file.sensor.model == "MPU-9150":
        from drivers.sensors.ak8975 import Ak8975
        h.magnetometer = Ak8975(bus, clock=clock)
    if rig_file.site is not None:
        h.site_field = {"field_ut": rig_file.site.field_ut, "inclination_deg": rig_file.site.inclination_deg,
                        "declination_deg": rig_file.site.declination_deg}
    return h


def _open_sim(rig_file, axes, seed, time_scale, on_event) -> RigHandles:
    from rig.simulation.simrig import SimSettings, SimulatedRig

    settings = SimSettings.from_mapping(rig_file.sim, f"{rig_file.path}: sim")
    if time_scale is not None:
        settings.time_scale = float(time_scale)
    faults = rig_file.faults or {}
    sim = SimulatedRig(settings, seed=seed, sensor_model=rig_file.sensor.model,
                       sensor_address=rig_file.sensor.address,
                       axis_signs=[axes[n].sign for n in AXES],
                       home_offsets_deg=[axes[n].home_offset_deg for n in AXES],
                       ximc_faults=faults.get("ximc"), sensor_faults=faults.get("sensor"))
    ports = sim.start()
    try:
        for n in AXES:
            axes[n].port = ports[n]
            axes[n].serial = sim.emulators[AXES.index(n)].serial_number
        stages = _open_stages(ports, sim.clock, on_event)
        sensor = open_sensor(rig_file.sensor.model, sim.bus, sim.sensor_address, clock=sim.clock)
    except Exception:
        sim.stop()
        raise
    h = RigHandles(kind="sim", clock=sim.clock, stages=stages, axes=axes, sensor=sensor,
                   sensor_model=rig_file.sensor.model, sensor_address=sim.sensor_address,
                   home_policy=rig_file.home_policy, chamber=sim.chamber, truth=sim.truth(),
                   rig_file=str(rig_file.path))
    h._closers.append(sim.stop)
    if rig_file.sensor.model == "MPU-9150":  # the AK8975 behind the MPU-9150's I2C bypass
        from drivers.sensors.ak8975 import Ak8975
        h.magnetometer = Ak8975(sim.bus, clock=sim.clock)
    fc = settings.magnetic_field
    h.site_field = {"field_ut": float(fc.magnitude_ut), "inclination_deg": float(fc.inclination_deg),
                    "declination_deg": float(fc.declination_deg)}
    h.sim = sim  # type: ignore[attr-defined]  # for tests that inspect the world
    return h

"""Open a hardware rig: three Standa controllers on serial ports and a sensor on an I2C bus."""

from __future__ import annotations

from drivers.clock import Clock, MonotonicClock
from drivers.sensors import open_sensor
from drivers.sensors.chips import chip_spec
from drivers.sensors.ak8975 import Ak8975
from drivers.ximc.stage import Stage
from rig.devices.buses import open_bus
from rig.devices.fixture import attach_hardware_fixture
from rig.devices.registry import register_rig_kind
from rig.devices.rig import Axis, Rig
from rig.planning.kinematics import STAGE_AXES


def open_stages(axes_config: dict, clock: Clock, on_event=None) -> dict[str, Axis]:
    """Open one ``Stage`` per axis on its configured port; close the opened ones on failure."""
    axes: dict[str, Axis] = {}
    try:
        for name in STAGE_AXES:
            config = axes_config[name]
            stage = Stage(config.port, clock=clock, name=name, on_event=on_event)
            stage.open()
            axes[name] = Axis(name, config, stage)
    except Exception:
        for axis in axes.values():
            axis.stage.close()
        raise
    return axes


def attach_sensors(rig: Rig, model: str, bus, address: int | None) -> None:
    """Open the sensor (and the AK8975 behind an MPU-9150's bypass) on ``bus``."""
    rig.sensor = open_sensor(model, bus, address, clock=rig.clock)
    if chip_spec(model).has_magnetometer:  # the AK8975 behind the MPU-9150's I2C bypass
        rig.magnetometer = Ak8975(bus, clock=rig.clock)


def open_hardware_rig(rig_file, *, seed: int | None = None, time_scale: float | None = None,
                      clock: str | None = None) -> Rig:
    """Open the rig a ``kind: hardware`` rig file describes (``seed``, ``time_scale`` and ``clock`` do not
    apply: hardware keeps wall time)."""
    clock = MonotonicClock()
    axes = open_stages(rig_file.axes, clock)
    rig = Rig(kind="hardware", clock=clock, axes=axes, sensor=None, turntable="standa-8smc",
              home_policy=rig_file.home_policy, rig_file=str(rig_file.path))
    try:
        if getattr(rig_file, "fixture", None) is not None:  # the slots instead of the one sensor (docs/fixture.md)
            attach_hardware_fixture(rig, rig_file)
        else:
            bus = open_bus(rig_file.sensor.bus, where=str(rig_file.path))
            rig.closers.append(bus.close)
            attach_sensors(rig, rig_file.sensor.model, bus, rig_file.sensor.address)
    except Exception:
        rig.close()
        raise
    if rig_file.site is not None:
        rig.site_field = {"field_ut": rig_file.site.field_ut, "inclination_deg": rig_file.site.inclination_deg,
                          "declination_deg": rig_file.site.declination_deg}
    return rig


register_rig_kind("hardware", open_hardware_rig)

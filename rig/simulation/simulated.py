"""The ``sim`` rig kind: emulated controllers on pseudo-terminals and a simulated chip on an
in-process I2C bus, opened through the same stage and sensor drivers as hardware."""

from __future__ import annotations

import yaml

from drivers.ximc.sim.protocol_ximcsim import attach, detach
from rig.config.rigfile import AxisConfig
from rig.devices.buses import register_bus, unregister_bus
from rig.devices.hardware import attach_sensors, open_stages
from rig.devices.registry import register_rig_kind
from rig.devices.rig import Rig
from rig.planning.kinematics import AXES
from rig.simulation.simrig import SimSettings, SimulatedRig


def start_simulated_rig(rig_file, *, seed: int, time_scale: float | None = None) -> SimulatedRig:
    """Start the simulated world a rig file describes (its ``sim:`` and ``faults:`` sections)."""
    settings = SimSettings.from_mapping(rig_file.sim, f"{rig_file.path}: sim")
    if time_scale is not None:
        settings.time_scale = float(time_scale)
    faults = rig_file.faults or {}
    sim = SimulatedRig(settings, seed=seed, sensor_model=rig_file.sensor.model,
                       sensor_address=rig_file.sensor.address,
                       axis_signs=[rig_file.axes[n].sign for n in AXES],
                       home_offsets_deg=[rig_file.axes[n].home_offset_deg for n in AXES],
                       ximc_faults=faults.get("ximc"), sensor_faults=faults.get("sensor"))
    sim.start()
    return sim


def open_simulated_rig(rig_file, *, seed: int | None = None, time_scale: float | None = None) -> Rig:
    """Open a ``kind: sim`` rig file: start the simulated world, then drive it like hardware."""
    seed = 0 if seed is None else int(seed)
    sim = start_simulated_rig(rig_file, seed=seed, time_scale=time_scale)
    try:
        axes_config = {n: rig_file.axes[n].with_port(sim.ports[n], sim.emulators[i].serial_number)
                       for i, n in enumerate(AXES)}
        axes = open_stages(axes_config, sim.clock)
    except Exception:
        sim.stop()
        raise
    field = sim.settings.magnetic_field
    rig = Rig(kind="sim", clock=sim.clock, axes=axes, sensor=None, turntable="sim:8smc5-emulator",
              home_policy=rig_file.home_policy, chamber=sim.chamber, seed=seed, rig_file=str(rig_file.path),
              site_field={"field_ut": float(field.magnitude_ut), "inclination_deg": float(field.inclination_deg),
                          "declination_deg": float(field.declination_deg)},
              attachments={"sim_truth.yaml": yaml.safe_dump(sim.truth(), sort_keys=False)})
    rig.closers.append(sim.stop)
    try:
        attach_sensors(rig, rig_file.sensor.model, sim.bus, sim.sensor_address)
    except Exception:
        rig.close()
        raise
    return rig


def publish_bus(sim: SimulatedRig, name: str = "sim") -> None:
    """Make the simulated world's I2C bus reachable as ``bus: NAME`` from a hardware rig file (the
    hardware code path on simulated devices); :func:`withdraw_bus` undoes it."""
    register_bus(name, lambda: sim.bus)


def withdraw_bus(name: str = "sim") -> None:
    unregister_bus(name)


register_rig_kind("sim", open_simulated_rig)


def open_in_process_rig(sim: SimulatedRig, name: str = "mem") -> Rig:
    """The simulated world of ``sim`` (not started: no pseudo-terminals) as a :class:`Rig` whose stages
    talk to the emulated controllers in memory (``ximcsim://`` URLs) through the real ``Stage``
    driver: the engine's unit tests run through hardware code in milliseconds."""
    axes_config = {}
    for i, n in enumerate(AXES):
        url = attach(f"{name}-{n}", sim.emulators[i].controller)
        axes_config[n] = AxisConfig(port=url, serial=sim.emulators[i].serial_number)
    rig = Rig(kind="sim", clock=sim.clock, axes=open_stages(axes_config, sim.clock), sensor=None,
              turntable="sim:8smc5-controller-in-memory", chamber=sim.chamber, seed=sim.seed)
    rig.closers.extend(lambda n=n: detach(f"{name}-{n}") for n in AXES)
    attach_sensors(rig, sim.sensor_model, sim.bus, sim.sensor_address)
    return rig

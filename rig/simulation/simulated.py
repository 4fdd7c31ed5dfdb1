"""The ``sim`` rig kind: emulated controllers on pseudo-terminals and a simulated chip on an
in-process I2C bus, opened through the same stage and sensor drivers as hardware."""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
import os
import time

import yaml

from drivers.clock import Clock, MonotonicClock, VirtualClock
from drivers.sensors import open_sensor
from drivers.ximc.sim.protocol_ximcsim import attach, detach
from rig.config.rigfile import AxisConfig
from rig.devices.buses import register_bus, unregister_bus
from rig.devices.hardware import attach_sensors, open_stages
from rig.devices.registry import register_rig_kind
from rig.devices.rig import LostSamples, Rig
from rig.errors import RigInputError
from rig.execution.capture import poll_interval_s
from rig.planning.kinematics import STAGE_AXES
from rig.simulation.fixture import attach_simulated_fixture
from rig.simulation.simrig import SimSettings, SimulatedRig

#: the share of this machine a capture's FIFO reads may take at a time scale it keeps up with; the other half
#: is the run's own work around them (settle detection, progress, the session writer, the emulated
#: controllers). A time scale at which the reads alone would take the whole machine (twice what it keeps
#: up with) is refused before recording.
KEEP_UP_SHARE = 0.5
#: wall time of one probe of the keep-up check, s
PROBE_WALL_S = 0.25


def drain_share(settings: SimSettings, seed: int, address: int | None, model: str, sensor_settings,
                time_scale: float, wall_s: float = PROBE_WALL_S) -> tuple[float, bool]:
    """Read a fresh simulated sensor (its own world and bus, no faults) at ``time_scale`` for ``wall_s``
    of wall time as a capture does; return the share of the wall time the reads took and whether its
    FIFO overflowed."""
    sim = SimulatedRig(dataclasses.replace(settings, time_scale=time_scale), seed=seed, sensor_model=model,
                       sensor_address=address)
    sensor = open_sensor(model, sim.bus, sim.sensor_address, clock=sim.clock)
    sensor.configure(sensor_settings)
    poll = poll_interval_s(sensor)
    sensor.start()
    busy, t0 = 0.0, time.perf_counter()
    while time.perf_counter() - t0 < wall_s:
        sim.clock.sleep(poll)
        t = time.perf_counter()
        sensor.read()
        busy += time.perf_counter() - t
    share = busy / (time.perf_counter() - t0)
    sensor.stop()
    return share, sensor.stats.overflows > 0


def keeps_up_with(settings: SimSettings, seed: int, address: int | None, model: str, sensor_settings,
                  time_scale: float) -> float:
    """The time scale this machine keeps up with for ``model`` at ``sensor_settings``: probe at
    ``time_scale``, then at ever slower ones while the FIFO overflows; at the first that does not, the
    scale at which the reads would take :data:`KEEP_UP_SHARE` of the machine (their load grows with
    the scale). 0 when not even 1/100 of real time keeps up."""
    pace = float(time_scale)
    while pace >= 0.01:
        share, overflowed = drain_share(settings, seed, address, model, sensor_settings, pace)
        if not overflowed and share < 1.0:
            return pace * KEEP_UP_SHARE / max(share, 1e-6)
        pace /= 8.0
    return 0.0


class ScaledClock:
    """The clock of a simulated rig at time scale K > 0 (K simulated seconds per wall second), as the
    rig's :class:`rig.devices.rig.PacedClock`: time is the shared ``MonotonicClock``'s, unchanged; what
    it adds is what that pace means on this machine (the keep-up check before recording, and why
    samples were lost).

    ``where``: the rig file whose ``sim.time_scale`` set K (None: ``--time-scale``); ``probe(model,
    settings, K)``: the time scale this machine keeps up with (:func:`keeps_up_with`).
    """

    def __init__(self, inner: MonotonicClock, where: str | None, probe) -> None:
        self.inner = inner
        self.where = where
        self.probe = probe
        self.keeps_up_x: float | None = None  # measured by check_keep_up
        self.sensor = ""  # "1 kHz MPU-9150", named by check_keep_up

    @property
    def time_scale(self) -> float:
        return self.inner.time_scale

    def now(self) -> float:
        return self.inner.now()

    def sleep(self, dt_s: float) -> None:
        self.inner.sleep(dt_s)

    def _setting(self) -> str:
        return f"{'--time-scale' if self.where is None else 'sim.time_scale'} {self.time_scale:g}"

    def check_keep_up(self, model: str, settings) -> None:
        """Refuse (RigInputError, one line) a time scale clearly beyond what this machine keeps up with:
        one at which reading the sensor alone would take the whole machine."""
        self.keeps_up_x = self.probe(model, settings, self.time_scale)
        self.sensor = f"{_rate(settings.sample_rate_hz)} {model}"
        if self.time_scale > self.keeps_up_x / KEEP_UP_SHARE:
            raise RigInputError(self.where, None, None, f"{self._setting()}: this machine keeps up with about "
                                f"{_about(self.keeps_up_x)}x for a {self.sensor}; use {_slower(self.keeps_up_x)}")

    def explain_lost_samples(self) -> LostSamples:
        """Samples lost at this pace are this machine's, not the sensor's: stop, resume slower."""
        limit = min(self.time_scale, self.keeps_up_x or math.inf) / 2
        slower = nice_below(limit)
        measured = (f"this machine kept up with about {_about(self.keeps_up_x)}x for a {self.sensor} when the run "
                    "started; " if self.keeps_up_x else "")
        return LostSamples(f"the simulated clock ({self._setting()}) outran this machine, which did not read the "
                           "sensor's FIFO before it filled (the simulated sensor itself lost nothing)",
                           advice=measured + f"use {_slower(limit)}", stop_run=True,
                           resume_options=f"--time-scale {slower:g}" if slower else "--time-scale 0")


def nice_below(x: float) -> float | None:
    """The largest of ..., 0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 50, ... not above ``x`` (None below 0.1)."""
    if not x >= 0.1:
        return None
    e = math.floor(math.log10(x))
    return max(m * 10.0 ** e for m in (1, 2, 5) if m * 10.0 ** e <= x * (1 + 1e-9))


def _slower(keeps_up_x: float) -> str:
    k = nice_below(keeps_up_x)
    return f"--time-scale {k:g} or 0 (virtual time)" if k else "--time-scale 0 (virtual time)"


def _about(x: float) -> str:
    """37, 120, 1.5: two significant digits."""
    return f"{x:.1f}" if x < 10 else f"{float(f'{x:.2g}'):g}"


def _rate(hz: float) -> str:
    return f"{hz / 1000:g} kHz" if hz >= 1000 else f"{hz:g} Hz"


def rig_clock(sim: SimulatedRig, where: str | None) -> Clock:
    """The rig's clock: virtual time and an elastic clock (which waits for a late reader, so this machine
    always keeps up) as they are, a strict time-scaled clock as a :class:`ScaledClock`."""
    if sim.settings.time_scale == 0 or sim.settings.clock == "elastic":
        return sim.clock
    return ScaledClock(sim.clock, where, functools.partial(keeps_up_with, sim.settings, sim.seed, sim.sensor_address))


def start_simulated_rig(rig_file, *, seed: int, time_scale: float | None = None, clock: str | None = None,
                        start: bool = True) -> SimulatedRig:
    """The simulated world a rig file describes (its ``sim:`` and ``faults:`` sections), its emulators
    started on pseudo-terminals unless ``start`` is false; ``time_scale`` and ``clock`` override the file's."""
    settings = SimSettings.from_mapping(rig_file.sim, f"{rig_file.path}: sim")
    if time_scale is not None:
        settings.time_scale = float(time_scale)
    if clock is not None:
        settings.clock = clock
    if "transport" not in (rig_file.sim or {}):
        settings.transport = default_transport()
    faults = rig_file.faults or {}
    sim = SimulatedRig(settings, seed=seed, sensor_model=rig_file.sensor.model,
                       sensor_address=rig_file.sensor.address,
                       axis_signs=[rig_file.axes[n].sign for n in STAGE_AXES],
                       home_offsets_deg=[rig_file.axes[n].home_offset_deg for n in STAGE_AXES],
                       ximc_faults=faults.get("ximc"), sensor_faults=faults.get("sensor"))
    if start:
        sim.start()
    return sim


def open_simulated_rig(rig_file, *, seed: int | None = None, time_scale: float | None = None,
                       clock: str | None = None) -> Rig:
    """Open a ``kind: sim`` rig file: start the simulated world, then drive it like hardware (through the
    stage driver, over pseudo-terminals or, with ``sim.transport: memory``, in process)."""
    seed = 0 if seed is None else int(seed)
    sim = start_simulated_rig(rig_file, seed=seed, time_scale=time_scale, clock=clock, start=False)
    rig_clock_ = rig_clock(sim, str(rig_file.path) if time_scale is None else None)
    closers: list = []
    try:
        ports, closers = TRANSPORT_OPENERS[sim.settings.transport](sim.emulators, sim.clock)
        sim.ports = dict(ports)
        axes_config = {n: rig_file.axes[n].with_port(ports[n], sim.emulators[i].serial_number)
                       for i, n in enumerate(STAGE_AXES)}
        axes = open_stages(axes_config, sim.clock)
    except Exception:
        for close in closers:
            close()
        sim.stop()
        raise
    field = sim.settings.magnetic_field
    turntable = "sim:8smc5-emulator" + ("-in-memory" if sim.settings.transport == "memory" else "")
    rig = Rig(kind="sim", clock=rig_clock_, axes=axes, sensor=None, turntable=turntable,
              home_policy=rig_file.home_policy, chamber=sim.chamber, seed=seed, rig_file=str(rig_file.path),
              site_field={"field_ut": float(field.magnitude_ut), "inclination_deg": float(field.inclination_deg),
                          "declination_deg": float(field.declination_deg)},
              attachments={"sim_truth.yaml": yaml.safe_dump(sim.truth(), sort_keys=False)})
    rig.closers.extend(closers)  # stop (pty) or detach (memory) the emulators: all sim.stop would do
    try:
        if getattr(rig_file, "fixture", None) is not None:  # the slots instead of the one sensor (docs/fixture.md)
            attach_simulated_fixture(rig, sim, rig_file)
        else:
            attach_sensors(rig, rig_file.sensor.model, sim.bus, sim.sensor_address)
            rig.remount = sim.remount  # the simulated operator turns the sensor at a prompt's mount:
    except Exception:
        rig.close()
        raise
    return rig


#: the environment variable that chooses ``sim.transport`` for a rig file that does not (the tests set memory)
TRANSPORT_ENV = "RIG_SIM_TRANSPORT"


def default_transport() -> str:
    """``sim.transport`` when the rig file does not say: ``$RIG_SIM_TRANSPORT``, else ``pty``."""
    value = os.environ.get(TRANSPORT_ENV) or "pty"
    if value not in TRANSPORT_OPENERS:
        raise RigInputError(None, None, TRANSPORT_ENV,
                            f"expected one of {', '.join(TRANSPORT_OPENERS)}, got {value!r}")
    return value


def _pty_transport(emulators, clock) -> tuple[dict[str, str], list]:
    """The emulators on pseudo-terminals (their serving threads started): axis -> device path, and what
    stops them."""
    ports = {n: emu.start() for n, emu in zip(STAGE_AXES, emulators)}
    return ports, [emu.stop for emu in emulators]


#: numbers the in-process rigs of this program, so that two open at once never share a ``ximcsim://`` name
_MEMORY_RIGS = itertools.count(1)


def _memory_transport(emulators, clock) -> tuple[dict[str, str], list]:
    """The emulators in process: axis -> ``ximcsim://`` URL, and what detaches them. The wire's own faults
    (answer latency, a vanishing port) need a wire: refused here, one line."""
    for n, emu in zip(STAGE_AXES, emulators):
        f = emu.faults
        wire = [k for k, on in (("latency_s", f.latency_s > 0), ("vanish_at_s", f.vanish_at_s is not None)) if on]
        if wire:
            raise RigInputError(None, None, f"faults.ximc.{n}.{wire[0]}",
                                "a fault of the serial line needs sim.transport: pty (got memory)")
    if isinstance(clock, VirtualClock):
        clock.yields = False  # no emulator thread to yield to
    rig_no = next(_MEMORY_RIGS)
    names = {n: f"sim{rig_no}-{n}" for n in STAGE_AXES}
    ports = {n: attach(names[n], emu.controller) for n, emu in zip(STAGE_AXES, emulators)}
    return ports, [lambda name=name: detach(name) for name in names.values()]


#: sim.transport (one opener per name of rig.simulation.settings.TRANSPORTS) -> how the runner reaches the
#: emulated controllers: (emulators, clock) -> (axis -> port, what closes them)
TRANSPORT_OPENERS = {"pty": _pty_transport, "memory": _memory_transport}


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
    for i, n in enumerate(STAGE_AXES):
        url = attach(f"{name}-{n}", sim.emulators[i].controller)
        axes_config[n] = AxisConfig(port=url, serial=sim.emulators[i].serial_number)
    rig = Rig(kind="sim", clock=rig_clock(sim, None), axes=open_stages(axes_config, sim.clock), sensor=None,
              turntable="sim:8smc5-controller-in-memory", chamber=sim.chamber, seed=sim.seed)
    rig.closers.extend(lambda n=n: detach(f"{name}-{n}") for n in STAGE_AXES)
    attach_sensors(rig, sim.sensor_model, sim.bus, sim.sensor_address)
    rig.remount = sim.remount
    return rig

"""A fixture as the engine drives it: N slots on one turntable, each a sensor behind its own piece of wiring.

A :class:`Fixture` is opened from the rig file's ``fixture:`` section (:class:`rig.config.fixture.FixtureConfig`)
by :func:`attach_fixture`, on buses that the rig's opener provides (``bus_for``: ``/dev/i2c-N`` through smbus2
on hardware, the simulated world's in-process buses on the simulated rig). Whatever provides the buses, the
engine gets the same slots and never asks which kind of rig it is.

The multiplexer policy of docs/fixture.md is kept here and only here: before any transfer to a slot's chip,
its :class:`BusSwitches` disconnects the bus's other multiplexer (when one is connected) and connects the slot's
channel (one channel of one multiplexer at a time). A slot's sensor and magnetometer are wrapped in
:class:`Behind`, which selects before every call, so the engine reads a slot's sensor as it reads the one
sensor of a rig.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from drivers.sensors import open_sensor
from drivers.sensors.ak8975 import Ak8975
from drivers.sensors.chips import chip_spec
from drivers.sensors.tca9548a import Tca9548a
from rig.devices.buses import open_bus


class BusSwitches:
    """The TCA9548A multiplexers of one bus and which channel is connected.

    Parameters
    ----------
    bus : smbus2.SMBus-compatible
        The upstream bus.
    bus_name : str
        The bus as the rig file names it (error messages).
    """

    def __init__(self, bus, bus_name: str) -> None:
        self.bus = bus
        self.bus_name = bus_name
        self.muxes: dict[int, Tca9548a] = {}
        self.connected: tuple[int, int] | None = None  # (mux address, channel) selected last

    def mux(self, address: int) -> Tca9548a:
        """The driver of the multiplexer at ``address`` (made on first use)."""
        if address not in self.muxes:
            self.muxes[address] = Tca9548a(self.bus, address, bus_name=self.bus_name)
        return self.muxes[address]

    def select(self, address: int | None, channel: int | None) -> None:
        """Connect ``channel`` of the multiplexer at ``address`` (None: a chip on the bus itself, nothing to
        select); another multiplexer of this bus that is connected is disconnected first. Every call
        selects again (and reads back): a switch reset by a glitch is noticed at the next transfer.

        Raises
        ------
        drivers.sensors.tca9548a.MuxError
            The switch did not answer or did not take the selection.
        """
        if address is None:
            return
        if self.connected is not None and self.connected[0] != address:
            self.mux(self.connected[0]).disable()
        self.mux(address).select(channel)
        self.connected = (address, channel)


class Behind:
    """A device driver behind a multiplexer channel: every method call selects the slot's channel first;
    attributes (rates, scale factors, statistics) are the driver's own.

    Parameters
    ----------
    device : a sensor or magnetometer driver
    select : callable
        Connects the device's channel (:meth:`BusSwitches.select` bound to the slot).
    """

    def __init__(self, device, select: Callable[[], None]) -> None:
        object.__setattr__(self, "_device", device)
        object.__setattr__(self, "_select", select)

    def __getattr__(self, name: str) -> Any:
        value = getattr(self._device, name)
        if not callable(value):
            return value

        def call(*args, **kwargs):
            self._select()
            return value(*args, **kwargs)

        return call

    def __setattr__(self, name: str, value) -> None:
        setattr(self._device, name, value)


@dataclass
class Slot:
    """One slot of an open fixture.

    Attributes
    ----------
    index : int
        The slot's position in the rig file's list, from 0.
    config : rig.config.fixture.SlotConfig
        Its wiring, chip, mounting and serial as the rig file gives them.
    sensor : the slot's sensor driver (behind its channel)
    magnetometer : the AK8975 behind an MPU-9150's bypass, or None
    attachments : dict
        Files (name -> text) stored in the slot's session, e.g. its ``sim_truth.yaml``.
    """

    index: int
    config: Any
    sensor: Any
    magnetometer: Any | None = None
    attachments: dict[str, str] = field(default_factory=dict)

    @property
    def serial(self) -> str:
        """The unit's serial (the rig file's), or ``slot-N`` when the file gives none."""
        return self.config.serial if self.config.serial is not None else f"slot-{self.index}"

    @property
    def rotation(self) -> np.ndarray:
        """The mounting rotation R (3, 3): slot frame to turntable frame, ``v_turntable = R v_slot``."""
        return self.config.rotation.as_array()

    def to_slot_frame(self, v_turntable) -> list[float]:
        """A vector in the turntable frame (the one-sensor rig's sensor frame: specific force, g; body rate,
        deg/s) in this slot's frame: ``R^T v``."""
        return [float(x) for x in self.rotation.T @ np.asarray(v_turntable, float)]

    def describe(self) -> dict:
        """The slot's identity for its session manifest (``rig.sensor.fixture``)."""
        c = self.config
        rot = c.rotation
        return {"slot": self.index, "serial": self.serial, "bus": c.bus,
                "mux": None if c.mux is None else int(c.mux), "channel": c.channel,
                "rotation": rot.name if rot.name is not None else [list(r) for r in rot.matrix],
                "rotation_matrix": [[float(x) + 0.0 for x in r] for r in rot.matrix]}


@dataclass
class Fixture:
    """The slots of a fixture, opened; ``config`` is the rig file's section."""

    config: Any
    slots: list[Slot]


def attach_fixture(config, bus_for: Callable[[str], Any], *, clock, attachments: Callable[[int], dict] | None = None
                   ) -> Fixture:
    """Open every slot of a ``fixture:`` section: its sensor (and an MPU-9150's AK8975) behind its channel.

    Parameters
    ----------
    config : rig.config.fixture.FixtureConfig
    bus_for : callable
        Bus name of the rig file -> an open smbus2-compatible bus (called once per name).
    clock : the rig's clock
    attachments : callable, optional
        Slot index -> files for the slot's session (the simulated rig's ``sim_truth.yaml``).
    """
    switches: dict[str, BusSwitches] = {}
    slots = []
    for i, sc in enumerate(config.slots):
        if sc.bus not in switches:
            switches[sc.bus] = BusSwitches(bus_for(sc.bus), sc.bus)
        sw = switches[sc.bus]

        def select(sw=sw, mux=sc.mux, channel=sc.channel) -> None:
            sw.select(mux, channel)

        select()
        sensor = Behind(open_sensor(sc.model, sw.bus, sc.address, clock=clock), select)
        mag = Behind(Ak8975(sw.bus, clock=clock), select) if chip_spec(sc.model).has_magnetometer else None
        slots.append(Slot(i, sc, sensor, mag, dict(attachments(i)) if attachments is not None else {}))
    return Fixture(config, slots)


def attach_hardware_fixture(rig, rig_file) -> Fixture:
    """Open a hardware rig file's ``fixture:`` on its buses (``/dev/i2c-N``, or a bus another part of this program
    provides by name: :func:`rig.devices.buses.register_bus`); ``rig.sensor`` and ``rig.magnetometer`` are then the
    first slot's (what the checks before anything moves look at). The buses close with the rig."""

    def bus_for(name: str):
        bus = open_bus(name, where=str(rig_file.path))
        rig.closers.append(bus.close)
        return bus

    fixture = attach_fixture(rig_file.fixture, bus_for, clock=rig.clock)
    rig.fixture = fixture
    rig.sensor = fixture.slots[0].sensor
    rig.magnetometer = fixture.slots[0].magnetometer
    return fixture

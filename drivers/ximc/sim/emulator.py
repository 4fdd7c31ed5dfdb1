"""A virtual 8SMC5-USB controller with an 8MR191 rotation stage, served on a pseudo-terminal.

Any serial program (our ``Stage``, Standa's own libximc via ``xi-com:/dev/pts/N``) talks to
it as to hardware. :class:`ControllerEmulator` is a thin shell: the protocol and the motion
live in the sans-I/O :class:`~drivers.ximc.sim.controller.Controller`, the port in
:class:`~drivers.ximc.sim.pty.PtyServer`; this class wires them and adds the wall-time answer
latency fault. Motion follows the shared :class:`~drivers.clock.Clock`, so it runs in real
time, scaled time or virtual time alike. ``rig sim`` starts some from the command line.
"""

from __future__ import annotations

import time

from drivers.clock import Clock, MonotonicClock
from drivers.ximc.sim.axis import DEG_PER_STEP, USTEPS, StageModel
from drivers.ximc.sim.controller import Controller, split_usteps
from drivers.ximc.sim.faults import XimcFaults
from drivers.ximc.sim.pty import PtyServer

__all__ = ["DEG_PER_STEP", "USTEPS", "ControllerEmulator", "StageModel", "XimcFaults", "split_usteps"]


def _controller_attribute(name: str, doc: str) -> property:
    """A read/write attribute of the emulator that is the sans-I/O controller's."""
    return property(lambda self: getattr(self.controller, name),
                    lambda self, value: setattr(self.controller, name, value), doc=doc)


class ControllerEmulator:
    """One emulated controller + stage on a pseudo-terminal.

    Parameters
    ----------
    serial_number : int
    clock : Clock
        Default real time.
    faults : XimcFaults or None
    stage : StageModel
    seed : int
        Seeds random faults when ``faults.seed`` is 0.

    Attributes
    ----------
    controller : Controller
        The sans-I/O controller (settings, flags, motion).
    path : str or None
        The pty device path once started; ``stable_path`` survives a simulated replug.
    """

    def __init__(self, serial_number: int, *, clock: Clock | None = None, faults: XimcFaults | None = None,
                 stage: StageModel = StageModel(), seed: int = 0) -> None:
        self.controller = Controller(serial_number, clock=clock or MonotonicClock(), faults=faults, stage=stage,
                                     seed=seed)
        self.server = PtyServer(self._on_bytes, name=f"{self.serial_number:08X}", clock=self.clock,
                                vanish=lambda: (self.faults.vanish_at_s, self.faults.vanish_for_s),
                                on_reopen=self.controller.clear_input)

    # -- identity, settings and state -------------------------------------------------------
    move_settings = _controller_attribute("move_settings", "P.MoveSettings the controller holds (``gmov``/``smov``).")
    engine_settings = _controller_attribute("engine_settings", "P.EngineSettings (``geng``/``seng``).")
    home_settings = _controller_attribute("home_settings", "P.HomeSettings (``ghom``/``shom``).")
    firmware = _controller_attribute("firmware", "P.FirmwareVersion answered to ``gfwv``.")
    device_info = _controller_attribute("device_info", "P.DeviceInformation answered to ``geti``.")

    @property
    def serial_number(self) -> int:
        return self.controller.serial_number

    @property
    def clock(self) -> Clock:
        return self.controller.clock

    @property
    def faults(self) -> XimcFaults:
        return self.controller.faults

    @faults.setter
    def faults(self, faults: XimcFaults) -> None:
        self.controller.faults = faults

    @property
    def stage(self) -> StageModel:
        return self.controller.stage

    @property
    def requests_seen(self) -> int:
        return self.controller.requests_seen

    @property
    def path(self) -> str | None:
        return self.server.path

    @property
    def stable_path(self) -> str:
        return self.server.stable_path

    @property
    def replugged(self) -> bool:
        """Whether the port vanished and came back (``faults.vanish_at_s``)."""
        return self.server.replugged

    def position_deg_at(self, t_s):
        """True physical angle of the stage at clock time(s) ``t_s``, deg (scalar or array)."""
        return self.controller.position_deg_at(t_s)

    def speed_deg_s_at(self, t_s):
        """True angular rate of the stage at clock time(s) ``t_s``, deg/s (scalar or array)."""
        return self.controller.speed_deg_s_at(t_s)

    def direction_at(self, t_s):
        """The direction (+1 or -1) the motor last turned at clock time(s) ``t_s`` (the world model's lost
        motion follows it; ``rig.simulation.geometry``)."""
        return self.controller.direction_at(t_s)

    def state_at(self, t_s):
        """(angle deg, rate deg/s, last direction) of the stage at clock time(s) ``t_s``: the three above from one
        evaluation of its motion."""
        return self.controller.state_at(t_s)

    def rest_pose(self, t_s: float) -> tuple[float, float] | None:
        """(physical angle deg, last direction) the stage stands still at from clock time ``t_s`` on; None while
        it moves then (the world model's shortcut for a block of samples at rest)."""
        return self.controller.rest_pose(t_s)

    # -- lifecycle ---------------------------------------------------------------------------
    def start(self) -> str:
        """Open the pseudo-terminal and serve; returns the device path."""
        return self.server.start()

    def stop(self) -> None:
        """Stop serving and remove the pty and its stable path."""
        self.server.stop()

    def _on_bytes(self, data: bytes, arrival_s: float) -> bytes:
        answered = self.controller.requests_answered
        answer = self.controller.receive(data, arrival_s=arrival_s)
        handled = self.controller.requests_answered - answered
        if handled and self.faults.latency_s > 0:
            time.sleep(self.faults.latency_s * handled)
        return answer

"""A rig as the engine drives it: a clock, three axes, a sensor, and optionally a magnetometer
and a climate chamber.

Whatever opened it (hardware from a rig file, the simulated rig, the replay of a session: see
:mod:`rig.devices.registry`), the engine gets the same :class:`Rig` and never asks which kind it
is. What differs between kinds is data on the rig, not branches in the engine: how stillness is
judged (``settle``), which files describe it in the session (``attachments``), which devices want
to know that a step begins (``step_listeners``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Protocol

from drivers.clock import Clock
from rig.config.rigfile import AxisConfig
from rig.planning.kinematics import STAGE_AXES


@dataclass(frozen=True)
class LostSamples:
    """Why a capture lost samples (its sensor's FIFO overflowed), in the words of the rig's clock.

    ``reason`` is one phrase for the step's flag and the end of the run, ``advice`` what to do about
    it (may be empty). ``stop_run``: the loss comes from the clock's own pace and would repeat at
    every later step, so the run stops (motors stopped, session resumable) instead of recording steps
    with holes; ``resume_options`` are the ``rig run --resume`` options that avoid it.
    """

    reason: str
    advice: str = ""
    stop_run: bool = False
    resume_options: str = ""


#: the explanation of a clock that keeps wall time (hardware): the computer read the FIFO too late
HOST_LOST_SAMPLES = LostSamples("this computer did not read the sensor's FIFO before it filled (was it busy?)")


class PacedClock(Protocol):
    """What a rig's clock may add to ``now`` and ``sleep`` when it runs at a pace of its own against
    wall time (a time-scaled simulated rig): the engine asks the clock, never the rig's kind.

    ``explain_lost_samples()`` says why samples were lost (a clock without it keeps wall time:
    :data:`HOST_LOST_SAMPLES`); ``check_keep_up(model, settings)`` refuses (RigInputError, one line)
    a pace this machine cannot keep up with for that sensor at those settings.
    """

    def explain_lost_samples(self) -> LostSamples: ...

    def check_keep_up(self, model: str, settings) -> None: ...


class Chamber(Protocol):
    """A climate chamber the engine can set (simulated chamber, a driver of a real one)."""

    def set_target_c(self, target_c: float) -> None: ...


class RampingChamber(Chamber, Protocol):
    """A chamber that ramps its set-point by itself (the ``ramp:`` step, docs/procedures.md). A
    chamber without ``ramp_to_c`` still runs ramp procedures: the operator starts each ramp."""

    def ramp_to_c(self, to_c: float, rate_c_per_min: float, from_c: float | None = None) -> float:
        """Ramp the set-point from ``from_c`` (None: where it is) to ``to_c`` (C) at ``rate_c_per_min``
        and hold it there; return the ramp's duration, s."""
        ...


@dataclass
class Axis:
    """One stage of the turntable: its rig-file configuration and its driver.

    Angles: ``kinematic`` is the axis angle of the kinematics contract (docs/kinematics.md),
    ``stage`` the controller's own position; ``kinematic = sign * (stage - home_offset)``.
    """

    name: str
    config: AxisConfig
    stage: Any  # drivers.ximc.stage.Stage

    def stage_angle_deg(self, kinematic_deg: float) -> float:
        """Stage (controller) angle that puts the axis at ``kinematic_deg``."""
        return self.config.sign * kinematic_deg + self.config.home_offset_deg

    def kinematic_angle_deg(self, stage_deg: float) -> float:
        """Kinematic angle of the axis when the controller reads ``stage_deg``."""
        return self.config.sign * (stage_deg - self.config.home_offset_deg)


@dataclass
class Rig:
    """Everything a run drives.

    Parameters
    ----------
    kind : str
        The registry name it was opened with ("hardware", "sim", "replay"); recorded, never
        branched on.
    turntable : str
        What the turntable is, for the session ("standa-8smc", "sim:8smc5-emulator", ...).
    settle : str
        How the engine knows the table is still: "accelerometer" (watch the sensor until its
        windows agree) or "none" (the samples were recorded after settling: replay).
    seed : int | None
        Seed of a simulated sensor: part of the rig's identity (a resume must use the same).
    attachments : dict
        Files (name -> text) stored in a new session directory, e.g. ``sim_truth.yaml``.
    step_listeners : list
        Called with the step index when a step begins (a replayed sensor seeks its recording).
    fixture : rig.devices.fixture.Fixture | None
        The slots of a rig file's ``fixture:`` section, opened (None: the rig has its one ``sensor``);
        ``sensor`` is then the first slot's, for the checks made before anything moves.
    remount : callable | None
        Called with the sensor's turn in its fixture (3x3, sensor frame -> fixture frame, relative to the
        reference mounting) once the operator has confirmed a prompt step with ``mount:``: a simulated rig turns
        its simulated sensor; None on hardware (the technician turned it).
    """

    kind: str
    clock: Clock
    axes: dict[str, Axis]
    sensor: Any  # drivers.sensors.base.AccelSensor
    turntable: str = "standa-8smc"
    home_policy: str = "zero"  # none | zero | home
    chamber: Chamber | None = None
    magnetometer: Any | None = None  # drivers.sensors.ak8975.Ak8975-like: configure(), read_field_ut()
    site_field: dict | None = None  # {field_ut, inclination_deg, declination_deg}
    settle: str = "accelerometer"
    seed: int | None = None
    rig_file: str | None = None
    attachments: dict[str, str] = field(default_factory=dict)
    step_listeners: list[Callable[[int], None]] = field(default_factory=list)
    closers: list[Callable[[], None]] = field(default_factory=list)
    closed: bool = False
    fixture: Any | None = None  # rig.devices.fixture.Fixture
    remount: Callable[[Any], None] | None = None
    #: the unit's own accelerometer bias stability (calib.numerics.stability.BiasStability, from its noise profile,
    #: docs/noise.md) when the workflow found one for the sensor it opened; the accuracy-target predictor's, in place
    #: of the chip family's figures
    unit_accel_stability: Any | None = None

    @property
    def stages(self) -> dict[str, Any]:
        """Axis name -> stage driver."""
        return {name: axis.stage for name, axis in self.axes.items()}

    def begin_step(self, index: int) -> None:
        """Tell the devices that want to know that step ``index`` begins."""
        for listener in self.step_listeners:
            listener(index)

    def explain_lost_samples(self) -> LostSamples:
        """Why this rig's captures lose samples, as its clock explains it (:class:`PacedClock`)."""
        explain = getattr(self.clock, "explain_lost_samples", None)
        return explain() if explain is not None else HOST_LOST_SAMPLES

    def check_keep_up(self, settings) -> None:
        """Refuse (RigInputError) a clock pace this machine cannot keep up with for the sensor at
        ``settings`` (a ``SensorSettings``); nothing to check for wall time or virtual time."""
        check = getattr(self.clock, "check_keep_up", None)
        if check is not None:
            check(self.sensor.model, settings)

    def describe(self) -> dict:
        """Identity of every device, for the session manifest's ``rig`` section."""
        axes = {}
        for name in STAGE_AXES:
            axis = self.axes[name]
            ident = axis.stage.identify()
            axes[name] = {"port": axis.config.port, "serial": ident.serial_number, "firmware": ident.firmware,
                          "device": ident.device, "sign": axis.config.sign,
                          "home_offset_deg": axis.config.home_offset_deg}
        out = {"turntable": {"kind": self.turntable, "axes": axes}, "sensor": describe_sensor(self.sensor),
               "rig_file": self.rig_file}
        if self.site_field is not None:
            out["site"] = dict(self.site_field)
        return out

    def close(self) -> None:
        """Close every driver and stop what the opener started; never raises; idempotent."""
        if self.closed:
            return
        self.closed = True
        for axis in self.axes.values():
            _quietly(axis.stage.close)
        for closer in reversed(self.closers):
            _quietly(closer)


def describe_sensor(sensor) -> dict:
    """The sensor's identity and settings, for the manifest's ``rig.sensor``."""
    info = {
        "model": sensor.model, "address": int(sensor.address), "identity": sensor.identify().to_dict(),
        "accel_range_g": int(sensor.accel_range_g), "accel_lsb_per_g": float(sensor.accel_lsb_per_g),
        "sample_rate_hz": float(sensor.sample_rate_hz), "has_temperature": bool(sensor.has_temperature),
    }
    if getattr(sensor, "has_gyro", False):
        info["gyro_range_dps"] = getattr(sensor, "gyro_range_dps", None)
        info["gyro_lsb_per_dps"] = getattr(sensor, "gyro_lsb_per_dps", None)
    return info


def _quietly(action: Callable[[], None]) -> None:
    try:
        action()
    except Exception:  # noqa: BLE001 - closing: nothing more can be done, and the others must close too
        pass

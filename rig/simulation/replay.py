"""The ``replay`` rig kind: a rig that serves a recorded session.

It has emulated controllers (so every move goes through the real Stage driver and protocol), a
:class:`ReplaySensor` with the ``AccelSensor`` interface of the I2C drivers serving each step's
recorded samples in clock time, the recorded magnetometer readings, and a chamber whose
thermometer reads what the recording read. The engine, the session writer and the solver are the
ones a live run uses (``rig.workflow.replay``), so a replay gives the identical calibration.
"""

from __future__ import annotations

import numpy as np

from drivers.clock import VirtualClock
from drivers.sensors.base import CaptureStats, SampleBlock, SensorError, SensorIdentity
from drivers.ximc.sim.emulator import ControllerEmulator
from drivers.ximc.stage_spec import MAX_SPEED_DEG_S
from drivers.sensors.regs.ak8975 import DEFAULT_ADDRESS as AK8975_ADDRESS
from rig.config.rigfile import AxisConfig
from rig.devices.hardware import open_stages
from rig.devices.registry import register_rig_kind
from rig.devices.rig import Rig
from rig.planning.kinematics import STAGE_AXES
from rig.session import MAG_COUNTS_PER_UT
from rig.simulation.simulated import TRANSPORT_OPENERS, default_transport

#: the replay table moves fast and has no limits: the recording already proved the poses legal
REPLAY_AXIS = AxisConfig(port=None, speed_deg_s=MAX_SPEED_DEG_S, accel_deg_s2=200.0, soft_limits_deg=(-36000.0, 36000.0),
                         cable_wrap_deg=36000.0)


class ReplaySensor:
    """Serves a session's recorded samples, one step at a time, through the AccelSensor interface."""

    #: a replay has no FIFO to overflow; the host reads it as it would a 32-entry one
    fifo_samples = 32

    def __init__(self, session, clock) -> None:
        s = session.info.rig.sensor
        self.session = session
        self.clock = clock
        self.model = s.model or "replay"
        self.address = int(s.address or 0)
        self.has_temperature = bool(s.has_temperature)
        self.has_gyro = "gyro_counts" in session.samples and bool(s.gyro_lsb_per_dps)
        self.accel_lsb_per_g = float(s.accel_lsb_per_g)
        self.gyro_lsb_per_dps = float(s.gyro_lsb_per_dps) if self.has_gyro else None
        self.gyro_range_dps = s.gyro_range_dps
        self.sample_rate_hz = float(s.sample_rate_hz)
        self.accel_range_g = int(s.accel_range_g or 0)
        self.stats = CaptureStats()
        self._step: int | None = None
        self._cursor = 0
        self._t_clock0 = 0.0
        self._data = None
        self._temp_c = None

    def identify(self) -> SensorIdentity:
        """The identity the recording holds (the chip answered it when the session was recorded)."""
        recorded = self.session.info.rig.sensor.identity or {}
        return SensorIdentity(model=self.model, address=self.address,
                              identity_register=recorded.get("identity_register"),
                              identity_value=recorded.get("identity_value"), bus="replay")

    def configure(self, settings) -> None:
        """Recorded data has the recorded settings; nothing to configure."""

    def seek_step(self, index: int) -> None:
        self._step = index
        self._data = self.session.step_samples(index)
        self._cursor = 0
        stats = self.session.info.steps[index].stats
        self._temp_c = stats.temp_c if stats is not None else None

    def read_temperature_c(self) -> float:
        """The temperature the recording reached in this step (temperature steps), C."""
        if self._temp_c is None:
            raise SensorError(f"replay: step {self._step + 1} of the recording has no temperature")
        return float(self._temp_c)

    def start(self) -> None:
        self._t_clock0 = self.clock.now()

    def stop(self) -> None:
        pass

    def read(self) -> SampleBlock:
        d = self._data
        if d is None or self._cursor >= len(d["t_s"]):
            return _empty_block(self.has_gyro)
        t_rec = d["t_s"]
        elapsed = self.clock.now() - self._t_clock0
        end = int(np.searchsorted(t_rec - t_rec[0], elapsed, side="right"))
        end = max(end, self._cursor)
        sl = slice(self._cursor, end)
        self._cursor = end
        temp = d["temp_c"][sl] if d.get("temp_c") is not None else np.full(end - sl.start, np.nan)
        # the recorded session times become the sample times, so the replayed session matches
        gyro = d["gyro_counts"][sl].astype(np.int64) if self.has_gyro else None
        return SampleBlock(t_s=t_rec[sl], accel_counts=d["accel_counts"][sl], temp_c=temp, gyro_counts=gyro)


class ReplayMagnetometer:
    """Serves a session's recorded magnetometer readings (uT), one step at a time."""

    model = "AK8975"

    def __init__(self, session) -> None:
        info = session.info.rig.sensor.magnetometer
        self.session = session
        self.address = int(info.address if info and info.address is not None else AK8975_ADDRESS)
        self.asa_factor = np.asarray(info.asa_factor if info and info.asa_factor is not None else [1.0] * 3, float)
        self.lsb_per_ut = float(info.mag_lsb_per_ut if info and info.mag_lsb_per_ut else MAG_COUNTS_PER_UT)
        self._rows = np.empty((0, 3))
        self._cursor = 0

    def configure(self) -> None:
        """Recorded data: nothing to configure."""

    def seek_step(self, index: int) -> None:
        m = self.session.step_samples(index)["mag_counts"]
        self._rows = m[np.all(np.isfinite(m), axis=1)]
        self._cursor = 0

    def read_field_ut(self) -> np.ndarray:
        if self._cursor >= len(self._rows):
            raise SensorError("replay: the recording has no more magnetometer readings for this step")
        v = self._rows[self._cursor] / self.lsb_per_ut
        self._cursor += 1
        return v


def _empty_block(has_gyro: bool) -> SampleBlock:
    return SampleBlock(t_s=np.empty(0), accel_counts=np.empty((0, 3), np.int64), temp_c=np.empty(0),
                       gyro_counts=np.empty((0, 3), np.int64) if has_gyro else None)




class ReplayChamber:
    """The recording's chamber: set-points are noted, the temperatures come from the recording."""

    def __init__(self) -> None:
        self.target_c: float | None = None

    def set_target_c(self, target_c: float) -> None:
        self.target_c = float(target_c)


def open_replay_rig(session, *, seed: int | None = None, time_scale: float | None = None,
                    clock: str | None = None) -> Rig:
    """A rig that serves ``session`` (a loaded ``rig.session`` Session) in virtual time, its emulated
    controllers reached as ``$RIG_SIM_TRANSPORT`` says (pseudo-terminals by default; ``time_scale`` and
    ``clock`` do not apply: a replay has no time of its own to keep)."""
    vclock = VirtualClock()
    emulators = [ControllerEmulator(0x7E00 + i, clock=vclock) for i in range(3)]
    closers = [e.stop for e in emulators]
    try:
        ports, closers = TRANSPORT_OPENERS[default_transport()](emulators, vclock)
        axes = open_stages({n: _replay_axis(ports[n], emulators[i].serial_number) for i, n in enumerate(STAGE_AXES)},
                           vclock)
    except Exception:
        for close in closers:
            close()
        raise
    sensor = ReplaySensor(session, vclock)
    mag = ReplayMagnetometer(session) if "mag_counts" in session.samples else None
    rig = Rig(kind="replay", clock=vclock, axes=axes, sensor=sensor, turntable="replay:8smc5-emulator",
              home_policy="zero", chamber=ReplayChamber(), magnetometer=mag,
              site_field=session.info.rig.site.model_dump() if session.info.rig.site else None,
              settle="none", step_listeners=[sensor.seek_step] + ([mag.seek_step] if mag is not None else []))
    rig.closers.extend(closers)
    return rig


def _replay_axis(port: str, serial: int) -> AxisConfig:
    return REPLAY_AXIS.with_port(port, serial)


register_rig_kind("replay", open_replay_rig)

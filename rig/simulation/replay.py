"""``rig replay``: re-run a recorded procedure against a rig that serves the recording.

The replay rig has emulated controllers (so every move goes through the real
Stage driver and protocol) and a :class:`ReplaySensor` that implements the
same ``AccelSensor`` interface as the I2C drivers, serving each step's
recorded samples in clock time. The runner, the session writer and the solver
are the ones a live run uses, so a replay gives the identical calibration.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from drivers.clock import VirtualClock
from drivers.sensors.base import CaptureStats, SampleBlock, SensorIdentity
from drivers.ximc.sim.emulator import ControllerEmulator
from drivers.ximc.stage import Stage
from rig import __version__
from rig.devices.rig import AXES, AxisSetup, RigHandles
from rig.config.procedure import load_procedure_text
from rig.execution.lifecycle import RunResult, identify
from rig.execution.engine import Runner
from rig.session.store import SessionWriter, load_session
from rig.console import ConsoleUI


class ReplaySensor:
    """Serves a session's recorded samples, one step at a time, through the AccelSensor interface."""

    def __init__(self, session, clock) -> None:
        s = session.manifest["rig"]["sensor"]
        self.session = session
        self.clock = clock
        self.model = s.get("model", "replay")
        self.address = int(s.get("address") or 0)
        self.has_temperature = bool(s.get("has_temperature"))
        self.has_gyro = "gyro_counts" in session.samples and bool(s.get("gyro_lsb_per_dps"))
        self.accel_lsb_per_g = float(s["accel_lsb_per_g"])
        self.gyro_lsb_per_dps = float(s["gyro_lsb_per_dps"]) if self.has_gyro else None
        self.gyro_range_dps = s.get("gyro_range_dps")
        self.sample_rate_hz = float(s["sample_rate_hz"])
        self.accel_range_g = int(s.get("accel_range_g") or 0)
        self.stats = CaptureStats()
        self._step: int | None = None
        self._cursor = 0
        self._t_clock0 = 0.0
        self._data = None

    def identify(self) -> SensorIdentity:
        return SensorIdentity(model=self.model, address=self.address, identity_register=None,
                              identity_value=None, bus="replay")

    def configure(self, settings) -> None:
        """Recorded data has the recorded settings; nothing to configure."""

    def seek_step(self, index: int) -> None:
        self._step = index
        self._data = self.session.step_samples(index)
        self._cursor = 0

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
        info = session.manifest["rig"]["sensor"].get("magnetometer") or {}
        self.session = session
        self.address = int(info.get("address", 0x0C))
        self.asa_factor = np.asarray(info.get("asa_factor", [1.0, 1.0, 1.0]), float)
        self.lsb_per_ut = float(info.get("mag_lsb_per_ut", 100.0))
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
            from drivers.sensors.base import SensorError
            raise SensorError("replay: the recording has no more magnetometer readings for this step")
        v = self._rows[self._cursor] / self.lsb_per_ut
        self._cursor += 1
        return v


def _empty_block(has_gyro: bool) -> SampleBlock:
    return SampleBlock(t_s=np.empty(0), accel_counts=np.empty((0, 3), np.int64), temp_c=np.empty(0),
                       gyro_counts=np.empty((0, 3), np.int64) if has_gyro else None)


def replay_session(session_dir, *, out_dir=None, ui: ConsoleUI | None = None) -> RunResult:
    """Replay a session into a new session directory and solve it."""
    ui = ui or ConsoleUI(quiet=True)
    original = load_session(session_dir)
    manifest0 = original.manifest
    procedure = load_procedure_text(manifest0["procedure"]["text"], manifest0["procedure"].get("file") or "<session>")
    clock = VirtualClock()
    emulators = [ControllerEmulator(0x7E00 + i, clock=clock) for i in range(3)]
    ports = {n: e.start() for n, e in zip(AXES, emulators)}
    stages = {}
    sensor = ReplaySensor(original, clock)
    try:
        for n in AXES:
            stages[n] = Stage(ports[n], clock=clock, name=n)
            stages[n].open()
        axes = {n: AxisSetup(name=n, port=ports[n], serial=emulators[i].serial_number,
                             speed_deg_s=48.0, accel_deg_s2=200.0, soft_limits_deg=(-1e6, 1e6),
                             cable_wrap_deg=1e6)
                for i, n in enumerate(AXES)}
        mag = ReplayMagnetometer(original) if "mag_counts" in original.samples else None
        rig = RigHandles(kind="replay", clock=clock, stages=stages, axes=axes, sensor=sensor,
                         sensor_model=sensor.model, sensor_address=sensor.address, home_policy="zero",
                         is_replay=True, on_step_begin=sensor.seek_step, magnetometer=mag,
                         site_field=manifest0["rig"].get("site"))
        out_root = Path(out_dir) if out_dir is not None else Path(session_dir).resolve().parent
        text = manifest0["procedure"]["text"]
        manifest = {
            "id": f"{original.id}-replay-{datetime.now(timezone.utc).strftime('%Y%m%dT%H%M%SZ')}",
            "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "status": "running",
            "replay_of": original.id,
            "procedure": dict(manifest0["procedure"], sha256=hashlib.sha256(text.encode()).hexdigest()),
            "software": {"name": "rig-calibration", "version": __version__},
            "steps": [step.to_manifest() for step in procedure.expanded_steps()],
        }
        manifest["rig"] = identify(rig)
        manifest["rig"]["sensor"].update({k: manifest0["rig"]["sensor"].get(k) for k in
                                          ("model", "address", "accel_range_g", "accel_lsb_per_g",
                                           "sample_rate_hz", "has_temperature", "gyro_range_dps",
                                           "gyro_lsb_per_dps", "magnetometer")
                                          if k in manifest0["rig"]["sensor"]})
        writer = SessionWriter.create(out_root, manifest["id"], manifest,
                                      columns=tuple(manifest0.get("columns") or ()) or None)
        # recorded sample times are session times: make the runner's session clock start at 0 now
        runner = Runner(procedure, rig, writer, ui, time_offset_s=clock.now())
        runner.prepare(resuming=False)
        try:
            outcomes = runner.run()
        except BaseException as exc:
            writer.event("abort", reason=str(exc))
            writer.set_status("aborted")
            raise
    finally:
        for st in stages.values():
            st.close()
        for e in emulators:
            e.stop()
    cal = cal_path = None
    if procedure.solve is not None:
        from rig.analysis.solve import solve_session
        cal, cal_path = solve_session(writer.session_dir)
    writer.set_status("complete")
    return RunResult(writer.session_dir, "complete", outcomes, cal_path, cal)

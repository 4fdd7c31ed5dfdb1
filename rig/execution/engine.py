"""The procedure runner: move, settle, capture, check, record; stop the motors on any error.

One :class:`Runner` executes the expanded steps of a procedure on a rig
(:class:`rig.devices.rig.RigHandles`) and records into a session
(:class:`rig.session.store.SessionWriter`). Every finished step is fsynced before
the next begins, so an interrupted run resumes from the first incomplete step
(``first_step``) without repeating finished ones.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from rig.planning import targets as planning
from rig.devices.rig import AXES, RigHandles
from drivers.sensors.base import SensorError
from rig.execution.checks import CheckLimits, check_step
from rig.errors import RigInputError
from rig.execution.settle import SettleDetector, SettleRule
from rig.console import ConsoleUI, StepProgress


class RunError(Exception):
    """A run cannot continue; the message is one line for the technician."""


class RunAborted(Exception):
    """The operator interrupted the run (Ctrl-C or 'abort' at a prompt)."""


@dataclass
class StepOutcome:
    index: int
    status: str  # complete | flagged
    n_samples: int
    problems: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class RunnerOptions:
    max_attempts: int = 3  # captures of one step before it is flagged
    keep_settle_windows: bool = False  # count the settle detector's still windows as captured data
    position_tolerance_deg: float = 0.02
    move_timeout_s: float = 120.0
    limits: CheckLimits = field(default_factory=CheckLimits)
    temp_window_s: float = 1.0  # averaging window for the thermometer while waiting


class Runner:
    """Execute a procedure's steps on a rig, recording a session.

    Parameters
    ----------
    procedure : rig.config.procedure.Procedure
    rig : RigHandles
    writer : rig.session.store.SessionWriter
    ui : ConsoleUI
    first_step : int
        Index of the first step to execute (resume); earlier steps are kept as recorded.
    """

    def __init__(self, procedure, rig: RigHandles, writer, ui: ConsoleUI | None = None,
                 *, first_step: int = 0, options: RunnerOptions = RunnerOptions(),
                 time_offset_s: float = 0.0) -> None:
        self.procedure = procedure
        self.rig = rig
        self.writer = writer
        self.ui = ui or ConsoleUI(quiet=True)
        self.first_step = first_step
        self.options = options
        self.steps = procedure.expanded_steps()
        self.outcomes: list[StepOutcome] = []
        self._t0 = rig.clock.now() - time_offset_s
        self._wall0 = time.monotonic()
        self._io_retries_seen = getattr(rig.sensor.stats, "io_retries", 0)
        self._step_estimates = self._estimate_steps()

    # -- public -----------------------------------------------------------------------
    def session_time(self) -> float:
        """Seconds since the session started (continues across resumes)."""
        return self.rig.clock.now() - self._t0

    def preflight(self, start_deg: dict[str, float] | None = None) -> None:
        """Plan every remaining move before anything moves: an unreachable pose (soft limits,
        cable wrap) is refused up front, naming the step and the axis."""
        cur = dict(start_deg or {n: 0.0 for n in AXES})
        for step in self.steps[self.first_step:]:
            if step.kind not in ("static", "rate"):
                continue
            if step.kind == "rate":
                self._preflight_rate(step)
            for i, name in enumerate(AXES):
                ax = self.rig.axes[name]
                wanted = self.rig.stage_angle_deg(name, float(step.angles_deg[i]))
                try:
                    cur[name] = planning.plan_axis_target(cur[name], wanted, ax.soft_limits_deg, ax.cable_wrap_deg,
                                                          axis=name)
                except RigInputError as exc:
                    raise RigInputError(self.procedure.path, step.source_line, f"steps: {step.name}: {name}",
                                        exc.message) from None

    def _preflight_rate(self, step) -> None:
        ax = self.rig.axes[step.rate_axis]
        rate = abs(step.rate_deg_s)
        where = f"steps: {step.name}: {step.rate_axis}"
        if rate > 48.0 + 1e-9:
            raise RigInputError(self.procedure.path, step.source_line, where,
                                f"rate {rate:g} deg/s is above the stage's limit of 48 deg/s")
        if not ax.slip_ring:
            travel = rate * (step.dwell.seconds + step.settle.min_s + 2 * rate / ax.accel_deg_s2 + 1.0)
            if travel > ax.cable_wrap_deg:
                raise RigInputError(self.procedure.path, step.source_line, where,
                                    f"spinning {step.dwell.seconds:g} s at {rate:g} deg/s turns {travel:.0f} deg, beyond "
                                    f"the cable wrap of {ax.cable_wrap_deg:g} deg; set slip_ring: true for "
                                    f"{step.rate_axis} in the rig file if it has one, or shorten the step")

    def prepare(self, resuming: bool) -> None:
        """Apply the rig's home/zero policy and the move and sensor settings."""
        start = {n: self.rig.stages[n].get_position_deg() for n in AXES} if resuming else None
        self.preflight(start)
        for name in AXES:
            st = self.rig.stages[name]
            ax = self.rig.axes[name]
            st.set_speed_deg_s(ax.speed_deg_s, accel_deg_s2=ax.accel_deg_s2)
        policy = self.rig.home_policy
        if policy == "home":
            for name in AXES:
                self.writer.event("home", t_s=self.session_time(), axis=name)
                self.rig.stages[name].command_home()
            for name in AXES:
                self.rig.stages[name].command_wait_for_stop(10, timeout_s=self.options.move_timeout_s)
                self.rig.stages[name].command_zero()
        elif policy == "zero" and not resuming:
            for name in AXES:
                self.writer.event("zero", t_s=self.session_time(), axis=name)
                self.rig.stages[name].command_zero()

    def run(self) -> list[StepOutcome]:
        """Execute the steps from ``first_step`` on; stop all motors on any error."""
        try:
            for step in self.steps[self.first_step:]:
                if self.rig.on_step_begin is not None:
                    self.rig.on_step_begin(step.index)
                self._run_step(step)
        except KeyboardInterrupt:
            self.stop_motors(soft=True)
            raise RunAborted("interrupted by the operator") from None
        except BaseException:
            self.stop_motors(soft=False)
            raise
        return self.outcomes

    def stop_motors(self, soft: bool) -> None:
        """Stop every axis (soft: decelerate; else immediately); never raises."""
        for name in AXES:
            st = self.rig.stages.get(name)
            if st is None:
                continue
            try:
                st.command_sstp() if soft else st.command_stop()
            except Exception:  # noqa: BLE001 - the port may be gone; try the others
                try:
                    st.command_stop()
                except Exception:  # noqa: BLE001
                    pass

    # -- steps ------------------------------------------------------------------------
    def _run_step(self, step) -> None:
        kind = step.kind
        if kind == "prompt":
            self._progress(step, "prompt")
            ok = self.ui.confirm(step.prompt)
            self.writer.event("prompt", t_s=self.session_time(), step=step.index, text=step.prompt,
                              answer="yes" if ok else "abort")
            if not ok:
                raise RunAborted(f"operator aborted at step {step.index + 1} ({step.name})")
            self.writer.complete_step(step.index, {"t_end_s": self.session_time()})
            return
        if kind == "thermal":
            self._temperature_step(step)
            return
        if kind == "rate":
            self._rate_step(step)
            return
        self._static_step(step)

    def _static_step(self, step) -> None:
        self._move_to(step)
        attempts = 0
        while True:
            attempts += 1
            try:
                t, a, temp, gyro, settle_s, noise_g, problems_pre = self._settle_and_capture(step)
            except SensorError as exc:
                if attempts >= self.options.max_attempts:
                    raise
                self.writer.event("warning", t_s=self.session_time(), step=step.index, source="sensor",
                                  message=f"sensor error, measuring step {step.index + 1} again: {exc}")
                self.ui.warn(f"step {step.index + 1} ({step.name}): {exc}; measuring again")
                self.rig.clock.sleep(1.0)
                continue
            check = check_step(a, temp, self._n_expected(step), self.rig.sensor.has_temperature,
                               self.options.limits)
            problems = problems_pre + check.problems
            if not problems or attempts >= self.options.max_attempts:
                break
            self.writer.event("warning", t_s=self.session_time(), step=step.index,
                              message=f"re-measuring step {step.index + 1} ({step.name}): " + "; ".join(problems),
                              attempt=attempts)
            self.ui.warn(f"step {step.index + 1} ({step.name}): {'; '.join(problems)}; measuring again")
        if self.rig.sensor.stats.io_retries > self._io_retries_seen:
            n = self.rig.sensor.stats.io_retries - self._io_retries_seen
            self._io_retries_seen = self.rig.sensor.stats.io_retries
            self.writer.event("warning", t_s=self.session_time(), step=step.index, source="sensor",
                              message=f"{n} I2C transfer(s) failed and were retried")
        status = "complete" if not problems else "flagged"
        if problems:
            self.writer.event("warning", t_s=self.session_time(), step=step.index,
                              message=f"step {step.index + 1} ({step.name}) flagged and left out of the solve: "
                                      + "; ".join(problems))
            self.ui.warn(f"step {step.index + 1} ({step.name}) flagged: {'; '.join(problems)}")
        ts = t - self._t0
        angles = self._angles_now()
        mag = self._read_magnetometer(step, len(ts))
        self.writer.append_samples(step.index, ts, a, temp_c=temp if self.rig.sensor.has_temperature else None,
                                   gyro_counts=gyro, angles_deg=np.broadcast_to(angles, (len(ts), 3)),
                                   mag_counts=mag)
        lsb = self.rig.sensor.accel_lsb_per_g
        stats = {
            "n_samples": int(len(ts)),
            "t_start_s": float(ts[0]) if len(ts) else None,
            "t_end_s": float(ts[-1]) if len(ts) else None,
            "temp_c": float(np.nanmean(temp)) if self.rig.sensor.has_temperature and len(temp) else None,
            "noise_g": [float(x) for x in (a.std(axis=0, ddof=1) / lsb)] if len(a) > 1 else None,
            "settle_s": settle_s,
            "attempts": attempts,
            "problems": problems,
            "angles_measured_deg": [float(x) for x in angles],
        }
        self.writer.complete_step(step.index, stats, status=status)
        self.writer.event("capture", t_s=self.session_time(), step=step.index, n_samples=int(len(ts)),
                          status=status)
        self.outcomes.append(StepOutcome(step.index, status, int(len(ts)), problems))

    def _move_to(self, step) -> None:
        self._progress(step, "move")
        targets = {}
        for i, name in enumerate(AXES):
            ax = self.rig.axes[name]
            st = self.rig.stages[name]
            current = st.get_position_deg()
            wanted = self.rig.stage_angle_deg(name, float(step.angles_deg[i]))
            target = planning.plan_axis_target(current, wanted, ax.soft_limits_deg, ax.cable_wrap_deg,
                                               axis=name)
            targets[name] = target
            if abs(target - current) > 1e-6:
                self.writer.event("move", t_s=self.session_time(), step=step.index, axis=name,
                                  from_deg=current, to_deg=target)
                st.move_deg(target)
        self._coarse_wait(targets)
        for name in AXES:
            st = self.rig.stages[name]
            st.command_wait_for_stop(50, timeout_s=self.options.move_timeout_s)
            reached = st.get_position_deg()
            if abs(reached - targets[name]) > self.options.position_tolerance_deg:
                from drivers.ximc.stage import TurntableError
                raise TurntableError(st.port, "move",
                                     f"{name} stopped at {reached:.4f} deg, short of target {targets[name]:.4f} deg",
                                     name=name)

    def _coarse_wait(self, targets: dict) -> None:
        """Wait out the bulk of a long move polling every 0.5 s (errors still seen within 0.5 s),
        leaving the last 0.3 s to the 50 ms poll of ``command_wait_for_stop``."""
        t_end = self.rig.clock.now()
        for name, target in targets.items():
            ax = self.rig.axes[name]
            dist = abs(target - self.rig.stages[name].get_position_deg())
            t_end = max(t_end, self.rig.clock.now() + planning.move_time_s(dist, ax.speed_deg_s, ax.accel_deg_s2))
        while t_end - self.rig.clock.now() > 0.8:
            self.rig.clock.sleep(0.5)
            for name in targets:
                st = self.rig.stages[name].get_status()
                if not st.running and st.command_error:
                    return  # command_wait_for_stop raises with the details

    def _read_magnetometer(self, step, n_rows: int):
        """``mag_samples`` AK8975 readings as integer 0.01 uT on the step's first rows (NaN elsewhere)."""
        if not self.procedure.sensor.magnetometer or n_rows == 0:
            return None
        from rig.execution.lifecycle import MAG_LSB_PER_UT
        n = min(self.procedure.sensor.mag_samples, n_rows)
        out = np.full((n_rows, 3), np.nan)
        mag = self.rig.magnetometer
        if hasattr(mag, "seek_step"):
            mag.seek_step(step.index)
        for i in range(n):
            out[i] = np.round(np.asarray(mag.read_field_ut(), float) * MAG_LSB_PER_UT)
        return out

    # -- rate steps (gyroscope) -----------------------------------------------------------
    def _rate_step(self, step) -> None:
        """Spin one axis at a constant rate and capture only the constant-rate part."""
        self._move_to(step)
        name = step.rate_axis
        ax = self.rig.axes[name]
        st = self.rig.stages[name]
        clock = self.rig.clock
        stage_rate = ax.sign * step.rate_deg_s
        self._progress(step, "spin-up")
        self.writer.event("rotate", t_s=self.session_time(), step=step.index, axis=name, rate_deg_s=step.rate_deg_s)
        st.set_speed_deg_s(abs(stage_rate), accel_deg_s2=ax.accel_deg_s2)
        st.command_right() if stage_rate >= 0 else st.command_left()
        try:
            spin_up = abs(stage_rate) / ax.accel_deg_s2 + step.settle.min_s
            clock.sleep(spin_up)
            speed0 = self._stage_speed_deg_s(st)
            if abs(speed0 - stage_rate) > 0.01 * abs(stage_rate) + 0.02:
                raise RunError(f"step {step.index + 1} ({step.name}): {name} turns at {speed0:.3f} deg/s after "
                               f"{spin_up:.1f} s, expected {stage_rate:g} deg/s")
            self.rig.sensor.start()  # (re)starts sampling now: nothing from the spin-up is kept
            self._progress(step, "capture")
            t, a, temp, gyro = self._capture(step, (np.empty(0), np.empty((0, 3), np.int64), np.empty(0),
                                                    np.empty((0, 3), np.int64)), self._poll_s())
            speed1 = self._stage_speed_deg_s(st)
        finally:
            st.command_sstp()
            st.command_wait_for_stop(50, timeout_s=self.options.move_timeout_s)
            st.set_speed_deg_s(ax.speed_deg_s, accel_deg_s2=ax.accel_deg_s2)
        self._wrap_position(name)
        problems = []
        if gyro is None or len(t) == 0:
            raise RunError(f"step {step.index + 1} ({step.name}): the {self.rig.sensor_model} has no gyroscope")
        if abs(speed1 - stage_rate) > 0.01 * abs(stage_rate) + 0.02:
            problems.append(f"the rate changed during capture ({speed0:.3f} -> {speed1:.3f} deg/s)")
        status = "complete" if not problems else "flagged"
        ts = t - self._t0
        self.writer.append_samples(step.index, ts, a, temp_c=temp if self.rig.sensor.has_temperature else None,
                                   gyro_counts=gyro)
        glsb = self.rig.sensor.gyro_lsb_per_dps
        self.writer.complete_step(step.index, {
            "n_samples": int(len(ts)), "t_start_s": float(ts[0]), "t_end_s": float(ts[-1]),
            "temp_c": float(np.nanmean(temp)) if self.rig.sensor.has_temperature else None,
            "stage_rate_deg_s": [speed0, speed1], "problems": problems,
            "gyro_mean_dps": [float(x) for x in gyro.mean(axis=0) / glsb] if glsb else None,
        }, status=status)
        self.writer.event("capture", t_s=self.session_time(), step=step.index, n_samples=int(len(ts)), status=status)
        self.outcomes.append(StepOutcome(step.index, status, int(len(ts)), problems))

    def _stage_speed_deg_s(self, st) -> float:
        s = st.get_status()
        return (s.CurSpeed + s.uCurSpeed / st.usteps_per_step) * st.deg_per_step

    def _wrap_position(self, name: str) -> None:
        """After spinning, renumber the stage position into (-180, 180] (the same physical angle)."""
        st = self.rig.stages[name]
        pos = st.get_position_deg()
        wrapped = (pos + 180.0) % 360.0 - 180.0
        if abs(wrapped - pos) > 1e-9:
            from drivers.ximc.protocol import SetPosition
            steps, usteps = st._deg_to_steps(wrapped)
            st.set_position(SetPosition(steps, usteps))
            self.writer.event("renumber", t_s=self.session_time(), axis=name, from_deg=pos, to_deg=wrapped)

    def _angles_now(self) -> np.ndarray:
        return np.array([self.rig.kinematic_angle_deg(n, self.rig.stages[n].get_position_deg()) for n in AXES])

    def _settle_and_capture(self, step):
        sensor = self.rig.sensor
        overflows0 = sensor.stats.overflows
        clock = self.rig.clock
        rate = sensor.sample_rate_hz
        rule = self._settle_rule(step)
        det = SettleDetector(rule, rate, sensor.accel_lsb_per_g)
        poll = self._poll_s()
        sensor.start()
        t_start = clock.now()
        det.start(t_start)
        problems: list[str] = []
        if self.rig.is_replay:
            # a recording holds only settled samples: capture from its first sample
            empty = (np.empty(0), np.empty((0, 3), np.int64), np.empty(0), None)
            t, a, temp, gyro = self._capture(step, empty, poll)
            noise_g = a.std(axis=0, ddof=1) / sensor.accel_lsb_per_g if len(a) > 1 else np.full(3, np.nan)
            return t, a, temp, gyro, 0.0, noise_g, problems
        self._progress(step, "settle")
        settled = None
        buf: list = []
        while settled is None:
            clock.sleep(poll)
            blk = sensor.read()
            settled = det.feed(blk.t_s, blk.accel_counts, blk.temp_c, blk.gyro_counts)
            buf.append(blk)
            if settled is None and clock.now() - t_start > rule.timeout_s:
                problems.append(f"did not settle within {rule.timeout_s:g} s")
                # capture anyway from here on; the step is flagged
                settled_t = np.empty(0)
                det_keep = (settled_t, np.empty((0, 3), np.int64), np.empty(0),
                            None if blk.gyro_counts is None else np.empty((0, 3), np.int64))
                break
        if settled is not None:
            if self.options.keep_settle_windows:
                det_keep = (settled.keep_t_s, settled.keep_accel, settled.keep_temp_c, settled.keep_gyro)
            else:
                # the windows that proved the table still still hold the tail of the ringing, whose mean
                # biases the step mean by ~0.1 mg (found by rig discover as a spurious drift): start afresh
                det_keep = (np.empty(0), np.empty((0, 3), np.int64), np.empty(0),
                            None if settled.keep_gyro is None else np.empty((0, 3), np.int64))
            settle_s = settled.elapsed_s
            self.writer.event("settle", t_s=self.session_time(), step=step.index, settle_s=settle_s,
                              noise_g=[float(x) for x in settled.noise_g])
        else:
            settle_s = None
        t, a, temp, gyro = self._capture(step, det_keep, poll)
        if sensor.stats.overflows > overflows0:
            problems.append(f"sensor FIFO overflowed {sensor.stats.overflows - overflows0} time(s): samples lost")
        noise_g = a.std(axis=0, ddof=1) / sensor.accel_lsb_per_g if len(a) > 1 else np.full(3, np.nan)
        return t, a, temp, gyro, settle_s, noise_g, problems

    def _capture(self, step, keep, poll):
        sensor = self.rig.sensor
        clock = self.rig.clock
        rate = sensor.sample_rate_hz
        lsb = sensor.accel_lsb_per_g
        dwell = step.dwell
        ts, acc, temps, gyros = [keep[0]], [keep[1]], [keep[2]], [keep[3]] if keep[3] is not None else []
        n = len(keep[0])
        t_begin = clock.now()
        n_target = self._n_expected(step)
        max_s = dwell.max_seconds if dwell.sem_g is not None else None
        while True:
            if n_target and n >= n_target:
                break
            if dwell.sem_g is not None:
                stop_n = _sem_stop_index(np.concatenate(acc), lsb, dwell.sem_g)
                if stop_n is not None:
                    n_target = stop_n
                    break
                if max_s is not None and n >= max_s * rate:
                    n_target = int(round(max_s * rate))
                    break
            if clock.now() - t_begin > self._capture_timeout(step):
                break
            clock.sleep(poll)
            blk = sensor.read()
            if len(blk.t_s):
                ts.append(blk.t_s)
                acc.append(blk.accel_counts)
                temps.append(blk.temp_c)
                if blk.gyro_counts is not None:
                    gyros.append(blk.gyro_counts)
                n += len(blk.t_s)
                self._progress(step, "capture", noise_ug=_noise_ug(acc, lsb),
                               temp_c=float(blk.temp_c[-1]) if len(blk.temp_c) else None,
                               eta_s=(max(n_target - n, 0) / rate) if n_target else None)
        sensor.stop()
        t = np.concatenate(ts)
        a = np.concatenate(acc).astype(np.int64)
        temp = np.concatenate(temps)
        gyro = np.concatenate(gyros).astype(np.int64) if gyros else None
        if n_target:
            t, a, temp = t[:n_target], a[:n_target], temp[:n_target]
            gyro = gyro[:n_target] if gyro is not None else None
        return t, a, temp, gyro

    def _temperature_step(self, step) -> None:
        target = step.temperature
        sensor = self.rig.sensor
        if not sensor.has_temperature:
            raise RunError(f"step {step.index + 1} ({step.name}) waits for the sensor's thermometer, "
                           f"but the {self.rig.sensor_model} has none")
        if self.rig.is_replay:
            self.writer.complete_step(step.index, {"t_end_s": self.session_time(), "replayed": True})
            return
        if target.mode == "wait" and self.rig.chamber is not None:
            self.rig.chamber.set_target_c(target.target_c)
            self.writer.event("chamber", t_s=self.session_time(), step=step.index, setpoint_c=target.target_c)
        else:
            self._progress(step, "prompt")
            ok = self.ui.confirm(f"Set the chamber to {target.target_c:g} C, then confirm.")
            self.writer.event("prompt", t_s=self.session_time(), step=step.index,
                              text=f"set chamber to {target.target_c:g} C", answer="yes" if ok else "abort")
            if not ok:
                raise RunAborted(f"operator aborted at step {step.index + 1} ({step.name})")
            if self.rig.chamber is not None:  # simulated rig: the simulated operator sets the simulated chamber
                self.rig.chamber.set_target_c(target.target_c)
        clock = self.rig.clock
        t_start = clock.now()
        in_band_since = None
        readings: list[tuple[float, float]] = []
        first_c: float | None = None  # the leg's starting temperature (heating or cooling, for discover)
        mean_c = float("nan")
        while True:
            clock.sleep(1.0)
            now = clock.now()
            readings.append((now, sensor.read_temperature_c()))
            if first_c is None:
                first_c = readings[-1][1]
            readings = [(t, c) for t, c in readings if t >= now - max(self.options.temp_window_s, 5.0)]
            mean_c = float(np.mean([c for _, c in readings]))
            if abs(mean_c - target.target_c) <= target.tolerance_c:
                if in_band_since is None:
                    in_band_since = now
                if now - in_band_since >= target.hold_s:
                    break
            else:
                in_band_since = None
            remaining = (target.hold_s - (now - in_band_since)) if in_band_since is not None else None
            self._progress(step, "temperature", temp_c=mean_c, eta_s=remaining)
            if now - t_start > target.timeout_s:
                raise RunError(f"step {step.index + 1} ({step.name}): sensor temperature {mean_c:.2f} C did not "
                               f"reach {target.target_c:g} +- {target.tolerance_c:g} C within {target.timeout_s:g} s")
        self.writer.event("temperature", t_s=self.session_time(), step=step.index, temp_c=mean_c,
                          start_c=first_c, waited_s=clock.now() - t_start)
        self.writer.complete_step(step.index, {"t_end_s": self.session_time(), "temp_c": mean_c,
                                               "waited_s": clock.now() - t_start})
        self.outcomes.append(StepOutcome(step.index, "complete", 0))

    # -- helpers ----------------------------------------------------------------------
    def _n_expected(self, step) -> int:
        d = step.dwell
        rate = self.rig.sensor.sample_rate_hz
        if d.samples is not None:
            return int(d.samples)
        if d.seconds is not None:
            return int(round(d.seconds * rate))
        return 0

    def _capture_timeout(self, step) -> float:
        d = step.dwell
        rate = self.rig.sensor.sample_rate_hz
        nominal = (d.seconds if d.seconds is not None else
                   d.samples / rate if d.samples is not None else d.max_seconds or 600.0)
        return 2.0 * nominal + 5.0

    def _settle_rule(self, step) -> SettleRule:
        s = step.settle
        return SettleRule(window_s=s.window_s, threshold_g=s.threshold_g, mean_tol_sigma=s.mean_tol_sigma,
                          timeout_s=s.timeout_s, min_s=s.min_s)

    def _poll_s(self) -> float:
        # drain the FIFO well before it can overflow (ADXL345: 32 samples)
        return min(0.05, 8.0 / self.rig.sensor.sample_rate_hz)

    def _estimate_steps(self) -> list[float]:
        """Expected duration of each step (moves at the set speeds, 1 s settle, dwell), s."""
        out, prev = [], np.zeros(3)
        rate = self.rig.sensor.sample_rate_hz
        for s in self.steps:
            if s.kind not in ("static", "rate"):
                out.append(300.0 if s.kind == "thermal" else 0.0)
                continue
            ang = np.asarray(s.angles_deg, float)
            move = max(planning.move_time_s(abs(b - a), self.rig.axes[n].speed_deg_s, self.rig.axes[n].accel_deg_s2)
                       for n, a, b in zip(AXES, prev, ang))
            d = s.dwell
            dwell = d.seconds if d.seconds is not None else (d.samples / rate if d.samples else d.max_seconds)
            out.append(move + 1.0 + dwell)
            prev = ang
        return out

    def _progress(self, step, phase: str, **kw) -> None:
        run_eta = sum(self._step_estimates[step.index + 1:]) + (kw.get("eta_s") or 0.0)
        self.ui.progress(StepProgress(index=step.index, total=len(self.steps), name=step.name, phase=phase,
                                      run_eta_s=run_eta, **kw))


def _noise_ug(acc: list[np.ndarray], lsb: float) -> float | None:
    a = np.concatenate(acc) if acc else np.empty((0, 3))
    if len(a) < 3:
        return None
    return float(np.max(a.std(axis=0, ddof=1)) / lsb * 1e6)


def _sem_stop_index(a: np.ndarray, lsb_per_g: float, sem_g: float, step: int = 10, min_n: int = 20) -> int | None:
    """Smallest n (a multiple of ``step``, >= ``min_n``) at which every axis' standard
    error of the mean over the first n samples is at most ``sem_g``; None if not yet.

    Deterministic in the sample sequence, so a replay stops at the same sample.
    """
    n_all = len(a)
    if n_all < min_n:
        return None
    x = a.astype(float) / lsb_per_g
    c1 = np.cumsum(x, axis=0)
    c2 = np.cumsum(x * x, axis=0)
    ns = np.arange(min_n, n_all + 1, step)
    if len(ns) == 0:
        return None
    s1, s2 = c1[ns - 1], c2[ns - 1]
    nn = ns[:, None].astype(float)
    var = np.maximum((s2 - s1 * s1 / nn) / (nn - 1), 0.0)
    sem = np.sqrt(var / nn)
    ok = np.all(sem <= sem_g, axis=1)
    idx = np.flatnonzero(ok)
    return int(ns[idx[0]]) if len(idx) else None


def estimate_duration_s(procedure, rig: RigHandles) -> float:
    """Rough lower bound of a run's duration (moves at set speeds + dwell), s."""
    total = 0.0
    rate = rig.sensor.sample_rate_hz
    prev = np.zeros(3)
    for step in procedure.expanded_steps():
        if step.kind == "static" and step.angles_deg is not None:
            ang = np.asarray(step.angles_deg, float)
            total += max(planning.move_time_s(abs(b - a), rig.axes[n].speed_deg_s, rig.axes[n].accel_deg_s2)
                         for n, a, b in zip(AXES, prev, ang))
            prev = ang
            d = step.dwell
            total += d.seconds if d.seconds is not None else (d.samples / rate if d.samples else 0.0)
    return total

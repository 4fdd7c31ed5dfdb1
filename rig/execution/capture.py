"""Settle and capture: wait until the table is still, then record a step's samples.

The result is a typed :class:`Capture`. How stillness is judged is chosen by the rig's ``settle``
(``SETTLERS``): from the accelerometer itself (hardware, simulated rig), or not at all (a replayed
recording holds only settled samples).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from drivers.sensors.base import SampleBlock
from rig.config.bus_budget import POLL_FIFO_SHARE, POLL_MAX_S  # one poll rule: the capture's and the bus budget's
from rig.execution.context import RunContext, RunError
from rig.execution.settle import SettleDetector, SettleRule


@dataclass
class Capture:
    """One step's capture: the samples, how long settling took (s; None: it never settled) and
    the problems that flag the step."""

    samples: SampleBlock
    settle_s: float | None
    problems: list[str] = field(default_factory=list)


class SamplesLost(RunError):
    """Every attempt at a capture lost samples to the pace of the rig's clock (a time-scaled simulated
    rig outran this machine): the run stops, resumable, rather than record a session with holes."""


def loss_counters(sensor) -> tuple[int, int]:
    """The sensor's (FIFO overflows, samples dropped) so far: what :func:`lost_samples` compares."""
    return sensor.stats.overflows, sensor.stats.dropped


def lost_samples(ctx: RunContext, step, since: tuple[int, int], *, last_attempt: bool = True) -> list[str] | None:
    """The step's problem when the sensor's FIFO overflowed since ``since`` (:func:`loss_counters`), with
    the reason the rig's clock gives (:meth:`rig.devices.rig.Rig.explain_lost_samples`).

    When the clock says the loss comes from its pace (``stop_run``), the step gets no flag: None asks
    for the capture again (a warning says why), and on the ``last_attempt`` :class:`SamplesLost` stops
    the run, so no step is ever recorded with a hole.
    """
    overflows, dropped = (now - then for now, then in zip(loss_counters(ctx.rig.sensor), since))
    if overflows <= 0:
        return []
    why = ctx.rig.explain_lost_samples()
    what = f"sensor FIFO overflowed {overflows} time(s), {dropped} samples lost: {why.reason}"
    if not why.stop_run:
        return [what + (f"; {why.advice}" if why.advice else "")]
    if not last_attempt:
        ctx.event("warning", step=step.index, source="clock", message=f"measuring step {step.index + 1} again: {what}")
        ctx.operator.warn(f"step {step.index + 1} ({step.name}): {what}; measuring again")
        return None
    where = ctx.recorder.session_dir
    resume = f"rig run --resume {where}" + (f" {why.resume_options}" if why.resume_options else "")
    raise SamplesLost(f"step {step.index + 1} ({step.name}): {what}; run stopped (motors stopped, session kept)"
                      + (f"; {why.advice}" if why.advice else "") + f"; resume with: {resume}")


def poll_interval_s(sensor) -> float:
    """Read the FIFO when a quarter of it has filled (at most every 0.25 s): three quarters to spare for a
    late host (MPU-9150 at 100 Hz: 73 samples, read every 0.18 s; ADXL345 at 100 Hz: 32, every 0.08 s)."""
    return min(POLL_MAX_S, POLL_FIFO_SHARE * sensor.fifo_samples / sensor.sample_rate_hz)


def expected_samples(step, rate_hz: float) -> int:
    """Samples the step's dwell asks for (0: decided while capturing, by ``dwell.sem_g``)."""
    d = step.dwell
    if d.samples is not None:
        return int(d.samples)
    if d.seconds is not None:
        return int(round(d.seconds * rate_hz))
    return 0


def nominal_dwell_s(step, rate_hz: float) -> float:
    """The dwell's expected length, s (the cap for an uncertainty-targeted dwell)."""
    d = step.dwell
    if d.seconds is not None:
        return float(d.seconds)
    if d.samples is not None:
        return d.samples / rate_hz
    return float(d.max_seconds or 600.0)


def settle_with_accelerometer(ctx: RunContext, step) -> tuple[SampleBlock, float | None, list[str]]:
    """Watch the accelerometer until consecutive windows agree (``SettleDetector``); return the
    samples to keep (none unless ``keep_settle_windows``), the settle time and problems."""
    sensor, clock = ctx.rig.sensor, ctx.rig.clock
    s = step.settle
    rule = SettleRule(window_s=s.window_s, threshold_g=s.threshold_g, mean_tol_sigma=s.mean_tol_sigma,
                      timeout_s=s.timeout_s, min_s=s.min_s)
    detector = SettleDetector(rule, sensor.sample_rate_hz, sensor.accel_lsb_per_g)
    t_start = clock.now()
    detector.start(t_start)
    ctx.progress(step, "settle")
    while True:
        clock.sleep(poll_interval_s(sensor))
        block = sensor.read()
        settled = detector.feed(block.t_s, block.accel_counts, block.temp_c, block.gyro_counts)
        if settled is not None:
            break
        if clock.now() - t_start > rule.timeout_s:
            # capture anyway from here on; the step is flagged
            return (SampleBlock.empty(block.gyro_counts is not None), None,
                    [f"did not settle within {rule.timeout_s:g} s"])
    ctx.event("settle", step=step.index, settle_s=settled.elapsed_s, noise_g=[float(x) for x in settled.noise_g])
    if ctx.options.keep_settle_windows:
        keep = SampleBlock(settled.keep_t_s, settled.keep_accel, settled.keep_temp_c, settled.keep_gyro)
    else:
        # the windows that proved the table still hold the tail of the ringing, whose mean biases
        # the step mean by ~0.1 mg (rig discover named it as a spurious drift): start afresh
        keep = SampleBlock.empty(settled.keep_gyro is not None)
    return keep, settled.elapsed_s, []


def settle_not_needed(ctx: RunContext, step) -> tuple[SampleBlock, float | None, list[str]]:
    """A recording holds only settled samples: capture from its first sample."""
    return SampleBlock.empty(False), 0.0, []


#: rig.settle -> how stillness is judged
SETTLERS = {"accelerometer": settle_with_accelerometer, "none": settle_not_needed}


def settle_and_capture(ctx: RunContext, step) -> Capture:
    """Start the sensor, settle as the rig says, capture the dwell; FIFO overflows flag the step, or, lost
    to the pace of the rig's clock, have it settled and captured again and stop the run when every
    attempt loses samples (:func:`lost_samples`)."""
    sensor = ctx.rig.sensor
    attempts = ctx.options.max_attempts
    for attempt in range(1, attempts + 1):
        since = loss_counters(sensor)
        sensor.start()
        keep, settle_s, problems = SETTLERS[ctx.rig.settle](ctx, step)
        samples = capture_dwell(ctx, step, keep)
        lost = lost_samples(ctx, step, since, last_attempt=attempt >= attempts)
        if lost is not None:
            return Capture(samples, settle_s, problems + lost)
    raise AssertionError("unreachable: the last attempt returns or raises")


def capture(ctx: RunContext, step, keep: SampleBlock) -> SampleBlock:
    """:func:`capture_dwell` on a started sensor (a rate step's constant-rate part); samples lost to the
    pace of the rig's clock have it captured again (the sensor restarted) and stop the run when every
    attempt loses samples (:func:`lost_samples`)."""
    attempts = ctx.options.max_attempts
    for attempt in range(1, attempts + 1):
        since = loss_counters(ctx.rig.sensor)
        samples = capture_dwell(ctx, step, keep)
        if lost_samples(ctx, step, since, last_attempt=attempt >= attempts) is not None:
            return samples
        ctx.rig.sensor.start()
    raise AssertionError("unreachable: the last attempt returns or raises")


def capture_dwell(ctx: RunContext, step, keep: SampleBlock) -> SampleBlock:
    """Read the sensor until the dwell is done (samples, seconds, or a standard-error target)."""
    sensor, clock = ctx.rig.sensor, ctx.rig.clock
    rate, lsb, dwell = sensor.sample_rate_hz, sensor.accel_lsb_per_g, step.dwell
    parts = [keep]
    n = len(keep)
    scatter = Scatter().add(keep.accel_counts)
    t_begin = clock.now()
    n_target = expected_samples(step, rate)
    timeout_s = 2.0 * nominal_dwell_s(step, rate) + 5.0
    while not (n_target and n >= n_target):
        if dwell.sem_g is not None:
            stop_n = sem_stop_index(np.concatenate([p.accel_counts for p in parts]), lsb, dwell.sem_g)
            if stop_n is not None or (dwell.max_seconds is not None and n >= dwell.max_seconds * rate):
                n_target = stop_n if stop_n is not None else int(round(dwell.max_seconds * rate))
                break
        if clock.now() - t_begin > timeout_s:
            break
        clock.sleep(poll_interval_s(sensor))
        block = sensor.read()
        if len(block.t_s):
            parts.append(block)
            n += len(block.t_s)
            ctx.progress(step, "capture", noise_ug=scatter.add(block.accel_counts).noise_ug(lsb),
                         temp_c=float(block.temp_c[-1]) if len(block.temp_c) else None,
                         eta_s=(max(n_target - n, 0) / rate) if n_target else None)
    sensor.stop()
    return _join(parts, n_target)


def _join(parts: list[SampleBlock], n_target: int) -> SampleBlock:
    gyros = [p.gyro_counts for p in parts if p.gyro_counts is not None]
    out = SampleBlock(np.concatenate([p.t_s for p in parts]),
                      np.concatenate([p.accel_counts for p in parts]).astype(np.int64),
                      np.concatenate([p.temp_c for p in parts]),
                      np.concatenate(gyros).astype(np.int64) if gyros else None)
    if n_target:
        out = SampleBlock(out.t_s[:n_target], out.accel_counts[:n_target], out.temp_c[:n_target],
                          out.gyro_counts[:n_target] if out.gyro_counts is not None else None)
    return out


class Scatter:
    """The per-axis sample standard deviation of a capture's counts so far, updated block by block (Chan, Golub and
    LeVeque's pairwise update of mean and sum of squared deviations): the capture's noise line costs one pass over
    each new block, not over everything captured (a 2-hour dwell polled every 0.18 s re-read its whole capture
    43,000 times: 26 of a 600 s dwell's 60 s of CPU, and quadratic in the dwell)."""

    def __init__(self) -> None:
        self.n, self.mean, self.m2 = 0, 0.0, 0.0

    def add(self, counts) -> "Scatter":
        a = np.asarray(counts, float)
        k = len(a)
        if k:
            mean = a.mean(axis=0)
            m2 = ((a - mean) ** 2).sum(axis=0)
            total = self.n + k
            delta = mean - self.mean
            self.m2 = self.m2 + m2 + delta**2 * self.n * k / total
            self.mean = self.mean + delta * k / total
            self.n = total
        return self

    def noise_ug(self, lsb: float) -> float | None:
        """The largest axis's sample standard deviation (ddof 1), ug; None below 3 samples."""
        if self.n < 3:
            return None
        return float(np.max(np.sqrt(self.m2 / (self.n - 1))) / lsb * 1e6)


def sem_stop_index(a: np.ndarray, lsb_per_g: float, sem_g: float, step: int = 10, min_n: int = 20) -> int | None:
    """Smallest n (a multiple of ``step``, >= ``min_n``) at which every axis' standard error of the
    mean over the first n samples is at most ``sem_g`` (g); None if not yet.

    Deterministic in the sample sequence, so a replay stops at the same sample.
    """
    if len(a) < min_n:
        return None
    x = a.astype(float) / lsb_per_g
    c1, c2 = np.cumsum(x, axis=0), np.cumsum(x * x, axis=0)
    ns = np.arange(min_n, len(a) + 1, step)
    if len(ns) == 0:
        return None
    s1, s2 = c1[ns - 1], c2[ns - 1]
    nn = ns[:, None].astype(float)
    sem = np.sqrt(np.maximum((s2 - s1 * s1 / nn) / (nn - 1), 0.0) / nn)
    idx = np.flatnonzero(np.all(sem <= sem_g, axis=1))
    return int(ns[idx[0]]) if len(idx) else None

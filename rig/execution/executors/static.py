"""A static step: move to a pose, settle, capture the dwell, check the data, record.

A capture that fails its checks (or meets a sensor error) is measured again, up to
``options.max_attempts`` times; a step that still fails is recorded but flagged (left out of the
solve).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from drivers.sensors.base import SensorError
from rig.config.procedure import PlannedStep
from rig.execution.capture import Capture, expected_samples, settle_and_capture
from rig.execution.checks import check_step
from rig.execution.context import RunContext
from rig.execution.motion import angles_now_deg, move_to
from rig.session import MAG_COUNTS_PER_UT


def execute(ctx: RunContext, step: PlannedStep) -> None:
    run_pose(ctx, step, settle_and_capture)


def run_pose(ctx: RunContext, step: PlannedStep, capture_step: Callable[[RunContext, PlannedStep], Capture],
             extra_stats: Callable[[], dict] | None = None, expected: int | None = None) -> tuple[Capture, str]:
    """Move, capture with ``capture_step`` (re-measured on bad data), record; return the capture and
    the step's status. ``extra_stats`` adds keys to the step's recorded stats (a targeted pose's
    decision); ``expected`` the samples the checks expect (default: what the step's dwell asks
    for; 0: decided while capturing)."""
    move_to(ctx, step)
    capture, attempts, problems = _measure(ctx, step, capture_step, expected)
    _note_bus_retries(ctx, step)
    status = "complete" if not problems else "flagged"
    if problems:
        ctx.warn(step, f"step {step.index + 1} ({step.name}) flagged and left out of the solve: "
                       + "; ".join(problems))
    _record(ctx, step, capture, attempts, problems, status, extra_stats() if extra_stats else None)
    return capture, status


def _measure(ctx: RunContext, step, capture_step, expected: int | None) -> tuple[Capture, int, list[str]]:
    """Capture until the data pass the checks or the attempts run out."""
    sensor = ctx.rig.sensor
    attempts = 0
    while True:
        attempts += 1
        try:
            capture = capture_step(ctx, step)
        except SensorError as exc:
            if attempts >= ctx.options.max_attempts:
                raise
            ctx.event("warning", step=step.index, source="sensor",
                      message=f"sensor error, measuring step {step.index + 1} again: {exc}")
            ctx.operator.warn(f"step {step.index + 1} ({step.name}): {exc}; measuring again")
            ctx.rig.clock.sleep(1.0)
            continue
        s = capture.samples
        n_expected = expected_samples(step, sensor.sample_rate_hz) if expected is None else expected
        check = check_step(s.accel_counts, s.temp_c, n_expected, sensor.has_temperature, ctx.options.limits)
        problems = capture.problems + check.problems
        if not problems or attempts >= ctx.options.max_attempts:
            return capture, attempts, problems
        ctx.event("warning", step=step.index, attempt=attempts,
                  message=f"re-measuring step {step.index + 1} ({step.name}): " + "; ".join(problems))
        ctx.operator.warn(f"step {step.index + 1} ({step.name}): {'; '.join(problems)}; measuring again")


def _note_bus_retries(ctx: RunContext, step) -> None:
    retries = ctx.rig.sensor.stats.io_retries
    if retries > ctx.io_retries_seen:
        ctx.event("warning", step=step.index, source="sensor",
                  message=f"{retries - ctx.io_retries_seen} I2C transfer(s) failed and were retried")
    ctx.io_retries_seen = retries


def _record(ctx: RunContext, step, capture: Capture, attempts: int, problems: list[str], status: str,
            extra: dict | None = None) -> None:
    sensor = ctx.rig.sensor
    s = capture.samples
    ts = s.t_s - ctx.t0_s
    angles = angles_now_deg(ctx.rig)
    has_temp = sensor.has_temperature
    ctx.recorder.append_samples(step.index, ts, s.accel_counts, temp_c=s.temp_c if has_temp else None,
                                gyro_counts=s.gyro_counts, angles_deg=np.broadcast_to(angles, (len(ts), 3)),
                                mag_counts=read_magnetometer(ctx, len(ts)))
    lsb = sensor.accel_lsb_per_g
    stats = {
        "n_samples": int(len(ts)),
        "t_start_s": float(ts[0]) if len(ts) else None,
        "t_end_s": float(ts[-1]) if len(ts) else None,
        "temp_c": float(np.nanmean(s.temp_c)) if has_temp and len(s.temp_c) else None,
        "noise_g": [float(x) for x in (s.accel_counts.std(axis=0, ddof=1) / lsb)] if len(ts) > 1 else None,
        "settle_s": capture.settle_s,
        "attempts": attempts,
        "problems": problems,
        "angles_measured_deg": [float(x) for x in angles],
        **(extra or {}),
    }
    ctx.finish(step, stats, status, int(len(ts)), problems)


def read_magnetometer(ctx: RunContext, n_rows: int) -> np.ndarray | None:
    """``ctx.magnetometer_samples`` readings as integer 0.01 uT on the step's first rows (NaN
    elsewhere); None when the procedure does not read the magnetometer."""
    if not ctx.magnetometer_samples or n_rows == 0:
        return None
    out = np.full((n_rows, 3), np.nan)
    for i in range(min(ctx.magnetometer_samples, n_rows)):
        out[i] = np.round(np.asarray(ctx.rig.magnetometer.read_field_ut(), float) * MAG_COUNTS_PER_UT)
    return out

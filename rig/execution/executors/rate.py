"""A rate step (gyroscope): spin one axis at a constant rate and capture only the constant-rate part.

Before anything moves, :func:`preflight` refuses rates above the stage's limit and spins that
would wind the cable beyond its wrap on an axis without a slip ring.
"""

from __future__ import annotations

import numpy as np

from rig.errors import RigInputError
from drivers.sensors.base import SampleBlock
from rig.execution.capture import capture
from rig.execution.context import RunContext, RunError
from rig.execution.motion import move_to, wrap_position
from drivers.ximc.stage_spec import MAX_SPEED_DEG_S as STAGE_MAX_SPEED_DEG_S


def preflight(procedure, step, rig) -> None:
    """Refuse a rate the stage cannot turn, or a spin the cable cannot follow (RigInputError)."""
    axis = rig.axes[step.rate_axis]
    rate = abs(step.rate_deg_s)
    where = f"steps: {step.name}: {step.rate_axis}"
    if rate > STAGE_MAX_SPEED_DEG_S + 1e-9:
        raise RigInputError(procedure.path, step.source_line, where,
                            f"rate {rate:g} deg/s is above the stage's limit of {STAGE_MAX_SPEED_DEG_S:g} deg/s")
    if not axis.config.slip_ring:
        travel = rate * (step.dwell.seconds + step.settle.min_s + 2 * rate / axis.config.accel_deg_s2 + 1.0)
        if travel > axis.config.cable_wrap_deg:
            raise RigInputError(procedure.path, step.source_line, where,
                                f"spinning {step.dwell.seconds:g} s at {rate:g} deg/s turns {travel:.0f} deg, beyond "
                                f"the cable wrap of {axis.config.cable_wrap_deg:g} deg; set slip_ring: true for "
                                f"{step.rate_axis} in the rig file if it has one, or shorten the step")


def execute(ctx: RunContext, step) -> None:
    move_to(ctx, step)
    name = step.rate_axis
    axis = ctx.rig.axes[name]
    stage_rate = axis.config.sign * step.rate_deg_s
    ctx.progress(step, "spin-up")
    ctx.event("rotate", step=step.index, axis=name, rate_deg_s=step.rate_deg_s)
    axis.stage.set_speed_deg_s(abs(stage_rate), accel_deg_s2=axis.config.accel_deg_s2)
    axis.stage.command_right() if stage_rate >= 0 else axis.stage.command_left()
    try:
        speed0, samples, speed1 = _spin_and_capture(ctx, step, axis, stage_rate)
    finally:
        axis.stage.command_sstp()
        axis.stage.command_wait_for_stop(50, timeout_s=ctx.options.move_timeout_s)
        axis.stage.set_speed_deg_s(axis.config.speed_deg_s, accel_deg_s2=axis.config.accel_deg_s2)
    wrap_position(ctx, name)
    if samples.gyro_counts is None or len(samples) == 0:
        raise RunError(f"step {step.index + 1} ({step.name}): the {ctx.rig.sensor.model} has no gyroscope")
    problems = []
    if abs(speed1 - stage_rate) > 0.01 * abs(stage_rate) + 0.02:
        problems.append(f"the rate changed during capture ({speed0:.3f} -> {speed1:.3f} deg/s)")
    _record(ctx, step, samples, [speed0, speed1], problems)


def _spin_and_capture(ctx: RunContext, step, axis, stage_rate: float) -> tuple[float, SampleBlock, float]:
    """Wait out the acceleration, check the speed, capture, check it again."""
    spin_up = abs(stage_rate) / axis.config.accel_deg_s2 + step.settle.min_s
    ctx.rig.clock.sleep(spin_up)
    speed0 = axis.stage.get_speed_deg_s()
    if abs(speed0 - stage_rate) > 0.01 * abs(stage_rate) + 0.02:
        raise RunError(f"step {step.index + 1} ({step.name}): {axis.name} turns at {speed0:.3f} deg/s after "
                       f"{spin_up:.1f} s, expected {stage_rate:g} deg/s")
    ctx.rig.sensor.start()  # (re)starts sampling now: nothing from the spin-up is kept
    ctx.progress(step, "capture")
    samples = capture(ctx, step, SampleBlock.empty(True))
    return speed0, samples, axis.stage.get_speed_deg_s()


def _record(ctx: RunContext, step, samples: SampleBlock, speeds: list[float], problems: list[str]) -> None:
    sensor = ctx.rig.sensor
    status = "complete" if not problems else "flagged"
    ts = samples.t_s - ctx.t0_s
    has_temp = sensor.has_temperature
    ctx.recorder.append_samples(step.index, ts, samples.accel_counts,
                                temp_c=samples.temp_c if has_temp else None, gyro_counts=samples.gyro_counts)
    lsb = sensor.gyro_lsb_per_dps
    ctx.finish(step, {
        "n_samples": int(len(ts)), "t_start_s": float(ts[0]), "t_end_s": float(ts[-1]),
        "temp_c": float(np.nanmean(samples.temp_c)) if has_temp else None,
        "stage_rate_deg_s": speeds, "problems": problems,
        "gyro_mean_dps": [float(x) for x in samples.gyro_counts.mean(axis=0) / lsb] if lsb else None,
    }, status, int(len(ts)), problems)


"""A temperature step: set the chamber (or ask the operator to), then wait until the sensor's own
thermometer holds the target for ``hold_s``.

The leg's starting temperature is recorded (``start_c`` of the ``temperature`` event): the
discrepancy workflow tells heating from cooling legs by it.
"""

from __future__ import annotations

import numpy as np

from rig.config.procedure import PlannedStep, Procedure
from rig.devices.rig import Rig
from rig.execution.context import RunAborted, RunContext, RunError, StepOutcome


def preflight(procedure: Procedure | None, step: PlannedStep, rig: Rig) -> None:
    """A temperature step needs a thermometer on the sensor."""
    if not rig.sensor.has_temperature:
        raise RunError(f"step {step.index + 1} ({step.name}) waits for the sensor's thermometer, "
                       f"but the {rig.sensor.model} has none")


def apply_setpoint(ctx: RunContext, step) -> None:
    """Set the chamber to the step's target: directly when the rig has a chamber and the step says
    ``mode: wait``; otherwise the operator sets it and confirms."""
    target = step.temperature
    chamber = ctx.rig.chamber
    if target.mode == "wait" and chamber is not None:
        chamber.set_target_c(target.target_c)
        ctx.event("chamber", step=step.index, setpoint_c=target.target_c)
        return
    ctx.progress(step, "prompt")
    ok = ctx.operator.confirm(f"Set the chamber to {target.target_c:g} C, then confirm.")
    ctx.event("prompt", step=step.index, text=f"set chamber to {target.target_c:g} C",
              answer="yes" if ok else "abort")
    if not ok:
        raise RunAborted(f"operator aborted at step {step.index + 1} ({step.name})")
    if chamber is not None:  # simulated rig: the simulated operator sets the simulated chamber
        chamber.set_target_c(target.target_c)


def execute(ctx: RunContext, step: PlannedStep) -> None:
    preflight(None, step, ctx.rig)
    apply_setpoint(ctx, step)
    clock = ctx.rig.clock
    t_start = clock.now()
    mean_c, first_c = wait_in_band(ctx, step, t_start)
    waited_s = clock.now() - t_start
    ctx.event("temperature", step=step.index, temp_c=mean_c, start_c=first_c, waited_s=waited_s)
    ctx.recorder.complete_step(step.index, {"t_end_s": ctx.session_time(), "temp_c": mean_c, "waited_s": waited_s})
    ctx.outcomes.append(StepOutcome(step.index, "complete", 0))


def restore(ctx: RunContext, step: PlannedStep, next_step: PlannedStep | None = None) -> None:
    """On a resume after temperature step ``step`` (``next_step``: the step the run resumes at): set its
    set-point again and wait until the sensor is back in band before the next capture (the chamber may
    have drifted while the run was stopped); the step itself stays as recorded."""
    apply_setpoint(ctx, step)
    t_start = ctx.rig.clock.now()
    mean_c, first_c = wait_in_band(ctx, step, t_start)
    ctx.event("temperature", step=step.index, temp_c=mean_c, start_c=first_c,
              waited_s=ctx.rig.clock.now() - t_start, restored=True)


def wait_in_band(ctx: RunContext, step, t_start: float) -> tuple[float, float]:
    """Read the thermometer every second until the mean over the last ``window`` seconds has
    stayed within tolerance for ``hold_s``; return (that mean, the first reading), C."""
    target = step.temperature
    clock, sensor = ctx.rig.clock, ctx.rig.sensor
    window_s = max(ctx.options.temp_window_s, 5.0)
    readings: list[tuple[float, float]] = []
    first_c = None
    in_band_since = None
    while True:
        clock.sleep(1.0)
        now = clock.now()
        readings.append((now, sensor.read_temperature_c()))
        first_c = readings[-1][1] if first_c is None else first_c
        readings = [(t, c) for t, c in readings if t >= now - window_s]
        mean_c = float(np.mean([c for _, c in readings]))
        if abs(mean_c - target.target_c) <= target.tolerance_c:
            in_band_since = now if in_band_since is None else in_band_since
            if now - in_band_since >= target.hold_s:
                return mean_c, first_c
        else:
            in_band_since = None
        remaining = (target.hold_s - (now - in_band_since)) if in_band_since is not None else None
        ctx.progress(step, "temperature", temp_c=mean_c, eta_s=remaining)
        if now - t_start > target.timeout_s:
            raise RunError(f"step {step.index + 1} ({step.name}): sensor temperature {mean_c:.2f} C did not "
                           f"reach {target.target_c:g} +- {target.tolerance_c:g} C within {target.timeout_s:g} s")

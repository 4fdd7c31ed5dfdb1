"""A thermal ramp: the step that starts the chamber's ramp, and the poses captured while it runs.

The start step (kind ``thermal``, :attr:`RampPlan.capture` 0) sets the chamber ramping from its
set-point (or the procedure's ``from_c``) to ``to_c`` at ``rate_c_per_min`` and completes at once:
the run never waits for the chamber. Each pose of the ramp is then a static step (move, settle,
capture its dwell, the data checks, re-measure on bad data), captured on the move in temperature;
its stats add ``ramp``: the leg, its plan, and the temperature rate the sensor's thermometer saw
over the capture (C/min, the least-squares slope). The progress shows the ramp: the sensor's
temperature, its rate over the last half minute and the captures done of the leg.

A resume inside a ramp (:func:`restore`) brings the chamber back to the temperature of the leg's
last recorded capture, waits until the sensor is there, and ramps on from it at the same rate.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np

from rig.config.procedure import PlannedStep, Procedure, RampPlan
from rig.config.procedure_model import TemperatureTarget
from rig.devices.rig import Rig
from rig.execution.capture import settle_and_capture
from rig.execution.context import RunAborted, RunContext, StepOutcome
from rig.execution.executors import temperature
from rig.execution.executors.static import run_pose
from rig.execution.operator import Operator, StepProgress

#: a resume waits until the sensor is this close to the temperature it resumes the ramp from (C), for this long (s)
RESUME_TOLERANCE_C = 0.3
RESUME_HOLD_S = 10.0
#: the progress's temperature rate is the slope over this much of the latest readings, s
RATE_WINDOW_S = 30.0


def preflight(procedure: Procedure | None, step: PlannedStep, rig: Rig) -> None:
    """A ramp reads the sensor's thermometer."""
    temperature.preflight(procedure, step, rig)


def execute(ctx: RunContext, step: PlannedStep) -> None:
    (start if step.ramp.capture == 0 else capture)(ctx, step)


def start(ctx: RunContext, step) -> None:
    """Set the chamber ramping and record where the sensor is; the poses follow at once."""
    preflight(None, step, ctx.rig)
    plan = step.ramp
    start_c = float(ctx.rig.sensor.read_temperature_c())
    set_ramp(ctx, step, plan.from_c if plan.from_given else None)
    stats = {"t_end_s": ctx.session_time(), "temp_c": start_c, "ramp": plan.to_manifest()}
    ctx.event("ramp", step=step.index, leg=plan.leg, start_c=start_c, to_c=plan.to_c,
              rate_c_per_min=plan.rate_c_per_min, captures=plan.captures)
    ctx.recorder.complete_step(step.index, stats)
    ctx.outcomes.append(StepOutcome(step.index, "complete", 0))


def set_ramp(ctx: RunContext, step, from_c: float | None) -> None:
    """Ramp the chamber's set-point from ``from_c`` (None: where it is) to the leg's ``to_c``: directly when
    the chamber can ramp, otherwise the operator starts the ramp and confirms."""
    plan, chamber = step.ramp, ctx.rig.chamber
    ramp_to_c = getattr(chamber, "ramp_to_c", None)
    if ramp_to_c is not None:
        duration_s = ramp_to_c(plan.to_c, plan.rate_c_per_min, from_c)
        ctx.event("chamber", step=step.index, ramp_to_c=plan.to_c, rate_c_per_min=plan.rate_c_per_min,
                  from_c=from_c, duration_s=duration_s)
        return
    where = f"from {from_c:g} C " if from_c is not None else ""
    question = f"Start the chamber's ramp {where}to {plan.to_c:g} C at {plan.rate_c_per_min:g} C/min, then confirm."
    ctx.progress(step, "prompt")
    ok = ctx.operator.confirm(question)
    ctx.event("prompt", step=step.index, text=question, answer="yes" if ok else "abort")
    if not ok:
        raise RunAborted(f"operator aborted at step {step.index + 1} ({step.name})")


def capture(ctx: RunContext, step) -> None:
    """One pose of the ramp: the static step's move, settle, capture and checks, with the ramp's state."""
    plan = step.ramp
    held: dict = {}

    def capture_step(c, s):
        held["capture"] = settle_and_capture(c, s)
        return held["capture"]

    def ramp_stats() -> dict:
        samples = held["capture"].samples
        return {"ramp": {**plan.to_manifest(), "temp_rate_c_per_min": slope_c_per_min(samples.t_s, samples.temp_c)}}

    operator = ctx.operator
    ctx.operator = RampProgress(operator, plan, ctx.session_time, _previous_rate(ctx, step))
    try:
        run_pose(ctx, step, capture_step, ramp_stats)
    finally:
        ctx.operator = operator
    if plan.capture == plan.captures:
        sensor_c = float(ctx.rig.sensor.read_temperature_c())
        ctx.operator.info(f"ramp {plan.leg} ({plan.from_c:g} -> {plan.to_c:g} C at {plan.rate_c_per_min:g} C/min): "
                          f"{plan.captures} captures done, sensor at {sensor_c:.2f} C")


def slope_c_per_min(t_s, temp_c) -> float | None:
    """Least-squares slope of ``temp_c`` (C) against ``t_s`` (s), C/min; None without two finite readings."""
    t, y = np.asarray(t_s, float), np.asarray(temp_c, float)
    ok = np.isfinite(t) & np.isfinite(y)
    if ok.sum() < 2 or np.ptp(t[ok]) <= 0:
        return None
    return float(np.polyfit(t[ok] - t[ok][0], y[ok], 1)[0] * 60.0)


class RampProgress:
    """The operator during a ramp's capture: the progress names the ramp beside the step (the sensor's rate
    over the last :data:`RATE_WINDOW_S` of the capture's readings, before them the previous capture's, and
    the captures done of the leg); everything else passes through. ``now`` gives the session time, s."""

    def __init__(self, inner: Operator, plan: RampPlan, now: Callable[[], float],
                 last_rate_c_per_min: float | None) -> None:
        self.inner, self.plan, self.now = inner, plan, now
        self.rate = last_rate_c_per_min
        self.readings: list[tuple[float, float]] = []

    def info(self, message: str) -> None:
        self.inner.info(message)

    def warn(self, message: str) -> None:
        self.inner.warn(message)

    def confirm(self, question: str) -> bool:
        return self.inner.confirm(question)

    def can_confirm(self) -> bool:
        return self.inner.can_confirm()

    def progress(self, p: StepProgress) -> None:
        if p.temp_c is not None and p.temp_c == p.temp_c:
            t = self.now()
            self.readings = [r for r in self.readings if r[0] >= t - RATE_WINDOW_S] + [(t, float(p.temp_c))]
            t_s, temp_c = zip(*self.readings)
            if len(t_s) > 2 and np.ptp(t_s) >= 2.0:
                self.rate = slope_c_per_min(t_s, temp_c)
        shown = f"{self.rate:+.2f} C/min, " if self.rate is not None else ""
        name = (f"{p.name} (ramp {self.plan.leg} to {self.plan.to_c:g} C: {shown}"
                f"{self.plan.capture - 1}/{self.plan.captures} captured)")
        self.inner.progress(replace(p, name=name))

    def __getattr__(self, name):  # anything else the operator has (a console's own attributes)
        return getattr(self.inner, name)


def _previous_rate(ctx: RunContext, step) -> float | None:
    """The temperature rate the previous capture of the same leg measured, C/min (None: none yet)."""
    steps = ctx.recorder.info.steps
    stats = steps[step.index - 1].stats if 0 < step.index <= len(steps) else None
    ramp = getattr(stats, "ramp", None) or {}  # an extra key of the recorded stats (StepStats keeps unknown keys)
    return ramp.get("temp_rate_c_per_min") if ramp.get("leg") == step.ramp.leg else None


def restore(ctx: RunContext, step: PlannedStep, next_step: PlannedStep | None = None) -> None:
    """On a resume after ramp start step ``step``: within the leg, bring the chamber to the temperature of the
    leg's last recorded capture, wait until the sensor holds it, and ramp on from there; after the leg, hold
    its ``to_c`` as a temperature step would."""
    plan = step.ramp
    within = next_step is not None and next_step.ramp is not None and next_step.ramp.leg == plan.leg
    resume_c = _last_capture_c(ctx, plan.leg, step) if within else plan.to_c
    hold = replace(step, temperature=TemperatureTarget(target_c=resume_c, tolerance_c=RESUME_TOLERANCE_C,
                                                       hold_s=RESUME_HOLD_S, timeout_s=3600.0))
    temperature.apply_setpoint(ctx, hold)
    t_start = ctx.rig.clock.now()
    mean_c, first_c = temperature.wait_in_band(ctx, hold, t_start)
    ctx.event("temperature", step=step.index, temp_c=mean_c, start_c=first_c,
              waited_s=ctx.rig.clock.now() - t_start, restored=True)
    if within:
        set_ramp(ctx, step, None)


def _last_capture_c(ctx: RunContext, leg: int, step) -> float:
    """Mean temperature of the leg's last recorded capture (the ramp's start temperature when none), C."""
    for record in reversed(ctx.recorder.info.steps):
        ramp = getattr(record, "ramp", None)  # the step's ramp plan: an extra key of the record
        stats = record.stats
        if (isinstance(ramp, dict) and ramp.get("leg") == leg and record.status in ("complete", "flagged")
                and stats is not None and stats.temp_c is not None):
            return float(stats.temp_c)
    return step.ramp.from_c

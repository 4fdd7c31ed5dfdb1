"""A prompt step: ask the operator to do something (mount the sensor, open the chamber) and confirm."""

from __future__ import annotations

from rig.config.procedure import PlannedStep
from rig.execution.context import RunAborted, RunContext


def execute(ctx: RunContext, step: PlannedStep) -> None:
    ctx.progress(step, "prompt")
    ok = ctx.operator.confirm(step.prompt)
    ctx.event("prompt", step=step.index, text=step.prompt, answer="yes" if ok else "abort")
    if not ok:
        raise RunAborted(f"operator aborted at step {step.index + 1} ({step.name})")
    ctx.recorder.complete_step(step.index, {"t_end_s": ctx.session_time()})

"""A prompt step: ask the operator to do something (mount the sensor, open the chamber) and confirm.

A prompt with ``mount:`` (docs/procedures.md, "Re-mounting the sensor") also tells the operator how to turn the
sensor in its fixture; once confirmed, the rig is told (``Rig.remount``: the simulated rig turns its sensor)."""

from __future__ import annotations

from rig.config.procedure import PlannedStep
from rig.execution.context import RunAborted, RunContext


def question(step: PlannedStep) -> str:
    """What the operator is asked: the prompt's text, and with ``mount:`` the turn from the reference mounting."""
    if step.mount is None:
        return step.prompt
    return f"{step.prompt} [sensor in its fixture: {step.mount.words()} from the reference mounting]"


def execute(ctx: RunContext, step: PlannedStep) -> None:
    ctx.progress(step, "prompt")
    text = question(step)
    ok = ctx.operator.confirm(text)
    ctx.event("prompt", step=step.index, text=text, answer="yes" if ok else "abort")
    if not ok:
        raise RunAborted(f"operator aborted at step {step.index + 1} ({step.name})")
    if step.mount is not None and ctx.rig.remount is not None:
        ctx.rig.remount(step.mount.turn)
    ctx.recorder.complete_step(step.index, {"t_end_s": ctx.session_time()})


def restore(ctx: RunContext, step: PlannedStep, next_step: PlannedStep | None = None) -> None:
    """On a resume after the re-mounting prompt ``step`` (``next_step``: where the run resumes): the sensor must be in
    that mounting again before the next capture (a resumed rig starts as placed; a technician may have taken the
    sensor out): the operator is asked to confirm it, then the rig is told (the simulated rig turns its sensor)."""
    text = (f"The run resumes at step {next_step.index + 1} ({next_step.name}) with the sensor in its fixture as "
            f"after step {step.index + 1}: {step.mount.words()} from the reference mounting. Confirm it is mounted so."
            if next_step is not None else question(step))
    ok = ctx.operator.confirm(text)
    ctx.event("prompt", step=step.index, text=text, answer="yes" if ok else "abort", restored=True)
    if not ok:
        raise RunAborted(f"operator aborted the resume before step {next_step.index + 1 if next_step else '?'}: "
                         "the sensor's mounting was not confirmed")
    if ctx.rig.remount is not None:
        ctx.rig.remount(step.mount.turn)

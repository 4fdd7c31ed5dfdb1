"""One small executor per step kind, chosen by table (``EXECUTORS``).

What the engine calls for a step is an :class:`Executor`: ``preflight(procedure, step, rig)`` for every
remaining step before anything moves, ``execute(ctx, step)`` to run it, and on a resume
``restore(ctx, step, next_step)`` of the last temperature step before the step the run resumes at. Each
step kind's module has the functions it needs; :class:`StepExecutor` puts them together, a step kind
without a preflight or a restore having none to do. A step names its executor
(``PlannedStep.executor``): its kind, or ``targeted`` for a pose whose dwell the procedure's accuracy
target decides, ``ramp`` for the steps of a thermal ramp.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol

from rig.config.procedure import PlannedStep, Procedure
from rig.devices.rig import Rig
from rig.execution.context import RunContext
from rig.execution.executors import prompt, ramp, rate, static, targeted, temperature


class Executor(Protocol):
    """What the engine calls for one step kind."""

    def preflight(self, procedure: Procedure, step: PlannedStep, rig: Rig) -> None:
        """Refuse the step before anything moves (RigInputError, RunError) if it cannot run on ``rig``."""
        ...

    def execute(self, ctx: RunContext, step: PlannedStep) -> None:
        """Run the step and record it (durable on return)."""
        ...

    def restore(self, ctx: RunContext, step: PlannedStep, next_step: PlannedStep | None) -> None:
        """On a resume at ``next_step``: bring back what the recorded ``step`` left behind (a temperature)."""
        ...


def no_preflight(procedure: Procedure, step: PlannedStep, rig: Rig) -> None:
    """A step kind that any rig can run."""


def nothing_to_restore(ctx: RunContext, step: PlannedStep, next_step: PlannedStep | None) -> None:
    """A step kind that leaves nothing behind for a resume: the recorded step stays as it is."""


@dataclass(frozen=True)
class StepExecutor:
    """An :class:`Executor` made of a step kind's functions."""

    execute: Callable[[RunContext, PlannedStep], None]
    preflight: Callable[[Procedure, PlannedStep, Rig], None] = no_preflight
    restore: Callable[[RunContext, PlannedStep, PlannedStep | None], None] = nothing_to_restore


#: step executor key (PlannedStep.executor: the step kind of rig-procedure/1, or targeted, ramp) -> its executor
EXECUTORS: dict[str, Executor] = {
    "static": StepExecutor(static.execute),
    "rate": StepExecutor(rate.execute, preflight=rate.preflight),
    "thermal": StepExecutor(temperature.execute, preflight=temperature.preflight, restore=temperature.restore),
    "prompt": StepExecutor(prompt.execute, restore=prompt.restore),
    "targeted": StepExecutor(targeted.execute, preflight=targeted.preflight),
    "ramp": StepExecutor(ramp.execute, preflight=ramp.preflight, restore=ramp.restore),
}


def executor_for(step: PlannedStep) -> Executor:
    """The executor that runs ``step``."""
    return EXECUTORS[step.executor]

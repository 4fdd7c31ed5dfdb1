"""One small executor per step kind, chosen by table (``EXECUTORS``).

Each executor module has ``execute(ctx, step)`` and may have ``preflight(procedure, step, rig)``,
which the engine calls for every remaining step before anything moves. A step names its executor
(``PlannedStep.executor``): its kind, or ``targeted`` for a pose whose dwell the procedure's
accuracy target decides, ``ramp`` for the steps of a thermal ramp.
"""

from __future__ import annotations

from types import ModuleType

from rig.execution.executors import prompt, ramp, rate, static, targeted, temperature

#: step executor key (PlannedStep.executor: the step kind of rig-procedure/1, or targeted) -> executor module
EXECUTORS: dict[str, ModuleType] = {"static": static, "rate": rate, "thermal": temperature, "prompt": prompt,
                                    "targeted": targeted, "ramp": ramp}


def executor_for(step) -> ModuleType:
    """The executor module that runs ``step``."""
    return EXECUTORS[step.executor]

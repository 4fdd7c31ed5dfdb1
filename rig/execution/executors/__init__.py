"""One small executor per step kind, chosen by table (``EXECUTORS``).

Each executor module has ``execute(ctx, step)`` and may have ``preflight(procedure, step, rig)``,
which the engine calls for every remaining step before anything moves.
"""

from __future__ import annotations

from types import ModuleType

from rig.execution.executors import prompt, rate, static, temperature

#: step kind (rig-procedure/1) -> executor module
EXECUTORS: dict[str, ModuleType] = {"static": static, "rate": rate, "thermal": temperature, "prompt": prompt}

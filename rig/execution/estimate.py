"""How long steps take: the one estimate used for the run's ETA and the planned duration.

Moves at the axes' configured speed and acceleration (all axes at once: the slowest sets the
time), 1 s to settle, then the dwell; a temperature step is guessed at 300 s, a prompt and the
step that starts a thermal ramp at 0 s (the ramp runs while its poses are captured). A
pose whose dwell an accuracy target decides is guessed at :data:`TARGET_DWELL_GUESS_S` (the run
replaces the guess by its plan after the first capture block).
"""

from __future__ import annotations

import numpy as np

from rig.execution.capture import nominal_dwell_s
from rig.planning.kinematics import STAGE_AXES
from rig.planning.targets import move_time_s

SETTLE_GUESS_S = 1.0
TEMPERATURE_GUESS_S = 300.0
TARGET_DWELL_GUESS_S = 3.0


def step_durations_s(steps, rig) -> list[float]:
    """Expected duration of each step, s (index by step index)."""
    out, previous = [], np.zeros(3)
    rate = rig.sensor.sample_rate_hz
    for step in steps:
        if step.kind not in ("static", "rate"):
            starts_ramp = getattr(step, "ramp", None) is not None
            out.append(TEMPERATURE_GUESS_S if step.kind == "thermal" and not starts_ramp else 0.0)
            continue
        angles = np.asarray(step.angles_deg, float)
        move = max(move_time_s(abs(b - a), rig.axes[n].config.speed_deg_s, rig.axes[n].config.accel_deg_s2)
                   for n, a, b in zip(STAGE_AXES, previous, angles))
        dwell = TARGET_DWELL_GUESS_S if step.dwell_rule == "target" else nominal_dwell_s(step, rate)
        out.append(move + SETTLE_GUESS_S + dwell)
        previous = angles
    return out

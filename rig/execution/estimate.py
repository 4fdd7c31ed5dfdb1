"""How long steps take: the one estimate used for the run's ETA and the planned duration.

Moves at the axes' configured speed and acceleration (all axes at once: the slowest sets the
time), 1 s to settle, then the dwell; a prompt and the step that starts a thermal ramp at 0 s (the
ramp runs while its poses are captured). A temperature step is its hold plus the chamber's approach
from the temperature before it (:func:`temperature_step_s`); the first one is counted from its own
target (the chamber's start is not known before the run: a step already in band then takes its hold,
which is what the run's first ETA says, and one that is not adds its approach to the ETA as the run
sees it). A pose whose dwell an accuracy target decides is guessed at :data:`TARGET_DWELL_GUESS_S`
(the run replaces the guess by its plan after the first capture block).
"""

from __future__ import annotations

import math

import numpy as np

from rig.execution.capture import nominal_dwell_s
from rig.planning.kinematics import STAGE_AXES
from rig.planning.targets import move_time_s

SETTLE_GUESS_S = 1.0
TARGET_DWELL_GUESS_S = 3.0
#: the time constant of the sensor following a new chamber set-point, s: the simulated chamber's (rigs/sim.yaml,
#: ``chamber.tau_s``); a chamber of its own makes the run's ETAs move as its temperature comes in
CHAMBER_TAU_GUESS_S = 120.0


def temperature_step_s(target, from_c: float | None) -> float:
    """Expected duration of a temperature step, s: the time a first-order chamber (:data:`CHAMBER_TAU_GUESS_S`)
    takes to bring the sensor from ``from_c`` to within ``target.tolerance_c`` of ``target.target_c``, then its
    ``hold_s``. ``from_c`` None (the first temperature step: where the chamber starts is not known): the hold."""
    gap_c = 0.0 if from_c is None else abs(float(target.target_c) - float(from_c))
    approach_s = CHAMBER_TAU_GUESS_S * math.log(gap_c / target.tolerance_c) if gap_c > target.tolerance_c else 0.0
    return approach_s + float(target.hold_s)


def step_durations_s(steps, rig) -> list[float]:
    """Expected duration of each step, s (index by step index)."""
    out, previous = [], np.zeros(3)
    rate = rig.sensor.sample_rate_hz
    last_c = None  # where the last temperature step (or ramp) left the chamber, C
    for step in steps:
        if step.kind not in ("static", "rate"):
            starts_ramp = getattr(step, "ramp", None) is not None
            target = getattr(step, "temperature", None)
            thermal = step.kind == "thermal" and target is not None
            out.append(temperature_step_s(target, last_c) if thermal and not starts_ramp else 0.0)
            last_c = float(target.target_c) if thermal else last_c
            continue
        angles = np.asarray(step.angles_deg, float)
        move = max(move_time_s(abs(b - a), rig.axes[n].config.speed_deg_s, rig.axes[n].config.accel_deg_s2)
                   for n, a, b in zip(STAGE_AXES, previous, angles))
        dwell = TARGET_DWELL_GUESS_S if step.dwell_rule == "target" else nominal_dwell_s(step, rate)
        out.append(move + SETTLE_GUESS_S + dwell)
        previous = angles
    return out

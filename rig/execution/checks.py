"""Per-step data checks: a step with bad data is re-measured or flagged, never silently used."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

INT16_MAX = 32767
INT16_MIN = -32768


@dataclass(frozen=True)
class CheckLimits:
    """Thresholds for the per-step checks.

    Attributes
    ----------
    saturation_margin_counts : int
        A sample within this many counts of the int16 rails counts as saturated.
    stuck_run : int
        This many identical consecutive raw words on an axis count as stuck data.
    temp_range_c : tuple[float, float]
        Plausible thermometer range, C (outside it the thermometer has failed).
    min_fraction : float
        Fewest samples accepted, as a fraction of those the dwell asked for.
    """

    saturation_margin_counts: int = 2
    stuck_run: int = 50
    temp_range_c: tuple[float, float] = (-40.0, 85.0)
    min_fraction: float = 0.98


@dataclass
class StepCheck:
    """Outcome of the checks on one step's capture."""

    problems: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.problems


def longest_constant_run(x: np.ndarray) -> int:
    """Length of the longest run of identical consecutive values in a 1-D array."""
    x = np.asarray(x)
    if x.size == 0:
        return 0
    change = np.flatnonzero(np.diff(x) != 0)
    edges = np.concatenate(([-1], change, [x.size - 1]))
    return int(np.max(np.diff(edges)))


def check_step(accel_counts: np.ndarray, temp_c: np.ndarray, n_expected: int,
               has_temperature: bool, limits: CheckLimits = CheckLimits()) -> StepCheck:
    """Check one step's samples.

    Parameters
    ----------
    accel_counts : (N, 3) int array of raw counts.
    temp_c : (N,) float array, C (NaN where the sensor has no thermometer).
    n_expected : int
        Samples the dwell asked for (0 when the dwell was open-ended).
    has_temperature : bool
    limits : CheckLimits
    """
    out = StepCheck()
    a = np.asarray(accel_counts)
    n = len(a)
    if n == 0:
        out.problems.append("no samples")
        return out
    if n_expected and n < limits.min_fraction * n_expected:
        out.problems.append(f"too few samples: {n} of {n_expected}")
    rail_hi = INT16_MAX - limits.saturation_margin_counts
    rail_lo = INT16_MIN + limits.saturation_margin_counts
    sat = (a >= rail_hi) | (a <= rail_lo)
    for j, axis in enumerate("xyz"):
        if sat[:, j].any():
            out.problems.append(f"saturated on {axis} ({int(sat[:, j].sum())} samples)")
    if n >= limits.stuck_run:
        for j, axis in enumerate("xyz"):
            run = longest_constant_run(a[:, j])
            if run >= limits.stuck_run:
                out.problems.append(f"stuck reading on {axis} ({run} identical samples)")
    if has_temperature:
        t = np.asarray(temp_c, float)
        lo, hi = limits.temp_range_c
        if not np.all(np.isfinite(t)) or np.any((t < lo) | (t > hi)):
            out.problems.append(f"temperature out of range {lo:g}..{hi:g} C (thermometer failed?)")
    return out

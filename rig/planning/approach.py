"""Every pose approached from the same direction (docs/kinematics.md, "Approach direction").

A worm-gear stage has lost motion: after a reversal the motor turns a little before the table follows, so
a pose reached moving up and the same pose reached moving down differ by the lost motion (0.02 deg class,
``docs/simulated-rig.md``). Approaching every pose from the same side takes it out of the poses (what is
left is the repeatability). An axis whose rig file says ``approach: positive`` (or ``negative``) reaches
each target moving in that direction of the stage: a move that would arrive the other way first goes
``overshoot_deg`` past the target (the planned overshoot, larger than any lost motion), then back. The
controller's own backlash compensation (``Antiplay``, ENGINE_ANTIPLAY) does the same in firmware; the
planned overshoot is used because it works the same on every controller and firmware and shows in the
session's events. Pure.
"""

from __future__ import annotations

#: the approach directions a rig file may give an axis: none (the shortest move), or the stage direction
#: every pose is reached in (+1, -1)
APPROACHES: dict[str, int] = {"none": 0, "positive": 1, "negative": -1}


def pre_target(current_deg: float, target_deg: float, approach: str, overshoot_deg: float,
               soft_limits_deg=(-float("inf"), float("inf"))) -> float | None:
    """Where the stage goes first so that the move to ``target_deg`` arrives moving in direction ``approach``;
    None when the direct move already does (or does not move, or the approach is ``none``), or when the
    overshoot would leave the soft limits (the pose is then reached directly).

    Parameters
    ----------
    current_deg, target_deg : stage positions, deg.
    approach : a key of :data:`APPROACHES`.
    overshoot_deg : how far past the target the stage goes first, deg (> 0).
    soft_limits_deg : (low, high) allowed stage positions, deg.
    """
    sign = APPROACHES[approach]
    travel = target_deg - current_deg
    if sign == 0 or abs(travel) < 1e-9 or sign * travel > 0:
        return None
    first = target_deg - sign * overshoot_deg
    lo, hi = soft_limits_deg
    return first if lo - 1e-9 <= first <= hi + 1e-9 else None


def pre_targets(current_deg: dict[str, float], targets_deg: dict[str, float], configs: dict) -> dict[str, float]:
    """The axes that need a planned overshoot before their move to ``targets_deg``, and where they go first
    (``configs``: axis name -> its rig-file ``AxisConfig``)."""
    out = {}
    for name, target in targets_deg.items():
        c = configs[name]
        first = pre_target(current_deg[name], target, c.approach, c.overshoot_deg, c.soft_limits_deg)
        if first is not None:
            out[name] = first
    return out

"""One small move of one axis, confirmed first, stopped at once on Ctrl-C (``rig jog``; docs/hardware.md).

Angles are kinematic (docs/kinematics.md): ``+5`` turns the axis by 5 deg in the rig file's direction, i.e.
the controller by ``sign * 5`` deg. The move stays within the axis's soft limits and within
:data:`MAX_JOG_DEG`: a jog is for finding ``sign`` and ``home_offset_deg``, and for checking that an axis
turns, not for travelling (several jogs for more).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from rig.config.rigfile import AxisConfig
from rig.errors import RigInputError

#: the largest single jog, deg (kinematic)
MAX_JOG_DEG = 10.0
#: a jog takes at most this long beyond its planned time before it is called stalled, s
JOG_MARGIN_S = 10.0


@dataclass(frozen=True)
class JogPlan:
    """A jog of ``axis`` by ``delta_deg`` (kinematic): the controller goes from ``from_deg`` to ``to_deg``."""

    axis: str
    port: str
    delta_deg: float
    from_deg: float
    to_deg: float
    speed_deg_s: float

    def question(self) -> str:
        return (f"move {self.axis} ({self.port}) by {self.delta_deg:+g} deg: controller {self.from_deg:.3f} -> "
                f"{self.to_deg:.3f} deg at {self.speed_deg_s:g} deg/s?")


def check_step(delta_deg: float) -> None:
    """Refuse (RigInputError) a step that is not a number in [-MAX_JOG_DEG, MAX_JOG_DEG] or is zero."""
    if not (abs(delta_deg) <= MAX_JOG_DEG) or delta_deg == 0:
        raise RigInputError(None, None, "DEG", f"expected a non-zero step of at most {MAX_JOG_DEG:g} deg either way, "
                            f"got {delta_deg:g} (jog again for more)")


def plan_jog(name: str, config: AxisConfig, stage, delta_deg: float) -> JogPlan:
    """Where a jog of ``delta_deg`` takes the controller from where it is; refused beyond the soft limits."""
    check_step(delta_deg)
    here = stage.get_position_deg()
    there = here + config.sign * delta_deg
    low, high = config.soft_limits_deg
    if not low <= there <= high:
        raise RigInputError(None, None, f"turntable.axes.{name}.soft_limits_deg",
                            f"a jog to {there:.3f} deg leaves the soft limits [{low:g}, {high:g}] deg "
                            f"(the controller is at {here:.3f} deg)")
    return JogPlan(name, stage.port, delta_deg, here, there, config.speed_deg_s)


@dataclass(frozen=True)
class JogResult:
    """Where the controller ended, deg, and whether Ctrl-C stopped it first."""

    at_deg: float
    interrupted: bool


def jog(plan: JogPlan, config: AxisConfig, stage, on_start: Callable[[], None] = lambda: None) -> JogResult:
    """Move as planned at the rig file's speed and acceleration and wait until the controller stops. Ctrl-C
    (KeyboardInterrupt) while it moves stops the motor at once (STOP, then wait for it) and says where."""
    stage.set_speed_deg_s(config.speed_deg_s, config.accel_deg_s2)
    timeout_s = abs(plan.to_deg - plan.from_deg) / config.speed_deg_s + 2 * config.speed_deg_s / \
        config.accel_deg_s2 + JOG_MARGIN_S
    try:
        stage.move_deg(plan.to_deg)
        on_start()
        stage.command_wait_for_stop(timeout_s=timeout_s)
    except KeyboardInterrupt:
        stop(stage)
        return JogResult(stage.get_position_deg(), True)
    except BaseException:
        stop(stage)
        raise
    return JogResult(stage.get_position_deg(), False)


def stop(stage) -> None:
    """Stop the motor now and wait until it stands (``rig``'s handlers ignore a second Ctrl-C meanwhile)."""
    stage.command_stop()
    stage.command_wait_for_stop(timeout_s=JOG_MARGIN_S)

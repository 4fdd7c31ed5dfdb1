"""Moving the turntable: plan legal targets, move all axes at once, wait, verify, stop.

Angles: kinematic angles of the procedure (docs/kinematics.md) are turned into stage angles by the
rig's axes; targets respect the soft limits and cable wrap (``rig.planning.targets``).
"""

from __future__ import annotations

import numpy as np

from drivers.ximc.stage import TurntableError
from rig.errors import RigInputError
from rig.execution.context import RunContext
from rig.planning import approach
from rig.planning import targets as planning
from rig.planning.kinematics import STAGE_AXES


def plan_targets(rig, angles_deg, current_deg: dict[str, float]) -> dict[str, float]:
    """Stage targets (deg) for kinematic ``angles_deg`` from the current stage positions.

    Raises
    ------
    RigInputError
        The pose is beyond an axis' soft limits or cable wrap (``key`` names the axis).
    """
    out = {}
    for i, name in enumerate(STAGE_AXES):
        axis = rig.axes[name]
        wanted = axis.stage_angle_deg(float(angles_deg[i]))
        out[name] = planning.plan_axis_target(current_deg[name], wanted, axis.config.soft_limits_deg,
                                              axis.config.cable_wrap_deg, axis=name)
    return out


def move_to(ctx: RunContext, step) -> None:
    """Move every axis to the step's pose at once; raise ``TurntableError`` if one falls short."""
    ctx.progress(step, "move")
    rig = ctx.rig
    current = {name: rig.axes[name].stage.get_position_deg() for name in STAGE_AXES}
    targets = plan_targets(rig, step.angles_deg, current)
    first = approach.pre_targets(current, targets, {n: rig.axes[n].config for n in STAGE_AXES})
    if first:  # the axes that would arrive against their approach direction overshoot first
        _move_axes(ctx, step, current, first)
        current.update(first)
    _move_axes(ctx, step, current, targets)


def _move_axes(ctx: RunContext, step, current: dict[str, float], targets: dict[str, float]) -> None:
    """Move the axes of ``targets`` at once; raise ``TurntableError`` if one falls short."""
    rig = ctx.rig
    for name in targets:
        if abs(targets[name] - current[name]) > 1e-6:
            ctx.event("move", step=step.index, axis=name, from_deg=current[name], to_deg=targets[name])
            rig.axes[name].stage.move_deg(targets[name])
    _coarse_wait(rig, targets)
    for name in targets:
        stage = rig.axes[name].stage
        stage.command_wait_for_stop(50, timeout_s=ctx.options.move_timeout_s)
        reached = stage.get_position_deg()
        if abs(reached - targets[name]) > ctx.options.position_tolerance_deg:
            raise TurntableError(stage.port, "move", f"{name} stopped at {reached:.4f} deg, short of target "
                                 f"{targets[name]:.4f} deg", name=name)


def _coarse_wait(rig, targets: dict[str, float]) -> None:
    """Wait out the bulk of a long move polling every 0.5 s (errors still seen within 0.5 s),
    leaving the last 0.3 s to the 50 ms poll of ``command_wait_for_stop``."""
    clock = rig.clock
    t_end = clock.now()
    for name, target in targets.items():
        axis = rig.axes[name]
        distance = abs(target - axis.stage.get_position_deg())
        t_end = max(t_end, clock.now() + planning.move_time_s(distance, axis.config.speed_deg_s,
                                                              axis.config.accel_deg_s2))
    while t_end - clock.now() > 0.8:
        clock.sleep(0.5)
        for name in targets:
            status = rig.axes[name].stage.get_status()
            if not status.running and status.command_error:
                return  # command_wait_for_stop raises with the details


def angles_now_deg(rig) -> np.ndarray:
    """The kinematic angles the controllers report now, deg (3,)."""
    return np.array([rig.axes[n].kinematic_angle_deg(rig.axes[n].stage.get_position_deg()) for n in STAGE_AXES])


def wrap_position(ctx: RunContext, name: str) -> None:
    """After spinning, renumber the stage position into (-180, 180] (the same physical angle)."""
    stage = ctx.rig.axes[name].stage
    pos = stage.get_position_deg()
    wrapped = (pos + 180.0) % 360.0 - 180.0
    if abs(wrapped - pos) > 1e-9:
        stage.set_position_deg(wrapped)
        ctx.event("renumber", axis=name, from_deg=pos, to_deg=wrapped)


def stop_motors(rig, soft: bool) -> None:
    """Stop every axis (soft: decelerate; else at once); never raises: the port may be gone."""
    for axis in rig.axes.values():
        try:
            axis.stage.command_sstp() if soft else axis.stage.command_stop()
        except Exception:  # noqa: BLE001 - try the hard stop, then the other axes
            try:
                axis.stage.command_stop()
            except Exception:  # noqa: BLE001
                pass


def check_reachable(procedure, steps, rig, start_deg: dict[str, float] | None) -> None:
    """Plan every move before anything moves: an unreachable pose is refused up front, naming the
    step and the axis (RigInputError)."""
    current = dict(start_deg or {n: 0.0 for n in STAGE_AXES})
    for step in steps:
        if step.angles_deg is None or step.kind not in ("static", "rate"):
            continue
        try:
            current = plan_targets(rig, step.angles_deg, current)
        except RigInputError as exc:
            raise RigInputError(procedure.path, step.source_line, f"steps: {step.name}: {exc.key}",
                                exc.message) from None

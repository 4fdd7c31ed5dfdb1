"""A pose whose dwell the procedure's accuracy target decides (``target:``; docs/procedures.md,
"Accuracy targets").

Like a static step (move, settle from the accelerometer, capture, check, record; re-measured on bad
data), but the capture runs in blocks and after every block the run's
:class:`~rig.execution.executors.target_policy.TargetPolicy` decides whether more samples at this
pose still pay. The decision of each pose is recorded in its stats (``target``); after the last
targeted pose the prediction from the recorded steps is an event (``target``) and a line for the
operator. :func:`preflight` refuses, before anything moves, a time cap the moves and settling alone
exceed and a target out of reach even at the chip's datasheet noise.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from calib.accel.predict import Predictor, plan_dwell
from drivers.sensors.chips import CHIPS
from rig.errors import RigInputError
from drivers.sensors.base import SampleBlock
from rig.execution.capture import (SETTLERS, Capture, loss_counters, lost_samples, nominal_dwell_s,
                                   poll_interval_s)
from rig.execution.capture import settle_and_capture as static_capture
from rig.execution.context import RunContext
from rig.execution.executors import static
from rig.execution.executors.target_policy import MIN_DWELL_S, TargetPolicy, TargetSetup

#: a capture that receives nothing for this long ends (a replayed recording ran out), s
IDLE_TIMEOUT_S = 1.0
#: the preflight takes a mean over T seconds to scatter like density * sqrt(OPTIMISM / T) (physics: 0.5;
#: the white-noise simulator at 1 kHz reaches 0.29): a target refused with it is out of reach on any setting
OPTIMISM = 0.25


def preflight(procedure, step, rig) -> None:
    """Once per procedure (at its first targeted pose): the time cap must leave room for the moves,
    the settling and the least dwell, and an attitude target must be within reach at the chip's
    datasheet noise (RigInputError naming ``target.max_seconds`` or ``target``). The sensor may not be
    configured yet, so its counts per g may not be the procedure's: an attitude bound does not depend
    on them (noise and bias stability are taken in the same counts); sigma targets, in counts, are
    left to the run."""
    targeted = [s for s in procedure.expanded_steps() if s.dwell_rule == "target"]
    if step.index != targeted[0].index:
        return
    policy = TargetSetup(procedure, rig)
    cap = procedure.target.max_seconds
    overhead = sum(policy.overhead_of(s.index) for s in policy.statics)
    fixed = sum(nominal_dwell_s(s, policy.rate) for s in policy.statics if s.dwell_rule != "target")
    least = overhead + fixed + MIN_DWELL_S * len(targeted)
    if least > cap:
        raise RigInputError(procedure.path, None, "target.max_seconds",
                            f"{cap:g} s is less than the moves, settling and least dwell alone (about {least:.0f} s "
                            f"on this rig): raise it")
    chip = CHIPS.get(rig.sensor.model)
    density = min(chip.accel_noise_density_g_rthz) if chip is not None else None  # the quietest axis: optimistic
    if density is None or procedure.target.attitude_error_deg is None:
        return  # sigma targets are in counts, whose scale the sensor knows only once configured
    attitude_only = Predictor(replace(policy.goal, sigma={}), rig.sensor.accel_lsb_per_g,
                              stability=policy.predictor.stability)
    f = np.array([s.f_nominal for s in policy.statics], float)
    free = np.array([s.dwell_rule == "target" for s in policy.statics])
    attitude_only.timeline = policy.timeline(0.0, policy.statics, [MIN_DWELL_S if s.dwell_rule == "target" else
                                                                   nominal_dwell_s(s, policy.rate)
                                                                   for s in policy.statics])
    unit = np.full(3, density * np.sqrt(OPTIMISM) * rig.sensor.accel_lsb_per_g)
    sem = np.tile(unit, (len(f), 1)) / np.sqrt([[max(nominal_dwell_s(s, policy.rate), MIN_DWELL_S)]
                                                for s in policy.statics])
    plan = plan_dwell(attitude_only, f, sem, unit, free, np.where(free, MIN_DWELL_S, 0.0), cap - overhead - fixed)
    if not plan.feasible:
        raise RigInputError(procedure.path, None, "target",
                            f"out of reach within max_seconds {cap:g}: even at the {rig.sensor.model}'s datasheet "
                            f"noise ({density * 1e6:.0f} ug/rtHz)"
                            + (" and with this unit's bias stability (its noise profile)"
                               if rig.unit_accel_stability is not None else "")
                            + f" the best reachable is {plan.ratio:.2g} times the target after the moves and "
                            "settling; relax the target or raise max_seconds")


def execute(ctx: RunContext, step) -> None:
    """A pose of a procedure with a target: its dwell decided by the policy, or its own (``given``)."""
    if ctx.target is None:
        ctx.target = TargetPolicy.for_run(ctx)
    policy = ctx.target
    if step.dwell_rule == "given":  # a pose with its own dwell: captured as stated, its data joins the plan
        capture, status = static.run_pose(ctx, step, static_capture)
    else:
        capture, status = static.run_pose(ctx, step, lambda c, s: settle_and_capture(c, s, policy),
                                          extra_stats=lambda: {"target": policy.step_stats(step)}, expected=0)
    policy.commit(step, capture.samples, status)
    if policy.is_last(step):
        policy.conclude()


def settle_and_capture(ctx: RunContext, step, policy: TargetPolicy) -> Capture:
    """Start the sensor, settle as the rig says, capture until the policy stops the pose; lost samples
    flag the step or stop the run (``rig.execution.capture.lost_samples``)."""
    since = loss_counters(ctx.rig.sensor)
    ctx.rig.sensor.start()
    keep, settle_s, problems = SETTLERS[ctx.rig.settle](ctx, step)
    samples = capture_until_decided(ctx, step, keep, policy)
    problems += lost_samples(ctx, step, since)  # flags the step, or stops the run (as a fixed dwell's capture)
    return Capture(samples, settle_s, problems)


def capture_until_decided(ctx: RunContext, step, keep: SampleBlock, policy: TargetPolicy) -> SampleBlock:
    """Read the sensor; at every ``policy.block_n`` samples (from ``policy.min_n`` on) ask the policy
    whether to stop. The decision sees exactly the first n samples, so a replay stops alike."""
    sensor, clock = ctx.rig.sensor, ctx.rig.clock
    parts, n = [keep], len(keep)
    next_n, stop_n = policy.min_n, None
    last_data = clock.now()
    while stop_n is None:
        clock.sleep(poll_interval_s(sensor))
        block = sensor.read()
        if len(block.t_s):
            parts.append(SampleBlock(block.t_s, block.accel_counts, block.temp_c, block.gyro_counts))
            n += len(block.t_s)
            last_data = clock.now()
        elif clock.now() - last_data > IDLE_TIMEOUT_S:
            stop_n = n  # nothing comes any more (a replayed recording ended here)
        joined = _join(parts) if n >= next_n else None
        while stop_n is None and n >= next_n:
            decision = policy.decide(step, joined.accel_counts[:next_n], joined.t_s[:next_n] - ctx.t0_s)
            ctx.progress(step, "capture", eta_s=decision.eta_s, noise_ug=_noise_ug(joined.accel_counts[:next_n],
                                                                                   sensor.accel_lsb_per_g),
                         temp_c=float(joined.temp_c[next_n - 1]), predicted=decision.predicted,
                         target=decision.target, target_unit=decision.unit)
            stop_n = next_n if decision.stop else None
            next_n += policy.block_n
    sensor.stop()
    return _cut(_join(parts), stop_n)


def _join(parts: list[SampleBlock]) -> SampleBlock:
    gyros = [p.gyro_counts for p in parts if p.gyro_counts is not None]
    return SampleBlock(np.concatenate([p.t_s for p in parts]),
                       np.concatenate([p.accel_counts for p in parts]).astype(np.int64),
                       np.concatenate([p.temp_c for p in parts]),
                       np.concatenate(gyros).astype(np.int64) if gyros else None)


def _cut(s: SampleBlock, n: int) -> SampleBlock:
    return SampleBlock(s.t_s[:n], s.accel_counts[:n], s.temp_c[:n], None if s.gyro_counts is None else s.gyro_counts[:n])


def _noise_ug(a: np.ndarray, lsb: float) -> float | None:
    return float(np.max(a.std(axis=0, ddof=1)) / lsb * 1e6) if len(a) > 2 else None

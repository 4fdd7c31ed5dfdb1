"""The engine: owns the loop over a procedure's steps, the abort and the cleanup.

Each step kind has a small executor (an :class:`~rig.execution.executors.Executor`, chosen by the
table of ``rig.execution.executors``); the engine checks every remaining step before anything moves
(:meth:`Engine.preflight`), prepares the axes and runs the steps, and stops the motors on any error or interruption. Every finished step is durable before
the next begins, so an interrupted run resumes from the first incomplete step (``first_step``).
"""

from __future__ import annotations

from rig.config.procedure import Procedure
from rig.devices.rig import Rig
from rig.errors import RigInputError
from rig.execution.context import EngineOptions, RunAborted, RunContext, StepOutcome
from rig.execution.estimate import step_durations_s
from rig.execution.executors import executor_for
from rig.execution.motion import check_reachable, stop_motors
from rig.execution.operator import Operator, OperatorAbsent, SilentOperator
from rig.planning.kinematics import STAGE_AXES
from rig.session.writer import SessionWriter


def check_before_recording(procedure: Procedure, rig: Rig, operator: Operator, *, first_step: int = 0,
                           start_deg: dict[str, float] | None = None) -> None:
    """Everything that can be refused before a session directory exists or anything moves: the sensor
    the procedure names, every remaining pose and rate (soft limits, cable wrap, stage speed), a
    thermometer for temperature steps, someone to answer the prompts, and a rig clock this machine can keep
    up with (a time-scaled simulated rig: :meth:`Rig.check_keep_up`)."""
    wanted = procedure.sensor.model
    if wanted is not None and wanted != rig.sensor.model:
        raise RigInputError(procedure.path, None, "sensor.model", f"the procedure is for the {wanted}, but the "
                            f"rig's sensor is the {rig.sensor.model}; run it on a rig with that sensor")
    steps = procedure.expanded_steps()[first_step:]
    check_reachable(procedure, steps, rig, start_deg)
    for step in steps:
        executor_for(step).preflight(procedure, step, rig)
    asks = [s for s in steps if s.kind == "prompt" or (
        s.kind == "thermal" and (s.temperature.mode != "wait" or rig.chamber is None))]
    if asks and not operator.can_confirm():
        raise OperatorAbsent(f"step {asks[0].index + 1} ({asks[0].name}) asks the operator to confirm, and nobody "
                             "can answer here (no terminal): run it from a terminal or with --yes")
    if any(s.kind in ("static", "rate") for s in steps):
        rig.check_keep_up(procedure.sensor_settings())  # a clock this machine cannot keep up with (time-scaled sim)


class Engine:
    """Execute a procedure's steps on a rig, recording a session.

    Parameters
    ----------
    procedure : rig.config.procedure.Procedure
    rig : Rig
    recorder : rig.session.SessionWriter
        Where events, samples and finished steps go.
    operator : Operator
        Sees progress and warnings; confirms prompts.
    first_step : int
        Index of the first step to execute (resume); earlier steps are kept as recorded.
    time_offset_s : float
        Session time at the start of this run (resume: where the interrupted run stopped).
    magnetometer_samples : int
        Magnetometer readings per static step (0: the procedure does not read it).
    """

    def __init__(self, procedure: Procedure, rig: Rig, recorder: SessionWriter, operator: Operator | None = None, *,
                 first_step: int = 0, options: EngineOptions = EngineOptions(), time_offset_s: float = 0.0,
                 magnetometer_samples: int = 0) -> None:
        self.procedure = procedure
        self.steps = procedure.expanded_steps()
        self.first_step = first_step
        self.ctx = RunContext(procedure=procedure, rig=rig, recorder=recorder,
                              operator=operator or SilentOperator(), options=options,
                              t0_s=rig.clock.now() - time_offset_s, total_steps=len(self.steps),
                              estimates_s=step_durations_s(self.steps, rig),
                              magnetometer_samples=magnetometer_samples,
                              io_retries_seen=rig.sensor.stats.io_retries)

    @property
    def outcomes(self) -> list[StepOutcome]:
        return self.ctx.outcomes

    def session_time(self) -> float:
        """Seconds since the session started (continues across resumes)."""
        return self.ctx.session_time()

    def remaining_duration_s(self) -> float:
        """Expected rig time of the steps still to run, s."""
        return sum(self.ctx.estimates_s[self.first_step:])

    def preflight(self, start_deg: dict[str, float] | None = None) -> None:
        """Check every remaining step before anything moves: poses within the soft limits and cable
        wrap, rates the stage can turn, a thermometer for temperature steps."""
        check_before_recording(self.procedure, self.ctx.rig, self.ctx.operator, first_step=self.first_step,
                               start_deg=start_deg)

    def prepare(self, resuming: bool, preflight: bool = True) -> None:
        """Preflight (unless the caller ran :func:`check_before_recording` already), then apply the move
        settings and the rig's home/zero policy; a Ctrl-C or an error while homing stops the motors, as
        in :meth:`run`."""
        try:
            self._prepare(resuming, preflight)
        except KeyboardInterrupt:
            stop_motors(self.ctx.rig, soft=True)
            raise RunAborted("interrupted by the operator") from None
        except BaseException:
            stop_motors(self.ctx.rig, soft=False)
            raise

    def _prepare(self, resuming: bool, preflight: bool) -> None:
        rig = self.ctx.rig
        if preflight:
            self.preflight({n: rig.axes[n].stage.get_position_deg() for n in STAGE_AXES} if resuming else None)
        for axis in rig.axes.values():
            axis.stage.set_speed_deg_s(axis.config.speed_deg_s, accel_deg_s2=axis.config.accel_deg_s2)
        if rig.home_policy == "home":
            for name in STAGE_AXES:
                self.ctx.event("home", axis=name)
                rig.axes[name].stage.command_home()
            for name in STAGE_AXES:
                rig.axes[name].stage.command_wait_for_stop(10, timeout_s=self.ctx.options.move_timeout_s)
                rig.axes[name].stage.command_zero()
        elif rig.home_policy == "zero" and not resuming:
            for name in STAGE_AXES:
                self.ctx.event("zero", axis=name)
                rig.axes[name].stage.command_zero()
        if resuming:
            self._restore_temperature()
            self._restore_mounting()

    def _restore_temperature(self) -> None:
        """A resume continues at the temperature of the last temperature step before it (a hold point, or
        a ramp: its executor's ``restore``), unless it resumes at a hold point (which sets its own)."""
        before = [s for s in self.steps[:self.first_step] if s.kind == "thermal"]
        if before and self.first_step < len(self.steps) and self.steps[self.first_step].executor != "thermal":
            executor_for(before[-1]).restore(self.ctx, before[-1], self.steps[self.first_step])

    def _restore_mounting(self) -> None:
        """A resume continues with the sensor in the mounting of the last re-mounting prompt before it (its
        executor's ``restore``: the operator confirms, the rig turns a simulated sensor), unless it resumes at a
        re-mounting prompt (which sets its own)."""
        before = [s for s in self.steps[:self.first_step] if s.kind == "prompt" and s.mount is not None]
        resumes_at = self.steps[self.first_step] if self.first_step < len(self.steps) else None
        if before and resumes_at is not None and not (resumes_at.kind == "prompt" and resumes_at.mount is not None):
            executor_for(before[-1]).restore(self.ctx, before[-1], resumes_at)

    def run(self) -> list[StepOutcome]:
        """Execute the steps from ``first_step`` on; stop all motors on any error."""
        try:
            for step in self.steps[self.first_step:]:
                self.ctx.rig.begin_step(step.index)
                executor_for(step).execute(self.ctx, step)
        except KeyboardInterrupt:
            stop_motors(self.ctx.rig, soft=True)
            raise RunAborted("interrupted by the operator") from None
        except BaseException:
            stop_motors(self.ctx.rig, soft=False)
            raise
        return self.ctx.outcomes

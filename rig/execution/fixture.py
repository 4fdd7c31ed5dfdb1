"""The fixture engine: one motion per pose, every live slot captured at every pose, each into its own session.

A fixture run (docs/fixture.md, "A fixture run") drives the turntable once for N units. The
:class:`FixtureEngine` owns the loop over the procedure's steps: it prepares the axes as the one-sensor
:class:`~rig.execution.engine.Engine` does (the same code), moves once per pose (:func:`move_to`), then
captures every live slot in one poll loop (:func:`capture_slots`): at each poll it reads every slot's FIFO in
turn (each read selects the slot's multiplexer channel first), and each slot settles and captures its dwell on
its own samples, as the one-sensor capture would. Each slot's step is then checked and recorded into the slot's
own session by the static executor's recorder.

**Isolation.** A slot whose sensor fails (a :class:`~drivers.sensors.base.SensorError`: no answer, a
multiplexer channel that does not take; or a step whose outputs are on a rail or frozen, :data:`CHIP_FAILURES`) is
*faulted*: its reason is kept, ``on_fault`` is told (the workflow
marks its session aborted) and the motion goes on for the others. Its reads cost the others no clock time (the
drivers retry without sleeping), so the others' data are what they would be without it. Anything else (the
turntable, an interrupt) stops the motors and leaves the engine, as in the one-sensor engine.

**Resume** (:class:`FixtureEngine` with ``first_step``): the motion continues at the earliest first unfinished
step of the slots it resumes (``SlotRun.first_step``, each slot's own: an interruption between two slots'
recordings of one pose leaves them one step apart); a slot records only the steps it has not finished.

Static poses with a fixed dwell run on a fixture, and temperature set-points and prompts once for every slot
(:data:`SHARED_STEPS`); rate steps, ramps and accuracy-targeted dwells not yet (:func:`check_fixture_procedure`,
before anything moves); a flagged step is recorded flagged, not measured again.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from drivers.sensors.base import SampleBlock, SensorError
from rig.config.procedure import PlannedStep, Procedure
from rig.devices.fixture import Slot
from rig.devices.rig import Rig
from rig.errors import RigInputError
from rig.execution.capture import Capture, _join, expected_samples, loss_counters, nominal_dwell_s, poll_interval_s
from rig.execution.checks import check_step
from rig.execution.context import EngineOptions, RunAborted, RunContext
from rig.execution.engine import Engine
from rig.execution.executors import prompt, static, temperature
from rig.execution.motion import move_to, stop_motors
from rig.execution.operator import Operator
from rig.execution.settle import SettleDetector, SettleRule

#: the step executors a fixture runs (PlannedStep.executor)
FIXTURE_EXECUTORS = ("static", "thermal", "prompt")


#: a step check's problems that say the chip itself failed (its outputs on a rail, or frozen): a slot that shows
#: one is quarantined (FAULT) for the rest of the batch, not calibrated from its other steps
CHIP_FAILURES = ("saturated on", "stuck reading on")


def check_fixture_procedure(procedure: Procedure) -> None:
    """Refuse (RigInputError, one line) a procedure a fixture cannot run yet, before anything moves."""
    for step in procedure.expanded_steps():
        static_ok = step.executor != "static" or (step.dwell is not None and step.dwell.sem_g is None)
        if step.executor == "prompt" and step.mount is not None and step.mount.name != "x+z+":
            raise RigInputError(procedure.path, step.source_line, "steps",
                                f"step {step.index + 1} ({step.name}) turns the sensor in its fixture (mount:): a fixture's "
                                "slots keep their mountings (a reversal runs on a one-sensor rig, docs/uncertainty.md)")
        if step.executor not in FIXTURE_EXECUTORS or not static_ok:
            what = step.executor if step.executor != "static" else "an uncertainty-targeted dwell"
            raise RigInputError(procedure.path, step.source_line, "steps",
                                f"step {step.index + 1} ({step.name}) is {what}: a fixture runs static poses with a "
                                "dwell of seconds or samples, temperature set-points and prompts only (docs/fixture.md, "
                                "\"A fixture run\")")


@dataclass
class SlotRun:
    """One slot in a fixture run: its slot, its own run context (its rig view and its session), the first step
    it records (``first_step``: 0, or its first unfinished step on a resume) and, once its sensor has failed, the
    reason (``fault``: one line) and the step it failed at."""

    slot: Slot
    ctx: RunContext
    fault: str | None = None
    fault_step: int | None = None
    first_step: int = 0

    @property
    def live(self) -> bool:
        return self.fault is None

    def due(self, step: PlannedStep) -> bool:
        """Whether this slot records ``step``: live, and the step not finished before (a resume)."""
        return self.live and step.index >= self.first_step


class FanOut:
    """The motion's recorder: an event of the shared motion (a move, a home) goes into every live slot's session."""

    def __init__(self, runs: list[SlotRun], where) -> None:
        self.runs = runs
        self.session_dir = where

    def event(self, kind: str, **fields) -> None:
        for run in self.runs:
            if run.live:
                run.ctx.recorder.event(kind, **fields)


@dataclass
class _SlotCapture:
    """One slot's capture of one step in progress: settling, then capturing, then done."""

    run: SlotRun
    detector: SettleDetector
    since: tuple[int, int]
    n_target: int
    phase: str = "settle"  # settle | capture | done
    settle_s: float | None = None
    problems: list[str] = field(default_factory=list)
    parts: list[SampleBlock] = field(default_factory=list)
    t_capture_s: float = 0.0

    @property
    def n(self) -> int:
        return sum(len(p) for p in self.parts)


class FixtureEngine:
    """Execute a procedure on a fixture: one motion per pose, every live slot recorded into its own session.

    Parameters
    ----------
    procedure : Procedure
    rig : Rig
        The turntable (axes, clock, chamber) the slots sit on.
    runs : list of SlotRun
        The slots to record, each with its run context (its session).
    operator : Operator
    options : EngineOptions
    on_fault : callable
        Called with a slot's run and the exception when its sensor fails (the run goes on without it).
    where : path
        The batch's directory (for messages).
    time_offset_s : float
        A resume: the session time the motion continues at (every slot's sessions share one clock).

    A resume starts the motion at the earliest ``first_step`` of the runs.
    """

    def __init__(self, procedure: Procedure, rig: Rig, runs: list[SlotRun], operator: Operator, *,
                 options: EngineOptions = EngineOptions(), on_fault: Callable[[SlotRun, BaseException], None],
                 where=None, time_offset_s: float = 0.0) -> None:
        self.procedure = procedure
        self.rig = rig
        self.runs = runs
        self.on_fault = on_fault
        first = min((r.first_step for r in runs), default=0)
        self.engine = Engine(procedure, rig, FanOut(runs, where), operator, options=options, first_step=first,
                             time_offset_s=time_offset_s)
        self.ctx = self.engine.ctx  # the motion's context: the shared clock, the session time, the operator
        for run in runs:  # one session time for the motion and every slot
            run.ctx.t0_s = self.ctx.t0_s

    def prepare(self, resuming: bool = False) -> None:
        """The axes' speeds and the home/zero policy, as the one-sensor engine does (checked before already); a
        resume keeps the axes' zero and restores the last temperature set-point before it, waiting on the first
        live slot's thermometer (the one-sensor engine's restore)."""
        live = [r for r in self.runs if r.live]
        if resuming and live:  # the restore reads a thermometer: a live slot's, not the rig's first slot's
            self.ctx.rig = live[0].ctx.rig
        try:
            self.engine.prepare(resuming=resuming, preflight=False)
        finally:
            self.ctx.rig = self.rig

    def run(self) -> list[SlotRun]:
        """Every step (from the first a slot has not finished): move once, capture every slot that records it,
        record each; stop the motors on any error."""
        try:
            for step in self.engine.steps[self.engine.first_step:]:
                self.rig.begin_step(step.index)
                if not any(r.live for r in self.runs):
                    break
                if step.executor in SHARED_STEPS:  # the chamber or the operator: one for every slot
                    SHARED_STEPS[step.executor](self, step)
                    continue
                move_to(self.ctx, step)
                captures = capture_slots(self.ctx, step, [r for r in self.runs if r.due(step)], self._fault)
                for cap in captures:
                    if cap.run.live:
                        self._record(step, cap)
        except KeyboardInterrupt:
            stop_motors(self.rig, soft=True)
            raise RunAborted("interrupted by the operator") from None
        except BaseException:
            stop_motors(self.rig, soft=False)
            raise
        return self.runs

    def _temperature(self, step: PlannedStep) -> None:
        """A temperature set-point: the chamber is set once, the wait reads a live slot's thermometer (the next one
        when it fails: that slot is faulted), and every live slot's session records the step with its own
        thermometer's reading at the end."""
        temperature.apply_setpoint(self.ctx, step)
        t_start = self.rig.clock.now()
        while True:
            live = [r for r in self.runs if r.due(step)]
            if not live:
                return
            try:
                mean_c, first_c = temperature.wait_in_band(live[0].ctx, step, t_start)
                break
            except SensorError as exc:
                self._fault(live[0], step, exc)
        waited_s = self.rig.clock.now() - t_start
        for run in (r for r in self.runs if r.due(step)):
            try:
                own_c = run.ctx.rig.sensor.read_temperature_c()
                run.ctx.event("temperature", step=step.index, temp_c=own_c, start_c=first_c, waited_s=waited_s,
                              band_mean_c=mean_c)
                run.ctx.recorder.complete_step(step.index, {"t_end_s": run.ctx.session_time(), "temp_c": own_c,
                                                            "waited_s": waited_s})
            except SensorError as exc:
                self._fault(run, step, exc)

    def _prompt(self, step: PlannedStep) -> None:
        """A prompt: asked once (the operator answers for the whole fixture), recorded in every live slot's session."""
        text = prompt.question(step)
        ok = self.ctx.operator.confirm(text)
        for run in (r for r in self.runs if r.due(step)):
            run.ctx.event("prompt", step=step.index, text=text, answer="yes" if ok else "abort")
        if not ok:
            raise RunAborted(f"operator aborted at step {step.index + 1} ({step.name})")
        for run in (r for r in self.runs if r.due(step)):
            run.ctx.recorder.complete_step(step.index, {"t_end_s": run.ctx.session_time()})

    def _fault(self, run: SlotRun, step: PlannedStep, exc: BaseException) -> None:
        run.fault = f"step {step.index + 1} ({step.name}): {exc}"
        run.fault_step = step.index
        self.ctx.operator.warn(f"slot {run.slot.index} ({run.slot.serial}): FAULT at {run.fault}; the others go on")
        try:
            run.ctx.recorder.event("error", t_s=run.ctx.session_time(), step=step.index, source="sensor",
                                   message=f"slot {run.slot.index} quarantined: {exc}")
        except (OSError, ValueError):
            pass
        self.on_fault(run, exc)

    def _record(self, step: PlannedStep, cap: _SlotCapture) -> None:
        ctx = cap.run.ctx
        sensor = ctx.rig.sensor
        samples = _join(cap.parts, cap.n_target)
        overflows, dropped = (now - then for now, then in zip(loss_counters(sensor), cap.since))
        problems = list(cap.problems)
        if overflows > 0:
            problems.append(f"sensor FIFO overflowed {overflows} time(s), {dropped} samples lost: "
                            f"{ctx.rig.explain_lost_samples().reason}")
        check = check_step(samples.accel_counts, samples.temp_c, cap.n_target, sensor.has_temperature,
                           ctx.options.limits)
        problems += check.problems
        status = "complete" if not problems else "flagged"
        broken = [p for p in check.problems if p.startswith(CHIP_FAILURES)]
        if problems and not broken:
            ctx.warn(step, f"slot {cap.run.slot.index}: step {step.index + 1} ({step.name}) flagged and left out of "
                           "the solve: " + "; ".join(problems))
        try:
            static._record(ctx, step, Capture(samples, cap.settle_s, problems), 1, problems, status)
        except SensorError as exc:  # its magnetometer did not answer
            self._fault(cap.run, step, exc)
            return
        if broken:  # the chip's outputs are on a rail or frozen: this unit is quarantined, the motion goes on
            self._fault(cap.run, step, SensorError("; ".join(broken) + ": the sensor's outputs failed"))


def capture_slots(ctx: RunContext, step: PlannedStep, runs: list[SlotRun],
                  fault: Callable[[SlotRun, PlannedStep, BaseException], None]) -> list[_SlotCapture]:
    """Start every slot's sensor, then poll them all until each has settled and captured the step's dwell.

    Each slot's settling (``step.settle``) and dwell are judged on its own samples; one poll reads every slot
    still capturing, in slot order, every ``poll_interval_s`` of the fastest-filling FIFO. A slot whose sensor
    fails is handed to ``fault`` and left out. Returns the captures of the slots still live, stopped.
    """
    clock = ctx.rig.clock
    s = step.settle
    rule = SettleRule(window_s=s.window_s, threshold_g=s.threshold_g, mean_tol_sigma=s.mean_tol_sigma,
                      timeout_s=s.timeout_s, min_s=s.min_s)
    caps: list[_SlotCapture] = []
    t_start = clock.now()
    ctx.progress(step, "settle")
    for run in runs:
        sensor = run.ctx.rig.sensor
        try:
            since = loss_counters(sensor)
            sensor.start()
        except SensorError as exc:
            fault(run, step, exc)
            continue
        detector = SettleDetector(rule, sensor.sample_rate_hz, sensor.accel_lsb_per_g)
        detector.start(t_start)
        caps.append(_SlotCapture(run, detector, since, expected_samples(step, sensor.sample_rate_hz)))
    if not caps:
        return []
    poll = min(poll_interval_s(c.run.ctx.rig.sensor) for c in caps)
    dwell_timeout_s = 2.0 * max(nominal_dwell_s(step, c.run.ctx.rig.sensor.sample_rate_hz) for c in caps) + 5.0
    while any(c.phase != "done" and c.run.live for c in caps):
        clock.sleep(poll)
        for cap in caps:
            if cap.phase == "done" or not cap.run.live:
                continue
            try:
                block = cap.run.ctx.rig.sensor.read()
            except SensorError as exc:
                fault(cap.run, step, exc)
                continue
            _advance(cap, step, block, clock.now(), t_start, rule.timeout_s, dwell_timeout_s)
        ctx.progress(step, "capture")
    for cap in caps:
        if cap.run.live:
            try:
                cap.run.ctx.rig.sensor.stop()
            except SensorError as exc:
                fault(cap.run, step, exc)
    return [c for c in caps if c.run.live]


def _advance(cap: _SlotCapture, step: PlannedStep, block: SampleBlock, now_s: float, t_start_s: float,
             settle_timeout_s: float, dwell_timeout_s: float) -> None:
    """Feed one slot's new samples to its settling or its dwell (the one-sensor capture's rules)."""
    ctx = cap.run.ctx
    if cap.phase == "settle":
        settled = cap.detector.feed(block.t_s, block.accel_counts, block.temp_c, block.gyro_counts)
        if settled is not None:
            ctx.event("settle", step=step.index, settle_s=settled.elapsed_s,
                      noise_g=[float(x) for x in settled.noise_g])
            cap.settle_s = settled.elapsed_s
            if ctx.options.keep_settle_windows:
                cap.parts.append(SampleBlock(settled.keep_t_s, settled.keep_accel, settled.keep_temp_c,
                                             settled.keep_gyro))
            cap.phase, cap.t_capture_s = "capture", now_s
        elif now_s - t_start_s > settle_timeout_s:  # capture anyway from here on; the step is flagged
            cap.problems.append(f"did not settle within {settle_timeout_s:g} s")
            cap.phase, cap.t_capture_s = "capture", now_s
        if not cap.parts:
            cap.parts.append(SampleBlock.empty(block.gyro_counts is not None))
        return
    if len(block.t_s):
        cap.parts.append(block)
    if (cap.n_target and cap.n >= cap.n_target) or now_s - cap.t_capture_s > dwell_timeout_s:
        cap.phase = "done"


__all__ = ["FixtureEngine", "SlotRun", "capture_slots", "check_fixture_procedure"]


#: the steps a fixture runs once for every slot (the shared chamber, the one operator), by executor
SHARED_STEPS = {"thermal": FixtureEngine._temperature, "prompt": FixtureEngine._prompt}

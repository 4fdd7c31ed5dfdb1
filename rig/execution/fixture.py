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

**Targeted dwells** (a dwell of ``sem_g``, or a procedure with an accuracy ``target:``): one motion, and the dwell at
a pose goes on until every live slot has met its own rule (the slowest unit decides; a quarantined slot no longer
counts). Each slot's rule is the one-sensor run's on its own samples: ``sem_stop_index`` for ``sem_g`` (bounded by
the dwell's ``max_seconds``), its own :class:`~rig.execution.executors.target_policy.TargetPolicy` for a target
(its own plan, time cap and refusal; decided at every block of its samples while the pose lasts, so the stats
recorded describe exactly the samples recorded). A slot that met its rule early goes on capturing while the
others finish: its session holds the whole dwell (its achieved standard error is below its target).

**Ramps** (:mod:`~rig.execution.executors.ramp`): the chamber is set ramping once for every slot, each slot's
session records the start with its own thermometer's reading; each pose of the ramp is one motion, captured by
every live slot while the chamber moves, and its stats add ``ramp`` with the temperature rate that slot's own
thermometer saw over its capture (the one-sensor ramp's). A resume inside a ramp restores the chamber from the
first live slot's record of the leg (the one-sensor engine's restore).

Static poses, targeted or not, and the poses of a ramp run on a fixture, and temperature set-points, a ramp's
start and prompts once for every slot (:data:`SHARED_STEPS`); rate steps not yet (:func:`check_fixture_procedure`,
before anything moves); a flagged step is recorded flagged, not measured again. A run whose slots their bus cannot
carry at the procedure's rate is refused before anything moves (:func:`check_fixture_bus`).
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from drivers.sensors.base import SampleBlock, SensorError
from rig.config.procedure import PlannedStep, Procedure
from rig.devices.fixture import Slot
from rig.devices.rig import Rig
from rig.errors import RigInputError
from rig.execution.capture import (Capture, _join, expected_samples, loss_counters, nominal_dwell_s, poll_interval_s,
                                   sem_stop_index)
from rig.execution.checks import check_step
from rig.execution.context import EngineOptions, RunAborted, RunContext, RunError
from rig.execution.engine import Engine
from rig.execution.executors import prompt, ramp, static, temperature
from rig.execution.executors.target_policy import TargetPolicy
from rig.execution.motion import move_to, stop_motors
from rig.execution.operator import Operator
from rig.execution.settle import SettleDetector, SettleRule

#: the step executors a fixture runs (PlannedStep.executor)
FIXTURE_EXECUTORS = ("static", "targeted", "ramp", "thermal", "prompt")


#: a step check's problems that say the chip itself failed (its outputs on a rail, or frozen): a slot that shows
#: one is quarantined (FAULT) for the rest of the batch, not calibrated from its other steps
CHIP_FAILURES = ("saturated on", "stuck reading on")


def check_fixture_procedure(procedure: Procedure) -> None:
    """Refuse (RigInputError, one line) a procedure a fixture cannot run yet, before anything moves."""
    for step in procedure.expanded_steps():
        if step.executor == "prompt" and step.mount is not None and step.mount.name != "x+z+":
            raise RigInputError(procedure.path, step.source_line, "steps",
                                f"step {step.index + 1} ({step.name}) turns the sensor in its fixture (mount:): a fixture's "
                                "slots keep their mountings (a reversal runs on a one-sensor rig, docs/uncertainty.md)")
        if step.executor not in FIXTURE_EXECUTORS:
            raise RigInputError(procedure.path, step.source_line, "steps",
                                f"step {step.index + 1} ({step.name}) is {step.executor}: a fixture runs static poses "
                                "(a dwell of seconds, samples or sem_g, or an accuracy target's), temperature "
                                "set-points, ramps and prompts only (docs/fixture.md, \"A fixture run\")")


def check_fixture_bus(procedure: Procedure, fixture, slots: list[int] | None = None, *, what: str = "its {n} slots"
                      ) -> None:
    """Refuse (RigInputError, one line with the numbers, at the procedure's ``sensor.sample_rate_hz``) a run whose
    slots one bus cannot carry at the rate the procedure reads them at, before anything moves.

    The rig file's own check (:class:`rig.config.fixture.FixtureConfig`) is at its ``rate_hz``; a run reads every
    slot at the procedure's rate, which may be higher (``six_position_rapid.yaml``: 200 Hz). ``fixture``: the rig
    file's section; ``slots``: the indexes the run reads (a re-test's, a resume's; default all); ``what`` names
    them in the message (``{n}``: how many). The simulated bus has no wire time: this is what refuses there what
    the hardware could not carry.
    """
    problem = fixture.over_budget(procedure_rate_hz(procedure), slots, what)
    if problem is not None:
        raise RigInputError(procedure.path, _line_of_rate(procedure), "sensor.sample_rate_hz", problem.message)


def procedure_rate_hz(procedure: Procedure) -> float:
    """The highest output rate the procedure's steps read the sensors at, Hz: every step captures at the rate of
    its ``sensor:`` section (a step sets no rate of its own), so that rate decides."""
    return float(procedure.sensor.sample_rate_hz)


def _line_of_rate(procedure: Procedure) -> int | None:
    """The line of the procedure's ``sample_rate_hz`` (None: not given, the default)."""
    for number, line in enumerate(procedure.text.splitlines(), start=1):
        if "sample_rate_hz" in line.split("#", 1)[0]:
            return number
    return None


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

    @property
    def info(self):
        """The first live slot's session manifest: what a resume's restore reads (a ramp's last capture)."""
        return next(r.ctx.recorder.info for r in self.runs if r.live)

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
    #: a targeted dwell (sem_g or target): this slot's own rule has said stop (the pose waits for the others)
    met: bool = False
    #: a target: the slot's policy, the sample count of its next decision and of its last, and its first stop
    policy: TargetPolicy | None = None
    next_n: int = 0
    decided_n: int = 0
    first_stop: tuple[float, str] | None = None

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
                if step.kind in SHARED_STEPS:  # the chamber or the operator: one for every slot
                    SHARED_STEPS[step.kind](self, step)
                    continue
                move_to(self.ctx, step)
                due = [r for r in self.runs if r.due(step)]
                if step.executor == "targeted":
                    self._targeted(step, due)
                    continue
                if step.executor == "ramp":
                    self._ramp_pose(step, due)
                    continue
                for cap in capture_slots(self.ctx, step, due, self._fault):
                    if cap.run.live:
                        self._record(step, cap)
        except KeyboardInterrupt:
            stop_motors(self.rig, soft=True)
            raise RunAborted("interrupted by the operator") from None
        except BaseException:
            stop_motors(self.rig, soft=False)
            raise
        return self.runs

    def _thermal(self, step: PlannedStep) -> None:
        """A thermal step: a ramp's start (:meth:`_ramp_start`) or a set-point (:meth:`_temperature`)."""
        (self._ramp_start if step.ramp is not None else self._temperature)(step)

    def _ramp_start(self, step: PlannedStep) -> None:
        """A ramp's start: the chamber set ramping once (the run never waits for it); every live slot's session
        records the step with its own thermometer's reading (a slot whose thermometer fails is faulted)."""
        plan = step.ramp
        ramp.set_ramp(self.ctx, step, plan.from_c if plan.from_given else None)
        for run in (r for r in self.runs if r.due(step)):
            try:
                start_c = float(run.ctx.rig.sensor.read_temperature_c())
                run.ctx.event("ramp", step=step.index, leg=plan.leg, start_c=start_c, to_c=plan.to_c,
                              rate_c_per_min=plan.rate_c_per_min, captures=plan.captures)
                run.ctx.recorder.complete_step(step.index, {"t_end_s": run.ctx.session_time(), "temp_c": start_c,
                                                            "ramp": plan.to_manifest()})
            except SensorError as exc:
                self._fault(run, step, exc)

    def _ramp_pose(self, step: PlannedStep, due: list[SlotRun]) -> None:
        """A pose of a ramp: captured by every slot that records it while the chamber moves (the progress names
        the ramp), each slot's stats adding ``ramp`` with the rate its own thermometer saw (C/min)."""
        plan = step.ramp
        operator = self.ctx.operator
        self.ctx.operator = ramp.RampProgress(operator, plan, self.ctx.session_time, None)
        try:
            captures = capture_slots(self.ctx, step, due, self._fault)
        finally:
            self.ctx.operator = operator
        for cap in captures:
            if cap.run.live:
                samples = _join(cap.parts, cap.n_target)
                self._record(step, cap, extra={"ramp": {**plan.to_manifest(), "temp_rate_c_per_min":
                                                        ramp.slope_c_per_min(samples.t_s, samples.temp_c)}})
        if plan.capture == plan.captures:
            operator.info(f"ramp {plan.leg} ({plan.from_c:g} -> {plan.to_c:g} C at {plan.rate_c_per_min:g} C/min): "
                          f"{plan.captures} captures done")

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

    def _targeted(self, step: PlannedStep, due: list[SlotRun]) -> None:
        """A pose of a procedure with an accuracy target, for every slot that records it: each slot's own policy
        (the one-sensor :mod:`~rig.execution.executors.targeted` executor's, from its own session on a resume)
        decides its dwell, the pose lasts until every live slot's has said stop; a pose with its own dwell
        (``given``) is captured as stated and joins each slot's plan. After the last pose each slot's prediction
        is concluded (its ``target`` event, a line naming the slot)."""
        for run in due:
            if run.ctx.target is None:
                run.ctx.target = TargetPolicy.for_run(run.ctx)
        with _slot_lines(due):  # a policy's warnings name its slot
            captures = capture_slots(self.ctx, step, due, self._fault)
        for cap in captures:
            if not cap.run.live:
                continue
            policy = cap.run.ctx.target
            if step.dwell_rule == "given":
                recorded = self._record(step, cap)
            else:
                recorded = self._record(step, cap, keep_n=cap.decided_n, expected=0,
                                        extra={"target": _target_stats(cap, step)})
            if recorded is not None:
                policy.commit(step, *recorded)
        with _slot_lines(due):
            for run in due:
                if run.live and run.ctx.target.is_last(step):
                    run.ctx.target.conclude()

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

    def _record(self, step: PlannedStep, cap: _SlotCapture, *, keep_n: int | None = None, expected: int | None = None,
                extra: dict | None = None) -> tuple[SampleBlock, str] | None:
        """Check one slot's capture and record it into its session (its first ``keep_n`` samples, default the
        dwell's bound; checked against ``expected`` samples, default what the dwell asks for, 0: decided while
        capturing; ``extra`` stats); return the samples and the step's status, None when the slot was quarantined
        instead."""
        ctx = cap.run.ctx
        sensor = ctx.rig.sensor
        samples = _join(cap.parts, cap.n_target if keep_n is None else keep_n)
        n_expected = expected_samples(step, sensor.sample_rate_hz) if expected is None else expected
        overflows, dropped = (now - then for now, then in zip(loss_counters(sensor), cap.since))
        problems = list(cap.problems)
        if overflows > 0:
            problems.append(f"sensor FIFO overflowed {overflows} time(s), {dropped} samples lost: "
                            f"{ctx.rig.explain_lost_samples().reason}")
        check = check_step(samples.accel_counts, samples.temp_c, n_expected, sensor.has_temperature,
                           ctx.options.limits)
        problems += check.problems
        status = "complete" if not problems else "flagged"
        broken = [p for p in check.problems if p.startswith(CHIP_FAILURES)]
        if problems and not broken:
            ctx.warn(step, f"slot {cap.run.slot.index}: step {step.index + 1} ({step.name}) flagged and left out of "
                           "the solve: " + "; ".join(problems))
        try:
            static._record(ctx, step, Capture(samples, cap.settle_s, problems), 1, problems, status, extra)
        except SensorError as exc:  # its magnetometer did not answer
            self._fault(cap.run, step, exc)
            return None
        if broken:  # the chip's outputs are on a rail or frozen: this unit is quarantined, the motion goes on
            self._fault(cap.run, step, SensorError("; ".join(broken) + ": the sensor's outputs failed"))
            return None
        return samples, status


def capture_slots(ctx: RunContext, step: PlannedStep, runs: list[SlotRun],
                  fault: Callable[[SlotRun, PlannedStep, BaseException], None]) -> list[_SlotCapture]:
    """Start every slot's sensor, then poll them all until each has settled and captured the step's dwell.

    Each slot's settling (``step.settle``) and dwell are judged on its own samples; one poll reads every slot
    still capturing, in slot order, every ``poll_interval_s`` of the fastest-filling FIFO. A targeted dwell
    (``sem_g``, or a target's pose: its slot's ``ctx.target`` decides) ends once every live slot's own rule has
    said stop (:func:`_advance`). A slot whose sensor fails (or whose target is refused at its first look) is
    handed to ``fault`` and left out. Returns the captures of the slots still live, stopped.
    """
    s = step.settle
    rule = SettleRule(window_s=s.window_s, threshold_g=s.threshold_g, mean_tol_sigma=s.mean_tol_sigma,
                      timeout_s=s.timeout_s, min_s=s.min_s)
    t_start = ctx.rig.clock.now()
    ctx.progress(step, "settle")
    caps = _start_captures(step, runs, rule, t_start, fault)
    if not caps:
        return []
    _poll_until_done(ctx, step, caps, rule, t_start, fault)
    _stop_captures(step, caps, fault)
    return [c for c in caps if c.run.live]


def _start_captures(step: PlannedStep, runs: list[SlotRun], rule: SettleRule, t_start_s: float,
                    fault: Callable[[SlotRun, PlannedStep, BaseException], None]) -> list[_SlotCapture]:
    """Start each slot's sensor and its settle detector (from ``t_start_s``, s); a slot whose sensor does not
    start is handed to ``fault`` and left out."""
    caps: list[_SlotCapture] = []
    for run in runs:
        sensor = run.ctx.rig.sensor
        try:
            since = loss_counters(sensor)
            sensor.start()
        except SensorError as exc:
            fault(run, step, exc)
            continue
        detector = SettleDetector(rule, sensor.sample_rate_hz, sensor.accel_lsb_per_g)
        detector.start(t_start_s)
        policy = run.ctx.target if step.dwell_rule == "target" else None
        caps.append(_SlotCapture(run, detector, since, 0 if policy is not None else
                                 expected_samples(step, sensor.sample_rate_hz), policy=policy,
                                 next_n=policy.min_n if policy is not None else 0))
    return caps


def _poll_until_done(ctx: RunContext, step: PlannedStep, caps: list[_SlotCapture], rule: SettleRule,
                     t_start_s: float, fault: Callable[[SlotRun, PlannedStep, BaseException], None]) -> None:
    """Read every live slot still capturing, one poll at a time (the fastest-filling FIFO's interval), until each
    has its dwell, or every live slot's targeted rule has said stop."""
    clock = ctx.rig.clock
    poll = min(poll_interval_s(c.run.ctx.rig.sensor) for c in caps)
    dwell_timeout_s = 2.0 * max(nominal_dwell_s(step, c.run.ctx.rig.sensor.sample_rate_hz) for c in caps) + 5.0
    targeted = step.dwell_rule == "target" or step.dwell.sem_g is not None
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
            try:
                _advance(cap, step, block, clock.now(), t_start_s, rule.timeout_s, dwell_timeout_s)
            except RunError as exc:  # its target refused at the first look: this unit, not the batch
                fault(cap.run, step, exc)
        if targeted and all(c.met for c in caps if c.run.live):  # the slowest unit has decided: the pose ends
            for cap in caps:
                cap.phase = "done"
        ctx.progress(step, "capture")


def _stop_captures(step: PlannedStep, caps: list[_SlotCapture],
                   fault: Callable[[SlotRun, PlannedStep, BaseException], None]) -> None:
    """Stop each live slot's sensor; one that fails to stop is handed to ``fault``."""
    for cap in caps:
        if cap.run.live:
            try:
                cap.run.ctx.rig.sensor.stop()
            except SensorError as exc:
                fault(cap.run, step, exc)


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
    if cap.policy is not None:
        _decide(cap, step)
    elif step.dwell.sem_g is not None:
        _sem_met(cap, step)
    if (cap.n_target and cap.n >= cap.n_target) or now_s - cap.t_capture_s > dwell_timeout_s:
        cap.phase, cap.met = "done", True


def _sem_met(cap: _SlotCapture, step: PlannedStep) -> None:
    """A ``sem_g`` dwell: the slot has met its rule once the standard error of its mean is within ``sem_g`` on
    every axis (``sem_stop_index``, the one-sensor capture's), or its dwell reached ``max_seconds``: then it
    stops capturing (``n_target``, the dwell's bound; a slot short of ``sem_g`` by then is recorded as a
    one-sensor run records it)."""
    sensor = cap.run.ctx.rig.sensor
    limit_n = int(round(step.dwell.max_seconds * sensor.sample_rate_hz))
    if cap.n >= limit_n:
        cap.n_target, cap.met = limit_n, True
    elif not cap.met and sem_stop_index(np.concatenate([p.accel_counts for p in cap.parts]), sensor.accel_lsb_per_g,
                                        step.dwell.sem_g) is not None:
        cap.met = True
        cap.n_target = limit_n  # it goes on capturing while the others finish, never beyond the dwell's bound


def _decide(cap: _SlotCapture, step: PlannedStep) -> None:
    """A target's pose: the slot's policy decides at every ``block_n`` of its samples (from ``min_n`` on), on
    exactly the first n samples and their session times (as the one-sensor capture); the first stop makes the
    slot met (it goes on being decided while the pose lasts)."""
    policy, ctx = cap.policy, cap.run.ctx
    if cap.n < cap.next_n:
        return
    joined = _join(cap.parts, 0)
    while cap.n >= cap.next_n:
        n = cap.next_n
        decision = policy.decide(step, joined.accel_counts[:n], joined.t_s[:n] - ctx.t0_s)
        cap.decided_n = n
        if decision.stop and cap.first_stop is None:
            cap.first_stop = (n / policy.rate, decision.reason)
            cap.met = True
        cap.next_n += policy.block_n


def _target_stats(cap: _SlotCapture, step: PlannedStep) -> dict:
    """The slot's target stats as the one-sensor run records them (its last decision: the recorded dwell, the
    prediction with every sample recorded), with when its own rule first said stop (``own_stop_s``, s of dwell;
    ``stop`` its reason when its last decision would have gone on) and how long the pose was held after that for
    the slots still going (``held_s``); a slot stopped by the time-out only has neither."""
    stats = cap.policy.step_stats(step)
    if cap.first_stop is not None:
        own_s, reason = cap.first_stop
        stats["stop"] = stats.get("stop") or reason
        stats["own_stop_s"] = own_s
        stats["held_s"] = max(float(stats.get("dwell_s", own_s)) - own_s, 0.0)
    return stats


@contextmanager
def _slot_lines(runs: list[SlotRun]):
    """While inside: each run's operator prefixes its lines with the slot (:class:`_SlotOperator`)."""
    kept = [run.ctx.operator for run in runs]
    for run in runs:
        run.ctx.operator = _SlotOperator(run.ctx.operator, f"slot {run.slot.index} ({run.slot.serial}): ")
    try:
        yield
    finally:
        for run, operator in zip(runs, kept):
            run.ctx.operator = operator


class _SlotOperator:
    """The operator, with one slot's lines prefixed (``slot 3 (SIM-3): ``): a slot's policy says what it concludes."""

    def __init__(self, operator: Operator, prefix: str) -> None:
        self._operator, self._prefix = operator, prefix

    def info(self, message: str) -> None:
        self._operator.info(self._prefix + message)

    def warn(self, message: str) -> None:
        self._operator.warn(self._prefix + message)

    def __getattr__(self, name):
        return getattr(self._operator, name)


__all__ = ["FixtureEngine", "SlotRun", "capture_slots", "check_fixture_bus", "check_fixture_procedure",
           "procedure_rate_hz"]


#: the steps a fixture runs once for every slot (the shared chamber, the one operator), by kind
SHARED_STEPS = {"thermal": FixtureEngine._thermal, "prompt": FixtureEngine._prompt}

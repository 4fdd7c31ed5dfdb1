"""``rig run``: open the rig, create or resume a session, run the procedure, solve."""

from __future__ import annotations

import secrets
from datetime import datetime, timezone
from pathlib import Path

from rig.config.procedure import load_procedure, load_procedure_text
from rig.config.rigfile import load_rig_file
from drivers.sensors.base import SensorError
from rig.devices import open_rig_file
from rig.devices.rig import describe_sensor
from rig.execution.context import EngineOptions, RunAborted, wall_per_rig_s
from rig.execution.estimate import step_durations_s
from rig.execution.engine import check_before_recording
from rig.execution.fixture import check_fixture_bus, check_fixture_procedure
from rig.execution.operator import Operator, SilentOperator
from rig.planning.kinematics import STAGE_AXES
from rig.lab.batch_record import BATCH_FILE, is_batch, read_batch
from rig.lab.noise_profiles import unit_accel_stability
from rig.session.lock import SessionLock
from rig.errors import RigInputError
from rig.session import SessionManifest, SessionWriter
from rig.session.recovery import check_resumable
from rig.workflow import identity
from rig.workflow.batch import BatchResult, plan_resume, refuse_finished, resume_batch, run_batch
from rig.workflow import kinds  # noqa: F401 - registers the "sim" rig kind (the simulator loads when it opens)
from rig.workflow.lifecycle import (NewSession, RunResult, abort_session, configure_devices, execute, file_sha256,
                                    finish, interrupted, start_session)

DEFAULT_RIG = Path(__file__).resolve().parents[2] / "rigs" / "sim.yaml"


def resolve_rig(spec: str | None) -> Path:
    """``sim`` (or nothing) means the embedded simulated rig; otherwise a rig-file path."""
    return DEFAULT_RIG if spec in (None, "sim") else Path(spec)


def new_session_id(procedure_name: str, seed: int | None) -> str:
    """``<procedure>-<UTC stamp>-s<seed>-<4 hex>``: unique even for runs started in the same second."""
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    tail = f"s{seed}-{secrets.token_hex(2)}" if seed is not None else secrets.token_hex(3)
    return f"{procedure_name}-{stamp}-{tail}"


def run_procedure(procedure_path: str | None, *, rig_spec: str | None = None, out_dir="sessions",
                  seed: int | None = None, resume_dir=None, ui: Operator | None = None,
                  time_scale: float | None = None, clock: str | None = None, solve: bool = True,
                  options: EngineOptions = EngineOptions(), history=None, slots: list[int] | None = None) -> RunResult:
    """Run (or resume) a procedure; return where the session is and how it ended.

    With ``solve`` (and a ``solve:`` section in the procedure) the session goes through the pipeline
    tail (:func:`rig.workflow.conclude.conclude`): the calibration file, the acceptance verdict, the
    history record (``history``: the database; default ``$RIG_HISTORY``, else the user's) and the
    report when the procedure asks: exactly what ``rig run`` prints (``RunResult.conclusion``).

    A rig file with a ``fixture:`` runs every slot in one motion (:func:`rig.workflow.batch.run_batch`, docs/fixture.md)
    and returns a :class:`~rig.workflow.batch.BatchResult` (each slot's outcome and session, the batch record).

    Raises the drivers' errors (TurntableError, SensorError), RigInputError, RunError and
    RunAborted; motors are stopped and the session marked aborted before any of them leaves.
    """
    operator = ui or SilentOperator()
    if resume_dir is not None and slots is not None:
        raise RigInputError(None, None, "--slots", "a re-test runs a new batch of some slots: give the procedure and "
                            "the fixture's rig file, not --resume")
    if resume_dir is not None and is_batch(resume_dir):  # an interrupted fixture batch: docs/fixture.md
        return _resume_batch(resume_dir, rig_spec=rig_spec, seed=seed, operator=operator, time_scale=time_scale,
                             clock=clock, solve=solve, options=options, history=history)
    if resume_dir is not None:
        return _resume(resume_dir, rig_spec=rig_spec, seed=seed, operator=operator, time_scale=time_scale,
                       clock=clock, solve=solve, options=options, history=history)
    procedure = load_procedure(procedure_path)
    rig_file = load_rig_file(resolve_rig(rig_spec))
    seed = 0 if seed is None else seed
    rig = open_rig_file(rig_file, seed=seed, time_scale=time_scale, clock=clock)
    if rig.fixture is not None:  # many units in one run: docs/fixture.md
        return _run_fixture(procedure, procedure_path, rig, out_dir=out_dir, seed=seed, operator=operator,
                            solve=solve, options=options, history=history, slots=slots)
    if slots is not None:
        rig.close()
        raise RigInputError(None, None, "--slots", "a re-test of some slots needs a rig file with a fixture: section "
                            "(docs/fixture.md); this rig has one sensor")
    return _run_one_sensor(procedure, procedure_path, rig, out_dir=out_dir, seed=seed, operator=operator,
                           solve=solve, options=options, history=history)


def _run_one_sensor(procedure, procedure_path, rig, *, out_dir, seed: int, operator: Operator, solve: bool,
                    options: EngineOptions, history) -> RunResult:
    """A one-sensor rig file: the checks before anything moves, a new session (locked), the engine, the pipeline
    tail; the rig is closed and the lock released on every way out."""
    lock = SessionLock(None)
    try:
        new = NewSession(Path(out_dir), new_session_id(procedure.name, seed), Path(procedure_path).read_text(),
                         str(procedure_path), extra={"seed": rig.seed})
        use_unit_noise(procedure, rig, None, operator, history)  # before the preflight: it judges the target too
        check_before_recording(procedure, rig, operator)
        announce_duration(procedure, rig, operator)
        writer = start_session(procedure, rig, new)
        try:
            lock = SessionLock(writer.session_dir).acquire()
            operator.info(f"session {writer.session_dir}")
        except BaseException as exc:  # between the session's creation and the engine: still resumable
            abort_session(writer, exc)
            if isinstance(exc, KeyboardInterrupt):
                raise interrupted(writer) from None
            raise
        try:
            outcomes = execute(procedure, rig, writer, operator, checked=True, options=options)
        finally:
            rig.close()
        return finish(procedure, writer, outcomes, solve=solve, history=history)
    finally:
        rig.close()
        lock.release()


def use_unit_noise(procedure, rig, manifest: dict | None, operator: Operator, history) -> None:
    """A run with an accuracy target predicts with the unit's own noise figures when the history holds its noise
    profile (``rig.unit_accel_stability``; docs/noise.md), and says so; the family's otherwise. ``manifest``: the
    session's (its plain mapping); None before the session starts: what identifies the unit is read from the rig
    (its sensor's identity, the seed)."""
    if procedure.target is None:
        return
    try:
        if manifest is None:
            manifest = {"rig": {"sensor": describe_sensor(rig.sensor)}, "seed": rig.seed}
        found = unit_accel_stability(manifest, history)
    except (SensorError, OSError):  # the chip did not answer its identity: the run's start says so, in its words
        return
    if found is not None:
        rig.unit_accel_stability, profile = found
        operator.info(f"accuracy target: predicted with the unit's own noise figures (its profile of "
                      f"{profile.measured_at[:10]}, session {profile.session}), not the {profile.sensor.model or 'chip'} "
                      "family's")


def _run_fixture(procedure, procedure_path, rig, *, out_dir, seed: int, operator: Operator, solve: bool,
                 options: EngineOptions, history, slots: list[int] | None = None) -> BatchResult:
    """A fixture rig file: every slot in one motion (:func:`rig.workflow.batch.run_batch`), or the ``slots`` of a
    re-test; the checks before anything moves are the one-sensor run's, and the fixture's own."""
    try:
        if slots is not None:
            known = [s.index for s in rig.fixture.slots]
            unknown = [n for n in slots if n not in known]
            if unknown or not slots:
                raise RigInputError(None, None, "--slots", f"slot {unknown[0] if unknown else '(none)'} is not in the "
                                    f"fixture (its slots: {', '.join(map(str, known))})")
        new = NewSession(Path(out_dir), new_session_id(procedure.name, seed), Path(procedure_path).read_text(),
                         str(procedure_path), extra={"seed": rig.seed})
        check_fixture_procedure(procedure)
        check_fixture_bus(procedure, rig.fixture.config, slots,
                          what="its {n} slots" if slots is None else "the {n} slots of this re-test")
        check_before_recording(procedure, rig, operator)
        announce_duration(procedure, rig, operator)
        return run_batch(procedure, rig, new, operator, options=options, solve=solve, history=history,
                         only_slots=slots)
    finally:
        rig.close()


#: runs planned longer than this (rig time, s) ask an interactive operator to confirm before moving
CONFIRM_ABOVE_S = 2 * 3600.0


def announce_duration(procedure, rig, operator: Operator) -> None:
    """Say how long the run will take before anything moves; ask first when that is long."""
    planned_s = sum(step_durations_s(procedure.expanded_steps(), rig))
    line = f"planned: {len(procedure.expanded_steps())} steps, about {format_duration(planned_s)} of rig time"
    operator.info(line + wall_clock_words(planned_s, rig.clock))
    if planned_s > CONFIRM_ABOVE_S and getattr(operator, "interactive", False) and not getattr(
            operator, "assume_yes", False):
        if not operator.confirm(f"{line}. Start?"):
            raise RunAborted("the operator did not start the run")


def wall_clock_words(planned_s: float, clock) -> str:
    """What the rig time is on the wall: nothing on hardware (the same), ``(about 12 s at time scale 10)`` for a
    time-scaled simulated rig, ``(virtual time: as fast as this machine runs it)`` for virtual time."""
    wall = wall_per_rig_s(clock)
    if wall is None:
        return " (virtual time: as fast as this machine runs it)"
    if abs(wall - 1.0) < 1e-9:
        return ""
    return f" (about {format_duration(planned_s * wall)} at time scale {1.0 / wall:g})"


def format_duration(seconds: float) -> str:
    """``45 s``, ``12 min``, ``3 h 05 min``."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 3600:
        return f"{seconds / 60:.0f} min"
    return f"{int(seconds // 3600)} h {int(seconds % 3600 // 60):02d} min"


def _resume_batch(batch_dir, *, rig_spec, seed, operator: Operator, time_scale, clock, solve: bool,
                  options: EngineOptions, history=None) -> BatchResult:
    """Continue an interrupted fixture batch (:func:`rig.workflow.batch.resume_batch`): lock it, open the rig file
    it recorded (or ``rig_spec``), check the rig, its fixture's slots and every slot's session before anything is
    touched (:func:`rig.workflow.batch.plan_resume`), then the checks before anything moves, then go on."""
    record = read_batch(batch_dir, finished=False)
    refuse_finished(batch_dir, record)  # before the lock and the rig: nothing to do
    with SessionLock(batch_dir) as lock:
        if lock.stale:
            operator.warn(f"took over the lock of pid {lock.stale.get('pid', '?')} on {lock.stale.get('host', '?')}, "
                          "which is no longer running")
        rig_path = resolve_rig(record.get("rig_file") if rig_spec is None else rig_spec)
        rig = open_rig_file(load_rig_file(rig_path), seed=record.get("seed") if seed is None else seed,
                            time_scale=time_scale, clock=clock)
        try:
            plan = plan_resume(batch_dir, record, rig, rig_path)
            procedure = None
            if plan.resumed:  # the procedure the slots recorded (every slot's session holds its text)
                info = plan.resumed[0][2]
                procedure = load_procedure_text(info.procedure.text or "", info.procedure.file or "<session>")
                first = min(_first_unfinished(m) for _, _, m in plan.resumed)
                check_fixture_procedure(procedure)
                check_fixture_bus(procedure, rig.fixture.config, [slot.index for slot, _, _ in plan.resumed],
                                  what="the {n} slots this resume reads")
                check_before_recording(procedure, rig, operator, first_step=first, start_deg={
                    name: rig.axes[name].stage.get_position_deg() for name in STAGE_AXES})
            operator.info(f"resuming batch {batch_dir}: " + (", ".join(
                f"slot {slot.index} at step {_first_unfinished(m) + 1}" for slot, _, m in plan.resumed) or
                "no slot to record, only the end of the batch"))
            return resume_batch(procedure, rig, plan, operator, options=options, solve=solve, history=history)
        finally:
            rig.close()


def _first_unfinished(info: SessionManifest) -> int:
    """The index of a session's first step not finished (complete or flagged); the step count when none."""
    return next((s.index for s in info.steps if s.status not in ("complete", "flagged")), len(info.steps))


def _resume(resume_dir, *, rig_spec, seed, operator: Operator, time_scale, clock, solve: bool,
            options: EngineOptions, history=None) -> RunResult:
    """Continue an interrupted session: lock it first (a second resume touches nothing)."""
    d = Path(resume_dir)
    if not (d / "session.yaml").exists() and any(d.glob("*-slot*/session.yaml")):  # a batch without its record
        raise RigInputError(str(d / BATCH_FILE), None, None, "missing: a fixture batch without its batch record "
                            "cannot be resumed (it stopped before every slot's session had started, or was recorded "
                            "before batches resumed); run the batch again, or solve a slot's session: rig solve SESSION")
    recorded, _ = SessionManifest.load(resume_dir)  # a directory that is not a session is refused before it is locked
    fixture = recorded.to_dict()["rig"]["sensor"].get("fixture")
    if fixture is not None:  # one slot of a batch: its sessions share one motion
        batch = Path(resume_dir).resolve().parent
        raise RigInputError(str(Path(resume_dir) / "session.yaml"), None, "rig.sensor.fixture",
                            f"this session is slot {fixture.get('slot')} of a fixture batch: resume the batch, "
                            f"rig run --resume {batch}" + ("" if (batch / BATCH_FILE).is_file() else
                                                          f" (it has no {BATCH_FILE}: it stopped before its slots' "
                                                          "sessions had all started; run the batch again)"))
    with SessionLock(resume_dir) as lock:
        if lock.stale:
            operator.warn(f"took over the lock of pid {lock.stale.get('pid', '?')} on {lock.stale.get('host', '?')}, "
                          "which is no longer running")
        return _resume_locked(resume_dir, rig_spec=rig_spec, seed=seed, operator=operator, time_scale=time_scale,
                              clock=clock, solve=solve, options=options, history=history)


def _resume_locked(resume_dir, *, rig_spec, seed, operator: Operator, time_scale, clock, solve: bool,
                   options: EngineOptions, history=None) -> RunResult:
    """Check the session's files against its manifest, open the rig, refuse it if it is not the one recorded,
    then reopen the session and go on. Nothing is touched before every check has passed."""
    recorded, _ = SessionManifest.load(resume_dir)  # read only: nothing is touched before the checks
    check_resumable(resume_dir, recorded)  # samples.csv agrees with the finished steps, before the rig moves
    procedure = load_procedure_text(recorded.procedure.text or "", recorded.procedure.file or "<session>")
    rig_path = resolve_rig(recorded.rig.rig_file if rig_spec is None else rig_spec)
    rig_file = load_rig_file(rig_path)
    rig = open_rig_file(rig_file, seed=recorded.seed if seed is None else seed, time_scale=time_scale, clock=clock)
    try:
        configure_devices(procedure, rig)
        differ = identity.differences(recorded, rig, file_sha256(rig_path))
        if differ:
            raise RigInputError(str(resume_dir), None, "rig", "cannot resume on another rig or sensor: "
                                + "; ".join(differ) + " (resume with the rig, rig file and --seed it was recorded with)")
        writer, first_step = SessionWriter.resume(resume_dir)
        time_offset = _resume_time_offset(writer.info)
        writer.event("resume", t_s=time_offset, first_step=first_step)
        operator.info(f"resuming {writer.session_dir} at step {first_step + 1}")
        use_unit_noise(procedure, rig, writer.info.to_dict(), operator, history)
        outcomes = execute(procedure, rig, writer, operator, first_step=first_step, resuming=True,
                           time_offset_s=time_offset, options=options)
    finally:
        rig.close()
    return finish(procedure, writer, outcomes, solve=solve, history=history)


def _resume_time_offset(info: SessionManifest) -> float:
    """Session time to continue from: 1 s after the last recorded step ended."""
    ends = [s.stats.t_end_s for s in info.steps
            if s.status in ("complete", "flagged") and s.stats is not None and s.stats.t_end_s is not None]
    return (max(ends) + 1.0) if ends else 0.0

"""``rig run`` on a fixture: one run, N units, each slot its own session, a batch table and a batch record.

    open the rig (its fixture's slots) -> a session per slot (its identity, its design through its mounting)
    -> the fixture engine: one motion per pose, every live slot captured -> each live slot's pipeline tail
    (the one-sensor run's :func:`rig.workflow.lifecycle.finish`) -> the batch table and ``batch.json``

A slot whose sensor fails its self-test or stops answering is FAULT (its session marked aborted, with the
reason) and the others go on; a turntable fault or an interrupt aborts every slot's session and leaves.
Where it all goes: ``OUT/<batch id>/`` holds ``batch.json`` and one session directory per slot,
``<batch id>-slotN``, and the batch's HTML report, ``batch-report.html`` (docs/fixture.md, "A fixture run").
Each slot's outcome also sorts its unit into a failure bin (:mod:`rig.lab.bins`).

``batch.json`` is written as soon as every slot's session has started (``status: running``, the slots still
recording without an outcome), rewritten atomically as a slot is quarantined or concluded, marked ``aborted`` when
the batch stops, and ``complete`` at its end (:class:`BatchRecord`). An interrupted batch resumes from it
(:func:`plan_resume`, :func:`resume_batch`; ``rig run --resume BATCH_DIR``): each recording slot's session
continues from its last finished step by the one-sensor resume's rules, the others keep what they have.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from calib.errors import CalibError
from calib.file.calibration import atomic_write_text
from calib.file import calibration as calfile
from drivers.sensors.base import SensorAbsent, SensorError
from rig.devices.fixture import Slot
from rig.devices.rig import Rig
from rig.errors import RigInputError
from rig.execution.context import EngineOptions, RunAborted, RunContext, RunError
from rig.execution.estimate import step_durations_s
from rig.execution.fixture import FixtureEngine, SlotRun
from rig.execution.operator import Operator
from rig.lab.batch_record import BATCH_FILE, BATCH_FORMAT
from rig.lab.bins import BINS, bin_counts, failure_bin
from rig.session import SessionManifest, SessionWriter, StepRecord
from rig.session.lock import SessionLock
from rig.session.recovery import check_resumable
from rig.workflow import identity
from rig.workflow.lifecycle import NewSession, RunResult, abort_session, configure_devices, file_sha256, finish, start_session

#: without acceptance limits a slot is NO LIMITS (not FAIL) when its fit's residual is at most this, g rms, and no
#: step was flagged
FIT_RESIDUAL_LIMIT_G = 1e-3
#: a slot's outcome, in the one-unit run's and the report's verdict words: PASS and FAIL against the procedure's
#: ``accept:`` limits, NO LIMITS (a good fit, no limits to judge it by), FAULT (its sensor failed), ABSENT (no chip
#: answered at the slot's address when the batch started: an empty slot, or one not wired)
OUTCOMES = ("PASS", "FAIL", "NO LIMITS", "FAULT", "ABSENT")
#: the outcomes that leave the run's exit code 0 (as the one-unit run without limits exits 0)
GOOD_OUTCOMES = ("PASS", "NO LIMITS")
#: the batch table's bin column, characters (the longest bin's name)
BIN_WIDTH = max(len(b) for b in BINS)


@dataclass
class SlotOutcome:
    """How one slot of a batch ended.

    Attributes
    ----------
    slot, serial : the slot's number and its unit's serial
    rotation : the mounting rotation's name (or its matrix, rows)
    outcome : one of :data:`OUTCOMES`
    reason : why FAIL or FAULT (one line), else None
    session_dir : the slot's session (None when its sensor failed before one was written)
    result : the slot's :class:`RunResult` (its calibration) when it was solved
    failed_limits : the names of the acceptance limits it failed (``range accel.bias_y``, ...)
    recorded : the slot's entry in ``batch.json`` when it ended before a resume (its bin, calibration and
        parameters as recorded then; the resume leaves the slot untouched)
    """

    slot: int
    serial: str
    rotation: object
    outcome: str
    reason: str | None = None
    session_dir: Path | None = None
    result: RunResult | None = None
    failed_limits: tuple[str, ...] = ()
    recorded: dict | None = None

    @property
    def bin(self) -> str:
        """The unit's failure bin (:func:`rig.lab.bins.failure_bin`): ``good``, the failed limit's family, ..."""
        if self.recorded is not None and self.recorded.get("bin"):
            return self.recorded["bin"]
        return failure_bin(self.outcome, self.reason, self.failed_limits)

    def parameters(self) -> dict | None:
        """The main calibrated parameters per sensor axis (its own frame): bias in counts (as every other view
        prints it) and in mg (``bias_mg``, the record's first key), scale factor in counts/g, residual in ug rms."""
        if self.result is None and self.recorded is not None:
            return self.recorded.get("parameters")
        return _parameters_of(None if self.result is None else self.result.calibration)

    def to_record(self, root: Path) -> dict:
        """The slot's entry in ``batch.json`` (paths relative to the batch directory)."""
        rel = (lambda p: None if p is None else str(Path(p).relative_to(root)) if Path(p).is_relative_to(root)
               else str(p))
        calibration = (self.result.calibration_path if self.result is not None else None if self.recorded is None
                       else self.recorded.get("calibration") and root / self.recorded["calibration"])
        return {"slot": self.slot, "serial": self.serial, "rotation": self.rotation, "outcome": self.outcome,
                "bin": self.bin, "reason": self.reason, "session": rel(self.session_dir),
                "calibration": rel(calibration), "parameters": self.parameters()}


@dataclass
class BatchResult(RunResult):
    """A fixture run: ``RunResult`` of the first slot with a session (what a one-sensor caller reads), plus the
    batch's directory, its record, its HTML report (None, with ``report_warning``, when it could not be written)
    and every slot's outcome."""

    batch_dir: Path | None = None
    record_path: Path | None = None
    report_path: Path | None = None
    report_warning: str | None = None
    slots: list[SlotOutcome] = field(default_factory=list)


def _parameters_of(cal) -> dict | None:
    """A calibration's main parameters per sensor axis (:meth:`SlotOutcome.parameters`); None without one."""
    if cal is None or cal.accelerometer is None:
        return None
    a = cal.accelerometer
    scale = np.asarray(a.scale_counts_per_g, float)
    return {"bias_mg": [round(float(b / k * 1e3), 4) for b, k in zip(a.bias_counts, scale)],
            "bias_counts": [round(float(b), 2) for b in a.bias_counts],
            "scale_counts_per_g": [round(float(k), 3) for k in scale],
            "residual_ug": round(float(a.fit.residual_rms_g) * 1e6, 2)}


def slot_rig(rig: Rig, slot: Slot) -> Rig:
    """The rig as one slot's session sees it: the shared turntable, clock and chamber, the slot's sensor and
    attachments (nothing to close of its own)."""
    return dataclasses.replace(rig, sensor=slot.sensor, magnetometer=slot.magnetometer,
                               attachments=dict(slot.attachments), closers=[], fixture=None, closed=False)


def slot_steps(procedure, slot: Slot) -> list[StepRecord]:
    """The procedure's planned steps for the slot's session: each pose's nominal specific force (g) and body
    rate (deg/s) taken from the turntable frame to the slot's frame through its mounting rotation (``R^T v``)."""
    return steps_in_frame(procedure, slot.rotation)


def steps_in_frame(procedure, rotation) -> list[StepRecord]:
    """The procedure's planned steps seen by a sensor mounted by ``rotation`` (3x3, its frame -> the turntable's):
    each pose's nominal specific force (g) and body rate (deg/s) as ``R^T v`` (a fixture slot's session, and the
    replay of one)."""
    r = np.asarray(rotation, float)
    out = []
    for step in procedure.expanded_steps():
        d = step.to_manifest()
        for key in ("f_nominal", "rate_nominal_dps"):
            if d.get(key) is not None:
                d[key] = [round(float(x), 12) + 0.0 for x in r.T @ np.asarray(d[key], float)]
        out.append(StepRecord.model_validate(d))
    return out


def start_slot_session(procedure, rig: Rig, slot: Slot, new: NewSession) -> SessionWriter:
    """Configure and self-test the slot's sensor, then write its session's manifest (its identity: slot, serial,
    mounting; its design through its mounting) and attachments (its ``sim_truth.yaml``).

    Raises the sensor's errors and RunError (a failed self-test): the slot is then FAULT without a session.
    """
    return start_session(procedure, rig, new, steps=slot_steps(procedure, slot),
                         sensor_info={"serial": slot.serial, "fixture": slot.describe()})


def run_batch(procedure, rig: Rig, new: NewSession, operator: Operator, *, options: EngineOptions = EngineOptions(),
              solve: bool = True, history=None, only_slots: list[int] | None = None) -> BatchResult:
    """Run ``procedure`` on every slot of ``rig.fixture`` in one motion; return every slot's outcome.

    ``new`` names the batch: its directory is ``new.sessions_root / new.session_id``, slot N's session
    ``<id>-slotN`` in it. The caller has checked the procedure against the rig (before anything moves) and
    closes the rig. Raises what the turntable raises (every live slot's session marked aborted first, the batch
    record ``aborted``; a RunAborted names the batch directory, what ``rig run --resume`` takes).
    """
    batch_dir = Path(new.sessions_root) / new.session_id
    batch_dir.mkdir(parents=True, exist_ok=False)
    with SessionLock(batch_dir):  # one run or resume of a batch at a time (its slots' sessions are written together)
        record = BatchRecord.start(batch_dir, new, procedure, rig, only_slots)
        runs: list[SlotRun] = []
        estimates = step_durations_s(procedure.expanded_steps(), rig)
        for slot in (s for s in rig.fixture.slots if only_slots is None or s.index in only_slots):  # a re-test: some
            view = slot_rig(rig, slot)
            rotation = slot.describe()["rotation"]
            try:
                writer = start_slot_session(procedure, view, slot, dataclasses.replace(
                    new, sessions_root=batch_dir, session_id=f"{new.session_id}-slot{slot.index}"))
            except (SensorError, RunError) as exc:  # its chip failed (no answer, its self-test): this slot only
                outcome = "ABSENT" if isinstance(exc, SensorAbsent) else "FAULT"
                record.put(SlotOutcome(slot.index, slot.serial, rotation, outcome, _one_line(exc)))
                operator.warn(f"slot {slot.index} ({slot.serial}): {outcome} before recording: {_one_line(exc)}; "
                              "the others go on")
                continue
            runs.append(SlotRun(slot, _slot_context(procedure, view, slot, writer, operator, options, estimates)))
            record.recording(slot, rotation, writer.session_dir)
            operator.info(f"slot {slot.index} ({slot.serial}): session {writer.session_dir}")
        record.write()  # from here on the batch can be resumed (rig run --resume BATCH_DIR)
        return _run_and_conclude(procedure, rig, runs, record, operator, options=options, solve=solve,
                                 history=history)


def _slot_context(procedure, view: Rig, slot: Slot, writer: SessionWriter, operator: Operator,
                  options: EngineOptions, estimates: list[float]) -> RunContext:
    """The run context of one slot's session (its rig view, its writer; the session clock is the motion's)."""
    return RunContext(procedure=procedure, rig=view, recorder=writer, operator=operator, options=options,
                      t0_s=view.clock.now(), total_steps=len(estimates), estimates_s=estimates,
                      magnetometer_samples=procedure.sensor.mag_samples if procedure.sensor.magnetometer else 0,
                      io_retries_seen=slot.sensor.stats.io_retries)


def _run_and_conclude(procedure, rig: Rig, runs: list[SlotRun], record: "BatchRecord", operator: Operator, *,
                      options: EngineOptions, solve: bool, history, resuming: bool = False,
                      time_offset_s: float = 0.0) -> BatchResult:
    """The motion (from each run's ``first_step``), then each run's pipeline tail, the record and the report.
    Anything that leaves on the way marks the record ``aborted`` (every live slot's session too, during the
    motion); a RunAborted then names the batch directory."""
    batch_dir = record.batch_dir

    def on_fault(run: SlotRun, exc: BaseException) -> None:
        abort_session(run.ctx.recorder, exc, t_s=run.ctx.session_time())
        record.put(_conclude_slot(procedure, run, solve=False, history=None))  # FAULT, quarantined
        record.write()

    try:
        n_steps = len(procedure.expanded_steps()) if runs else 0
        if any(r.live and r.first_step < n_steps for r in runs):
            engine = FixtureEngine(procedure, rig, runs, operator, options=options, on_fault=on_fault,
                                   where=batch_dir, time_offset_s=time_offset_s)
            try:
                engine.prepare(resuming=resuming)
                engine.run()
            except BaseException as exc:
                for run in runs:
                    if run.live:
                        abort_session(run.ctx.recorder, exc, t_s=run.ctx.session_time())
                raise
        for run in runs:
            record.put(_conclude_slot(procedure, run, solve=solve, history=history))
            record.write()
    except BaseException as exc:
        record.stop()
        if isinstance(exc, RunAborted):
            exc.session_dir = batch_dir  # what to resume: the batch, not its last slot's session
        raise
    path = record.finish()
    report, warning = write_report_of(batch_dir)
    ordered = record.outcomes()
    first = next((o for o in ordered if o.session_dir is not None), None)
    return BatchResult(session_dir=first.session_dir if first is not None else batch_dir,
                       status="complete", outcomes=[], conclusion=None, batch_dir=batch_dir, record_path=path,
                       report_path=report, report_warning=warning, slots=ordered)


def write_report_of(batch_dir: Path) -> tuple[Path | None, str | None]:
    """The batch's HTML report (``batch-report.html``), written last: (its path, None), or (None, why not) when it
    cannot be written (a full disk, ...): the sessions and the record written before it stand."""
    from rig.lab.report.batch import write_batch_report  # deferred: the page and its figure, at a batch's end only

    try:
        return write_batch_report(batch_dir), None
    except Exception as exc:  # noqa: BLE001 -- the report is the last thing made: its failure leaves the rest standing
        return None, (f"batch report not written ({type(exc).__name__}: {_one_line(exc)}); the batch stands: "
                      f"write it with rig report {batch_dir}")


def _conclude_slot(procedure, run: SlotRun, *, solve: bool, history) -> SlotOutcome:
    """The slot's pipeline tail (a FAULT slot has none: its session stays aborted), then its outcome."""
    slot, writer = run.slot, run.ctx.recorder
    rotation = slot.describe()["rotation"]
    if not run.live:
        return SlotOutcome(slot.index, slot.serial, rotation, "FAULT", run.fault, writer.session_dir)
    try:
        result = finish(procedure, writer, run.ctx.outcomes, solve=solve, history=history)
    except (CalibError, RunError) as exc:
        return SlotOutcome(slot.index, slot.serial, rotation, "FAIL", f"cannot solve: {_one_line(exc)}",
                           writer.session_dir)
    outcome, reason = _judge(run, result)
    acceptance = None if result.conclusion is None else result.conclusion.acceptance
    failed = tuple(c.name for c in acceptance.failed()) if acceptance is not None else ()
    return SlotOutcome(slot.index, slot.serial, rotation, outcome, reason, writer.session_dir, result, failed)


def _judge(run: SlotRun, result: RunResult) -> tuple[str, str | None]:
    """PASS/FAIL: the acceptance verdict when the procedure has limits; else NO LIMITS when the fit is good (no
    flagged step in the session, resumes included; residual within :data:`FIT_RESIDUAL_LIMIT_G`), FAIL when it is
    not."""
    flagged = [s.index + 1 for s in run.ctx.recorder.info.steps if s.status == "flagged"]
    c = result.conclusion
    if c is None:
        return _verdict(flagged, None, None)
    if c.acceptance is not None:
        return _verdict(flagged, (c.passed, [chk.line for chk in c.acceptance.failed()]), None)
    return _verdict(flagged, None, float(c.calibration.accelerometer.fit.residual_rms_g))


def _verdict(flagged: list[int], acceptance: tuple[bool, list[str]] | None,
             residual_g: float | None) -> tuple[str, str | None]:
    """The outcome and its reason from the flagged steps (numbers from 1), the acceptance verdict (passed, the
    failed limits' lines) when there are limits, else the fit's residual (g rms; None: not solved)."""
    if acceptance is not None:
        passed, failed = acceptance
        return ("PASS", None) if passed else ("FAIL", "acceptance: " + "; ".join(failed))
    if flagged:
        return "FAIL", "steps flagged: " + ", ".join(map(str, flagged))
    if residual_g is not None and residual_g > FIT_RESIDUAL_LIMIT_G:
        return "FAIL", f"fit residual {residual_g * 1e6:.0f} ug rms > {FIT_RESIDUAL_LIMIT_G * 1e6:.0f} ug"
    return "NO LIMITS", None


class BatchRecord:
    """``batch.json`` (format ``rig-batch/1``, docs/fixture.md) as a run keeps it: the batch's identity and every
    slot's session and outcome (``outcome`` null while the slot is recording); ``status`` running, aborted or
    complete; ``resumes`` lists every resume, appended. Every :meth:`write` replaces the file atomically."""

    def __init__(self, batch_dir: Path, doc: dict, kept: dict[int, SlotOutcome] | None = None) -> None:
        self.batch_dir = Path(batch_dir)
        self.doc = doc
        self.entries: dict[int, dict] = {int(e["slot"]): e for e in doc.get("slots", [])}
        self.ended: dict[int, SlotOutcome] = dict(kept or {})

    @classmethod
    def start(cls, batch_dir: Path, new: NewSession, procedure, rig: Rig,
              only_slots: list[int] | None = None) -> "BatchRecord":
        """A new batch's record (written by the first :meth:`write`); ``retest`` lists the slots a re-test runs
        (``rig run --slots``), null for the whole fixture."""
        doc = {"format": BATCH_FORMAT, "id": new.session_id,
               "created": datetime.now(timezone.utc).isoformat(timespec="seconds"), "status": "running",
               "procedure": {"name": procedure.name, "file": new.procedure_file},
               "rig_file": rig.rig_file, "rig_file_sha256": file_sha256(rig.rig_file) if rig.rig_file else None,
               "seed": rig.seed, "turntable": rig.turntable,
               "retest": sorted(only_slots) if only_slots is not None else None,
               "counts": {}, "bins": {}, "slots": []}
        return cls(batch_dir, doc)

    def recording(self, slot: Slot, rotation, session_dir: Path) -> None:
        """A slot whose session is being recorded: no outcome yet."""
        self.entries[slot.index] = {"slot": slot.index, "serial": slot.serial, "rotation": rotation, "outcome": None,
                                    "bin": None, "reason": None, "session": str(Path(session_dir).relative_to(
                                        self.batch_dir)), "calibration": None, "parameters": None}

    def put(self, outcome: SlotOutcome) -> None:
        """A slot that has ended (its outcome final)."""
        self.ended[outcome.slot] = outcome
        self.entries[outcome.slot] = outcome.to_record(self.batch_dir)

    def resumed(self, first_steps: dict[int, int]) -> None:
        """A resume (appended to ``resumes``): when, and each resumed slot's first step (index, from 0)."""
        self.doc["status"] = "running"
        self.doc.setdefault("resumes", []).append(
            {"utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
             "slots": [{"slot": i, "first_step_index": k} for i, k in sorted(first_steps.items())]})

    def outcomes(self) -> list[SlotOutcome]:
        return [self.ended[i] for i in sorted(self.ended)]

    def write(self) -> Path:
        ended = self.outcomes()
        self.doc["counts"] = {k: sum(1 for s in ended if s.outcome == k) for k in OUTCOMES}
        self.doc["bins"] = bin_counts(s.bin for s in ended)
        self.doc["slots"] = [self.entries[i] for i in sorted(self.entries)]
        path = self.batch_dir / BATCH_FILE
        atomic_write_text(path, json.dumps(self.doc, indent=2) + "\n")
        return path

    def stop(self) -> None:
        """The batch stopped before its end: ``aborted`` (best effort: on a full disk the last record stands)."""
        self.doc["status"] = "aborted"
        try:
            self.write()
        except OSError:
            pass

    def finish(self) -> Path:
        self.doc["status"] = "complete"
        return self.write()


def write_batch_record(batch_dir: Path, new: NewSession, procedure, rig: Rig, slots: list[SlotOutcome],
                       only_slots: list[int] | None = None) -> Path:
    """``batch.json`` of a batch whose slots have all ended (:class:`BatchRecord`, complete)."""
    record = BatchRecord.start(Path(batch_dir), new, procedure, rig, only_slots)
    for s in slots:
        record.put(s)
    return record.finish()


# -- resume ---------------------------------------------------------------------------------------------------
@dataclass
class ResumePlan:
    """What a resume of a batch will do, decided before anything is touched: the slots it resumes (each with its
    session's manifest as recorded) and the outcomes of the slots it leaves as they are."""

    batch_dir: Path
    record: dict
    resumed: list[tuple[Slot, dict, SessionManifest]] = field(default_factory=list)
    kept: dict[int, SlotOutcome] = field(default_factory=dict)

    def time_offset_s(self) -> float:
        """The session time the motion continues at: 1 s after the last step any resumed slot recorded."""
        ends = [s.stats.t_end_s for _, _, m in self.resumed for s in m.steps
                if s.status in ("complete", "flagged") and s.stats is not None and s.stats.t_end_s is not None]
        return (max(ends) + 1.0) if ends else 0.0


def refuse_finished(batch_dir, record: dict) -> None:
    """A batch that ended is not resumed (RigInputError, one line): a re-test is a new batch."""
    if record.get("status", "complete") == "complete":
        raise RigInputError(str(Path(batch_dir) / BATCH_FILE), None, "status", "the batch is already complete; "
                            "nothing to resume (a re-test of some units: rig run PROCEDURE --rig RIG --slots N,N)")


def plan_resume(batch_dir, record: dict, rig: Rig, rig_path) -> ResumePlan:
    """Check an interrupted batch against the rig it would resume on, reading only; return what to do.

    A slot with an outcome in the record (ABSENT, FAULT: quarantined; or concluded), or whose session holds the
    quarantine's ``error`` event, or whose session is complete, is kept as it is; every other slot's session is
    checked as a one-sensor resume checks it (:func:`rig.session.recovery.check_resumable`) and resumed. Raises
    RigInputError (one line) for a finished batch, another rig file, seed or fixture (a slot's serial, wiring or
    mounting), or another sensor in a slot; SessionFormatError for a session that cannot be resumed.
    """
    d = Path(batch_dir)
    where = str(d / BATCH_FILE)
    refuse_finished(d, record)
    if rig.fixture is None:
        raise RigInputError(where, None, "rig_file", f"cannot resume a fixture batch on {rig.rig_file}: it has no "
                            "fixture: section (resume with the batch's own rig file)")
    sha = file_sha256(rig_path)
    differ = []
    if record.get("seed") != rig.seed:
        differ.append(f"simulated sensor seed {rig.seed} (recorded {record.get('seed')})")
    if record.get("rig_file_sha256") and sha and record["rig_file_sha256"] != sha:
        differ.append(f"rig file {rig_path} has other contents than the one recorded (sha256 {sha[:12]}, recorded "
                      f"{record['rig_file_sha256'][:12]})")
    slots = {s.index: s for s in rig.fixture.slots}
    plan = ResumePlan(d, record)
    for entry in record["slots"]:
        slot = slots.get(entry["slot"])
        if slot is None or slot.serial != entry["serial"]:
            differ.append(f"slot {entry['slot']} " + ("missing" if slot is None else f"serial {slot.serial}")
                          + f" (recorded {entry['serial']})")
            continue
        kept = _kept_outcome(d, entry, slot)
        if kept is not None:
            plan.kept[slot.index] = kept
            continue
        manifest, _ = SessionManifest.load(d / entry["session"])
        differ += [f"slot {slot.index}: {x}" for x in _slot_differences(manifest, slot, rig, sha)]
        if not differ:
            check_resumable(d / entry["session"], manifest)
        plan.resumed.append((slot, entry, manifest))
    if differ:
        raise RigInputError(str(d), None, "rig", "cannot resume on another rig or sensor: " + "; ".join(differ)
                            + " (resume with the rig, rig file and --seed the batch was recorded with)")
    return plan


def _slot_differences(manifest: SessionManifest, slot: Slot, rig: Rig, sha: str | None) -> list[str]:
    """What differs between a slot's session as recorded and the slot now: the rig (the one-sensor resume's
    comparison, :func:`rig.workflow.identity.differences`) and the slot's wiring and mounting."""
    out = identity.differences(manifest, slot_rig(rig, slot), sha)
    was = manifest.to_dict()["rig"]["sensor"].get("fixture") or {}
    now = slot.describe()
    for key in ("bus", "mux", "channel", "rotation_matrix"):
        if key in was and was[key] != now[key]:
            out.append(f"{key} {now[key]} (recorded {was[key]})")
    return out


def _kept_outcome(batch_dir: Path, entry: dict, slot: Slot) -> SlotOutcome | None:
    """The outcome of a slot a resume leaves as it is (None: resume it): one the record gives, a quarantine the
    session's events record (the record not yet rewritten when the batch stopped), or a complete session."""
    session = batch_dir / entry["session"] if entry.get("session") else None
    if entry.get("outcome") is not None or session is None:
        return SlotOutcome(slot.index, entry["serial"], entry.get("rotation"), entry.get("outcome") or "FAULT",
                           entry.get("reason"), session, recorded=entry)
    rotation = entry.get("rotation")
    manifest, _ = SessionManifest.load(session)
    quarantined = _quarantine_reason(session, manifest)
    if quarantined is not None:
        return SlotOutcome(slot.index, entry["serial"], rotation, "FAULT", quarantined, session)
    if manifest.status == "complete":  # concluded; the record was not rewritten before the batch stopped
        return _outcome_on_disk(slot, rotation, session, manifest)
    return None


def _quarantine_reason(session: Path, manifest: SessionManifest) -> str | None:
    """The reason of the slot's quarantine when its session's events record one (the fixture engine's ``error``
    event, ``slot N quarantined: ...``), in the record's words (``step 4 (-X up): ...``), else None."""
    try:
        lines = (session / "events.jsonl").read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return None
    for line in lines:
        try:
            event = json.loads(line)
        except json.JSONDecodeError:
            continue
        if event.get("kind") == "error" and " quarantined: " in str(event.get("message", "")):
            step = event.get("step")
            why = event["message"].split(" quarantined: ", 1)[1]
            if isinstance(step, int) and 0 <= step < len(manifest.steps):
                return f"step {step + 1} ({manifest.steps[step].name}): {why}"
            return why
    return None


def _outcome_on_disk(slot: Slot, rotation, session: Path, manifest: SessionManifest) -> SlotOutcome:
    """A concluded slot's outcome from its session as it is (its flagged steps; its calibration file's acceptance
    verdict and fit), as :func:`_judge` gives it at the end of a run."""
    flagged = [s.index + 1 for s in manifest.steps if s.status == "flagged"]
    try:
        cal = calfile.read(session / "calibration.yaml")
    except (CalibError, OSError, ValueError):  # not solved
        return SlotOutcome(slot.index, slot.serial, rotation, *_verdict(flagged, None, None), session)
    acceptance = getattr(cal, "acceptance", None)
    failed = [lim for lim in acceptance["limits"] if not lim["passed"]] if acceptance else []
    verdict = _verdict(flagged, (acceptance["passed"], [lim["line"] for lim in failed]) if acceptance else None,
                       None if acceptance else float(cal.accelerometer.fit.residual_rms_g))
    recorded = {"calibration": str((session / "calibration.yaml").relative_to(session.parent)),
                "parameters": _parameters_of(cal)}
    return SlotOutcome(slot.index, slot.serial, rotation, *verdict, session, None,
                       tuple(lim["name"] for lim in failed), recorded)


def format_batch_table(slots: list[SlotOutcome], batch_dir: Path) -> str:
    """The batch table: the counts by outcome and by bin, one line per slot (serial, outcome, failure bin, bias
    counts and scale counts/g per axis, its session), then the reasons of the slots that did not pass. NO LIMITS
    and ABSENT are counted only when a slot has them, bins only when a unit is in them."""
    head = (f"{'slot':>4}  {'serial':<10} {'outcome':<9} {'bin':<{BIN_WIDTH}} {'bias x,y,z (counts)':<26} "
            f"{'scale x,y,z (counts/g)':<29} session")
    shown = [k for k in OUTCOMES if k not in ("NO LIMITS", "ABSENT") or any(s.outcome == k for s in slots)]
    lines = [f"batch {batch_dir}: " + ", ".join(f"{sum(1 for s in slots if s.outcome == k)} {k}" for k in shown),
             "bins: " + ", ".join(f"{n} {b}" for b, n in bin_counts(s.bin for s in slots).items() if n), head]
    for s in slots:
        p = s.parameters()
        bias = " ".join(f"{v:+8.2f}" for v in p["bias_counts"]) if p else "-"
        scale = " ".join(f"{v:9.1f}" for v in p["scale_counts_per_g"]) if p else "-"
        where = s.session_dir.name if s.session_dir is not None else "-"
        lines.append(f"{s.slot:>4}  {s.serial:<10} {s.outcome:<9} {s.bin:<{BIN_WIDTH}} {bias:<26} {scale:<29} {where}")
    for s in slots:
        if s.reason:
            lines.append(f"  slot {s.slot} ({s.serial}) {s.outcome}: {s.reason}")
    return "\n".join(lines)


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text else type(exc).__name__


def resume_batch(procedure, rig: Rig, plan: ResumePlan, operator: Operator, *,
                 options: EngineOptions = EngineOptions(), solve: bool = True, history=None) -> BatchResult:
    """Resume an interrupted batch as :func:`plan_resume` planned it (every check passed; the caller holds the
    batch's lock and closes the rig): each resumed slot's session is reopened (cut back to its finished steps,
    as a one-sensor resume does) and continues from its first unfinished step in one motion; the kept slots stay
    as they are. Then each resumed slot's pipeline tail, the record (the resume appended) and the report, as at
    the end of an uninterrupted batch. ``procedure``: the one the slots recorded (None when no slot is resumed: the
    batch stopped once every slot had ended, and only its end is made)."""
    record = BatchRecord(plan.batch_dir, dict(plan.record), plan.kept)
    offset_s = plan.time_offset_s()
    estimates = step_durations_s(procedure.expanded_steps(), rig) if plan.resumed else []
    runs: list[SlotRun] = []
    for slot, entry, _ in plan.resumed:
        view = slot_rig(rig, slot)
        writer, first = SessionWriter.resume(plan.batch_dir / entry["session"])
        writer.event("resume", t_s=offset_s, first_step=first)
        run = SlotRun(slot, _slot_context(procedure, view, slot, writer, operator, options, estimates),
                      first_step=first)
        try:
            configure_devices(procedure, view)
        except (SensorError, RunError) as exc:  # its chip no longer answers: this slot only
            run.fault = f"on resuming: {_one_line(exc)}"
            abort_session(writer, exc, t_s=offset_s)
            operator.warn(f"slot {slot.index} ({slot.serial}): FAULT on resuming: {_one_line(exc)}; the others go on")
        runs.append(run)
        operator.info(f"slot {slot.index} ({slot.serial}): resuming {writer.session_dir} at step {first + 1}")
    record.resumed({r.slot.index: r.first_step for r in runs})
    for slot_index, kept in plan.kept.items():
        record.put(kept)
        operator.info(f"slot {slot_index} ({kept.serial}): {kept.outcome} before the interruption; left as it is")
    record.write()
    return _run_and_conclude(procedure, rig, runs, record, operator, options=options, solve=solve, history=history,
                             resuming=True, time_offset_s=offset_s)

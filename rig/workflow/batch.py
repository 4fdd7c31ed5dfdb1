"""``rig run`` on a fixture: one run, N units, each slot its own session, a batch table and a batch record.

    open the rig (its fixture's slots) -> a session per slot (its identity, its design through its mounting)
    -> the fixture engine: one motion per pose, every live slot captured -> each live slot's pipeline tail
    (the one-sensor run's :func:`rig.workflow.lifecycle.finish`) -> the batch table and ``batch.json``

A slot whose sensor fails its self-test or stops answering is FAULT (its session marked aborted, with the
reason) and the others go on; a turntable fault or an interrupt aborts every slot's session and leaves.
Where it all goes: ``OUT/<batch id>/`` holds ``batch.json`` and one session directory per slot,
``<batch id>-slotN``, and the batch's HTML report, ``batch-report.html`` (docs/fixture.md, "A fixture run").
Each slot's outcome also sorts its unit into a failure bin (:mod:`rig.lab.bins`).
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
from drivers.sensors.base import SensorAbsent, SensorError
from rig.devices.fixture import Slot
from rig.devices.rig import Rig
from rig.execution.context import EngineOptions, RunContext, RunError
from rig.execution.estimate import step_durations_s
from rig.execution.fixture import FixtureEngine, SlotRun
from rig.execution.operator import Operator
from rig.lab.batch_record import BATCH_FILE, BATCH_FORMAT
from rig.lab.bins import BINS, bin_counts, failure_bin
from rig.session import SessionWriter, StepRecord
from rig.workflow.lifecycle import NewSession, RunResult, abort_session, finish, start_session

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
    """

    slot: int
    serial: str
    rotation: object
    outcome: str
    reason: str | None = None
    session_dir: Path | None = None
    result: RunResult | None = None
    failed_limits: tuple[str, ...] = ()

    @property
    def bin(self) -> str:
        """The unit's failure bin (:func:`rig.lab.bins.failure_bin`): ``good``, the failed limit's family, ..."""
        return failure_bin(self.outcome, self.reason, self.failed_limits)

    def parameters(self) -> dict | None:
        """The main calibrated parameters per sensor axis (its own frame): bias in counts (as every other view
        prints it) and in mg (``bias_mg``, the record's first key), scale factor in counts/g, residual in ug rms."""
        cal = None if self.result is None else self.result.calibration
        if cal is None or cal.accelerometer is None:
            return None
        a = cal.accelerometer
        scale = np.asarray(a.scale_counts_per_g, float)
        return {"bias_mg": [round(float(b / k * 1e3), 4) for b, k in zip(a.bias_counts, scale)],
                "bias_counts": [round(float(b), 2) for b in a.bias_counts],
                "scale_counts_per_g": [round(float(k), 3) for k in scale],
                "residual_ug": round(float(a.fit.residual_rms_g) * 1e6, 2)}

    def to_record(self, root: Path) -> dict:
        """The slot's entry in ``batch.json`` (paths relative to the batch directory)."""
        rel = (lambda p: None if p is None else str(Path(p).relative_to(root)) if Path(p).is_relative_to(root)
               else str(p))
        return {"slot": self.slot, "serial": self.serial, "rotation": self.rotation, "outcome": self.outcome,
                "bin": self.bin, "reason": self.reason, "session": rel(self.session_dir),
                "calibration": rel(None if self.result is None else self.result.calibration_path),
                "parameters": self.parameters()}


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
    closes the rig. Raises what the turntable raises (every live slot's session marked aborted first).
    """
    batch_dir = Path(new.sessions_root) / new.session_id
    batch_dir.mkdir(parents=True, exist_ok=False)
    outcomes: dict[int, SlotOutcome] = {}
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
            outcomes[slot.index] = SlotOutcome(slot.index, slot.serial, rotation, outcome, _one_line(exc))
            operator.warn(f"slot {slot.index} ({slot.serial}): {outcome} before recording: {_one_line(exc)}; "
                          "the others go on")
            continue
        ctx = RunContext(procedure=procedure, rig=view, recorder=writer, operator=operator, options=options,
                         t0_s=rig.clock.now(), total_steps=len(estimates), estimates_s=estimates,
                         magnetometer_samples=procedure.sensor.mag_samples if procedure.sensor.magnetometer else 0,
                         io_retries_seen=slot.sensor.stats.io_retries)
        runs.append(SlotRun(slot, ctx))
        operator.info(f"slot {slot.index} ({slot.serial}): session {writer.session_dir}")

    def on_fault(run: SlotRun, exc: BaseException) -> None:
        abort_session(run.ctx.recorder, exc, t_s=run.ctx.session_time())

    if runs:
        engine = FixtureEngine(procedure, rig, runs, operator, options=options, on_fault=on_fault, where=batch_dir)
        try:
            engine.prepare()
            engine.run()
        except BaseException as exc:
            for run in runs:
                if run.live:
                    abort_session(run.ctx.recorder, exc, t_s=run.ctx.session_time())
            raise
    for run in runs:
        outcomes[run.slot.index] = _conclude_slot(procedure, run, solve=solve, history=history)
    ordered = [outcomes[i] for i in sorted(outcomes)]
    record = write_batch_record(batch_dir, new, procedure, rig, ordered, only_slots)
    report, warning = write_report_of(batch_dir)
    first = next((o for o in ordered if o.session_dir is not None), None)
    return BatchResult(session_dir=first.session_dir if first is not None else batch_dir,
                       status="complete", outcomes=[], conclusion=None, batch_dir=batch_dir, record_path=record,
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
    flagged step, residual within :data:`FIT_RESIDUAL_LIMIT_G`), FAIL when it is not."""
    flagged = [o.index + 1 for o in run.ctx.outcomes if o.status == "flagged"]
    c = result.conclusion
    if c is None:
        return ("FAIL", "steps flagged: " + ", ".join(map(str, flagged))) if flagged else ("NO LIMITS", None)
    if c.acceptance is not None:
        return ("PASS", None) if c.passed else ("FAIL", "acceptance: " + "; ".join(
            chk.line for chk in c.acceptance.failed()))
    residual = float(c.calibration.accelerometer.fit.residual_rms_g)
    if flagged:
        return "FAIL", "steps flagged: " + ", ".join(map(str, flagged))
    if residual > FIT_RESIDUAL_LIMIT_G:
        return "FAIL", f"fit residual {residual * 1e6:.0f} ug rms > {FIT_RESIDUAL_LIMIT_G * 1e6:.0f} ug"
    return "NO LIMITS", None


def write_batch_record(batch_dir: Path, new: NewSession, procedure, rig: Rig, slots: list[SlotOutcome],
                       only_slots: list[int] | None = None) -> Path:
    """``batch.json`` (format ``rig-batch/1``, docs/fixture.md): the batch's identity and every slot's session and
    outcome; ``retest`` lists the slots a re-test ran (``rig run --slots``), null for the whole fixture."""
    doc = {"format": BATCH_FORMAT, "id": new.session_id,
           "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
           "procedure": {"name": procedure.name, "file": new.procedure_file},
           "rig_file": rig.rig_file, "seed": rig.seed, "turntable": rig.turntable,
           "retest": sorted(only_slots) if only_slots is not None else None,
           "counts": {k: sum(1 for s in slots if s.outcome == k) for k in OUTCOMES},
           "bins": bin_counts(s.bin for s in slots),
           "slots": [s.to_record(batch_dir) for s in slots]}
    path = batch_dir / BATCH_FILE
    atomic_write_text(path, json.dumps(doc, indent=2) + "\n")
    return path


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

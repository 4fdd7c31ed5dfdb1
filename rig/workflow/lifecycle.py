"""The one run-into-session lifecycle that ``rig run`` and ``rig replay`` share.

    open a rig -> start (or resume) a session -> engine: preflight, prepare, steps -> close the rig
    -> the pipeline tail (:func:`rig.workflow.conclude.conclude`: solve, verdict, calibration file,
    history) -> mark the session complete -> the report, when the procedure asks

Whatever fails on the way, the motors are stopped (by the engine), the session is marked aborted
and what is on disk stays valid and resumable.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

from calib.errors import CalibError
from rig.devices.rig import Rig
from rig.execution.context import EngineOptions, RunAborted, RunError, StepOutcome
from rig.execution.engine import Engine
from rig.execution.operator import Operator
from rig.lab.history import record_seal
from rig.workflow.conclude import Conclusion, conclude, report_asked, write_conclusion_report
from rig.session import load_session
from rig.session import BASE_COLUMNS, MAG_COUNTS_PER_UT, ProcedureInfo, RigInfo, SessionManifest, SessionWriter, StepRecord


@dataclass
class RunResult:
    """Where a run's session is and how it ended; ``conclusion`` is what the pipeline tail made of it
    (calibration, verdict, history, report), None without a solve."""

    session_dir: Path
    status: str  # complete | aborted
    outcomes: list[StepOutcome]
    conclusion: Conclusion | None = None
    warnings: list[str] = field(default_factory=list)

    @property
    def calibration(self):
        """The calibration file's content, or None without a solve."""
        return None if self.conclusion is None else self.conclusion.calibration

    @property
    def calibration_path(self) -> Path | None:
        return None if self.conclusion is None else self.conclusion.calibration_path


@dataclass(frozen=True)
class NewSession:
    """A session to create: where, under which id, with which extra manifest fields."""

    sessions_root: Path
    session_id: str
    procedure_text: str
    procedure_file: str | None
    extra: dict = field(default_factory=dict)


def session_columns(procedure, rig: Rig) -> tuple[str, ...]:
    """CSV columns: the base ones, the gyroscope's when the sensor has one, the magnetometer's when
    the procedure reads it, and the stage angles."""
    cols = BASE_COLUMNS
    if getattr(rig.sensor, "has_gyro", False):
        cols += ("wx", "wy", "wz")
    if procedure.sensor.magnetometer:
        cols += ("mx", "my", "mz")
    return cols + ("a1_deg", "a2_deg", "a3_deg")


def configure_devices(procedure, rig: Rig) -> dict | None:
    """Configure the sensor (and the magnetometer when the procedure reads it); return the
    magnetometer's description for the manifest (None when not read)."""
    rig.sensor.configure(procedure.sensor_settings())
    if not procedure.sensor.magnetometer:
        return None
    if rig.magnetometer is None:
        raise RunError(f"the procedure reads the magnetometer, but the {rig.sensor.model} on this rig has none")
    rig.magnetometer.configure()
    return {"model": "AK8975", "address": int(rig.magnetometer.address),
            "asa_factor": [float(x) for x in rig.magnetometer.asa_factor], "mag_lsb_per_ut": MAG_COUNTS_PER_UT}


#: run the sensor's self-test when a session starts (a switch for tests and benchmarks that need the old stream)
SELF_TEST_AT_START = True


def self_test(rig: Rig) -> dict | None:
    """The sensor's own self-test, when it has one; a failing chip stops the run (RunError).

    Returns the result for the manifest (``rig.sensor.self_test``), or None for a sensor without one.
    """
    run = getattr(rig.sensor, "self_test", None)
    if run is None or not SELF_TEST_AT_START:
        return None
    result = run()
    if not result.passed:
        raise RunError(f"{result.summary()}; the sensor is faulty: nothing was recorded")
    return result.to_dict()


def start_session(procedure, rig: Rig, new: NewSession, *, steps: list | None = None,
                  sensor_info: dict | None = None) -> SessionWriter:
    """Configure the devices, self-test the sensor, write the manifest (rig identity, planned steps,
    self-test result) and the attachments. ``steps``: the manifest's step records (default: the procedure's
    planned steps); ``sensor_info``: more of the sensor's identity (a fixture slot's serial and mounting)."""
    magnetometer = configure_devices(procedure, rig)
    checked = self_test(rig)
    rig_info = rig.describe()
    rig_info["sensor"].update(sensor_info or {})
    if checked is not None:
        rig_info["sensor"]["self_test"] = checked
    if magnetometer is not None:
        rig_info["sensor"]["magnetometer"] = magnetometer
    if rig.rig_file is not None:
        rig_info["rig_file_sha256"] = file_sha256(rig.rig_file)
    manifest = SessionManifest(
        id=new.session_id, created=datetime.now(timezone.utc).isoformat(timespec="seconds"), **new.extra,
        procedure=ProcedureInfo.from_text(procedure.name, new.procedure_file, new.procedure_text),
        steps=steps if steps is not None else [StepRecord.model_validate(step.to_manifest())
                                                for step in procedure.expanded_steps()],
        rig=RigInfo.model_validate(rig_info))
    writer = SessionWriter.create(new.sessions_root, new.session_id, manifest,
                                  columns=session_columns(procedure, rig))
    for name, text in rig.attachments.items():
        (writer.session_dir / name).write_text(text)
    return writer


def execute(procedure, rig: Rig, writer: SessionWriter, operator: Operator, *, first_step: int = 0,
            resuming: bool = False, time_offset_s: float = 0.0, checked: bool = False,
            options: EngineOptions = EngineOptions()) -> list[StepOutcome]:
    """Run the engine into ``writer``; on any failure mark the session aborted and re-raise.

    ``checked``: the caller ran ``check_before_recording`` on this procedure and rig (a new run does, before
    its session directory exists), so the engine does not preflight a second time.
    """
    _record_stage_events(rig, writer)
    engine = Engine(procedure, rig, writer, operator, first_step=first_step, options=options,
                    time_offset_s=time_offset_s,
                    magnetometer_samples=procedure.sensor.mag_samples if procedure.sensor.magnetometer else 0)
    try:
        engine.prepare(resuming=resuming, preflight=not checked)
        return engine.run()
    except BaseException as exc:
        abort_session(writer, exc, t_s=engine.session_time())
        raise


def abort_session(writer: SessionWriter, exc: BaseException, t_s: float | None = None) -> None:
    """Mark the session aborted (an ``abort`` event with the reason), so it can be resumed; a
    :class:`RunAborted` learns the session's directory, for the resume command the user is shown.
    Best effort: on a full disk even this may fail, and what is on disk stays valid."""
    if isinstance(exc, RunAborted):
        exc.session_dir = writer.session_dir
    try:
        writer.event("abort", **({"t_s": t_s} if t_s is not None else {}), reason=_one_line(exc))
        writer.set_status("aborted")
    except (OSError, ValueError):  # ValueError: the writer's files were closed already
        pass


def interrupted(writer: SessionWriter) -> RunAborted:
    """The RunAborted a Ctrl-C outside the engine becomes, with the session's directory (to resume it)."""
    exc = RunAborted("interrupted by the operator")
    exc.session_dir = writer.session_dir
    return exc


def finish(procedure, writer: SessionWriter, outcomes: list[StepOutcome], *, solve: bool = True,
           history=None) -> RunResult:
    """The pipeline tail when the procedure asks for a solve (:func:`conclude`: calibration file,
    verdict, history), then the session marked complete, then the report when the procedure asks.
    ``history``: the history database (default ``$RIG_HISTORY``, else the user's)."""
    conclusion = None
    if solve and procedure.solve is not None:
        flagged = [o.index + 1 for o in outcomes if o.status == "flagged"]
        try:
            session = load_session(writer.session_dir)
            conclusion = conclude(session, history=history, report=False)
        except KeyboardInterrupt:  # every step is recorded: a resume only solves
            abort_session(writer, KeyboardInterrupt())
            raise interrupted(writer) from None
        except CalibError as exc:
            writer.event("error", message=f"cannot solve: {exc}")
            writer.set_status("complete")
            if flagged:
                raise RunError(f"cannot solve: {exc} (steps {', '.join(map(str, flagged))} were flagged "
                               f"for bad data; session {writer.session_dir})") from None
            raise
        writer.event("solve", path=str(conclusion.calibration_path))
    writer.set_status("complete")  # which seals the session
    if conclusion is not None and conclusion.history_warning is None:  # recorded while running: the row gets the seal
        seal = {"id": writer.info.id, "seal": getattr(writer.info, "seal", None)}
        conclusion.history_warning = record_seal(writer.session_dir, history=history, manifest=seal)
    if conclusion is not None and report_asked(conclusion.session):
        conclusion.session.info = writer.info  # the session as it ends: complete
        write_conclusion_report(conclusion, history=history)
    return RunResult(writer.session_dir, "complete", outcomes, conclusion)


def file_sha256(path) -> str | None:
    """SHA-256 of a file's bytes (None if it cannot be read): what a resume compares."""
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return None


def _record_stage_events(rig: Rig, writer: SessionWriter) -> None:
    """Recovered turntable faults (retries, resynchronisation) become session events."""
    def on_event(kind: str, detail: dict) -> None:
        writer.event("warning" if kind != "info" else "info", source="turntable", what=kind, **detail)

    for axis in rig.axes.values():
        if hasattr(axis.stage, "on_event"):
            axis.stage.on_event = on_event


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0] if text else ''}"
